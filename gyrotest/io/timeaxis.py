"""The time axis: a time column to seconds (numbers or ISO-8601 timestamps), nominal
interval, gaps, jitter."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pyarrow as pa

from ..data import Gap, Timing
from ..errors import InputError
from ..units import factor
from .tables import RawTable, _column_to_float

GAP_FACTOR = 1.5  # an interval longer than this many nominal intervals is a gap
JITTER_WARN = 0.01  # relative std of the interval above which sampling is called irregular


def _time_seconds(raw: RawTable, col: str, unit: str) -> tuple[np.ndarray, str | None]:
    """The time column in seconds from its first value, plus the ISO start when timestamps."""
    arr = raw.table.column(col)
    t = arr.type
    if arr.null_count:
        i = int(np.flatnonzero(arr.is_null().to_numpy(zero_copy_only=False))[0])
        raise InputError(f"{raw.source}: empty time value in column {col!r}, {raw.where(i)}; "
                         "every row needs a time")
    if pa.types.is_timestamp(t) or pa.types.is_date(t):
        ns = arr.cast(pa.timestamp("ns")).to_numpy().astype("datetime64[ns]").astype(np.int64)
        start = str(np.datetime64(int(ns[0]), "ns"))
        return (ns - ns[0]).astype(np.float64) * 1e-9, start
    if pa.types.is_string(t) or pa.types.is_large_string(t):
        import pandas as pd

        s = arr.to_pandas()
        num = pd.to_numeric(s, errors="coerce")
        if num.notna().all():
            return num.to_numpy(dtype=np.float64) * factor(unit, "time", what=f"column {col!r}"), None
        try:
            ts = pd.to_datetime(s, format="ISO8601", utc=False)
        except (ValueError, TypeError):
            ts = pd.to_datetime(s, errors="coerce", format="ISO8601")
            i = int(np.flatnonzero(ts.isna().to_numpy())[0]) if ts.isna().any() else 0
            raise InputError(f"{raw.source}: cannot read time {str(s.iloc[i])[:40]!r} in column "
                             f"{col!r}, {raw.where(i)}; use seconds or ISO-8601 timestamps") from None
        if getattr(ts.dt, "tz", None) is not None:
            ts = ts.dt.tz_convert("UTC").dt.tz_localize(None)
        ns = ts.to_numpy().astype("datetime64[ns]").astype(np.int64)
        return (ns - ns[0]).astype(np.float64) * 1e-9, str(ts.iloc[0].isoformat())
    v = _column_to_float(raw, col, "time")
    bad = ~np.isfinite(v)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputError(f"{raw.source}: invalid time value in column {col!r}, {raw.where(i)}")
    f = factor(unit, "time", what=f"column {col!r}")
    v -= v[0]  # in place: no new 10^7-element arrays
    if f != 1.0:
        v *= f
    return v, None


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
