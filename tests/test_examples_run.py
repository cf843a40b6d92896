"""Every example a user is shown runs on the bundled data (issue 61): each shell block of the
README, the man page's EXAMPLES and every command's examples (as the man page and --help
show them), in a directory that looks like the repository root. The README's shown output
prints the same numbers; nothing is written into sample_data/; every file the examples leave
is listed in .gitignore.

The extraction and the little shell are in ``tests/examples.py``; an example already run
with the same words in an earlier block is not run again (unless its own block reads what it
writes). ``benchmarks/bench_examples.py`` runs every one, duplicates too, and times them.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import examples as E
import pytest

ROOT = Path(__file__).resolve().parents[1]
BLOCKS = E.all_blocks()
PLAN = E.plan(BLOCKS)
CASES = [(b, steps) for b, steps in zip(BLOCKS, PLAN) if any(not s.skip for s in steps)]
SAMPLE_FILES = sorted(p.name for p in (ROOT / "sample_data").iterdir())
#: numbers in the README's shown output ("1.77835", "-2.40e+05", "18,000")
NUMBER = re.compile(r"(?<![\w.])[-+−]?\d[\d,]*(?:\.\d+)?(?:e[-+]?\d+)?")


def test_every_example_is_run_or_has_a_reason():
    """Nothing is left out silently: each example not run names why (set-up command,
    benchmark, an address or an optional extra the bundled data cannot provide, or the same
    words run elsewhere)."""
    n_run = sum(not s.skip for steps in PLAN for s in steps)
    assert n_run >= 60, n_run
    for steps in PLAN:
        for s in steps:
            assert s.skip == "" or len(s.skip) > 10, s
            if s.skip.startswith("the same as"):
                assert any(not t.skip and t.example.key == s.example.key
                           for st in PLAN for t in st)
    sources = {b.source for b, _ in CASES}
    assert {"README.md", "man page"} <= sources
    # the help examples are the man page's (man/make_man.py --check keeps them identical)
    helps = {b.name.removesuffix(" --help"): [e.key for e in b.examples]
             for b in BLOCKS if b.source.endswith("--help")}
    mans = {b.name.removeprefix("man page: "): [e.key for e in b.examples]
            for b in BLOCKS if b.source == "man page"}
    for name, keys in helps.items():
        assert mans.get(name) == keys, name


@pytest.mark.parametrize("steps", [c[1] for c in CASES], ids=[c[0].name for c in CASES])
def test_examples_run(steps, tmp_path):
    wd = E.workdir(tmp_path / "repo")
    for st in steps:
        if st.skip:
            continue
        ex = st.example
        shown = ex.source == "README.md" and ex.output.strip()
        run = E.Example(ex.source, ex.block, ex.line, ex.command + " -v", ex.output) if (
            shown) else ex  # -v: the notes a terminal shows, on this redirected stderr
        r = E.run_example(run, wd)
        assert r.code == 0, f"{ex.where}: {ex.command}\nexit {r.code}: {r.err[-1500:]}"
        if shown:
            got = (r.out + r.err).replace("−", "-")
            missing = [n for n in NUMBER.findall(ex.output) if n.replace("−", "-") not in got]
            assert not missing, (f"{ex.where}: the README shows {missing} that "
                                 f"'{ex.command}' no longer prints")
    assert sorted(p.name for p in (ROOT / "sample_data").iterdir()) == SAMPLE_FILES, (
        "an example wrote into sample_data/")
    left = E.created_files(wd)
    if left and shutil.which("git") and (ROOT / ".git").exists():
        r = subprocess.run(["git", "check-ignore", "--no-index", "--stdin"], cwd=ROOT,
                           input="\n".join(left), capture_output=True, text=True)
        ignored = set(r.stdout.split())
        assert set(left) <= ignored, f"not in .gitignore: {sorted(set(left) - ignored)}"
