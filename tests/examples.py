"""The examples a user is shown (README, man page, every ``--help``), extracted and runnable.

Used by ``tests/test_examples_run.py`` (every example runs on ``sample_data/``) and by
``benchmarks/bench_examples.py`` (the slow ones, and the time of each).

An example is one shell command line as the user would paste it (continuation lines joined,
``$`` prompt and trailing ``# comment`` removed). Examples come in *blocks*: the commands of one
README code block, of one command's ``--help`` or of the man page's EXAMPLES section, run in
order in one working directory, because a later example may read what an earlier one wrote
(``-o model.json`` … ``--model model.json``); the README's blocks share one directory in the
README's order (``allan.json`` made in one section is exported in the next).

The runner understands the little shell the examples use: ``cmd > file``, ``cat FILE | cmd``,
globs (``lot/campaign_*.toml``) and quoting; ``gyrotest …`` runs in-process (``cliutil``),
``python sample_data/….py`` in a subprocess.

Templates: an example may name something the bundled data cannot provide (a Dask cluster's
address). :data:`TEMPLATES` lists those, each with the value the test fills in or the reason
it cannot run here; there are no other exceptions.
"""

from __future__ import annotations

import glob
import re
import shlex
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: placeholder text in an example -> (replacement, or None when it cannot run here, and why)
TEMPLATES: dict[str, tuple[str | None, str]] = {
    "tcp://HOST:PORT": (None, "needs a running Dask scheduler"),
    "tcp://10.0.0.5:8786": (None, "needs a running Dask scheduler"),
}


@dataclass
class Example:
    source: str          # "README.md", "man page", "gyrotest allan --help"
    block: str           # the block's id (examples of one block share a directory, in order)
    line: int            # 1-based line in the source (the README/man page) or example number
    command: str         # one shell line
    output: str = ""     # the output the README shows below it (README only)

    @property
    def key(self) -> str:
        """The command without comments or extra blanks: examples with one key are one run."""
        return " ".join(shlex.split(self.command, comments=True))


@dataclass
class Block:
    source: str
    name: str
    examples: list[Example] = field(default_factory=list)


_FENCE = re.compile(r"^```(\w*)\s*$")
_RUNNABLE = ("gyrotest", "python", "cat ", ".venv/bin/gyrotest")


def _join_continuations(lines: list[tuple[int, str]]) -> list[tuple[int, str, list[str]]]:
    """[(line number, text)] of a code block -> [(line, command, output lines)] for the lines
    that start with ``$ `` (README style) or, in a block without prompts, every line."""
    prompted = any(t.startswith("$ ") for _, t in lines)
    out: list[tuple[int, str, list[str]]] = []
    cont = False
    for no, text in lines:
        if cont:
            out[-1] = (out[-1][0], out[-1][1] + " " + text.strip().rstrip("\\").strip(),
                       out[-1][2])
            cont = text.rstrip().endswith("\\")
            continue
        if prompted and not text.startswith("$ "):
            if out:
                out[-1][2].append(text)
            continue
        cmd = text[2:] if text.startswith("$ ") else text
        if not cmd.strip():
            continue
        cont = cmd.rstrip().endswith("\\")
        out.append((no, cmd.strip().rstrip("\\").strip(), []))
    return out


def readme_blocks(path: Path = ROOT / "README.md") -> list[Block]:
    """Every shell code block of the README (```sh, ```console or unmarked)."""
    blocks: list[Block] = []
    lang = None
    body: list[tuple[int, str]] = []
    start = 0
    for no, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        m = _FENCE.match(line)
        if m and lang is None:
            lang, body, start = m.group(1), [], no
            continue
        if m and lang is not None:
            if lang in ("", "sh", "bash", "console"):
                b = Block("README.md", f"README.md:{start}")
                for ln, cmd, outp in _join_continuations(body):
                    if cmd.startswith(_RUNNABLE):
                        b.examples.append(Example("README.md", b.name, ln, cmd,
                                                  "\n".join(outp)))
                if b.examples:
                    blocks.append(b)
            lang = None
            continue
        if lang is not None:
            body.append((no, line))
    return blocks


def help_blocks() -> list[Block]:
    """The ``Example(s):`` section of every command's and sub-command's ``--help``."""
    import click

    from gyrotest.cli import cli

    blocks: list[Block] = []

    def walk(cmd, ctx, path):
        text = cmd.get_help(ctx)
        m = re.search(r"^\s*Examples?:\n(.*?)(?:\n\s*\n|\Z)", text, flags=re.S | re.M)
        if m:
            b = Block(f"{path} --help", f"{path} --help")
            lines = [(i, t.strip()) for i, t in enumerate(m.group(1).splitlines(), 1)]
            for no, cmd_, _ in _join_continuations(lines):
                b.examples.append(Example(b.source, b.name, no, cmd_))
            blocks.append(b)
        if isinstance(cmd, click.Group):
            for sub in cmd.list_commands(ctx):
                c = cmd.get_command(ctx, sub)
                walk(c, click.Context(c, info_name=sub, parent=ctx), f"{path} {sub}")

    walk(cli, click.Context(cli, info_name="gyrotest"), "gyrotest")
    return blocks


def man_blocks(path: Path = ROOT / "man" / "gyrotest.1") -> list[Block]:
    """The man page: its EXAMPLES section, and the examples of each command's section (the
    same text as ``--help``, checked here as the man page shows them)."""
    text = path.read_text(encoding="utf-8")
    plain = text.replace("\\-", "-").replace("\\e", "\\").replace("\\&", "")
    blocks: list[Block] = []
    sec = re.search(r"^\.SH EXAMPLES\n\.nf\n(.*?)\n\.fi", plain, flags=re.S | re.M)
    if sec:
        b = Block("man page", "man page: EXAMPLES")
        start = plain[:sec.start(1)].count("\n") + 1
        lines = [(start + i, t) for i, t in enumerate(sec.group(1).splitlines())]
        for no, cmd, _ in _join_continuations(lines):
            b.examples.append(Example(b.source, b.name, no, cmd))
        blocks.append(b)
    for m in re.finditer(r"^\.SS (.+?)\n(.*?)(?=^\.SS |^\.SH |\Z)", plain, flags=re.S | re.M):
        ex = re.search(r"^Examples?:\n(.*?)(?:\n\.fi|\n\s*\n|\n\.TP)", m.group(2),
                       flags=re.S | re.M)
        if not ex:
            continue
        b = Block("man page", f"man page: {m.group(1)}")
        start = plain[:m.start(2) + ex.start(1)].count("\n") + 1
        lines = [(start + i, t.strip()) for i, t in enumerate(ex.group(1).splitlines())]
        for no, cmd, _ in _join_continuations(lines):
            b.examples.append(Example(b.source, b.name, no, cmd))
        if b.examples:
            blocks.append(b)
    return blocks


def all_blocks() -> list[Block]:
    return readme_blocks() + man_blocks() + help_blocks()


# ----------------------------------------------------------------------------- running
@dataclass
class Ran:
    example: Example
    code: int
    out: str
    err: str
    seconds: float
    skipped: str = ""


def fill_template(cmd: str) -> tuple[str | None, str]:
    """The command with its placeholders filled, or (None, why it cannot run here)."""
    for ph, (value, why) in TEMPLATES.items():
        if ph in cmd:
            if value is None:
                return None, why
            cmd = cmd.replace(ph, value)
    return cmd, ""


def run_example(ex: Example, cwd: Path) -> Ran:
    """Run one example in ``cwd`` (which holds ``sample_data`` as the repository does)."""
    import os

    cmd, why = fill_template(ex.command)
    if cmd is None:
        return Ran(ex, 0, "", "", 0.0, skipped=why)
    words = shlex.split(cmd, comments=True)
    stdin = None
    if "|" in words:
        i = words.index("|")
        left, words = words[:i], words[i + 1:]
        assert left[0] == "cat" and len(left) == 2, f"unsupported pipe: {cmd}"
        stdin = (cwd / left[1]).read_bytes()
    out_file = None
    if ">" in words:
        i = words.index(">")
        words, out_file = words[:i], words[i + 1]
    expanded: list[str] = []
    for w in words:
        hits = sorted(glob.glob(str(cwd / w))) if any(c in w for c in "*?[") else []
        expanded += [str(Path(h).relative_to(cwd)) for h in hits] or [w]
    words = expanded
    t0 = time.perf_counter()
    old = Path.cwd()
    os.chdir(cwd)
    try:
        if words[0] in ("gyrotest", ".venv/bin/gyrotest"):
            from cliutil import run_cli

            r = run_cli(words[1:], stdin=stdin)
            code, out, err = r.code, r.out, r.err
        elif words[0] in ("python", "python3"):
            p = subprocess.run([sys.executable, *words[1:]], capture_output=True, text=True,
                               input=None if stdin is None else stdin.decode())
            code, out, err = p.returncode, p.stdout, p.stderr
        else:
            raise AssertionError(f"unsupported example: {cmd}")
        if out_file is not None and code == 0:
            Path(out_file).write_text(out, encoding="utf-8")
            out = ""
    finally:
        os.chdir(old)
    return Ran(ex, code, out, err, time.perf_counter() - t0)


def block_dir(b: Block) -> str:
    """The README's blocks share one directory (in order); every other block has its own."""
    return "README" if b.source == "README.md" else b.name


def workdir(tmp: Path) -> Path:
    """A scratch directory that looks like the repository root to the examples."""
    tmp.mkdir(parents=True, exist_ok=True)
    link = tmp / "sample_data"
    if not link.exists():
        link.symlink_to(ROOT / "sample_data", target_is_directory=True)
    return tmp


def _main() -> None:  # pragma: no cover - a quick listing while editing the docs
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        for b in all_blocks():
            wd = workdir(Path(d) / re.sub(r"\W+", "_", block_dir(b)))
            for ex in b.examples:
                r = run_example(ex, wd)
                print(f"{r.seconds:6.2f} s  exit {r.code}  {b.name}:{ex.line}  {ex.command}"
                      + (f"  [skipped: {r.skipped}]" if r.skipped else ""))
                if r.code:
                    print("        " + (r.err.strip().splitlines() or [""])[-1])


if __name__ == "__main__":  # pragma: no cover
    sys.path.insert(0, str(Path(__file__).parent))
    _main()
