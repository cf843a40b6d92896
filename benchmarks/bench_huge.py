#!/usr/bin/env python3
"""Peak memory and time of ``gyrotest allan`` on one very long Parquet log (issue #13, target 4:
10⁹ samples on a 24 GB machine). Run once by hand, never in CI:

    python benchmarks/bench_huge.py --samples 1e8            # writes /tmp/.../huge.parquet
    python benchmarks/bench_huge.py --samples 1e7 --samples 1e8 --whole   # scaling; and the
        # same logs read whole (streaming off) in the same invocation, for the before/after
    python benchmarks/bench_huge.py --samples 1e9 --dir /data/huge   # keep/reuse the files

Method: a Parquet log (columns t_s, omega_dph; 100 Hz; white rate noise + rate random walk)
is written row group by row group (2²⁰ rows each, never the whole record in memory), then
``gyrotest allan FILE --rate-unit deg/h --json`` (OADEV 10/decade + noise fit + diagnosis)
runs in a fresh process; reported: wall and CPU time (getrusage of the child) and the child's
peak resident memory (``ru_maxrss``) over the float64 record size (8 bytes × samples).
Every log here is streamed into the integrated angle (``gyrotest/io/stream.py``; the runs set
``GYROTEST_STREAM_MIN_ROWS=1``, since by default only logs of ≥ 2²⁴ rows are);
``--whole`` also runs each log with streaming off, i.e. read whole. Check ``free -g`` first: 10⁹ samples need 8 GB streamed, ≈ 6× that read whole.
"""

from __future__ import annotations

import argparse
import math
import os
import resource
import subprocess
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
ROW_GROUP = 1 << 20


def write_parquet(path: str, n: int, tau0: float = 0.01, seed: int = 1) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    rng = np.random.default_rng(seed)
    schema = pa.schema([("t_s", pa.float64()), ("omega_dph", pa.float64())])
    walk = 0.0
    with pq.ParquetWriter(path, schema, compression="none") as w:
        for i0 in range(0, n, ROW_GROUP):
            k = min(ROW_GROUP, n - i0)
            t = (np.arange(i0, i0 + k) + 1) * tau0
            rw = walk + np.cumsum(rng.standard_normal(k)) * (0.05 / 60.0 * math.sqrt(tau0))
            walk = float(rw[-1])
            x = rng.standard_normal(k) * (0.6 / math.sqrt(tau0)) + rw + 0.35
            w.write_table(pa.table({"t_s": t, "omega_dph": x}, schema=schema))


def run_allan(path: str, whole: bool = False) -> dict:
    """One ``gyrotest allan`` process; its own peak RSS from ``/usr/bin/time -v`` when present
    (``ru_maxrss`` of RUSAGE_CHILDREN is the largest child so far)."""
    cmd = [sys.executable, "-c", "from gyrotest.cli import main; main()", "-q", "allan", path,
           "--rate-unit", "deg/h", "--json"]
    timer = os.path.exists("/usr/bin/time")
    if timer:
        cmd = ["/usr/bin/time", "-v", *cmd]
    env = dict(os.environ)
    env["GYROTEST_STREAM_MIN_ROWS"] = str(10**15) if whole else "1"
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    p = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                       cwd=ROOT, env=env)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode:
        sys.exit(p.stderr)
    rss = r1.ru_maxrss / 1024
    if timer:
        for line in p.stderr.splitlines():
            if "Maximum resident set size" in line:
                rss = int(line.split()[-1]) / 1024
    return {"wall": wall, "cpu": r1.ru_utime - r0.ru_utime + r1.ru_stime - r0.ru_stime,
            "maxrss_mb": rss}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--samples", type=float, action="append", default=None)
    ap.add_argument("--keep", action="store_true", help="keep the Parquet files")
    ap.add_argument("--dir", default=None, help="write the logs here and reuse existing ones "
                                                "(implies --keep)")
    ap.add_argument("--whole", action="store_true",
                    help="also run each log read whole (streaming off), right after")
    a = ap.parse_args()
    tmp = a.dir or tempfile.mkdtemp(prefix="bench_huge_")
    keep = a.keep or a.dir is not None
    for n in sorted(int(s) for s in (a.samples or [1e8])):
        path = os.path.join(tmp, f"huge_{n:.0e}.parquet")
        if not os.path.exists(path):
            t0 = time.perf_counter()
            write_parquet(path, n)
            print(f"{n:.3g} samples: wrote {os.path.getsize(path) / 1e9:.2f} GB in "
                  f"{time.perf_counter() - t0:.0f} s", flush=True)
        rec = n * 8 / 2**20
        for whole in ((False, True) if a.whole else (False,)):
            load = os.getloadavg()[0]
            r = run_allan(path, whole)
            print(f"  {n:.3g} samples, {'read whole' if whole else 'streamed  '}: "
                  f"{r['wall']:.1f} s wall, {r['cpu']:.1f} s CPU "
                  f"({1e6 * r['cpu'] / n:.3f} µs/sample), peak RSS {r['maxrss_mb']:.0f} MB = "
                  f"{r['maxrss_mb'] / rec:.2f}× the float64 record ({rec:.0f} MB); load "
                  f"{load:.1f}", flush=True)
        if not keep:
            os.remove(path)


if __name__ == "__main__":
    main()
