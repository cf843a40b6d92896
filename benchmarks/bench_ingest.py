"""Ingest benchmark: a 10⁷-row, 4-column CSV to float64 arrays and Parquet, vs pandas.

Measures in one run (ratios, not absolute times — machines are noisy):

* ``pandas.read_csv`` (default C engine) of the CSV to a float64 array — the baseline;
* gyrotest's ingest (``read_log``: sniff, parse of the used columns — the numba fast path
  of ``gyrotest.fastcsv`` for big numeric files — units, timing analysis) plus writing
  Parquet with metadata; and the same with the fast path off (the pyarrow reader);
* re-reading that Parquet with ``read_log``;
* parse only, to float64 arrays: ``fastcsv.read_numeric`` (numba import and kernel load
  included) and ``pyarrow.csv.read_csv`` (multithreaded), against the pandas figure;
* the fast path's one-off JIT cost: compiling the kernels into an empty numba cache, and
  loading them from the cache (each with the numba import), in fresh processes.

Each measurement runs in a fresh subprocess so that its peak memory (the peak resident size
during the measurement, reset at its start, minus the resident size then; ru_maxrss minus its
value after the imports where /proc is missing) is its own; memory is reported relative to the size of
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
import json, os, resource, sys, time
import numpy as np
mode, path, out = sys.argv[1], sys.argv[2], sys.argv[3]
if mode == "gyrotest-arrow":
    os.environ["GYROTEST_FASTCSV"] = "0"
    mode = "gyrotest"
import pandas as pd
import pyarrow
import pyarrow.csv
from gyrotest.ingest import read_log, write_log


def rss_kb(field):  # Linux: current (VmRSS) or peak (VmHWM) resident size
    with open("/proc/self/status") as fh:
        return int(fh.read().split(field + ":")[1].split()[0])


try:  # reset the peak to the current size, so the peak below is this measurement's own
    with open("/proc/self/clear_refs", "w") as fh:
        fh.write("5")
    base = rss_kb("VmRSS")
    peak_kb = lambda: rss_kb("VmHWM")
except OSError:
    base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    peak_kb = lambda: resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
t0 = time.perf_counter()
if mode == "pandas":
    df = pd.read_csv(path)
    arr = df.to_numpy(dtype=np.float64)
    n = arr.shape[0]
elif mode == "fastparse":
    from gyrotest import fastcsv
    res = fastcsv.read_numeric(path, ",", 0, ["t_s", "rate_dph", "T_case_C", "vsupply"])
    n = res[1].shape[1]
elif mode == "arrowparse":
    tab = pyarrow.csv.read_csv(path, read_options=pyarrow.csv.ReadOptions(use_threads=True))
    cols = [tab.column(c).to_numpy().astype(np.float64, copy=False) for c in tab.column_names]
    n = len(cols[0])
elif mode == "jit":
    t1 = time.perf_counter()
    import numba
    t_import = time.perf_counter() - t1
    from gyrotest import fastcsv
    res = fastcsv.read_numeric(path, ",", 0, ["a", "b"])
    n = res[1].shape[1]
elif mode == "gyrotest":
    log = read_log(path, overrides={"columns": {"time": "t_s", "rate": ["rate_dph"],
                   "temperature": ["T_case_C"], "supply": "vsupply"}, "gyro": {"rate_unit": "deg/h"}})
    write_log(log, out)
    n = log.n
elif mode == "parquet":
    log = read_log(out)
    n = log.n
dt = time.perf_counter() - t0
peak = peak_kb()
print(json.dumps({"mode": mode, "seconds": dt, "rows": n, "peak_extra_bytes": (peak - base) * 1024,
                  "import_seconds": t_import if mode == "jit" else None}))
"""


def run_child(mode: str, csv: str, out: str, env: dict | None = None) -> dict:
    r = subprocess.run([sys.executable, "-c", CHILD, mode, csv, out], capture_output=True,
                       text=True, check=True, env=None if env is None else {**os.environ, **env})
    return json.loads(r.stdout.strip().splitlines()[-1])


def jit_cost(d: str) -> tuple[dict, dict]:
    """First use of the fast path in fresh processes: compile into an empty numba cache, then
    load from it."""
    small = os.path.join(d, "small.csv")
    with open(small, "w") as fh:
        fh.write("a,b\n1.5,2\n-0.25,3e-5\n")
    env = {"NUMBA_CACHE_DIR": os.path.join(d, "numba_cache")}
    return run_child("jit", small, "", env), run_child("jit", small, "", env)


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
        modes = ("pandas", "gyrotest", "parquet", "fastparse", "arrowparse", "gyrotest-arrow")
        for mode in modes:
            best = None
            for _ in range(args.repeat):
                r = run_child(mode, csv, out)
                if best is None or r["seconds"] < best["seconds"]:
                    best = r
            res[mode] = best
        array_bytes = rows * 4 * 8
        pd_s, gt_s, pq_s = (res[m]["seconds"] for m in ("pandas", "gyrotest", "parquet"))
        fp_s, ap_s, old_s = (res[m]["seconds"] for m in ("fastparse", "arrowparse",
                                                          "gyrotest-arrow"))
        cold, warm = jit_cost(d)
        print(f"\nrows: {rows:,}; float64 array: {array_bytes / 1e6:.0f} MB; parquet "
              f"{os.path.getsize(out) / 1e6:.0f} MB")
        print(f"{'measurement':40s} {'time, s':>9s} {'peak extra / array':>20s}")
        for mode, label in (("pandas", "pandas.read_csv (C engine) -> float64"),
                            ("gyrotest", "gyrotest ingest CSV -> arrays + Parquet"),
                            ("parquet", "gyrotest re-read Parquet"),
                            ("gyrotest-arrow", "  same ingest, fast path off (pyarrow)"),
                            ("fastparse", "  parse only: fastcsv -> float64"),
                            ("arrowparse", "  parse only: pyarrow.csv -> float64")):
            r = res[mode]
            print(f"{label:40s} {r['seconds']:9.2f} {r['peak_extra_bytes'] / array_bytes:20.2f}")
        print(f"\nspeed-up of ingest (incl. Parquet write) over pandas.read_csv: {pd_s / gt_s:.2f}x "
              "(target >= 3x)")
        print(f"Parquet re-read vs gyrotest CSV read: {gt_s / pq_s:.1f}x faster; vs pandas "
              f"{pd_s / pq_s:.1f}x (target >= 20x)")
        print(f"fast path vs pyarrow path, whole ingest: {old_s / gt_s:.2f}x faster")
        print(f"parse only: fastcsv {pd_s / fp_s:.2f}x faster than pandas, "
              f"{ap_s / fp_s:.2f}x faster than pyarrow.csv")
        print(f"fast path first-call JIT (fresh process, numba import included): compile "
              f"{cold['seconds']:.1f} s (empty cache), load {warm['seconds']:.2f} s (cached; "
              f"numba import {warm['import_seconds']:.2f} s)")


if __name__ == "__main__":
    main()
