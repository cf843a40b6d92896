"""What every Allan-family estimator shares (:mod:`.deviations`, :mod:`.theo`, :mod:`.gapdev`).

* :class:`DeviationResult`, the result of every deviation;
* the streaming kernels: each returns a sum of squares (and a term count) for one contiguous θ
  (:class:`~gyrotest.core.angle.AngleSeries`), processed in chunks of
  :data:`~gyrotest.core.angle.CHUNK`;
* the raw variances pooled over gap-free segments, their term counts, the bias factors of the
  total deviations and the pooled EDF;
* :func:`assign_alpha`: the noise type (α) of each τ that sets its EDF.

The estimators and their formulas are documented in :mod:`.deviations`."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..core.angle import CHUNK
from ..core.errors import InputError
from . import edf as _edf
from . import mtot as _mtot


def _json_float(v: float) -> float | None:
    v = float(v)
    return v if math.isfinite(v) else None


@dataclass
class DeviationResult:
    """A deviation table (one row per τ), Stable32-like.

    Fields: ``kind`` (e.g. "oadev"), ``input_kind``, ``tau0`` (s), ``m`` (averaging factors),
    ``tau`` (s), ``n`` (number of terms of the estimator, Stable32's "#"), ``alpha`` (noise
    exponent used for the EDF: −2 … 2, down to −4 for the Hadamard family), ``alpha_method``
    (per τ: "acf", "b1", "b1+rn", "reused", "assumed", "forced"), ``edf``, ``sigma``,
    ``sigma_lo``/``sigma_hi`` (χ² interval at ``confidence``), ``ci_method``, ``unit`` (of
    sigma), ``notes`` (gap pooling, τ dropped or moved, assumptions). ``alpha`` and the
    interval follow Stable32's noise identification; ``alpha_fit``/``edf_fit`` hold the
    statistical identification used for the noise-model fit's weights (see
    :func:`gyrotest.noise.edf.identify_noise_pair`).
    """

    kind: str
    input_kind: str
    tau0: float
    m: np.ndarray
    tau: np.ndarray
    n: np.ndarray
    alpha: np.ndarray
    edf: np.ndarray
    sigma: np.ndarray
    sigma_lo: np.ndarray
    sigma_hi: np.ndarray
    confidence: float
    ci_method: str
    unit: str
    notes: list[str] = field(default_factory=list)
    alpha_method: list[str] = field(default_factory=list)
    n_samples: int = 0
    segments: list[tuple[int, int]] = field(default_factory=list)
    #: the statistical identification (B1 theory at the number of averages) and its EDF, kept
    #: for the noise-model fit's weights where it differs from the printed (Stable32) α; None
    #: when α was forced/assumed or the kind has one identification only
    alpha_fit: np.ndarray | None = None
    alpha_fit_method: list[str] | None = None
    edf_fit: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.m)

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dict: lists of Python floats/ints, None instead of NaN."""
        return {
            "kind": self.kind,
            "name": _LONG_NAMES.get(self.kind, self.kind),
            "input_kind": self.input_kind,
            "tau0_s": float(self.tau0),
            "unit": self.unit,
            "confidence": float(self.confidence),
            "ci_method": self.ci_method,
            "n_samples": int(self.n_samples),
            "segments": [[int(a), int(b)] for a, b in self.segments],
            "m": [int(v) for v in self.m],
            "tau_s": [float(v) for v in self.tau],
            "n": [int(v) for v in self.n],
            "alpha": [int(v) for v in self.alpha],
            "alpha_method": list(self.alpha_method),
            "edf": [_json_float(v) for v in self.edf],
            "sigma": [_json_float(v) for v in self.sigma],
            "sigma_lo": [_json_float(v) for v in self.sigma_lo],
            "sigma_hi": [_json_float(v) for v in self.sigma_hi],
            **({} if self.alpha_fit is None else {
                "alpha_fit": [int(v) for v in self.alpha_fit],
                "alpha_fit_method": list(self.alpha_fit_method or []),
                "edf_fit": [_json_float(v) for v in self.edf_fit]}),
            "notes": list(self.notes),
        }

    def to_frame(self):
        """pandas DataFrame with Stable32's column order: tau, m, n, alpha, edf, sigma_lo,
        sigma, sigma_hi."""
        import pandas as pd

        return pd.DataFrame(
            {
                "tau": np.asarray(self.tau, dtype=float),
                "m": np.asarray(self.m, dtype=np.int64),
                "n": np.asarray(self.n, dtype=np.int64),
                "alpha": np.asarray(self.alpha, dtype=np.int64),
                "edf": np.asarray(self.edf, dtype=float),
                "sigma_lo": np.asarray(self.sigma_lo, dtype=float),
                "sigma": np.asarray(self.sigma, dtype=float),
                "sigma_hi": np.asarray(self.sigma_hi, dtype=float),
            }
        )


def _sumsq(b: np.ndarray) -> float:
    """Σ b² of a chunk buffer via single-threaded BLAS blocks (see ``edf.DOT_BLOCK``)."""
    return _edf.blocked_dot(b, b)


def _d2_sumsq(v: np.ndarray, lag: int, center: float = 0.0) -> tuple[float, int]:
    """Σ_k (v_{k+2lag} − 2v_{k+lag} + v_k − center)² over k = 0 … len(v)−2lag−1, chunked.

    For lag ≤ chunk: one pass a_k = v_{k+lag} − v_k over chunk+lag points into a preallocated
    buffer, then d_k = a_{k+lag} − a_k inside the (cache-resident) buffer — two passes instead
    of three, bit-identical results. Longer lags: three ``np.subtract/add(..., out=)`` passes.
    The sum of squares is a BLAS dot in single-threaded blocks. No temporaries beyond the two
    chunk buffers."""
    n = v.size - 2 * lag
    if n <= 0:
        return 0.0, 0
    size = min(CHUNK, n)
    buf = np.empty(size)
    ss = 0.0
    if lag <= CHUNK:
        abuf = np.empty(size + lag)
        for s in range(0, n, CHUNK):
            c = min(CHUNK, n - s)
            a = abuf[: c + lag]
            np.subtract(v[s + lag : s + 2 * lag + c], v[s : s + lag + c], out=a)
            b = buf[:c]
            np.subtract(a[lag:], a[:c], out=b)
            if center:
                b -= center
            ss += _sumsq(b)
        return ss, n
    for s in range(0, n, CHUNK):
        c = min(CHUNK, n - s)
        b = buf[:c]
        mid = v[s + lag : s + lag + c]
        np.subtract(v[s + 2 * lag : s + 2 * lag + c], mid, out=b)
        np.subtract(b, mid, out=b)
        np.add(b, v[s : s + c], out=b)
        if center:
            b -= center
        ss += _sumsq(b)
    return ss, n


def _d3_sumsq(v: np.ndarray, lag: int, center: float = 0.0) -> tuple[float, int]:
    """Σ_k (v_{k+3lag} − 3v_{k+2lag} + 3v_{k+lag} − v_k − center)², chunked (two buffers)."""
    n = v.size - 3 * lag
    if n <= 0:
        return 0.0, 0
    size = min(CHUNK, n)
    buf = np.empty(size)
    tmp = np.empty(size)
    ss = 0.0
    for s in range(0, n, CHUNK):
        c = min(CHUNK, n - s)
        b = buf[:c]
        t = tmp[:c]
        np.subtract(v[s + 3 * lag : s + 3 * lag + c], v[s : s + c], out=b)
        np.subtract(v[s + 2 * lag : s + 2 * lag + c], v[s + lag : s + lag + c], out=t)
        t *= 3.0
        b -= t
        if center:
            b -= center
        ss += _sumsq(b)
    return ss, n


def _window_diff_total(v: np.ndarray, a: int, b: int, count: int) -> float:
    """Σ_{k<count} (v_{k+a} − v_{k+b}), a > b, by telescoping: Σv[b+count : a+count] − Σv[b:a]."""
    if count <= 0:
        return 0.0
    w = a - b
    if w >= count:
        return float(np.sum(v[a : a + count]) - np.sum(v[b : b + count]))
    return float(np.sum(v[b + count : a + count]) - np.sum(v[b:a]))


def _d2_total(v: np.ndarray, lag: int) -> tuple[float, int]:
    """Σ_k (v_{k+2lag} − 2v_{k+lag} + v_k) in O(lag) by telescoping, and the term count."""
    n = v.size - 2 * lag
    if n <= 0:
        return 0.0, 0
    return _window_diff_total(v, 2 * lag, lag, n) - _window_diff_total(v, lag, 0, n), n


def _d3_total(v: np.ndarray, lag: int) -> tuple[float, int]:
    """Σ_k (v_{k+3lag} − 3v_{k+2lag} + 3v_{k+lag} − v_k) in O(lag) by telescoping."""
    n = v.size - 3 * lag
    if n <= 0:
        return 0.0, 0
    t = (
        _window_diff_total(v, 3 * lag, 2 * lag, n)
        - 2.0 * _window_diff_total(v, 2 * lag, lag, n)
        + _window_diff_total(v, lag, 0, n)
    )
    return t, n


def _mod_sumsq(v: np.ndarray, m: int) -> tuple[float, int]:
    """Σ_j s_j² with s_j = Σ_{i=j}^{j+m−1} (v_{i+2m} − 2v_{i+m} + v_i), j = 0 … N−3m (MDEV).

    s_{j+1} = s_j + e_j with the third difference e_j = v_{j+3m} − 3v_{j+2m} + 3v_{j+m} − v_j,
    so s is a running sum of third differences: O(N) per τ, chunked. When 3m fits in a chunk,
    s is re-anchored at every chunk start by a direct sum of m second differences, bounding
    the accumulated rounding error; otherwise the carry runs through (error ~ √N·ε).
    """
    N = v.size
    n = N - 3 * m + 1
    if n <= 0:
        return 0.0, 0
    size = min(CHUNK, n)
    buf = np.empty(size)
    tmp = np.empty(size)
    anchor = np.empty(m) if 3 * m <= CHUNK else None

    def direct(j: int) -> float:
        if anchor is not None:
            a = anchor
            np.subtract(v[j + 2 * m : j + 3 * m], v[j + m : j + 2 * m], out=a)
            np.subtract(a, v[j + m : j + 2 * m], out=a)
            np.add(a, v[j : j + m], out=a)
            return float(np.sum(a))
        return float(
            np.sum(v[j + 2 * m : j + 3 * m]) - 2.0 * np.sum(v[j + m : j + 2 * m])
            + np.sum(v[j : j + m])
        )

    ss = 0.0
    carry = 0.0
    for s in range(0, n, CHUNK):
        c = min(CHUNK, n - s)
        b = buf[:c]
        b[0] = direct(s) if (s == 0 or anchor is not None) else carry
        if c > 1:  # e_s … e_{s+c-2} feed s_{s+1} … s_{s+c-1}
            k = c - 1
            t = tmp[:k]
            np.subtract(v[s + 3 * m : s + 3 * m + k], v[s : s + k], out=b[1:c])
            np.subtract(v[s + 2 * m : s + 2 * m + k], v[s + m : s + m + k], out=t)
            t *= 3.0
            b[1:c] -= t
        np.cumsum(b, out=b)
        ss += _sumsq(b)
        j = s + c - 1  # e_j carries into the next chunk, if there is one
        if anchor is None and j <= n - 2:
            carry = float(b[c - 1]) + float(
                v[j + 3 * m] - 3.0 * v[j + 2 * m] + 3.0 * v[j + m] - v[j]
            )
    return ss, n


def _ext(theta: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """TOTDEV's doubly reflected series (SP1065 eq. 25) at integer indices −(N−2) … 2N−3."""
    N = theta.size
    out = np.empty(idx.shape)
    lo = idx < 0
    hi = idx > N - 1
    mid = ~(lo | hi)
    out[mid] = theta[idx[mid]]
    out[lo] = 2.0 * theta[0] - theta[-idx[lo]]
    out[hi] = 2.0 * theta[N - 1] - theta[2 * (N - 1) - idx[hi]]
    return out


def _tot_sumsq(v: np.ndarray, m: int) -> tuple[float, int]:
    """Σ_{i=1}^{N−2} (θ*_{i−m} − 2θ_i + θ*_{i+m})² for TOTDEV: the overlapping-Allan sum over
    the interior i ∈ [m, N−1−m] (no reflection needed) plus the 2(m−1) edge terms that use the
    reflected points. Term count N − 2 (Stable32's "#")."""
    N = v.size
    if N < 3 or m > N - 2:
        return 0.0, 0
    ss, _ = _d2_sumsq(v, m)
    # edge terms i ∈ [1, m) and [max(N−m, m), N−1), or every i ∈ [1, N−2] when there is no
    # interior; index chunks made on the fly (no m-long index array)
    hi_start = max(N - m, m) if N - 1 - m >= m else None
    if hi_start is None:
        edges = [(1, N - 1)]
    else:
        edges = [(1, min(m, N - 1)), (hi_start, N - 1)]
    for e0, e1 in edges:
        for s in range(e0, e1, CHUNK):
            i = np.arange(s, min(e1, s + CHUNK), dtype=np.int64)
            t = _ext(v, i - m) - 2.0 * v[i] + _ext(v, i + m)
            ss += _sumsq(t)
    return ss, N - 2


_mtot_sum = _mtot.mtot_sum


def _n_terms(kind: str, L: int, m: int) -> int:
    """Number of estimator terms of ``kind`` on a segment of L angle points."""
    if kind in ("oadev", "akdev"):
        return max(L - 2 * m, 0)
    if kind == "adev":
        return max((L - 1) // m - 1, 0)
    if kind in ("mdev", "tdev", "mtotdev"):
        return max(L - 3 * m + 1, 0)
    if kind in ("ohdev", "hkdev"):
        return max(L - 3 * m, 0)
    if kind == "hdev":
        return max((L - 1) // m - 2, 0)
    if kind == "totdev":
        return L - 2 if (L >= 3 and 2 * m <= L) else 0
    raise InputError(f"unknown deviation kind {kind!r}")


def _raw_variance(kind: str, parts: Sequence[np.ndarray], m: int) -> tuple[float, int, list[int]]:
    """Pooled raw variance of θ (in θ units², before the 1/τ² scaling) and term counts.

    Returns (var_raw, n_total, n_per_segment) with var_raw·scale²/τ² = σ².
    """
    ns = [_n_terms(kind, p.size, m) for p in parts]
    n_tot = int(sum(ns))
    if n_tot == 0:
        return math.nan, 0, ns
    ss = 0.0
    if kind in ("oadev", "adev", "totdev"):
        for p, nk in zip(parts, ns):
            if nk <= 0:
                continue
            if kind == "oadev":
                ss += _d2_sumsq(p, m)[0]
            elif kind == "adev":
                ss += _d2_sumsq(p[::m], 1)[0]
            else:
                ss += _tot_sumsq(p, m)[0]
        return ss / (2.0 * n_tot), n_tot, ns
    if kind in ("hdev", "ohdev"):
        for p, nk in zip(parts, ns):
            if nk > 0:
                ss += (_d3_sumsq(p, m) if kind == "ohdev" else _d3_sumsq(p[::m], 1))[0]
        return ss / (6.0 * n_tot), n_tot, ns
    if kind in ("mdev", "tdev"):
        for p, nk in zip(parts, ns):
            if nk > 0:
                ss += _mod_sumsq(p, m)[0]
        return ss / (2.0 * m * m * n_tot), n_tot, ns
    if kind == "mtotdev":
        for p, nk in zip(parts, ns):
            if nk > 0:
                ss += _mtot_sum(p, m)[0]
        return ss / (12.0 * m**3 * n_tot), n_tot, ns
    if kind in ("akdev", "hkdev"):
        tot_fn, sq_fn, norm = (
            (_d2_total, _d2_sumsq, 2.0) if kind == "akdev" else (_d3_total, _d3_sumsq, 6.0)
        )
        s1 = sum(tot_fn(p, m)[0] for p, nk in zip(parts, ns) if nk > 0)
        mean = s1 / n_tot
        for p, nk in zip(parts, ns):
            if nk > 0:
                ss += sq_fn(p, m, center=mean)[0]
        return ss / (norm * n_tot), n_tot, ns
    raise InputError(f"unknown deviation kind {kind!r}")


#: MTOTDEV bias B(α) = E[Mod Tot var]/Mod var (Howe & Vernotte 1999; SP1065 §5.2.12).
_MTOT_BIAS = {2: 0.94, 1: 0.83, 0: 0.73, -1: 0.70, -2: 0.69}


#: TOTDEV bias 1 − a·τ/T (SP1065 §5.2.11): a = 1/(3 ln 2) for flicker rate, 3/4 for random-walk rate.
_TOT_BIAS_A = {-1: 0.481, -2: 0.750}


def _bias_factor(kind: str, alpha: np.ndarray, tau: np.ndarray, T: float) -> np.ndarray:
    """Variance bias factor of TOTDEV (1 − a·τ/T) or MTOTDEV (B(α)) per τ."""
    if kind == "mtotdev":
        return np.array([_MTOT_BIAS[int(a)] for a in alpha])
    a = np.array([_TOT_BIAS_A.get(int(v), 0.0) for v in alpha])
    return 1.0 - a * tau / T


def _pooled_edf(kind: str, alpha: int, m: int, parts: Sequence[np.ndarray], ns: list[int]) -> tuple[float, str]:
    """EDF of the pooled estimate: 1/Σ_s (w_s²/edf_s), w_s = n_s/Σn (one segment: its EDF)."""
    used = [(p.size, nk) for p, nk in zip(parts, ns) if nk > 0]
    if len(used) == 1:
        return _edf.edf_for(kind, alpha, m, used[0][0])
    n_tot = float(sum(nk for _, nk in used))
    inv = 0.0
    label = ""
    edf_of = _edf_by_length(kind, alpha, m, [L for L, _ in used])
    for L, nk in used:
        e, label = edf_of(L)
        if not (e > 0 and math.isfinite(e)):
            return math.nan, label
        inv += (nk / n_tot) ** 2 / e
    return 1.0 / inv, label


#: a pooled EDF over more distinct segment lengths than this interpolates the EDF of the long
#: segments (Greenhall's sum costs ≈ 1 ms per call: a log with hundreds of gaps took seconds)
EDF_EXACT_LENGTHS = 24


def _edf_by_length(kind: str, alpha: int, m: int, lengths: Sequence[int]):
    """L → (EDF, label) for the segment lengths of one pooled estimate: exact for every
    length when there are few distinct ones, and for the short segments (L ≤ 8m, where the
    EDF is irregular); for the longer ones log–log interpolation of the exact values on
    :data:`EDF_EXACT_LENGTHS` lengths spread geometrically (the EDF is smooth and close to
    linear in L there: interpolation error < 1e-3, checked in tests/test_deviations.py)."""
    cache: dict[int, tuple[float, str]] = {}

    def exact(L: int) -> tuple[float, str]:
        if L not in cache:
            cache[L] = _edf.edf_for(kind, alpha, m, L)
        return cache[L]

    uniq = sorted(set(int(L) for L in lengths))
    long = [L for L in uniq if L > 8 * m]
    if len(uniq) <= EDF_EXACT_LENGTHS or len(long) <= EDF_EXACT_LENGTHS:
        return exact
    grid = sorted(set(int(round(v)) for v in np.geomspace(long[0], long[-1],
                                                          EDF_EXACT_LENGTHS)))
    vals = [exact(L) for L in grid]
    ge = np.array([v[0] for v in vals], float)
    if not np.all(np.isfinite(ge) & (ge > 0)):
        return exact
    lg, le, label = np.log(grid), np.log(ge), vals[-1][1]

    def edf_of(L: int) -> tuple[float, str]:
        if L <= 8 * m or L in cache:
            return exact(L)
        return float(np.exp(np.interp(math.log(L), lg, le))), label

    return edf_of


def assign_alpha(parts, m_id, *, alpha, noise_id: bool, input_kind: str, hadamard: bool,
                 notes: list[str], count_hint: str = "", n_terms=None, kind: str = "",
                 with_fit: bool = False):
    """The power-law noise type α per averaging factor ``m_id`` (one per τ row) and how it was
    found: ``alpha`` forced (one value or one per τ), else identified as Stable32 does
    (:func:`gyrotest.noise.edf.identify_noise`: lag-1 ACF, B1 ratio, R(n)) at each distinct
    averaging factor, else α = 0 assumed. Notes for reused/assumed α go to ``notes``.

    With ``n_terms`` (the statistic's number of terms per row) the B1 rule is Stable32's (B1
    theory at N = n_terms, :func:`gyrotest.noise.edf.identify_noise_pair`). Returns (α,
    methods), or with ``with_fit`` (α, methods, fit) where ``fit`` is None or (α, methods) of
    the statistical identification (B1 theory at the number of averages) for the noise-model
    fit's weights."""
    m_id = np.asarray(m_id, dtype=np.int64)
    alpha_min = -4 if hadamard else -2

    def done(a, meth, fit=None):
        return (a, meth, fit) if with_fit else (a, meth)

    if alpha is not None:
        a_in = np.asarray(alpha, dtype=np.int64)
        if a_in.ndim and a_in.size != m_id.size:
            raise InputError(f"forced alpha has {a_in.size} values for {m_id.size} τ{count_hint}; "
                             "give one α per τ or a single α")
        a_arr = np.broadcast_to(a_in, m_id.shape).copy()
        if np.any(a_arr > 2) or np.any(a_arr < alpha_min):
            raise InputError(f"forced alpha must be in [{alpha_min}, 2], got {np.unique(a_arr).tolist()}")
        return done(a_arr, ["forced"] * len(m_id))
    if not noise_id:
        notes.append("noise identification off: α = 0 (white rate noise) assumed for the EDF")
        return done(np.zeros(len(m_id), dtype=np.int64), ["assumed"] * len(m_id))
    data_type = "phase" if input_kind == "angle" else "frequency"

    def rn_ratio(mm: int) -> float:
        mv, _, _ = _raw_variance("mdev", parts, mm)
        av, _, _ = _raw_variance("oadev", parts, mm)
        return mv / av if av > 0 else math.nan

    uniq = sorted(set(int(v) for v in m_id))
    fit = None
    if n_terms is not None:
        n_by_m: dict[int, int] = {}
        for mm, nn in zip(m_id, n_terms):
            n_by_m[int(mm)] = max(n_by_m.get(int(mm), 0), int(nn))
        nids, fit_nids = _edf.identify_noise_pair(
            parts, uniq, [n_by_m[v] for v in uniq], kind=kind, data_type=data_type,
            dmax=3 if hadamard else 2, alpha_min=alpha_min, rn_ratio=rn_ratio)
        by_f = dict(zip(uniq, fit_nids))
        fit = (np.array([by_f[int(v)].alpha for v in m_id], dtype=np.int64),
               [by_f[int(v)].method for v in m_id])
    else:
        nids = _edf.identify_noise(parts, uniq, data_type=data_type, dmax=3 if hadamard else 2,
                                   alpha_min=alpha_min, rn_ratio=rn_ratio)
    by_m = dict(zip(uniq, nids))
    a_arr = np.array([by_m[int(v)].alpha for v in m_id], dtype=np.int64)
    a_methods = [by_m[int(v)].method for v in m_id]
    if any(mm == "reused" for mm in a_methods):
        notes.append("noise type at the longest τ reused from the previous τ (too few averages "
                     "for the lag-1 or B1 method), as Stable32 does")
    if fit is not None and np.any(fit[0] != a_arr):
        diff = np.flatnonzero(fit[0] != a_arr)
        notes.append(
            "α at averaging factor m = " + ", ".join(f"{m_id[i]:d}" for i in diff[:6])
            + (" …" if diff.size > 6 else "")
            + " is Stable32's B1 identification (theory at the statistic's number of terms); "
            "the noise-model fit weights with the B1 identification at the number of averages "
            "(Barnes 1969), which resolves random-walk rate noise")
    return done(a_arr, a_methods, fit)


_LONG_NAMES = {
    "adev": "Allan deviation (non-overlapping)",
    "oadev": "overlapping Allan deviation",
    "mdev": "modified Allan deviation",
    "tdev": "time deviation",
    "hdev": "Hadamard deviation (non-overlapping)",
    "ohdev": "overlapping Hadamard deviation",
    "totdev": "total deviation",
    "mtotdev": "modified total deviation",
    "akdev": "Allan-Krobka dispersion",
    "hkdev": "Hadamard-Krobka dispersion",
    "theo1": "Thêo1 deviation",
    "theoh": "ThêoH deviation (Allan deviation, then bias-removed Thêo1)",
    "ttotdev": "time total deviation",
    "htotdev": "Hadamard total deviation",
    "gapadev": "gap-tolerant overlapping Allan deviation",
}
