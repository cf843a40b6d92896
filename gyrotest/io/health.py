"""Channel health: a dead or stuck gyro output, and magnitudes the arithmetic cannot carry.

Checked once, where every log is read (:func:`gyrotest.io.ingest.read_log`), so that no analysis
starts on a channel that cannot hold a result:

* **Overflow.** A value beyond ±:data:`MAX_ABS` in any channel is a logger's overflow or error
  code (or a wrong unit), not a measurement. The bound is set by the arithmetic, not by a
  sensor: least squares squares the regressors, which hold up to cubes of a channel (the T3
  term) or products of three, so a sum over up to 10⁹ samples of |x|⁶ must stay below
  float64's 1.8e308: |x|⁶·10⁹ < 1.8e308 needs |x| < 7e49; 1e40 leaves room for the unit
  factors (×3600, ×206265) applied after reading. Such cells are treated like ±inf (an
  overflowed cell): an error naming the column and row, or dropped/interpolated with ``--nan``.
* **Out of physical range.** A temperature below absolute zero or above 10 000 °C, a magnetic
  field beyond ±1 kT: no sensor reads that (:data:`PHYSICAL_RANGE`); an error code
  (-9999, 9.9e37) treated like an overflow.
* **Dead or stuck gyro output.** A rate that does not change over the whole run — all zeros, a
  constant, or values of 1e-300 whose squares underflow — carries no measurement: no noise,
  no bias uncertainty, no fit. A real gyro's output always moves
  (noise, quantisation); one that does not is disconnected, stuck or mis-scaled. The spread
  counts as zero when it is below 8 units in the last place of the channel's magnitude (the
  rounding of the unit conversion) or below 1e-40 deg/h in absolute terms (the mirror of
  :data:`MAX_ABS`: its sixth power stays a normal float64).
* **Saturated gyro output.** An output clipped at a rail sits at exactly its largest (or
  smallest) value for a run of consecutive samples. Off the rails the record's own repeats
  give the chance p that a sample equals the one before (0 for a continuous signal, large for
  a coarsely quantised one); k repeats in a row then have a chance of about n·p^k anywhere in
  n samples. A run at a rail with n·p^k < :data:`SATURATION_ALPHA` (10⁻⁶) is not noise: the
  input exceeded the gyro's range, or the logger clipped. Pulse outputs (counts, up/down,
  counters) are not checked: at a rate-table plateau whose noise is below one pulse per
  sample the count is legitimately the same for hundreds of samples, which no statistic of
  the record tells from a clipped one (a simulated low-rate campaign: 586 equal counts at
  the fastest plateau); counters do not clip, they roll over.
"""

from __future__ import annotations

import numpy as np

from ..core.errors import InputError

#: largest magnitude accepted in any channel, in the file's units and in internal units
MAX_ABS = 1e40
#: smallest spread (max - min) of a gyro output that counts as a changing signal, deg/h
MIN_SPREAD = 1e-40
#: family-wise chance below which a run of repeats at a rail is called saturation
SATURATION_ALPHA = 1e-6


def saturation(v: np.ndarray) -> tuple[float, int, int] | None:
    """(rail value, first sample, run length) of the longest run of repeats at the largest or
    smallest value of ``v`` when it is improbable under the record's own repeat rate (module
    docstring), else None."""
    n = v.size
    if n < 3:
        return None
    lo, hi = float(np.min(v)), float(np.max(v))
    at_rail = (v == hi) | (v == lo)
    if at_rail.sum() < 2:
        return None
    eq = v[1:] == v[:-1]
    rail_pair = eq & at_rail[1:]
    if not rail_pair.any():
        return None
    off = ~(at_rail[1:] | at_rail[:-1])
    m = int(off.sum())
    p = float((eq & off).sum()) / m if m else 1.0
    # the longest run of consecutive rail pairs: k repeats = k + 1 samples
    idx = np.flatnonzero(np.diff(np.concatenate(([0], rail_pair.astype(np.int8), [0]))))
    starts, ends = idx[::2], idx[1::2]
    j = int(np.argmax(ends - starts))
    k = int(ends[j] - starts[j])
    if n * p**k >= SATURATION_ALPHA:
        return None
    return float(v[starts[j]]), int(starts[j]), k + 1


#: what a sensor of each quantity can read, in internal units, and why: below absolute zero no
#: temperature exists and above 10 000 °C every sensor (and gyro) has melted (tungsten at
#: 3422 °C); 1e9 µT = 1 kT is ten times the strongest pulsed magnet (≈ 100 T)
PHYSICAL_RANGE = {
    "temperature": (-273.15, 1e4, "-273.15…10000 degC, what any thermometer can read"),
    "field": (-1e9, 1e9, "±1e9 uT (1 kT), beyond any magnet"),
}


def outside_physical(v: np.ndarray, unit: str, quantity: str) -> np.ndarray:
    """Finite values of ``v`` (in ``unit``) outside :data:`PHYSICAL_RANGE` of ``quantity``."""
    from ..core.units import to_internal

    lo, hi, _ = PHYSICAL_RANGE[quantity]
    with np.errstate(invalid="ignore", over="ignore"):
        x = to_internal(np.array(v, dtype=float), unit, quantity)
        return np.isfinite(x) & ((x < lo) | (x > hi))


def overflow_mask(v: np.ndarray) -> np.ndarray:
    """Finite values beyond ±MAX_ABS."""
    with np.errstate(invalid="ignore"):
        return np.abs(v) > MAX_ABS


def _spread(v: np.ndarray) -> tuple[float, float, float]:
    finite = v[np.isfinite(v)]
    if finite.size == 0:
        return float("nan"), float("nan"), float("nan")
    lo, hi = float(finite.min()), float(finite.max())
    return lo, hi, hi - lo


def is_constant(v: np.ndarray) -> bool:
    """True when the finite values of ``v`` do not change beyond float rounding."""
    lo, hi, spread = _spread(v)
    if not np.isfinite(spread):
        return False
    scale = max(abs(lo), abs(hi))
    return spread <= max(MIN_SPREAD, 8.0 * float(np.spacing(scale)))


def _fmt(x: float) -> str:
    return f"{x:.6g}"


def check_log(log, *, dead: str = "error") -> None:
    """Refuse (InputError) a log whose gyro output is dead or stuck (``dead="note"``: add a
    note instead, for ``info`` and ``ingest``), or whose channels hold values beyond ±MAX_ABS
    after the unit conversion (a scale factor of 1e300, say)."""
    names = log.column_map.get("gyro_output") or []
    channels = [(f"gyro output {a!r}", v) for a, v in log.rates.items()]
    channels += [(f"temperature {c!r}", v) for c, v in log.temperature.items()]
    channels += [(f"field {c!r}", v) for c, v in log.field_uT.items()]
    if log.supply is not None:
        channels.append((f"supply {log.column_map.get('supply')!r}", log.supply))
    if log.table_rate is not None:
        channels.append((f"table rate {log.column_map.get('table_rate')!r}", log.table_rate))
    for label, v in channels:
        big = overflow_mask(v) | np.isinf(v)
        if big.any():
            i = int(np.flatnonzero(big)[0])
            raise InputError(
                f"{log.source}: {label} reaches {_fmt(float(v[i]))} at sample {i + 1} after "
                f"the unit conversion, beyond ±{MAX_ABS:g} where the arithmetic overflows; "
                "check the unit and the scale factor")
    pulses = log.gyro.output_kind in ("counts", "updown", "counter")
    for axis, v in log.rates.items():
        if v.size < 2 or not is_constant(v):
            sat = None if pulses else saturation(v)
            if sat is None:
                continue
            col = names[0] if len(log.rates) == 1 and names else axis
            level, i, run = sat
            t = log.t
            what = (f"the gyro output {col!r} sits at {_fmt(level)} deg/h, its "
                    f"{'largest' if level == float(np.max(v)) else 'smallest'} value, for "
                    f"{run:,} samples in a row from sample {i + 1} (t = {_fmt(float(t[i]))} s): "
                    "saturated — the input exceeded the gyro's range, or the logger clipped")
            if dead == "error":
                raise InputError(f"{log.source}: {what}; cut that part or lower the input rate")
            log.notes.append(f"warning: {what}")
            continue
        lo, hi, _ = _spread(v)
        col = names[0] if len(log.rates) == 1 and names else axis
        level = _fmt(lo) if lo == hi else f"{_fmt(lo)}…{_fmt(hi)}"
        what = (f"the gyro output {col!r} is constant ({level} deg/h) over the whole run "
                f"({v.size:,} samples): is the channel connected, or the logger stuck?")
        if dead == "error":
            raise InputError(f"{log.source}: {what} Nothing can be analysed on it")
        log.notes.append(f"warning: {what}")
