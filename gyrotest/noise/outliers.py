"""Spikes and heavy tails in a rate record: Hampel-type detection with a robust scale.

A single spike of 40 σ in a million samples moves the Allan deviation at short τ and the ARW
N noticeably, and a mean (bias) by far more than its 1σ; such samples come from the data link,
the ADC or a mechanical shock, not from the gyro's noise. :func:`detect_outliers` finds them
without assuming the noise is white:

1. the local level is a running median over ``window`` samples (Hampel filter: Hampel,
   "The influence curve and its role in robust estimation", J. Amer. Statist. Assoc. 69, 1974;
   Pearson, "Outliers in process modeling and identification", IEEE Trans. Control Syst.
   Technol. 10, 2002), so slow drift, flicker and random walk do not count;
2. the scale is the median absolute deviation of the residuals, σ_MAD = 1.4826·MAD (a Gaussian
   σ; Rousseeuw & Croux, "Alternatives to the median absolute deviation", J. Amer. Statist.
   Assoc. 88, 1993), but never below the 99 % quantile of |residual|/2.576 (equal to σ for
   Gaussian noise; larger for noise whose whole body is heavy-tailed, which is then not
   flagged sample by sample — it is reported as heavy tails instead); with coarse quantization
   (MAD = 0) the mean absolute deviation ×√(π/2) is used;
3. a sample is an outlier when |x − median| > k·σ_MAD, with k chosen so that a Gaussian record of
   the same length gives a false alarm with probability ``false_alarm`` (default 1 %) — at least
   ``k_min`` (6): k = max(k_min, Φ⁻¹(1 − false_alarm/(2n))).

Consecutive outliers form one event (start time, duration, peak |z|). The report also gives
the excess kurtosis of the residuals (heavy tails; 0 for Gaussian noise).

Records longer than 2²⁰ samples (:data:`SCALE_SAMPLE`) take the scale and the kurtosis from the
residuals of 64 contiguous stretches spread evenly over the record (2²⁰ residuals in all; the
MAD's relative standard error is then ≈ 0.1 %), and compute the running median only where a
sample can be an outlier: every window contains the aligned block of window//2 + 1 samples
around its centre, so the median lies between that block's minimum and maximum, and a sample
within the threshold of both cannot be flagged. The outliers found are exactly those of the
running median everywhere (for that scale); the check costs ≈ 0.2 s instead of ≈ 0.9 s per 10⁷
samples.

Treatments (``--outliers``): ``flag`` (default: report, analyse unchanged), ``remove`` (each
outlier replaced by its running median: the Hampel filter), ``robust`` (each residual clipped to
±k·σ_MAD: winsorised, keeps the sign and part of a large excursion).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["OUTLIER_MODES", "OutlierEvent", "OutlierReport", "apply_outliers", "detect_outliers"]

OUTLIER_MODES = ("flag", "remove", "robust")
#: defaults of the detector (tuned on seeds 0–99 of benchmarks/bench_outliers.py)
WINDOW = 51
K_MIN = 6.0
FALSE_ALARM = 0.01
#: the scale is never below the 99 % quantile of |residual| / 2.576 (its Gaussian value), so
#: noise with a heavy body (not isolated spikes) does not flag a few % of its samples; the
#: breakdown point of that quantile is 1 % of the samples
TAIL_Q = 0.99
Z_TAIL = 2.5758293035489
TAIL_RATIO_NOTE = 1.5
#: events listed by time in messages (all are in the report)
MAX_LISTED = 8


@dataclass
class OutlierEvent:
    """A run of consecutive outlier samples: index range [start, stop), time of the first
    sample (s), peak robust z = (x − median)/σ_MAD (signed)."""

    start: int
    stop: int
    t_s: float
    peak_z: float

    def to_dict(self) -> dict[str, Any]:
        return {"start_index": self.start, "n_samples": self.stop - self.start,
                "t_s": self.t_s, "peak_z": self.peak_z}


@dataclass
class OutlierReport:
    """What :func:`detect_outliers` found in one rate channel."""

    channel: str
    n: int
    scale: float
    scale_method: str
    k: float
    window: int
    mask: np.ndarray
    events: list[OutlierEvent]
    excess_kurtosis: float
    unit: str = "deg/h"
    notes: list[str] = field(default_factory=list)
    count: int | None = None  # set when ``mask`` is not kept (a streamed log)

    @property
    def n_outliers(self) -> int:
        return int(self.mask.sum()) if self.count is None else self.count

    @property
    def found(self) -> bool:
        return bool(self.events)

    def summary(self) -> str:
        """One line: count, largest, the first event times."""
        if not self.events:
            return (f"{self.channel}: no spikes beyond {self.k:.3g} robust σ (robust σ = "
                    f"{self.scale:.4g} {self.unit}); excess kurtosis {self.excess_kurtosis:.3g}")
        ev = sorted(self.events, key=lambda e: -abs(e.peak_z))
        times = ", ".join(f"t = {e.t_s:.6g} s ({e.peak_z:+.0f}σ)"
                          for e in sorted(ev[:MAX_LISTED], key=lambda e: e.t_s))
        more = f" and {len(ev) - MAX_LISTED} more" if len(ev) > MAX_LISTED else ""
        return (f"{self.channel}: {len(self.events)} spike event(s), {self.n_outliers} sample(s) "
                f"({100 * self.n_outliers / max(self.n, 1):.2g} %) beyond {self.k:.3g} robust σ "
                f"(robust σ = {self.scale:.4g} {self.unit}; largest {abs(ev[0].peak_z):.0f}σ; "
                f"excess kurtosis {self.excess_kurtosis:.3g}): {times}{more}")

    def to_dict(self) -> dict[str, Any]:
        return {"channel": self.channel, "n_samples": self.n, "n_outliers": self.n_outliers,
                "n_events": len(self.events), "scale": self.scale, "scale_unit": self.unit,
                "scale_method": self.scale_method, "threshold_k": self.k, "window": self.window,
                "excess_kurtosis": _num(self.excess_kurtosis),
                "method": "Hampel filter: running median over the window, robust scale "
                          "1.4826·MAD of the residuals, outlier when |x − median| > k·σ_MAD",
                "events": [e.to_dict() for e in self.events], "summary": self.summary(),
                "notes": list(self.notes)}


def _num(v: float) -> float | None:
    return float(v) if math.isfinite(v) else None


def threshold_k(n: int, false_alarm: float = FALSE_ALARM, k_min: float = K_MIN) -> float:
    """k = max(k_min, Φ⁻¹(1 − false_alarm/(2n))): the Gaussian two-sided level at which a record
    of n independent samples raises a false alarm with probability ≈ ``false_alarm``."""
    from statistics import NormalDist  # Φ⁻¹ (Wichura AS241); no scipy import in `info`

    return max(float(k_min), -NormalDist().inv_cdf(false_alarm / (2.0 * max(n, 1))))


#: records up to this many samples get the running median from numpy (no scipy import: `info`
#: on a small log stays quick); longer ones from scipy.ndimage (faster per sample)
NUMPY_MEDIAN_MAX = 200_000


#: samples per call of scipy's running median on long records: its C loop holds the GIL, so
#: it is called on pieces (with the window's overlap) and other threads (the deviation
#: kernels, the PSD; :func:`gyrotest.noise.analysis.analyse_allan` runs the spike check
#: beside them) get the interpreter between pieces
MEDIAN_PIECE = 1 << 18


def _running_median(x: np.ndarray, window: int, out: np.ndarray | None = None) -> np.ndarray:
    """Running median over ``window`` (odd) samples, edges padded with the end values
    (scipy.ndimage.median_filter with mode="nearest"; the same numbers either way), into
    ``out`` if given. Long records go in pieces of :data:`MEDIAN_PIECE` extended by
    window // 2 samples on each inner side, so every output sees the same window as in one
    call (identical numbers)."""
    if out is None:
        out = np.empty(x.size)
    if x.size > NUMPY_MEDIAN_MAX:
        from scipy.ndimage import median_filter

        h = window // 2
        for a in range(0, x.size, MEDIAN_PIECE):
            b = min(a + MEDIAN_PIECE, x.size)
            lo, hi = max(a - h, 0), min(b + h, x.size)
            out[a:b] = median_filter(x[lo:hi], size=window, mode="nearest")[a - lo:a - lo + b - a]
        return out
    h = window // 2
    xp = np.concatenate([np.full(h, x[0]), x, np.full(h, x[-1])])
    step = max(1, 4_000_000 // window)  # bounded memory: chunks of the window view
    view = np.lib.stride_tricks.sliding_window_view(xp, window)
    for i in range(0, x.size, step):
        out[i:i + step] = np.median(view[i:i + step], axis=1)
    return out


#: from this many values, order statistics are selected inside brackets taken from a strided
#: sample (:func:`_order_stats`) instead of partitioning the whole array
BRACKET_MIN = 1 << 18


def _order_stats(a: np.ndarray, ks: list[int]) -> dict[int, float]:
    """The values of rank ``ks`` (0-based, as ``np.partition`` places them; NaN ranks last)
    of ``a``, which may be reordered. Exact: long arrays are bracketed around each cluster of
    ranks by a strided sample's order statistics with a wide margin; the values below the
    bracket are counted and only those inside it are partitioned. A bracket that misses its
    ranks (checked by the counts) falls back to the partition of the whole array."""
    n = a.size
    if n < BRACKET_MIN:
        a.partition(ks)
        return {k: float(a[k]) for k in ks}
    step = max(n // (1 << 15), 1)
    smp = np.sort(a[::step])
    m = smp.size
    out: dict[int, float] = {}
    for k0 in sorted(set(ks)):
        if k0 in out:
            continue
        group = [k for k in ks if k0 <= k <= k0 + 1]
        p = k0 / max(n - 1, 1)
        j, dj = p * (m - 1), 8.0 * math.sqrt(m * p * (1.0 - p)) + 16.0
        lo_v = smp[max(int(j - dj), 0)]
        hi_v = smp[min(int(j + dj) + 1, m - 1)]
        below = int(np.count_nonzero(a < lo_v))
        inside = a[(a >= lo_v) & (a <= hi_v)]
        if not all(below <= k < below + inside.size for k in group):
            a.partition(ks)  # pragma: no cover - a 8σ miss of the sample quantile
            return {k: float(a[k]) for k in ks}
        inside.partition([k - below for k in group])
        out.update({k: float(inside[k - below]) for k in group})
    return out


def _median_quantile(a: np.ndarray, q: float) -> tuple[float, float]:
    """(np.median(a), np.quantile(a, q)) — the same numbers (numpy's linear interpolation,
    reproduced) from the order statistics of ``a`` (:func:`_order_stats`; ``a`` may be
    reordered) instead of two partitioned copies."""
    n = a.size
    vi = (n - 1) * q  # numpy's virtual index, method="linear"
    lo = min(max(int(math.floor(vi)), 0), n - 1)
    hi = min(lo + 1, n - 1)
    v = _order_stats(a, sorted({(n - 1) // 2, n // 2, lo, hi}))
    med = v[n // 2] if n % 2 else float((v[n // 2 - 1] + v[n // 2]) / 2.0)
    x0, x1, g = v[lo], v[hi], vi - math.floor(vi)
    d = x1 - x0
    quant = x1 - d * (1 - g) if g >= 0.5 else x0 + d * g
    return med, quant


def _scale(r: np.ndarray) -> tuple[float, str]:
    a = np.abs(r)
    med, q_abs = _median_quantile(a, TAIL_Q)
    if med > 0:
        s_mad = 1.4826 * med
        s_q = q_abs / Z_TAIL
        if s_q > TAIL_RATIO_NOTE * s_mad:
            return s_q, (f"99 % quantile of |residual|/2.576 (heavy-bodied noise: "
                         f"{s_q / s_mad:.3g}× 1.4826·MAD)")
        return max(s_mad, s_q), "max(1.4826·MAD, 99 % quantile of |residual|/2.576)"
    mad_mean = float(np.mean(np.abs(r - np.mean(r))))
    if mad_mean > 0:
        s_q = q_abs / Z_TAIL
        return max(math.sqrt(math.pi / 2.0) * mad_mean, s_q), (
            "max(√(π/2)·mean absolute deviation, 99 % quantile of |residual|/2.576) (MAD = 0: "
            "coarse quantization)")
    return 0.0, "constant"


def detect_outliers(x, tau0: float, *, t0: float = 0.0, channel: str = "rate",
                    window: int = WINDOW, k: float | None = None,
                    false_alarm: float = FALSE_ALARM, k_min: float = K_MIN,
                    segments=None, unit: str = "deg/h") -> OutlierReport:
    """Hampel-type spike detection in the rate samples ``x`` (module docstring).

    ``tau0`` and ``t0`` give the event times (t0 + i·τ0 s); ``segments`` [(start, stop), ...]
    are gap-free stretches, each filtered on its own (default: the whole record). ``k`` fixes
    the threshold; by default it follows the record length (:func:`threshold_k`). Records longer
    than :data:`SCALE_SAMPLE` take the scale and the kurtosis from a sample of the residuals
    and the running median only where a sample can be an outlier (:func:`_detect_screened`).
    """
    x = np.asarray(x, dtype=np.float64)
    n = x.size
    window = max(3, int(window) | 1)
    segs = segments or [(0, n)]
    kk = threshold_k(n, false_alarm, k_min) if k is None else float(k)
    if n > SCALE_SAMPLE:
        return _detect_screened(x, tau0, t0=t0, channel=channel, window=window, kk=kk,
                                segs=segs, unit=unit)
    r = np.empty_like(x)  # the running median, then x − median in place
    for a, b in segs:
        w = _seg_window(a, b, window)
        if w >= 3:
            _running_median(x[a:b], w, out=r[a:b])
        else:
            r[a:b] = x[a:b]
    np.subtract(x, r, out=r)
    scale, how = _scale(r)
    if scale <= 0:
        mask = np.zeros(n, dtype=bool)
    else:  # |r/scale| > kk, without a full-size z array
        lim = kk * scale * (1.0 - 1e-12)  # |r| > lim: a superset; the exact test below
        mask = r > lim  # two sign tests instead of a full-size |r| copy
        mask |= r < -lim
        cand = np.flatnonzero(mask)
        mask[cand] = np.abs(r[cand] / scale) > kk
    idx = np.flatnonzero(mask)
    events = outlier_events(idx, r[idx] / scale if idx.size else np.zeros(0), t0, tau0)
    n_clean = n - int(mask.sum()) if scale > 0 else n
    kurt = excess_kurtosis(r)  # r is not needed any more: central moments in place
    notes = []
    if scale > 0 and n_clean and not mask.any() and math.isfinite(kurt) and kurt > 10:
        notes.append(f"heavy tails without isolated spikes (excess kurtosis {kurt:.3g})")
    return OutlierReport(channel=channel, n=n, scale=scale, scale_method=how, k=kk,
                         window=window, mask=mask, events=events, excess_kurtosis=kurt,
                         unit=unit, notes=notes)


#: records longer than this many samples take the robust scale and the excess kurtosis from
#: the residuals of :data:`SCALE_STRETCHES` evenly spaced stretches holding this many samples
#: in all (:func:`scale_stretches`; the whole record and a streamed one use the same samples)
SCALE_SAMPLE = 1 << 20
SCALE_STRETCHES = 64
#: when the screen of :func:`_screen` leaves more than this fraction of the samples as
#: candidates (coarse quantization, a very noisy block), the running median is computed
#: everywhere instead (the same answer, only slower)
SCREEN_MAX_FRACTION = 0.01
#: blocks of the screen processed per numpy call (bounded temporaries)
SCREEN_BLOCKS = 1 << 15


def scale_stretches(n: int) -> list[tuple[int, int]]:
    """Index ranges [lo, hi) of the residuals that give the robust scale and the kurtosis of a
    record of ``n`` samples: all of it up to :data:`SCALE_SAMPLE`, else
    :data:`SCALE_STRETCHES` contiguous stretches of SCALE_SAMPLE/SCALE_STRETCHES samples, each
    centred in one of as many equal parts of the record. Contiguous stretches cost one call of
    the running median each; a systematic every-s-th sample would need a median per sample."""
    if n <= SCALE_SAMPLE:
        return [(0, n)]
    L = SCALE_SAMPLE // SCALE_STRETCHES
    part = n / SCALE_STRETCHES
    out = []
    for j in range(SCALE_STRETCHES):
        lo = int(j * part + (part - L) / 2)
        out.append((lo, lo + L))
    return out


def stretch_note(size: int, count: int) -> str:
    """What the scale method adds when the scale comes from :func:`scale_stretches`."""
    return f"; from {size} residuals in {count} stretches spread over the record"


def excess_kurtosis(r: np.ndarray) -> float:
    """Excess kurtosis m4/m2² − 3 of ``r`` (0 for Gaussian noise); ``r`` is overwritten."""
    n = r.size
    if n <= 3:
        return math.nan
    r -= r.mean()
    m2 = float(np.dot(r, r)) / n
    if m2 <= 0:
        return math.nan
    np.multiply(r, r, out=r)
    return float(np.dot(r, r) / n / m2 ** 2 - 3.0)


def outlier_events(idx: np.ndarray, z: np.ndarray, t0: float, tau0: float) -> list[OutlierEvent]:
    """Runs of consecutive outlier indices ``idx`` (sorted) as events; ``z`` = residual/scale
    of each."""
    events: list[OutlierEvent] = []
    if not idx.size:
        return events
    breaks = np.flatnonzero(np.diff(idx) > 1)
    starts = np.concatenate([[0], breaks + 1])
    stops = np.concatenate([breaks + 1, [idx.size]])
    for a, b in zip(starts, stops):
        j = a + int(np.argmax(np.abs(z[a:b])))
        events.append(OutlierEvent(int(idx[a]), int(idx[b - 1]) + 1,
                                   float(t0 + idx[a] * tau0), float(z[j])))
    return events


def _seg_window(a: int, b: int, window: int) -> int:
    """The running-median window of segment [a, b) (odd; 1: no median, residual 0)."""
    return min(window, (b - a) | 1) if b - a >= 3 else 1


def _residuals_range(x: np.ndarray, a: int, b: int, w: int, lo: int, hi: int) -> np.ndarray:
    """x − running median for indices [lo, hi) ⊂ segment [a, b): the median of the samples
    [lo − w//2, hi + w//2) clipped to the segment, so every output sees the same window as the
    running median of the whole segment (identical numbers)."""
    if w < 3:
        return np.zeros(hi - lo)
    from scipy.ndimage import median_filter  # (a long record: scipy's median is faster)

    h = w // 2
    elo, ehi = max(a, lo - h), min(b, hi + h)
    med = median_filter(x[elo:ehi], size=w, mode="nearest")
    return x[lo:hi] - med[lo - elo:hi - elo]


def _medians_at(x: np.ndarray, a: int, b: int, w: int, idx: np.ndarray) -> np.ndarray:
    """The running median of segment [a, b) (window ``w``, ends padded with the end values)
    at the indices ``idx`` only."""
    h = w // 2
    out = np.empty(idx.size)
    off = np.arange(-h, h + 1)
    for s in range(0, idx.size, 1 << 14):
        j = np.clip(idx[s:s + (1 << 14), None] + off, a, b - 1)
        out[s:s + (1 << 14)] = np.median(x[j], axis=1)
    return out


def _screen(seg: np.ndarray, h: int, lim: float) -> np.ndarray:
    """Indices of ``seg`` whose |x − running median| (window 2h + 1) may exceed ``lim``.

    Each index lies in an aligned block of h + 1 samples, and every window of 2h + 1 samples
    (padded at the ends with the end values) contains the block of its centre; at least h + 1
    of its values are ≥ the block's minimum and h + 1 are ≤ its maximum, so the median lies in
    [block min, block max] and |x − median| ≤ max(x − min, max − x). A sample for which both
    are ≤ ``lim`` cannot be an outlier; the rest (and the last partial block) are returned."""
    B = h + 1
    nb = seg.size // B
    out = []
    for s in range(0, nb, SCREEN_BLOCKS):
        e = min(nb, s + SCREEN_BLOCKS)
        X = seg[s * B:e * B].reshape(-1, B)
        c = X > (X.min(axis=1) + lim)[:, None]
        c |= X < (X.max(axis=1) - lim)[:, None]
        out.append(np.flatnonzero(c) + s * B)
    out.append(np.arange(nb * B, seg.size))
    return np.concatenate(out)


def _detect_screened(x: np.ndarray, tau0: float, *, t0: float, channel: str, window: int,
                     kk: float, segs, unit: str) -> OutlierReport:
    """:func:`detect_outliers` of a long record: the scale and the kurtosis from the residuals
    of :func:`scale_stretches`; the outliers exactly as with the running median everywhere (for
    that scale), from the running median at the samples the screen of :func:`_screen` cannot
    clear — about 10⁻⁴ of them for Gaussian noise, so the check costs ~0.2 s instead of ~0.9 s
    per 10⁷ samples."""
    n = x.size
    pieces = []
    for lo, hi in scale_stretches(n):
        for a, b in segs:
            s, e = max(lo, a), min(hi, b)
            if s < e:
                pieces.append(_residuals_range(x, a, b, _seg_window(a, b, window), s, e))
    rs = np.concatenate(pieces) if pieces else np.zeros(0)
    scale, how = _scale(rs)
    how += stretch_note(rs.size, SCALE_STRETCHES)
    kurt = excess_kurtosis(rs)
    del rs, pieces
    idx = np.zeros(0, np.int64)
    z = np.zeros(0)
    if scale > 0:
        lim = kk * scale * (1.0 - 1e-12)
        amax = max(abs(float(x.max())), abs(float(x.min()))) if n else 0.0  # no |x| copy
        clear = lim - (1e-9 * lim + 1e-12 * amax)  # rounding margin of the screen
        found_i, found_r = [], []
        plan = []
        total = 0
        for a, b in segs:
            w = _seg_window(a, b, window)
            if w < 3:
                continue
            c = _screen(x[a:b], w // 2, clear) + a
            plan.append((a, b, w, c))
            total += c.size
        if total > SCREEN_MAX_FRACTION * n:  # the screen clears too little: median everywhere
            plan = [(a, b, w, None) for a, b, w, _ in plan]
        for a, b, w, c in plan:
            if c is None:
                r = _residuals_range(x, a, b, w, a, b)
                c = np.flatnonzero((r > lim) | (r < -lim)) + a
                rc = r[c - a]
            else:
                rc = x[c] - _medians_at(x, a, b, w, c)
            keep = np.abs(rc / scale) > kk
            found_i.append(c[keep])
            found_r.append(rc[keep])
        if found_i:
            idx = np.concatenate(found_i)
            z = np.concatenate(found_r) / scale
            order = np.argsort(idx, kind="stable")
            idx, z = idx[order], z[order]
    mask = np.zeros(n, dtype=bool)
    mask[idx] = True
    events = outlier_events(idx, z, t0, tau0)
    notes = []
    if scale > 0 and idx.size < n and not events and math.isfinite(kurt) and kurt > 10:
        notes.append(f"heavy tails without isolated spikes (excess kurtosis {kurt:.3g})")
    return OutlierReport(channel=channel, n=n, scale=scale, scale_method=how, k=kk,
                         window=window, mask=mask, events=events, excess_kurtosis=kurt,
                         unit=unit, notes=notes)


def apply_outliers(x, report: OutlierReport, mode: str, *, segments=None) -> np.ndarray:
    """The samples after the ``mode`` treatment: ``flag`` returns ``x`` unchanged, ``remove``
    replaces each outlier by its running median, ``robust`` clips each residual to ±k·σ_MAD."""
    if mode not in OUTLIER_MODES:
        from ..core.errors import InputError

        raise InputError(f"unknown --outliers {mode!r}; use flag, remove or robust")
    x = np.asarray(x, dtype=np.float64)
    if mode == "flag" or not report.found:
        return x
    n = x.size
    segs = segments or [(0, n)]
    med = np.empty_like(x)
    for a, b in segs:
        w = _seg_window(a, b, report.window)
        if w >= 3:
            _running_median(x[a:b], w, out=med[a:b])
        else:
            med[a:b] = x[a:b]
    out = x.copy()
    m = report.mask
    if mode == "remove":
        out[m] = med[m]
    else:
        lim = report.k * report.scale
        out[m] = med[m] + np.clip(x[m] - med[m], -lim, lim)
    return out
