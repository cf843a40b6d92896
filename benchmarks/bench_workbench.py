#!/usr/bin/env python3
"""Randomized validation campaign of the model workbench verdict ("missing effect: X").

Not part of the test suite (a test may run ``--quick`` or import :func:`run_case` and
:func:`summarise` after ``sys.path.insert(0, "benchmarks")``). Run from the repository root:

    python benchmarks/bench_workbench.py --seeds 5000-5199 --jobs 2      # the reported campaign
    python benchmarks/bench_workbench.py --quick --jobs 2                # ~20 short cases, < 2 min
    python benchmarks/bench_workbench.py --seeds 1000-1199 --kinds chamber,helmholtz --json r.json
    python benchmarks/bench_workbench.py --validate --seeds 5000-5059    # harness check only
    python benchmarks/bench_workbench.py --summarise a.json b.json        # pool stored runs

Seed ranges: **1-4999 are for tuning** (developing the verdict rules or this harness; the
quick set is seeds 100-119); **5000 and up are for reporting**. Numbers quoted in
benchmarks/README.md come from a reporting range that nobody tuned on. A case is fully
determined by (seed, kind, max_hours).

Method
------
Each case comes from the independent simulator ``benchmarks/workbench_sim.py`` (no
``gyrotest.simulation``; see its docstring for the physics, the noise and the truth). The log is
written as CSV or Parquet and read back with ``gyrotest.io.ingest.read_log`` using the case's
column roles, so ingest and channel naming are exercised; then ``prepare`` (gyrotest's
working resolution) and

* the **true model**: ``fit_model(wd, case.true_terms)`` (every injected effect written as the
  exact library term or a custom expression with the true parameters) gives the reference
  held-out RMS, and its coefficients are compared with the injected ones (z = (fit −
  truth)/σ_HAC);
* the **plain user loop**: start from ``case.base_terms``; ``diagnose``; when it reports a
  missing effect, drop the base term it replaces (if any) and add the top one; when it
  finds none but says "the model does better without X: remove it", remove X (once per
  term); when it finds none but names a better reading of the model's own sensors ("limited
  by the sensors: Y reads the model's nodes better ... to use it: --terms ..."), add Y (once
  per term; not a missing effect, so never a false alarm); repeat, at most ``--max-steps``
  (5) diagnoses; the final model is what the loop ends with.

Measures (per missing effect e, with B() = gyrotest's own smoother + block means, i.e.
``wd.bmean(wd.smooth(x))``, and floor = RMS of B(noise), the noise actually injected, at the
working resolution):

* ``magnitude`` = RMS(B(e) − mean) / floor (the realised size; the brief's definition) and
  ``magnitude_unique`` = the same for the part of B(e) not explained by a bias, the other true
  effects and the base model's spurious terms (what any method could at best attribute to e);
  "strong" = magnitude >= 3;
* **found** (recall): the final model accounts for the effect: the RMS of B(e) left unexplained
  by the final model's block regressors is at most half of what the base model's regressors
  left unexplained (``capture`` >= 0.5; regressors from the fits' design matrices);
* **named**: found and one of the terms the loop added (each the top "missing effect" of its
  step) is in the effect's ``accept`` list (key and channels, channel order ignored);
  ``named_equiv`` also accepts a term the verdict listed as indistinguishable from the one it
  chose (``Candidate.equivalents``, when the installed gyrotest provides it);
  ``named_data_equiv`` accepts an added term that is an exact equivalent *in this log*: the
  part of its fitted contribution outside the base model's regressors correlates at
  |r| >= 0.99 with the part of the effect's signal outside them (or with that of the summed
  missing effects); e.g. a lag of the chamber air and a lag of the case sensor, which is
  itself a lag of the air, or a lagged node's rate and a lagging sensor's rate;
* **false alarm**: a null case (nothing missing) whose first diagnosis reports a missing
  effect; it is *spurious* when the added term explains < 0.1 floor of the injected truth
  (otherwise it repairs the base model, e.g. a smoother regressor for a noisy-sensor term).
  "possible missing effect" verdicts (no ``found``) are counted separately, not as alarms;
* **final/true**: final model's held-out RMS / true model's held-out RMS (ok when <= 1.1),
  also restricted to cases whose true model is within 1.2x of the injected floor;
* **floor ratio check**: the first diagnosis' printed held-out/floor ratio vs the true ratio
  base held-out / true model's held-out (ok when within a factor 2); and the printed floor vs
  the injected floor (within a factor 2);
* **added terms**: how many terms the loop added in non-null cases, how many name no missing
  effect, and how many explain < 0.1 floor of the injected truth (per step, the RMS of the
  noise-free truth left unexplained by the model's regressors is tracked in floor units);
* **harness checks**: true model's held-out RMS / injected floor, and true-model
  coefficients vs the injected ones (z with the HAC standard error);
* ``regressor_error``: RMS of B(e) minus the truth term's regressor as gyrotest computes it
  from the *logged* channels (noisy, quantised) times the true coefficient, in floor units.
  An effect with regressor error >= 1 floor cannot be modelled to the floor from the logged
  channels by any method (errors in variables: a noisy sensor's derivative, ...); the
  "observable" recall row leaves such effects out.

A crash anywhere (ingest, prepare, a fit, a diagnosis) is recorded in the row (``error``,
``crash_stage``) and the campaign goes on. Output: Markdown tables (overall, per run kind,
per effect class) on stdout, progress on stderr, every row with ``--json``.
"""

from __future__ import annotations

import os

for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")  # one BLAS thread per worker (the VM has 2 cores)

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import re  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
import traceback  # noqa: E402
from multiprocessing import Pool  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

import workbench_sim as ws  # noqa: E402

DEFAULT_SEEDS = "5000-5059"
QUICK_SEEDS = range(100, 120)
QUICK_MAX_HOURS = 3.0
MAX_STEPS = 5
FOUND_CAPTURE = 0.5
FINAL_OK = 1.1
FLOOR_FACTOR = 2.0
STRONG = 3.0
SPURIOUS = 0.1
#: an added term is an exact equivalent of a missing effect in this log when their signals
#: outside the base model correlate at least this well (the workbench's own rule for
#: "indistinguishable in this log" is 0.995 between fitted contributions)
EQUIV_R = 0.99
TRUE_AT_FLOOR = 1.2
#: an added term that explains at least this much of the injected truth (floor units) is a
#: part of it (harness measure)
PART = 0.5
OBSERVABLE = 1.0


# ============================================================================ helpers
def parse_seeds(text: str) -> list[int]:
    """``1000-1199`` or ``1,2,10-19`` -> list of seeds."""
    out: list[int] = []
    for part in text.split(","):
        part = part.strip()
        if not part:
            continue
        if "-" in part:
            a, b = part.split("-", 1)
            out += list(range(int(a), int(b) + 1))
        else:
            out.append(int(part))
    return out


def case_kind(seed: int, kinds: list[str] | None) -> str | None:
    """The run kind of a seed: drawn by the simulator, or cycled through ``kinds``."""
    return kinds[seed % len(kinds)] if kinds else None


_ACC = re.compile(r"^([A-Za-z0-9_]+)(?:\((.*)\))?$")


def _parse_accept(text: str) -> tuple[str, frozenset[str] | None]:
    """``key(a,b)`` -> (key, {a, b}); ``key`` -> (key, None) (also for candidate labels)."""
    m = _ACC.match(text.replace(" ", ""))
    if not m:
        return text, None
    chans = frozenset(c for c in (m.group(2) or "").split(",") if c) if m.group(2) else None
    return m.group(1), chans


def names_effect(key: str, channels, accept: list[str]) -> bool:
    """Does a candidate (``key``, ``channels``) name an effect with this ``accept`` list?
    Keys must be equal; channels must be the same set when the accept entry lists any."""
    ch = frozenset(channels or ())
    for a in accept:
        k, c = _parse_accept(a)
        if k == key and (c is None or c == ch):
            return True
    return False


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(x)))) if len(x) else math.nan


def _unexplained(x: np.ndarray, X: np.ndarray | None) -> float:
    """RMS of the part of ``x`` (block level) outside the column space of ``X`` (+ a bias)."""
    A = np.ones((len(x), 1)) if X is None or X.shape[1] == 0 else np.column_stack(
        [np.ones(len(x)), X])
    s = np.sqrt(np.sum(A * A, axis=0))
    s[s == 0] = 1.0
    beta, *_ = np.linalg.lstsq(A / s, x, rcond=None)
    return _rms(x - (A / s) @ beta)


def _resid(x: np.ndarray, X: np.ndarray | None) -> np.ndarray:
    """The part of ``x`` outside the column space of ``X`` (+ a bias)."""
    A = np.ones((len(x), 1)) if X is None or X.shape[1] == 0 else np.column_stack(
        [np.ones(len(x)), X])
    s = np.sqrt(np.sum(A * A, axis=0))
    s[s == 0] = 1.0
    beta, *_ = np.linalg.lstsq(A / s, x, rcond=None)
    return x - (A / s) @ beta


def _corr(a: np.ndarray, b: np.ndarray) -> float:
    if np.std(a) == 0 or np.std(b) == 0:
        return 0.0
    return float(abs(np.corrcoef(a, b)[0, 1]))


def _added_contributions(fit, added: list[dict]) -> dict[str, np.ndarray]:
    """Block-level fitted contribution of every added term that is in ``fit``."""
    from gyrotest.envmodel.modelfit import predict_blocks
    out = {}
    for a in added:
        spec = next((s for s in fit.specs if s.label == a["label"]), None)
        if spec is None:
            continue
        try:
            out[a["label"]] = np.asarray(predict_blocks(fit, [spec]), float)
        except Exception:  # noqa: BLE001 - internal API may change
            continue
    return out


def _fit_truth(wd, case):
    """The true model fitted by gyrotest; truth terms that are degenerate on this log (two
    custom field terms that the coil sequence makes one, e.g. H_x² and |H|² with the other
    coils off) are fitted as their true sum, a single term with coefficient 1 — the model
    the workbench refuses to fit with both (returns the fit and (merged term, the labels it
    replaces), or None)."""
    from gyrotest.core.errors import AnalysisError
    from gyrotest.envmodel import fit_model

    try:
        return fit_model(wd, case.true_terms), None
    except AnalysisError as e:
        m = re.search(r"terms c\[(\w+)\] and c\[(\w+)\] are degenerate", str(e))
        if not m:
            raise
        pair = [t for t in case.truth if t.term_label in m.groups()]
        if len(pair) != 2 or not all(":" in t.term for t in pair):
            raise
        name = "_".join(t.term_label for t in pair)
        expr = " + ".join(f"{t.coef_term!r}*({t.term.split(':', 1)[1]})" for t in pair)
        terms = [t.term for t in case.truth if t not in pair] + [f"{name}:{expr}"]
        return fit_model(wd, terms), (name, [t.term_label for t in pair])


def _design(fit) -> np.ndarray | None:
    """Block-level design matrix of a fit (gyrotest internals; None when unavailable)."""
    try:
        return np.asarray(fit._fitter.X(fit._thetas), float)
    except Exception:  # noqa: BLE001 - internal API may change
        return None


def _spec_info(spec) -> dict:
    return {"label": spec.label, "key": spec.key, "channels": list(spec.channels)}


def _fmt_err(e: BaseException) -> str:
    return f"{type(e).__name__}: {e}"[:500]


# ============================================================================ one case
def realised_magnitudes(case: ws.Case, wd) -> tuple[float, dict[str, dict]]:
    """Floor and per-effect magnitudes on gyrotest's working grid (see the module docstring).
    Returns (floor deg/h, {effect name: {magnitude, magnitude_unique, block}})."""
    n = wd.frame.n
    if n != len(case.df):
        raise ValueError(f"ingest kept {n} of {len(case.df)} rows; cannot map the truth")

    def B(x):
        return wd.bmean(wd.smooth(np.asarray(x, float)))

    nb = B(case.noise_signal)
    floor = _rms(nb - nb.mean())
    blocks = {e.name: B(e.signal) for e in case.truth}
    extra = [B(v) for v in case.base_extra.values()]
    out = {}
    for e in case.truth:
        others = [blocks[o.name] for o in case.truth if o is not e] + extra
        X = np.column_stack(others) if others else None
        b = blocks[e.name]
        out[e.name] = {"magnitude": _rms(b - b.mean()) / floor,
                       "magnitude_unique": _unexplained(b, X) / floor, "block": b}
    return floor, out


def _best_candidates(d, total: np.ndarray, floor: float, u0, top: int = 3) -> list[dict]:
    """The ``top`` candidates by significance with their test, and what the chosen one
    explains of the injected truth (floor units), for studying the decisions."""
    import math as _m
    ok = [c for c in d.candidates if _m.isfinite(getattr(c, "log_p", _m.nan))]
    out = []
    for c in ok[:top]:
        X = _design(c._fit) if c._fit is not None else None
        u1 = _unexplained(total, X) / floor if X is not None else None
        out.append({"term": c.term, "class": c.klass, "key": c.spec.key if c.spec else None,
                    "lr": c.lr, "df": c.df, "p": c.p, "p_family": c.p_family,
                    "delta_bic": c.dbic, "searched": c.searched, "n_params": c.n_params,
                    "significant": c.significant, "replaces": c.replaces,
                    "theta": {k: float(v) for k, v in (c.theta or {}).items()},
                    "truth_reduction_floor": (u0 - u1) if (u0 is not None and u1 is not None)
                    else None})
    return out


def run_case(case: ws.Case, *, max_steps: int = MAX_STEPS, loop: bool = True,
             reference: bool = False, path_steps: int = 1) -> dict:
    """Run one case through gyrotest (see the module docstring); returns a JSON-able row.
    ``loop=False`` only fits the true model (the harness check). ``reference``: the floor comes
    from a static reference run of the same simulated gyro (:func:`workbench_sim.reference_noise`,
    as ``--reference LOG`` does) instead of the log's own noise. ``path_steps``: the steps of
    the forward path each diagnosis follows (``model diagnose --path``). The loop adds only
    the chosen effect and diagnoses again, so the path's further steps ("then X" in the
    verdict) change no decision of the loop; the default 1 skips them."""
    from gyrotest.core.errors import AnalysisError
    from gyrotest.envmodel import diagnose, fit_model, prepare
    from gyrotest.envmodel.terms import parse_terms, resolve_terms
    from gyrotest.io.ingest import read_log

    row: dict = case.to_dict()
    row.update(status="ok", error=None, crash_stage=None, steps=[], times={})
    if case.skipped:
        row["status"] = "skipped"
        return row
    T0 = time.perf_counter()
    stage = "ingest"
    try:
        with tempfile.TemporaryDirectory(prefix="gt_wb_") as td:
            path = ws.write_case(case, td)
            log = read_log(path, overrides=case.profile)
            ref_log = None
            if reference:
                x = ws.reference_noise(case.noise, len(case.df), case.seed)
                if x is not None:
                    rp = Path(td) / "reference.csv"
                    pd.DataFrame({"t_s": np.arange(len(x), dtype=float), "rate_dph": x}
                                 ).to_csv(rp, index=False)
                    ref_log = read_log(rp, overrides={
                        "columns": {"time": "t_s", "rate": ["rate_dph"]},
                        "gyro": {"rate_unit": "deg/h"}})
        stage = "prepare"
        wd = prepare(log)
        # the bench metadata: the log starts at the gyro's power-on (a warm-up is possible)
        wd.power_on = bool(getattr(log.gyro, "power_on_at_start", False))
        row["reference"] = ref_log is not None
        if ref_log is not None:
            from gyrotest.envmodel.floor import check_reference
            from gyrotest.envmodel.likelihood import reference_noise

            noise = reference_noise(ref_log, wd)
            check_reference(ref_log, log, wd, noise)
            wd.noise_ref = noise
        row.update(resolution_s=wd.resolution_s, smoothing_s=wd.refs.smoothing_s, blocks=wd.nb)
        stage = "truth mapping"
        floor, mags = realised_magnitudes(case, wd)
        row["floor_true_dph"] = floor
        for t in row["truth"]:
            t["magnitude_nominal"] = t["magnitude"]
            t["magnitude"] = mags[t["name"]]["magnitude"]
            t["magnitude_unique"] = mags[t["name"]]["magnitude_unique"]
        row["times"]["prepare_s"] = time.perf_counter() - T0
        # ---- the true model
        stage = "true fit"
        t1 = time.perf_counter()
        true_fit, merged = _fit_truth(wd, case)
        if merged:
            row["true_terms_merged"] = merged[0]
        row["times"]["true_fit_s"] = time.perf_counter() - t1
        row["true_holdout_dph"] = true_fit.rms_holdout
        row["true_over_floor"] = true_fit.rms_holdout / floor
        row["floor_printed_true_model"] = true_fit.floor.rms_dph if true_fit.floor else None
        checks = []
        for e in case.truth:
            label, true = e.term_label, e.coef_term
            if merged and label in merged[1]:  # fitted as one term whose true coefficient is 1
                label, true = merged[0], 1.0
            try:
                c = true_fit.coef(label)
                z = (c.value - true) / c.stderr if c.stderr > 0 else math.nan
                checks.append({"term": label, "true": true, "fit": c.value,
                               "stderr": c.stderr, "z": z})
            except KeyError:
                checks.append({"term": label, "true": true, "fit": None,
                               "stderr": None, "z": None})
        row["coef_checks"] = checks
        # the true model as a user writes it with the workbench's terms (the starting model
        # plus every missing effect's library form, e.g. Hx,Hy,Hz for a misaligned field
        # sensitivity and Tlag(c) with a fitted τ): what the loop can reach at best
        stage = "true fit (library terms)"
        u_terms = list(case.base_terms)
        for e in case.missing:
            for part in ws._split_user(e.user_term):
                if part not in u_terms:
                    u_terms.append(part)
        try:
            row["true_user_holdout_dph"] = fit_model(
                wd, resolve_terms(parse_terms(u_terms), wd.frame)).rms_holdout
        except Exception as e:  # noqa: BLE001 - reported, not fatal
            row["true_user_holdout_dph"] = None
            row["true_user_error"] = _fmt_err(e)
        # how well the truth terms, computed by gyrotest from the *logged* (noisy) channels,
        # reproduce the injected signals: regressor error x coefficient, in floor units
        X_true = _design(true_fit)
        offs = getattr(getattr(true_fit, "_fitter", None), "_offsets", lambda: {})()
        for t, e in zip(row["truth"], case.truth):
            a_b = offs.get(e.term_label)
            if X_true is None or a_b is None or a_b[1] - a_b[0] != 1:
                t["regressor_error"] = None
                continue
            b = mags[e.name]["block"]
            xr = X_true[:, a_b[0]] * e.coef_term
            t["regressor_error"] = _rms((b - b.mean()) - (xr - xr.mean())) / floor
        if not loop:
            row["times"]["total_s"] = time.perf_counter() - T0
            return row
        # ---- the plain user loop
        stage = "base terms"
        terms = resolve_terms(parse_terms(case.base_terms), wd.frame)
        total = sum((m["block"] for m in mags.values()), np.zeros(wd.nb))
        added: list[dict] = []
        removed: set[str] = set()
        reread: set[str] = set()
        final_fit = None
        X_base = None
        for k in range(max_steps):
            stage = f"diagnose step {k}"
            t1 = time.perf_counter()
            try:
                d = diagnose(wd, terms, path_steps=path_steps)
            except AnalysisError as e:
                if k == 0 and "degenerate" in str(e):
                    # the drawn starting model cannot be fitted on this log (two field terms
                    # the coil sequence makes one); the workbench refuses it, as it should
                    row["status"] = "skipped"
                    row["skipped"] = f"starting model degenerate on this log: {e}"
                    return row
                raise
            dt = time.perf_counter() - t1
            found = d.found
            step = {"step": k, "terms": [s.label for s in terms], "verdict": d.verdict,
                    "n_candidates": len(d.candidates), "n_found": len(found),
                    "holdout_dph": d.base.rms_holdout, "ratio_to_floor": d.ratio_to_floor,
                    "noise_floor_dph": d.noise_floor_dph, "time_s": dt,
                    "candidate_errors": [c.term for c in d.candidates if c.error]}
            Xk = _design(d.base)
            step["truth_unexplained_floor"] = (_unexplained(total, Xk) / floor
                                               if Xk is not None else None)
            step["possible"] = d.verdict.startswith("possible")
            step["best"] = _best_candidates(d, total, floor, step["truth_unexplained_floor"])
            if k == 0:
                X_base = Xk
                row.update(base_holdout_dph=d.base.rms_holdout,
                           base_ratio_printed=d.ratio_to_floor,
                           noise_floor_printed_dph=d.noise_floor_dph,
                           first_verdict=d.verdict, alarm=bool(found),
                           possible=step["possible"],
                           noise_first={"N": d.noise.N, "B": d.noise.B, "K": d.noise.K},
                           whiteness_p=d.whiteness.p if d.whiteness else None)
            if found:
                top = found[0]
                step["top"] = {**_spec_info(top.spec), "replaces": top.replaces,
                               "improvement_pct": top.improvement_pct, "lr": top.lr,
                               "p": top.p, "p_family": top.p_family, "delta_bic": top.dbic,
                               "z": top.z, "class": top.klass, "searched": top.searched,
                               "pair": getattr(top, "pair", None) is not None,
                               "equivalents": list(top.equivalents)}
                added.append({"step": k, **_spec_info(top.spec), "replaces": top.replaces,
                              "equivalents": list(getattr(top, "equivalents", None) or [])})
            rm = getattr(d, "remove", None)
            if not found and rm is not None and rm.term not in removed:
                # "the model does better without X: remove it" -- the user removes it
                step["removed"] = rm.to_dict()
                removed.add(rm.term)
                row["steps"].append(step)
                terms = [s for s in terms if s.label != rm.term]
                continue
            held = [c for c in d.candidates if getattr(c, "sensor_limited", None) is not None
                    and c.spec is not None and c.term not in reread]
            if not found and held:
                # "limited by the sensors: Y reads the model's nodes better (to use it:
                # --terms ...)" -- the user takes the better reading the verdict names
                best = max(held, key=lambda c: c.lr_fixed if math.isfinite(c.lr_fixed)
                           else c.lr)
                reread.add(best.term)
                step["better_reading"] = best.term
                added.append({"step": k, **_spec_info(best.spec), "replaces": None,
                              "equivalents": [], "better_reading": True})
                row["steps"].append(step)
                terms = terms + [best.spec]
                continue
            row["steps"].append(step)
            if not found:
                final_fit = d.base
                break
            top = found[0]
            if top.replaces:
                gone = set(top.replaces.split("; "))
                terms = [s for s in terms if s.label not in gone]
            terms = terms + [top.spec]
        else:
            stage = "final fit"
            final_fit = fit_model(wd, terms)
            row["step_limit"] = True
        row["final_terms"] = [s.label for s in terms]
        row["added"] = added
        row["final_holdout_dph"] = final_fit.rms_holdout
        row["final_over_true"] = final_fit.rms_holdout / true_fit.rms_holdout
        tu = row.get("true_user_holdout_dph")
        row["final_over_true_user"] = final_fit.rms_holdout / tu if tu else None
        row["ratio_true"] = row["base_holdout_dph"] / true_fit.rms_holdout
        rp = row["base_ratio_printed"]
        row["floor_check_factor"] = (rp / row["ratio_true"]
                                     if rp and math.isfinite(rp) else math.nan)
        # ---- what each added term explained of the injected truth (noise-free, so any
        # reduction is real explanatory power; < 0.1 floor counts as spurious)
        X_final = _design(final_fit)
        u_end = _unexplained(total, X_final) / floor if X_final is not None else None
        row["truth_unexplained_final_floor"] = u_end
        us = [s_["truth_unexplained_floor"] for s_ in row["steps"]]
        for a in added:
            k = a["step"]
            u0 = us[k]
            u1 = us[k + 1] if k + 1 < len(us) else u_end
            a["truth_reduction_floor"] = (u0 - u1) if u0 is not None and u1 is not None \
                else None
        # ---- per missing effect: found (captured by the final model) and named
        missing_names = {e.name for e in case.missing}
        for t, e in zip(row["truth"], case.truth):
            if e.name not in missing_names:
                continue
            b = mags[e.name]["block"]
            # a better reading the user took is not a missing effect named
            named_by = [a for a in added if not a.get("better_reading")
                        and names_effect(a["key"], a["channels"], e.accept)]
            if X_base is not None and X_final is not None:
                u0, u1 = _unexplained(b, X_base), _unexplained(b, X_final)
                capture = 1.0 - u1 / u0 if u0 > 0 else math.nan
                t["capture"] = capture
                t["found"] = bool(capture >= FOUND_CAPTURE)
            else:  # no design matrices: fall back to naming
                t["capture"] = None
                t["found"] = bool(named_by)
            t["named"] = bool(t["found"] and named_by)
            t["named_at_step"] = named_by[0]["step"] if named_by else None
            t["named_equiv"] = bool(t["found"] and (named_by or any(
                names_effect(*_parse_accept(q), e.accept) for a in added
                for q in a["equivalents"])))
        # ---- naming up to an exact equivalent in this log: an added term whose fitted
        # contribution, outside what the base model spans, correlates at |r| >= EQUIV_R with
        # the effect's own signal (or with the summed signal of the missing effects it
        # replaces together) outside the base model: the log cannot tell them apart
        contrib = (_added_contributions(final_fit, [a for a in added
                                                    if not a.get("better_reading")])
                   if X_base is not None else {})
        miss_b = [mags[e.name]["block"] for e in case.missing]
        comb = _resid(sum(miss_b, np.zeros(wd.nb)), X_base) if miss_b and contrib else None
        for t, e in zip(row["truth"], case.truth):
            if e.name not in missing_names:
                continue
            t["named_data_equiv"] = bool(t.get("named"))
            t["equiv_r"] = None
            if t["named"] or not t["found"] or not contrib:
                continue
            bu = _resid(mags[e.name]["block"], X_base)
            rs = []
            for x in contrib.values():
                xu = _resid(x, X_base)
                rs.append(max(_corr(xu, bu), _corr(xu, comb) if comb is not None else 0.0))
            t["equiv_r"] = max(rs) if rs else None
            t["named_data_equiv"] = bool(rs and max(rs) >= EQUIV_R)
        row["unmatched_added"] = [a["label"] for a in added if not any(
            names_effect(a["key"], a["channels"], e.accept) for e in case.missing)]
        # an added term that names no missing effect is still justified when it is an exact
        # equivalent of one in this log (|r| >= EQUIV_R outside the base model) or a part of
        # the truth (it explains >= PART floor of the injected signal: a component of a
        # rotated field sensitivity, a node read through another sensor)
        unjust = []
        for a in added:
            if a["label"] not in row["unmatched_added"]:
                continue
            r_eq = 0.0
            if a["label"] in contrib:
                xu = _resid(contrib[a["label"]], X_base)
                for e in case.missing:
                    r_eq = max(r_eq, _corr(xu, _resid(mags[e.name]["block"], X_base)))
                if comb is not None:
                    r_eq = max(r_eq, _corr(xu, comb))
            a["equiv_r"] = r_eq
            red = a.get("truth_reduction_floor")
            if not (r_eq >= EQUIV_R or (red is not None and red >= PART)):
                unjust.append(a["label"])
        row["unjustified_added"] = unjust
        row["spurious_added"] = [a["label"] for a in added
                                 if a["truth_reduction_floor"] is not None
                                 and a["truth_reduction_floor"] < SPURIOUS]
        # a false alarm whose term explains part of the truth repairs the base model (e.g. a
        # smoother regressor for a noisy-sensor term); a spurious one follows noise
        row["alarm_spurious"] = bool(case.is_null and row.get("alarm") and added
                                     and added[0]["label"]
                                     in row["spurious_added"])
    except Exception as e:  # noqa: BLE001 - record and go on
        row.update(status="crash", crash_stage=stage, error=_fmt_err(e),
                   traceback=traceback.format_exc(limit=6))
    row["times"]["total_s"] = time.perf_counter() - T0
    return row


# ============================================================================ summary
def _frac(k: int, n: int) -> dict:
    return {"k": k, "n": n, "frac": (k / n) if n else math.nan}


def _effects(rows: list[dict]) -> list[dict]:
    out = []
    for r in rows:
        if r.get("status") != "ok" or "added" not in r:
            continue
        for t in r["truth"]:
            if t["missing"] and "found" in t:
                out.append({**t, "kind": r["kind"], "seed": r["seed"]})
    return out


def _other_names(rows: list[dict], cls: str, top: int = 3) -> list[tuple[str, int]]:
    """For effects of class ``cls`` found but not named: the keys of the first term the loop
    added, most common first."""
    count: dict[str, int] = {}
    for r in rows:
        for t in r.get("truth", []):
            if t["cls"] == cls and t["missing"] and t.get("found") and not t.get("named") \
                    and r.get("added"):
                k = r["added"][0]["key"]
                if any(_parse_accept(a)[0] == k for a in t["accept"]):
                    k += " (other channel)"
                count[k] = count.get(k, 0) + 1
    return sorted(count.items(), key=lambda kv: -kv[1])[:top]


def summarise(rows: list[dict]) -> dict:
    """Campaign measures over ``rows`` (from :func:`run_case`): overall, per run kind and per
    effect class; every rate as {k, n, frac}."""

    def block(rs: list[dict]) -> dict:
        ok = [r for r in rs if r.get("status") == "ok" and "added" in r]
        eff = _effects(rs)
        strong = [e for e in eff if e["magnitude"] >= STRONG]
        strong_u = [e for e in eff if e["magnitude_unique"] >= STRONG]
        strong_o = [e for e in eff if e["magnitude_unique"] >= STRONG
                    and (e.get("regressor_error") or 0.0) < OBSERVABLE]
        nulls = [r for r in ok if r["null"]]
        tr = [r for r in rs if "true_over_floor" in r]
        fin = [r for r in ok if math.isfinite(r.get("final_over_true", math.nan))]
        flo = [r for r in ok if math.isfinite(r.get("floor_check_factor", math.nan))]
        t = [r["times"]["total_s"] for r in rs if r.get("status") != "skipped"
             and "total_s" in r.get("times", {})]
        return {
            "cases": len(rs),
            "completed": len(ok),
            "crashed": sum(r.get("status") == "crash" for r in rs),
            "skipped": sum(r.get("status") == "skipped" for r in rs),
            "nulls": len(nulls),
            "missing_effects": len(eff),
            "recall": _frac(sum(e["found"] for e in eff), len(eff)),
            "recall_strong": _frac(sum(e["found"] for e in strong), len(strong)),
            "recall_strong_unique": _frac(sum(e["found"] for e in strong_u), len(strong_u)),
            "recall_strong_observable": _frac(sum(e["found"] for e in strong_o), len(strong_o)),
            "named_strong_observable": _frac(sum(e["named"] for e in strong_o), len(strong_o)),
            "named": _frac(sum(e["named"] for e in eff), len(eff)),
            "named_strong": _frac(sum(e["named"] for e in strong), len(strong)),
            "named_given_found": _frac(sum(e["named"] for e in eff),
                                       sum(e["found"] for e in eff)),
            "named_equiv": _frac(sum(e.get("named_equiv", False) for e in eff), len(eff)),
            "named_data_equiv_strong": _frac(sum(e.get("named_data_equiv", False)
                                                 for e in strong), len(strong)),
            "named_data_equiv_strong_unique": _frac(sum(e.get("named_data_equiv", False)
                                                        for e in strong_u), len(strong_u)),
            "unjustified_cases": _frac(sum(bool(r.get("unjustified_added")) for r in ok
                                           if not r["null"]),
                                       sum(not r["null"] for r in ok)),
            "false_alarms": _frac(sum(r["alarm"] for r in nulls), len(nulls)),
            "false_alarms_synthetic": _frac(
                sum(r["alarm"] for r in nulls if r["noise"].get("type") != "real"),
                sum(r["noise"].get("type") != "real" for r in nulls)),
            "false_alarms_real": _frac(
                sum(r["alarm"] for r in nulls if r["noise"].get("type") == "real"),
                sum(r["noise"].get("type") == "real" for r in nulls)),
            "false_alarms_spurious": _frac(sum(r.get("alarm_spurious", False) for r in nulls),
                                           len(nulls)),
            # the real records are few (four axes of two IMUs), so the cases drawn from one
            # record share its events: per record, any term / spurious
            "false_alarms_real_by_record": {
                rec: (_frac(sum(r["alarm"] for r in g), len(g)),
                      _frac(sum(r.get("alarm_spurious", False) for r in g), len(g)))
                for rec in sorted({r["noise"].get("record", "?") for r in nulls
                                   if r["noise"].get("type") == "real"})
                for g in [[r for r in nulls if r["noise"].get("type") == "real"
                           and r["noise"].get("record", "?") == rec]]},
            "false_alarms_spurious_synthetic": _frac(
                sum(r.get("alarm_spurious", False) for r in nulls
                    if r["noise"].get("type") != "real"),
                sum(r["noise"].get("type") != "real" for r in nulls)),
            "false_alarms_spurious_real": _frac(
                sum(r.get("alarm_spurious", False) for r in nulls
                    if r["noise"].get("type") == "real"),
                sum(r["noise"].get("type") == "real" for r in nulls)),
            # nulls whose true model, written on the logged channels, reaches the floor (the
            # others leave something the starting model cannot express: a lagging or noisy
            # sensor's dT/dt, so a refinement of a present term is not a false alarm there)
            "false_alarms_true_at_floor": _frac(
                sum(r["alarm"] for r in nulls if r["true_over_floor"] <= TRUE_AT_FLOOR),
                sum(r["true_over_floor"] <= TRUE_AT_FLOOR for r in nulls)),
            "final_ok": _frac(sum(r["final_over_true"] <= FINAL_OK for r in fin), len(fin)),
            "floor_ok": _frac(sum(1 / FLOOR_FACTOR <= r["floor_check_factor"] <= FLOOR_FACTOR
                                  for r in flo), len(flo)),
            "floor_vs_injected_ok": _frac(sum(
                1 / FLOOR_FACTOR <= r["noise_floor_printed_dph"] / r["floor_true_dph"]
                <= FLOOR_FACTOR for r in flo), len(flo)),
            "final_ok_user": _frac(sum(r["final_over_true_user"] <= FINAL_OK for r in fin
                                       if r.get("final_over_true_user")),
                                   sum(bool(r.get("final_over_true_user")) for r in fin)),
            "final_ok_at_floor": _frac(sum(r["final_over_true"] <= FINAL_OK for r in fin
                                           if r["true_over_floor"] <= TRUE_AT_FLOOR),
                                       sum(r["true_over_floor"] <= TRUE_AT_FLOOR for r in fin)),
            "possible_on_nulls": _frac(sum(bool(r.get("possible")) for r in nulls), len(nulls)),
            "step_limit": sum(bool(r.get("step_limit")) for r in ok),
            "added": sum(len(r.get("added", [])) for r in ok if not r["null"]),
            "unmatched_added": sum(len(r.get("unmatched_added", [])) for r in ok
                                   if not r["null"]),
            "spurious_added": sum(len(r.get("spurious_added", [])) for r in ok
                                  if not r["null"]),
            "true_at_floor": _frac(sum(r["true_over_floor"] <= TRUE_AT_FLOOR for r in tr),
                                   len(tr)),
            "time_median_s": statistics.median(t) if t else math.nan,
            "time_max_s": max(t) if t else math.nan,
        }

    out = {"overall": block(rows), "by_kind": {}, "by_effect": {}, "crashes": [],
           "skipped": [], "coef": {}, "candidate_errors": {}}
    for r in rows:
        for st in r.get("steps", []):
            for lab in st.get("candidate_errors", []):
                out["candidate_errors"][lab] = out["candidate_errors"].get(lab, 0) + 1
    for k in sorted({r["kind"] for r in rows}):
        out["by_kind"][k] = block([r for r in rows if r["kind"] == k])
    eff = _effects(rows)
    for c in sorted({e["cls"] for e in eff}):
        es = [e for e in eff if e["cls"] == c]
        strong = [e for e in es if e["magnitude"] >= STRONG]
        out["by_effect"][c] = {
            "n": len(es), "recall": _frac(sum(e["found"] for e in es), len(es)),
            "recall_strong": _frac(sum(e["found"] for e in strong), len(strong)),
            "named": _frac(sum(e["named"] for e in es), len(es)),
            "named_strong": _frac(sum(e["named"] for e in strong), len(strong)),
            "library": bool(es[0].get("library", True)),
            "other_names": _other_names(rows, c),
            "median_magnitude": statistics.median(e["magnitude"] for e in es),
        }
    for r in rows:
        if r.get("status") == "crash":
            out["crashes"].append({"seed": r["seed"], "kind": r["kind"],
                                   "stage": r["crash_stage"], "error": r["error"]})
        elif r.get("status") == "skipped":
            out["skipped"].append({"seed": r["seed"], "why": r.get("skipped")})
    zs = [c["z"] for r in rows for c in r.get("coef_checks", [])
          if c.get("z") is not None and math.isfinite(c["z"])]
    out["coef"] = {"n": len(zs), "within_3sigma": _frac(sum(abs(z) <= 3 for z in zs), len(zs)),
                   "rms_z": _rms(np.array(zs)) if zs else math.nan,
                   "missing": sum(c.get("fit") is None for r in rows
                                  for c in r.get("coef_checks", []))}
    tof = [r["true_over_floor"] for r in rows if "true_over_floor" in r]
    out["true_over_floor"] = ({"median": statistics.median(tof),
                               "p90": float(np.percentile(tof, 90)), "max": max(tof)}
                              if tof else {})
    return out


def _pct(f: dict) -> str:
    if not f["n"]:
        return "–"
    return f"{100 * f['frac']:.0f} % ({f['k']}/{f['n']})"


def markdown(s: dict, *, title: str = "") -> str:
    """Markdown tables of a :func:`summarise` result (for benchmarks/README.md)."""
    o = s["overall"]
    lines = []
    if title:
        lines += [title, ""]
    lines += [
        "| measure | result |", "|---|---|",
        f"| cases (completed / crashed / skipped) | {o['cases']} ({o['completed']} / "
        f"{o['crashed']} / {o['skipped']}) |",
        f"| recall, all missing effects | {_pct(o['recall'])} |",
        f"| recall, magnitude >= {STRONG:g}x floor | {_pct(o['recall_strong'])} |",
        f"| recall, unique magnitude >= {STRONG:g}x floor | {_pct(o['recall_strong_unique'])} |",
        f"| recall, unique magnitude >= {STRONG:g}x and regressor error < {OBSERVABLE:g} "
        f"floor | {_pct(o['recall_strong_observable'])} |",
        f"| named correctly, all | {_pct(o['named'])} |",
        f"| named correctly, magnitude >= {STRONG:g}x | {_pct(o['named_strong'])} |",
        f"| named correctly, unique >= {STRONG:g}x and regressor error < {OBSERVABLE:g} "
        f"floor | {_pct(o['named_strong_observable'])} |",
        f"| named correctly when found | {_pct(o['named_given_found'])} |",
        f"| named correctly or among the verdict's indistinguishable equivalents | "
        f"{_pct(o['named_equiv'])} |",
        f"| named correctly or an exact equivalent in this log (signals outside the base "
        f"model at |r| >= {EQUIV_R:g}), magnitude >= {STRONG:g}x | "
        f"{_pct(o['named_data_equiv_strong'])} |",
        f"| ... unique magnitude >= {STRONG:g}x | "
        f"{_pct(o['named_data_equiv_strong_unique'])} |",
        f"| false alarms on null cases | {_pct(o['false_alarms'])} |",
        f"| ... synthetic noise / a segment of a real gyro record | "
        f"{_pct(o['false_alarms_synthetic'])} / {_pct(o['false_alarms_real'])} |",
        f"| ... whose added term explains < {SPURIOUS:g} floor of the truth (spurious) | "
        f"{_pct(o['false_alarms_spurious'])} |",
        f"| ... spurious, synthetic noise / real gyro noise | "
        f"{_pct(o.get('false_alarms_spurious_synthetic', _frac(0, 0)))} / "
        f"{_pct(o.get('false_alarms_spurious_real', _frac(0, 0)))} |",
        *[f"| ... real noise from {rec}: any term / spurious | {_pct(a)} / {_pct(sp)} |"
          for rec, (a, sp) in o.get("false_alarms_real_by_record", {}).items()],
        f"| ... nulls whose true model reaches the floor (true held-out <= {TRUE_AT_FLOOR:g}x "
        f"the injected floor) | {_pct(o.get('false_alarms_true_at_floor', _frac(0, 0)))} |",
        f"| final held-out / true held-out <= {FINAL_OK:g} | {_pct(o['final_ok'])} |",
        f"| ... among cases whose true model is at the floor | {_pct(o['final_ok_at_floor'])} |",
        f"| final held-out / held-out of the true model in the workbench's terms <= 1.1 | "
        f"{_pct(o['final_ok_user'])} |",
        f"| printed floor ratio within {FLOOR_FACTOR:g}x of the true ratio | "
        f"{_pct(o['floor_ok'])} |",
        f"| printed noise floor within {FLOOR_FACTOR:g}x of the injected floor | "
        f"{_pct(o['floor_vs_injected_ok'])} |",
        f"| cases (not nulls) with an added term that is neither true nor an exact equivalent "
        f"nor a part of the truth (>= {PART:g} floor) | {_pct(o['unjustified_cases'])} |",
        f"| \"possible missing effect\" on null cases (not an alarm) | "
        f"{_pct(o['possible_on_nulls'])} |",
        f"| loops stopped by the step limit | {o['step_limit']} |",
        f"| terms added in non-null cases / naming no missing effect / explaining < "
        f"{SPURIOUS:g} floor of the truth | {o['added']} / {o['unmatched_added']} / "
        f"{o['spurious_added']} |",
        f"| true model held-out <= {TRUE_AT_FLOOR:g}x injected floor (harness) | "
        f"{_pct(o['true_at_floor'])} |",
        f"| true-model coefficients within 3 sigma (harness) | {_pct(s['coef']['within_3sigma'])}"
        f", rms z {s['coef']['rms_z']:.2f} |",
        f"| time per case, median / max | {o['time_median_s']:.1f} s / {o['time_max_s']:.1f} s |",
        "",
        "| kind | cases | nulls | false alarms | missing | recall | recall >= 3x | named | "
        "named >= 3x | final <= 1.1 | floor 2x | crashes | median s |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for k, b in s["by_kind"].items():
        lines.append(f"| {k} | {b['cases']} | {b['nulls']} | {_pct(b['false_alarms'])} | "
                     f"{b['missing_effects']} | {_pct(b['recall'])} | "
                     f"{_pct(b['recall_strong'])} | {_pct(b['named'])} | "
                     f"{_pct(b['named_strong'])} | {_pct(b['final_ok'])} | "
                     f"{_pct(b['floor_ok'])} | {b['crashed']} | {b['time_median_s']:.1f} |")
    lines += ["", "| effect | truth term | missing | median magnitude | recall | "
              "recall >= 3x | named | named >= 3x | found but named first as |",
              "|---|---|---|---|---|---|---|---|---|"]
    for c, b in s["by_effect"].items():
        other = ", ".join(f"{k} ({n})" for k, n in b["other_names"]) or "–"
        lines.append(f"| {c} | {'library' if b['library'] else 'custom'} | {b['n']} | "
                     f"{b['median_magnitude']:.1f} | {_pct(b['recall'])} | "
                     f"{_pct(b['recall_strong'])} | {_pct(b['named'])} | "
                     f"{_pct(b['named_strong'])} | {other} |")
    if s["crashes"]:
        lines += ["", "Crashes:", ""]
        lines += [f"* seed {c['seed']} ({c['kind']}), {c['stage']}: {c['error']}"
                  for c in s["crashes"]]
    if s["candidate_errors"]:
        lines += ["", "Candidates that could not be fitted (count over all diagnoses): "
                  + ", ".join(f"{k} ({v})" for k, v in sorted(s["candidate_errors"].items()))]
    if s["skipped"]:
        lines += ["", "Skipped: " + ", ".join(f"{c['seed']} ({c['why']})" for c in s["skipped"])]
    return "\n".join(lines)


# ============================================================================ campaign
def _job(args: tuple) -> dict:
    seed, kind, max_hours, max_steps, loop, reference, null, path_steps, real = args
    t0 = time.perf_counter()
    try:
        case = ws.make_case(seed, kind, max_hours=max_hours, null=null, real=real)
    except Exception as e:  # noqa: BLE001 - a simulator bug must not stop the campaign
        return {"seed": seed, "kind": kind or "?", "status": "crash", "crash_stage": "simulate",
                "error": _fmt_err(e), "traceback": traceback.format_exc(limit=6),
                "null": False, "truth": [], "times": {"total_s": time.perf_counter() - t0}}
    t_sim = time.perf_counter() - t0
    row = run_case(case, max_steps=max_steps, loop=loop, reference=reference,
                   path_steps=path_steps)
    row["times"]["simulate_s"] = t_sim
    return row


def run_campaign(seeds: list[int], *, kinds: list[str] | None = None, jobs: int = 1,
                 max_hours: float | None = None, max_steps: int = MAX_STEPS, loop: bool = True,
                 progress: bool = True, reference: bool = False, nulls: bool = False,
                 path_steps: int = 1, real: bool | None = None) -> list[dict]:
    """Run every seed (in a multiprocessing Pool when ``jobs`` > 1); rows in seed order.
    ``nulls``: every case has nothing missing (false alarms only); ``path_steps``: see
    :func:`run_case`; ``real``: every case on real gyro noise (True), none (False), or the
    simulator's 15 % (None)."""
    tasks = [(s, case_kind(s, kinds), max_hours, max_steps, loop, reference, nulls,
              path_steps, real) for s in seeds]
    rows: list[dict] = []
    t0 = time.perf_counter()

    def note(r: dict) -> None:
        rows.append(r)
        if progress:
            miss = [t["cls"] for t in r.get("truth", []) if t.get("missing")]
            got = [t["cls"] + ("+" if t.get("named") else "~" if t.get("found") else "-")
                   for t in r.get("truth", []) if t.get("missing")]
            tag = r["status"] if r["status"] != "ok" else (
                f"alarm={r.get('alarm')}" if not miss else " ".join(got))
            print(f"[{len(rows)}/{len(tasks)} {time.perf_counter() - t0:6.0f}s] seed "
                  f"{r['seed']} {r['kind']}: {tag} ({r['times'].get('total_s', 0):.1f} s)"
                  + (f" {r['error']}" if r.get("error") else ""), file=sys.stderr, flush=True)

    if jobs > 1:
        with Pool(jobs) as pool:
            for r in pool.imap_unordered(_job, tasks):
                note(r)
    else:
        for t in tasks:
            note(_job(t))
    rows.sort(key=lambda r: r["seed"])
    return rows


def gyrotest_state() -> dict:
    """Which gyrotest was measured: git HEAD, modified files under gyrotest/, and a sha256 of
    the gyrotest/envmodel sources (the verdict logic is under active change)."""
    import hashlib
    import subprocess

    repo = HERE.parent
    h = hashlib.sha256()
    for p in sorted((repo / "gyrotest" / "envmodel").glob("*.py")):
        h.update(p.name.encode() + p.read_bytes())
    out = {"envmodel_sha256": h.hexdigest()[:16]}
    try:
        out["head"] = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=repo,
                                     capture_output=True, text=True, check=True).stdout.strip()
        st = subprocess.run(["git", "status", "--porcelain", "gyrotest"], cwd=repo,
                            capture_output=True, text=True, check=True).stdout
        out["modified"] = [ln[3:] for ln in st.splitlines()]
    except (OSError, subprocess.CalledProcessError):
        pass
    return out


def run_quick(jobs: int = 2, progress: bool = False) -> list[dict]:
    """The ``--quick`` campaign (for the test suite): seeds 100-119, kinds cycled, <= 3 h."""
    return run_campaign(list(QUICK_SEEDS), kinds=list(ws.KINDS), jobs=jobs,
                        max_hours=QUICK_MAX_HOURS, progress=progress)


def _json_default(o):
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, np.generic):
        return o.item()
    return str(o)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", default=None,
                    help=f"seed range(s), e.g. 5000-5199 or 1,2,10-19 (default {DEFAULT_SEEDS};"
                         " 1-4999 tuning, >= 5000 reporting)")
    ap.add_argument("--kinds", default=None,
                    help=f"comma-separated run kinds to cycle through ({', '.join(ws.KINDS)}); "
                         "default: drawn per seed")
    ap.add_argument("--jobs", type=int, default=1, help="worker processes")
    ap.add_argument("--json", default=None, help="write every row to this JSON file")
    ap.add_argument("--quick", action="store_true",
                    help=f"~20 short cases (seeds {QUICK_SEEDS.start}-{QUICK_SEEDS.stop - 1}, "
                         f"kinds cycled, <= {QUICK_MAX_HOURS:g} h) for the test suite")
    ap.add_argument("--max-steps", type=int, default=MAX_STEPS, help="diagnoses per case")
    ap.add_argument("--path-steps", type=int, default=1,
                    help="forward-path steps per diagnosis (model diagnose --path; the loop's "
                         "decisions do not depend on it, only the verdict's 'then X' text)")
    ap.add_argument("--max-hours", type=float, default=None, help="cap the record length")
    ap.add_argument("--reference", action="store_true",
                    help="give every case a static reference run of the same simulated gyro "
                         "(the floor then comes from it, as with --reference LOG)")
    ap.add_argument("--real-noise", action="store_true",
                    help="every case on a segment of a real gyro record (ADIS16405 x/y/z, "
                         "XSens MTi-G x) instead of the simulator's 15 %%")
    ap.add_argument("--nulls", action="store_true",
                    help="null cases only (nothing missing): a larger sample of false alarms")
    ap.add_argument("--validate", action="store_true",
                    help="harness check only: fit the true model, no diagnosis loop")
    ap.add_argument("--summarise", nargs="+", metavar="JSON", default=None,
                    help="no run: the tables of the rows stored by earlier --json runs, "
                         "pooled (e.g. several fresh report sets)")
    a = ap.parse_args(argv)
    if a.summarise:
        rows = []
        for path in a.summarise:
            with open(path) as fh:
                rows.extend(json.load(fh)["rows"])
        print(markdown(summarise(rows), title=f"Pooled rows of {', '.join(a.summarise)}"))
        return 0
    kinds = [k.strip() for k in a.kinds.split(",") if k.strip()] if a.kinds else None
    for k in kinds or []:
        if k not in ws.KINDS:
            ap.error(f"unknown kind {k!r} (kinds: {', '.join(ws.KINDS)})")
    if a.quick:
        seeds = list(QUICK_SEEDS) if a.seeds is None else parse_seeds(a.seeds)
        kinds = kinds or list(ws.KINDS)
        max_hours = a.max_hours or QUICK_MAX_HOURS
    else:
        seeds = parse_seeds(a.seeds or DEFAULT_SEEDS)
        max_hours = a.max_hours
    if not ws.real_noise_available():
        print(f"note: {ws.REAL_NOISE} not found; real-noise cases are skipped", file=sys.stderr)
    state = gyrotest_state()
    t0 = time.perf_counter()
    rows = run_campaign(seeds, kinds=kinds, jobs=a.jobs, max_hours=max_hours,
                        max_steps=a.max_steps, loop=not a.validate, reference=a.reference,
                        nulls=a.nulls, path_steps=a.path_steps,
                        real=True if a.real_noise else None)
    wall = time.perf_counter() - t0
    s = summarise(rows)
    rng = f"{seeds[0]}-{seeds[-1]}" if seeds == list(range(seeds[0], seeds[-1] + 1)) else \
        ",".join(map(str, seeds))
    if a.json:
        with open(a.json, "w") as fh:
            json.dump({"seeds": seeds, "kinds": kinds, "max_hours": max_hours,
                       "gyrotest": state,
                       "summary": s, "rows": rows}, fh, indent=1, default=_json_default)
    print(markdown(s, title=f"Seeds {rng}" + (f", kinds {','.join(kinds)}" if kinds else "")
                   + (f", <= {max_hours:g} h" if max_hours else "")
                   + (", null cases only" if a.nulls else "")
                   + (", real gyro noise only" if a.real_noise else "")
                   + f", {a.jobs} job(s), wall {wall:.0f} s"
                   + (" (validate: true model only)" if a.validate else "")
                   + f"; gyrotest {state.get('head', '?')}, envmodel "
                   f"{state['envmodel_sha256']}"
                   + (" (uncommitted changes)" if state.get("modified") else "")))
    return 0


if __name__ == "__main__":
    sys.exit(main())
