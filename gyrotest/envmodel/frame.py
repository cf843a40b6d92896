"""The channels frame of the drift model: a uniformly sampled set of channels (full rate or
block means) split into contiguous segments at gaps, built from a :class:`~gyrotest.core.data.GyroLog`;
and the earth-rate projection along an input axis that changes direction during a log.

Conventions: time s, temperature degC, field uT, supply V, rates deg/h.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..core.errors import InputError

SEC_PER_HOUR = 3600.0


def _numeric(v) -> bool:
    try:
        return np.asarray(v).dtype.kind in "fiub"
    except Exception:  # pragma: no cover
        return False


@dataclass
class EnvFrame:
    """Channels on a uniform time grid (full rate or block means), split into segments.

    ``t`` s from the log start; ``dt`` grid spacing s; ``bounds`` contiguous (start, stop)
    index ranges (gaps between them); ``rate`` gyro rate deg/h (input rate removed when the
    log has a rate-table channel); temperatures degC; field uT (X, Y, Z order); supply V;
    table rate deg/h; extra channels in their own units.
    """

    t: np.ndarray
    dt: float
    bounds: list[tuple[int, int]]
    rate: np.ndarray | None = None
    temperature: dict[str, np.ndarray] = field(default_factory=dict)
    field_uT: dict[str, np.ndarray] = field(default_factory=dict)
    supply: np.ndarray | None = None
    table_rate: np.ndarray | None = None
    extra: dict[str, np.ndarray] = field(default_factory=dict)
    source: str = "log"
    #: earth-rate component along the IA per sample, deg/h, when the log has a position or
    #: IA-attitude channel and a site latitude (:func:`earth_projection`); else None
    earth_dph: np.ndarray | None = None
    #: temperature rates per channel (:mod:`gyrotest.envmodel.excursions`), computed on first use
    rate_cache: dict[str, np.ndarray] = field(default_factory=dict, init=False, repr=False,
                                              compare=False)

    @property
    def n(self) -> int:
        return len(self.t)

    @property
    def duration_s(self) -> float:
        return float(self.t[-1] - self.t[0] + self.dt) if self.n else 0.0

    def group(self, group: str) -> dict[str, np.ndarray]:
        return {"temperature": self.temperature, "field": self.field_uT,
                "extra": self.extra}[group]

    def channel_values(self, group: str, name: str) -> np.ndarray:
        """The values of one channel; InputError naming it when the log lacks it."""
        if group == "t":
            return self.t
        if group == "t_h":
            return self.t / SEC_PER_HOUR
        if group in ("supply", "table_rate"):
            v = getattr(self, group)
            if v is None:
                raise InputError(f"{self.source} has no {group.replace('_', ' ')} channel")
            return v
        chans = self.group(group)
        if name not in chans:
            have = ", ".join(chans) or "none"
            raise InputError(f"{self.source} has no {group} channel {name!r} "
                             f"({group} channels: {have})")
        return chans[name]


def frame_from_log(log, *, axis: str | None = None, dt: float | None = None,
                   subtract_table: bool = True) -> EnvFrame:
    """Build an :class:`EnvFrame` from a :class:`~gyrotest.core.data.GyroLog`.

    With ``dt`` (s) the channels are averaged over consecutive bins of m = round(dt/τ0)
    samples within each segment (a trailing part shorter than m/2 is dropped); otherwise the
    frame is at full rate. The gyro rate of ``axis`` (default: first) minus the rate-table
    rate (when present and ``subtract_table``) becomes ``rate``.
    """
    if axis is None:
        axis = log.axes[0]
    if axis not in log.rates:
        raise InputError(f"{log.source}: no gyro axis {axis!r} (axes: {', '.join(log.axes)})")
    rate = np.asarray(log.rates[axis], dtype=np.float64)
    if log.table_rate is not None and subtract_table:
        rate = rate - log.table_rate
    t = log.t
    m = 1 if dt is None else max(1, int(round(dt / log.tau0)))
    chans: dict[str, Any] = {
        "earth_dph": earth_projection(log),
        "rate": rate,
        "temperature": dict(log.temperature),
        "field_uT": dict(log.field_uT),
        "supply": log.supply,
        "table_rate": log.table_rate,
        "extra": {k: v for k, v in log.extra.items() if _numeric(v)},
    }
    if m == 1:
        return EnvFrame(t=np.asarray(t, float), dt=log.tau0, bounds=list(log.segments),
                        source=log.source, **chans)
    idx_parts, bounds, pos = [], [], 0
    seg_of = []
    for a, b in log.segments:
        nb = (b - a) // m
        rem = (b - a) - nb * m
        starts = a + m * np.arange(nb)
        if rem >= (m + 1) // 2:
            starts = np.append(starts, a + nb * m)
        if len(starts) == 0:
            continue
        idx_parts.append(starts)
        seg_of.append((a, b))
        bounds.append((pos, pos + len(starts)))
        pos += len(starts)
    if not idx_parts:
        raise InputError(f"{log.source}: too short for {dt:g} s bins")
    starts = np.concatenate(idx_parts)
    # bin ends: next start within the same segment, or the segment end
    ends = np.empty_like(starts)
    k = 0
    for (_a, b), part in zip(seg_of, idx_parts):
        e = np.append(part[1:], min(b, part[-1] + m))
        ends[k:k + len(part)] = e
        k += len(part)

    def binmean(x):
        if x is None:
            return None
        x = np.asarray(x, dtype=np.float64)
        c = np.concatenate([[0.0], np.cumsum(x - x[0])])
        return (c[ends] - c[starts]) / (ends - starts) + x[0]

    return EnvFrame(
        t=binmean(t), dt=m * log.tau0, bounds=bounds, source=log.source,
        rate=binmean(chans["rate"]),
        temperature={k: binmean(v) for k, v in chans["temperature"].items()},
        field_uT={k: binmean(v) for k, v in chans["field_uT"].items()},
        supply=binmean(chans["supply"]), table_rate=binmean(chans["table_rate"]),
        extra={k: binmean(v) for k, v in chans["extra"].items()},
        earth_dph=binmean(chans["earth_dph"]),
    )


_ELEV_NAMES = ("ia_elevation_deg", "ia_el_deg", "ia_elev_deg", "elevation_deg", "elev_deg")
_AZIM_NAMES = ("ia_azimuth_deg", "ia_az_deg", "ia_azim_deg", "azimuth_deg", "azim_deg")


def earth_projection(log) -> np.ndarray | None:
    """Earth-rate component along the input axis for every sample of ``log``, deg/h, when the
    IA direction changes during the log (a tumble or multi-position test): from the position
    labels (``up``, ``north``, ``AZ/EL``, ...) or from numeric IA elevation/azimuth channels
    (``ia_elevation_deg``, ``ia_azimuth_deg``), at the site latitude. None without a
    latitude or such a channel. Formula: Ω_IA = Ω_E (cos φ cos e cos A + sin φ sin e)
    (:func:`gyrotest.core.earth.earth_rate_component`)."""
    from ..core.earth import earth_rate_component, parse_ia

    site = getattr(log, "site", None)
    if site is None:
        return None
    lat = site.latitude_deg
    pos = getattr(log, "position", None)
    if pos is not None:
        labels = np.asarray(pos).astype(str)
        uniq, inv = np.unique(labels, return_inverse=True)
        vals = []
        for u in uniq:
            try:
                az, el, _ = parse_ia(u)
            except InputError:
                return None
            vals.append(earth_rate_component(lat, az, el))
        return np.asarray(vals, float)[inv]
    low = {k.lower(): k for k in log.extra}
    el_k = next((low[n] for n in _ELEV_NAMES if n in low), None)
    if el_k is None:
        return None
    el = np.asarray(log.extra[el_k], float)
    az_k = next((low[n] for n in _AZIM_NAMES if n in low), None)
    az = np.asarray(log.extra[az_k], float) if az_k else site.ia_azimuth_deg
    return np.asarray(earth_rate_component(lat, az, el), float)


# ============================================================================ channel lookup
def find_channel(frame: EnvFrame, name: str) -> tuple[str, np.ndarray]:
    """(group, values) of the channel ``name``: a temperature, field or extra channel, or
    ``supply`` / ``table_rate``. InputError listing the channels when there is none."""
    for group, chans in (("temperature", frame.temperature), ("field", frame.field_uT),
                         ("extra", frame.extra)):
        if name in chans:
            return group, np.asarray(chans[name], dtype=np.float64)
    if name == "supply" and frame.supply is not None:
        return "supply", np.asarray(frame.supply, dtype=np.float64)
    if name == "table_rate" and frame.table_rate is not None:
        return "table_rate", np.asarray(frame.table_rate, dtype=np.float64)
    have = list(frame.temperature) + list(frame.field_uT) + list(frame.extra)
    if frame.supply is not None:
        have.append("supply")
    if frame.table_rate is not None:
        have.append("table_rate")
    raise InputError(f"{frame.source} has no channel {name!r} (channels: "
                     f"{', '.join(have) or 'none'})")


def _white_sigma(frame: EnvFrame) -> float:
    """White-noise σ of the gyro rate per fine sample (deg/h): the robust scale of its first
    differences / √2 (steps and drifts do not count)."""
    r = np.asarray(frame.rate, float)
    d = np.concatenate([np.diff(r[a:b]) for a, b in frame.bounds if b - a > 1] or [[0.0]])
    return 1.4826 * float(np.median(np.abs(d - np.median(d)))) / math.sqrt(2.0)
