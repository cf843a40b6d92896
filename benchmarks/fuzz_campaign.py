"""Random bad-input campaigns (issues 15 and 62): many generated inputs through the CLI
in-process; counts exit codes and keeps every case that exits 1, prints a traceback, hangs,
changes an input or leaves a file behind.

Default (issue 15): random text tables (names, tokens, delimiters, BOM, comments, spliced
bytes) and byte-level mutations of a good small log (flip, delete, duplicate, insert), each
with random ingest options, through ``gyrotest info`` (every 10th case also ``ingest -o``).
Failing inputs are written to ``--keep DIR`` for the regression corpus (tests/data/bad/).

``--families`` (issue 62): the damaged-input families of ``tests/fuzzcases.py`` through every
command — value families of a log column (all-zero, constant, tiny, huge, overflow codes,
mixed extremes, NaN/inf, one column in two roles), damaged profiles, campaigns, scenarios,
model and history files and set-point tables (deep nesting, wrong types, missing and unknown
keys, bad units and dates, hex overflow, gzip, binary, empty), options with wild values, an
output that is an input, FIFOs with no writer, devices and directories — each case in a fresh
directory with a time limit (a hang is a case that does not end within ``--limit`` s).

    python benchmarks/fuzz_campaign.py --cases 100000 --seconds 600 --seed 1
    python benchmarks/fuzz_campaign.py --families --cases 100000 --seconds 36000 --seed 1
"""

from __future__ import annotations

import argparse
import collections
import contextlib
import io
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from gyrotest.cli import main

NAMES = ["t", "time", "timestamp", "time [s]", "t_ms", "rate", "gx", "gy [deg/s]", "wz",
         "gyro_x_rps", "rate_dph", "counts", "up", "down", "counter", "voltage", "temp",
         "T_case_C", "temp (degC)", "Hx", "Hy", "Hz", "vsupply", "table_dps", "pos", "x", "",
         "a b", "Ω"]
TOKENS = ["0", "1", "-1", "0.1", "1e300", "-1e308", "1e-300", "nan", "inf", "-inf", "", "-",
          "NA", "abc", "0,5", "2024-05-12T10:00:00", "2024-05-12T10:00:00+02:00",
          "1716200000000000000", "1716200000000", "up", '"1,2"', "9" * 40, "0x10", " 3 "]
OPTIONS = [["--rate-unit", "deg/h"], ["--rate-unit", "rad/s"], ["--sample-rate", "10"],
           ["--sample-rate", "1e300"], ["--time-unit", "ns"], ["--nan", "gap"],
           ["--nan", "interpolate"], ["--rate-col", "rate"], ["--counts-col", "counts"],
           ["--scale-factor", "0.2"], ["--time-col", "x"], ["--latitude", "48"],
           ["--temp-col", "temp"], ["--counter-col", "counter"], ["--voltage-col", "voltage"]]
GOOD = ("t,rate,temp\n" + "\n".join(f"{i / 10:.1f},{np.sin(i) * 0.1:.4f},{20 + i / 100:.2f}"
                                    for i in range(80)) + "\n").encode()


def random_table(rng: np.random.Generator) -> bytes:
    delim = rng.choice([",", ";", "\t", " ", "|"])
    ncol = int(rng.integers(1, 6))
    header = [NAMES[i] for i in rng.integers(0, len(NAMES), ncol)]
    rows = []
    mono = rng.random() < 0.7
    for i in range(int(rng.integers(0, 40))):
        cells = []
        for j in range(ncol):
            if mono and j == 0 and rng.random() < 0.95:
                cells.append(f"{i * 0.1:.1f}")
            elif rng.random() < 0.2:
                cells.append(TOKENS[int(rng.integers(len(TOKENS)))])
            else:
                cells.append(repr(float(rng.normal(0, 10))))
        rows.append(delim.join(cells))
    data = "\n".join([delim.join(header), *rows]).encode()
    if rng.random() < 0.15:
        data = b"\xef\xbb\xbf" + data
    return data


def mutate(rng: np.random.Generator, data: bytes) -> bytes:
    b = bytearray(data)
    for _ in range(int(rng.integers(1, 3))):
        if not b:
            break
        op = rng.integers(4)
        i = int(rng.integers(len(b)))
        if op == 0:
            b[i] = int(rng.integers(256))
        elif op == 1:
            del b[i:i + int(rng.integers(1, 20))]
        elif op == 2:
            b[i:i] = b[i:i + int(rng.integers(1, 40))]
        else:
            b[i:i] = bytes(rng.choice(list(b",;\t\n.-e+0123456789nanif#\"\r"),
                                      int(rng.integers(1, 8))))
    return bytes(b)


def run(args: list[str]) -> tuple[int, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            main(args)
            code = 0
        except SystemExit as e:
            code = e.code if isinstance(e.code, int) else 1
    return code, err.getvalue()


def campaign(cases: int, seconds: float, seed: int, keep: Path | None) -> dict:
    rng = np.random.default_rng(seed)
    codes: collections.Counter = collections.Counter()
    kinds: collections.Counter = collections.Counter()
    failures = []
    t0 = time.perf_counter()
    n = 0
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        for n in range(1, cases + 1):
            kind = "table" if rng.random() < 0.5 else "mutation"
            data = random_table(rng) if kind == "table" else mutate(rng, GOOD)
            src = d / "log.csv"
            src.write_bytes(data)
            opts = [a for k in rng.integers(0, len(OPTIONS), int(rng.integers(0, 3)))
                    for a in OPTIONS[k]]
            if rng.random() < 0.6:  # most logs name their rate unit: reach the deeper paths
                opts = ["--rate-unit", "deg/h", *opts]
            cmd = ["info", str(src), *opts]
            if n % 10 == 0:
                cmd = ["ingest", str(src), "-o", str(d / "out.parquet"), *opts]
            code, err = run(cmd)
            codes[code] += 1
            kinds[(kind, code)] += 1
            bad = code not in (0, 2) or "Traceback" in err or "Warning" in err
            if n % 10 == 0:
                left = [p.name for p in d.iterdir() if p.name.startswith(".out.parquet.")]
                if left or (code != 0 and (d / "out.parquet").exists()):
                    bad = True
                (d / "out.parquet").unlink(missing_ok=True)
            if src.read_bytes() != data:
                bad = True
            if bad:
                failures.append((cmd[0], opts, err.strip()[-300:]))
                if keep is not None:
                    keep.mkdir(parents=True, exist_ok=True)
                    (keep / f"fail_{seed}_{n}.csv").write_bytes(data)
            if time.perf_counter() - t0 > seconds:
                break
    return {"cases": n, "seconds": time.perf_counter() - t0, "exit_codes": dict(codes),
            "by_kind": {f"{k}:{c}": v for (k, c), v in sorted(kinds.items())},
            "failures": failures[:20], "n_failures": len(failures)}


def families(cases: int, seconds: float, seed: int, keep: Path | None, limit_s: float,
             report_every: int = 0) -> dict:
    """The issue-62 campaign (module docstring)."""
    import os
    import shutil

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from fuzzcases import RngDraw, build_case, log_text, run_case

    os.environ.setdefault("GYROTEST_FIFO_WAIT", "0.2")  # a FIFO with no writer: refused fast
    rng = np.random.default_rng(seed)
    codes: collections.Counter = collections.Counter()
    by_family: dict[str, collections.Counter] = collections.defaultdict(collections.Counter)
    failures = []
    slowest: list[tuple[float, str]] = []
    t0 = time.perf_counter()
    n = 0
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        base, _, _ = log_text(RngDraw(np.random.default_rng(0)), n=120)
        (d / "base.csv").write_text(base)
        code, err = run(["model", "fit", str(d / "base.csv"), "--rate-unit", "deg/h",
                         "--terms", "T", "-o", str(d / "good.json"), "--no-history", "-q"])
        assert code == 0, err
        good_model = (d / "good.json").read_bytes()
        for n in range(1, cases + 1):
            case = build_case(RngDraw(rng), good_model)
            work = d / f"c{n}"
            with contextlib.redirect_stdout(io.StringIO()):
                out = run_case(case, work, limit_s=limit_s)
            key = "hang" if out.code is None else out.code
            codes[key] += 1
            by_family[case.family.split(":")[0]][key] += 1
            slowest = sorted([*slowest, (out.seconds, repr(case))], reverse=True)[:5]
            if out.problem:
                failures.append((repr(case), out.problem, out.err.strip()[-300:]))
                if keep is not None:
                    dest = keep / f"fail_{seed}_{n}"
                    shutil.copytree(work, dest, symlinks=True, ignore=lambda *a: [
                        x for x in a[1] if (Path(a[0]) / x).is_fifo()])
                    (dest / "argv.txt").write_text(" ".join(case.argv) + "\n")
            shutil.rmtree(work, ignore_errors=True)
            if report_every and n % report_every == 0:
                print(json.dumps({"cases": n, "seconds": round(time.perf_counter() - t0),
                                  "exit_codes": {str(k): v for k, v in codes.items()},
                                  "failures": len(failures)}), file=sys.stderr, flush=True)
            if time.perf_counter() - t0 > seconds:
                break
    return {"cases": n, "seconds": time.perf_counter() - t0,
            "exit_codes": {str(k): v for k, v in codes.items()},
            "by_family": {f: {str(k): v for k, v in c.items()} for f, c in by_family.items()},
            "slowest": slowest, "failures": failures[:30], "n_failures": len(failures)}


def cli() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=100_000)
    ap.add_argument("--seconds", type=float, default=600.0)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--keep", type=Path, default=None)
    ap.add_argument("--families", action="store_true",
                    help="the issue-62 damaged-input families through every command")
    ap.add_argument("--limit", type=float, default=60.0,
                    help="seconds after which a --families case counts as a hang")
    ap.add_argument("--report-every", type=int, default=0,
                    help="print running tallies to stderr every N cases")
    a = ap.parse_args()
    if a.families:
        res = families(a.cases, a.seconds, a.seed, a.keep, a.limit, a.report_every)
    else:
        res = campaign(a.cases, a.seconds, a.seed, a.keep)
    json.dump(res, sys.stdout, indent=2)
    sys.stdout.write("\n")


if __name__ == "__main__":
    cli()
