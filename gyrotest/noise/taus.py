"""Averaging-time (τ) grids for the deviations of :mod:`gyrotest.noise.deviations`.

Every deviation is evaluated at τ = m·τ0 with an integer averaging factor m ≥ 1 (Stable32's
"AF"). This module turns a grid specification into the sorted, unique m list:

============== =====================================================================
spec            averaging factors m
============== =====================================================================
``"octave"``    1, 2, 4, 8, … (powers of two)
``"decade"``    1, 2, 4, 10, 20, 40, 100, … (Stable32's decade grid)
``"decadeN"``   N log-spaced points per decade, rounded and made unique
                (``"decade10"`` is gyrotest's default; ``"decade20"``, ``"decade100"`` …)
``"all"``       every m = 1, 2, 3, … — the deviation then costs O(N²) in total: use it
                for short records only
sequence        explicit τ values in seconds, rounded to m = round(τ/τ0) and deduplicated;
                each τ that had to be moved is reported in the notes
============== =====================================================================

The largest m of a generated grid is set like Stable32 by a **stop ratio**: m_max =
floor(N / ratio), N the number of input samples (Riley, *Handbook of Frequency Stability
Analysis*, NIST SP1065, and Riley, "The evolution of frequency stability analysis software",
Table III). Stable32's ratios are in :data:`STOP_RATIOS`; ``stop_ratio=`` overrides them.
Explicit τ lists are not cut by the stop ratio (only by what the estimator can compute),
unless a stop ratio is passed explicitly.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..core.errors import InputError

__all__ = [
    "STOP_RATIOS",
    "TauGrid",
    "all_m",
    "decade_m",
    "max_averaging_factor",
    "m_from_taus",
    "octave_m",
    "per_decade_m",
    "tau_grid",
]

#: Stable32 stop ratios (max AF = N // ratio), Riley "Evolution of frequency stability analysis
#: software" Table III. gyrotest's Allan–Krobka (akdev) and Hadamard–Krobka (hkdev) dispersions
#: use the ratio of the deviation they are built from.
STOP_RATIOS: dict[str, int] = {
    "adev": 5,
    "oadev": 4,
    "mdev": 4,
    "tdev": 4,
    "hdev": 5,
    "ohdev": 4,
    "totdev": 2,
    "mtotdev": 2,
    "ttotdev": 2,
    "htotdev": 3,
    "tierms": 4,
    "mtie": 2,
    "theo1": 1,
    "theoh": 1,
    "gapadev": 4,
    "akdev": 4,
    "hkdev": 4,
}

_DECADE_RE = re.compile(r"^decade(\d+)$")


@dataclass(frozen=True)
class TauGrid:
    """A τ grid: integer averaging factors ``m`` (sorted, unique), the sample interval ``tau0``
    in seconds and ``notes`` (τ values that were moved or dropped, and why)."""

    m: np.ndarray
    tau0: float
    spec: str
    notes: tuple[str, ...] = field(default_factory=tuple)

    @property
    def tau(self) -> np.ndarray:
        """Averaging times τ = m·τ0 in seconds."""
        return self.m * self.tau0

    def __len__(self) -> int:
        return len(self.m)


def max_averaging_factor(n_data: int, kind: str = "oadev", stop_ratio: float | None = None) -> int:
    """Largest averaging factor of a generated grid: ``floor(n_data / stop_ratio)``.

    ``n_data`` is the number of input samples (rate, increment or angle samples: Stable32 counts
    the points of the file it was given). ``stop_ratio`` defaults to Stable32's ratio for
    ``kind`` (:data:`STOP_RATIOS`); it must be ≥ 1.
    """
    ratio = STOP_RATIOS.get(kind, 4) if stop_ratio is None else stop_ratio
    if not (ratio >= 1.0 and math.isfinite(ratio)):
        raise InputError(f"stop ratio must be a number >= 1, got {stop_ratio!r}")
    return int(math.floor(n_data / ratio))


def octave_m(m_max: int) -> np.ndarray:
    """Octave grid m = 1, 2, 4, …, 2^k ≤ m_max (empty if m_max < 1)."""
    if m_max < 1:
        return np.zeros(0, dtype=np.int64)
    k = int(math.floor(math.log2(m_max)))
    m = 2 ** np.arange(k + 1, dtype=np.int64)
    return m[m <= m_max]


def decade_m(m_max: int) -> np.ndarray:
    """Stable32 decade grid m = 1, 2, 4, 10, 20, 40, 100, … ≤ m_max."""
    out: list[int] = []
    p = 1
    while p <= m_max:
        out.extend(v for v in (p, 2 * p, 4 * p) if v <= m_max)
        p *= 10
    return np.array(out, dtype=np.int64)


def per_decade_m(m_max: int, n_per_decade: int = 10) -> np.ndarray:
    """``n_per_decade`` log-spaced factors per decade: m = unique(round(10^(k/n))) ≤ m_max.

    For n = 10 this gives 1, 2, 3, 4, 5, 6, 8, 10, 13, 16, 20, 25, 32, 40, 50, 63, 79, 100, …
    (the first decade has fewer than n points because of the rounding to integers).
    """
    if n_per_decade < 1:
        raise InputError(f"points per decade must be >= 1, got {n_per_decade}")
    if m_max < 1:
        return np.zeros(0, dtype=np.int64)
    kmax = int(math.floor(n_per_decade * math.log10(m_max) + 1e-9))
    m = np.unique(np.rint(10.0 ** (np.arange(kmax + 1) / n_per_decade)).astype(np.int64))
    return m[(m >= 1) & (m <= m_max)]


def all_m(m_max: int) -> np.ndarray:
    """Every averaging factor 1 … m_max. The deviations cost O(N) per τ, so this grid costs
    O(N·m_max) = O(N²) in total: keep it for short records."""
    return np.arange(1, max(m_max, 0) + 1, dtype=np.int64)


def m_from_taus(taus: Sequence[float] | np.ndarray, tau0: float) -> tuple[np.ndarray, list[str]]:
    """Round explicit τ values (seconds) to averaging factors m = round(τ/τ0).

    Returns the sorted unique m (≥ 1) and notes for every τ that had to be moved by more than
    0.1 % (or merged with another τ, or raised to τ0).
    """
    arr = np.asarray(taus, dtype=float).ravel()
    if arr.size == 0:
        raise InputError("empty τ list; give at least one averaging time in seconds")
    if not np.all(np.isfinite(arr)) or np.any(arr <= 0):
        raise InputError(f"τ values must be finite and > 0 s, got {arr.tolist()}")
    notes: list[str] = []
    ms = np.rint(arr / tau0).astype(np.int64)
    low = ms < 1
    if np.any(low):
        notes.append(
            f"τ = {', '.join(f'{t:g}' for t in arr[low])} s below τ0 = {tau0:g} s: raised to τ0"
        )
        ms[low] = 1
    moved = np.abs(ms * tau0 - arr) > 1e-3 * arr
    moved &= ~low
    if np.any(moved):
        pairs = ", ".join(f"{t:g} s → {mm * tau0:g} s" for t, mm in zip(arr[moved], ms[moved]))
        notes.append(f"τ rounded to a multiple of τ0 = {tau0:g} s: {pairs}")
    uniq = np.unique(ms)
    if uniq.size < ms.size:
        notes.append(f"{ms.size - uniq.size} τ value(s) merged after rounding to m = τ/τ0")
    return uniq, notes


def tau_grid(
    spec: str | Sequence[float] | np.ndarray,
    *,
    n_data: int,
    tau0: float,
    kind: str = "oadev",
    stop_ratio: float | None = None,
) -> TauGrid:
    """Build the τ grid for ``kind`` from a specification (see the module docstring).

    Parameters
    ----------
    spec : ``"octave"``, ``"decade"``, ``"decadeN"`` (e.g. ``"decade10"``), ``"all"``, or a
        sequence of τ in seconds.
    n_data : number of input samples N (sets m_max = N // stop_ratio for generated grids).
    tau0 : sample interval, s.
    kind : deviation name, selects the Stable32 stop ratio (:data:`STOP_RATIOS`).
    stop_ratio : overrides the stop ratio (applies to explicit lists too when given).

    The estimator's own limit (e.g. N − 2m ≥ 1 for OADEV) is applied later by the deviation,
    which drops such τ with a note.
    """
    if not (tau0 > 0 and math.isfinite(tau0)):
        raise InputError(f"sample interval tau0 must be > 0 s, got {tau0!r}")
    notes: list[str] = []
    if isinstance(spec, str):
        key = spec.strip().lower()
        m_max = max_averaging_factor(n_data, kind, stop_ratio)
        if key == "octave":
            m = octave_m(m_max)
        elif key == "decade":
            m = decade_m(m_max)
        elif key == "all":
            m = all_m(m_max)
        elif (match := _DECADE_RE.match(key)) is not None:
            m = per_decade_m(m_max, int(match.group(1)))
        elif key in ("log10",):
            m = per_decade_m(m_max, 10)
        else:
            raise InputError(
                f"unknown τ grid {spec!r}; use 'octave', 'decade', 'decadeN' (e.g. 'decade10'), "
                "'all' or a list of τ in seconds"
            )
        label = key
    else:
        m, notes = m_from_taus(spec, tau0)
        label = "explicit"
        if stop_ratio is not None:
            m_max = max_averaging_factor(n_data, kind, stop_ratio)
            cut = m[m > m_max]
            if cut.size:
                notes.append(
                    f"τ = {', '.join(f'{v * tau0:g}' for v in cut)} s dropped: beyond the stop "
                    f"ratio {stop_ratio:g} (m_max = {m_max})"
                )
                m = m[m <= m_max]
    return TauGrid(m=np.asarray(m, dtype=np.int64), tau0=float(tau0), spec=label, notes=tuple(notes))
