"""No output over an input: the files a run reads and the files it writes, kept apart.

One guard per command run (:func:`io_guard`, opened by the command line around every command).
The run declares what it reads (:func:`declare_input`: the command line's file arguments and
options, the files a campaign names, every log :func:`gyrotest.io.ingest.read_log` opens) and what
it will write (:func:`declare_output`, before any computation); each declaration is compared
with every declaration of the other kind, by resolved path (symbolic links followed) and by
``(st_dev, st_ino)`` (a hard link or a bind mount of the same file), so the refusal comes as
soon as both paths are known, whichever is declared first. :func:`gyrotest.core.output.atomic_path`,
the one place every file is written through, checks its destination again
(:func:`check_write`): a file a run writes that nobody declared (a figure beside a plot, a
``--session`` step, a ``.truth.json`` beside a simulated log) can never replace an input either.

An input may be marked ``replaceable`` (the log of ``ingest``/``compensate``): with ``--force``
writing over it is allowed, because replacing a log with its converted or compensated version
is something a user may mean; a profile, model or scenario is never replaced.

Without an open guard (the Python API) every function here is a no-op.
"""

from __future__ import annotations

import contextlib
import contextvars
import os
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from .errors import InputError


@dataclass(frozen=True)
class _Entry:
    shown: str  # the path as the user wrote it
    real: str  # os.path.realpath
    ident: tuple[int, int] | None  # (st_dev, st_ino) when the file exists
    what: str  # "the log", "the profile", "a figure", ...
    replaceable: bool = False


@dataclass
class IOGuard:
    """The inputs and outputs of one run. ``force``: the user allowed replacing a replaceable
    input (``--force``)."""

    force: bool = False
    inputs: list[_Entry] = field(default_factory=list)
    outputs: list[_Entry] = field(default_factory=list)

    # -- declarations
    def input(self, path: str | os.PathLike, what: str, *, replaceable: bool = False) -> None:
        e = _entry(path, what, replaceable)
        if e is None or any(_same(i, e) for i in self.inputs):  # known: keep the first label
            return
        for o in self.outputs:
            _refuse_if_same(o, e, self.force)
        self.inputs.append(e)

    def output(self, path: str | os.PathLike, what: str = "output") -> None:
        e = _entry(path, what)
        if e is None or any(_same(o, e) for o in self.outputs):
            return
        for i in self.inputs:
            _refuse_if_same(e, i, self.force)
        self.outputs.append(e)

    def check_write(self, path: str | os.PathLike) -> None:
        e = _entry(path, "output")
        if e is None:
            return
        for i in self.inputs:
            _refuse_if_same(e, i, self.force)


def _entry(path: str | os.PathLike, what: str, replaceable: bool = False) -> _Entry | None:
    shown = os.fspath(path)
    if shown in ("", "-"):  # stdin/stdout
        return None
    real = os.path.realpath(shown)
    try:
        st = os.stat(real)
        ident = (st.st_dev, st.st_ino)
    except OSError:
        ident = None
    return _Entry(shown, real, ident, what, replaceable)


def _same(a: _Entry, b: _Entry) -> bool:
    return a.real == b.real or (a.ident is not None and a.ident == b.ident)


def _refuse_if_same(out: _Entry, inp: _Entry, force: bool) -> None:
    if not _same(out, inp):
        return
    if inp.replaceable and force:
        return
    same_name = os.path.abspath(out.shown) == os.path.abspath(inp.shown)
    which = (f"{inp.what} this command reads" if same_name else
             f"{inp.what} {inp.shown} this command reads (the same file under another name)")
    fix = ("name another output file, or pass --force to replace it" if inp.replaceable
           else "name another output file")
    raise InputError(f"refusing to write {out.shown} ({out.what}): it is {which} and would be "
                     f"lost; {fix}")


_current: contextvars.ContextVar[IOGuard | None] = contextvars.ContextVar("gyrotest_io_guard",
                                                                          default=None)


@contextlib.contextmanager
def io_guard(*, force: bool = False) -> Iterator[IOGuard]:
    """Open the guard of one run (nested calls share the outer one)."""
    outer = _current.get()
    if outer is not None:
        yield outer
        return
    g = IOGuard(force=force)
    token = _current.set(g)
    try:
        yield g
    finally:
        _current.reset(token)


def current() -> IOGuard | None:
    return _current.get()


def declare_input(path: str | os.PathLike | None, what: str, *,
                  replaceable: bool = False) -> None:
    """``path`` is read by this run (no-op without a guard, for None or ``-``)."""
    g = _current.get()
    if g is not None and path is not None:
        g.input(path, what, replaceable=replaceable)


def declare_output(path: str | os.PathLike | None, what: str = "output") -> None:
    """``path`` will be written by this run: refused at once if it is one of its inputs."""
    g = _current.get()
    if g is not None and path is not None:
        g.output(path, what)


def check_write(path: str | os.PathLike) -> None:
    """The last check before a file is replaced (:func:`gyrotest.core.output.atomic_path`)."""
    g = _current.get()
    if g is not None:
        g.check_write(path)


def forced() -> bool:
    """Whether the run was given ``--force``."""
    g = _current.get()
    return bool(g is not None and g.force)


def is_ours(path: Path, marker: bytes) -> bool:
    """Whether an existing file starts (within its first 4 KiB) with ``marker``: a file gyrotest
    wrote before and may replace, as opposed to a user's own file of the same name."""
    try:
        with open(path, "rb") as fh:
            return marker in fh.read(4096)
    except OSError:
        return False
