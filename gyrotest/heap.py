"""glibc heap settings for commands that read a whole log into memory.

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
``allan`` on that log stayed the same (≈ 0.55 GB). Streamed logs (:mod:`gyrotest.stream`)
set their own, opposite, settings to keep their peak low. No effect off glibc.
"""

from __future__ import annotations

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
