#!/usr/bin/env python3
"""Krobka's central case through the whole ``gyrotest allan`` analysis, over many seeds: what
the final (diagnosed) noise model contains against the simulation truth.

Truth: 2 h at 100 Hz, white rate N = 2e-4 deg/√h, first-order Gauss–Markov q_c = 4 deg/h/√s
(240 deg/h/√h), T_c = 0.2 s, flicker B = 0.003 deg/h. The hump's white tail (N_eq = q_c·T_c ≈
0.013 deg/√h) hides B over the whole record, so the identifiable model is {N, markov} with
bounds on Q, B, K, R. Run from the repository root (≈ 4 min for 50 seeds):

    python benchmarks/bench_krobka_case.py --seeds 100:150
"""

from __future__ import annotations

import argparse
import re
import sys
from collections import Counter
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from gyrotest.core.data import GyroConstants, GyroLog, Timing  # noqa: E402
from gyrotest.noise.analysis import analyse_allan  # noqa: E402
from gyrotest.simulation import simulate  # noqa: E402

TRUTH = {"N": 2e-4, "B": 0.003, "markov": [{"q_c": 240.0, "T_c": 0.2}]}


def run(seed: int):
    sc = {"record": {"sample_rate_hz": 100.0, "duration_s": 7200},
          "gyro": {"output": "rate", "rate_unit": "deg/h", "noise": TRUTH}}
    y = np.asarray(simulate(sc, seed=seed).rate_dph, float)
    log = GyroLog(source=f"seed{seed}", rates={"z": y}, tau0=0.01,
                  timing=Timing(n=y.size, tau0=0.01, duration_s=y.size * 0.01, source="sim"),
                  gyro=GyroConstants(output_kind="rate"))
    a = analyse_allan(log).axes[0]
    return a.diagnosis.final if a.diagnosis is not None else a.fit


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="100:150")
    args = ap.parse_args()
    a, b = (int(v) for v in args.seeds.split(":"))
    exact = 0
    extra: Counter[str] = Counter()
    n_err, tc_err, qc_err = [], [], []
    for seed in range(a, b):
        fin = run(seed)
        ids = [t for t in fin.terms if t.identified]
        keys = [t.key for t in ids]
        exact += sorted(keys) == ["N", "markov"]
        for k in keys:
            if k not in ("N", "markov"):
                extra[k] += 1
        if keys.count("markov") > 1:
            extra["second markov"] += 1
        if "N" not in keys:
            extra["N not identified"] += 1
        for t in ids:
            if t.key == "N":
                n_err.append(abs(t.params["N"] / 2e-4 - 1))
            if t.key == "markov" and re.fullmatch(r"markov(\[0\])?", t.label):
                tc_err.append(abs(t.params["T_c"] / 0.2 - 1))
                qc_err.append(abs(t.params["q_c"] / 240.0 - 1))
    n = b - a
    print(f"seeds {a}–{b - 1}: final model = {{N, markov}} exactly in {exact}/{n}")
    print(f"extra or missing: {dict(extra)}")
    if n_err:
        print(f"N error: median {np.median(n_err):.1%}, max {np.max(n_err):.1%} "
              f"({len(n_err)} identified)")
    if tc_err:
        print(f"markov T_c error median {np.median(tc_err):.1%} (max {np.max(tc_err):.1%}), "
              f"q_c median {np.median(qc_err):.1%} (max {np.max(qc_err):.1%})")


if __name__ == "__main__":
    main()
