"""Resources bounded up front: a request for more samples than this machine's memory can hold
is refused before anything is allocated, with the limit in the message.

The memory a command needs grows with the samples it holds at once; :func:`max_samples` turns
the memory available now (``MemAvailable`` of ``/proc/meminfo``, or the free physical pages)
into a sample count for a given cost per sample. The simulator holds about 110 bytes per
sample for a rate-only scenario (peak RSS of ``gyrotest simulate`` at 0.72 and 2.88 million
samples: 344 and 586 MB, fog_static.toml); thermal, magnetic and supply channels add a few
arrays each, so :data:`SIMULATE_BYTES_PER_SAMPLE` is 256.
"""

from __future__ import annotations

import math
import os

from .errors import InputError

SIMULATE_BYTES_PER_SAMPLE = 256
#: assumed when the available memory cannot be read (not Linux)
FALLBACK_BYTES = 8 << 30


def available_memory() -> int:
    """Bytes of memory available to a new allocation now."""
    try:
        with open("/proc/meminfo", "rb") as fh:
            for line in fh:
                if line.startswith(b"MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return int(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return FALLBACK_BYTES


def max_samples(bytes_per_sample: int, *, cap: int | None = None) -> int:
    """Most samples that fit in the available memory at ``bytes_per_sample`` (≤ ``cap``)."""
    n = available_memory() // max(1, bytes_per_sample)
    return int(min(n, cap)) if cap is not None else int(n)


def check_samples(n: float, *, bytes_per_sample: int, what: str, fix: str,
                  cap: int | None = None) -> int:
    """``n`` samples as an int, or an InputError naming the limit when ``n`` is not finite or
    more than :func:`max_samples` allows."""
    limit = max_samples(bytes_per_sample, cap=cap)
    if not math.isfinite(n) or n > limit:
        shown = f"{n:.3g}" if math.isfinite(n) else "infinitely many"
        raise InputError(f"{what}: {shown} samples, more than this machine can hold now (limit "
                         f"{limit:,} samples at {bytes_per_sample} bytes each, "
                         f"{available_memory() / 2**30:.1f} GiB available); {fix}")
    return int(round(n))
