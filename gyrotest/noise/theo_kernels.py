"""Fast exact kernels for Thêo1 and the Hadamard total variance (pure numpy/scipy).

Thêo1 (Howe & Tasset, "Theo1: characterization of very long-term frequency stability", Proc.
18th EFTF 2004; NIST SP1065 eq. 30) of N angle ("phase") points x at an even averaging factor
m, h = m/2, L = N − m:

    S(m) = Σ_{i=0}^{L−1} Σ_{δ=0}^{h−1} [(x_i − x_{i−δ+h}) + (x_{i+m} − x_{i+δ+h})]² / (h − δ)
         = Σ_{k=1}^{h} (1/k) Σ_{i=0}^{L−1} E_k(i)²,   E_k(i) = x_i − x_{i+k} − x_{i+m−k} + x_{i+m}

(k = h − δ). The direct double sum costs O(L·h) per τ (AllanTools: a Python loop, minutes for
a few thousand points). :func:`theo1_sum` expands E² into squares (prefix sums) and lagged
products. Every windowed lagged sum Σ_{j=s}^{s+L−1} x_j x_{j+ℓ} is the full autocorrelation
R(ℓ) (one FFT per record, shared by all τ) minus a head and a tail that involve only the first
or the last m points; those are autocorrelations of length-m pieces (one FFT each per τ)
except for the symmetric products x_{i+k}·x_{i+m−k}, whose head and tail are *half*
convolutions Σ_{a<b, a+b=s} u_a v_b, computed by divide and conquer with FFTs
(:func:`half_convolution`, O(m log² m)). Cost per τ: O(N + m log² m), exact up to rounding;
the tests compare it with the direct sum (:func:`theo1_sum_direct`) to 1e-9.

HTOTDEV (Howe, Beard, Greenhall, Riley, "Total Hadamard variance", NIST SP1065 eq. 29) has
the algebra of MTOTDEV applied to the rate series (3m-point subsequences, half-average slope
removed, even reflection to 9m points, second differences of m-point averages), so it reuses
the O(N)-per-τ MTOTDEV kernel of :mod:`gyrotest.noise.deviations` on the rate samples.
"""

from __future__ import annotations

import numpy as np
from scipy import fft as _fft
from scipy.signal import fftconvolve

__all__ = [
    "autocorrelation",
    "half_convolution",
    "theo1_sum",
    "theo1_sum_direct",
    "theo1_terms",
]

#: half-convolution blocks at most this long are summed directly (tuned: 48–96 all within 10 %)
_HC_BASE = 64
#: below this L·h the direct Thêo1 sum (vectorised over i) is used: fast and free of the
#: cancellation of the expanded form
DIRECT_MAX_WORK = 4_000_000
#: the fast (expanded) form is accepted when its estimated relative rounding error is below this
FAST_MAX_REL_ERROR = 1e-10
#: … otherwise the direct sum is used up to this L·h (≈ 10 s); beyond, the fast value is kept
#: and its error estimate reported
DIRECT_BUDGET = 2_000_000_000


def theo1_terms(n_points: int, m: int) -> int:
    """Number of terms of the Thêo1 double sum, Stable32's "#": (N − m)·m/2."""
    return max(n_points - m, 0) * (m // 2)


def theo1_sum_direct(x: np.ndarray, m: int) -> float:
    """S(m) by its definition, vectorised over i: O((N − m)·m/2). The reference of the tests
    and the fast path for small L·h."""
    N = x.size
    h = m // 2
    L = N - m
    if L <= 0 or m < 2 or m % 2:
        return float("nan")
    tot = 0.0
    buf = np.empty(L)
    for k in range(1, h + 1):
        np.subtract(x[0:L], x[k : k + L], out=buf)
        buf -= x[m - k : m - k + L]
        buf += x[m : m + L]
        tot += float(np.dot(buf, buf)) / k
    return tot


def autocorrelation(x: np.ndarray) -> np.ndarray:
    """R(ℓ) = Σ_{j=0}^{N−1−ℓ} x_j x_{j+ℓ} for ℓ = 0 … N−1, by FFT (O(N log N))."""
    n = x.size
    nfft = _fft.next_fast_len(2 * n, real=True)
    f = _fft.rfft(x, nfft)
    return _fft.irfft(f * np.conj(f), nfft)[:n]


def _acorr_small(x: np.ndarray) -> np.ndarray:
    n = x.size
    if n <= 256:
        return np.correlate(x, x, mode="full")[n - 1 :]
    return autocorrelation(x)


def half_convolution(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """c(s) = Σ_{a<b, a+b=s} u_a·v_b for s = 0 … 2n − 2 (u, v of equal length n).

    Divide and conquer on the index range: pairs with a in the left half and b in the right
    half all satisfy a < b and form one full convolution (FFT); pairs inside each half
    recurse. O(n log² n)."""
    n = u.size
    out = np.zeros(max(2 * n - 1, 1))
    stack = [(0, n)]
    while stack:
        lo, hi = stack.pop()
        w = hi - lo
        if w <= 1:
            continue
        if w <= _HC_BASE:
            for a in range(lo, hi - 1):
                out[2 * a + 1 : a + hi] += u[a] * v[a + 1 : hi]
            continue
        mid = (lo + hi) // 2
        left = u[lo:mid]
        right = v[mid:hi]
        if left.size * right.size <= 4096:
            c = np.convolve(left, right)
        else:
            c = fftconvolve(left, right)
        out[lo + mid : lo + mid + c.size] += c
        stack.append((lo, mid))
        stack.append((mid, hi))
    return out


def _sym_head(x: np.ndarray, m: int) -> float:
    """Σ_{e=0}^{h−1} (1/(h−e)) Σ_{a=0}^{h−e−1} x_a x_{a+2e} (the head of the symmetric-product
    term) as Σ_{s even, 2 ≤ s ≤ m} (2/s)·c(s), c the half convolution of x_0…x_m with its
    reverse."""
    u = x[: m + 1]
    v = u[::-1]
    c = half_convolution(u, v)
    s = np.arange(2, m + 1, 2)
    return float(np.dot(2.0 / s, c[s]))


class Theo1Engine:
    """Thêo1 sums S(m) of one angle series for many m, sharing the record's autocorrelation.

    ``x`` should be free of a large offset and slope (the caller passes θ minus its end-point
    line, which leaves S unchanged: E_k cancels a + b·i)."""

    def __init__(self, x: np.ndarray):
        self.x = np.ascontiguousarray(x, dtype=np.float64)
        self._R: np.ndarray | None = None
        c2 = np.empty(self.x.size + 1)
        c2[0] = 0.0
        np.cumsum(self.x * self.x, out=c2[1:])
        self._c2 = c2
        self.last_scale = 0.0
        self.last_rel_error = 0.0

    @property
    def R(self) -> np.ndarray:
        if self._R is None:
            self._R = autocorrelation(self.x)
        return self._R

    def sum(self, m: int) -> float:
        """S(m); the rounding-error estimate of the last call is in ``last_rel_error``."""
        x = self.x
        N = x.size
        h = m // 2
        L = N - m
        self.last_rel_error = 0.0
        if L <= 0 or m < 2 or m % 2:
            return float("nan")
        if L * h <= DIRECT_MAX_WORK:
            return theo1_sum_direct(x, m)
        s = self._fast(m)
        # the expanded form loses digits in proportion to (size of the cancelled terms)/S:
        # measured error ≈ 1e-14 × that ratio (random-walk-rate angle is the worst case)
        est = 1e-14 * self.last_scale / s if s > 0 else float("inf")
        if est > FAST_MAX_REL_ERROR and L * h <= DIRECT_BUDGET:
            return theo1_sum_direct(x, m)
        self.last_rel_error = est
        return s

    def _fast(self, m: int) -> float:
        x, c2 = self.x, self._c2
        N = x.size
        h = m // 2
        L = N - m
        R = self.R
        k = np.arange(1, h + 1)
        w = 1.0 / k
        # squares: x_i², x_{i+k}², x_{i+m−k}², x_{i+m}² over i ∈ [0, L)
        q = (c2[L] - c2[0]) + (c2[k + L] - c2[k]) + (c2[m - k + L] - c2[m - k]) + (c2[N] - c2[m])
        Ru = _acorr_small(x[:m])  # lags 0 … m−1 of the first m points
        Ry = _acorr_small(x[N - m :])  # … of the last m points
        Ru = np.append(Ru, 0.0)
        Ry = np.append(Ry, 0.0)
        A1 = R[k] - Ry[k]  # Σ x_i x_{i+k}
        A2 = R[m - k] - Ry[m - k]  # Σ x_i x_{i+m−k}
        A3 = R[m] if m < N else 0.0  # Σ x_i x_{i+m}
        A5 = R[m - k] - Ru[m - k]  # Σ x_{i+k} x_{i+m}
        A6 = R[k] - Ru[k]  # Σ x_{i+m−k} x_{i+m}
        # Σ_k (1/k) Σ_i x_{i+k} x_{i+m−k}: full lag sums minus head and tail half-convolutions
        a4 = float(np.dot(w, R[m - 2 * k])) - _sym_head(x, m) - _sym_head(x[::-1], m)
        tot = float(np.dot(w, q - 2.0 * A1 - 2.0 * A2 + 2.0 * A3 - 2.0 * A5 - 2.0 * A6))
        self.last_scale = float(np.dot(w, q))  # size of the cancelled terms (≥ Σ x² scale)
        return tot + 2.0 * a4


def theo1_sum(x: np.ndarray, m: int) -> float:
    """S(m) of the module docstring for one averaging factor (see :class:`Theo1Engine` for
    many)."""
    return Theo1Engine(x).sum(m)
