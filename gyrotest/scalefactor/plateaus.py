"""Plateau extraction from continuous rate-table logs (IEEE 952 §12.9.3.1 data, §12.9.4).

A rate-table scale-factor test holds the table at a set of rates ±ω_i; for each plateau the
gyro output is averaged after the settling time. This module finds the plateaus in a
:class:`~gyrotest.core.data.GyroLog` and reduces each to one point (input rate, mean output,
standard error, duration, mean temperature):

* from the commanded-rate column (``log.table_rate``) when the log has one: every stretch of
  constant command at least ``min_dwell_s`` long is a plateau (a noisy measured table rate
  falls back to step detection on that column);
* otherwise by step detection on the output itself (:func:`detect_steps`): block means, a robust
  noise scale, breaks where consecutive block means jump by more than ``k_sigma`` noise
  scales, re-merging of fragments whose levels agree (heteroscedastic noise), trimming of
  slow ramps. Unequal dwell times and any sweep order are fine. The input rate of a detected
  plateau comes from ``--rates`` or is snapped to the shortest decimal within ``snap_tol``
  of the bias-corrected output level (:func:`snap_rates`).

Settling: the averaging window starts at the settling time found in the plateau's own data
(:func:`~gyrotest.scalefactor.settling.find_settling`: transient against the plateau's noise
floor), at least ``settle_s`` after the command change (detected: after the end of the
previous plateau); ``auto_settle=False`` uses ``settle_s`` as given. It ends ``trim_end_s``
before the next change.

Standard error of a plateau mean (honest for correlated noise), two methods:

* ``allan`` (default, :func:`allan_stderr`): the **Allan deviation at the plateau length**,
  σ_A(T), from a noise model 3Q²/τ² + N²/τ + B² fitted to the overlapping Allan variances
  pooled over all plateaus of the run (IEEE 952 Annex C). Exact for white rate noise,
  1.5× the variance for quantization/white angle noise (pulse outputs, where σ/√n and batch
  means are far too large), the flicker floor for bias instability. Pooling gives stable
  weights; a plateau that is significantly noisier than the pool is scaled up.
* ``batch`` (:func:`mean_stderr`): batch means, ``std(32 batch means)/√32``; unbiased for
  noise correlated over less than a batch, conservative for quantization noise.

The naive white-noise ``σ/√n`` is kept beside it for comparison.

Units: rates deg/h (1 deg/h = 1 arcsec/s), time s, temperature degC.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..core.errors import AnalysisError, InputError
from .repeatability import power_on_label
from .settling import SettlingFound, find_settling

DPS = 3600.0  # deg/h per deg/s

STDERR_METHODS = {
    "allan": "Allan deviation at the plateau length, sigma_A(T), from a 3Q^2/tau^2 + N^2/tau "
             "(+ B^2) model fitted to the run's pooled overlapping Allan variances",
    "batch": "batch means: std(32 contiguous batch means)/sqrt(32)",
    "points": "as given in the points table",
}


@dataclass
class Plateau:
    """One rate-table plateau reduced to a point.

    ``output_dph`` is the mean of the log's rate, i.e. the native output times the nominal
    scale factor S0 (IEEE 952 §8.3: S0·ΔN/Δt or S0·V), in deg/h. ``input_rate_dph`` is the
    inertial input along the IA: table rate + earth-rate component (GYRO_REFERENCE §2).
    """

    run: str
    index: int  # order in the run (time order), 0-based
    table_rate_dph: float
    earth_rate_dph: float
    output_dph: float
    stderr_dph: float  # batch-means standard error of output_dph (NaN: unknown)
    t_start_s: float = math.nan  # averaging window, s from the start of the log
    t_end_s: float = math.nan
    dwell_start_s: float = math.nan  # command change (or detected transition start)
    dwell_end_s: float = math.nan
    n_samples: int = 0
    temperature_degC: float = math.nan
    stderr_white_dph: float = math.nan  # σ/√n, for comparison
    rate_source: str = "table column"
    sweep: int = 0
    locked: bool = False  # inside a lock-in dead band (excluded from the fits)
    settling: SettlingFound | None = None  # found from the data (None: points table)

    @property
    def input_rate_dph(self) -> float:
        return self.table_rate_dph + self.earth_rate_dph

    @property
    def duration_s(self) -> float:
        return self.t_end_s - self.t_start_s

    @property
    def dwell_s(self) -> float:
        return self.dwell_end_s - self.dwell_start_s

    def to_dict(self) -> dict:
        return {
            "run": self.run,
            "index": self.index,
            "sweep": self.sweep,
            "table_rate_dps": self.table_rate_dph / DPS,
            "table_rate_dph": self.table_rate_dph,
            "earth_rate_dph": self.earth_rate_dph,
            "input_rate_dph": self.input_rate_dph,
            "output_dph": self.output_dph,
            "stderr_dph": self.stderr_dph,
            "stderr_white_dph": self.stderr_white_dph,
            "t_start_s": self.t_start_s,
            "t_end_s": self.t_end_s,
            "duration_s": self.duration_s,
            "dwell_s": self.dwell_s,
            "n_samples": self.n_samples,
            "temperature_degC": self.temperature_degC,
            "rate_source": self.rate_source,
            "locked": self.locked,
            "settling_found_s": self.settling.found_s if self.settling else math.nan,
            "settling_used_s": self.settling.used_s if self.settling else math.nan,
        }


@dataclass
class RunPlateaus:
    """The plateaus of one run (one log or one run of a points table)."""

    run: str
    source: str
    plateaus: list[Plateau]
    method: str  # "table column", "detected", "points table"
    earth_rate_dph: float = 0.0
    settle_s: float = math.nan
    trim_end_s: float = math.nan
    noise_block_dph: float = math.nan  # robust σ of the detector's block means
    block_s: float = math.nan
    ignored_short: int = 0  # constant stretches shorter than min_dwell_s
    notes: list[str] = field(default_factory=list)
    stderr_method: str = "allan"
    auto_settle: bool = False
    power_on: str | None = None  # power-on label from the log (None: not given)

    @property
    def settling(self) -> list[SettlingFound]:
        return [p.settling for p in self.plateaus if p.settling is not None]

    @property
    def settling_worst_s(self) -> float:
        """Longest settling found in the data over the run's plateaus (NaN: none)."""
        st = self.settling
        return max(s.found_s for s in st) if st else math.nan

    def to_dict(self) -> dict:
        st = self.settling
        worst = max(st, key=lambda s: s.found_s) if st else None
        return {
            "settling_from_data": self.auto_settle,
            "settling_worst_s": worst.found_s if worst else math.nan,
            "settling_worst_step_dps": [worst.from_rate_dps, worst.to_rate_dps] if worst else None,
            "settling_per_step": [s.to_dict() for s in st],
            "run": self.run,
            "source": self.source,
            "method": self.method,
            "earth_rate_dph": self.earth_rate_dph,
            "settle_s": self.settle_s,
            "trim_end_s": self.trim_end_s,
            "detector_block_s": self.block_s,
            "detector_noise_block_dph": self.noise_block_dph,
            "ignored_short_stretches": self.ignored_short,
            "n_plateaus": len(self.plateaus),
            "stderr_method": STDERR_METHODS.get(self.stderr_method, self.stderr_method),
            "notes": self.notes,
        }


# ----------------------------------------------------------------------------- statistics
def mean_stderr(y: np.ndarray, n_batches: int = 32) -> tuple[float, float, float]:
    """Mean of ``y`` and its standard error by batch means, plus the white-noise σ/√n.

    ``SE = std(b_j, ddof=1)/√m`` with b_j the means of m = min(n_batches, n//2) contiguous
    equal batches (the non-overlapping block estimator of the variance of a mean of correlated
    data; equivalent to the Allan-variance route σ²(T) for white noise, IEEE 952 Annex C).
    Units: those of ``y``. Needs n ≥ 4 samples.
    """
    y = np.asarray(y, dtype=np.float64)
    n = len(y)
    if n < 4:
        raise AnalysisError(f"{n} samples are too few for a mean and its standard error")
    mean = float(np.mean(y))
    m = max(2, min(int(n_batches), n // 2))
    L = n // m
    bm = y[: m * L].reshape(m, L).mean(axis=1)
    se = float(np.std(bm, ddof=1) / math.sqrt(m))
    se_white = float(np.std(y, ddof=1) / math.sqrt(n))
    return mean, se, se_white


def _avar_sums(y: np.ndarray, tau0: float, ms: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """Sums of squared second differences of the angle and their counts, per cluster size m
    (overlapping Allan variance, IEEE 952 Annex C; strided by m/8 for large m)."""
    th = np.empty(len(y) + 1)
    th[0] = 0.0
    np.cumsum(y, out=th[1:])
    th *= tau0
    sq = np.zeros(len(ms))
    cnt = np.zeros(len(ms))
    for j, m in enumerate(ms):
        if 2 * m > len(y):
            continue
        st = max(1, m // 8)
        d = th[2 * m::st] - 2 * th[m:len(th) - m:st] + th[:len(th) - 2 * m:st]
        sq[j] = float(np.dot(d, d))
        cnt[j] = len(d)
    return sq, cnt


def allan_stderr(windows: list[np.ndarray], tau0: float, *, inflate_ratio: float = 2.0
                 ) -> tuple[np.ndarray, dict]:
    """Standard errors of the means of ``windows`` (one run's plateaus) from the Allan
    deviation at each window's length T: ``SE_i = σ_A(T_i)``.

    The overlapping Allan variances of all windows are pooled per cluster time τ = m·τ0
    (m = 1, 2, 4, … ≤ n/4) and ``σ²(τ) = 3Q²/τ² + N²/τ + B²`` (white angle/quantization,
    white rate, flicker floor; IEEE 952 Annex C) is fitted with non-negative coefficients
    (relative errors) over the five octaves below the longest τ — the part that is
    extrapolated — then evaluated at τ = T_i. The floor B² is fitted only when 3Q²/τ² + N²/τ
    falls short at the longest τ by more than three standard errors of that Allan variance
    (over a few octaves B² and N²/τ are nearly degenerate). For white rate noise σ²_A(T) is exactly the
    variance of the mean over T; for quantization/white angle noise it is 1.5× it; for
    bias instability it is the usual floor. A window whose own Allan variance at τ ≈ T_i/16
    exceeds the pooled model by ``inflate_ratio`` (≈ 1 % false-alarm) is scaled up by that
    ratio. Units: those of the windows. Returns (SE array, info).
    """
    from scipy.optimize import nnls

    n_max = max(len(w) for w in windows)
    ms = [1]
    while ms[-1] * 2 <= max(1, n_max // 4):
        ms.append(ms[-1] * 2)

    def pow2_le(x: int) -> int:
        return 1 << max(0, int(x).bit_length() - 1) if x >= 1 else 1

    # only the octaves that are used: the top five (fitted) and each window's own τ ≈ T/16
    need = {m for m in ms if m >= ms[-1] // 32} | {pow2_le(len(w) // 16) for w in windows}
    ms = sorted(m for m in need if m in ms) or [1]
    per = [_avar_sums(w, tau0, ms) for w in windows]
    taus_all = np.array(ms, float) * tau0
    # windows much noisier than the rest at a common short τ (unfinished settling, a
    # disturbance) are kept out of the pool and scaled on their own below
    n_min = min(len(w) for w in windows)
    k_ref = max([k for k, m in enumerate(ms) if m <= max(1, n_min // 16)] or [0])
    own_ref = np.array([sq[k_ref] / cnt[k_ref] / (2 * taus_all[k_ref] ** 2) if cnt[k_ref] else np.nan
                        for sq, cnt in per])
    med = float(np.nanmedian(own_ref)) if np.any(np.isfinite(own_ref)) else np.nan
    pooled = [i for i in range(len(windows))
              if not (math.isfinite(med) and med > 0 and own_ref[i] > inflate_ratio * med)]
    if len(pooled) < max(1, len(windows) // 2):
        pooled = list(range(len(windows)))
    tot_sq = np.zeros(len(ms))
    tot_n = np.zeros(len(ms))
    for i in pooled:
        tot_sq += per[i][0]
        tot_n += per[i][1]
    taus = np.array(ms, float) * tau0
    ok = tot_n > 0
    av = np.where(ok, tot_sq / np.maximum(tot_n, 1) / (2 * taus ** 2), np.nan)
    # effective number of independent clusters ~ count·stride/m
    strides = np.array([max(1, m // 8) for m in ms], float)
    edf = np.maximum(tot_n * strides / np.array(ms, float), 1.0)
    ok &= np.isfinite(av) & (av > 0)
    # fit the octaves next to the plateau lengths (what is extrapolated), at least three
    if ok.sum() > 3:
        top = taus[ok].max()
        near = ok & (taus >= top / 16.0)
        if near.sum() >= 3:
            ok = near
        else:
            ok &= taus >= np.sort(taus[ok])[-3]
    if ok.sum() == 0:
        se = np.array([float(np.std(w, ddof=1) / math.sqrt(len(w))) for w in windows])
        return se, {"method": "white (too few samples for Allan)", "coef": None}
    A = np.column_stack([1 / taus ** 2, 1 / taus, np.ones_like(taus)])[ok]
    wts = np.sqrt(edf[ok]) / av[ok]
    coef2, _ = nnls(A[:, :2] * wts[:, None], av[ok] * wts)
    coef = np.r_[coef2, 0.0]
    # a flicker floor only when Q + N clearly fall short at the longest τ (else the floor
    # and N are nearly degenerate over a few octaves and the floor would inflate every SE)
    jl = np.flatnonzero(ok)[-1]
    pred = coef2[0] / taus[jl] ** 2 + coef2[1] / taus[jl]
    if edf[jl] >= 10 and av[jl] > pred * (1 + 3 * math.sqrt(2 / edf[jl])):
        coef, _ = nnls(A * wts[:, None], av[ok] * wts)

    def model(t):
        return coef[0] / t ** 2 + coef[1] / t + coef[2]

    se = np.empty(len(windows))
    inflated = 0
    for i, (w, (sq, cnt)) in enumerate(zip(windows, per)):
        T = len(w) * tau0
        v = model(T)
        j = [k for k, m in enumerate(ms) if m <= max(1, len(w) // 16) and cnt[k] > 0]
        if j:
            k = j[-1]
            own = sq[k] / cnt[k] / (2 * taus[k] ** 2)
            ratio = own / model(taus[k]) if model(taus[k]) > 0 else 1.0
            if ratio > inflate_ratio:
                v *= ratio
                inflated += 1
        se[i] = math.sqrt(v) if v > 0 else float(np.std(w, ddof=1) / math.sqrt(len(w)))
    info = {"method": "allan", "coef": coef.tolist(), "taus": taus.tolist(),
            "avar": av.tolist(), "inflated": inflated,
            "excluded_from_pool": len(windows) - len(pooled)}
    return se, info


def _robust_std(x: np.ndarray) -> float:
    if len(x) < 2:
        return 0.0
    return float(1.4826 * np.median(np.abs(x - np.median(x))))


# ----------------------------------------------------------------------------- segmentation
@dataclass
class Segment:
    """A steady stretch found in a signal: samples ``start:stop``; ``change`` is the sample
    where the transition into it began (command change or end of the previous plateau)."""

    start: int
    stop: int
    change: int
    level: float = math.nan


def constant_runs(x: np.ndarray, *, rtol: float = 1e-9) -> tuple[np.ndarray, np.ndarray]:
    """Start and stop (exclusive) indices of the stretches where ``x`` is constant to within
    ``rtol`` of its largest magnitude: the plateaus of a commanded-rate column (IEEE 952
    §12.9.3.1 test data). Consecutive equal commands form one stretch."""
    x = np.asarray(x, dtype=np.float64)
    if len(x) == 0:
        return np.zeros(0, int), np.zeros(0, int)
    atol = rtol * max(1.0, float(np.max(np.abs(x))))
    brk = np.flatnonzero(np.abs(np.diff(x)) > atol) + 1
    starts = np.r_[0, brk]
    stops = np.r_[brk, len(x)]
    return starts, stops


def detect_steps(y: np.ndarray, tau0: float, *, min_dwell_s: float = 2.0,
                 block_s: float | None = None, k_sigma: float = 6.0,
                 ) -> tuple[list[Segment], dict]:
    """Find the steady plateaus of a piecewise-constant signal (rate-table output).

    1. block means m_j over blocks of ``block_s`` (default min_dwell/8, 0.05…1 s);
    2. noise scale σ_d = 1.4826·MAD(m_{j+1} − m_j) (robust: most blocks are steady), and a
       local one from the rolling median of |m_{j+1} − m_j| over 21 blocks;
    3. a break wherever |m_{j+1} − m_j| > k_sigma·max(σ_d, local): steps and ramps break,
       noise does not (also on a noisier plateau);
    4. neighbouring stretches (≥ 3 blocks, at most 2 blocks apart) whose medians agree within
       k_sigma × their own block scatter are merged (noisier plateaus, isolated spikes);
    5. leading/trailing blocks further than the threshold from the level of the settled
       second half are trimmed (slow settling); what still trends by more than the threshold
       is a ramp and is dropped;
    6. stretches shorter than ``min_dwell_s`` are ignored.

    Returns (segments, info) with info: ``block_s``, ``noise_block`` (σ of a block mean, units
    of y), ``threshold``, ``ignored_short``, ``ramps``. Pure numpy; O(n).
    """
    y = np.asarray(y, dtype=np.float64)
    n = len(y)
    if block_s is None:
        block_s = min(max(min_dwell_s / 8.0, 0.05), 1.0)
    B = max(1, int(round(block_s / tau0)))
    nb = n // B
    if nb < 6:
        raise AnalysisError(f"the log ({n} samples) is too short to find rate plateaus")
    m = y[: nb * B].reshape(nb, B).mean(axis=1)
    d = np.diff(m)
    sig_d = 1.4826 * float(np.median(np.abs(d - np.median(d))))
    floor = 1e-9 * max(1.0, float(np.max(np.abs(m))))
    sig_d = max(sig_d, floor)
    thr = k_sigma * sig_d
    # local noise (rolling median of |Δ| over ~21 blocks) raises the threshold on noisier
    # plateaus; single steps do not move a median, long ramps are rejected in step 5
    from scipy.ndimage import median_filter

    loc = 1.4826 * median_filter(np.abs(d - np.median(d)), size=min(21, len(d)), mode="nearest")
    thr_j = k_sigma * np.maximum(sig_d, loc)
    brk = np.flatnonzero(np.abs(d) > thr_j)
    starts = np.r_[0, brk + 1]
    ends = np.r_[brk, nb - 1]  # inclusive block indices
    # 4. merge long stretches separated by at most 2 blocks when their levels agree
    long_segs: list[list[int]] = []
    sig_b = sig_d / math.sqrt(2.0)
    for s, e in zip(starts.tolist(), ends.tolist()):
        if e - s + 1 < 3:
            continue
        if long_segs:
            ps, pe = long_segs[-1]
            if s - pe - 1 <= 2:
                a, b = m[ps:pe + 1], m[s:e + 1]
                sc = max(_robust_std(a), _robust_std(b), sig_b)
                if abs(np.median(a) - np.median(b)) <= k_sigma * sc:
                    long_segs[-1][1] = e
                    continue
        long_segs.append([s, e])
    # 5. trim slow settling, drop ramps
    min_blocks = max(3, int(math.ceil(min_dwell_s / (B * tau0))))
    kept: list[tuple[int, int]] = []
    ramps = 0
    ignored = 0
    for s, e in long_segs:
        blk = m[s:e + 1]
        half = blk[len(blk) // 2:]
        ref = float(np.median(half))
        # scatter of the settled half from block-to-block differences (a trend does not count)
        sc = _robust_std(np.diff(half)) / math.sqrt(2.0) if len(half) > 2 else 0.0
        tol = max(thr, k_sigma * sc)
        dev = np.abs(blk - ref) > tol
        i0, i1 = 0, len(blk) - 1
        while i0 < i1 and dev[i0]:
            i0 += 1
        while i1 > i0 and dev[i1]:
            i1 -= 1
        s2, e2 = s + i0, s + i1
        if e2 - s2 + 1 < min_blocks:
            ignored += 1
            continue
        seg = m[s2:e2 + 1]
        tt = np.arange(len(seg), dtype=float)
        slope = np.polyfit(tt, seg, 1)[0] if len(seg) >= 3 else 0.0
        if abs(slope) * len(seg) > tol:
            ramps += 1
            continue
        kept.append((s2, e2))
    segs: list[Segment] = []
    prev_end = 0
    for s, e in kept:
        start = s * B
        stop = n if e == nb - 1 else (e + 1) * B
        segs.append(Segment(start=start, stop=stop, change=prev_end,
                            level=float(np.median(m[s:e + 1]))))
        prev_end = stop
    info = {"block_s": B * tau0, "noise_block": sig_b, "threshold": thr,
            "ignored_short": ignored, "ramps": ramps}
    return segs, info


# ----------------------------------------------------------------------------- input rates
def _zero_level(levels: np.ndarray, earth_rate_dph: float) -> tuple[float, str]:
    """Output at zero table rate, to centre the detected levels before snapping: a zero-rate
    plateau if there is one (a level much closer to the earth rate than any other), else the
    midpoint of the smallest ± pair (least affected by scale-factor asymmetry), else the
    earth rate itself."""
    d = np.abs(levels - earth_rate_dph)
    i = int(np.argmin(d))
    others = np.delete(d, i)
    if len(others) and d[i] < 0.05 * float(np.min(others)):
        return float(levels[i]), "the zero-rate plateau"
    pos = np.sort(levels[levels > earth_rate_dph])
    neg = levels[levels < earth_rate_dph]
    for p in pos:  # smallest first
        if len(neg) == 0:
            break
        j = int(np.argmin(np.abs((p - earth_rate_dph) + (neg[:] - earth_rate_dph))))
        if abs((p - earth_rate_dph) + (neg[j] - earth_rate_dph)) < 0.01 * abs(p - earth_rate_dph):
            return 0.5 * (p + float(neg[j])), "the smallest ± pair"
    return float(earth_rate_dph), "the earth rate"


def _snap_one(x: float, tol: float) -> float | None:
    """Shortest decimal within relative ``tol`` of x, unique at its number of digits."""
    if x == 0:
        return 0.0
    e = math.floor(math.log10(abs(x)))
    for digits in range(1, 7):
        q = 10.0 ** (e - digits + 1)
        c = round(x / q)
        cands = [k * q for k in (c - 1, c, c + 1) if abs(k * q - x) <= tol * abs(x)]
        if len(cands) == 1:
            return float(f"{cands[0]:.{digits + 2}g}")
        if len(cands) > 1:
            return None
    return None


def snap_rates(levels_dph: np.ndarray, stderr_dph: np.ndarray, *, earth_rate_dph: float = 0.0,
               rates_dps: list[float] | None = None, snap_tol: float = 3e-3,
               source: str = "") -> tuple[np.ndarray, str]:
    """Table rates (deg/h) of plateaus detected in the output, without a commanded column.

    The output level at zero table rate b is taken from a zero-rate plateau, else from the
    smallest ± pair, else the earth rate; x_i = (L_i − b)/3600 deg/s is then matched to ``rates_dps`` (each ± and 0)
    within ``snap_tol`` relative, or, without a list, snapped to the shortest decimal that lies
    within ``snap_tol`` (relative) of x_i and is unique at that number of digits (e.g. 499.7 →
    500, 0.3502 → 0.35; 123.45 is ambiguous → error). ``snap_tol`` must cover the scale-factor
    error of the gyro (default 0.3 %). Returns (table_rate_dph, description).
    """
    L = np.asarray(levels_dph, dtype=float)
    se = np.asarray(stderr_dph, dtype=float)
    b, how = _zero_level(L, earth_rate_dph)
    x = (L - b) / DPS
    zero_tol = 20.0 * np.nan_to_num(se, nan=0.0) / DPS
    out = np.empty_like(x)
    if rates_dps is not None:
        mags = sorted({abs(float(r)) for r in rates_dps if r != 0})
        if not mags:
            raise InputError("--rates lists no non-zero rate")
        cands = np.array(sorted({0.0} | {m for m in mags} | {-m for m in mags}))
        rmin = mags[0]
        for i, xi in enumerate(x):
            j = int(np.argmin(np.abs(cands - xi)))
            c = cands[j]
            lim = snap_tol * (abs(c) if c != 0 else rmin) + zero_tol[i]
            if abs(xi - c) > lim:
                raise InputError(
                    f"{source}: the plateau at output {L[i] / DPS:+.6g} deg/s matches none of "
                    f"--rates within {snap_tol:g} (relative); check the list or raise --snap-tol")
            out[i] = c * DPS
        return out, f"matched to --rates (zero-rate output from {how})"
    nz = np.abs(x) > zero_tol
    if not nz.any():
        raise AnalysisError(f"{source}: every detected plateau is at zero rate; a scale factor "
                            "needs non-zero input rates")
    rmin = float(np.min(np.abs(x[nz])))
    for i, xi in enumerate(x):
        if abs(xi) <= max(zero_tol[i], 0.05 * rmin):
            out[i] = 0.0
            continue
        c = _snap_one(float(xi), snap_tol)
        if c is None:
            raise InputError(
                f"{source}: cannot infer the input rate of the plateau at output "
                f"{L[i] / DPS:+.6g} deg/s (no unique round value within {snap_tol:g}); give the "
                "commanded rates with --rates or a table-rate column (--table-col)")
        out[i] = c * DPS
    return out, f"snapped to round values (zero-rate output from {how})"


def assign_sweeps(rates_dph: np.ndarray) -> np.ndarray:
    """Sweep number of each plateau (time order): a new sweep starts when a non-zero rate
    repeats within the current sweep; zero-rate plateaus never start one. The sweeps are the
    "test series" whose scale factors give the stability (IEEE 952 §12.9.4.2.4)."""
    sweep = np.zeros(len(rates_dph), dtype=int)
    seen: set[float] = set()
    k = 0
    for i, r in enumerate(rates_dph):
        key = round(float(r), 6)
        if key != 0.0 and key in seen:
            k += 1
            seen = set()
        if key != 0.0:
            seen.add(key)
        sweep[i] = k
    return sweep


# ----------------------------------------------------------------------------- main entry
def extract_plateaus(log, run: str | None = None, *, settle_s: float = 0.0,
                     auto_settle: bool = True,
                     trim_end_s: float = 0.0, min_dwell_s: float = 2.0, detect: str = "auto",
                     rates_dps: list[float] | None = None, snap_tol: float = 3e-3,
                     stderr: str = "allan", n_batches: int = 32, k_sigma: float = 6.0
                     ) -> RunPlateaus:
    """Reduce a continuous rate-table log to plateau points (IEEE 952 §12.9.3.1/§12.9.4).

    ``detect``: ``auto`` (commanded column if the log has one, else the output), ``table`` or
    ``output``. Each plateau's window is [change + settle, next change − trim_end_s], with
    settle the settling time found in the plateau's data (:func:`find_settling`) but at least
    ``settle_s`` (``auto_settle=False``: ``settle_s`` exactly); its
    mean output (deg/h, S0 × native output), batch-means standard error (see module doc),
    sample count, and mean of the first temperature channel (degC). The earth-rate component
    along the IA (from ``log.site``; 0 without a site) is stored with each point so that the
    input is table rate + Ω_IA. ``stderr``: ``allan`` (default, :func:`allan_stderr`: σ_A at
    the plateau length from the run's pooled noise model) or ``batch`` (:func:`mean_stderr`).
    Raises :class:`~gyrotest.core.errors.InputError` naming the rate and the run for a plateau that
    does not settle within its dwell or is left with fewer than 8 samples after
    settling/trimming ("shorter than the settling time").
    """
    if detect not in ("auto", "table", "output"):
        raise InputError(f"unknown plateau detection {detect!r}; use auto, table or output")
    if stderr not in ("allan", "batch"):
        raise InputError(f"unknown standard-error method {stderr!r}; use allan or batch")
    src = log.source
    run = run or src
    t = log.t
    y = log.rate
    tau0 = log.tau0
    notes: list[str] = []
    er = log.site.earth_rate_dph() if log.site is not None else 0.0
    if log.site is None:
        notes.append("no site (latitude/IA) given: the earth rate is not removed from the input; "
                     "the bias then includes it")
    use_table = log.table_rate is not None and detect in ("auto", "table")
    if detect == "table" and log.table_rate is None:
        raise InputError(f"{src}: --detect table but the log has no table-rate column; name it "
                         "with --table-col or use --detect output")
    info: dict = {}
    segs: list[Segment] = []
    method = "table column"
    ignored = 0
    if use_table:
        tr = log.table_rate
        starts, stops = constant_runs(tr)
        dur = t[np.minimum(stops, len(t) - 1)] - t[starts]
        dur = np.where(stops >= len(t), t[-1] - t[starts] + tau0, dur)
        ok = dur >= min_dwell_s
        ignored = int(np.count_nonzero(~ok & (stops - starts > 1)))
        covered = float(np.sum(dur[ok])) / max(log.duration_s, tau0)
        if ok.sum() >= 1 and covered > 0.3:
            for s, e in zip(starts[ok].tolist(), stops[ok].tolist()):
                segs.append(Segment(start=s, stop=e, change=s, level=float(tr[s])))
        else:
            # a measured (noisy) table rate: find its steps like an output signal
            segs, info = detect_steps(tr, tau0, min_dwell_s=min_dwell_s, k_sigma=k_sigma)
            ignored = info["ignored_short"]
            method = "table column (measured, steps detected)"
            notes.append("the table-rate column is not piecewise constant; its plateaus were found "
                         "by step detection")
    else:
        segs, info = detect_steps(y, tau0, min_dwell_s=min_dwell_s, k_sigma=k_sigma)
        ignored = info["ignored_short"]
        method = "detected"
        if info.get("ramps"):
            notes.append(f"{info['ramps']} ramp-like stretch(es) ignored")
    if not segs:
        raise AnalysisError(
            f"{src}: no rate plateau of at least {min_dwell_s:g} s found"
            + (f" ({ignored} shorter stretch(es) ignored; lower --min-dwell)" if ignored else ""))
    temp = next(iter(log.temperature.values())) if log.temperature else None
    rows = []
    windows = []
    prev_level = math.nan
    for k, sg in enumerate(segs):
        t_change = float(t[sg.change])
        t_first = float(t[sg.start])
        t_stop = float(t[sg.stop - 1]) + tau0
        lvl = (float(log.table_rate[sg.start]) if use_table and method == "table column"
               else sg.level) / DPS
        what = "commanded" if use_table else "output"
        st = find_settling(y[sg.change:sg.stop], tau0)
        st.from_rate_dps, st.to_rate_dps = prev_level, lvl
        prev_level = lvl
        if auto_settle and not st.settled:
            raise InputError(
                f"{src} (run {run}): the plateau at {what} {lvl:+.6g} deg/s (t = {t_change:.6g}…"
                f"{t_stop:.6g} s) is still settling after {st.found_s:.3g} s of its "
                f"{t_stop - t_change:.4g} s (transient above the plateau's noise floor); record "
                "longer dwells, or force a settling time with --settle S --fixed-settle")
        settle = max(settle_s, st.found_s) if auto_settle else settle_s
        st.used_s = settle
        w0 = max(t_change + settle, t_first)
        w1 = t_stop - trim_end_s
        i0 = int(np.searchsorted(t, w0 - 1e-9 * tau0, side="left"))
        i1 = int(np.searchsorted(t, w1 - 1e-9 * tau0, side="left"))
        i0, i1 = max(i0, sg.start), min(i1, sg.stop)
        st.used_s = float(t[min(i0, len(t) - 1)]) - t_change
        if i1 - i0 < 8:
            how = ("found in the data" if auto_settle and st.found_s >= settle_s
                   else "--settle")
            raise InputError(
                f"{src} (run {run}): the plateau at {what} {lvl:+.6g} deg/s (plateau {k + 1}, "
                f"t = {t_change:.6g}…{t_stop:.6g} s) lasts {t_stop - t_change:.4g} s, not "
                f"longer than its settling time {settle:.3g} s ({how}) + end trim "
                f"{trim_end_s:g} s; record longer dwells or lower --settle/--trim-end")
        mean, se, se_w = mean_stderr(y[i0:i1], n_batches)
        windows.append(y[i0:i1])
        tmean = float(np.mean(temp[i0:i1])) if temp is not None else math.nan
        if use_table:
            table = float(np.mean(log.table_rate[i0:i1]))
        else:
            table = math.nan
        rows.append(dict(index=k, table=table, out=mean, se=se, se_w=se_w, t0=float(t[i0]),
                         t1=float(t[i1 - 1]) + tau0, c0=t_change, c1=t_stop, n=i1 - i0,
                         temp=tmean, settling=st))
    if stderr == "allan":
        se_a, ainfo = allan_stderr(windows, tau0)
        for r, v in zip(rows, se_a):
            r["se"] = float(v)
        if ainfo.get("inflated"):
            notes.append(f"{ainfo['inflated']} plateau(s) noisier than the others at short τ "
                         "(their standard errors scaled up)"
                         + ("" if auto_settle else "; if that is unfinished settling, raise "
                            "--settle or drop --fixed-settle"))
    if use_table:
        rate_source = method
    else:
        L = np.array([r["out"] for r in rows])
        se = np.array([r["se"] for r in rows])
        tab, how = snap_rates(L, se, earth_rate_dph=er, rates_dps=rates_dps, snap_tol=snap_tol,
                              source=src)
        for r, v in zip(rows, tab):
            r["table"] = float(v)
        rate_source = f"detected, {how}"
        notes.append(f"no commanded-rate column: {len(rows)} plateaus detected in the output, "
                     f"input rates {how}")
    tabs = np.array([r["table"] for r in rows])
    sweeps = assign_sweeps(tabs)
    plateaus = [
        Plateau(run=run, index=r["index"], table_rate_dph=r["table"], earth_rate_dph=er,
                output_dph=r["out"], stderr_dph=r["se"], t_start_s=r["t0"], t_end_s=r["t1"],
                dwell_start_s=r["c0"], dwell_end_s=r["c1"], n_samples=r["n"],
                temperature_degC=r["temp"], stderr_white_dph=r["se_w"], rate_source=rate_source,
                sweep=int(sw), settling=r["settling"])
        for r, sw in zip(rows, sweeps)
    ]
    return RunPlateaus(run=run, source=src, plateaus=plateaus, method=method,
                       earth_rate_dph=er, settle_s=settle_s, trim_end_s=trim_end_s,
                       noise_block_dph=info.get("noise_block", math.nan),
                       block_s=info.get("block_s", math.nan), ignored_short=ignored, notes=notes,
                       stderr_method=stderr, auto_settle=auto_settle,
                       power_on=power_on_label(log))
