#!/usr/bin/env python3
"""Whole-process speed of ``gyrotest`` against the pandas + AllanTools script (issue #13).

Not part of the test suite. Run from the repository root:

    python benchmarks/bench_speed.py --startup            # --help, info, allan on 1.2·10^4 rows
    python benchmarks/bench_speed.py --big --rows 1e7     # allan on a 10^7-row CSV, Parquet path
    python benchmarks/bench_speed.py --startup --big --pairs 7

Method
------
Every measurement is a fresh subprocess. The machine is shared, so absolute times are noisy:
gyrotest and the peer script run **alternately** (paired, interleaved, ``--pairs`` pairs, one
warm-up pair discarded) and the table shows medians of wall time and of CPU time
(``resource.getrusage(RUSAGE_CHILDREN)`` user + system, per child) and the median of the
per-pair ratios peer / gyrotest (> 1: gyrotest is faster).

The peer ("the script a lab would write"):

    import pandas as pd, allantools
    df = pd.read_csv(path)
    allantools.oadev(df[col].to_numpy(), rate=1/tau0, data_type="freq", taus="octave")

gyrotest runs as the installed console script does (``from gyrotest.cli import main; main()``,
stdout to a file, its modules byte-compiled first as ``pip install`` does): ``allan FILE --rate-unit deg/h`` prints everything the command prints (deviation table
with CIs, fit, diagnosis, warnings, impact); ``--json`` the same as JSON.
"""

from __future__ import annotations

import argparse
import compileall
import math
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)

PEER = r"""
import sys
import pandas as pd, allantools
path = sys.argv[1]
df = pd.read_csv(path)
x = df["omega_dph"].to_numpy(dtype=float)
tau0 = float(df["t_s"].iloc[1] - df["t_s"].iloc[0])
t, dev, err, n = allantools.oadev(x, rate=1.0 / tau0, data_type="freq", taus="octave")
for a, b in zip(t, dev):
    print(f"{a:g} {b:.6g}")
"""

GY = [sys.executable, "-c", "from gyrotest.cli import main; main()"]  # = the console script


def run(cmd: list[str], out=subprocess.DEVNULL, env=None, cwd=ROOT) -> tuple[float, float]:
    """(wall s, CPU s) of one child process."""
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    p = subprocess.run(cmd, stdout=out, stderr=subprocess.PIPE, text=True, cwd=cwd, env=env)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode != 0:
        sys.exit(f"failed ({p.returncode}): {' '.join(cmd)}\n{p.stderr}")
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    return wall, cpu


def write_csv(path: str, rows: int, tau0: float = 0.01, seed: int = 1) -> None:
    """t_s, omega_dph at 100 Hz: white rate noise + rate random walk + bias (as bench_allan)."""
    import pyarrow as pa
    import pyarrow.csv as pacsv

    rng = np.random.default_rng(seed)
    n_int, k_int = 0.6, 0.05 / 60.0
    x = rng.standard_normal(rows) * (n_int / math.sqrt(tau0))
    x += np.cumsum(rng.standard_normal(rows)) * (k_int * math.sqrt(tau0)) + 0.35
    t = np.arange(1, rows + 1) * tau0
    pacsv.write_csv(pa.table({"t_s": t, "omega_dph": x}), path)


def paired(label_a: str, cmd_a: list[str], label_b: str, cmd_b: list[str], pairs: int,
           out_a=None, cwd_b=ROOT, env_b=None) -> dict:
    """Alternate a and b ``pairs`` times (+1 discarded warm-up pair); medians and ratio b/a."""
    res: dict[str, list] = {"a": [], "b": []}
    for i in range(pairs + 1):
        wa = run(cmd_a, out=open(out_a, "w") if out_a else subprocess.DEVNULL)
        wb = run(cmd_b, cwd=cwd_b, env=env_b)
        if i:
            res["a"].append(wa)
            res["b"].append(wb)
    med = {k: (statistics.median(w for w, _ in v), statistics.median(c for _, c in v))
           for k, v in res.items()}
    r_wall = statistics.median(b[0] / a[0] for a, b in zip(res["a"], res["b"]))
    r_cpu = statistics.median(b[1] / a[1] for a, b in zip(res["a"], res["b"]))
    print(f"  {label_a:<44} {med['a'][0]:7.2f} s wall {med['a'][1]:7.2f} s CPU")
    print(f"  {label_b:<44} {med['b'][0]:7.2f} s wall {med['b'][1]:7.2f} s CPU")
    print(f"  {'ratio ' + label_b.split()[0] + ' / ' + label_a.split()[0]:<44} "
          f"{r_wall:7.2f}× wall {r_cpu:7.2f}× CPU   (median of {pairs} pairs; load now "
          f"{os.getloadavg()[0]:.1f})")
    return {"a": med["a"], "b": med["b"], "ratio_wall": r_wall, "ratio_cpu": r_cpu}


def solo(label: str, cmd: list[str], n: int) -> tuple[float, float]:
    ws = [run(cmd) for _ in range(n + 1)][1:]
    w = statistics.median(x for x, _ in ws)
    c = statistics.median(x for _, x in ws)
    print(f"  {label:<44} {w:7.2f} s wall {c:7.2f} s CPU   (median of {n})")
    return w, c


def startup(pairs: int, tmp: str, before: str | None = None) -> None:
    small = os.path.join(tmp, "small.csv")
    write_csv(small, 12_000)
    print(f"start-up ({os.path.getsize(small) / 1e3:.0f} kB, 12 000 rows; load "
          f"{os.getloadavg()[0]:.1f})")
    solo("gyrotest --help", [*GY, "--help"], pairs)
    solo("gyrotest info small.csv", [*GY, "info", small, "--rate-unit", "deg/h"], pairs)
    paired("gyrotest allan small.csv", [*GY, "allan", small, "--rate-unit", "deg/h"],
           "peer pandas.read_csv + allantools.oadev", [sys.executable, "-c", PEER, small], pairs,
           out_a=os.path.join(tmp, "out.txt"))
    if before:  # another checkout (e.g. ``git archive`` of an older commit), paired with this one
        compileall.compile_dir(os.path.join(before, "gyrotest"), quiet=1)
        env = dict(os.environ, PYTHONPATH=before)
        paired("gyrotest allan small.csv", [*GY, "allan", small, "--rate-unit", "deg/h"],
               "before: gyrotest allan small.csv", [*GY, "allan", small, "--rate-unit", "deg/h"],
               pairs, cwd_b=before, env_b=env)


def big(rows: int, pairs: int, tmp: str, before: str | None = None) -> None:
    path = os.path.join(tmp, "big.csv")
    write_csv(path, rows)
    pq = os.path.join(tmp, "big.parquet")
    run([*GY, "-q", "ingest", path, "--rate-unit", "deg/h", "-o", pq])
    print(f"\nend to end, {rows:.3g} rows ({os.path.getsize(path) / 1e6:.0f} MB CSV; load "
          f"{os.getloadavg()[0]:.1f})")
    out = os.path.join(tmp, "out.txt")
    paired("gyrotest allan big.csv", [*GY, "allan", path, "--rate-unit", "deg/h"],
           "peer pandas.read_csv + allantools.oadev", [sys.executable, "-c", PEER, path], pairs,
           out_a=out)
    paired("gyrotest allan big.csv --json", [*GY, "allan", path, "--rate-unit", "deg/h",
                                             "--json"],
           "peer pandas.read_csv + allantools.oadev", [sys.executable, "-c", PEER, path], pairs,
           out_a=out)
    paired("gyrotest allan big.parquet", [*GY, "allan", pq], "gyrotest allan big.csv",
           [*GY, "allan", path, "--rate-unit", "deg/h"], pairs, out_a=out)
    if before:  # this checkout against another one, paired, on the same CSV
        compileall.compile_dir(os.path.join(before, "gyrotest"), quiet=1)
        env = dict(os.environ, PYTHONPATH=before)
        cmd = [*GY, "allan", path, "--rate-unit", "deg/h", "--json"]
        paired("gyrotest allan big.csv --json", cmd, "before: gyrotest allan big.csv --json", cmd,
               pairs, out_a=out, cwd_b=before, env_b=env)
    parse_stage(path, pq, pairs)


PARSE = r"""
import json, resource, sys, time
import pyarrow.csv, pyarrow.parquet  # imported before the clock starts: the stage only
from gyrotest.io.ingest import read_log
r0, t0 = resource.getrusage(resource.RUSAGE_SELF), time.perf_counter()
log = read_log(sys.argv[1], overrides={"gyro": {"rate_unit": "deg/h"}})
r1 = resource.getrusage(resource.RUSAGE_SELF)
print(json.dumps({"wall": time.perf_counter() - t0, "user": r1.ru_utime - r0.ru_utime,
                  "sys": r1.ru_stime - r0.ru_stime, "n": log.n}))
"""


def parse_stage(csv_path: str, pq_path: str, pairs: int) -> dict:
    """read_log of the CSV vs of its Parquet conversion, fresh processes, alternating; the
    clock runs around read_log only (imports done before)."""
    import json

    ts: dict[str, list[dict]] = {"csv": [], "parquet": []}
    for i in range(pairs + 1):
        for k, p in (("csv", csv_path), ("parquet", pq_path)):
            r = subprocess.run([sys.executable, "-c", PARSE, p], capture_output=True, text=True,
                               cwd=ROOT, check=True)
            if i:
                ts[k].append(json.loads(r.stdout))
    med = {k: {q: statistics.median(d[q] for d in v) for q in ("wall", "user", "sys")}
           for k, v in ts.items()}
    ratio = {q: statistics.median(c[q] / max(p[q], 1e-3) for c, p in zip(ts["csv"],
                                                                          ts["parquet"]))
             for q in ("wall", "user")}
    ratio_cpu = statistics.median((c["user"] + c["sys"]) / max(p["user"] + p["sys"], 1e-3)
                                  for c, p in zip(ts["csv"], ts["parquet"]))
    for k in ("csv", "parquet"):
        m = med[k]
        print(f"  parse stage read_log({k:<7}) {m['wall']:7.3f} s wall {m['user']:6.3f} s user "
              f"{m['sys']:6.3f} s sys")
    print(f"  {'ratio CSV / Parquet':<44} {ratio['wall']:7.1f}× wall {ratio['user']:7.1f}× user "
          f"{ratio_cpu:5.1f}× CPU (user+sys)   (median of {pairs} pairs)")
    return {"median": med, "ratio": ratio, "ratio_cpu": ratio_cpu}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--startup", action="store_true")
    ap.add_argument("--big", action="store_true")
    ap.add_argument("--parse", action="store_true", help="only the CSV vs Parquet parse stage")
    ap.add_argument("--rows", type=float, default=1e7)
    ap.add_argument("--pairs", type=int, default=5)
    ap.add_argument("--before", metavar="DIR",
                    help="also pair `allan small.csv` (--startup) and `allan big.csv --json` "
                         "(--big) against the gyrotest in DIR (e.g. a `git archive` of an older "
                         "commit)")
    a = ap.parse_args()
    if not (a.startup or a.big or a.parse):
        a.startup = a.big = True
    tmp = tempfile.mkdtemp(prefix="bench_speed_")
    # byte-compile this checkout, as ``pip install`` does: the peer's modules in site-packages
    # have their .pyc, and with PYTHONDONTWRITEBYTECODE set (as on the reference VM) a source
    # checkout would otherwise recompile every gyrotest module in every run
    compileall.compile_dir(os.path.join(ROOT, "gyrotest"), quiet=1)
    try:
        if a.startup:
            startup(a.pairs, tmp, a.before)
        if a.big:
            big(int(a.rows), a.pairs, tmp, a.before)
        elif a.parse:
            path, pq = os.path.join(tmp, "big.csv"), os.path.join(tmp, "big.parquet")
            write_csv(path, int(a.rows))
            run([*GY, "-q", "ingest", path, "--rate-unit", "deg/h", "-o", pq])
            print(f"\nparse stage, {a.rows:.3g} rows ({os.path.getsize(path) / 1e6:.0f} MB CSV, "
                  f"{os.path.getsize(pq) / 1e6:.0f} MB Parquet; load {os.getloadavg()[0]:.1f})")
            parse_stage(path, pq, a.pairs)
    finally:  # the logs are hundreds of MB: never leave them in /tmp
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
