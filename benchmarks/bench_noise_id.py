#!/usr/bin/env python3
"""Power-law noise identification campaign: Stable32's rule (printed α, interval) against the
statistical rule (the noise-model fit's weights), on simulated records not used for tuning.

Run from the repository root (≈ 1–2 min):

    python benchmarks/bench_noise_id.py [--seeds 1000:1200] [--fit-seeds 2000:2020]

Part 1: rate records with PSD ∝ f^α (α = 2 … −2: exact differences/sums for even α, FFT
shaping for odd α), 64-sample averages, record lengths giving 10, 20, 28 averages (B1 regime)
and 100 (lag-1 ACF regime). Both identifications come from one
:func:`gyrotest.noise.edf.identify_noise_pair` call with Stable32's term count of the OADEV
(N_phase − 2m). Reported: recall of the true α per rule.

Part 2: the end-to-end fit (``compute_deviation`` → ``fit_deviation``) on simulated gyro logs
with random-walk rate K (the case the Stable32 rule cannot identify at 8–29 averages): K and
N recovered by the fit (which uses ``alpha_fit``), and for comparison by a fit that weights
with the printed (Stable32) α.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from gyrotest.core.angle import angle_series  # noqa: E402
from gyrotest.noise.deviations import compute_deviation  # noqa: E402
from gyrotest.noise.edf import identify_noise_pair  # noqa: E402
from gyrotest.noise.noisefit import fit_deviation  # noqa: E402

ALPHAS = (2, 1, 0, -1, -2)
AVERAGES = (10, 20, 28, 100)
M = 64


def power_law_rate(alpha: int, n: int, rng: np.random.Generator) -> np.ndarray:
    w = rng.standard_normal(n + 1)
    if alpha == 2:
        return np.diff(w)
    if alpha == 0:
        return w[:n]
    if alpha == -2:
        return np.cumsum(w[:n])
    f = np.fft.rfftfreq(2 * n)
    f[0] = f[1]
    spec = np.fft.rfft(rng.standard_normal(2 * n)) * f ** (alpha / 2.0)
    return np.fft.irfft(spec, 2 * n)[:n]


def id_campaign(seeds: range) -> dict:
    from gyrotest.noise.devcore import _raw_variance

    out = {}
    for avg in AVERAGES:
        n = avg * M
        for alpha in ALPHAS:
            hits = {"stable32": 0, "fit": 0}
            for seed in seeds:
                rng = np.random.default_rng(seed * 7919 + 31 * (alpha + 3) + avg)
                y = power_law_rate(alpha, n, rng)
                parts = angle_series(y, 1.0, input_kind="rate").parts()

                def rn(mm, parts=parts):
                    mv, _, _ = _raw_variance("mdev", parts, mm)
                    av, _, _ = _raw_variance("oadev", parts, mm)
                    return mv / av if av > 0 else float("nan")

                s32, fit = identify_noise_pair(parts, [M], [n + 1 - 2 * M], kind="oadev",
                                               data_type="frequency", rn_ratio=rn)
                hits["stable32"] += s32[0].alpha == alpha
                hits["fit"] += fit[0].alpha == alpha
            out[(avg, alpha)] = {k: v / len(seeds) for k, v in hits.items()}
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="1000:1200")
    ap.add_argument("--fit-seeds", default="2000:2020")
    args = ap.parse_args()
    a, b = (int(v) for v in args.seeds.split(":"))
    res = id_campaign(range(a, b))
    print(f"Part 1: recall of the true α, m = {M}, seeds {a}–{b - 1} ({b - a} records per cell)\n")
    print("| averages | rule | " + " | ".join(f"α = {al}" for al in ALPHAS) + " |")
    print("|---:|---|" + "---:|" * len(ALPHAS))
    for avg in AVERAGES:
        for rule, label in (("stable32", "Stable32 (printed α)"), ("fit", "statistical (fit)")):
            print(f"| {avg} | {label} | "
                  + " | ".join(f"{res[(avg, al)][rule]:.2f}" for al in ALPHAS) + " |")
    fa, fb = (int(v) for v in args.fit_seeds.split(":"))
    rows = fit_recovery(range(fa, fb))
    print(f"\nPart 2: fit recovery, seeds {fa}–{fb - 1}\n")
    print("| truth | weights | K identified | median abs K error | N identified | "
          "median abs N error |")
    print("|---|---|---:|---:|---:|---:|")
    for r in rows:
        print(f"| {r['truth']} | {r['weights']} | {r['k_id']:.2f} | {r['k_err']:.1%} | "
              f"{r['n_id']:.2f} | {r['n_err']:.1%} |")


def fit_recovery(seeds: range) -> list[dict]:
    """K and N from the fit with its own α (alpha_fit) and with the printed Stable32 α."""
    from dataclasses import replace

    from gyrotest.simulation import simulate

    def sim_rate(noise, *, hours, fs, seed):
        sc = {"record": {"sample_rate_hz": fs, "duration_s": hours * 3600},
              "gyro": {"output": "rate", "rate_unit": "deg/h", "noise": noise}}
        return simulate(sc, seed=seed)

    truths = [{"N": 0.005, "B": 0.005, "K": 0.1}, {"N": 0.005, "B": 0.02, "K": 0.01}]
    rows = []
    for truth in truths:
        res = {"own α (alpha_fit)": [], "Stable32 α": []}
        for seed in seeds:
            r = sim_rate(dict(truth), hours=8, fs=10.0, seed=seed)
            d = compute_deviation(r.rate_dph, 0.1, input_kind="rate")
            s32 = replace(d, alpha_fit=None, alpha_fit_method=None, edf_fit=None)
            for label, dev in (("own α (alpha_fit)", d), ("Stable32 α", s32)):
                f = fit_deviation(dev)
                k, n = f.term("K"), f.term("N")
                res[label].append((k.identified, abs(k.value / truth["K"] - 1)
                                   if k.identified else np.nan,
                                   n.identified, abs(n.value / truth["N"] - 1)
                                   if n.identified else np.nan))
        for label, v in res.items():
            arr = np.array(v, dtype=float)
            rows.append({"truth": ", ".join(f"{k} {x:g}" for k, x in truth.items()),
                         "weights": label, "k_id": np.mean(arr[:, 0]),
                         "k_err": np.nanmedian(arr[:, 1]) if np.any(arr[:, 0]) else np.nan,
                         "n_id": np.mean(arr[:, 2]),
                         "n_err": np.nanmedian(arr[:, 3]) if np.any(arr[:, 2]) else np.nan})
    return rows


if __name__ == "__main__":
    main()
