"""Where a model fails: stretches of large residual, described by what the channels did.

Rule: the block residual is smoothed with a centred moving mean over w blocks (w ≈ 1 min,
at least 3 blocks); σ is the RMS that the white and flicker part of the fitted noise model
leaves at the working resolution (:func:`gyrotest.envmodel.floor.floor_rms`; or, without one,
1.4826·MAD of the smoothed series); an excursion is a run where
|smoothed residual| > k·σ (k = 4 on the command line), runs closer than 3·w blocks are merged. Each
excursion is described from the channels over the same time: temperature ramp up/down or
turn-around (from the smoothed dT/dt), field steps per axis, supply or rate-table changes,
and the warm-up period when the log starts at power-on.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .terms import temperature_rate


@dataclass
class Excursion:
    """A stretch where the residual exceeds k·σ, with what the channels were doing."""

    t_start_s: float
    t_end_s: float
    peak_dph: float
    mean_dph: float
    description: str

    def to_dict(self) -> dict:
        return {"t_start_s": self.t_start_s, "t_end_s": self.t_end_s, "peak_dph": self.peak_dph,
                "mean_dph": self.mean_dph, "description": self.description}


def _moving_mean(x: np.ndarray, w: int) -> np.ndarray:
    if w <= 1:
        return x.copy()
    c = np.concatenate([[0.0], np.cumsum(x)])
    n = len(x)
    k = np.arange(n)
    lo = np.maximum(k - w // 2, 0)
    hi = np.minimum(k + w // 2 + 1, n)
    return (c[hi] - c[lo]) / (hi - lo)


def excursion_runs(resid: np.ndarray, resolution_s: float, k_sigma: float = 3.0,
                   sigma: float | None = None
                   ) -> tuple[list[tuple[int, int]], np.ndarray, float]:
    """Runs (start, stop block indices) where the smoothed residual exceeds k·σ; σ is the
    noise floor when given (``sigma``), else 1.4826·MAD of the smoothed residual. Also returns
    the smoothed residual and σ (deg/h)."""
    n = len(resid)
    w = int(max(3, min(round(60.0 / resolution_s), max(3, n // 20))))
    rs = _moving_mean(resid, w)
    if sigma is not None and np.isfinite(sigma) and sigma > 0:
        sig = float(sigma)
    else:
        sig = 1.4826 * float(np.median(np.abs(rs - np.median(rs))))
    if not sig > 0:
        return [], rs, sig
    over = np.abs(rs) > k_sigma * sig
    runs: list[tuple[int, int]] = []
    i = 0
    while i < n:
        if over[i]:
            j = i
            while j < n and over[j]:
                j += 1
            if runs and i - runs[-1][1] < 3 * w:
                runs[-1] = (runs[-1][0], j)
            else:
                runs.append((i, j))
            i = j
        else:
            i += 1
    runs = [(a, b) for a, b in runs if b - a >= 2]
    return runs, rs, sig


def describe_interval(frame, refs, t1: float, t2: float, power_on: bool = False) -> str:
    """What the logged channels did between t1 and t2 (s): ramps, steps, and the warm-up
    when the log starts at the gyro's power-on (``power_on``)."""
    parts: list[str] = []
    t = frame.t
    pad = max(frame.dt, 0.5 * refs.smoothing_s)
    sel = (t >= t1 - pad) & (t <= t2 + pad)
    if not sel.any():
        return "no data"
    inside = (t >= t1) & (t <= t2)
    if not inside.any():
        inside = sel
    cache = frame.rate_cache
    for name, T in list(frame.temperature.items())[:1]:
        if name not in cache:
            cache[name] = temperature_rate(T, frame.dt, refs.smoothing_s, frame.bounds)
        r = cache[name][inside]
        thr = max(0.5, refs.hyst_threshold_c_per_h.get(name, 0.1))
        rm = float(np.mean(r))
        ta, tb = float(T[inside][0]), float(T[inside][-1])
        if np.any(r > thr) and np.any(r < -thr):
            parts.append(f"temperature turn-around ({name} near {np.mean(T[inside]):.1f} °C)")
        elif rm > thr:
            parts.append(f"temperature ramp up ({rm:+.2g} °C/h, {name} {ta:.1f}→{tb:.1f} °C)")
        elif rm < -thr:
            parts.append(f"temperature ramp down ({rm:+.2g} °C/h, {name} {ta:.1f}→{tb:.1f} °C)")
        else:
            before = (t >= t1 - 4 * refs.smoothing_s) & (t < t1)
            if before.any() and np.max(np.abs(cache[name][before])) > thr:
                parts.append(f"settling after a temperature change ({name} {ta:.1f} °C)")
    # steps are reported where the excursion begins (a step in the middle of a long ramp
    # excursion is incidental)
    onset = (t >= t1 - pad) & (t <= min(t2, t1 + max(3 * pad, 0.2 * (t2 - t1))) + pad)
    if onset.any():
        sel = onset
    for name, H in frame.field_uT.items():
        seg = H[sel]
        span = float(np.ptp(H)) if len(H) else 0.0
        jump = float(seg.max() - seg.min())
        if span > 0 and jump > max(5.0, 0.05 * span):
            parts.append(f"field step in {name} ({seg[0]:+.0f}→{seg[-1]:+.0f} µT)")
        elif span > 0 and abs(float(np.median(seg)) - float(np.median(H))) > 0.25 * span:
            parts.append(f"{name} held at {np.median(seg):+.0f} µT")
    if frame.supply is not None:
        seg = frame.supply[sel]
        if float(seg.max() - seg.min()) > max(0.02, 0.005 * abs(float(np.median(seg)))):
            parts.append(f"supply change ({seg[0]:.3g}→{seg[-1]:.3g} V)")
    if frame.table_rate is not None:
        seg = frame.table_rate[sel]
        if float(seg.max() - seg.min()) > 1e-3 * max(1.0, float(np.abs(frame.table_rate).max())):
            parts.append("rate-table step")
    t_on = refs.t_on_s
    if power_on and t1 - t_on < max(600.0, 0.03 * frame.duration_s):
        parts.append(f"warm-up ({(t1 - t_on) / 60:.0f}–{(t2 - t_on) / 60:.0f} min after power-on)")
    if not parts:
        return "no logged channel changes (noise, or an effect that is not logged)"
    return "; ".join(parts)


def find_excursions(res, k_sigma: float = 3.0, max_items: int = 20) -> list:
    """Excursions of a :class:`~gyrotest.envmodel.modelfit.FitResult` (see the module docstring),
    chronological, at most ``max_items`` (the largest)."""

    # the white and flicker part of the fitted noise at the working resolution: a random walk
    # the noise model took on may be an effect the model lacks, and a step or a transient it
    # absorbed is exactly what the excursions should show
    floor = res.floor.white_flicker_rms if res.floor is not None else None
    runs, rs, sig = excursion_runs(res.resid, res.resolution_s, k_sigma, floor)
    if not runs:
        return []
    t = res.t
    tb = res.resolution_s
    items = []
    for a, b in runs:
        seg = rs[a:b]
        i = int(np.argmax(np.abs(seg)))
        items.append((abs(float(seg[i])), a, b, float(seg[i]), float(np.mean(res.resid[a:b]))))
    items.sort(reverse=True)
    items = sorted(items[:max_items], key=lambda x: x[1])
    out = []
    for _, a, b, peak, mean in items:
        t1, t2 = float(t[a] - tb / 2), float(t[b - 1] + tb / 2)
        out.append(Excursion(t1, t2, peak, mean, describe_interval(
            res.wd.frame, res.wd.refs, t1, t2, power_on=bool(getattr(res.wd, "power_on", False)))))
    return out
