"""Frequency-domain and correlation views of a gyro rate record.

The Allan deviation is one projection of the rate PSD; a few things are easier to see in the
spectrum or in the correlation function (Krobka §4 and §7 feature 9: "autocorrelation
and PSD views"; notes-allan-topology M8 "noise is white"):

* a sinusoid (dither residue, mechanical resonance) is a *line* in the PSD at f0, while in
  σ(τ) it is a lobe at τ ≈ 0.371/f0 with nulls at k/f0 that a 10-per-decade τ grid may miss;
* a Markov hump is a Lorentzian knee at f_c = 1/(2π T_c) and an exponential ACF e^(−|τ|/T_c);
* the cross-correlation of the axes of a multi-axis unit is Krobka's "minimum necessary
  information" for strapdown use (Krobka (Allan-graph topology) conclusions; noise correlation matrix eq. 2.36).

Conventions (as :mod:`gyrotest.noise.terms`): rate in deg/h, time in s, frequency in Hz, and
the PSD is the **two-sided** rate PSD S(f) in (deg/h)²/Hz evaluated on f > 0, normalised so that
the variance of the samples is ∫_{−fs/2}^{fs/2} S df and white noise S = N² has σ²(τ) = N²/τ
(IEEE 952 Annex C; Krobka (Allan-graph topology) eq. 5.1). scipy's one-sided Welch density P is therefore halved.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import special

__all__ = [
    "Autocorrelation",
    "CrossCorrelation",
    "PsdEstimate",
    "SpectralLine",
    "autocorrelation",
    "cross_correlation",
    "find_lines",
    "welch_psd",
]

#: At most this many samples enter the Welch estimate (the first ones): bounds the cost on
#: 10^8-sample records; the lowest resolved frequency is set by the segment length anyway.
WELCH_MAX_SAMPLES = 1 << 23


@dataclass
class PsdEstimate:
    """A Welch PSD estimate: ``f`` (Hz, > 0), ``psd`` two-sided (deg/h)²/Hz, ``dof`` the χ²
    degrees of freedom of each bin (≈ 2 × the number of averaged segments, Hann, 50 % overlap
    counted as 0.9 effective), ``nperseg``, ``tau0`` (s) and notes."""

    f: np.ndarray
    psd: np.ndarray
    dof: float
    nperseg: int
    tau0: float
    n_used: int
    notes: list[str] = field(default_factory=list)

    def log_binned(self, per_decade: int = 20) -> tuple[np.ndarray, np.ndarray]:
        """Geometric-mean frequency and mean PSD in log-spaced bins (for plotting)."""
        f, p = self.f, self.psd
        if f.size < 2:
            return f, p
        k = np.arange(math.floor(math.log10(f[0]) * per_decade),
                      math.ceil(math.log10(f[-1]) * per_decade) + 2)
        edges = 10.0 ** (k / per_decade)
        idx = np.digitize(f, edges)
        fo, po = [], []
        for k in np.unique(idx):
            sel = idx == k
            fo.append(float(np.exp(np.mean(np.log(f[sel])))))
            po.append(float(np.mean(p[sel])))
        return np.array(fo), np.array(po)

    def to_dict(self, per_decade: int = 20) -> dict[str, Any]:
        fb, pb = self.log_binned(per_decade)
        return {
            "method": "Welch, Hann window, 50 % overlap, mean removed per segment; two-sided "
                      "rate PSD (variance = ∫ S df over ±fs/2)",
            "unit": "(deg/h)^2/Hz",
            "nperseg": int(self.nperseg),
            "samples_used": int(self.n_used),
            "dof_per_bin": float(self.dof),
            "f_hz": fb.tolist(),
            "psd": pb.tolist(),
            "notes": list(self.notes),
        }


def _segment_length(n: int, tau0: float, f_min: float | None) -> int:
    """Power-of-two segment length: long enough for ``f_min`` (if given), at least 8 segments."""
    target = n // 8 if n >= 64 else n
    if f_min is not None and f_min > 0:
        target = min(target, int(2 ** math.ceil(math.log2(max(4.0 / (f_min * tau0), 16)))))
    nper = 1 << max(4, int(math.floor(math.log2(max(target, 16)))))
    return int(min(nper, n, 1 << 20))


def welch_psd(rate: np.ndarray, tau0: float, *, segments: Sequence[tuple[int, int]] | None = None,
              nperseg: int | None = None, f_min: float | None = None) -> PsdEstimate:
    """Welch estimate of the two-sided rate PSD S(f), (deg/h)²/Hz (Krobka (Allan-graph topology) eq. 5.1 convention).

    ``S(f) = P_welch(f)/2`` with scipy's one-sided density (Hann window, 50 % overlap, each
    segment's mean removed). Gap-aware: segments of the record (``segments``, sample index
    ranges) are processed separately and the periodograms averaged, weighted by the number of
    Welch segments; parts shorter than ``nperseg`` are skipped. Each bin is ≈ χ² with
    ``dof`` ≈ 2·0.9·(number of averaged segments) degrees of freedom (Welch 1967; Percival &
    Walden 1993 §6.17). ``f_min`` asks for a segment long enough to resolve that frequency.
    """
    x = np.asarray(rate, dtype=float)
    n = x.size
    segs = list(segments) if segments else [(0, n)]
    longest = max(b - a for a, b in segs)
    if nperseg is None:
        nperseg = _segment_length(longest, tau0, f_min)
    nperseg = int(max(8, min(nperseg, longest)))
    fs = 1.0 / tau0
    acc = None
    count = 0
    used = 0
    notes: list[str] = []
    for a, b in segs:
        if b - a < nperseg:
            continue
        b = min(b, a + WELCH_MAX_SAMPLES)
        part = x[a:b]
        k = 1 + (part.size - nperseg) // (nperseg // 2)
        f, p = _welch_density(part, fs, nperseg)
        acc = p * k if acc is None else acc + p * k
        count += k
        used += part.size
    if acc is None:
        raise ValueError("record too short for a Welch PSD")
    if used < sum(b - a for a, b in segs):
        notes.append(f"PSD from the first {used} samples ({WELCH_MAX_SAMPLES} per segment at most)")
    psd = 0.5 * acc / count
    keep = f > 0
    return PsdEstimate(f=f[keep], psd=psd[keep], dof=2.0 * 0.9 * count if count > 1 else 2.0,
                       nperseg=nperseg, tau0=tau0, n_used=used, notes=notes)


def _welch_density(x: np.ndarray, fs: float, nperseg: int) -> tuple[np.ndarray, np.ndarray]:
    """One-sided Welch PSD density of ``x``: periodic Hann window, 50 % overlap, the mean of
    each segment removed, |FFT|² averaged over segments (Welch 1967) — the same numbers as
    ``scipy.signal.welch(x, fs, window="hann", nperseg=nperseg, noverlap=nperseg // 2,
    detrend="constant", scaling="density")`` (checked in the tests), without importing
    scipy.signal (≈ 0.5–1 s) and with the segments transformed in cache-sized batches."""
    step = nperseg - nperseg // 2
    k = 1 + (x.size - nperseg) // step
    win = 0.5 - 0.5 * np.cos(2.0 * np.pi * np.arange(nperseg) / nperseg)  # periodic Hann
    scale = 1.0 / (fs * float(np.dot(win, win)))
    segs = np.lib.stride_tricks.as_strided(x, shape=(k, nperseg),
                                           strides=(step * x.strides[0], x.strides[0]),
                                           writeable=False)
    acc = np.zeros(nperseg // 2 + 1)
    batch = max(1, (1 << 20) // nperseg)
    for i in range(0, k, batch):
        blk = segs[i:i + batch]
        blk = (blk - blk.mean(axis=1, keepdims=True)) * win
        spec = np.fft.rfft(blk, axis=1)
        acc += (spec.real ** 2 + spec.imag ** 2).sum(axis=0)
    p = acc * (scale / k)
    p[1:] *= 2.0  # one-sided: fold the negative frequencies
    if nperseg % 2 == 0:
        p[-1] /= 2.0  # the Nyquist bin has no mirror
    return np.arange(nperseg // 2 + 1) * (fs / nperseg), p


@dataclass
class SpectralLine:
    """A narrow spectral line: frequency ``f_hz``, amplitude ``amplitude_dph`` (of Ω0·sin),
    ``snr`` (peak / local background), ``significance`` (χ² tail probability of the peak
    under the background)."""

    f_hz: float
    amplitude_dph: float
    snr: float
    p_value: float

    def to_dict(self) -> dict[str, float]:
        return {"f_hz": self.f_hz, "amplitude_dph": self.amplitude_dph, "snr": self.snr,
                "p_value": self.p_value}


def _background(f: np.ndarray, p: np.ndarray, half_width: float = 0.1) -> np.ndarray:
    """Robust PSD background: median over ±``half_width`` decade (at least ±4 bins), evaluated
    at 20 centres per decade and interpolated in log–log (O(n) instead of a median per bin)."""
    lf = np.log10(f)
    nb = f.size
    centres = np.arange(lf[0], lf[-1] + 0.05, 0.05)
    vals = np.empty(centres.size)
    for k, c in enumerate(centres):
        a = int(np.searchsorted(lf, c - half_width))
        b = int(np.searchsorted(lf, c + half_width, side="right"))
        i = int(np.clip(np.searchsorted(lf, c), 0, nb - 1))
        a, b = min(a, max(i - 4, 0)), max(b, min(i + 5, nb))
        vals[k] = np.median(p[a:b])
    vals = np.maximum(vals, np.finfo(float).tiny)
    return 10.0 ** np.interp(lf, centres, np.log10(vals))


def find_lines(psd: PsdEstimate, *, max_lines: int = 3, p_false: float = 1e-6,
               min_snr: float = 4.0) -> list[SpectralLine]:
    """Narrow lines standing out of the local PSD background (sinusoid candidates).

    Background = running median over ±1/10 decade (robust to the line itself). A bin is a line
    candidate when its PSD exceeds the background by ``min_snr`` and the χ² tail probability
    P(χ²_ν > ν·ratio) with ν = ``psd.dof`` is below ``p_false``/n_bins (Bonferroni). Adjacent
    bins merge; the frequency is the power-weighted centroid of the merged bins, and the
    amplitude of Ω0 sin(2πf0 t) follows from the line power above the background:
    Ω0 = sqrt(4·Σ(S_k − S_bg)·Δf) (two-sided S: each of ±f0 carries Ω0²/4).
    """
    f, p = psd.f, psd.psd
    nb = f.size
    if nb < 16:
        return []
    bg = _background(f, p)
    ratio = p / bg
    nu = max(psd.dof, 2.0)
    above = ratio > min_snr
    pv = np.ones(nb)  # χ² survival, needed only above min_snr (a line's peak bin is there too)
    pv[above] = special.chdtrc(nu, nu * ratio[above])
    cand = above & (pv < p_false / nb)
    cand[0] = False  # the lowest bin is not a line
    lines: list[SpectralLine] = []
    df = f[1] - f[0] if nb > 1 else f[0]
    idx = np.flatnonzero(cand)  # runs of adjacent candidate bins (no Python loop over bins)
    starts = idx[np.r_[True, np.diff(idx) > 1]] if idx.size else idx
    ends = idx[np.r_[np.diff(idx) > 1, True]] if idx.size else idx
    for i, j in zip(starts.tolist(), ends.tolist()):
        a, b = max(i - 1, 0), min(j + 2, nb)
        excess = np.maximum(p[a:b] - bg[a:b], 0.0)
        tot = float(np.sum(excess))
        if tot > 0:
            fc = float(np.sum(f[a:b] * excess) / tot)
            amp = math.sqrt(4.0 * tot * df)
            k = a + int(np.argmax(ratio[a:b]))
            lines.append(SpectralLine(fc, amp, float(ratio[k]), float(pv[k])))
    lines.sort(key=lambda ln: -ln.amplitude_dph)
    return lines[:max_lines]


@dataclass
class Autocorrelation:
    """Normalised autocorrelation ρ(lag) of the rate (mean removed), lags in s, and the
    approximate 95 % white-noise band ±1.96/√n."""

    lag_s: np.ndarray
    rho: np.ndarray
    band: float
    n: int

    def to_dict(self, max_points: int = 200) -> dict[str, Any]:
        idx = np.unique(np.round(np.geomspace(1, max(self.lag_s.size - 1, 1), max_points))
                        .astype(int)) if self.lag_s.size > max_points else np.arange(self.lag_s.size)
        idx = np.concatenate(([0], idx[idx > 0]))
        return {"method": "FFT autocorrelation of the mean-removed rate, biased estimator",
                "lag_s": self.lag_s[idx].tolist(), "rho": self.rho[idx].tolist(),
                "white_noise_band_95": self.band, "n": self.n}


def _fast_len(n: int) -> int:
    """The smallest 2^a·3^b·5^c ≥ n (a quick FFT length, at most ≈ 1.1 n for large n)."""
    best = 1 << max(0, (n - 1).bit_length())
    p5 = 1
    while p5 < best:
        p35 = p5
        while p35 < best:
            v = p35
            while v < n:
                v *= 2
            best = min(best, v)
            p35 *= 3
        p5 *= 5
    return best


def autocorrelation(rate: np.ndarray, tau0: float, *, max_lag: int | None = None,
                    max_samples: int = 1 << 22) -> Autocorrelation:
    """ρ(k) = Σ (x_i − x̄)(x_{i+k} − x̄) / Σ (x_i − x̄)² (biased estimator; Box & Jenkins), by FFT
    on at most ``max_samples`` samples, lags 0 … ``max_lag`` (default n/10, ≤ 10⁵). Lags in s.
    White noise: |ρ(k≥1)| < 1.96/√n at 95 % (Bartlett). Krobka (Allan-graph topology Fig. 4.1) used such
    ACFs to show FOG noise is not white."""
    x = np.asarray(rate[:max_samples], dtype=float)
    x = x - x.mean()
    n = x.size
    if max_lag is None:
        max_lag = min(n // 10, 100_000)
    max_lag = int(max(1, min(max_lag, n - 1)))
    nfft = _fast_len(n + max_lag)  # no circular wrap into lags ≤ max_lag
    X = np.fft.rfft(x, nfft)
    del x
    p = X.real ** 2  # |X|² = X·conj(X) exactly, without the complex temporaries
    p += X.imag ** 2
    del X
    r = np.fft.irfft(p, nfft)[: max_lag + 1]
    rho = r / r[0] if r[0] > 0 else np.zeros_like(r)
    return Autocorrelation(np.arange(max_lag + 1) * tau0, rho, 1.96 / math.sqrt(n), n)


@dataclass
class CrossCorrelation:
    """Correlation-coefficient matrices of the axes' rates averaged over τ (s): ``tau`` list,
    ``matrices[i]`` the k×k matrix at ``tau[i]`` (k = number of axes), with the approximate 95 %
    half-width for zero correlation ``band[i]`` = 1.96/√(number of averages)."""

    axes: list[str]
    tau: list[float]
    matrices: list[np.ndarray]
    band: list[float]

    def max_offdiag(self) -> tuple[float, float, str, str]:
        """(|ρ|, τ, axis a, axis b) of the largest off-diagonal correlation."""
        best = (0.0, math.nan, "", "")
        k = len(self.axes)
        for t, m in zip(self.tau, self.matrices):
            for i in range(k):
                for j in range(i + 1, k):
                    if abs(m[i, j]) > best[0]:
                        best = (abs(float(m[i, j])), t, self.axes[i], self.axes[j])
        return best

    def to_dict(self) -> dict[str, Any]:
        return {
            "method": "Pearson correlation of non-overlapping τ-averages of each axis' rate "
                      "(mean removed); 95 % band for zero correlation 1.96/sqrt(n)",
            "axes": list(self.axes),
            "tau_s": [float(t) for t in self.tau],
            "matrices": [m.tolist() for m in self.matrices],
            "band_95": [float(b) for b in self.band],
        }


def cross_correlation(rates: dict[str, np.ndarray], tau0: float, *,
                      taus: Sequence[float] | None = None,
                      segments: Sequence[tuple[int, int]] | None = None) -> CrossCorrelation:
    """Correlation matrix of the axes at several averaging times (Krobka (Allan-graph topology) eq. 2.36: the
    noise correlation matrix K(t1, t2) is the minimum information for three gyros).

    For each τ = m·τ0 the rates are averaged over non-overlapping blocks of m samples within
    each gap-free segment, and ρ_ab = cov(ā, b̄)/(σ_ā σ_b̄) over the blocks (the "correlation
    coefficients" of Krobka's Fig. 4.1, extended to the averaging times of the Allan graph).
    Default τ: τ0 and every decade up to T/30.
    """
    axes = list(rates)
    n = len(next(iter(rates.values())))
    segs = list(segments) if segments else [(0, n)]
    if taus is None:
        T = n * tau0
        taus = [tau0] + [10.0**k for k in range(-3, 7) if tau0 < 10.0**k <= T / 30]
    out_t, out_m, out_b = [], [], []
    seen: set[int] = set()
    for tau in taus:
        m = max(1, int(round(tau / tau0)))
        if m in seen:
            continue
        seen.add(m)
        blocks = []
        for a, b in segs:
            nb = (b - a) // m
            if nb < 1:
                continue
            blocks.append(np.stack([rates[k][a:a + nb * m].reshape(nb, m).mean(axis=1)
                                    for k in axes]))
        if not blocks:
            continue
        Y = np.concatenate(blocks, axis=1)
        if Y.shape[1] < 10:
            continue
        with np.errstate(invalid="ignore", divide="ignore"):
            C = np.corrcoef(Y)
        C = np.atleast_2d(np.nan_to_num(C, nan=0.0))
        out_t.append(m * tau0)
        out_m.append(C)
        out_b.append(1.96 / math.sqrt(Y.shape[1]))
    return CrossCorrelation(axes, out_t, out_m, out_b)
