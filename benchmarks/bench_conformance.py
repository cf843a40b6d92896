#!/usr/bin/env python3
"""Conformance of ``gyrotest allan``'s table with Stable32 on the shared real records.

Not part of the test suite (tests/test_conformance_realdata.py runs the same comparison).
Run from the repository root:

    python benchmarks/bench_conformance.py            # prints the markdown table
    python benchmarks/bench_conformance.py --rows     # also every row outside tolerance

For every Stable32 table in ``../shared/reference/data/realdata/stable32`` the record is read,
the table's deviation is computed by :func:`gyrotest.noise.analysis.analyse_allan` (the code
path of ``gyrotest allan --dev KIND --taus ... --no-fit``, default ``--ci stable32``) at
Stable32's averaging factors, and compared: σ relative error (Stable32 prints 5 digits: ≤ 5e-5
when right), n, the identified α, and both interval bounds (≤ 1e-3 relative) where Stable32
printed an interval.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from gyrotest.core.data import GyroConstants, GyroLog, Timing  # noqa: E402
from gyrotest.noise.analysis import analyse_allan  # noqa: E402
from gyrotest.noise.realdata import load_rate_csv, read_stable32, stable32_table_kind  # noqa: E402

REAL = REPO.parent / "shared" / "reference" / "data" / "realdata"
#: tables made by Stable32 with α fixed (README of the shared folder): intervals not comparable
FIXED_ALPHA = ("cs5071a_totdev_all", "cs5071a_totdev_decade", "pink_totdev_alpha0")


def record_for(table: str) -> str:
    if table.startswith("pink_s32"):
        return "pink1"
    return {"gps": "gps", "cs5071a": "cs5071a", "tic": "tic", "pink": "pink42"}[
        table.split("_")[0]]


_cache: dict[str, tuple[np.ndarray, float]] = {}


def load(rec: str) -> tuple[np.ndarray, float]:
    if rec not in _cache:
        t, y = load_rate_csv(REAL / "data" / f"{rec}.csv.gz")
        _cache[rec] = (y, float(np.median(np.diff(t))))
    return _cache[rec]


def compare(path: Path) -> dict:
    """One table: worst errors, counts and the rows outside tolerance."""
    name = path.stem
    kind = stable32_table_kind(path)
    rows = read_stable32(path)
    y, tau0 = load(record_for(name))
    log = GyroLog(source=name, rates={"y": y}, tau0=tau0,
                  timing=Timing(n=y.size, tau0=tau0, duration_s=y.size * tau0, source="bench"),
                  gyro=GyroConstants(output_kind="rate"))
    a = analyse_allan(log, dev=kind, taus=[r.m * tau0 for r in rows], fit_model=False,
                      spectral=False, trend_check=False).axes[0]
    tab = a.table()
    out = {"table": name, "kind": kind, "rows": len(rows), "fixed_alpha": name in FIXED_ALPHA,
           "sig": 0.0, "lo": 0.0, "hi": 0.0, "ci_rows": 0, "n_bad": 0, "alpha_bad": [],
           "ci_bad": [], "sig_bad": []}
    for i, r in enumerate(rows):
        es = abs(float(tab["sigma"][i]) / r.sigma - 1.0)
        out["sig"] = max(out["sig"], es)
        if es > 5e-5:
            out["sig_bad"].append((r, float(tab["sigma"][i])))
        out["n_bad"] += int(tab["n"][i]) != r.n
        if int(tab["alpha"][i]) != r.alpha:
            out["alpha_bad"].append((r, int(tab["alpha"][i])))
        if r.lo > 0 and r.hi > 0 and not out["fixed_alpha"]:
            el = abs(float(tab["sigma_lo"][i]) / r.lo - 1.0)
            eh = abs(float(tab["sigma_hi"][i]) / r.hi - 1.0)
            if int(tab["alpha"][i]) == r.alpha:
                out["ci_rows"] += 1
                out["lo"], out["hi"] = max(out["lo"], el), max(out["hi"], eh)
            if max(el, eh) > 1e-3:
                out["ci_bad"].append((r, int(tab["alpha"][i]), float(tab["sigma_lo"][i]),
                                      float(tab["sigma_hi"][i])))
    return out


def tables() -> list[Path]:
    return sorted((REAL / "stable32").glob("*.txt"))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", action="store_true", help="print the rows outside tolerance")
    args = ap.parse_args()
    if not REAL.is_dir():
        sys.exit(f"shared real data not found at {REAL}")
    print("| table | kind | rows | max σ err | n equal | α equal | rows with CI (α equal) | "
          "max lo err | max hi err | CI rows > 1e-3 |")
    print("|---|---|---:|---:|---|---|---:|---:|---:|---:|")
    for p in tables():
        c = compare(p)
        ci = "fixed α (not compared)" if c["fixed_alpha"] else str(c["ci_rows"])
        alpha = "yes" if not c["alpha_bad"] else f"{len(c['alpha_bad'])} differ"
        print(f"| {c['table']} | {c['kind']} | {c['rows']} | {c['sig']:.1e} | "
              f"{'yes' if c['n_bad'] == 0 else c['n_bad']} | "
              f"{alpha} | "
              f"{ci} | {c['lo']:.1e} | {c['hi']:.1e} | {len(c['ci_bad'])} |")
        if args.rows:
            for r, al in c["alpha_bad"]:
                print(f"    α: m={r.m} n={r.n} Stable32 α={r.alpha} ours α={al}")
            for r, al, lo, hi in c["ci_bad"]:
                print(f"    CI: m={r.m} Stable32 α={r.alpha} [{r.lo:.5g}, {r.hi:.5g}] ours "
                      f"α={al} [{lo:.5g}, {hi:.5g}]")


if __name__ == "__main__":
    main()
