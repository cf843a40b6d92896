"""Warm-up detection: does a static record start with a settling transient?

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
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["WarmupResult", "detect_warmup"]

N_BLOCKS = 200
K_AMP = 3.0
MIN_GAIN = 30.0


@dataclass
class WarmupResult:
    detected: bool
    amplitude_dph: float
    tau_s: float
    skip_s: float
    block_sigma_dph: float
    gain: float
    bias_shift_dph: float  # how much the transient moves the mean of the whole record

    def message(self) -> str:
        from .units import format_duration

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
                  min_gain: float = MIN_GAIN) -> WarmupResult | None:
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
    return WarmupResult(detected, A, tw, skip, sb, gain, shift)
