"""The lot-outlier rule of ``gyrotest fleet``: threshold table, false alarms, recall; and speed.

Method (the outlier rule is a classifier, so it is tuned on one seed and reported on others):

* ``--tune``: for each lot size n, 200 000 lots of n standard-normal values (seed 1); the
  threshold c(n) is the 99 % quantile of max_i |M_i| (modified z-score, Iglewicz & Hoaglin
  1993), i.e. a 1 % chance per spec item and lot that a lot without an outlier shows one. The
  printed table is :data:`gyrotest.fleet.core.OUTLIER_THRESHOLDS`.
* ``--check`` (default): on seeds 2024 … (never used for tuning), lots of n normal values,
  null (no outlier) and with one member shifted by δ = 4, 6, 8, 12, 20 σ (also heavy-tailed
  lots: Student t with 5 degrees of freedom, whose spread the rule was not tuned on). Reports
  the false-alarm rate (any flag in a null lot), the recall (the shifted member flagged) and the
  rate of wrong flags (another member flagged) in a lot with an outlier. Writes
  ``benchmarks/fleet_outliers.png`` with ``--plot``.
* ``--speed DIR``: a simulated lot (``gyrotest.simulation.lot.write_lot``, 6 serials + 2 earlier
  tests) analysed serially, on the process pool (2 workers) and on a Dask LocalCluster, with the
  wall time of each and a check that the three summaries are equal.

    python benchmarks/bench_fleet.py --check --plot
    python benchmarks/bench_fleet.py --tune
    python benchmarks/bench_fleet.py --speed /tmp/lot
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

NS = (5, 6, 7, 8, 9, 10, 12, 15, 20, 25, 30, 40, 50)
SHIFTS = (4.0, 6.0, 8.0, 12.0, 20.0)


def _maxz(X: np.ndarray) -> np.ndarray:
    med = np.median(X, axis=1, keepdims=True)
    mad = np.median(np.abs(X - med), axis=1, keepdims=True)
    return np.max(np.abs(0.6745 * (X - med) / mad), axis=1)


def tune(alpha: float = 0.01, lots: int = 200_000, seed: int = 1) -> dict[int, float]:
    """c(n) = the (1 − alpha) quantile of max |M| over null lots of n normal values."""
    rng = np.random.default_rng(seed)
    return {n: float(np.quantile(_maxz(rng.standard_normal((lots, n))), 1 - alpha)) for n in NS}


def check(lots: int = 4000, seed: int = 2024, dist: str = "normal") -> list[dict]:
    """False alarms and recall of :func:`gyrotest.fleet.core.flag_outliers` (vectorised with
    the same thresholds)."""
    from gyrotest.fleet.core import outlier_threshold

    rng = np.random.default_rng(seed)
    draw = (lambda shape: rng.standard_normal(shape)) if dist == "normal" else (
        lambda shape: rng.standard_t(5, shape) / np.sqrt(5 / 3))
    rows = []
    for n in (5, 6, 8, 12, 20, 40):
        c = outlier_threshold(n)

        def flags(X, c=c):
            med = np.median(X, axis=1, keepdims=True)
            mad = np.median(np.abs(X - med), axis=1, keepdims=True)
            return np.abs(0.6745 * (X - med) / mad) > c

        row = {"n": n, "threshold": c, "false_alarm": float(flags(draw((lots, n))).any(1).mean())}
        for d in SHIFTS:
            X = draw((lots, n))
            X[:, 0] += d
            f = flags(X)
            row[f"recall_{d:g}"] = float(f[:, 0].mean())
            row[f"wrong_{d:g}"] = float(f[:, 1:].any(1).mean())
        rows.append(row)
    return rows


def speed(directory: str) -> None:
    """Serial vs process pool vs Dask LocalCluster on a simulated lot: wall times, equality."""
    from gyrotest.fleet import run_fleet
    from gyrotest.simulation.lot import SMALL, write_lot

    lot = write_lot(directory, 6, size=SMALL)
    res = {}
    for how, kw in (("serial", {"jobs": 1}), ("pool, 2 workers", {"jobs": 2}),
                    ("dask LocalCluster, 2 workers", {"jobs": 2, "scheduler": "local"})):
        t0 = time.perf_counter()
        f = run_fleet(lot.campaigns, **kw)
        res[how] = f.to_dict(timing=False)
        print(f"{how:30s} {time.perf_counter() - t0:6.1f} s wall "
              f"({f.run['campaign_seconds']:.1f} s in the campaigns)")
    first = next(iter(res.values()))
    print("identical summaries:", all(v == first for v in res.values()))


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tune", action="store_true")
    ap.add_argument("--check", action="store_true")
    ap.add_argument("--plot", action="store_true")
    ap.add_argument("--speed", metavar="DIR")
    a = ap.parse_args(argv)
    if a.tune:
        print({n: round(c, 2) for n, c in tune().items()})
    if a.speed:
        speed(a.speed)
    if a.check or not (a.tune or a.speed):
        for dist in ("normal", "t5"):
            rows = check(dist=dist)
            print(f"\n{dist} lots: n, c(n), false alarm, then recall / wrong flags per shift (σ)")
            for r in rows:
                print(f"n={r['n']:3d} c={r['threshold']:5.2f} FA={r['false_alarm']:.3f}  "
                      + "  ".join(f"{d:g}σ {r[f'recall_{d:g}']:.2f}/{r[f'wrong_{d:g}']:.3f}"
                                  for d in SHIFTS))
            if a.plot and dist == "normal":
                import matplotlib.pyplot as plt

                fig, ax = plt.subplots(figsize=(8.5, 4))
                for r in rows:
                    ax.plot(SHIFTS, [r[f"recall_{d:g}"] for d in SHIFTS], "o-",
                            label=f"n = {r['n']} (false alarm {r['false_alarm']:.1%})")
                ax.set_xlabel("shift of one serial, σ of the lot")
                ax.set_ylabel("recall (the shifted serial flagged)")
                ax.set_title("gyrotest fleet outlier rule (1 % false alarm per item and lot)",
                             fontsize=9.5)
                ax.grid(alpha=0.3)
                ax.legend(fontsize=8, loc="center left", bbox_to_anchor=(1.02, 0.5))
                fig.tight_layout()
                out = Path(__file__).with_name("fleet_outliers.png")
                fig.savefig(out, dpi=110)
                print("wrote", out)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
