"""Run one analysis per log on a process pool (``--jobs N``).

Lab scripts hand gyrotest a whole campaign (``gyrotest allan *.parquet``); each log is read
and analysed independently, so the logs go to a pool of worker processes (fork on Linux:
the workers inherit the imported modules). Results come back in the order of the arguments,
and each worker runs exactly the serial code path, so the output is identical to ``--jobs 1``
(``tests/test_fastpaths.py`` compares the JSON). The ingest notes of each log are printed by
the parent, in argument order. Stdin (``-``) and a single log run in-process.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import sys
import time
from collections.abc import Callable, Sequence
from typing import Any

import click

from .. import _runtime


def jobs_option(func):
    """``--jobs N``: logs analysed in parallel (default: the number of CPU cores)."""
    return click.option("--jobs", "-j", type=click.IntRange(min=1), default=None,
                        help="Logs analysed in parallel (worker processes, each holding one "
                             "log in memory; default: the number of CPU cores). Results are "
                             "identical to --jobs 1.")(func)


def default_jobs() -> int:
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


@contextlib.contextmanager
def deviation_progress(min_s: float = 2.0):
    """Progress of the deviation τ loops on a terminal (not with -q, nothing when piped).
    The bar appears only once a loop has run for ``min_s`` seconds: short steps stay quiet."""
    from .common import progress, settings

    if settings().quiet or not sys.stderr.isatty():
        yield
        return
    with contextlib.ExitStack() as stack:
        state: dict[str, Any] = {"t0": None, "advance": None, "done": 0, "kind": None}

        def hook(done: int, total: int, kind: str) -> None:
            now = time.monotonic()
            if state["t0"] is None or done <= state["done"] or kind != state["kind"]:
                state.update(t0=now, done=0, kind=kind)  # a new loop
            label = kind if " " in kind else f"{kind.upper()} τ"  # "reading rows", "OADEV τ"
            if state["advance"] is None:
                if now - state["t0"] >= min_s and done < total:
                    state["advance"] = stack.enter_context(progress(label, total))
                    state["advance"](done, description=label)
                state["done"] = done
                return
            state["advance"](done - state["done"], total=total, description=label)
            state["done"] = done
            if done == total:
                state["advance"](-total)  # reset for the next loop (transient bar)

        old, _runtime.PROGRESS = _runtime.PROGRESS, hook
        try:
            yield
        finally:
            _runtime.PROGRESS = old


def _work(args: tuple[Callable, str, dict, dict, bool]) -> tuple[Any, list[str]]:
    fn, path, opts, kw, stream = args
    from .common import load_log

    _runtime.PROGRESS = None  # a worker process draws no bar

    log = load_log(path, opts, announce=False, stream=stream)
    return named(fn, log, **kw), [f"{log.source}: {m}" for m in log.notes]


def named(fn: Callable, log, **kw):
    """``fn(log, **kw)``; an error about the data that does not say which log it is about
    ("record too short for τ = 1e5 s …") gets the log's name in front, as every other
    one-line error has."""
    from ..core.errors import InputError

    try:
        return fn(log, **kw)
    except InputError as e:
        src = getattr(log, "source", None)
        if src and len(e.args) == 1 and isinstance(e.args[0], str) and src not in e.args[0]:
            e.args = (f"{src}: {e.args[0]}",)
        raise


def prefetch_log(paths: Sequence[str], opts: dict):
    """Start reading the only log of a run on a background thread, so that the parse (pyarrow
    and numpy, mostly without the GIL) overlaps the import of the analysis modules; returns a
    Future of the log for :func:`map_logs` (``loaded=``), or None (several logs, stdin, an
    unreadable path, or a Parquet file, which may be streamed with a progress bar drawn from
    the calling thread). The notes are printed by :func:`map_logs` and any error is raised
    there, after the options have been checked, as without the prefetch."""
    if len(paths) != 1 or paths[0] == "-":
        return None
    from ..core.documents import path_kind

    if path_kind(paths[0]) != "file":  # a FIFO is never opened here (it would block)
        return None
    try:
        with open(paths[0], "rb") as fh:
            if fh.read(4) == b"PAR1":
                return None
    except OSError:
        return None
    from functools import partial

    from .._runtime import reuse_freed_memory, run_on_thread
    from .common import load_log

    reuse_freed_memory()  # read whole (text): before any thread starts (gyrotest._runtime)
    return run_on_thread(partial(load_log, announce=False), paths[0], opts,
                         name="gyrotest-read")


def map_logs(fn: Callable, paths: Sequence[str], opts: dict, *, jobs: int | None = None,
             announce: bool = True, stream: bool = False, loaded=None, **kw) -> list:
    """``[fn(load_log(p), **kw) for p in paths]``, on ``jobs`` worker processes when there is
    more than one log. ``fn`` must be a module-level function (it is pickled by name).
    ``stream``: long Parquet logs may be streamed into θ (:mod:`gyrotest.io.stream`).
    ``loaded``: the Future of :func:`prefetch_log` for the only log."""
    from .common import load_logs, note, progress

    if loaded is not None:
        log = loaded.result()
        if announce:
            for msg in log.notes:
                note(f"{log.source}: {msg}")
        return [named(fn, log, **kw)]
    n_jobs = min(jobs or default_jobs(), len(paths))
    if n_jobs < 2 or "-" in paths:
        return [named(fn, log, **kw) for log in load_logs(paths, opts, announce=announce,
                                                   stream=stream)]
    from concurrent.futures import ProcessPoolExecutor

    method = "fork" if sys.platform.startswith("linux") else None
    ctx = multiprocessing.get_context(method)
    out = []
    with (progress(f"{len(paths)} logs on {n_jobs} processes", total=len(paths)) as advance,
          ProcessPoolExecutor(max_workers=n_jobs, mp_context=ctx) as ex):
        for res, notes in ex.map(_work, [(fn, p, opts, kw, stream) for p in paths]):
            if announce:
                for m in notes:
                    note(m)
            out.append(res)
            advance()
    return out
