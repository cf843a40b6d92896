"""Short gaps in a bench log: the gap map, and bridging gaps of a few missed samples.

A logger that drops single samples (a busy bus, a full buffer) splits a long record into
short gap-free stretches: the Allan analysis, which never lets a difference span a gap, then
ends at a quarter of the longest stretch instead of a quarter of the record. 236 single missed
samples in 58 h end it at τ ≈ 1000 s. :func:`fill_gaps` bridges gaps of at most ``max_missing``
missing samples, with a stated effect:

* rate outputs (``rate``, ``voltage``): each missing rate sample is the linear interpolation of
  its neighbours. For white rate noise this changes the expected Allan variance at
  τ = m·τ0 by −1.5·f (τ = τ0) to +1.5·f·n/(n − 2m) (≤ +3·f at τ = T/4), f the filled fraction
  of the n samples: each filled sample enters 2m of the n − 2m + 1 overlapping differences,
  and a cluster sum holding it has the variance m + 1.5 instead of m (its neighbours weigh
  1.5). Noise correlated over more than a sample (flicker, random walk, Markov) is
  interpolated almost exactly. Checked against the gap-free record and the closed form N²/τ
  in tests/test_allan_mems.py and benchmarks/bench_gaps.py.
* cumulative outputs (``counter``, ``angle``): the angle across the gap is known; the sample
  after the gap carries the mean rate over the whole gap, and is split into missing + 1
  samples of that rate: the angle stays exact, only its split inside the gap is unknown.
* increment outputs (``counts``, ``updown``, ``delta-angle``): a missing increment is lost
  angle. Interpolating it adds a permanent angle step of the size of the white angle noise Q
  at every filled sample, which at long τ is not small against 3Q²/τ²: these logs are not
  bridged (``max_missing`` is ignored unless ``force``, Python API only), and the note says
  why.

Every other channel (temperature, field, supply, table rate, extras) is interpolated linearly,
positions repeat the previous label. The returned :class:`FillReport` states all of it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ..core.data import Gap, GyroLog

__all__ = ["FillReport", "fill_gaps", "gap_map", "DEFAULT_FILL"]

#: gaps of at most this many missed samples are bridged by default (``--fill``)
DEFAULT_FILL = 1
RATE_KINDS = ("rate", "voltage")
CUMULATIVE_KINDS = ("counter", "angle")
INCREMENT_KINDS = ("counts", "updown", "delta-angle")


def gap_map(log: GyroLog, max_missing: int = DEFAULT_FILL) -> dict[str, Any]:
    """The gaps of ``log`` in numbers: how many of each size (missed samples), the longest
    gap-free stretch, the missed samples in all, and which gaps ``--fill max_missing`` would
    bridge (with the stretch it would leave)."""
    tm = log.timing
    sizes: dict[int, int] = {}
    for g in tm.gaps:
        sizes[g.missing] = sizes.get(g.missing, 0) + 1
    segs = log.segments
    longest = max((b - a for a, b in segs), default=0)
    missing = sum(max(g.missing, 0) for g in tm.gaps)
    bridged = [g for g in tm.gaps if 0 < g.missing <= max_missing]
    cuts = [0] + [g.index for g in tm.gaps if g not in bridged] + [log.n]
    after = 0
    for a, b in zip(cuts[:-1], cuts[1:]):
        after = max(after, (b - a) + sum(g.missing for g in bridged if a < g.index < b))
    largest = sorted(tm.gaps, key=lambda g: -g.duration_s)[:5]
    return {
        "n_gaps": len(tm.gaps),
        "by_missing_samples": {str(k): v for k, v in sorted(sizes.items())},
        "missing_samples": int(missing),
        "missing_fraction": missing / max(log.n + missing, 1),
        "longest_gap_free_samples": int(longest),
        "longest_gap_free_s": longest * log.tau0,
        "fill_max_missing": int(max_missing),
        "bridged_by_fill": len(bridged),
        "longest_after_fill_s": after * log.tau0,
        "largest": [g.to_dict() for g in largest],
    }


@dataclass
class FillReport:
    """What :func:`fill_gaps` did: ``filled`` gaps bridged with ``samples`` new samples
    (``fraction`` of the filled record), ``method``, ``effect`` on σ, ``kept`` gaps left
    (longer than ``max_missing``), ``skipped`` why nothing was filled (or None)."""

    max_missing: int
    filled: int = 0
    samples: int = 0
    fraction: float = 0.0
    method: str = ""
    effect: str = ""
    kept: int = 0
    skipped: str | None = None
    gaps: list[dict[str, Any]] = field(default_factory=list)
    #: per sample of the filled log: recorded (True) or filled (False); None if nothing filled
    present: np.ndarray | None = field(default=None, repr=False)
    #: the gap-free segments of the log before filling (indices of the recorded samples)
    segments_before: list[tuple[int, int]] = field(default_factory=list)

    def note(self) -> str:
        if self.skipped:
            return self.skipped
        return (f"{self.filled} gap(s) of ≤ {self.max_missing} missed sample(s) bridged "
                f"({self.samples} sample(s), {100 * self.fraction:.3g} % of the record; "
                f"{self.method}); {self.effect}"
                + (f"; {self.kept} longer gap(s) still split the record" if self.kept else "")
                + " (--fill 0 never bridges)")

    def to_dict(self) -> dict[str, Any]:
        return {"max_missing": self.max_missing, "filled_gaps": self.filled,
                "filled_samples": self.samples, "filled_fraction": self.fraction,
                "method": self.method, "effect_on_sigma": self.effect, "gaps_kept": self.kept,
                "skipped": self.skipped, "note": self.note()}


def white_rate_effect(fraction: float) -> str:
    """The stated effect of linear interpolation on σ (module docstring)."""
    return (f"for white rate noise this moves σ²(τ) by −1.5·f at τ0 to at most +3·f at T/4, "
            f"f = {fraction:.3g} (σ by ≤ {100 * 1.5 * fraction:.2g} %); correlated noise is "
            "interpolated almost exactly")


def fill_gaps(log: GyroLog, max_missing: int = DEFAULT_FILL, *, force: bool = False
              ) -> tuple[GyroLog, FillReport]:
    """``log`` with its gaps of 1 … ``max_missing`` missed samples bridged (module
    docstring), and the report. Gaps whose length is not a whole number of sample intervals
    (more than ±0.25 τ0 off) are left alone. Increment outputs are bridged only with
    ``force``. Returns ``log`` itself when nothing is filled."""
    rep = FillReport(max_missing=int(max_missing))
    tm = log.timing
    kind = log.gyro.output_kind
    cand = [g for g in tm.gaps if 1 <= g.missing <= max_missing
            and abs(g.duration_s / log.tau0 - (g.missing + 1)) <= 0.25]
    rep.kept = len(tm.gaps) - len(cand)
    if max_missing <= 0 or not cand:
        return log, rep
    if kind in INCREMENT_KINDS and not force:
        rep.skipped = (f"{len(cand)} gap(s) of ≤ {max_missing} missed sample(s) not bridged: a "
                       f"missed {kind} sample is lost angle, and filling it would add a "
                       "permanent angle step of the white angle noise's size at every gap "
                       "(the long-τ σ of quantization noise would be biased); the gaps split "
                       "the record")
        return log, rep
    n = log.n
    t_old = log.t
    # index map: old sample i goes to i + (missed samples of the filled gaps before it)
    shift = np.zeros(n, dtype=np.int64)
    for g in cand:
        shift[g.index:] += g.missing
    new_n = n + int(sum(g.missing for g in cand))
    pos = np.arange(n) + shift
    present = np.zeros(new_n, dtype=bool)
    present[pos] = True
    grid = np.arange(new_n)

    def interp(v: np.ndarray) -> np.ndarray:
        v = np.asarray(v, dtype=np.float64)
        out = np.empty(new_n, dtype=np.float64)
        out[pos] = v
        miss = ~present
        out[miss] = np.interp(grid[miss], pos, v)
        return out

    rates: dict[str, np.ndarray] = {}
    for k, v in log.rates.items():
        if kind in CUMULATIVE_KINDS:
            out = np.empty(new_n, dtype=np.float64)
            out[pos] = v
            for g in cand:  # the sample after the gap holds the mean over the whole gap
                j = int(pos[g.index])
                out[j - g.missing:j + 1] = v[g.index]
            rates[k] = out
        else:
            rates[k] = interp(v)
    time = None
    if log.time is not None:
        time = interp(t_old)
    if kind in CUMULATIVE_KINDS:
        rep.method = ("the mean rate over each gap (from the cumulative angle) split evenly "
                      "over its samples: the angle is exact")
        rep.effect = "σ is unchanged beyond the split inside each gap (a sample or two)"
    else:
        rep.method = "linear interpolation of the rate between the neighbours"
        rep.effect = ""
    pos_labels = None
    if log.position is not None:
        pos_labels = np.empty(new_n, dtype=object)
        pos_labels[pos] = log.position
        last = None
        for i in range(new_n):  # repeat the previous label (a few samples)
            if present[i]:
                last = pos_labels[i]
            else:
                pos_labels[i] = last
    kept_gaps = []
    for g in tm.gaps:
        if g in cand:
            continue
        j = int(pos[g.index])
        kept_gaps.append(Gap(index=j, time_s=g.time_s, duration_s=g.duration_s,
                             missing=g.missing))
    filled = int(sum(g.missing for g in cand))
    rep.filled, rep.samples = len(cand), filled
    rep.present = present
    rep.segments_before = log.segments
    rep.fraction = filled / new_n
    if not rep.effect:
        rep.effect = white_rate_effect(rep.fraction)
    rep.gaps = [g.to_dict() for g in cand[:20]]
    if time is not None:
        dur = float(time[-1] - time[0]) + log.tau0
    else:
        dur = new_n * log.tau0
    timing = replace(tm, n=new_n, gaps=kept_gaps, duration_s=dur)
    new = GyroLog(
        source=log.source, rates=rates, tau0=log.tau0, timing=timing, gyro=log.gyro,
        time=time, temperature={k: interp(v) for k, v in log.temperature.items()},
        field_uT={k: interp(v) for k, v in log.field_uT.items()},
        supply=None if log.supply is None else interp(log.supply),
        table_rate=None if log.table_rate is None else interp(log.table_rate),
        position=pos_labels, extra={k: interp(v) for k, v in log.extra.items()},
        site=log.site, column_map=dict(log.column_map), units=dict(log.units),
        notes=list(log.notes) + [rep.note()], meta=dict(log.meta))
    for name in ("accels",):  # channels added by later layers (accelerometers)
        if hasattr(log, name) and getattr(log, name):
            setattr(new, name, {k: interp(v) for k, v in getattr(log, name).items()})
    if not math.isfinite(rep.fraction):
        rep.fraction = 0.0
    return new, rep
