"""Settling time of each rate-table plateau, found from the data (IEEE 952 §12.9.3.1: "allow
the table and gyro to stabilise" before averaging).

After a command change the table (and the gyro's own filters) approach the new rate through a
transient: a first-order lag e^(−t/τ), an overshoot, a servo ringing. Averaging any of it biases
the plateau mean by far more than its standard error (an 800 deg/s reversal with τ = 2 s still
carries e^(−5)·800 deg/s after 10 s). :func:`find_settling` looks at the plateau itself:

1. block means m_j over blocks of T_b ≈ 1 s (at least 40 blocks per plateau);
2. the plateau's own noise floor from its settled end (the final half, shortened while it
   still contains the transient): the Allan deviation at T_b from the first differences
   Δm_j (IEEE 952 Annex C), σ_b = RMS₉₀(Δm − median Δm)/(0.789·√2) (the 90 % smallest
   deviations, so a spike or the transient's end does not count; a linear drift does not
   either), and the final level L (mean of the last eighth) with its standard error;
   The noise window must itself be flat (a fitted line may not change by more than 2k
   standard errors over it; else it is shortened by a quarter at a time, and a plateau still
   drifting over its last 12 blocks never settled);
3. a block is unsettled when |m_j − L| > k·√(σ_b² + σ_L²) (``k_sigma`` = 5: about 6e-7
   false alarms per block for Gaussian noise); the transient ends with the last unsettled block
   that is not an isolated spike (a run of two, or the first block);
4. when the transient is resolved (three or more unsettled blocks between 1 and 10⁴
   thresholds), log|m_j − L| is fitted with a straight line: its slope gives the time constant
   τ of the decay, and a margin Δ = τ·ln(k·τ/(β·√(T_b·T_w))) (β = 0.5) is added so that the
   remaining exponential tail biases the window mean by less than β standard errors
   (tail ∫ = k·σ_b·τ·e^(−Δ/τ) over a window T_w whose mean has SE σ_b·√(T_b/T_w)); the
   margin is capped to keep 10 % of the plateau, and the bound of the tail left in the mean
   is then reported.

The settling time is measured from the command change (or the start of the transition for
plateaus detected in the output) to the start of the window, in seconds. Units: the rates of the
log (deg/h), time s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass
class SettlingFound:
    """Settling of one plateau: ``found_s`` from the data, ``used_s`` the start of the
    averaging window after the change (≥ the --settle minimum), and the fitted decay."""

    found_s: float
    used_s: float = math.nan
    tau_s: float = math.nan  # fitted time constant of the transient (NaN: not resolved)
    detected_s: float = 0.0  # end of the last block outside the noise band
    margin_s: float = 0.0  # tail margin added after it
    noise_block_dph: float = math.nan  # σ_b, Allan deviation at the block length
    block_s: float = math.nan
    from_rate_dps: float = math.nan
    to_rate_dps: float = math.nan
    settled: bool = True  # False: the plateau never became stationary
    margin_capped: bool = False  # tail margin shortened to keep a window
    tail_bias_bound_dph: float = 0.0  # bound of the exponential tail left in the window mean

    def to_dict(self) -> dict:
        return {"from_rate_dps": self.from_rate_dps, "to_rate_dps": self.to_rate_dps,
                "settling_found_s": self.found_s, "settling_used_s": self.used_s,
                "transient_tau_s": self.tau_s, "outside_noise_band_until_s": self.detected_s,
                "tail_margin_s": self.margin_s, "noise_block_dph": self.noise_block_dph,
                "block_s": self.block_s, "settled": self.settled,
                "tail_margin_capped": self.margin_capped,
                "tail_bias_bound_dph": self.tail_bias_bound_dph}


def _noise(m: np.ndarray) -> float:
    """Allan deviation of block means from first differences Δm, robust to a few outliers and to
    quantized outputs: the RMS of the 90 % smallest |Δm − median Δm|, divided by 0.789 (the RMS
    of a normal variable truncated at its 90 % quantile is 0.789 σ) and by √2."""
    d = np.diff(m)
    if len(d) < 2:
        return 0.0
    a = np.sort(np.abs(d - np.median(d)))
    keep = a[: max(2, int(math.ceil(0.9 * len(a))))]
    return float(np.sqrt(np.mean(keep ** 2))) / 0.789 / math.sqrt(2.0)


def find_settling(y: np.ndarray, tau0: float, *, k_sigma: float = 5.0, beta: float = 0.2,
                  block_s: float = 1.0, min_blocks: int = 40,
                  min_window_frac: float = 0.1) -> SettlingFound:
    """Settling time (s from the first sample of ``y``) of one plateau's output ``y``, which
    starts at the command change and ends at the next one. See the module doc for the method.
    ``settled`` is False when the output is still outside its noise band within the final
    eighth of the plateau or leaves less than ``min_window_frac`` of it (the plateau is too
    short for its transient). The tail margin is capped so that ``min_window_frac`` of the
    plateau stays; ``tail_bias_bound_dph`` then says how much the remaining exponential tail
    may shift the window mean."""
    y = np.asarray(y, dtype=np.float64)
    n = len(y)
    B = max(1, min(int(round(block_s / tau0)), n // min_blocks))
    nb = n // B
    if nb < 8:
        return SettlingFound(found_s=0.0, block_s=B * tau0, settled=True)
    m = y[: nb * B].reshape(nb, B).mean(axis=1)
    Tb = B * tau0
    T = n * tau0
    n_lev = max(8, nb // 8)  # level from the final eighth (at least 8 blocks)
    j_noise = nb - max(16, nb // 2)  # noise floor from the final half (at least 16 blocks)
    last = -1
    sig = thr = 0.0
    L = float(np.mean(m[nb - n_lev:]))
    trending = False
    for _ in range(12):
        win = m[max(0, j_noise):]
        # a noise-free (e.g. clipped) output: a floor of 1e-9 of the level, not zero
        sig = max(_noise(win), 1e-9 * max(1.0, abs(float(np.median(win)))))
        # the noise window itself must be flat: a straight line over it may not change by
        # more than 2k standard errors of that change (σ_b·√(12/n) for white block noise)
        xx = np.arange(len(win), dtype=float)
        trend = abs(float(np.polyfit(xx, win, 1)[0])) * len(win)
        trending = trend > 2 * k_sigma * sig * math.sqrt(12.0 / len(win))
        if trending:
            if nb - j_noise <= 12:
                break
            j_noise = min(j_noise + max(2, (nb - j_noise) // 4), nb - 12)
            continue
        L = float(np.mean(m[nb - n_lev:]))
        sig_tot = math.hypot(sig, sig / math.sqrt(n_lev))
        thr = k_sigma * max(sig_tot, 1e-12 * max(1.0, abs(L)))
        out = np.abs(m - L) > thr
        idx = np.flatnonzero(out)
        last = -1
        for j in idx[::-1]:
            if j == 0 or out[j - 1]:
                last = int(j)
                break
        if last < j_noise or nb - (last + 1) < 16:
            break
        j_noise = last + 1  # the noise window still held the transient: use what follows
    detected = (last + 1) * Tb
    res = SettlingFound(found_s=detected, detected_s=detected, noise_block_dph=sig,
                        block_s=Tb)
    if trending:  # still drifting at the end of the plateau: never stationary
        return SettlingFound(found_s=T, detected_s=T, noise_block_dph=sig, block_s=Tb,
                             settled=False)
    res.settled = last < nb - n_lev and T - detected >= min_window_frac * T
    if last >= 0:
        dev = np.abs(m[: last + 1] - L)
        sel = np.flatnonzero((dev > thr) & (dev < 1e4 * thr))
        if len(sel) >= 3:  # the contiguous end of the decay
            brk = np.flatnonzero(np.diff(sel) > 1)
            sel = sel[brk[-1] + 1:] if len(brk) else sel
        if len(sel) >= 3:
            tt = (sel + 0.5) * Tb
            slope, icpt = np.polyfit(tt, np.log(dev[sel]), 1)
            if slope < 0:
                tau = -1.0 / slope
                Tw = max(Tb, T - detected)
                arg = k_sigma * tau / (beta * math.sqrt(Tb * Tw))
                margin = tau * math.log(arg) if arg > 1 else 0.0
                # keep at least min_window_frac of the plateau; say what the tail may leave
                cap = max(0.0, (1 - min_window_frac) * T - detected)
                if margin > cap:
                    res.margin_capped = True
                    margin = cap
                Tw = max(Tb, T - detected - margin)
                # amplitude at the detected end: the fitted decay there, at least the band
                # plus two noise scales (the last block outside may be just inside in truth)
                amp = max(thr * (k_sigma + 2) / k_sigma, math.exp(icpt + slope * detected))
                res.tail_bias_bound_dph = float(amp * tau * math.exp(-margin / tau) / Tw)
                res.tau_s = float(tau)
                res.margin_s = float(margin)
                res.found_s = float(detected + margin)
    return res
