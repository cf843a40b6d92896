"""The examples a user is shown (README, man page, every ``--help``), extracted and runnable.

Used by ``tests/test_examples_run.py`` (every example runs on ``sample_data/``) and by
``benchmarks/bench_examples.py`` (every example, duplicates too, with the time of each).

An example is one shell command line as the user would paste it (continuation lines joined,
``$`` prompt removed). Examples come in *blocks*: the commands of one README code block, of
one command's ``--help`` or of the man page's EXAMPLES section. A block runs in order in a
directory of its own that looks like the repository root (``sample_data/`` in it), because a
later example may read what an earlier one wrote (``-o model.json`` … ``--model model.json``):
every block is self-contained, as a reader copying it would need it to be.

The runner understands the little shell the examples use: ``a && b``, ``cmd > file``,
``cat FILE | cmd``, globs (``lot/campaign_*.toml``), quoting and comments, ``mkdir -p`` and
``cp``; ``gyrotest …`` runs in-process (``cliutil``), ``python sample_data/….py`` in a
subprocess.

Not run, each with its reason (:func:`why_not`): the set-up commands of the README's first
screen and Development section (``.ci/run`` runs them), benchmark scripts (``benchmarks/``),
examples naming what the bundled data cannot provide (:data:`TEMPLATES`: a Dask cluster's
address) and examples of an optional extra that is not installed (:data:`REQUIRES`).
:func:`plan` leaves out an example already run with the same words in an earlier block,
unless a later example of its own block reads what it wrote.
"""

from __future__ import annotations

import glob
import importlib.util
import os
import re
import shlex
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: placeholder text in an example -> (replacement, or None when it cannot run here, and why)
TEMPLATES: dict[str, tuple[str | None, str]] = {
    "tcp://10.0.0.5:8786": (None, "needs a running Dask scheduler at that address"),
}
#: text in an example -> the module it needs (an optional extra of pyproject.toml)
REQUIRES: dict[str, str] = {"--scheduler local": "distributed"}
#: command prefixes that are not gyrotest examples -> why they are not run here
NOT_EXAMPLES: dict[str, str] = {
    "python3 -m venv": "set-up command (.ci/run runs the README's)",
    ".venv/bin/pip": "set-up command (.ci/run runs the README's)",
    ".venv/bin/pytest": "the test suite itself",
    ".venv/bin/python benchmarks/": "a benchmark (benchmarks/README.md)",
    "python benchmarks/": "a benchmark (benchmarks/README.md)",
}


@dataclass
class Example:
    source: str          # "README.md", "man page", "gyrotest allan --help"
    block: str           # the block's id
    line: int            # 1-based line in the source, or the example's line in the help
    command: str         # one shell line
    output: str = ""     # the output the README shows below it (README only)

    @property
    def key(self) -> str:
        """The command without comments or extra blanks: examples with one key are one run."""
        return " ".join(shlex.split(self.command, comments=True))

    @property
    def where(self) -> str:
        return f"{self.block}, line {self.line}"


@dataclass
class Block:
    source: str
    name: str
    examples: list[Example] = field(default_factory=list)


_FENCE = re.compile(r"^```(\w*)\s*$")
_RUNNABLE = ("gyrotest", "python", "cat ", "mkdir", ".venv/")


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
    same text as ``--help``, taken here as the man page shows them)."""
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


# ----------------------------------------------------------------------------- planning
def why_not(ex: Example) -> str:
    """Why an example is not run here ("" when it is run)."""
    cmd = ex.command.strip()
    for prefix, why in NOT_EXAMPLES.items():
        if cmd.startswith(prefix):
            return why
    for ph, (value, why) in TEMPLATES.items():
        if ph in cmd and value is None:
            return why
    for text, module in REQUIRES.items():
        if text in cmd and importlib.util.find_spec(module) is None:
            return f"needs the optional module {module!r}, not installed"
    return ""


#: options whose value is a file an example writes
_OUT_OPTS = ("-o", "--output", "--pdf", "--md", "--html", "--plot", "--csv", "--points",
             "--psd", "--init", ">")


def _words(ex: Example) -> list[str]:
    return [w for part in re.split(r"\s&&\s", ex.command)
            for w in shlex.split(part, comments=True)]


def outputs(ex: Example) -> set[str]:
    """What an example writes, as paths relative to its directory: the values of the output
    options, ``> file``, a script's or ``mkdir``'s directory, ``cp``'s destination, and the
    profile and truth files ``simulate -o NAME.csv`` writes beside its log."""
    w = _words(ex)
    out = {w[i + 1] for i, x in enumerate(w[:-1]) if x in _OUT_OPTS}
    if w and w[0] in ("python", "python3", "mkdir"):
        out |= {x for x in w[2 if w[0] != "mkdir" else 1:] if not x.startswith("-")}
    if "cp" in w:
        out.add(w[-1])
    if len(w) > 1 and w[:2] == ["gyrotest", "simulate"]:
        for o in list(out):
            stem = o.rsplit(".", 1)[0]
            out |= {stem, f"{stem}.profile.toml", f"{stem}.truth.json"}
    return {o.rstrip("/") for o in out}


def _reads(ex: Example, made: set[str]) -> bool:
    """Does the example name one of the paths ``made`` (or something inside one)?"""
    for x in _words(ex):
        x = x.rstrip("/")
        if any(x == m or x.startswith(m + "/") or x.startswith(m + "_run") for m in made):
            return True
    return False


@dataclass
class Step:
    example: Example
    skip: str = ""       # why it is not run ("" = run)


def plan(blocks: list[Block]) -> list[list[Step]]:
    """Per block, its examples with the reason to leave one out: :func:`why_not`, or the same
    words already run in an earlier block (README, man page, --help order) while no example
    run after it in its own block reads what it writes."""
    seen: dict[str, str] = {}
    out = []
    for b in blocks:
        steps = [Step(ex, why_not(ex)) for ex in b.examples]
        first = {i: ex.key in seen for i, ex in enumerate(b.examples)}
        for i in range(len(steps) - 1, -1, -1):  # from the last: who needs whom
            st = steps[i]
            if st.skip or not first[i]:
                continue
            later = [s.example for s in steps[i + 1:] if not s.skip]
            if not any(_reads(e, outputs(st.example)) for e in later):
                st.skip = f"the same as {seen[st.example.key]}"
        for st in steps:
            if not st.skip:
                seen.setdefault(st.example.key, st.example.where)
        out.append(steps)
    return out


# ----------------------------------------------------------------------------- running
@dataclass
class Ran:
    example: Example
    code: int
    out: str
    err: str
    seconds: float


def _glob(words: list[str], cwd: Path) -> list[str]:
    out: list[str] = []
    for w in words:
        hits = sorted(glob.glob(str(cwd / w))) if any(c in w for c in "*?[") else []
        out += [os.path.relpath(h, cwd) for h in hits] or [w]
    return out


def _run_words(words: list[str], cwd: Path, stdin: bytes | None) -> tuple[int, str, str]:
    """One simple command (no && or |) in ``cwd``."""
    if words[0] == "mkdir":
        for d in [w for w in words[1:] if not w.startswith("-")]:
            (cwd / d).mkdir(parents=True, exist_ok=True)
        return 0, "", ""
    if words[0] == "cp":
        *srcs, dst = [w for w in words[1:] if not w.startswith("-")]
        for s in srcs:
            shutil.copy(cwd / s, cwd / dst)
        return 0, "", ""
    if words[0] in ("gyrotest", ".venv/bin/gyrotest"):
        from cliutil import run_cli

        r = run_cli(words[1:], stdin=stdin)
        return r.code, r.out, r.err
    if words[0] in ("python", "python3"):
        p = subprocess.run([sys.executable, *words[1:]], capture_output=True, text=True,
                           input=None if stdin is None else stdin.decode(), cwd=cwd)
        return p.returncode, p.stdout, p.stderr
    raise AssertionError(f"unsupported command in an example: {' '.join(words)}")


def run_example(ex: Example, cwd: Path) -> Ran:
    """Run one example in ``cwd`` (which holds ``sample_data`` as the repository does)."""
    cmd = ex.command
    for ph, (value, _) in TEMPLATES.items():
        if value is not None:
            cmd = cmd.replace(ph, value)
    t0 = time.perf_counter()
    old = Path.cwd()
    os.chdir(cwd)
    code, out, err = 0, "", ""
    try:
        for part in re.split(r"\s&&\s", cmd):
            words = shlex.split(part, comments=True)
            stdin = None
            if "|" in words:
                i = words.index("|")
                left, words = words[:i], words[i + 1:]
                assert left[0] == "cat" and len(left) == 2, f"unsupported pipe: {part}"
                stdin = (cwd / left[1]).read_bytes()
            out_file = None
            if ">" in words:
                i = words.index(">")
                words, out_file = words[:i], words[i + 1]
            code, o, e = _run_words(_glob(words, cwd), cwd, stdin)
            out, err = out + (o if out_file is None else ""), err + e
            if code != 0:
                break
            if out_file is not None:
                (cwd / out_file).write_text(o, encoding="utf-8")
    finally:
        os.chdir(old)
    return Ran(ex, code, out, err, time.perf_counter() - t0)


def workdir(tmp: Path) -> Path:
    """A scratch directory that looks like the repository root to the examples."""
    tmp.mkdir(parents=True, exist_ok=True)
    link = tmp / "sample_data"
    if not link.exists():
        link.symlink_to(ROOT / "sample_data", target_is_directory=True)
    return tmp


def created_files(root: Path) -> list[str]:
    """Files and directories an example run left in ``root`` (relative, the ``sample_data``
    link excluded; a directory once, not its contents)."""
    out = []
    for p in sorted(root.iterdir()):
        if p.name != "sample_data":
            out.append(p.name + ("/" if p.is_dir() else ""))
    return out
