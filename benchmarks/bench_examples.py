"""Every example of the README, the man page and --help, duplicates too, with its time.

    python benchmarks/bench_examples.py            # all blocks, one line per example
    python benchmarks/bench_examples.py --slow 5   # only the examples slower than 5 s

``tests/test_examples_run.py`` runs each distinct example once (an example with the same
words as an earlier one is left out unless its block needs its output); this script runs
them all, in the order a reader meets them, each block in a fresh directory that looks like
the repository root, and prints the wall time, the exit code and the first error line. The
sum tells what the examples cost a newcomer who tries every one; the slowest are where an
example could show the same with less work.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

import examples as E  # noqa: E402  (tests/examples.py: extraction and the little shell)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--slow", type=float, default=0.0,
                    help="print only examples slower than this, s")
    a = ap.parse_args()
    t_all = time.perf_counter()
    total, failed, n = 0.0, 0, 0
    with tempfile.TemporaryDirectory() as d:
        for i, b in enumerate(E.all_blocks()):
            wd = E.workdir(Path(d) / f"block{i}")
            for ex in b.examples:
                why = E.why_not(ex)
                if why:
                    continue
                r = E.run_example(ex, wd)
                n += 1
                total += r.seconds
                failed += r.code != 0
                if r.seconds >= a.slow or r.code:
                    err = (r.err.strip().splitlines() or [""])[-1][:120] if r.code else ""
                    print(f"{r.seconds:7.2f} s  exit {r.code}  {ex.where}: {ex.command[:90]}"
                          + (f"\n           {err}" if err else ""), flush=True)
    print(f"{n} examples in {total:.1f} s ({time.perf_counter() - t_all:.1f} s wall), "
          f"{failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
