"""Warm-up time after power-on (IEEE 952 §5.3.3 test conditions, "warm-up time"; IEEE Std 528:
the time from power-on until the sensor meets its performance): the time until the bias stays
within a stated band of its final value.

:func:`warmup_time` works on a static log that starts at power-on:

1. block means B_j of the rate over ``block_s`` (default 60 s), t_j their end times;
2. the final bias B_∞ = mean of the blocks in the last quarter of the record, and the block
   noise σ_B from their first differences (Allan deviation at the block length, robust:
   RMS of the 90 % smallest |ΔB − median| / 0.789 / √2);
3. the band: ``band_dph`` as stated (the spec's bias-stability requirement), else 3·σ_B (the
   tightest band the record can resolve);
4. warm-up = the end of the last block outside B_∞ ± band, not counting an isolated block (a
   spike: its neighbour before it inside); 0 when the bias is inside from the first block. A band below 2·σ_B cannot be resolved with these blocks
   (``resolvable`` False: longer blocks or a wider band).

Units: deg/h, s. Pure: arrays in, a dataclass out.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .errors import AnalysisError


@dataclass
class WarmupResult:
    """Warm-up time and how it was found."""

    status: str  # "ok", "not reached within the record", ...
    warmup_s: float
    band_dph: float
    band_source: str  # "stated" or "3 sigma of the block means"
    final_bias_dph: float
    block_s: float
    block_noise_dph: float
    resolvable: bool
    initial_offset_dph: float  # first block − final bias

    def to_dict(self) -> dict:
        return {"status": self.status, "warmup_time_s": self.warmup_s,
                "band_dph": self.band_dph, "band_source": self.band_source,
                "final_bias_dph": self.final_bias_dph, "block_s": self.block_s,
                "block_noise_dph": self.block_noise_dph, "band_resolvable": self.resolvable,
                "initial_offset_dph": self.initial_offset_dph,
                "definition": "time from power-on (start of the log) until the bias (block "
                              "means) stays within the band of its final value"}


def _block_noise(b: np.ndarray) -> float:
    d = np.diff(b)
    if len(d) < 2:
        return math.nan
    a = np.sort(np.abs(d - np.median(d)))
    keep = a[: max(2, int(math.ceil(0.9 * len(a))))]
    return float(np.sqrt(np.mean(keep ** 2))) / 0.789 / math.sqrt(2.0)


def warmup_time(rate_dph: np.ndarray, tau0: float, *, band_dph: float | None = None,
                block_s: float = 60.0) -> WarmupResult:
    """Warm-up time of a power-on log (rate in deg/h, sample interval ``tau0`` s); see the
    module doc. Raises AnalysisError for a record shorter than 16 blocks."""
    y = np.asarray(rate_dph, dtype=np.float64)
    B = max(1, int(round(block_s / tau0)))
    nb = len(y) // B
    if nb < 16:
        raise AnalysisError(f"the record has {nb} blocks of {block_s:g} s; the warm-up time "
                            "needs at least 16 (a longer record or shorter --block)")
    m = y[: nb * B].reshape(nb, B).mean(axis=1)
    Tb = B * tau0
    ref = m[nb - max(4, nb // 4):]
    final = float(np.mean(ref))
    sig = _block_noise(ref)
    if band_dph is None:
        band, src = 3.0 * sig, "3 sigma of the block means"
    else:
        band, src = float(band_dph), "stated"
    out = np.abs(m - final) > band
    last = -1
    for j in np.flatnonzero(out)[::-1]:
        if j == 0 or out[j - 1]:
            last = int(j)
            break
    res = WarmupResult("ok", (last + 1) * Tb, band, src, final, Tb, sig,
                       bool(band >= 2 * sig), float(m[0] - final))
    if not res.resolvable:
        res.status = (f"band {band:.3g} deg/h below 2 sigma of the {Tb:g} s block means "
                      f"({sig:.3g} deg/h): not resolvable; widen the band or lengthen the blocks")
        res.warmup_s = math.nan
    elif last >= nb - len(ref):
        res.status = ("not reached within the record (the bias still leaves the band in the "
                      "last quarter)")
        res.warmup_s = math.nan
    return res
