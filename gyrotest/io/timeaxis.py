"""The time axis: a time column to seconds (numbers or ISO-8601 timestamps), nominal
interval, gaps, jitter."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import pyarrow as pa

from ..core.data import Gap, Timing
from ..core.errors import InputError
from ..core.units import factor
from .rawtable import RawTable
from .tables import _column_to_float

GAP_FACTOR = 1.5  # an interval longer than this many nominal intervals is a gap
JITTER_WARN = 0.01  # relative std of the interval above which sampling is called irregular


#: Unix-epoch range taken as "a timestamp" when guessing the unit of a numeric time column:
#: 2000-01-01 … 2100-01-01 in seconds
EPOCH_MIN_S, EPOCH_MAX_S = 946_684_800.0, 4_102_444_800.0
#: sample rates outside this range are refused as a misread time axis (a unit error)
MIN_RATE_HZ, MAX_RATE_HZ = 1e-5, 1e8
#: the numeric time units gyrotest can guess, and their length in seconds
GUESS_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
TIME_UNIT_FIX = "give the unit with --time-unit s|ms|us|ns (or [gyro] time_unit in the profile)"


@dataclass
class TimeAxis:
    """A time column in seconds from its first value, and how it was read."""

    t: np.ndarray
    start: str | None = None  # ISO-8601 start when the column held timestamps (or epochs)
    unit: str = "s"  # the unit the numbers were read in ("ISO-8601" for timestamps)
    notes: list[str] = field(default_factory=list)


def _median_step(v: np.ndarray) -> float:
    """Median positive step of the first 10^5 values (cheap on 10^7-row logs); NaN if none."""
    d = np.diff(v[: 100_001])
    d = d[np.isfinite(d) & (d > 0)]
    return float(np.median(d)) if d.size else float("nan")


def guess_time_unit(first: float, step: float, sample_rate_hz: float | None = None
                    ) -> tuple[str | None, str]:
    """Guess the unit of a numeric time column without a stated unit.

    A given sample rate picks the unit whose spacing matches it within 1 %; otherwise a first
    value inside the Unix-epoch range (2000…2100) in exactly one of s/ms/µs/ns whose spacing
    gives a plausible sample rate is taken as an epoch in that unit. Returns (unit or None,
    reason); None means "seconds, not an epoch" (the caller still checks the rate).
    """
    if not (math.isfinite(step) and step > 0):
        return None, ""
    if sample_rate_hz:
        for u, f in GUESS_UNITS.items():
            if abs(1.0 / (step * f) - sample_rate_hz) <= 0.01 * sample_rate_hz:
                return u, f"its spacing matches the sample rate {sample_rate_hz:g} Hz"
    hits = [u for u, f in GUESS_UNITS.items()
            if EPOCH_MIN_S <= abs(first) * f <= EPOCH_MAX_S
            and MIN_RATE_HZ <= 1.0 / (step * f) <= MAX_RATE_HZ]
    if len(hits) == 1:
        return hits[0], "Unix-epoch magnitude and spacing"
    return None, ""


def check_rate(tau0: float, source: str, what: str) -> None:
    """Refuse a sample rate no bench log has (a misread time unit)."""
    rate = 1.0 / tau0 if tau0 > 0 else float("inf")
    if not (math.isfinite(tau0) and MIN_RATE_HZ <= rate <= MAX_RATE_HZ):
        raise InputError(f"{source}: implausible sample rate {rate:.4g} Hz (interval {tau0:.4g} s) "
                         f"from {what}; gyrotest accepts {MIN_RATE_HZ:g} to {MAX_RATE_HZ:g} Hz: "
                         f"{TIME_UNIT_FIX}")


def _iso_to_ns(raw: RawTable, col: str, s) -> tuple[np.ndarray, str, list[str]]:
    """ISO-8601 strings to int64 ns since the epoch (UTC when any row has a zone)."""
    import pandas as pd

    notes: list[str] = []
    try:
        ts = pd.to_datetime(s, format="ISO8601", utc=False)
    except (ValueError, TypeError) as e:
        ts = None
        if "mixed time" in str(e).lower() or "tz-aware" in str(e).lower() \
                or "timezone" in str(e).lower():
            # naive and zone-aware rows (or several zones): all to UTC, naive rows taken as UTC
            try:
                ts = pd.to_datetime(s, format="ISO8601", utc=True)
                notes.append(f"time column {col!r} mixes time zones (or zone-less rows): all "
                             "converted to UTC, rows without a zone taken as UTC")
            except (ValueError, TypeError):
                ts = None
        if ts is None:
            num = pd.to_numeric(s, errors="coerce")
            if num.notna().any() and num.isna().any():
                # a column of seconds with a stray text cell: name that cell, not the first row
                bad = num
            else:
                bad = pd.to_datetime(s, errors="coerce", format="ISO8601", utc=True)
            i = int(np.flatnonzero(bad.isna().to_numpy())[0]) if bad.isna().any() else 0
            raise InputError(f"{raw.source}: cannot read time {str(s.iloc[i])[:40]!r} in column "
                             f"{col!r}, {raw.where(i)}; use seconds or ISO-8601 timestamps") from None
    if ts.isna().any():
        i = int(np.flatnonzero(ts.isna().to_numpy())[0])
        raise InputError(f"{raw.source}: cannot read time {str(s.iloc[i])[:40]!r} in column "
                         f"{col!r}, {raw.where(i)}; use seconds or ISO-8601 timestamps")
    if getattr(ts.dt, "tz", None) is not None:
        ts = ts.dt.tz_convert("UTC").dt.tz_localize(None)
    ns = ts.to_numpy().astype("datetime64[ns]").astype(np.int64)
    return ns, str(ts.iloc[0].isoformat()), notes


def _time_seconds(raw: RawTable, col: str, unit: str | None = "s", *,
                  sample_rate_hz: float | None = None) -> TimeAxis:
    """The time column in seconds from its first value.

    ``unit`` None means "not stated": numbers are checked for a ms/µs/ns epoch
    (:func:`guess_time_unit`). Integer columns are differenced in int64 before the float
    conversion, so nanosecond epochs (≈1.7e18) keep their resolution.
    """
    arr = raw.table.column(col)
    t = arr.type
    what = f"column {col!r}"
    if arr.null_count:
        i = int(np.flatnonzero(arr.is_null().to_numpy(zero_copy_only=False))[0])
        raise InputError(f"{raw.source}: empty time value in column {col!r}, {raw.where(i)}; "
                         "every row needs a time")
    if pa.types.is_timestamp(t) or pa.types.is_date(t):
        ns = arr.cast(pa.timestamp("ns")).to_numpy().astype("datetime64[ns]").astype(np.int64)
        start = str(np.datetime64(int(ns[0]), "ns"))
        return TimeAxis((ns - ns[0]).astype(np.float64) * 1e-9, start, "ISO-8601")
    ints: np.ndarray | None = None
    if pa.types.is_string(t) or pa.types.is_large_string(t):
        import pandas as pd

        s = arr.to_pandas()
        num = pd.to_numeric(s, errors="coerce")
        if not num.notna().all():
            ns, start, notes = _iso_to_ns(raw, col, s)
            return TimeAxis((ns - ns[0]).astype(np.float64) * 1e-9, start, "ISO-8601", notes)
        if pd.api.types.is_integer_dtype(num.dtype):
            ints = num.to_numpy(dtype=np.int64)
        v = np.array(num.to_numpy(dtype=np.float64))  # a writeable copy: shifted in place
    elif pa.types.is_integer(t) and arr.null_count == 0:
        from .fastcsv import int64_values  # Arrow's to_numpy would import pandas

        ints = int64_values(arr)
        v = None
    else:
        v = _column_to_float(raw, col, "time")
    if v is not None:
        bad = ~np.isfinite(v)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise InputError(f"{raw.source}: invalid time value {v[i]!r} in column {col!r}, "
                             f"{raw.where(i)}; every row needs a finite time")
    first = float(ints[0]) if ints is not None else float(v[0])
    notes = []
    start = None
    if unit is None:
        step = _median_step(ints.astype(np.float64) if ints is not None and v is None else v)
        guess, why = guess_time_unit(first, step, sample_rate_hz)
        unit = guess or "s"
        if guess and why.startswith("Unix"):
            notes.append(f"time column {col!r} read as a Unix epoch in {guess} ({why}); "
                         f"override with --time-unit")
        elif guess and guess != "s":
            notes.append(f"time column {col!r} read in {guess} ({why}); override with --time-unit")
    f = factor(unit, "time", what=what)
    if EPOCH_MIN_S <= abs(first) * f <= EPOCH_MAX_S:
        start = str(np.datetime64(int(round(first * f * 1e3)), "ms"))
    if ints is not None:
        rel = ints - ints[0]  # exact in int64
        v = rel.astype(np.float64)
    else:
        v -= v[0]  # in place: no new 10^7-element arrays
    if f != 1.0:
        v *= f
    if not np.isfinite(v).all():
        i = int(np.flatnonzero(~np.isfinite(v))[0])
        raise InputError(f"{raw.source}: time value in column {col!r}, {raw.where(i)} is too far "
                         f"from the first one to be a time; fix the column or {TIME_UNIT_FIX}")
    return TimeAxis(v, start, unit, notes)


def analyse_timing(t: np.ndarray, source: str, where: Callable[[int], str],
                   tau0: float | None = None) -> tuple[Timing, np.ndarray]:
    """Nominal interval, gaps, jitter; raises on backwards time. Returns (Timing, keep mask for
    exact duplicate timestamps — the caller decides whether the duplicated rows are identical).
    """
    n = len(t)
    if n < 2:
        raise InputError(f"{source}: only {n} sample(s); a log needs at least 2")
    dt = np.diff(t)
    dmin, dmax = float(dt.min()), float(dt.max())
    if dmin > 0 and dmax <= dmin * (1 + 1e-6) and (tau0 is None or abs(dmin - tau0) <= 1e-6 * tau0):
        # uniform sampling (the common case): no median/partition over 10^7 intervals
        tau0 = (float(t[-1]) - float(t[0])) / (n - 1) if tau0 is None else tau0
        timing = Timing(n=n, tau0=tau0, duration_s=float(t[-1] - t[0] + tau0), source="",
                        jitter_rel=(dmax - dmin) / tau0 / math.sqrt(12.0))
        return timing, np.ones(n, dtype=bool)
    back = np.flatnonzero(dt < 0)
    if back.size:
        i = int(back[0]) + 1
        raise InputError(f"{source}: time goes backwards at {where(i)} ({t[i]:.6g} s after "
                         f"{t[i - 1]:.6g} s); sort the log by time or fix the logger")
    dup = dt == 0
    pos = dt[~dup]
    if pos.size == 0:
        raise InputError(f"{source}: all timestamps are equal")
    if tau0 is None:
        tau0 = float(np.median(pos))
    gap_idx = np.flatnonzero(dt > GAP_FACTOR * tau0)
    gaps = [Gap(index=int(i) + 1, time_s=float(t[i + 1]), duration_s=float(dt[i]),
                missing=int(round(dt[i] / tau0)) - 1) for i in gap_idx]
    inside = pos[pos <= GAP_FACTOR * tau0]
    jitter = float(np.std(inside) / tau0) if inside.size > 1 else 0.0
    keep = np.ones(n, dtype=bool)
    keep[1:][dup] = False
    timing = Timing(n=n, tau0=tau0, duration_s=float(t[-1] - t[0] + tau0), source="",
                    gaps=gaps, jitter_rel=jitter, irregular=jitter > JITTER_WARN)
    return timing, keep
