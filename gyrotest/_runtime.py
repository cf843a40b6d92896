"""The process runtime of gyrotest (private): memory, child processes, threads.

**glibc heap** (:func:`reuse_freed_memory`): the settings for commands that read a whole log
into memory.

numpy takes every array of ≥ 32 MiB (a 10⁷-sample column is 80 MB) from glibc's ``malloc``,
which serves such blocks with a fresh ``mmap`` and unmaps them on ``free``: every full-size
temporary of the analysis (θ, the running median, |residual|, the Welch segments …) is then
faulted in page by page again. On the 2-core reference VM this was 0.7–1.5 s of system time
per ``allan`` of a 10⁷-row CSV (``benchmarks/README.md``, bench_speed, fourth pass).

:func:`reuse_freed_memory` tells glibc to serve large blocks from its heap instead
(``M_MMAP_MAX`` = 0) and to keep freed memory there (a high ``M_TRIM_THRESHOLD``), so a freed
array's pages are reused, already mapped, by the next one; and to give every thread that
heap (``M_ARENA_MAX`` = 1: a thread's own arena is made of 64 MiB pieces, so it would still
map and unmap each 80 MB array of the spike check and the deviation threads). Call it before
the threads start. The peak resident memory of
``allan`` on that log stayed the same (≈ 0.55 GB). Streamed logs (:mod:`gyrotest.io.stream`)
set their own, opposite, settings to keep their peak low. No effect off glibc.

**Work beside the caller** (:func:`run_beside`, :func:`run_on_thread`): one function run in a
forked child process (or a thread) beside the caller's work.

Some steps hold Python's GIL for their whole run (scipy's running median in the spike check),
so a thread beside the deviations does not overlap them: on a 10⁷-sample log the thread and the
main work took as long together as one after the other (benchmarks/README.md, issue #13, sixth
pass). A forked child shares the record copy-on-write, needs no pickling of its inputs and runs
on the other core; only its (small) result comes back through a pipe.

:func:`run_beside` returns a handle whose ``result()`` returns the function's value or raises
its exception, as a direct call would. Off Linux (no ``fork``, or a fork that system
frameworks do not support) or when the fork fails, the function runs in the caller when
``result()`` is called. The child leaves with ``os._exit``: no atexit handlers, no flush of
the parent's buffered output.

:func:`run_on_thread` is the in-process counterpart for work that releases the GIL (numpy,
pyarrow): a thread instead of a child, the same ``result()``.
"""

from __future__ import annotations

import os
import pickle
import sys
import warnings
from collections.abc import Callable
from typing import Any

#: optional ``hook(done, total, kind)`` of long computations (the τ loop of the deviations,
#: the spike check and the reading of a streamed log), called in the calling thread after each
#: step (the CLI's progress display sets it; the core never prints); for MTOTDEV also within
#: a τ, with a fractional ``done`` (i + fraction of τ number i + 1's work)
PROGRESS: Callable[[float, int, str], None] | None = None

_M_TRIM_THRESHOLD, _M_MMAP_MAX, _M_ARENA_MAX = -1, -4, -8


def reuse_freed_memory() -> None:
    """Large blocks from glibc's heap, freed memory kept for reuse (module docstring)."""
    try:
        import ctypes

        libc = ctypes.CDLL("libc.so.6")
        libc.mallopt(_M_MMAP_MAX, 0)
        libc.mallopt(_M_ARENA_MAX, 1)
        libc.mallopt(_M_TRIM_THRESHOLD, (1 << 31) - 1)  # the largest int: 2 GiB
    except (OSError, AttributeError):  # pragma: no cover - not glibc
        pass


class _Inline:
    def __init__(self, fn: Callable[..., Any], args: tuple) -> None:
        self._fn, self._args = fn, args

    def result(self) -> Any:
        return self._fn(*self._args)


class _Forked:
    def __init__(self, pid: int, fd: int) -> None:
        self._pid, self._fd = pid, fd
        self._done = False

    def result(self) -> Any:
        if self._done:
            raise RuntimeError("result() already taken")
        self._done = True
        chunks = []
        with os.fdopen(self._fd, "rb") as f:
            while True:
                b = f.read(1 << 20)
                if not b:
                    break
                chunks.append(b)
        _, status = os.waitpid(self._pid, 0)
        data = b"".join(chunks)
        if not data:  # killed (out of memory, a signal): no answer
            raise RuntimeError(f"the child process of the spike check ended without a result "
                               f"(wait status {status}); rerun with --outliers remove or robust "
                               "to run it in the main process")
        ok, value = pickle.loads(data)
        if ok:
            return value
        raise value


def run_beside(fn: Callable[..., Any], *args: Any) -> _Inline | _Forked:
    """Start ``fn(*args)`` in a forked child (Linux); its value or exception comes back through
    :meth:`result`. Falls back to running it in the caller at ``result()``."""
    if not sys.platform.startswith("linux") or not hasattr(os, "fork"):
        return _Inline(fn, args)
    try:
        r, w = os.pipe()
    except OSError:
        return _Inline(fn, args)
    try:
        with warnings.catch_warnings():  # Python ≥ 3.12 warns on fork with threads alive; the
            warnings.simplefilter("ignore", DeprecationWarning)  # child only computes and exits
            pid = os.fork()
    except OSError:
        os.close(r)
        os.close(w)
        return _Inline(fn, args)
    if pid == 0:  # the child: compute, send, leave without atexit handlers or stdio flushes
        code = 0
        try:
            os.close(r)
            try:
                out = (True, fn(*args))
            except BaseException as e:  # noqa: BLE001 - re-raised in the parent
                out = (False, e)
            try:
                data = pickle.dumps(out, protocol=pickle.HIGHEST_PROTOCOL)
            except Exception as e:  # noqa: BLE001 - an unpicklable exception: send its text
                data = pickle.dumps((False, RuntimeError(f"{type(e).__name__}: {e}")))
            with os.fdopen(w, "wb") as f:
                f.write(data)
        except BaseException:  # noqa: BLE001
            code = 1
        finally:
            os._exit(code)
    os.close(w)
    return _Forked(pid, r)


def run_on_thread(fn: Callable[..., Any], *args: Any, name: str = "gyrotest-beside"):
    """Start ``fn(*args)`` on a new thread; a Future whose ``result()`` returns its value or
    raises its exception, as a direct call would (for work that releases the GIL)."""
    from concurrent.futures import ThreadPoolExecutor

    ex = ThreadPoolExecutor(max_workers=1, thread_name_prefix=name)
    fut = ex.submit(fn, *args)
    ex.shutdown(wait=False)
    return fut
