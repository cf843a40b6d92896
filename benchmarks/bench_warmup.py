#!/usr/bin/env python3
"""Randomized check of the warm-up detector of ``gyrotest bias`` (:mod:`gyrotest.staticbias.warmup`).

    python benchmarks/bench_warmup.py --seeds 1000:1040     # report range (tuned on 0:20)

4 h at 10 Hz, N = 0.01 deg/√h. Nulls: white; + flicker B = 0.02 deg/h; + RRW K = 0.05
deg/h/√h; + ramp R = 0.05 deg/h/h. Warm-ups: N + B with an exponential of amplitude 0.01 …
0.3 deg/h (the block-mean scatter is ≈ 0.08 deg/h) and τ_w uniform in 300 … 2400 s.
Printed: detections per case type (false alarms for the nulls, recall for the warm-ups).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from gyrotest.simulation import simulate  # noqa: E402
from gyrotest.staticbias.warmup import detect_warmup  # noqa: E402


def run(seed: int, kind: str, amp: float = 0.0):
    noise: dict = {"N": 0.01}
    if kind in ("flicker", "warmup"):
        noise["B"] = 0.02
    if kind == "rrw":
        noise["K"] = 0.05
    if kind == "ramp":
        noise["R"] = 0.05
    sc: dict = {"record": {"sample_rate_hz": 10.0, "duration_s": 4 * 3600},
                "gyro": {"output": "rate", "rate_unit": "deg/h", "noise": noise}}
    if amp:
        tw = float(np.random.default_rng(seed).uniform(300, 2400))
        sc["effects"] = {"warmup": {"amplitude_dph": amp, "tau_s": tw}}
    return detect_warmup(np.asarray(simulate(sc, seed=seed).rate_dph, float), 0.1)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="1000:1040")
    a, b = (int(v) for v in ap.parse_args().seeds.split(":"))
    for kind in ("white", "flicker", "rrw", "ramp"):
        print(f"null {kind}: {sum(run(s, kind).detected for s in range(a, b))}/{b - a} flagged")
    for amp in (0.01, 0.03, 0.1, 0.3):
        rs = [run(s, "warmup", amp) for s in range(a, b)]
        amp_err = [abs(r.amplitude_dph / amp - 1) for r in rs if r.detected]
        print(f"warm-up {amp} deg/h: {sum(r.detected for r in rs)}/{b - a} detected"
              + (f", median amplitude error {np.median(amp_err):.2f}" if amp_err else ""))


if __name__ == "__main__":
    main()
