"""The integrated angle series θ every Allan-family deviation is computed from.

A record of rate samples Ω_k, per-sample angle increments ΔΘ_k or cumulative angles Θ_k becomes,
per gap-free segment, the angle series θ with a leading 0: θ = [0, cumsum(Ω − Ω̄)·τ0] (rate),
[0, cumsum(ΔΘ − mean ΔΘ)] (increment), or Θ minus the straight line through its first and last
points (angle); see :mod:`gyrotest.noise.deviations` for why the mean rate is removed.
:class:`AngleSeries` is the foundation both of the deviations (:mod:`gyrotest.noise`) and of a
long log streamed straight into θ (:mod:`gyrotest.io.stream`), so it lives below both."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from .errors import AnalysisError, InputError

INPUT_KINDS = ("rate", "increment", "angle")


#: Elements per chunk of the streaming kernels (64 Ki float64 = 512 KiB buffer; with the three
#: input streams it stays in L2; tuned on the reference VM, see benchmarks/README.md).
CHUNK = 1 << 16


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
