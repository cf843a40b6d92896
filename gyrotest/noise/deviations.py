"""Allan-family deviations of gyro rate, increment or angle records (pure numpy).

Input kinds
-----------
Every public function takes ``input_kind`` explicitly — there is no default that silently
assumes angle ("phase") data:

* ``"rate"``: rate samples Ω_k (e.g. deg/h), each the average over the sample interval τ0 — the
  "fractional frequency" of time-and-frequency metrology. Results are in the rate unit.
* ``"increment"``: angle increments per sample ΔΘ_k = Ω_k·τ0 (pulse count × scale factor).
  Results are in angle unit per second.
* ``"angle"``: cumulative angle Θ_k (the "phase"). Results are in angle unit per second.

Internally the record becomes the angle series θ with a leading 0,
θ = [0, cumsum(Ω − Ω̄)·τ0] (rate), [0, cumsum(ΔΘ − mean ΔΘ)] (increment), or Θ minus the
straight line through its first and last points (angle). Removing the mean rate first keeps
the cumulative sum small (precision; the PTB fix AllanTools also applies) and changes none of
the statistics here: all of them are invariant to a constant rate offset — the finite
differences cancel it, TOTDEV's odd reflection continues a straight line, and MTOTDEV removes
each subsequence's own frequency offset. (This is checked in the tests.)

Statistics (τ = m·τ0, N angle points θ_0 … θ_{N−1}; NIST SP1065 equation numbers)
------------------------------------------------------------------------------------
========= ============================================================================= =====
adev      σ² = Σ_k (θ_{(k+2)m} − 2θ_{(k+1)m} + θ_{km})² / (2τ²n), n = ⌊(N−1)/m⌋ − 1     (7)
oadev     σ² = Σ_{k=0}^{N−2m−1} (θ_{k+2m} − 2θ_{k+m} + θ_k)² / (2τ²(N−2m))              (11)
mdev      σ² = Σ_j [Σ_{i=j}^{j+m−1} (θ_{i+2m} − 2θ_{i+m} + θ_i)]² / (2m²τ²(N−3m+1))      (14)
tdev      σ_x = τ/√3 · mdev (angle unit)                                                (15)
hdev      σ² = Σ_k (θ_{(k+3)m} − 3θ_{(k+2)m} + 3θ_{(k+1)m} − θ_{km})² / (6τ²n)           (18)
ohdev     σ² = Σ_{k=0}^{N−3m−1} (θ_{k+3m} − 3θ_{k+2m} + 3θ_{k+m} − θ_k)² / (6τ²(N−3m))  (20)
totdev    OADEV of the series reflected at both ends (θ*_{−j} = 2θ_0 − θ_j, θ*_{N−1+j} =
          2θ_{N−1} − θ_{N−1−j}), σ² = Σ_{i=1}^{N−2} (θ*_{i−m} − 2θ_i + θ*_{i+m})²/(2τ²(N−2)) (25)
mtotdev   MVAR of each 3m-point subsequence with its half-average slope removed and extended
          by even reflection to 9m points, averaged over the N−3m+1 subsequences          (27)
akdev     Allan–Krobka dispersion (Krobka eq. 5.10):
          σ²_AK = ½⟨(ω̄_{k+m} − ω̄_k)²⟩ − ½⟨ω̄_{k+m} − ω̄_k⟩² over overlapping cluster
          averages ω̄_k = (θ_{k+m} − θ_k)/τ; zero for a rate ramp Ω = Rt (OADEV = Rτ/√2)
hkdev     the Hadamard analogue: (⟨h²⟩ − ⟨h⟩²)/(6τ²), h the third difference of ohdev
========= ============================================================================= =====

IEEE Std 952-1997 Annex C gives the Allan variance of gyro rate in exactly the overlapping
form of ``oadev`` (GYRO_REFERENCE §4). TOTDEV and MTOTDEV are computed *without* bias
correction (Stable32's "no bias correction" setting), in the phase (angle) domain of SP1065.

Cost: every statistic is O(N) per τ, vectorised and processed in cache-sized chunks so the
temporaries stay small; the only full-size array is θ (1× the input; measured peak extra
memory of OADEV 1.00–1.02× the input at 10⁷–10⁸ samples). MTOTDEV uses an exact O(N)-per-τ
reformulation (``gyrotest/noise/mtot.py``) instead of the O(N·m) direct sum; its prefix sums
are streamed along each block in chunks, so its working set on top of θ is a few dozen chunk
buffers: ≈ 0.3–0.7× the record at 10⁶–10⁷ points, at most ≈ 25 MB whatever N. TOTDEV's
reflected edge terms are chunked the same way (≤ 1 MB).

Gaps
----
``segments`` is a list of (start, stop) sample-index ranges (Python slice convention, on the
input array) of contiguous, uniformly sampled data. Each segment is integrated separately
(its own leading zero and mean rate); each estimator's sum of squares and term count are
added over segments and the variance is the pooled sum / pooled count — no difference ever
spans a gap. TOTDEV reflects at the ends of each segment; MTOTDEV subsequences lie within one
segment. The EDF of a pooled estimate is 1/Σ_s (w_s²/edf_s), w_s = n_s/Σn (independent
segments). The τ grid is built on the longest segment.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..core.errors import AnalysisError, InputError
from . import edf as _edf
from . import kinds as _kinds
from . import mtot as _mtot
from .taus import STOP_RATIOS, tau_grid

__all__ = [
    "DEVIATION_KINDS",
    "INPUT_KINDS",
    "AngleSeries",
    "DeviationResult",
    "adev",
    "akdev",
    "angle_series",
    "compute_deviation",
    "hdev",
    "hkdev",
    "mdev",
    "mtotdev",
    "oadev",
    "ohdev",
    "tdev",
    "totdev",
]

INPUT_KINDS = ("rate", "increment", "angle")
DEVIATION_KINDS = _kinds.DEVIATION_KINDS
_EXTRA_KINDS = ("theo1", "theoh", "ttotdev", "htotdev", "gapadev")
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

#: Elements per chunk of the streaming kernels (64 Ki float64 = 512 KiB buffer; with the three
#: input streams it stays in L2; tuned on the reference VM, see benchmarks/README.md).
CHUNK = 1 << 16


# ---------------------------------------------------------------------------------------------
# Result type
# ---------------------------------------------------------------------------------------------


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


# ---------------------------------------------------------------------------------------------
# Input → angle series
# ---------------------------------------------------------------------------------------------


@dataclass
class AngleSeries:
    """The integrated angle series θ of one or more gap-free segments.

    ``theta`` holds all segments back to back; ``bounds`` are (start, stop) of each segment in
    ``theta``; the true angle is ``scale·theta`` (scale = τ0 for rate input, whose cumulative
    sum is kept in rate × samples to save a pass; 1 otherwise). ``segments`` are the input-index
    ranges, ``n_data`` the number of input samples used, ``n_longest`` the samples of the
    longest segment.
    """

    theta: np.ndarray
    bounds: list[tuple[int, int]]
    scale: float
    tau0: float
    input_kind: str
    segments: list[tuple[int, int]]
    n_data: int
    n_longest: int
    notes: list[str] = field(default_factory=list)

    def parts(self) -> list[np.ndarray]:
        """Views of θ, one per segment."""
        return [self.theta[a:b] for a, b in self.bounds]


def _as_float_array(data, what: str = "data") -> np.ndarray:
    try:
        arr = np.asarray(data, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{what} is not numeric: {exc}") from None
    if arr.ndim != 1:
        raise InputError(f"{what} must be a 1-D array of samples, got shape {arr.shape}")
    return arr


def _check_kind(input_kind: str) -> str:
    if input_kind not in INPUT_KINDS:
        raise InputError(
            f"input_kind must be one of {', '.join(INPUT_KINDS)} (got {input_kind!r}); "
            "say explicitly whether the samples are rates, per-sample angle increments or "
            "cumulative angles"
        )
    return input_kind


def _normalise_segments(segments, n: int) -> list[tuple[int, int]]:
    if segments is None:
        return [(0, n)]
    segs: list[tuple[int, int]] = []
    for s in segments:
        try:
            a, b = (int(s[0]), int(s[1]))
        except (TypeError, ValueError, IndexError):
            raise InputError(f"segment {s!r} is not a (start, stop) pair of sample indices") from None
        if not 0 <= a < b <= n:
            raise InputError(
                f"segment ({a}, {b}) outside the record of {n} samples; use 0 <= start < stop <= {n}"
            )
        segs.append((a, b))
    if not segs:
        raise InputError("empty segment list; give at least one (start, stop) range")
    segs.sort()
    for (a0, b0), (a1, _) in zip(segs, segs[1:]):
        if a1 < b0:
            raise InputError(f"segments ({a0}, {b0}) and ({a1}, ...) overlap; segments must be disjoint")
    return segs


def _first_bad(arr: np.ndarray) -> int:
    for s in range(0, arr.size, CHUNK):
        bad = ~np.isfinite(arr[s : s + CHUNK])
        if bad.any():
            return s + int(np.argmax(bad))
    return -1


def _span(x: np.ndarray) -> tuple[float, float]:
    """(max − min, max |x|) of a segment, streaming, no full-size temporaries."""
    return float(np.max(x) - np.min(x)), float(max(abs(np.max(x)), abs(np.min(x))))


def _diff_span(x: np.ndarray) -> tuple[float, float]:
    """(max − min, max |·|) of the first differences of x, chunked."""
    lo, hi = math.inf, -math.inf
    for s in range(0, x.size - 1, CHUNK):
        d = np.diff(x[s : s + CHUNK + 1])
        lo = min(lo, float(d.min()))
        hi = max(hi, float(d.max()))
    return hi - lo, max(abs(lo), abs(hi))


def angle_series(
    data, tau0: float, *, input_kind: str, segments: Sequence[tuple[int, int]] | None = None
) -> AngleSeries:
    """Convert rate, increment or angle samples to the angle series θ (see module docstring).

    θ = [0, cumsum(Ω − Ω̄)]·τ0 for rate input (kept as [0, cumsum(Ω − Ω̄)] with ``scale`` = τ0),
    [0, cumsum(ΔΘ − mean)] for increments, Θ − (Θ_0 + k·(Θ_end − Θ_0)/(n − 1)) for angles; per
    segment. Memory: one float64 array of about the input size; the cumulative sum is done in
    chunks with a carry, so no other full-size temporary is made.

    Raises :class:`InputError` for NaN/inf samples, an empty record or bad segments, and
    :class:`AnalysisError` for a constant rate (every deviation would be zero).
    """
    _check_kind(input_kind)
    if not (isinstance(tau0, (int, float, np.floating)) and math.isfinite(tau0) and tau0 > 0):
        raise InputError(f"sample interval tau0 must be a number > 0 s, got {tau0!r}")
    arr = _as_float_array(data)
    n = arr.size
    if n == 0:
        raise InputError("empty record: no samples to analyse")
    segs = _normalise_segments(segments, n)
    notes: list[str] = []
    means: list[float] = []
    for a, b in segs:
        # NaN/inf check without a full-size temporary: any NaN/inf makes the mean non-finite
        # (and the mean is needed anyway for rate and increment input).
        mean = float(np.mean(arr[a:b]))
        if not math.isfinite(mean):
            i = _first_bad(arr[a:b])
            if i >= 0:
                raise InputError(
                    f"{input_kind} sample {a + i} is {float(arr[a + i])}: remove or interpolate "
                    "it, or pass segments that exclude it (gap-aware analysis)"
                )
            raise InputError(f"{input_kind} samples overflow float64; rescale the data")
        means.append(mean)
    per = 1 if input_kind != "angle" else 0  # extra leading point per segment
    total = sum(b - a + per for a, b in segs)
    theta = np.empty(total, dtype=np.float64)
    bounds: list[tuple[int, int]] = []
    pos = 0
    any_variation = False
    for (a, b), mean in zip(segs, means):
        x = arr[a:b]
        L = b - a + per
        out = theta[pos : pos + L]
        if input_kind == "angle":
            if x.size >= 2:
                span, _ = _diff_span(x)
                _, mag = _span(x)  # rounding of the angles themselves sets the noise floor
                any_variation |= span > 16 * np.finfo(float).eps * max(mag, 1e-300)
            slope = (x[-1] - x[0]) / (x.size - 1) if x.size > 1 else 0.0
            x0 = x[0]
            for s in range(0, x.size, CHUNK):
                e = min(x.size, s + CHUNK)
                k = np.arange(s, e, dtype=np.float64)
                k *= slope
                np.subtract(x[s:e], x0, out=out[s:e])
                out[s:e] -= k
        else:
            out[0] = 0.0
            carry = 0.0
            lo, hi = math.inf, -math.inf
            for s in range(0, x.size, CHUNK):
                e = min(x.size, s + CHUNK)
                xs = x[s:e]
                lo = min(lo, float(xs.min()))  # the chunk is cache-resident: cheap
                hi = max(hi, float(xs.max()))
                buf = out[1 + s : 1 + e]
                np.subtract(xs, mean, out=buf)
                buf[0] += carry  # the carry propagates through the cumulative sum
                np.cumsum(buf, out=buf)
                carry = float(buf[-1])
            mag = max(abs(lo), abs(hi))
            any_variation |= (hi - lo) > 4 * np.finfo(float).eps * max(mag, 1e-300)
        bounds.append((pos, pos + L))
        pos += L
    if not any_variation:
        what = "angle increases at a constant rate" if input_kind == "angle" else (
            f"{input_kind} is constant ({float(arr[segs[0][0]]):.6g} in every sample)"
        )
        raise AnalysisError(
            f"the {what}: every deviation is exactly zero and no noise can be identified; "
            "check the channel, scale factor and quantization (a gyro output this quiet is "
            "below its resolution)"
        )
    if len(segs) > 1:
        notes.append(
            f"gap-aware estimate: {len(segs)} segments analysed separately, sums of squares and "
            "term counts pooled; no difference spans a gap"
        )
    lengths = [b - a for a, b in segs]
    return AngleSeries(
        theta=theta,
        bounds=bounds,
        scale=float(tau0) if input_kind == "rate" else 1.0,
        tau0=float(tau0),
        input_kind=input_kind,
        segments=segs,
        n_data=int(sum(lengths)),
        n_longest=int(max(lengths)),
        notes=notes,
    )


# ---------------------------------------------------------------------------------------------
# Streaming kernels: each returns a sum of squares (and a term count) for one contiguous θ
# ---------------------------------------------------------------------------------------------


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


# --- MTOTDEV: the kernel lives in gyrotest/noise/mtot.py ------------------------------------

_mtot_sum = _mtot.mtot_sum


# ---------------------------------------------------------------------------------------------
# Raw variances (pooled over segments)
# ---------------------------------------------------------------------------------------------


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


# ---------------------------------------------------------------------------------------------
# The dispatcher
# ---------------------------------------------------------------------------------------------

_MIN_POINTS_TEXT = {
    "oadev": "2m + 1 angle points (N − 2m ≥ 1 cluster differences)",
    "akdev": "2m + 1 angle points",
    "adev": "2m + 1 angle points (at least one pair of adjacent clusters)",
    "mdev": "3m angle points",
    "tdev": "3m angle points",
    "mtotdev": "3m angle points",
    "ohdev": "3m + 1 angle points",
    "hkdev": "3m + 1 angle points",
    "hdev": "3m + 1 angle points",
    "totdev": "2m angle points",
}


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


#: below this many samples the τ loop runs in one thread (thread start-up would dominate)
PARALLEL_MIN_SAMPLES = 200_000
#: optional ``hook(done, total, kind)`` called after each τ of the τ loop, in the calling
#: thread (the CLI's progress display sets it; the core never prints); for MTOTDEV also within
#: a τ, with a fractional ``done`` (i + fraction of τ number i + 1's work)
PROGRESS: Callable[[float, int, str], None] | None = None


def _akdev_from_oadev(parts: Sequence[np.ndarray], m: int, var_oa: float, n_tot: int,
                      ns: list[int]) -> tuple[float, int, list[int]]:
    """AKDEV's raw variance from the OADEV's at the same m: (Σd² − n·d̄²)/(2n) = var_OA − d̄²/2,
    with the mean second difference d̄ telescoped in O(m) (:func:`_d2_total`): no pass over θ."""
    s1 = sum(_d2_total(p, m)[0] for p, nk in zip(parts, ns) if nk > 0)
    mean = s1 / n_tot
    return max(var_oa - 0.5 * mean * mean, 0.0), n_tot, ns


def _raw_variances(kind: str, parts: Sequence[np.ndarray], ms, longest: int,
                   known: dict[int, float] | None = None) -> list:
    """:func:`_raw_variance` for every averaging factor in ``ms``, in order. ``known``: for
    AKDEV, the OADEV raw variance of the same θ per m, from which AKDEV follows in O(m).

    The τ values are independent and the kernels spend their time in numpy calls that release
    the GIL, so long records are processed by a small thread pool (one thread per core, at
    most 4); the result is identical to the serial loop. Not MTOTDEV: its streamed kernel makes
    many calls on small buffers, which contend for the GIL on threads (at 10⁶ samples, 2
    threads took 22 s of CPU and 20 s of wall time against 17 s and 17 s serially)."""
    ms = [int(m) for m in ms]
    if kind == "akdev" and known:
        done = {}
        for m in ms:
            if m in known:
                ns = [_n_terms(kind, p.size, m) for p in parts]
                n_tot = int(sum(ns))
                done[m] = (_akdev_from_oadev(parts, m, known[m], n_tot, ns) if n_tot
                           else (math.nan, 0, ns))
        rest = iter(_raw_variances(kind, parts, [m for m in ms if m not in done], longest))
        return [done[m] if m in done else next(rest) for m in ms]
    hook = PROGRESS
    out: list = []
    workers = min(os.cpu_count() or 1, 4, len(ms))
    if workers < 2 or longest < PARALLEL_MIN_SAMPLES or kind == "mtotdev":
        for i, m in enumerate(ms):
            if hook is not None and kind == "mtotdev":  # progress within a τ too (long records)
                _mtot.STEP = lambda f, i=i: hook(i + f, len(ms), kind)
            try:
                out.append(_raw_variance(kind, parts, m))
            finally:
                _mtot.STEP = None
            if hook is not None:
                hook(len(out), len(ms), kind)
        return out
    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(max_workers=workers) as ex:
        for r in ex.map(lambda m: _raw_variance(kind, parts, m), ms):
            out.append(r)
            if hook is not None:  # called in the calling thread, in τ order
                hook(len(out), len(ms), kind)
    return out


def compute_deviation(
    data,
    tau0: float,
    *,
    input_kind: str,
    kind: str = "oadev",
    taus: str | Sequence[float] = "decade10",
    confidence: float = _edf.DEFAULT_CONFIDENCE,
    stop_ratio: float | None = None,
    segments: Sequence[tuple[int, int]] | None = None,
    unit: str = "deg/h",
    noise_id: bool = True,
    alpha: int | Sequence[int] | None = None,
    bias_correction: bool = False,
    reuse: DeviationResult | None = None,
) -> DeviationResult:
    """Compute one deviation with noise identification, EDF and χ² confidence interval.

    Parameters
    ----------
    data : 1-D array of rate, increment or angle samples (no NaN: use ``segments`` for gaps),
        or an :class:`AngleSeries` already built from them (then ``segments`` is ignored).
    tau0 : sample interval, s.
    input_kind : "rate" | "increment" | "angle" (required; see the module docstring).
    kind : one of :data:`DEVIATION_KINDS` (default "oadev", the IEEE 952 Annex C estimator).
    taus : τ grid: "octave", "decade", "decadeN" (default "decade10"), "all", or a list of τ
        in seconds (see :mod:`gyrotest.noise.taus`).
    confidence : two-sided confidence of [sigma_lo, sigma_hi] (default 0.683 as Stable32).
    stop_ratio : max m = N // stop_ratio for generated grids (default: Stable32's per kind).
    segments : gap-free (start, stop) sample ranges; default the whole record.
    unit : rate unit of the data (rate input) or of the result, stored in the result.
    noise_id : identify α per τ (lag-1 ACF, B1 fallback); if False, α = 0 (white rate noise)
        is assumed for the EDF and the notes say so.
    alpha : force α (an int for all τ, or one per τ, e.g. Stable32's column) instead of
        identifying it.
    bias_correction : TOTDEV/MTOTDEV only. False (default) gives the plain estimators, as
        Stable32's "no bias correction" and the NBS14 reference values. True divides the
        variance by the SP1065 bias factor for the identified α: TOTDEV 1 − a·τ/T with
        a = 0.481 (α = −1) or 0.750 (α = −2), T the (longest) segment length (no bias for
        α ≥ 0);
        MTOTDEV 0.94, 0.83, 0.73, 0.70, 0.69 for α = 2 … −2 (Howe & Vernotte 1999).
    reuse : AKDEV only: an OADEV of the same data (same τ0, input kind and segments). At its
        τ, AKDEV follows from its sums, σ²_AK = σ²_OA − (scale·d̄/τ)²/2 with the mean second
        difference d̄ telescoped in O(m): no pass over θ (the trend check of ``allan``).

    Returns a :class:`DeviationResult`. Units: σ in the rate unit of the input (rate input) or
    angle unit per second (increment/angle input); TDEV in the angle unit (rate unit × s).

    Raises :class:`InputError` (bad input, NaN, τ the record cannot support in an explicit
    list) or :class:`AnalysisError` (constant signal, record too short for any τ).
    """
    if kind not in DEVIATION_KINDS:
        raise InputError(f"unknown deviation {kind!r}; choose one of {', '.join(DEVIATION_KINDS)}")
    if kind in _EXTRA_KINDS:
        return _compute_extra(data, tau0, input_kind=input_kind, kind=kind, taus=taus,
                              confidence=confidence, stop_ratio=stop_ratio, segments=segments,
                              unit=unit, noise_id=noise_id, alpha=alpha,
                              bias_correction=bias_correction)
    _check_kind(input_kind)
    if not 0.0 < confidence < 1.0:
        raise InputError(f"confidence must be between 0 and 1 (e.g. 0.683), got {confidence!r}")
    if isinstance(data, AngleSeries):  # θ already built (a streamed log): no copy
        series = data
        if series.input_kind != input_kind or not math.isclose(series.tau0, tau0):
            raise InputError(f"angle series of {series.input_kind} input at τ0 = {series.tau0:g} "
                             f"s given for {input_kind} input at τ0 = {tau0:g} s")
    else:
        series = angle_series(data, tau0, input_kind=input_kind, segments=segments)
    parts = series.parts()
    grid = tau_grid(taus, n_data=series.n_longest, tau0=series.tau0, kind=kind, stop_ratio=stop_ratio)
    notes = list(series.notes) + list(grid.notes)
    explicit = grid.spec == "explicit"
    longest = max(p.size for p in parts)

    rows_m: list[int] = []
    rows_var: list[float] = []
    rows_n: list[int] = []
    rows_ns: list[list[int]] = []
    dropped: list[int] = []
    known = None
    if (reuse is not None and kind == "akdev" and reuse.kind == "oadev"
            and reuse.input_kind == input_kind and math.isclose(reuse.tau0, series.tau0)
            and list(reuse.segments) == list(series.segments)):
        known = {int(mm): float((sg * tt / series.scale) ** 2)
                 for mm, sg, tt in zip(reuse.m, reuse.sigma, reuse.tau)}
    for m, (var, n_tot, ns) in zip(grid.m, _raw_variances(kind, parts, grid.m, longest,
                                                           known)):
        m = int(m)
        if n_tot < 1:
            dropped.append(m)
            continue
        rows_m.append(m)
        rows_var.append(var)
        rows_n.append(n_tot)
        rows_ns.append(ns)
    if dropped and explicit:
        tau_txt = ", ".join(f"{mm * series.tau0:g}" for mm in dropped)
        raise InputError(
            f"record too short for τ = {tau_txt} s: the longest segment has {series.n_longest} "
            f"samples ({longest} angle points) and {kind} needs {_MIN_POINTS_TEXT[kind]}; "
            "drop the longer τ from --taus"
        )
    if dropped:
        notes.append(
            f"τ = {', '.join(f'{mm * series.tau0:g}' for mm in dropped)} s dropped: fewer than "
            f"one {kind} term ({_MIN_POINTS_TEXT[kind]} needed)"
        )
    if not rows_m:
        ratio = STOP_RATIOS.get(kind, 4) if stop_ratio is None else stop_ratio
        raise AnalysisError(
            f"record too short for {kind}: {series.n_longest} samples in the longest segment give "
            f"no τ (stop ratio {ratio:g}; {kind} needs {_MIN_POINTS_TEXT[kind]} at τ = m·τ0); "
            "record a longer log or use a smaller stop ratio"
        )

    m_arr = np.array(rows_m, dtype=np.int64)
    tau = m_arr * series.tau0
    var = np.array(rows_var)
    sigma = np.sqrt(var) * series.scale / tau
    out_unit = unit
    if kind == "tdev":
        sigma = sigma * tau / math.sqrt(3.0)
        out_unit = f"({unit})·s"

    # --- noise identification -----------------------------------------------------------
    hadamard = kind in ("hdev", "ohdev", "hkdev")
    a_arr, a_methods, fit_ids = assign_alpha(
        parts, m_arr, alpha=alpha, noise_id=noise_id, input_kind=input_kind, hadamard=hadamard,
        notes=notes, count_hint=" (after rounding τ to multiples of τ0 and merging duplicates)",
        n_terms=rows_n, kind=kind, with_fit=True)

    if bias_correction:
        if kind not in ("totdev", "mtotdev"):
            raise InputError(f"bias correction is defined for totdev and mtotdev only, not {kind}")
        factor = _bias_factor(kind, a_arr, tau, series.tau0 * (longest - 1))
        sigma = sigma / np.sqrt(factor)
        notes.append(
            "SP1065 bias correction applied: "
            + ("TOTDEV / (1 − a·τ/T), a = 0.481 (α = −1), 0.750 (α = −2)" if kind == "totdev"
               else "MTOTDEV / B(α), B = 0.94, 0.83, 0.73, 0.70, 0.69 for α = 2 … −2")
        )

    # --- EDF and confidence interval ------------------------------------------------------
    edf_kind = "mdev" if kind == "tdev" else kind
    edfs = np.empty(len(m_arr))
    methods: list[str] = []
    for i, (mm, aa, ns) in enumerate(zip(m_arr, a_arr, rows_ns)):
        e, lab = _pooled_edf(edf_kind, int(aa), int(mm), parts, ns)
        edfs[i] = e if (e > 0 and math.isfinite(e)) else math.nan
        methods.append(lab)
    lo, hi = _edf.chi2_interval(sigma, edfs, confidence)
    alpha_fit = alpha_fit_method = edf_fit = None
    if fit_ids is not None:
        alpha_fit, alpha_fit_method = fit_ids
        edf_fit = edfs.copy()
        for i in np.flatnonzero(alpha_fit != a_arr):
            e, _ = _pooled_edf(edf_kind, int(alpha_fit[i]), int(m_arr[i]), parts, rows_ns[i])
            edf_fit[i] = e if (e > 0 and math.isfinite(e)) else math.nan
    uniq = list(dict.fromkeys(methods))
    ci_method = uniq[0] if len(uniq) == 1 else "; ".join(uniq)
    if kind in ("akdev", "hkdev"):
        ci_method = "OADEV/OHDEV Greenhall-Riley EDF minus 1 (approximation), chi-square"
        if _edf.CI_SIMPLE in uniq:
            ci_method += "; " + _edf.CI_SIMPLE
    if len(uniq) > 1 and _edf.CI_SIMPLE in uniq:
        notes.append("SP1065 Table 5 simple EDF used where the primary EDF method has no entry")
    if series.input_kind != "rate":
        notes.append(f"{series.input_kind} input: σ in angle unit per second")
    return DeviationResult(
        kind=kind,
        input_kind=input_kind,
        tau0=series.tau0,
        m=m_arr,
        tau=tau,
        n=np.array(rows_n, dtype=np.int64),
        alpha=a_arr,
        edf=edfs,
        sigma=sigma,
        sigma_lo=lo,
        sigma_hi=hi,
        confidence=float(confidence),
        ci_method=ci_method,
        unit=out_unit,
        notes=notes,
        alpha_method=a_methods,
        n_samples=series.n_data,
        segments=list(series.segments),
        alpha_fit=alpha_fit,
        alpha_fit_method=alpha_fit_method,
        edf_fit=edf_fit,
    )


def _compute_extra(data, tau0, *, kind, **kw) -> DeviationResult:
    """Thêo1, ThêoH, TTOTDEV, HTOTDEV (:mod:`gyrotest.noise.theo`) and the gap-tolerant
    OADEV (:mod:`gyrotest.noise.gapdev`), imported lazily (they build on this module)."""
    if kind == "gapadev":
        from .gapdev import compute_gap_oadev

        kw.pop("bias_correction", None)
        return compute_gap_oadev(data, tau0, **kw)
    from .theo import compute_theo_deviation

    return compute_theo_deviation(data, tau0, kind=kind, **kw)


# ---------------------------------------------------------------------------------------------
# One function per statistic
# ---------------------------------------------------------------------------------------------

_COMMON_DOC = """
    Parameters are those of :func:`compute_deviation` (``data``, ``tau0`` in s, keyword-only
    ``input_kind`` — required —, ``taus``, ``confidence``, ``stop_ratio``, ``segments``,
    ``unit``, ``noise_id``, ``alpha``; ``bias_correction`` for totdev/mtotdev). Returns a
    :class:`DeviationResult` with α, EDF and the χ² interval filled in.
"""


def _make(kind: str, doc: str) -> Callable[..., DeviationResult]:
    def f(
        data,
        tau0: float,
        *,
        input_kind: str,
        taus: str | Sequence[float] = "decade10",
        confidence: float = _edf.DEFAULT_CONFIDENCE,
        stop_ratio: float | None = None,
        segments: Sequence[tuple[int, int]] | None = None,
        unit: str = "deg/h",
        noise_id: bool = True,
        alpha: int | Sequence[int] | None = None,
        **kwargs,
    ) -> DeviationResult:
        return compute_deviation(
            data, tau0, input_kind=input_kind, kind=kind, taus=taus, confidence=confidence,
            stop_ratio=stop_ratio, segments=segments, unit=unit, noise_id=noise_id, alpha=alpha,
            **kwargs,
        )

    f.__name__ = kind
    f.__qualname__ = kind
    f.__doc__ = doc + _COMMON_DOC
    return f


oadev = _make(
    "oadev",
    """Overlapping Allan deviation (the default; IEEE 952 Annex C; NIST SP1065 eq. 11).

    σ²(τ) = 1/(2τ²(N−2m)) · Σ_{k=0}^{N−2m−1} (θ_{k+2m} − 2θ_{k+m} + θ_k)², τ = m·τ0, θ the
    angle series of N points. Rate unit. EDF: Greenhall & Riley (2004), d = 2, overlapping.
    Stop ratio 4.""",
)
adev = _make(
    "adev",
    """Non-overlapping Allan deviation (NIST SP1065 eq. 7; IEEE 952 eq. C.1 with disjoint
    clusters).

    σ²(τ) = 1/(2τ²n) · Σ_k (θ_{(k+2)m} − 2θ_{(k+1)m} + θ_{km})², n = ⌊(N−1)/m⌋ − 1. Rate unit.
    EDF: Greenhall & Riley (2004), d = 2, non-overlapping. Stop ratio 5.""",
)
mdev = _make(
    "mdev",
    """Modified Allan deviation (NIST SP1065 eq. 14).

    Mod σ²(τ) = 1/(2m²τ²(N−3m+1)) · Σ_{j=0}^{N−3m} [Σ_{i=j}^{j+m−1} (θ_{i+2m} − 2θ_{i+m} + θ_i)]²,
    computed in O(N) per τ as a running sum of third differences. Separates white from flicker
    angle noise. Rate unit. EDF: Greenhall & Riley, d = 2, modified. Stop ratio 4.""",
)
tdev = _make(
    "tdev",
    """Time deviation (NIST SP1065 eq. 15): σ_x(τ) = τ/√3 · Mod σ(τ).

    The angle-domain counterpart of MDEV: unit = (rate unit)·s, i.e. an angle (deg/h·s =
    arcsec for deg/h input). EDF: that of MDEV. Stop ratio 4.""",
)
hdev = _make(
    "hdev",
    """Non-overlapping Hadamard deviation (NIST SP1065 eq. 18).

    σ²_H(τ) = 1/(6τ²n) · Σ_k (θ_{(k+3)m} − 3θ_{(k+2)m} + 3θ_{(k+1)m} − θ_{km})²,
    n = ⌊(N−1)/m⌋ − 2. Insensitive to a rate ramp (drift) and convergent for α down to −4.
    Rate unit. EDF: Greenhall & Riley, d = 3, non-overlapping. Stop ratio 5.""",
)
ohdev = _make(
    "ohdev",
    """Overlapping Hadamard deviation (NIST SP1065 eq. 20).

    σ²_H(τ) = 1/(6τ²(N−3m)) · Σ_{k=0}^{N−3m−1} (θ_{k+3m} − 3θ_{k+2m} + 3θ_{k+m} − θ_k)².
    Zero for a rate ramp Ω = Rt. Rate unit. EDF: Greenhall & Riley, d = 3, overlapping.
    Stop ratio 4.""",
)
totdev = _make(
    "totdev",
    """Total deviation (NIST SP1065 eq. 25; Howe & Greenhall 1997; Stable32 TOTDEV).

    The angle series is extended at both ends by odd reflection, θ*_{−j} = 2θ_0 − θ_j and
    θ*_{N−1+j} = 2θ_{N−1} − θ_{N−1−j} (j = 1 … N−2), and
    Tot σ²(τ) = 1/(2τ²(N−2)) · Σ_{i=1}^{N−2} (θ*_{i−m} − 2θ_i + θ*_{i+m})²
    (the phase-domain definition of SP1065; no bias correction). Better confidence than OADEV
    at long τ. Rate unit. EDF: SP1065 Table 7 (α = 0, −1, −2), else Table 5. Stop ratio 2.""",
)
mtotdev = _make(
    "mtotdev",
    """Modified total deviation (NIST SP1065 eq. 27; Howe & Vernotte 1999; Stable32 MTOTDEV
    without bias correction).

    For each of the N−3m+1 subsequences of 3m angle points: remove the frequency offset
    (slope = difference of the means of the first and last ⌊3m/2⌋ points divided by their
    distance), extend to 9m points by even reflection at both ends, and take the MVAR sum over
    its 6m second differences of m-point averages; average over subsequences and divide by
    2τ². Computed exactly in O(N) per τ (see ``_mtot_sum``). Rate unit. EDF: SP1065 Table 8.
    Stop ratio 2 (and 3m ≤ N).""",
)
akdev = _make(
    "akdev",
    """Allan–Krobka dispersion (Krobka eq. 5.10; notes-allan-topology §2.4).

    σ²_AK(τ) = ½⟨(ω̄_{k+m} − ω̄_k)²⟩ − ½⟨ω̄_{k+m} − ω̄_k⟩², with the overlapping cluster
    averages ω̄_k = (θ_{k+m} − θ_k)/τ, i.e. half the *variance* (not the mean square) of the
    first differences of cluster averages: OAVAR minus the squared mean difference, so a rate
    ramp Ω = Rt (OADEV = Rτ/√2) gives exactly 0 and a deterministic trend no longer masquerades
    as rate random walk. For zero-mean stationary noise it equals OADEV in expectation. Rate
    unit. EDF: OADEV's Greenhall EDF minus 1. Stop ratio 4.""",
)
hkdev = _make(
    "hkdev",
    """Hadamard–Krobka dispersion (Krobka §5: the Hadamard analogue of eq. 5.10).

    σ²_HK(τ) = (⟨h²⟩ − ⟨h⟩²)/(6τ²) with h_k = θ_{k+3m} − 3θ_{k+2m} + 3θ_{k+m} − θ_k: the
    overlapping Hadamard variance with the mean third difference removed, so a quadratic rate
    trend Ω = Ct² gives zero. Rate unit. EDF: OHDEV's Greenhall EDF minus 1. Stop ratio 4.""",
)


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
