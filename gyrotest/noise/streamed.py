"""Rate-domain checks of a streamed log, computed from its angle series θ in bounded memory.

A log streamed by :mod:`gyrotest.io.stream` keeps only θ (per gap-free segment
[0, cumsum(x − x̄)], see :class:`~gyrotest.core.angle.AngleSeries`). The rate samples are
rebuilt from it where they are needed, Ω_k = (θ_{k+1} − θ_k)/s + x̄ (s = 1 for rate input, τ0
for increments; the rounding error is ε·|θ|, far below any gyro's noise):

* :func:`detect_outliers_series`: the Hampel spike check of
  :func:`gyrotest.noise.outliers.detect_outliers` batch by batch (the running median of each
  batch gets ``window//2`` samples of the neighbours, so the residuals are identical); the
  robust scale (1.4826·MAD, 99 % quantile) and the kurtosis come from the residuals of the
  same stretches as for a record read whole
  (:func:`~gyrotest.noise.outliers.scale_stretches`: all of them up to
  :data:`~gyrotest.noise.outliers.SCALE_SAMPLE` samples), and only the residuals beyond 3
  provisional σ are kept as candidates;
* :func:`welch_psd_series`: the Welch PSD of :func:`~gyrotest.noise.spectral.welch_psd` (the
  first 2²³ samples of each segment) from a few Welch segments at a time;
* :func:`rate_prefixes`: the first samples of each segment for the axis cross-correlation
  (and :func:`rate_segment` for the autocorrelation's first 2²⁰).
"""

from __future__ import annotations

import math

import numpy as np

from .. import _runtime
from ..core.angle import AngleSeries
from .outliers import (
    FALSE_ALARM,
    K_MIN,
    WINDOW,
    OutlierReport,
    _running_median,
    _scale,
    _seg_window,
    excess_kurtosis,
    outlier_events,
    scale_stretches,
    stretch_note,
    threshold_k,
)
from .spectral import WELCH_MAX_SAMPLES, PsdEstimate, _segment_length, _welch_density

__all__ = ["detect_outliers_series", "rate_prefixes", "rate_segment",
           "welch_psd_series"]

#: samples per batch of the streamed spike check
BATCH = 1 << 18


def rate_segment(series: AngleSeries, means: list[float], j: int, a: int, b: int) -> np.ndarray:
    """Rate samples ``a:b`` (deg/h) of gap-free segment ``j``, rebuilt from θ."""
    p0, _ = series.bounds[j]
    x = np.diff(series.theta[p0 + a:p0 + b + 1])
    if series.input_kind == "increment":
        x /= series.tau0
    x += means[j]
    return x


def rate_prefixes(series: AngleSeries, means: list[float], *, per_segment: int,
                  total: int) -> tuple[np.ndarray, list[tuple[int, int]], int]:
    """The first ``per_segment`` rate samples of each segment, back to back, at most ``total``
    in all: (samples, their segments as index ranges, samples of the record left out)."""
    pieces, segs = [], []
    pos = 0
    for j, (a, b) in enumerate(series.bounds):
        L = b - a - 1
        k = min(L, per_segment, total - pos)
        if k <= 0:
            break
        pieces.append(rate_segment(series, means, j, 0, k))
        segs.append((pos, pos + k))
        pos += k
    return np.concatenate(pieces), segs, series.n_data - pos


def _residual_batches(series: AngleSeries, means: list[float], window: int):
    """(global index of the first sample, residual x − running median) per batch."""
    h = window // 2
    g0 = 0
    for j, (a, b) in enumerate(series.bounds):
        L = b - a - 1
        w = _seg_window(0, L, window)
        hh = w // 2 if w >= 3 else 0
        for s in range(0, L, BATCH):
            e = min(L, s + BATCH)
            lo, hi = max(0, s - max(hh, h)), min(L, e + max(hh, h))
            xs = rate_segment(series, means, j, lo, hi)
            if w >= 3:
                med = _running_median(xs, w)
                r = xs[s - lo:e - lo] - med[s - lo:e - lo]
            else:
                r = np.zeros(e - s)
            yield g0 + s, r
        g0 += L


def detect_outliers_series(series: AngleSeries, means: list[float], tau0: float, *,
                           t0: float = 0.0, channel: str = "rate", window: int = WINDOW,
                           false_alarm: float = FALSE_ALARM, k_min: float = K_MIN,
                           unit: str = "deg/h") -> OutlierReport:
    """:func:`gyrotest.noise.outliers.detect_outliers` of the rate behind ``series`` (module
    docstring): the same residuals, threshold and events, and the scale and kurtosis from the
    same residuals (:func:`~gyrotest.noise.outliers.scale_stretches`). The report's
    ``mask`` is empty (``count`` holds the number of outliers)."""
    n = series.n_data
    window = max(3, int(window) | 1)
    kk = threshold_k(n, false_alarm, k_min)
    stretches = scale_stretches(n)
    sample: list[np.ndarray] = []
    cand_i: list[np.ndarray] = []
    cand_r: list[np.ndarray] = []
    cth = None
    for g, r in _residual_batches(series, means, window):
        if _runtime.PROGRESS is not None:
            _runtime.PROGRESS(g + r.size, n, "spike check")
        for lo, hi in stretches:
            s, e = max(lo, g), min(hi, g + r.size)
            if s < e:
                sample.append(r[s - g:e - g].copy())
        if cth is None:
            med = float(np.median(np.abs(r)))
            cth = 3.0 * 1.4826 * med if med > 0 else math.inf
        if math.isfinite(cth):
            big = np.flatnonzero(np.abs(r) > cth)
            if big.size:
                cand_i.append(big + g)
                cand_r.append(r[big])
    rs = np.concatenate(sample) if sample else np.zeros(0)
    scale, how = _scale(rs)
    if len(stretches) > 1:
        how += stretch_note(rs.size, len(stretches))
    kurt = excess_kurtosis(rs)
    del rs, sample
    events = []
    count = 0
    if scale > 0:
        thr = kk * scale * (1.0 - 1e-12)  # candidates; then |r/scale| > k exactly as whole
        if cth is None or thr < cth:  # the provisional cut was too high: a second pass
            cand_i, cand_r = [], []
            for g, r in _residual_batches(series, means, window):
                big = np.flatnonzero(np.abs(r) > thr)
                if big.size:
                    cand_i.append(big + g)
                    cand_r.append(r[big])
        idx = np.concatenate(cand_i) if cand_i else np.zeros(0, np.int64)
        val = np.concatenate(cand_r) if cand_r else np.zeros(0)
        keep = np.abs(val / scale) > kk
        idx, z = idx[keep], val[keep] / scale
        count = int(idx.size)
        events = outlier_events(idx, z, t0, tau0)
    notes = []
    if scale > 0 and count < n and not events and math.isfinite(kurt) and kurt > 10:
        notes.append(f"heavy tails without isolated spikes (excess kurtosis {kurt:.3g})")
    return OutlierReport(channel=channel, n=n, scale=scale, scale_method=how, k=kk,
                         window=window, mask=np.zeros(0, dtype=bool), events=events,
                         excess_kurtosis=kurt, unit=unit, notes=notes, count=count)


def welch_psd_series(series: AngleSeries, means: list[float], tau0: float, *,
                     f_min: float | None = None) -> PsdEstimate:
    """:func:`gyrotest.noise.spectral.welch_psd` of the rate behind ``series`` (the same
    segments, lengths and numbers, up to summation order), with the rate rebuilt from θ a few
    Welch segments at a time instead of held whole."""
    lengths = [b - a - 1 for a, b in series.bounds]
    longest = max(lengths)
    nperseg = int(max(8, min(_segment_length(longest, tau0, f_min), longest)))
    step = nperseg - nperseg // 2
    per = max(1, (1 << 21) // nperseg)  # Welch segments per batch
    fs = 1.0 / tau0
    acc = None
    count = used = 0
    f = None
    for j, L in enumerate(lengths):
        if L < nperseg:
            continue
        L = min(L, WELCH_MAX_SAMPLES)
        k_all = 1 + (L - nperseg) // step
        for i in range(0, k_all, per):
            k = min(per, k_all - i)
            a = i * step
            x = rate_segment(series, means, j, a, a + (k - 1) * step + nperseg)
            f, p = _welch_density(x, fs, nperseg)
            acc = p * k if acc is None else acc + p * k
        count += k_all
        used += L
    if acc is None:
        raise ValueError("record too short for a Welch PSD")
    notes = []
    if used < series.n_data:
        notes.append(f"PSD from the first {used} samples ({WELCH_MAX_SAMPLES} per segment at "
                     "most)")
    psd = 0.5 * acc / count
    keep = f > 0
    return PsdEstimate(f=f[keep], psd=psd[keep], dof=2.0 * 0.9 * count if count > 1 else 2.0,
                       nperseg=nperseg, tau0=tau0, n_used=used, notes=notes)
