"""The in-memory bench log every analysis works on.

:class:`GyroLog` holds the gyro output converted to angular rate in deg/h (one array per
axis), the sample interval, the auxiliary channels by role in internal units, the gyro and site
constants, and what ingest found about the timing (gaps, jitter). It knows nothing about files
or terminals; :mod:`gyrotest.io.ingest` builds it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .earth import Site


@dataclass
class Gap:
    """A hole in the time axis: samples ``index-1`` and ``index`` are ``duration_s`` apart
    although the nominal interval is ``tau0``."""

    index: int  # first sample after the gap (0-based)
    time_s: float  # time of that sample, s from the start
    duration_s: float  # time between the samples either side
    missing: int  # samples that would fit in the hole

    def to_dict(self) -> dict:
        return {"index": self.index, "time_s": self.time_s, "duration_s": self.duration_s,
                "missing_samples": self.missing}


@dataclass
class Timing:
    """What ingest found about the time axis."""

    n: int
    tau0: float  # nominal sample interval, s
    duration_s: float
    source: str  # "time column 't_s'" or "sample rate 10 Hz"
    gaps: list[Gap] = field(default_factory=list)
    jitter_rel: float = 0.0  # std of the sample interval / tau0 (outside gaps)
    irregular: bool = False
    duplicates_dropped: int = 0
    start: str | None = None  # ISO timestamp of the first sample when the log has one

    @property
    def sample_rate_hz(self) -> float:
        return 1.0 / self.tau0

    def to_dict(self) -> dict:
        return {
            "samples": self.n,
            "tau0_s": self.tau0,
            "sample_rate_hz": self.sample_rate_hz,
            "duration_s": self.duration_s,
            "time_source": self.source,
            "gaps": [g.to_dict() for g in self.gaps],
            "jitter_rel": self.jitter_rel,
            "irregular": self.irregular,
            "duplicates_dropped": self.duplicates_dropped,
            "start": self.start,
        }


@dataclass
class GyroConstants:
    """The gyro's output kind and the constants that turn it into rate."""

    output_kind: str  # rate | counts | updown | counter | voltage | delta-angle | angle
    scale_factor: float | None = None  # arcsec/pulse (pulse kinds) or (deg/h)/V (voltage)
    scale_factor_unit: str | None = None
    offset_v: float | None = None
    rate_unit: str | None = None  # unit of the original rate column
    counter_bits: int | None = None
    model: str | None = None
    serial: str | None = None
    type: str | None = None
    #: the log starts at the gyro's power-on (a warm-up transient is a candidate effect)
    power_on_at_start: bool | None = None

    @property
    def angle_quantum_arcsec(self) -> float | None:
        """Angle per output pulse (arcsec) for pulse outputs, else None. Quantization noise
        of an ideal pulse integrator has Q = S0/√12 (IEEE 952 Annex C)."""
        if self.output_kind in ("counts", "updown", "counter"):
            return self.scale_factor
        return None

    def to_dict(self) -> dict:
        d = {k: v for k, v in self.__dict__.items() if v is not None}
        if self.angle_quantum_arcsec is not None:
            d["angle_quantum_arcsec"] = self.angle_quantum_arcsec
        return d


@dataclass
class GyroLog:
    """A bench log in internal units.

    ``rates`` maps axis name to the gyro rate in deg/h per sample (the average rate over the
    sample interval). ``time`` is seconds from the first sample, or None for a uniformly
    sampled log without a time column (use :attr:`t`). Auxiliary channels are in internal
    units: temperatures degC, field uT (keys are the column names, in X, Y, Z order), supply
    V, table rate deg/h.
    """

    source: str
    rates: dict[str, np.ndarray]
    tau0: float
    timing: Timing
    gyro: GyroConstants
    time: np.ndarray | None = None
    temperature: dict[str, np.ndarray] = field(default_factory=dict)
    field_uT: dict[str, np.ndarray] = field(default_factory=dict)
    supply: np.ndarray | None = None
    table_rate: np.ndarray | None = None  # deg/h
    position: np.ndarray | None = None  # labels (object array of str)
    extra: dict[str, np.ndarray] = field(default_factory=dict)
    site: Site | None = None
    column_map: dict[str, Any] = field(default_factory=dict)
    units: dict[str, str] = field(default_factory=dict)  # original column -> unit
    notes: list[str] = field(default_factory=list)
    meta: dict[str, Any] = field(default_factory=dict)

    # ------------------------------------------------------------------ basics
    @property
    def n(self) -> int:
        return len(next(iter(self.rates.values())))

    @property
    def axes(self) -> list[str]:
        return list(self.rates)

    @property
    def rate(self) -> np.ndarray:
        """The first (primary) axis' rate, deg/h."""
        return next(iter(self.rates.values()))

    @property
    def t(self) -> np.ndarray:
        """Time of each sample, s from the first sample."""
        if self.time is not None:
            return self.time
        return np.arange(self.n, dtype=np.float64) * self.tau0

    @property
    def duration_s(self) -> float:
        return self.timing.duration_s

    @property
    def segments(self) -> list[tuple[int, int]]:
        """Contiguous, uniformly sampled stretches as (start, stop) index ranges: the log
        split at its gaps. Analyses that need uniform sampling work per segment or pool."""
        cuts = [0] + [g.index for g in self.timing.gaps] + [self.n]
        return [(a, b) for a, b in zip(cuts[:-1], cuts[1:]) if b > a]

    def channel(self, name: str) -> np.ndarray | None:
        """Look up any auxiliary channel by its column name."""
        for group in (self.temperature, self.field_uT, self.extra):
            if name in group:
                return group[name]
        if name in self.rates:
            return self.rates[name]
        return None

    def slice(self, start: int, stop: int | None = None) -> GyroLog:
        """A new log with samples ``start:stop`` (gaps and time re-based accordingly)."""
        stop = self.n if stop is None else min(stop, self.n)
        start = max(0, start)
        sl = slice(start, stop)
        t_full = self.t
        t0 = float(t_full[start]) if stop > start else 0.0
        time = None if self.time is None else self.time[sl] - t0
        gaps = [
            Gap(g.index - start, g.time_s - t0, g.duration_s, g.missing)
            for g in self.timing.gaps
            if start < g.index < stop
        ]
        n = stop - start
        dur = (float(t_full[stop - 1]) - t0 + self.tau0) if n else 0.0
        timing = Timing(
            n=n, tau0=self.tau0, duration_s=dur, source=self.timing.source, gaps=gaps,
            jitter_rel=self.timing.jitter_rel, irregular=self.timing.irregular,
            duplicates_dropped=self.timing.duplicates_dropped, start=self.timing.start,
        )

        def cut(d):
            return {k: v[sl] for k, v in d.items()}

        return GyroLog(
            source=self.source, rates=cut(self.rates), tau0=self.tau0, timing=timing,
            gyro=self.gyro, time=time, temperature=cut(self.temperature),
            field_uT=cut(self.field_uT),
            supply=None if self.supply is None else self.supply[sl],
            table_rate=None if self.table_rate is None else self.table_rate[sl],
            position=None if self.position is None else self.position[sl],
            extra=cut(self.extra), site=self.site, column_map=dict(self.column_map),
            units=dict(self.units), notes=list(self.notes), meta=dict(self.meta),
        )

    def skip(self, seconds: float) -> GyroLog:
        """Drop the first ``seconds`` (warm-up trim)."""
        if seconds <= 0:
            return self
        idx = int(np.searchsorted(self.t, seconds - 1e-9 * self.tau0, side="left"))
        return self.slice(idx)

    def summary(self) -> dict:
        """Channels with their ranges, for ``gyrotest info`` and reports."""
        def stats(a, unit):
            a = np.asarray(a, dtype=float)
            return {"unit": unit, "min": float(np.min(a)), "mean": float(np.mean(a)),
                    "max": float(np.max(a)), "std": float(np.std(a))}

        ch: dict[str, Any] = {}
        for k, v in self.rates.items():
            ch[f"rate:{k}"] = stats(v, "deg/h")
        for k, v in self.temperature.items():
            ch[f"temperature:{k}"] = stats(v, "degC")
        for k, v in self.field_uT.items():
            ch[f"field:{k}"] = stats(v, "uT")
        if self.supply is not None:
            ch["supply"] = stats(self.supply, "V")
        if self.table_rate is not None:
            ch["table_rate"] = stats(self.table_rate / 3600.0, "deg/s")
        for k, v in self.extra.items():
            ch[f"extra:{k}"] = stats(v, self.units.get(k, ""))
        out = {
            "source": self.source,
            "timing": self.timing.to_dict(),
            "gyro": self.gyro.to_dict(),
            "site": self.site.to_dict() if self.site else None,
            "columns": self.column_map,
            "channels": ch,
            "notes": self.notes,
        }
        if self.position is not None:
            labels, counts = np.unique(self.position.astype(str), return_counts=True)
            out["positions"] = {str(a): int(c) for a, c in zip(labels, counts)}
        return out
