#!/usr/bin/env python3
"""KROBKA-M1 ("ARW line above the measured curve") and Krobka's bound N_upper on white rate
noise: false alarms on clean records, detection of a hump that screens the white noise, and
how often the bound holds the true N.

    python benchmarks/bench_m1.py --seeds 1000:1060

Rules compared:

* current: N_fit > N_upper, the 95 % upper bound of N from the upper confidence limits of σ̂
  (family-wise over the τ; :func:`gyrotest.noise.noisefit.n_upper_bound`);
* former (before issue 58): one τ beyond the Bonferroni level Φ⁻¹(1 − 0.05/(2n)) in CI units,
  or two adjacent τ beyond 3 CI, with N_upper = min σ̂√τ/60 read on the estimates.

Cases: clean, 2 h at 10 Hz of N = 0.01 deg/√h + B = 0.005 deg/h + K = 0.002 deg/h/√h (nothing
above the N line); hump, the same plus a Markov hump (q_c = 60, T_c = 0.3 s) that screens the
white noise, the case M1 exists for; white, 10 min at 100 Hz of white rate noise N = 0.3
deg/√h (the bundled IMU demo of sample_data/make_imu_files.py). Default τ grid.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from statistics import NormalDist

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from gyrotest.core.data import GyroConstants, GyroLog, Timing  # noqa: E402
from gyrotest.noise.analysis import analyse_allan  # noqa: E402
from gyrotest.simulation import simulate  # noqa: E402

CASES = {
    "clean": ({"N": 0.01, "B": 0.005, "K": 0.002}, 10.0, 7200.0),
    "hump": ({"N": 0.01, "B": 0.005, "K": 0.002, "markov": [{"q_c": 60.0, "T_c": 0.3}]},
             10.0, 7200.0),
    "white": ({"N": 0.3}, 100.0, 600.0),
}


def case(seed: int, name: str) -> dict:
    noise, fs, dur = CASES[name]
    sc = {"record": {"sample_rate_hz": fs, "duration_s": dur},
          "gyro": {"output": "rate", "rate_unit": "deg/h", "noise": noise}}
    x = np.asarray(simulate(sc, seed=seed).rate_dph, float)
    tau0 = 1.0 / fs
    log = GyroLog(source="sim", rates={"r": x}, tau0=tau0,
                  timing=Timing(n=x.size, tau0=tau0, duration_s=x.size * tau0, source="bench"),
                  gyro=GyroConstants(output_kind="rate"))
    a = analyse_allan(log, spectral=False, trend_check=False, run_diagnosis=False).axes[0]
    w = next((w for w in a.warnings if w.code == "KROBKA-M1"
              and w.title == "ARW line above the measured curve"), None)
    f = a.fit
    N = f.term("N")
    sig = np.sqrt(N.avar(f.tau)) if N is not None and N.coef > 0 else np.zeros_like(f.tau)
    over = (sig > f.sigma) & np.isfinite(f.sigma_hi)
    exc = np.where(over, (sig - f.sigma) / np.maximum(f.sigma_hi - f.sigma, 1e-300), 0.0)
    n = int(np.count_nonzero(np.isfinite(f.sigma_hi)))
    z = max(3.0, -NormalDist().inv_cdf(0.05 / (2.0 * max(n, 1))))
    big = exc > 3.0
    old = bool(exc.max() > z or np.any(big[1:] & big[:-1]))
    n_true = noise["N"]
    return {"new": w is not None, "old": old,
            "covers": a.readoffs["N_upper"] >= n_true,
            "graph_covers": a.readoffs["N_upper_graph"] >= n_true}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="1000:1060")
    a, b = (int(v) for v in ap.parse_args().seeds.split(":"))
    print("| case | records | M1 fires (N_fit > N_upper) | former rule | N_upper ≥ N "
          "| min σ̂√τ/60 ≥ N |")
    print("|---|---:|---:|---:|---:|---:|")
    for name in CASES:
        rs = [case(s, name) for s in range(a, b)]
        cov = "—" if name == "hump" else f"{sum(r['covers'] for r in rs)}"
        gcov = "—" if name == "hump" else f"{sum(r['graph_covers'] for r in rs)}"
        print(f"| {name} | {len(rs)} | {sum(r['new'] for r in rs)} | "
              f"{sum(r['old'] for r in rs)} | {cov} | {gcov} |")


if __name__ == "__main__":
    main()
