"""Equivalent degrees of freedom, χ² confidence intervals and power-law noise identification.

Conventions
-----------
* Power-law noise is named by α, the exponent of the *rate* PSD S_Ω(f) ∝ f^α (the fractional
  frequency PSD S_y of time and frequency metrology): α = 2 white angle noise (white PM),
  1 flicker angle (flicker PM), 0 white rate = angle random walk (white FM), −1 flicker rate =
  bias instability (flicker FM), −2 rate random walk (random-walk FM); −3 and −4 (flicker walk
  and random run) are reachable only by the Hadamard family.
* ``n_phase`` is the number of angle (phase) points of the record, i.e. the length of the
  integrated series θ (rate input: number of rate samples + 1).

Sources
-------
* C. A. Greenhall and W. J. Riley, "Uncertainty of stability variances based on finite
  differences", Proc. 35th PTTI (2003/2004): the EDF algorithm (eqs. 7-10, cases 1-4,
  Tables 1-3) in :func:`edf_greenhall`, written here from the published description.
* NIST SP1065 (W. J. Riley, *Handbook of Frequency Stability Analysis*, 2008): Table 5
  (simple EDF, :func:`edf_simple`), Table 7 (TOTDEV, :func:`edf_totdev`), Table 8 (MTOTDEV,
  :func:`edf_mtotdev`), eq. 45 (χ² interval, :func:`chi2_interval`).
* W. J. Riley and C. A. Greenhall, "Power law noise identification using the lag 1
  autocorrelation", Proc. 18th EFTF (2004): :func:`acf_noise_id`.
* J. A. Barnes, "Tables of bias functions B1 and B2", NBS TN 375 (1969), and D. A. Howe et al.
  (2000) for the B1 ratio; IEEE Std 1139 for the R(n) = MVAR/AVAR ratio (:func:`b1_noise_id`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from statistics import NormalDist

import numpy as np
from scipy import special

from ..core.errors import AnalysisError, InputError

__all__ = [
    "DEFAULT_CONFIDENCE",
    "NoiseId",
    "acf_noise_id",
    "b1_noise_id",
    "b1_theory",
    "chi2_interval",
    "edf_for",
    "edf_greenhall",
    "edf_mtotdev",
    "edf_simple",
    "edf_totdev",
    "identify_noise",
    "lag1_acf",
]

#: Stable32's default confidence factor ("Confidence Factor = 0.683").
DEFAULT_CONFIDENCE = 0.683

#: Greenhall & Riley (2004) Table 1: (a0, a1) for modified variances (F = 1), by α then d.
_GR_TABLE1: dict[int, dict[int, tuple[float, float]]] = {
    2: {1: (2 / 3, 1 / 3), 2: (7 / 9, 1 / 2), 3: (22 / 25, 2 / 3)},
    1: {1: (0.840, 0.345), 2: (0.997, 0.616), 3: (1.141, 0.843)},
    0: {1: (1.079, 0.368), 2: (1.033, 0.607), 3: (1.184, 0.848)},
    -1: {2: (1.048, 0.534), 3: (1.180, 0.816)},
    -2: {2: (1.302, 0.535), 3: (1.175, 0.777)},
    -3: {3: (1.194, 0.703)},
    -4: {3: (1.489, 0.702)},
}
#: Greenhall & Riley (2004) Table 2: (a0, a1) for unmodified variances (F = m), by α then d.
_GR_TABLE2: dict[int, dict[int, tuple[float, float]]] = {
    2: {1: (3 / 2, 1 / 2), 2: (35 / 18, 1.0), 3: (231 / 100, 3 / 2)},
    1: {1: (78.6, 25.2), 2: (790.0, 410.0), 3: (9950.0, 6520.0)},
    0: {1: (2 / 3, 1 / 6), 2: (2 / 3, 1 / 3), 3: (7 / 9, 1 / 2)},
    -1: {2: (0.852, 0.375), 3: (0.997, 0.617)},
    -2: {2: (1.079, 0.368), 3: (1.033, 0.607)},
    -3: {3: (1.053, 0.553)},
    -4: {3: (1.302, 0.535)},
}
#: Greenhall & Riley (2004) Table 3: (b0, b1) for α = 1, unmodified variances, by d.
_GR_TABLE3: dict[int, tuple[float, float]] = {1: (6.0, 4.0), 2: (15.23, 12.0), 3: (47.8, 40.0)}
_GR_JMAX = 100

#: NIST SP1065 Table 7: TOTDEV EDF = b·(N/m) − c, by α (white, flicker, random-walk rate).
_SP1065_TABLE7: dict[int, tuple[float, float]] = {0: (1.50, 0.0), -1: (1.17, 0.22), -2: (0.93, 0.36)}
#: NIST SP1065 Table 8: MTOTDEV EDF = b·(N/m) − c, by α.
_SP1065_TABLE8: dict[int, tuple[float, float]] = {
    2: (1.90, 2.1),
    1: (1.20, 1.40),
    0: (1.10, 1.2),
    -1: (0.85, 0.50),
    -2: (0.75, 0.31),
}

#: EDF method labels, as they appear in ``DeviationResult.ci_method``.
CI_GREENHALL = "Greenhall-Riley EDF (2004), chi-square"
CI_TOTDEV = "NIST SP1065 Table 7 TOTDEV EDF, chi-square"
CI_MTOTDEV = "NIST SP1065 Table 8 MTOTDEV EDF, chi-square"
CI_SIMPLE = "NIST SP1065 Table 5 simple EDF, chi-square"


#: Largest vector handed to BLAS ``ddot`` in one call. OpenBLAS runs ddot multithreaded above
#: ~10 000 elements; on a busy machine its worker threads stall for milliseconds per call
#: (measured: 4x slower OADEV at 10^7 samples on a loaded 2-core VM), so longer dot products
#: are split into blocks of this size, which run single-threaded and stay cache-resident.
DOT_BLOCK = 8192


def blocked_dot(a: np.ndarray, b: np.ndarray) -> float:
    """Σ a_i·b_i as a float, in BLAS ddot blocks of :data:`DOT_BLOCK` elements."""
    n = a.size
    if n <= DOT_BLOCK:
        return float(np.dot(a, b))
    s = 0.0
    for i in range(0, n, DOT_BLOCK):
        s += float(np.dot(a[i : i + DOT_BLOCK], b[i : i + DOT_BLOCK]))
    return s


# ---------------------------------------------------------------------------------------------
# Greenhall & Riley EDF
# ---------------------------------------------------------------------------------------------


def _sw(t: np.ndarray, alpha: int) -> np.ndarray:
    """Greenhall & Riley eq. 7: the generalised autocovariance sw(t) of power-law noise α.

    −|t| (α=2), t²ln|t| (1), |t|³ (0), −t⁴ln|t| (−1), −|t|⁵ (−2), t⁶ln|t| (−3), |t|⁷ (−4),
    with 0·ln 0 = 0. (The overall sign of each α cancels in the EDF.)
    """
    a = np.abs(np.asarray(t, dtype=float))
    p = 3 - alpha
    sign = -1.0 if alpha in (2, -1, -2) else 1.0
    if alpha % 2 == 0:
        return sign * a**p
    with np.errstate(divide="ignore", invalid="ignore"):
        out = a**p * np.log(a)
    return sign * np.where(a > 0, out, 0.0)


def _sw_second_difference(t: np.ndarray, h: float, alpha: int) -> np.ndarray:
    """sw(t+h) + sw(t−h) − 2·sw(t), computed without cancellation for |t| > h.

    For |t|^p the binomial expansion leaves only even powers of h; for t^p·ln|t| we write
    ln|t±h| = ln|t| + log1p(±h/|t|), so the sum becomes
    ln|t|·Δ²(|t|^p) + E·log1p(−h²/t²) + 2·O·atanh(h/|t|), with E and O the even and odd
    parts of (|t|+h)^p. This keeps full precision for small h = 1/F (large averaging factors),
    where the direct form loses ~F² in relative accuracy.
    """
    t = np.abs(np.asarray(t, dtype=float))
    p = 3 - alpha
    sign = -1.0 if alpha in (2, -1, -2) else 1.0
    out = np.empty_like(t)
    near = t <= h
    if np.any(near):
        tn = t[near]
        out[near] = _sw(tn + h, alpha) + _sw(tn - h, alpha) - 2.0 * _sw(tn, alpha)
    far = ~near
    if np.any(far):
        a = t[far]
        even = np.zeros_like(a)  # sum over even k >= 2 of C(p,k) a^(p-k) h^k
        E = a**p  # even part of (a+h)^p, k = 0 term
        O = np.zeros_like(a)
        for k in range(1, p + 1):
            term = math.comb(p, k) * a ** (p - k) * h**k
            if k % 2 == 0:
                even += term
                E = E + term
            else:
                O = O + term
        if alpha % 2 == 0:
            out[far] = sign * 2.0 * even
        else:
            x = h / a
            val = np.log(a) * 2.0 * even + E * np.log1p(-x * x) + 2.0 * O * np.arctanh(x)
            out[far] = sign * val
    return out


def _sx(t: np.ndarray, F: float, alpha: int) -> np.ndarray:
    """Greenhall & Riley eq. 8: sx(t) = F²·[2sw(t) − sw(t−1/F) − sw(t+1/F)]; sw(t, α+2) if F = ∞."""
    if math.isinf(F):
        return _sw(t, alpha + 2)
    h = 1.0 / F
    return -(F * F) * _sw_second_difference(t, h, alpha)


def _sz(t: np.ndarray, F: float, alpha: int, d: int) -> np.ndarray:
    """Greenhall & Riley eq. 9: sz(t) = Σ_k (−1)^k C(2d, d+k) sx(t+k), k = −d…d."""
    t = np.asarray(t, dtype=float)
    out = np.zeros_like(t)
    for k in range(-d, d + 1):
        out = out + (-1) ** abs(k) * math.comb(2 * d, d + k) * _sx(t + k, F, alpha)
    return out


def _basic_sum(J: int, M: float, S: float, F: float, alpha: int, d: int) -> float:
    """Greenhall & Riley eq. 10:
    BasicSum = sz²(0) + (1 − J/M)·sz²(J/S) + 2·Σ_{j=1}^{J−1} (1 − j/M)·sz²(j/S)."""
    j = np.arange(1, int(J), dtype=float)
    head = _sz(np.array([0.0, J / S]), F, alpha, d) ** 2
    body = 2.0 * np.sum((1.0 - j / M) * _sz(j / S, F, alpha, d) ** 2) if j.size else 0.0
    return float(head[0] + (1.0 - J / M) * head[1] + body)


def edf_greenhall(
    alpha: int, d: int, m: int, n_phase: int, *, overlapping: bool, modified: bool
) -> float:
    """Equivalent degrees of freedom of a finite-difference variance (Greenhall & Riley 2004).

    Parameters
    ----------
    alpha : noise exponent, −4 … 2, with α + 2d > 1.
    d : order of the difference: 2 for the Allan family (ADEV, OADEV, MDEV, TDEV), 3 for the
        Hadamard family (HDEV, OHDEV); 1 for the first-difference variance.
    m : averaging factor, τ = m·τ0.
    n_phase : number of angle (phase) points N.
    overlapping : stride factor S = m (overlapping estimator) or S = 1.
    modified : filter factor F = 1 (modified variance: MDEV, TDEV) or F = m.

    Algorithm (paper eqs. 7-13): L = m/F + m·d, M = 1 + floor(S(N − L)/m), J = min(M, (d+1)S),
    r = M/S, J_max = 100, and 1/edf is BasicSum(J, M, S, F, α, d)/(M·sz²(0)) when J ≤ J_max,
    the Table 1/2 asymptote (a0 − a1/r)/r when r ≥ d+1, else a BasicSum with J_max terms and
    stride m' = J_max/r; α = 1 unmodified uses Table 3 (b0 + b1 ln m)² for large J and α = 2
    unmodified uses the exact white-noise form (1/edf = (1/M)[1 + 2Σ_{k<r, k≤d} (1 − k/r)
    C(2d, d−k)²/C(2d, d)²], which is a0 − a1/r of the paper when ⌈r⌉ > d).

    Returns the EDF (dimensionless). Raises :class:`AnalysisError` if N < L (no estimator term)
    or α + 2d ≤ 1 (the variance does not converge for that noise).
    """
    alpha = int(alpha)
    d = int(d)
    m = int(m)
    if d not in (1, 2, 3):
        raise InputError(f"difference order d must be 1, 2 or 3, got {d}")
    if not -4 <= alpha <= 2 or alpha + 2 * d <= 1:
        raise AnalysisError(
            f"no Greenhall EDF for alpha = {alpha} with d = {d} (needs -4 <= alpha <= 2 and "
            "alpha + 2d > 1): the variance does not converge for that noise"
        )
    F = 1.0 if modified else float(m)
    S = float(m) if overlapping else 1.0
    L = m / F + m * d
    if n_phase < L:
        raise AnalysisError(
            f"record too short for the EDF at m = {m}: {n_phase} angle points < L = {L:g}"
        )
    M = 1.0 + math.floor(S * (n_phase - L) / m)
    J = int(min(M, (d + 1) * S))
    r = M / S
    if modified:  # case 1: modified variances, all alpha
        if J <= _GR_JMAX:
            inv = _basic_sum(J, M, S, 1.0, alpha, d) / (M * float(_sz(np.array([0.0]), 1.0, alpha, d)[0]) ** 2)
        elif r >= d + 1:
            a0, a1 = _GR_TABLE1[alpha][d]
            inv = (a0 - a1 / r) / r
        else:
            mp = _GR_JMAX / r
            inv = _basic_sum(_GR_JMAX, _GR_JMAX, mp, 1.0, alpha, d) / (
                _GR_JMAX * float(_sz(np.array([0.0]), 1.0, alpha, d)[0]) ** 2
            )
        return 1.0 / inv
    if alpha <= 0:  # case 2: unmodified variances, alpha <= 0
        if J <= _GR_JMAX:
            mp = float(m) if m * (d + 1) <= _GR_JMAX else math.inf
            sz0 = float(_sz(np.array([0.0]), mp, alpha, d)[0])
            inv = _basic_sum(J, M, S, mp, alpha, d) / (M * sz0 * sz0)
        elif r >= d + 1:
            a0, a1 = _GR_TABLE2[alpha][d]
            inv = (a0 - a1 / r) / r
        else:
            mp = _GR_JMAX / r
            sz0 = float(_sz(np.array([0.0]), math.inf, alpha, d)[0])
            inv = _basic_sum(_GR_JMAX, _GR_JMAX, mp, math.inf, alpha, d) / (_GR_JMAX * sz0 * sz0)
        return 1.0 / inv
    if alpha == 1:  # case 3: unmodified variances, alpha = 1
        if J <= _GR_JMAX:
            sz0 = float(_sz(np.array([0.0]), float(m), 1, d)[0])
            inv = _basic_sum(J, M, S, float(m), 1, d) / (M * sz0 * sz0)
        elif r >= d + 1:
            a0, a1 = _GR_TABLE2[1][d]
            b0, b1 = _GR_TABLE3[d]
            inv = (a0 - a1 / r) / ((b0 + b1 * math.log(m)) ** 2 * r)
        else:
            mp = _GR_JMAX / r
            b0, b1 = _GR_TABLE3[d]
            inv = _basic_sum(_GR_JMAX, _GR_JMAX, mp, mp, 1, d) / (
                _GR_JMAX * (b0 + b1 * math.log(m)) ** 2
            )
        return 1.0 / inv
    # case 4: unmodified variances, alpha = 2 (white angle noise): exact covariance sum
    K = math.ceil(r)
    c0 = math.comb(2 * d, d) ** 2
    if K <= d:
        acc = 1.0 + 2.0 * sum((1.0 - k / r) * math.comb(2 * d, d - k) ** 2 / c0 for k in range(1, K))
        inv = acc / M
    else:
        a0 = math.comb(4 * d, 2 * d) / c0
        a1 = d / 2.0
        inv = (a0 - a1 / r) / M
    return 1.0 / inv


# ---------------------------------------------------------------------------------------------
# NIST SP1065 tables
# ---------------------------------------------------------------------------------------------


def edf_simple(n_phase: int, m: int, alpha: int) -> float:
    """Simple EDF approximations of NIST SP1065 Table 5 (Stein 1985) for the Allan variance.

    With N angle points and averaging factor m:
    α=2: (N+1)(N−2m)/(2(N−m)); α=1: exp(√(ln((N−1)/2m)·ln((2m+1)(N−1)/4)));
    α=0: [3(N−1)/(2m) − 2(N−2)/N]·4m²/(4m²+5); α=−1: 2(N−2)/(2.3N−4.9) for m = 1,
    5N²/(4m(N+3m)) for m ≥ 2; α=−2: (N−2)/(m(N−3)²)·[(N−1)² − 3m(N−1) + 4m²].
    Any other α: N − 1 (uncorrelated terms). The fallback of gyrotest when no better EDF applies.
    """
    N = float(n_phase)
    m = float(m)
    alpha = int(alpha)
    if alpha == 2:
        return (N + 1) * (N - 2 * m) / (2 * (N - m))
    if alpha == 1:
        return math.exp(math.sqrt(math.log((N - 1) / (2 * m)) * math.log((2 * m + 1) * (N - 1) / 4)))
    if alpha == 0:
        return (3 * (N - 1) / (2 * m) - 2 * (N - 2) / N) * (4 * m * m) / (4 * m * m + 5)
    if alpha == -1:
        if m == 1:
            return 2 * (N - 2) / (2.3 * N - 4.9)
        return 5 * N * N / (4 * m * (N + 3 * m))
    if alpha == -2:
        return (N - 2) / (m * (N - 3) ** 2) * ((N - 1) ** 2 - 3 * m * (N - 1) + 4 * m * m)
    return N - 1


def edf_totdev(n_phase: int, m: int, alpha: int) -> float:
    """TOTDEV EDF, NIST SP1065 Table 7: edf = b·(N/m) − c with (b, c) = (1.50, 0) for α=0,
    (1.17, 0.22) for α=−1, (0.93, 0.36) for α=−2; N = number of angle points.

    The table has no entry for white or flicker angle noise (α = 2, 1); for those gyrotest
    falls back to :func:`edf_simple` (as does AllanTools) — see ``edf_for``.
    """
    alpha = int(alpha)
    if alpha in _SP1065_TABLE7:
        b, c = _SP1065_TABLE7[alpha]
        return b * (float(n_phase) / float(m)) - c
    return edf_simple(n_phase, m, alpha)


def edf_mtotdev(n_phase: int, m: int, alpha: int) -> float:
    """MTOTDEV EDF, NIST SP1065 Table 8: edf = b·(N/m) − c with (b, c) = (1.90, 2.1) α=2,
    (1.20, 1.40) α=1, (1.10, 1.2) α=0, (0.85, 0.50) α=−1, (0.75, 0.31) α=−2."""
    alpha = int(alpha)
    if alpha not in _SP1065_TABLE8:
        raise AnalysisError(f"no SP1065 Table 8 MTOTDEV EDF for alpha = {alpha} (table covers -2 … 2)")
    b, c = _SP1065_TABLE8[alpha]
    return b * (float(n_phase) / float(m)) - c


def chi2_interval(
    sigma: np.ndarray | float, edf: np.ndarray | float, confidence: float = DEFAULT_CONFIDENCE
) -> tuple[np.ndarray, np.ndarray]:
    """χ² confidence interval of a deviation (NIST SP1065 eq. 45).

    σ_lo = σ·√(edf/χ²(1 − p, edf)), σ_hi = σ·√(edf/χ²(p, edf)), p = (1 − confidence)/2, with
    χ²(q, ν) the q-quantile of the χ² distribution. Same unit as σ. NaN edf gives NaN bounds.
    """
    if not 0.0 < confidence < 1.0:
        raise InputError(f"confidence must be between 0 and 1, got {confidence!r}")
    sigma = np.asarray(sigma, dtype=float)
    edf = np.asarray(edf, dtype=float)
    p = 0.5 * (1.0 - confidence)
    with np.errstate(invalid="ignore", divide="ignore"):
        # χ² quantiles: chdtri(ν, y) is the x with P(χ²_ν > x) = y (= stats.chi2.ppf(1 − y, ν))
        chi_lo = special.chdtri(edf, 1.0 - p)
        chi_hi = special.chdtri(edf, p)
        lo = sigma * np.sqrt(edf / chi_hi)
        hi = sigma * np.sqrt(edf / chi_lo)
    return lo, hi


#: (Greenhall d, overlapping, modified) for the finite-difference deviations.
_GREENHALL_KIND: dict[str, tuple[int, bool, bool]] = {
    "adev": (2, False, False),
    "oadev": (2, True, False),
    "mdev": (2, True, True),
    "tdev": (2, True, True),
    "hdev": (3, False, False),
    "ohdev": (3, True, False),
    "akdev": (2, True, False),
    "hkdev": (3, True, False),
}


def edf_for(kind: str, alpha: int, m: int, n_phase: int) -> tuple[float, str]:
    """EDF of deviation ``kind`` at averaging factor m for noise α; returns (edf, method label).

    * adev, oadev, mdev, tdev, hdev, ohdev: :func:`edf_greenhall` (d = 2 or 3).
    * akdev, hkdev (Allan–/Hadamard–Krobka): the OADEV/OHDEV Greenhall EDF minus one degree
      of freedom for the subtracted mean difference (an approximation; floor 1).
    * totdev: SP1065 Table 7 for α ∈ {0, −1, −2}; mtotdev: SP1065 Table 8.
    * Fallback (α outside a method's range, or no estimator term for Greenhall): SP1065
      Table 5 simple EDF (:func:`edf_simple`).
    """
    if kind in _GREENHALL_KIND:
        d, ov, mod = _GREENHALL_KIND[kind]
        try:
            e = edf_greenhall(alpha, d, m, n_phase, overlapping=ov, modified=mod)
        except AnalysisError:
            return edf_simple(n_phase, m, alpha), CI_SIMPLE
        if kind in ("akdev", "hkdev"):
            e = max(e - 1.0, 1.0)
        return e, CI_GREENHALL
    if kind == "totdev":
        if int(alpha) in _SP1065_TABLE7:
            return edf_totdev(n_phase, m, alpha), CI_TOTDEV
        return edf_simple(n_phase, m, alpha), CI_SIMPLE
    if kind == "mtotdev":
        if int(alpha) in _SP1065_TABLE8:
            return edf_mtotdev(n_phase, m, alpha), CI_MTOTDEV
        return edf_simple(n_phase, m, alpha), CI_SIMPLE
    raise InputError(f"no EDF rule for deviation kind {kind!r}")


# ---------------------------------------------------------------------------------------------
# Noise identification
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class NoiseId:
    """Result of a noise identification at one averaging factor.

    ``alpha`` integer α, ``alpha_float`` the continuous estimate (NaN for B1/reused), ``d`` the
    number of differences taken by the lag-1 method, ``rho`` the lag-1 statistic r1/(1+r1),
    ``method`` one of "acf", "b1", "b1+rn", "reused", "assumed", "forced", ``n_points`` the
    number of averaged points it was based on.
    """

    alpha: int
    alpha_float: float
    d: int
    rho: float
    method: str
    n_points: int


def lag1_acf(x: np.ndarray) -> float:
    """Lag-1 autocorrelation r1 = Σ(x_i − x̄)(x_{i+1} − x̄) / Σ(x_i − x̄)² (Riley & Greenhall 2004
    eq. 2), vectorised."""
    x = np.asarray(x, dtype=float)
    xc = x - x.mean()
    den = blocked_dot(xc, xc)
    if den == 0.0:
        return 0.0
    return blocked_dot(xc[:-1], xc[1:]) / den


def _detrend(x: np.ndarray, deg: int) -> np.ndarray:
    """Least-squares removal of a polynomial of degree ``deg`` (≤ 2) on a uniform grid.

    Uses the orthogonal basis 1, t, t² − mean(t²) on the symmetric grid t ∈ [−1, 1]
    (Gram–Schmidt in closed form), so it costs a few O(n) passes and no Vandermonde matrix.
    """
    n = x.size
    r = x - x.mean()
    if n <= deg + 1 or deg < 1:
        return r
    t = np.linspace(-1.0, 1.0, n)
    r -= t * (blocked_dot(t, r) / blocked_dot(t, t))
    if deg >= 2:
        t *= t
        t -= t.mean()
        r -= t * (blocked_dot(t, r) / blocked_dot(t, t))
    return r


def _acf_from_parts(parts: Sequence[np.ndarray], data_type: str, dmin: int, dmax: int) -> NoiseId:
    """Lag-1 ACF noise ID pooled over contiguous parts (sums of lag products and squares)."""
    deg = 2 if data_type == "phase" else 1
    xs = [_detrend(np.asarray(p, dtype=float), deg) for p in parts]
    n_pts = int(sum(p.size for p in parts))
    d = 0
    while True:
        num = 0.0
        den = 0.0
        for x in xs:
            if x.size < 2:
                continue
            xc = x - x.mean()
            num += blocked_dot(xc[:-1], xc[1:])
            den += blocked_dot(xc, xc)
        r1 = num / den if den > 0 else 0.0
        rho = r1 / (1.0 + r1) if r1 > -1.0 else -math.inf
        if d >= dmin and (rho < 0.25 or d >= dmax):
            add = 2 if data_type == "phase" else 0
            a_float = -2.0 * (rho + d) + add
            a_int = int(-np.round(2.0 * rho) - 2 * d) + add if math.isfinite(rho) else 2
            return NoiseId(a_int, float(a_float), d, float(rho), "acf", n_pts)
        xs = [np.diff(x) for x in xs]
        d += 1


def acf_noise_id(x: np.ndarray, *, data_type: str, dmin: int = 0, dmax: int = 2) -> NoiseId:
    """Lag-1 autocorrelation noise identification (Riley & Greenhall 2004).

    ``x`` is the already decimated angle (``data_type="phase"``) or averaged rate
    (``"frequency"``) series at the averaging factor of interest. It is detrended (quadratic
    for phase, linear for frequency), then differenced d = dmin, dmin+1, … times until
    ρ = r1/(1 + r1) < 0.25 or d = dmax; α = −2(ρ + d) (+2 for phase data), rounded to the
    integer −round(2ρ) − 2d (+2). Needs ≥ 30 points for a reliable answer.
    """
    return _acf_from_parts([np.asarray(x, dtype=float)], data_type, dmin, dmax)


def b1_theory(n: int, mu: int) -> float:
    """Barnes' B1 bias function for n averages and Allan-variance τ exponent μ:
    B1 = n(1 − n^μ) / (2(n − 1)(1 − 2^μ)), and n·ln n/(2(n − 1)·ln 2) for μ = 0."""
    n = float(n)
    if mu == 0:
        return n * math.log(n) / (2.0 * (n - 1.0) * math.log(2.0))
    return n * (1.0 - n**mu) / (2.0 * (n - 1.0) * (1.0 - 2.0**mu))


def _rn_theory_fpm(m: int) -> float:
    """R(n) = MVAR/AVAR for flicker angle noise with bandwidth f_h = 1/(2τ0) (IEEE 1139)."""
    avar = (1.038 + 3.0 * math.log(2.0 * math.pi * 0.5 * m)) / (4.0 * math.pi**2)
    mvar = 3.0 * math.log(256.0 / 27.0) / (8.0 * math.pi**2)
    return mvar / avar


def b1_noise_id(
    y_avg: np.ndarray,
    m: int,
    *,
    mu_max: int = 1,
    rn_ratio: float | Callable[[], float] | None = None,
    n_theory: int | None = None,
) -> NoiseId:
    """B1-ratio noise identification for short series (Barnes 1969; Howe, Beard, Greenhall &
    Riley 2000), with the R(n) ratio to split white from flicker angle noise.

    ``y_avg`` are the non-overlapping m-sample rate averages. B1 = (sample variance of y_avg) /
    (Allan variance of y_avg) is compared with :func:`b1_theory` for μ = −2 … ``mu_max``; the
    boundaries are geometric means of neighbouring theoretical values. μ maps to α = −μ − 1
    (μ = −2 means α = 2 or 1, decided by R(n) = MVAR/AVAR against 1/m (white) and the flicker
    value, boundary their geometric mean; without ``rn_ratio`` α = 1 is returned).
    ``rn_ratio`` may be a zero-argument callable: it is then evaluated only when needed.
    ``n_theory`` is the N at which :func:`b1_theory` is evaluated (default: the number of
    averages). Stable32's tables are reproduced with N = the statistic's number of terms (its
    ``#`` column, large for the overlapping kinds): on the Cs 5071A, GPS and TIC records every
    α of the OADEV/MDEV/TDEV/OHDEV tables then agrees (inferred from Stable32's tables, not from
    its documentation).
    """
    y = np.asarray(y_avg, dtype=float)
    n = y.size
    if n < 3:
        raise AnalysisError("B1 noise identification needs at least 3 averages")
    var = float(np.var(y, ddof=1))
    avar = 0.5 * float(np.mean(np.diff(y) ** 2))
    if avar <= 0:
        return NoiseId(0, math.nan, 0, math.nan, "b1", n)
    b1 = var / avar
    mus = list(range(-2, mu_max + 1))
    nt = n if n_theory is None else max(int(n_theory), 2)
    theo = [b1_theory(nt, mu) for mu in mus]
    mu_sel = mus[-1]
    for i in range(len(mus) - 1):
        if b1 < math.sqrt(theo[i] * theo[i + 1]):
            mu_sel = mus[i]
            break
    if mu_sel == -2:
        if rn_ratio is None or m <= 1:
            return NoiseId(1, math.nan, 0, math.nan, "b1", n)
        rn = rn_ratio() if callable(rn_ratio) else float(rn_ratio)
        bound = math.sqrt((1.0 / m) * _rn_theory_fpm(m))
        return NoiseId(2 if rn < bound else 1, math.nan, 0, math.nan, "b1+rn", n)
    return NoiseId(-mu_sel - 1, math.nan, 0, math.nan, "b1", n)


#: Points needed after averaging for the lag-1 method (Riley & Greenhall) and for B1.
ACF_MIN_POINTS = 30
#: Points from which a lag-1 identification of angle noise (α > 0) is decisive. Under white
#: rate noise the lag-1 estimate ρ̂ of n averages has a standard error ≈ 1/√n, and the method
#: reads α ≥ 1 when ρ̂ ≤ −0.25 (Riley & Greenhall 2004): that happens with probability
#: Φ(−0.25·√n), ≤ 1 % from n = (z₀.₉₉/0.25)² = 87 points on; with 30 points it is 9 %, and the
#: Greenhall EDF of a wrongly read α = +2 is the number of samples (thousands of times the
#: white-rate EDF at long τ). Below this count an α > 0 is not trusted for the fit's EDF
#: (:func:`gyrotest.noise.noisefit.robust_edf_rules`); Stable32's rule (30 points) is kept for the
#: printed α.
ACF_DECISIVE_POINTS = math.ceil((NormalDist().inv_cdf(0.99) / 0.25) ** 2)
B1_MIN_POINTS = 8
#: At most this many averaged points per segment enter the identification (the first ones);
#: the lag-1 estimate then has a standard error of about 4e-3, far below the ±0.25 decision
#: margin, and the extra memory stays below 1 MB even for 10^8-sample records.
NOISE_ID_MAX_POINTS = 1 << 16


def identify_noise(
    segments: Sequence[np.ndarray],
    m_values: Sequence[int],
    *,
    data_type: str,
    dmax: int = 2,
    alpha_min: int = -2,
    rn_ratio: Callable[[int], float] | None = None,
    b1_n_theory: Sequence[int] | None = None,
    b1_min_points: int | None = None,
) -> list[NoiseId]:
    """Identify the power-law noise α at each averaging factor (vectorised; gap-aware).

    ``segments`` are the contiguous angle series θ (one per gap-free segment). At each m:

    * ``data_type="frequency"`` (rate or increment input): the non-overlapping m-sample rate
      averages, diff(θ[::m]); ``"phase"`` (angle input): the decimated angles θ[::m].
    * ≥ 30 points in total: lag-1 autocorrelation method (:func:`acf_noise_id`), with the lag
      products and squares pooled over segments (each detrended on its own).
    * ``b1_min_points`` (default 8) … 29 points: B1 ratio on the longest segment
      (:func:`b1_noise_id`), R(n) from ``rn_ratio(m)`` to split α = 2/1; the theoretical B1
      is evaluated at ``b1_n_theory[i]`` when given (Stable32: the statistic's number of
      terms, see :func:`identify_noise_stable32`), else at the number of averages.
    * fewer: the α identified at the previous (shorter) τ is reused — Stable32's rule for the
      longest τ; with no previous α, α = 0 (white rate noise) is assumed.

    α is clipped to [``alpha_min``, 2] (−2 for the Allan family, −4 for Hadamard).
    """
    return _identify_rules(segments, m_values, data_type=data_type, dmax=dmax,
                           alpha_min=alpha_min, rn_ratio=rn_ratio,
                           rules=[(b1_n_theory, b1_min_points or B1_MIN_POINTS)])[0]


#: Stable32's minimum number of averages for the B1 ratio on a total deviation (TOTDEV):
#: the two Stable32 TOTDEV tables on real records (GPS, Keysight TIC) identify the noise
#: type by B1 at 6 and 7 averages, where their OADEV tables reuse the previous α; at 3
#: averages TOTDEV reuses it too (inferred from the tables, not from Stable32's documentation).
B1_MIN_POINTS_TOTDEV = 6


def identify_noise_pair(
    segments: Sequence[np.ndarray],
    m_values: Sequence[int],
    n_terms: Sequence[int],
    *,
    kind: str,
    data_type: str,
    dmax: int = 2,
    alpha_min: int = -2,
    rn_ratio: Callable[[int], float] | None = None,
) -> tuple[list[NoiseId], list[NoiseId]]:
    """Two identifications in one pass (the lag-1 ACF part is shared): (Stable32's, the
    statistical one).

    * Stable32's rule, for the printed α and its confidence interval: with 8 … 29 averages
      (6 … 29 for TOTDEV, :data:`B1_MIN_POINTS_TOTDEV`) B1 is compared with Barnes' theory
      evaluated at N = ``n_terms[i]``, the statistic's number of terms (Stable32's ``#``
      column) — for the overlapping kinds a large N, so effectively the asymptotic B1. This
      reproduces every α of Stable32's tables on the shared real records (Cs 5071A, GPS,
      Keysight TIC) but almost never calls random-walk rate noise at 8 … 29 averages (B1
      diverges with N for μ = 1).
    * The statistical rule (Barnes 1969; Howe, Beard, Greenhall & Riley 2000): B1 theory at
      N = the number of averages, 8 … 29 averages. Used for the noise-model fit's weights.
    """
    mins = B1_MIN_POINTS_TOTDEV if kind == "totdev" else B1_MIN_POINTS
    s32, stat = _identify_rules(segments, m_values, data_type=data_type, dmax=dmax,
                                alpha_min=alpha_min, rn_ratio=rn_ratio,
                                rules=[(list(n_terms), mins), (None, B1_MIN_POINTS)])
    return s32, stat


def _identify_rules(segments, m_values, *, data_type, dmax, alpha_min, rn_ratio, rules):
    """The identification loop of :func:`identify_noise` for several B1 rules at once:
    ``rules`` = [(b1_n_theory or None, b1_min_points), ...]; one list of NoiseId per rule."""
    if data_type not in ("phase", "frequency"):
        raise InputError(f"data_type must be 'phase' or 'frequency', got {data_type!r}")
    outs: list[list[NoiseId]] = [[] for _ in rules]
    prevs: list[int | None] = [None] * len(rules)
    for i_m, m in enumerate(m_values):
        m = int(m)
        parts = []
        for th in segments:
            dec = th[::m]
            if data_type == "frequency":
                part = np.diff(dec[: NOISE_ID_MAX_POINTS + 1])
            else:
                part = np.array(dec[:NOISE_ID_MAX_POINTS], dtype=float)
            if part.size >= 3:
                parts.append(part)
        n_pts = int(sum(p.size for p in parts))
        acf = _acf_from_parts(parts, data_type, 0, dmax) if n_pts >= ACF_MIN_POINTS else None
        rn = None
        if rn_ratio is not None and m > 1:
            cache: dict[int, float] = {}

            def rn(f=rn_ratio, mm=m, c=cache):  # evaluated only if B1 says white/flicker angle
                if mm not in c:
                    c[mm] = f(mm)
                return c[mm]
        for k, (n_theory, min_pts) in enumerate(rules):
            if acf is not None:
                nid = acf
            elif parts and max(p.size for p in parts) >= min_pts:
                longest = max(parts, key=lambda p: p.size)
                y = longest if data_type == "frequency" else np.diff(longest)
                nid = b1_noise_id(y, m, mu_max=min(-alpha_min - 1, 3), rn_ratio=rn,
                                  n_theory=None if n_theory is None else n_theory[i_m])
            elif prevs[k] is not None:
                nid = NoiseId(prevs[k], math.nan, 0, math.nan, "reused", n_pts)
            else:
                nid = NoiseId(0, math.nan, 0, math.nan, "assumed", n_pts)
            a = int(min(max(nid.alpha, alpha_min), 2))
            if a != nid.alpha:
                nid = NoiseId(a, nid.alpha_float, nid.d, nid.rho, nid.method, nid.n_points)
            outs[k].append(nid)
            prevs[k] = nid.alpha
    return outs
