"""Would a circular-shift surrogate test tell a real effect from slow noise that happens to
follow a slow channel? (A probe behind benchmarks/README.md, workbench campaign, twenty-sixth
pass; the answer was no, and the workbench does not use it.)

For every term the plain user loop of a campaign run added (``--json`` rows of
``bench_workbench.py``), the held-out gain of that term over the model it was added to is
recomputed with the term's channels as logged ("aligned") and with the channels circularly
shifted by K offsets spread over 15–85 % of the record ("surrogates": each channel keeps its
own spectrum and the residual keeps its own, only their alignment in time is destroyed; the
classic test for a spurious correlation of two autocorrelated series). A real effect should
lose its gain when shifted; slow noise that a flexible term (a lag with a fitted τ, a
hysteresis width) fits by chance should not. The channels are shifted in a copy added beside
the originals, so the terms the model already has keep their own channels.

    python benchmarks/probe_shift_surrogates.py rows.json [nulls.json ...] [--k 8]

Prints one line per added term: seed, noise, term, the aligned gain, the largest and the
median surrogate gain, whether the case is a null (every added term there is spurious) and
how much of the truth the term explained in the campaign (floor units).
It also prints the term's gain over the model plus a smooth drift of the gyro itself (a
cubic in time: ``ramp`` and two custom terms), the other way to ask whether the term only
stands in for slow noise.
Terms without channels (ramp, warm-up, sinusoid) and the field-vector blocks (Hmag2, Hquad
without channel list) are skipped.
"""

from __future__ import annotations

import argparse
import copy
import json
import re
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import workbench_sim as ws  # noqa: E402

from gyrotest.envmodel import fit_model, prepare  # noqa: E402
from gyrotest.io.ingest import read_log  # noqa: E402


def gains(seed: int, null: bool, base: list[str], term: str, k: int = 8
          ) -> tuple[float, list[float], float] | None:
    """(aligned held-out gain, [surrogate gains], gain over base + a cubic drift in time) of
    ``term`` over ``base``; None when the term names no logged channel."""
    case = ws.make_case(seed, null=null)
    m = re.match(r"^(\w+)\((.*)\)$", term)
    chans = [c.strip() for c in m.group(2).split(",")] if m else []
    chans = [c for c in chans if c in case.df.columns]
    if not chans:
        return None
    n = len(case.df)
    with tempfile.TemporaryDirectory() as td:
        wd = prepare(read_log(ws.write_case(case, td), overrides=case.profile))
        rb = fit_model(wd, list(base))
        aligned = 1.0 - fit_model(wd, list(base) + [term]).rms_holdout / rb.rms_holdout
        m = float(np.mean(wd.t)) / 3600.0
        drift = [d for d in ("ramp", f"q2:(t_h-{m:.4f})**2", f"q3:(t_h-{m:.4f})**3")
                 if d not in base]
        rd = fit_model(wd, list(base) + drift)
        over_drift = 1.0 - fit_model(wd, list(base) + drift + [term]).rms_holdout / rd.rms_holdout
        rng = np.random.default_rng(seed)
        out = []
        for j in range(k):
            off = int(n * (0.15 + 0.7 * (j + rng.random()) / k))
            c2 = copy.copy(case)
            c2.df = case.df.copy()
            c2.profile = copy.deepcopy(case.profile)
            lab = term
            for ch in chans:
                c2.df[ch + "_rs"] = np.roll(case.df[ch].to_numpy(), off)
                for cols in c2.profile["columns"].values():
                    if isinstance(cols, list) and ch in cols:
                        cols.append(ch + "_rs")
                lab = re.sub(rf"\b{re.escape(ch)}\b", ch + "_rs", lab)
            wd2 = prepare(read_log(ws.write_case(c2, td), overrides=c2.profile))
            try:
                rb2 = fit_model(wd2, list(base))
                out.append(1.0 - fit_model(wd2, list(base) + [lab]).rms_holdout
                           / rb2.rms_holdout)
            except Exception:  # noqa: BLE001 - a surrogate that cannot be fitted is skipped
                out.append(float("nan"))
    return aligned, out, over_drift


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", nargs="+", help="bench_workbench.py --json outputs")
    ap.add_argument("--k", type=int, default=8, help="surrogates per term")
    a = ap.parse_args()
    for path in a.runs:
        for r in json.load(open(path))["rows"]:
            added = r.get("added") or []
            for i, ad in enumerate(added):
                base = list(r["base_terms"]) + [x["label"] for x in added[:i]]
                try:
                    g = gains(r["seed"], bool(r.get("null")), base, ad["label"], a.k)
                except Exception as e:  # noqa: BLE001 - reported, the probe goes on
                    print(r["seed"], ad["label"], "error:", e, flush=True)
                    continue
                if g is None:
                    continue
                al, s, od = g
                s = np.array(s)
                print(f"{r['seed']} {'null' if r.get('null') else 'case'} {r['noise']['type']} "
                      f"{ad['label']} aligned {al:.3f} surrogate max {np.nanmax(s):.3f} "
                      f"median {np.nanmedian(s):.3f} over cubic drift {od:.3f} explains "
                      f"{ad.get('truth_reduction_floor')} floor of the truth", flush=True)


if __name__ == "__main__":
    main()
