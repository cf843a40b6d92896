#!/usr/bin/env python3
"""KROBKA-M1 ("ARW line above the measured curve") false alarms on clean records, and its
detection of a hump that screens the white noise, with the multiplicity allowance (a single τ
beyond the Bonferroni level of the tested τ, or two adjacent τ beyond 3 CI) and without it (any
τ beyond 3 CI, the former rule).

    python benchmarks/bench_m1.py --seeds 1000:1060

Clean: 2 h at 10 Hz of N = 0.01 deg/√h + B = 0.005 deg/h + K = 0.002 deg/h/√h (nothing above
the N line). Hump: the same plus a Markov hump (q_c = 60, T_c = 0.3 s) that screens the white
noise, the case M1 exists for. Default τ grid (10/decade), simulator of the project.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from gyrotest.data import GyroConstants, GyroLog, Timing  # noqa: E402
from gyrotest.noise.analysis import analyse_allan  # noqa: E402
from gyrotest.simulate import simulate  # noqa: E402


def case(seed: int, hump: bool) -> dict:
    noise = {"N": 0.01, "B": 0.005, "K": 0.002}
    if hump:
        noise["markov"] = [{"q_c": 60.0, "T_c": 0.3}]
    sc = {"record": {"sample_rate_hz": 10.0, "duration_s": 7200},
          "gyro": {"output": "rate", "rate_unit": "deg/h", "noise": noise}}
    x = np.asarray(simulate(sc, seed=seed).rate_dph, float)
    log = GyroLog(source="sim", rates={"r": x}, tau0=0.1,
                  timing=Timing(n=x.size, tau0=0.1, duration_s=x.size * 0.1, source="bench"),
                  gyro=GyroConstants(output_kind="rate"))
    a = analyse_allan(log, spectral=False, trend_check=False, run_diagnosis=False).axes[0]
    w = next((w for w in a.warnings if w.code == "KROBKA-M1"
              and w.title == "ARW line above the measured curve"), None)
    N = a.fit.term("N")
    sig = np.sqrt(N.avar(a.fit.tau)) if N is not None and N.coef > 0 else np.zeros_like(a.fit.tau)
    over = (sig > a.fit.sigma) & np.isfinite(a.fit.sigma_hi)
    exc = np.where(over, (sig - a.fit.sigma) / np.maximum(a.fit.sigma_hi - a.fit.sigma, 1e-300),
                   0.0)
    return {"new": w is not None, "old": bool(exc.max() > 3.0)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="1000:1060")
    a, b = (int(v) for v in ap.parse_args().seeds.split(":"))
    for hump in (False, True):
        rs = [case(s, hump) for s in range(a, b)]
        print(f"{'hump' if hump else 'clean'}: {len(rs)} records; M1 fires: with the "
              f"multiplicity allowance {sum(r['new'] for r in rs)}, former rule (any τ > 3 CI) "
              f"{sum(r['old'] for r in rs)}")


if __name__ == "__main__":
    main()
