"""Warm-up of a gyro after power-on: detection in a static record, and the warm-up time.

**Detection** (:func:`detect_warmup`, used by ``gyrotest bias``). Warm-up detection: does a static record start with a settling transient?

A gyro switched on drifts while it warms up, typically an exponential approach to its running
bias, ω(t) = D + A·e^(−t/τ_w) (IEEE Std 952-1997 §8.3 "warm-up"; the model workbench's
``warmup`` term). A bias taken over a record that includes it is biased by A·τ_w/T.
:func:`detect_warmup` fits that curve to block means of the record and calls it a warm-up when

* the exponential beats a straight line through the same blocks (a ramp or a random walk is
  not a warm-up): Δχ² = (RSS_line − RSS_exp)/(RSS_exp/(n_blocks − 3)) ≥ ``min_gain``,
* |A| ≥ ``k_amp`` × the robust scatter of the block means of the record's second half
  (first differences, 1.4826·MAD/√2, so slow wander does not inflate it),
* the transient settles inside the record (3·τ_w ≤ T/2),

and suggests ``--skip`` = the time where |A|·e^(−t/τ_w) falls below one block-mean scatter.

**Warm-up time** (:func:`warmup_time`, a spec-sheet item). Warm-up time after power-on (IEEE 952 §5.3.3 test conditions, "warm-up time"; IEEE Std 528:
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
5. its 1σ: the block resolution B/√12 combined with the jitter of the band crossing,
   σ_B/|dB/dt| (slope of a line through the 10 blocks around the crossing). On simulated
   warm-ups (A = 0.35…2 °/h, τ_w = 900 s, bands 0.05/0.1 °/h, blocks 60…300 s, 40 seeds each)
   the error/σ has an RMS of 0.8…1.0 and 90…100 % of the times lie within 2σ.

Units: deg/h, s. Pure: arrays in, a dataclass out.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core.errors import AnalysisError

__all__ = ["WarmupDetection", "WarmupTime", "detect_warmup", "warmup_time"]

N_BLOCKS = 200
K_AMP = 3.0
MIN_GAIN = 30.0


@dataclass
class WarmupDetection:
    detected: bool
    amplitude_dph: float
    tau_s: float
    skip_s: float
    block_sigma_dph: float
    gain: float
    bias_shift_dph: float  # how much the transient moves the mean of the whole record

    def message(self) -> str:
        from ..core.units import format_duration

        return (f"the record starts with a warm-up transient: an exponential settling of "
                f"{self.amplitude_dph:+.3g} deg/h with time constant {format_duration(self.tau_s)}"
                f" (fit to block means; {self.amplitude_dph / self.block_sigma_dph:+.0f}× their "
                f"scatter) moves the mean of the whole record by {self.bias_shift_dph:+.3g} "
                f"deg/h; trim it: --skip {_minutes(self.skip_s)}")

    def to_dict(self) -> dict[str, Any]:
        return {"detected": self.detected, "amplitude_dph": self.amplitude_dph,
                "tau_s": self.tau_s, "suggested_skip_s": self.skip_s,
                "block_sigma_dph": self.block_sigma_dph, "gain_over_line": self.gain,
                "bias_shift_dph": self.bias_shift_dph,
                "method": "D + A·exp(−t/τ_w) vs a line on block means; warm-up when the "
                          "exponential wins, |A| is large against the block scatter and the "
                          "transient settles inside the record"}


def _minutes(s: float) -> str:
    return f"{math.ceil(s / 60.0)}min" if s >= 60 else f"{math.ceil(s)}s"


def detect_warmup(rate, tau0: float, *, n_blocks: int = N_BLOCKS, k_amp: float = K_AMP,
                  min_gain: float = MIN_GAIN) -> WarmupDetection | None:
    """Fit a warm-up transient to ``rate`` (deg/h at interval ``tau0``); None when the record is
    too short (< 40 blocks of 10 samples)."""
    x = np.asarray(rate, dtype=np.float64)
    n = x.size
    nb = min(n_blocks, n // 10)
    if nb < 40:
        return None
    L = n // nb
    m = x[: nb * L].reshape(nb, L).mean(axis=1)
    t = (np.arange(nb) + 0.5) * L * tau0
    T = nb * L * tau0
    second = m[nb // 2:]
    d = np.diff(second)
    sb = 1.4826 * float(np.median(np.abs(d - np.median(d)))) / math.sqrt(2.0)
    if not sb > 0:
        return None
    X1 = np.column_stack([np.ones(nb), t])
    rss_line = float(np.sum((m - X1 @ np.linalg.lstsq(X1, m, rcond=None)[0]) ** 2))
    best = (math.inf, 0.0, 0.0, 0.0)
    for tw in np.geomspace(2 * L * tau0, T / 6.0, 60):
        X = np.column_stack([np.ones(nb), np.exp(-t / tw)])
        c = np.linalg.lstsq(X, m, rcond=None)[0]
        rss = float(np.sum((m - X @ c) ** 2))
        if rss < best[0]:
            best = (rss, float(tw), float(c[1]), float(c[0]))
    rss_exp, tw, A, D = best
    # Δχ² of the exponential over the line, in units of the per-block residual variance
    gain = (rss_line - rss_exp) / max(rss_exp / (nb - 3), 1e-300)
    skip = tw * math.log(max(abs(A) / sb, 1.0)) if abs(A) > sb else 0.0
    shift = A * tw / T * (1.0 - math.exp(-T / tw))
    detected = bool(gain >= min_gain and abs(A) >= k_amp * sb and 3.0 * tw <= T / 2.0)
    return WarmupDetection(detected, A, tw, skip, sb, gain, shift)


@dataclass
class WarmupTime:
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
    #: 1σ of the time: block resolution B/√12 ⊕ block noise / |slope of the bias| at the crossing
    sigma_s: float = math.nan

    def to_dict(self) -> dict:
        return {"status": self.status, "warmup_time_s": self.warmup_s,
                "warmup_time_sigma_s": self.sigma_s if math.isfinite(self.sigma_s) else None,
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


def _time_sigma(m: np.ndarray, Tb: float, last: int, sig: float) -> float:
    """1σ of the warm-up time: the block resolution Tb/√12 combined with the timing jitter of
    a band crossing, σ_B/|dB/dt|, the slope from a line through the 10 blocks around the
    crossing (none when the bias is inside from the first block)."""
    res = Tb / math.sqrt(12.0)
    if last < 0 or not math.isfinite(sig):
        return res
    lo, hi = max(0, last - 4), min(len(m), last + 6)
    if hi - lo < 3:
        return res
    t = (np.arange(lo, hi) + 0.5) * Tb
    slope = abs(float(np.polyfit(t, m[lo:hi], 1)[0]))
    if not slope > 0:
        return res
    return float(math.hypot(res, min(sig / slope, len(m) * Tb)))


def warmup_time(rate_dph: np.ndarray, tau0: float, *, band_dph: float | None = None,
                block_s: float = 60.0) -> WarmupTime:
    """Warm-up time of a power-on log (rate in deg/h, sample interval ``tau0`` s); see the
    module doc. Raises AnalysisError for a record shorter than 16 blocks."""
    y = np.asarray(rate_dph, dtype=np.float64)
    B = max(1, int(round(block_s / tau0)))
    nb = len(y) // B
    if nb < 16:
        raise AnalysisError(f"the record has {nb} blocks of {block_s:g} s; the warm-up time "
                            "needs at least 16 (a longer record or shorter blocks, --warmup-block)")
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
    res = WarmupTime("ok", (last + 1) * Tb, band, src, final, Tb, sig,
                       bool(band >= 2 * sig), float(m[0] - final),
                       _time_sigma(m, Tb, last, sig))
    if not res.resolvable:
        res.status = (f"band {band:.3g} deg/h below 2 sigma of the {Tb:g} s block means "
                      f"({sig:.3g} deg/h): not resolvable; widen the band or lengthen the blocks")
        res.warmup_s = math.nan
    elif last >= nb - len(ref):
        res.status = ("not reached within the record (the bias still leaves the band in the "
                      "last quarter)")
        res.warmup_s = math.nan
    return res
