"""Ingest benchmark: a 10⁷-row, 4-column CSV to float64 arrays and Parquet, vs pandas.

Measures in one run (ratios, not absolute times — machines are noisy):

* ``pandas.read_csv`` (default C engine) of the CSV to a float64 array — the baseline;
* gyrotest's ingest (``read_log``: sniff, pyarrow's multithreaded streaming parse of the used
  columns straight into float64 arrays, units, timing analysis) plus writing Parquet with
  metadata;
* re-reading that Parquet with ``read_log``.

Each measurement runs in a fresh subprocess so that its peak memory (ru_maxrss minus the
interpreter's baseline after imports) is its own; memory is reported relative to the size of
the float64 array (rows × 4 × 8 bytes). Targets (issue #2): ingest ≥ 3× faster than pandas,
Parquet re-read ≥ 20× faster than the CSV read, peak memory ≤ 3× the array.

Usage::

    python benchmarks/bench_ingest.py            # 10⁷ rows
    python benchmarks/bench_ingest.py --rows 2e6 # quicker
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

CHILD = r"""
import json, resource, sys, time
import numpy as np
mode, path, out = sys.argv[1], sys.argv[2], sys.argv[3]
import pandas as pd
import pyarrow
from gyrotest.io.ingest import read_log, write_log
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
t0 = time.perf_counter()
if mode == "pandas":
    df = pd.read_csv(path)
    arr = df.to_numpy(dtype=np.float64)
    n = arr.shape[0]
elif mode == "gyrotest":
    log = read_log(path, overrides={"columns": {"time": "t_s", "rate": ["rate_dph"],
                   "temperature": ["T_case_C"], "supply": "vsupply"}, "gyro": {"rate_unit": "deg/h"}})
    write_log(log, out)
    n = log.n
elif mode == "read":
    log = read_log(path, overrides={"columns": {"time": "t_s", "rate": ["rate_dph"],
                   "temperature": ["T_case_C"], "supply": "vsupply"}, "gyro": {"rate_unit": "deg/h"}})
    n = log.n
elif mode == "parquet":
    log = read_log(out)
    n = log.n
dt = time.perf_counter() - t0
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps({"mode": mode, "seconds": dt, "rows": n, "peak_extra_bytes": (peak - base) * 1024}))
"""


def run_child(mode: str, csv: str, out: str) -> dict:
    r = subprocess.run([sys.executable, "-c", CHILD, mode, csv, out], capture_output=True,
                       text=True, check=True)
    return json.loads(r.stdout.strip().splitlines()[-1])


def make_csv(path: str, rows: int) -> None:
    import numpy as np
    import pyarrow as pa
    import pyarrow.csv as pcsv

    rng = np.random.default_rng(0)
    table = pa.table({
        "t_s": np.arange(rows) * 0.01,
        "rate_dph": 1.5 + rng.normal(scale=0.3, size=rows),
        "T_case_C": 25 + np.cumsum(rng.normal(scale=1e-3, size=rows)),
        "vsupply": 15 + rng.normal(scale=0.01, size=rows),
    })
    pcsv.write_csv(table, path)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", type=float, default=1e7)
    ap.add_argument("--repeat", type=int, default=2, help="best of N runs per measurement")
    args = ap.parse_args()
    rows = int(args.rows)
    with tempfile.TemporaryDirectory() as d:
        csv = os.path.join(d, "bench.csv")
        out = os.path.join(d, "bench.parquet")
        t0 = time.perf_counter()
        make_csv(csv, rows)
        print(f"made {rows:,}-row CSV ({os.path.getsize(csv) / 1e6:.0f} MB) in "
              f"{time.perf_counter() - t0:.1f} s")
        res = {}
        for mode in ("pandas", "read", "gyrotest", "parquet"):
            best = None
            for _ in range(args.repeat):
                r = run_child(mode, csv, out)
                if best is None or r["seconds"] < best["seconds"]:
                    best = r
            res[mode] = best
        array_bytes = rows * 4 * 8
        pd_s, rd_s, gt_s, pq_s = (res[m]["seconds"] for m in ("pandas", "read", "gyrotest", "parquet"))
        print(f"\nrows: {rows:,}; float64 array: {array_bytes / 1e6:.0f} MB; parquet "
              f"{os.path.getsize(out) / 1e6:.0f} MB")
        print(f"{'measurement':40s} {'time, s':>9s} {'peak extra / array':>20s}")
        for mode, label in (("pandas", "pandas.read_csv (C engine) -> float64"),
                            ("read", "gyrotest read CSV -> float64 arrays"),
                            ("gyrotest", "gyrotest ingest CSV -> arrays + Parquet"),
                            ("parquet", "gyrotest re-read Parquet")):
            r = res[mode]
            print(f"{label:40s} {r['seconds']:9.2f} {r['peak_extra_bytes'] / array_bytes:20.2f}")
        print(f"\nspeed-up of the CSV read over pandas.read_csv: {pd_s / rd_s:.2f}x; of read + "
              f"Parquet write: {pd_s / gt_s:.2f}x (target >= 3x)")
        print(f"Parquet re-read vs gyrotest CSV read: {gt_s / pq_s:.1f}x faster; vs pandas "
              f"{pd_s / pq_s:.1f}x (target >= 20x)")


if __name__ == "__main__":
    main()
