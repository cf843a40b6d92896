#!/usr/bin/env python3
"""Working set and time of the MTOTDEV and TOTDEV kernels per τ (issue #13, target 5:
"working set ≤ 1.2× the record on top of θ"). Run by hand, never in CI:

    python benchmarks/bench_mtot_memory.py                      # N = 1e6 and 1e7, a few m
    python benchmarks/bench_mtot_memory.py --n 1e6 --m 333333 --m 1000
    python benchmarks/bench_mtot_memory.py --impl /tmp/old_tree  # another checkout's gyrotest

Method: one fresh process per (kind, N, m). It builds θ (N float64 points: a random walk plus
white noise, i.e. white + random-walk rate noise integrated) and then calls the kernel that
``compute_deviation`` calls for one τ (``_mtot_sum`` for MTOTDEV, ``_tot_sumsq`` for TOTDEV)
after a warm-up call on a short record, timed (process CPU time), then once more with ``tracemalloc`` on (not timed: tracing slows
every allocation): numpy reports every array allocation to it, so the traced peak is the
kernel's working set on top of θ (θ itself is allocated before tracing starts). Also reported:
the growth of the resident-set high-water mark (``ru_maxrss``) over the timed call, as a
cross-check that counts what tracemalloc cannot see. The
ratio is peak / (8·N bytes), the record's float64 size. ``--impl DIR`` puts DIR first on the
path instead of this checkout (e.g. a ``git archive`` of the commit before the change), so
before and after run in one invocation.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)

CHILD = r"""
import json, resource, sys, time, tracemalloc
import numpy as np
from gyrotest.noise import devcore
from gyrotest.noise import deviations as dv
kind, n, m = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
rng = np.random.default_rng(5)
theta = np.cumsum(rng.standard_normal(n)) + 0.3 * rng.standard_normal(n)
# warm-up on a short record (first-call costs of numpy's einsum/cumsum paths are not per τ)
(devcore._mtot_sum if kind == "mtotdev" else devcore._tot_sumsq)(theta[:20000], 50)
fn = devcore._mtot_sum if kind == "mtotdev" else devcore._tot_sumsq
rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
t0 = time.process_time()
val = fn(theta, m)[0]
cpu = time.process_time() - t0
rss1 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
tracemalloc.start()  # second call, traced (tracemalloc slows every allocation: not timed)
fn(theta, m)
peak = tracemalloc.get_traced_memory()[1]
tracemalloc.stop()
print(json.dumps({"value": val, "cpu_s": cpu, "peak_bytes": peak,
                  "rss_growth_bytes": (rss1 - rss0) * 1024}))
"""


def run(impl: str, kind: str, n: int, m: int) -> dict:
    env = dict(os.environ, PYTHONPATH=impl, OPENBLAS_NUM_THREADS="1")
    # cwd = impl: ``python -c`` puts the working directory first on sys.path
    out = subprocess.run([sys.executable, "-c", CHILD, kind, str(n), str(m)], env=env, cwd=impl,
                         capture_output=True, text=True, check=True)
    return json.loads(out.stdout)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", action="append", type=float, help="record length (repeatable)")
    ap.add_argument("--m", action="append", type=int,
                    help="averaging factor (repeatable; default: N//3, N//3 − 7, N//4, N//12, N//30, "
                         "N//300, 1000)")
    ap.add_argument("--kind", action="append", choices=("mtotdev", "totdev"))
    ap.add_argument("--impl", action="append",
                    help="directory put first on PYTHONPATH (repeatable; default: this checkout)")
    a = ap.parse_args()
    impls = a.impl or [ROOT]
    for kind in a.kind or ["mtotdev", "totdev"]:
        for nf in a.n or [1e6, 1e7]:
            n = int(nf)
            ms = a.m or [(n - 1) // 3, (n - 1) // 3 - 7, n // 4, n // 12, n // 30, n // 300, 1000]
            for m in ms:
                vals = []
                for impl in impls:
                    r = run(impl, kind, n, m)
                    vals.append(r["value"])
                    print(f"{kind:8s} N={n:>9d} m={m:>8d} {os.path.basename(impl.rstrip('/')):>10s}: "
                          f"CPU {r['cpu_s']:7.2f} s, peak {r['peak_bytes'] / 2**20:8.1f} MB = "
                          f"{r['peak_bytes'] / (8.0 * n):5.2f}x the record "
                          f"(RSS growth {r['rss_growth_bytes'] / 2**20:7.1f} MB)", flush=True)
                if len(vals) > 1:
                    rel = max(abs(v - vals[0]) for v in vals) / abs(vals[0])
                    print(f"    same value across implementations to {rel:.1e}", flush=True)


if __name__ == "__main__":
    main()
