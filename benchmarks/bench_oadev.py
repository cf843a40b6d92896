#!/usr/bin/env python3
"""Benchmark: gyrotest OADEV (and TOTDEV/MTOTDEV) against AllanTools.

Not part of the test suite. Run from the repository root:

    python benchmarks/bench_oadev.py                 # 10^7 samples, octave + decade10 grids
    python benchmarks/bench_oadev.py --big           # also 10^8 samples (needs ~6 GB for AllanTools)
    python benchmarks/bench_oadev.py --sweep-chunks  # chunk-size sweep of the OADEV kernel
    python benchmarks/bench_oadev.py --only-tot      # TOTDEV/MTOTDEV scaling only
    python benchmarks/bench_oadev.py --sizes 1e8 --repeat 2   # OADEV at the given sizes only

Method
------
Every measurement runs in a fresh subprocess (``--child``), so one run's allocations and
caches cannot leak into the next. The child creates the input (white rate noise, float64), then

* time: best of ``--repeat`` runs, wall clock (``time.perf_counter``) and process CPU time
  (``time.process_time``, less sensitive to other jobs competing for the cores), measured
  **without** tracemalloc (it traces every Python object, which slows gyrotest's chunk loop);
* memory: a separate child runs the same call once under ``tracemalloc`` and reports the peak
  of traced allocations (numpy reports its buffers to tracemalloc), i.e. the peak *extra*
  memory on top of the input array, which was allocated before tracing started. It also
  reports the ``ru_maxrss`` high-water mark minus its value right after the input was built
  (a cross-check that includes allocator slack; Linux reports it in KiB).

Both tools get the same τ list: gyrotest builds it (Stable32 stop ratio 4 for OADEV) and
AllanTools receives it as ``taus=`` with ``data_type="freq"``, ``rate = 1/τ0``. gyrotest is
timed with noise identification off (σ + Greenhall EDF + χ² interval, α assumed 0: the same
statistic AllanTools returns, plus the CIs) and, separately, with noise identification on.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
TAU0 = 0.01  # 100 Hz


def _maxrss_bytes() -> int:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


def child(args) -> dict:
    """Run one measurement; print a JSON line."""
    sys.path.insert(0, str(REPO))
    import numpy as np

    from gyrotest.noise import deviations as dv

    if args.chunk:
        from gyrotest.core import angle
        from gyrotest.noise import devcore

        angle.CHUNK = devcore.CHUNK = args.chunk
    n = int(args.n)
    y = np.random.default_rng(1).standard_normal(n)
    kind = args.kind
    grid = dv.tau_grid(args.grid, n_data=n, tau0=TAU0, kind=kind)
    taus = grid.tau

    if args.impl == "gyrotest":
        def run():
            return dv.compute_deviation(y, TAU0, input_kind="rate", kind=kind, taus=taus, noise_id=False)
    elif args.impl == "gyrotest+id":
        def run():
            return dv.compute_deviation(y, TAU0, input_kind="rate", kind=kind, taus=taus, noise_id=True)
    elif args.impl == "allantools":
        import allantools

        fn = getattr(allantools, kind)

        def run():
            return fn(y, rate=1.0 / TAU0, data_type="freq", taus=taus)
    else:
        raise SystemExit(f"unknown impl {args.impl}")

    out = {"impl": args.impl, "kind": kind, "n": n, "grid": args.grid, "n_tau": int(len(taus)),
           "input_bytes": int(y.nbytes)}
    if args.mode == "time":
        best = best_cpu = float("inf")
        for _ in range(args.repeat):
            t = time.perf_counter()
            c = time.process_time()
            run()
            best_cpu = min(best_cpu, time.process_time() - c)
            best = min(best, time.perf_counter() - t)
        out["seconds"] = best
        out["cpu_seconds"] = best_cpu
    else:
        import tracemalloc

        rss0 = _maxrss_bytes()
        tracemalloc.start()
        run()
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        out["peak_traced_bytes"] = int(peak)
        out["maxrss_delta_bytes"] = int(_maxrss_bytes() - rss0)
    print(json.dumps(out), flush=True)
    return out


def spawn(impl: str, n: float, grid: str, mode: str, kind: str = "oadev", repeat: int = 3,
          chunk: int = 0) -> dict:
    cmd = [sys.executable, __file__, "--child", "--impl", impl, "--n", str(int(n)), "--grid", grid,
           "--mode", mode, "--kind", kind, "--repeat", str(repeat), "--chunk", str(chunk)]
    env = dict(os.environ)
    res = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=REPO)
    if res.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed:\n{res.stderr[-2000:]}")
    return json.loads(res.stdout.strip().splitlines()[-1])


def bench_oadev(sizes, grids, repeat):
    print(f"\nOADEV, white rate noise, tau0 = {TAU0} s, best of {repeat} (time) / one traced run (memory)")
    print(f"{'N':>10} {'grid':>9} {'#tau':>5} | {'AllanTools s':>12} {'gyrotest s':>10} {'ratio':>6} "
          f"{'cpu ratio':>9} {'+noise ID s':>11} | peak extra / input (tracemalloc; maxrss)")
    rows = []
    for n in sizes:
        for grid in grids:
            t_at = spawn("allantools", n, grid, "time", repeat=repeat)
            t_gt = spawn("gyrotest", n, grid, "time", repeat=repeat)
            t_id = spawn("gyrotest+id", n, grid, "time", repeat=repeat)
            m_at = spawn("allantools", n, grid, "mem")
            m_gt = spawn("gyrotest", n, grid, "mem")
            m_id = spawn("gyrotest+id", n, grid, "mem")
            inp = t_gt["input_bytes"]
            ratio = t_at["seconds"] / t_gt["seconds"]
            cpu_ratio = t_at["cpu_seconds"] / t_gt["cpu_seconds"]
            mem = (f"AT {m_at['peak_traced_bytes'] / inp:4.2f}x; {m_at['maxrss_delta_bytes'] / inp:4.2f}x  "
                   f"gt {m_gt['peak_traced_bytes'] / inp:4.2f}x; {m_gt['maxrss_delta_bytes'] / inp:4.2f}x  "
                   f"gt+id {m_id['peak_traced_bytes'] / inp:4.2f}x")
            print(f"{int(n):>10} {grid:>9} {t_gt['n_tau']:>5} | {t_at['seconds']:>12.3f} "
                  f"{t_gt['seconds']:>10.3f} {ratio:>5.1f}x {cpu_ratio:>8.1f}x {t_id['seconds']:>11.3f} "
                  f"| {mem}", flush=True)
            rows.append(dict(n=int(n), grid=grid, allantools=t_at, gyrotest=t_gt, gyrotest_id=t_id,
                             mem_allantools=m_at, mem_gyrotest=m_gt, mem_gyrotest_id=m_id))
    return rows


def bench_tot(repeat):
    print("\nTOTDEV and MTOTDEV, octave tau, gyrotest (noise ID off): time vs N (O(N) per tau)")
    print(f"{'kind':>8} {'N':>9} {'#tau':>5} {'wall s':>8} {'cpu s':>7} {'cpu s per tau per 1e6 samples':>31}")
    for kind in ("totdev", "mtotdev"):
        for n in (2.5e5, 5e5, 1e6):
            r = spawn("gyrotest", n, "octave", "time", kind=kind, repeat=1 if kind == "mtotdev" else repeat)
            print(f"{kind:>8} {int(n):>9} {r['n_tau']:>5} {r['seconds']:>8.2f} {r['cpu_seconds']:>7.2f} "
                  f"{r['cpu_seconds'] / r['n_tau'] / (n / 1e6):>31.3f}", flush=True)
    r = spawn("allantools", 1e6, "octave", "time", kind="totdev", repeat=repeat)
    print(f"AllanTools totdev 1e6 octave: {r['seconds']:.2f} s ({r['n_tau']} tau)")
    r = spawn("allantools", 2000, "octave", "time", kind="mtotdev", repeat=1)
    g = spawn("gyrotest", 2000, "octave", "time", kind="mtotdev", repeat=repeat)
    print(f"mtotdev N = 2000 octave ({r['n_tau']} tau): AllanTools {r['seconds']:.2f} s, "
          f"gyrotest {g['seconds']:.3f} s")


def sweep_chunks(n, repeat):
    print(f"\nOADEV kernel chunk sweep, N = {int(n)}, octave (gyrotest, noise ID off)")
    for chunk in (1 << 12, 1 << 13, 1 << 14, 1 << 15, 1 << 16, 1 << 17, 1 << 18):
        r = spawn("gyrotest", n, "octave", "time", repeat=repeat, chunk=chunk)
        print(f"  chunk {chunk:>7}: wall {r['seconds']:.3f} s, cpu {r['cpu_seconds']:.3f} s", flush=True)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--impl", default="gyrotest")
    ap.add_argument("--n", default="10000000")
    ap.add_argument("--grid", default="octave")
    ap.add_argument("--mode", default="time", choices=("time", "mem"))
    ap.add_argument("--kind", default="oadev")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--chunk", type=int, default=0)
    ap.add_argument("--big", action="store_true", help="also run 10^8 samples")
    ap.add_argument("--sizes", default="", help="comma-separated N list for OADEV, e.g. 1e8")
    ap.add_argument("--sweep-chunks", action="store_true")
    ap.add_argument("--only-tot", action="store_true")
    args = ap.parse_args(argv)
    if args.child:
        child(args)
        return
    print(f"python {sys.version.split()[0]}, {os.cpu_count()} CPUs, load average "
          f"{', '.join(f'{v:.1f}' for v in os.getloadavg())}")
    if args.sweep_chunks:
        sweep_chunks(1e7, args.repeat)
        return
    if not args.only_tot:
        if args.sizes:
            sizes = [float(v) for v in args.sizes.split(",")]
        else:
            sizes = [1e7] + ([1e8] if args.big else [])
        bench_oadev(sizes, ["octave", "decade10"], args.repeat)
        if args.sizes:
            return
    bench_tot(args.repeat)


if __name__ == "__main__":
    main()
