#!/usr/bin/env python3
"""Benchmark: gyrotest Thêo1, ThêoH, TTOTDEV, HTOTDEV and gap-tolerant OADEV vs AllanTools.

Not part of the test suite. Run from the repository root:

    python benchmarks/bench_theo.py            # N = 1000, 2000, 4000 side by side; gyrotest to 10^6
    python benchmarks/bench_theo.py --quick    # N = 1000 only

Method: white rate noise (float64, seed 1), octave grids; both tools get the same averaging
factors (Thêo1: even m ≥ 10, which AllanTools reports at τ = m·τ0 and gyrotest at 0.75·m·τ0).
gyrotest runs with noise identification off (σ, EDF and χ² interval); AllanTools returns σ
only. Wall clock, best of ``--repeat``; AllanTools is skipped above ``--at-max`` samples (its
theo1/ttotdev/htotdev are Python double loops, O(N·m) per τ). The largest relative difference
of σ between the tools is printed as a check. ThêoH has no AllanTools counterpart (timed alone).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from gyrotest.noise.deviations import compute_deviation


def best(f, repeat):
    t = []
    out = None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = f()
        t.append(time.perf_counter() - t0)
    return min(t), out


def octave(mmax, even=False, lo=1):
    m = 2 ** np.arange(0, int(np.log2(mmax)) + 1)
    m = m[(m >= lo) & (m <= mmax)]
    return m


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--at-max", type=int, default=4000)
    a = ap.parse_args()
    import allantools as at

    sizes = [1000] if a.quick else [1000, 2000, 4000, 100_000, 1_000_000]
    print(f"{'kind':8s} {'N':>8s} {'#tau':>5s} {'gyrotest s':>11s} {'AllanTools s':>13s} "
          f"{'ratio':>8s} {'max rel diff':>13s}")
    for N in sizes:
        y = np.random.default_rng(1).standard_normal(N)
        x = np.concatenate(([0.0], np.cumsum(y)))
        cases = {
            "theo1": (octave(N - 1, lo=16), lambda m: 0.75 * m, "angle", x,
                      lambda m, x=x: at.theo1(x, rate=1.0, data_type="phase", taus=m.astype(float))),
            "ttotdev": (octave(N // 2), lambda m: m * 1.0, "angle", x,
                        lambda m, x=x: at.ttotdev(x, rate=1.0, data_type="phase", taus=m.astype(float))),
            "htotdev": (octave(N // 3), lambda m: m * 1.0, "rate", y,
                        lambda m, y=y: at.htotdev(y, rate=1.0, data_type="freq", taus=m.astype(float))),
            "gapadev": (octave(N // 4), lambda m: m * 1.0, "rate", y,
                        lambda m, y=y: at.oadev(y, rate=1.0, data_type="freq", taus=m.astype(float))),
            "theoh": (None, None, "rate", y, None),
        }
        for kind, (ms, tau_of, ik, data, atf) in cases.items():
            taus = "octave" if ms is None else list(tau_of(ms))
            tg, res = best(lambda d=data, i=ik, k=kind, t=taus: compute_deviation(
                d, 1.0, input_kind=i, kind=k, taus=t, noise_id=False), a.repeat)
            if atf is not None and N <= a.at_max:
                ta, r_at = best(lambda f=atf, mm=ms: f(mm), 1)
                diff = float(np.max(np.abs(res.sigma / r_at[1] - 1)))
                print(f"{kind:8s} {N:8d} {len(res.m):5d} {tg:11.4f} {ta:13.4f} {ta / tg:8.3g} "
                      f"{diff:13.1e}")
            else:
                print(f"{kind:8s} {N:8d} {len(res.m):5d} {tg:11.4f} {'—':>13s} {'':>8s} {'':>13s}")


if __name__ == "__main__":
    main()
