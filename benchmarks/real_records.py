#!/usr/bin/env python3
"""What the real-noise cases of the workbench campaign are made of.

``bench_workbench.py --real-noise`` scales segments of four real gyro records
(:data:`workbench_sim.REAL_RECORDS`: ADIS16405 x/y/z, 2.4 h after their 20-min start-up
transient, which the campaign leaves out; XSens MTi-G x, 1.35 h) as the
"noise" of a simulated run. A false alarm there counts any term the workbench adds; this script
shows what the records carry besides noise, so that the per-record false-alarm rates can be
read: the level of the 60-s means before and after the shift the ADIS16405 y and z axes share
near 0.8–1.0 h, the first minutes against 0.3–0.5 h (a start-up transient), the coherence of
the three ADIS16405 axes at periods of 400–700 s against the rest of the band, the strongest
spectral line of each record (Thomson's harmonic F-test), and the white-noise level of a 60-s
mean for scale. ``--plot F.png`` draws the 60-s means.

Run from the repository root with ``../shared`` beside it::

    python benchmarks/real_records.py --plot records.png
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from scipy import signal

sys.path.insert(0, str(Path(__file__).resolve().parent))

from workbench_sim import REAL_RECORDS, _real_record  # noqa: E402


def _means(x: np.ndarray, m: int) -> np.ndarray:
    return x[: len(x) // m * m].reshape(-1, m).mean(axis=1)


def line_test(x: np.ndarray, dt: float = 1.0, pmin: float = 150.0, pmax: float = 4800.0,
              nw: float = 4.0, k: int = 7, pad: int = 4) -> tuple[float, float, float]:
    """Thomson's harmonic F-test (D. J. Thomson, "Spectrum estimation and harmonic
    analysis", Proc. IEEE 70(9), 1982) for a line (a sinusoid) in coloured noise, over the
    periods the workbench searches: the multitaper estimate of a line's amplitude at each
    frequency against the tapers' residual, F(2, 2k − 2) under no line. Returns (period s,
    F, family-wise p) of the strongest, Bonferroni over the ``pad``-times oversampled
    frequencies of the band (on white + random-walk noise this holds its size: 2 of 40 at
    p < 0.05)."""
    from scipy import stats

    x = np.asarray(x, float)
    x = x - x.mean()
    n = len(x)
    tapers = signal.windows.dpss(n, nw, k)
    u0 = tapers.sum(axis=1)
    y = np.fft.rfft(tapers * x[None, :], n=pad * n, axis=1)
    f = np.fft.rfftfreq(pad * n, dt)
    mu = (u0[:, None] * y).sum(axis=0) / (u0 ** 2).sum()
    F = ((k - 1) * np.abs(mu) ** 2 * (u0 ** 2).sum()
         / (np.abs(y - mu[None, :] * u0[:, None]) ** 2).sum(axis=0))
    band = (f >= 1 / pmax) & (f <= 1 / pmin)
    j = int(np.argmax(F[band]))
    m = pad * max(1, round(n * dt * (1 / pmin - 1 / pmax)))
    p = min(1.0, m * float(stats.f.sf(F[band][j], 2, 2 * k - 2)))
    return 1.0 / f[band][j], float(F[band][j]), p


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plot", default=None, help="write the 60-s means to this PNG")
    a = ap.parse_args(argv)
    recs = [_real_record(i, settled=False) for i in range(len(REAL_RECORDS))]
    if any(r is None for r in recs):
        print("the real records are not in ../shared/reference/data/realdata", file=sys.stderr)
        return 2
    print("mean of the 60-s means over each stretch (deg/h), and the white-noise σ of one 60-s "
          "mean")
    print("| record | 60-s white σ | 0–6 min | 0.3–0.5 h | 0.5–0.75 h | 1.05–1.3 h |")
    print("|---|---|---|---|---|---|")
    for (label, *_), x in zip(REAL_RECORDS, recs):
        b = _means(x, 60)
        t = (np.arange(len(b)) + 0.5) / 60.0
        lv = [b[(t > lo) & (t < hi)].mean() for lo, hi in
              ((0, 0.1), (0.3, 0.5), (0.5, 0.75), (1.05, 1.3))]
        w = np.std(np.diff(x)) / np.sqrt(2.0) / np.sqrt(60.0)
        print(f"| {label} | {w:.0f} | " + " | ".join(f"{v:+.0f}" for v in lv) + " |")
    B = [_means(x, 20) for x in recs[:3]]
    n = min(len(b) for b in B)
    print("\ncoherence of the ADIS16405 axes (20-s means, Welch 128):")
    for i in range(3):
        for k in range(i + 1, 3):
            f, C = signal.coherence(B[i][:n], B[k][:n], fs=1 / 20.0, nperseg=128)
            band = (f > 1 / 700) & (f < 1 / 400)
            print(f"  {'xyz'[i]}–{'xyz'[k]}: {C[band].max():.2f} at 400–700 s, median "
                  f"{np.median(C[f > 1 / 100]):.2f} at periods < 100 s")
    print("\nstrongest line at 150–4800 s (Thomson's harmonic F-test, whole record at 1 s):")
    for (label, *_), x in zip(REAL_RECORDS, recs):
        per, F, p = line_test(x)
        print(f"  {label}: {per:.0f} s, F = {F:.1f}, family-wise p = {p:.2g}")
    if a.plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(len(recs), 1, figsize=(9, 8), sharex=True)
        for axi, (label, *_), x in zip(ax, REAL_RECORDS, recs):
            b = _means(x, 60)
            axi.plot(np.arange(len(b)) / 60.0, b, lw=0.8)
            axi.set_ylabel(f"{label}\n(deg/h)")
            axi.grid(alpha=0.3)
        ax[-1].set_xlabel("time since the record's start (h)")
        fig.suptitle("60-s means of the real records (mean removed)")
        fig.tight_layout()
        fig.savefig(a.plot, dpi=90)
        print(f"wrote {a.plot}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
