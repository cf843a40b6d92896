"""Which gyro axes of a log an analysis runs on, by name.

A log may hold several gyro axes (``GyroLog.rates``: ``gx, gy, gz`` or whatever the rate
columns are called). Every analysis command analyses every axis by default, or the ones named
with ``--axis`` (comma-separated), and names the axis in its tables, headings and JSON. This
module is the one place that parses ``--axis`` and checks the names against the logs.
"""

from __future__ import annotations

from collections.abc import Sequence

from .errors import InputError


def parse_axis_option(value: str | Sequence[str] | None) -> list[str] | None:
    """``"gx,gz"`` → ``["gx", "gz"]``; None or empty → None (every axis)."""
    if value is None:
        return None
    parts = value.split(",") if isinstance(value, str) else list(value)
    names = [str(p).strip() for p in parts if str(p).strip()]
    return names or None


def choose_axes(logs: Sequence, axis: str | Sequence[str] | None) -> list[str]:
    """The axis names to analyse in ``logs`` (:class:`~gyrotest.core.data.GyroLog` objects).

    With ``axis`` (``--axis``, comma-separated or a list) every name must be an axis of every
    log: otherwise an :class:`InputError` names the file and its axes. Without it: the axes
    common to all logs, in the first log's order; an error when the logs share none.
    """
    if not logs:
        return []
    wanted = parse_axis_option(axis)
    if wanted:
        for g in logs:
            missing = [a for a in wanted if a not in g.rates]
            if missing:
                raise InputError(
                    f"{g.source}: no axis {missing[0]!r}; axes are {', '.join(g.axes)} "
                    "(give one of them with --axis)")
        return list(dict.fromkeys(wanted))
    common = [a for a in logs[0].axes if all(a in g.rates for g in logs[1:])]
    if not common:
        listing = "; ".join(f"{g.source}: {', '.join(g.axes)}" for g in logs)
        raise InputError(f"the logs share no gyro axis ({listing}); name the rate columns "
                         "alike (--rate-col) or pick one log at a time")
    return common

