"""Gap-tolerant overlapping Allan deviation (records with NaN-marked missing samples).

Missing samples are NaN in a uniformly sampled record (the time grid is kept; a logger dropout
of 3 samples is 3 NaN). Every Allan difference whose inputs are all present is used; the
others are skipped; n per τ counts the differences used (Sesia & Tavella, "Estimating the
Allan variance in the presence of long periods of missing data and outliers", Metrologia 45
(2008) S134; the "gap resistant" ADEV of AllanTools for angle data):

* ``"angle"`` input θ_k: d_k = θ_{k+2m} − 2θ_{k+m} + θ_k is used when its three angles are
  present — a difference may straddle a gap (missing angle points do not break the angle
  count), σ² = Σ d_k² / (2τ²n).
* ``"rate"``/``"increment"`` input: a cluster average needs all m samples (one missing rate
  sample leaves the angle after it unknown), so a difference is used when the 2m samples
  k … k+2m−1 are all present; σ² = Σ (Ω̄_{k+m} − Ω̄_k)² / (2n). This equals the OADEV pooled
  over the gap-free runs of :mod:`gyrotest.noise.deviations` (checked in the tests).

Cost O(N) per τ (prefix sums of the zero-filled data and of the presence mask).
EDF: Greenhall–Riley OADEV EDF pooled over the gap-free runs (rate input: exact pooling of
independent runs; angle input: the same pooling, which ignores the differences that straddle a
gap and so errs on the safe side). Noise type: identified on the runs.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..core import angle as _angle
from ..core.errors import AnalysisError, InputError
from . import devcore as _dv
from . import edf as _edf
from .taus import tau_grid

__all__ = ["compute_gap_oadev", "finite_runs", "gap_oadev_sums"]


def finite_runs(arr: np.ndarray) -> list[tuple[int, int]]:
    """(start, stop) of the runs of finite values."""
    ok = np.isfinite(arr).astype(np.int8)
    edges = np.diff(np.concatenate(([0], ok, [0])))
    starts = np.flatnonzero(edges == 1)
    stops = np.flatnonzero(edges == -1)
    return [(int(a), int(b)) for a, b in zip(starts, stops)]


def gap_oadev_sums(x: np.ndarray, m: int, input_kind: str) -> tuple[float, int]:
    """(Σ d², n) of the module docstring for one part (NaN = missing). For rate/increment
    input d is the difference of m-sample *sums* (divide by m²·2n for σ² in the data unit);
    for angle input the second difference of θ (divide by 2τ²n)."""
    ok = np.isfinite(x)
    if input_kind == "angle":
        n = x.size - 2 * m
        if n <= 0:
            return 0.0, 0
        d = x[2 * m :] - 2.0 * x[m:-m] + x[: x.size - 2 * m]
        good = np.isfinite(d)
        d = d[good]
        return float(np.dot(d, d)), int(good.sum())
    z = np.where(ok, x, 0.0)
    C = np.concatenate(([0.0], np.cumsum(z)))
    K = np.concatenate(([0], np.cumsum(ok, dtype=np.int64)))
    n = x.size - 2 * m + 1
    if n <= 0:
        return 0.0, 0
    complete = (K[2 * m :] - K[: n]) == 2 * m
    d = C[2 * m :] - 2.0 * C[m : m + n] + C[:n]
    d = d[complete]
    return float(np.dot(d, d)), int(complete.sum())


def compute_gap_oadev(
    data,
    tau0: float,
    *,
    input_kind: str,
    taus="decade10",
    confidence: float = _edf.DEFAULT_CONFIDENCE,
    stop_ratio: float | None = None,
    segments: Sequence[tuple[int, int]] | None = None,
    unit: str = "deg/h",
    noise_id: bool = True,
    alpha=None,
) -> _dv.DeviationResult:
    """Gap-tolerant OADEV (``kind="gapadev"``) of a record whose missing samples are NaN.

    Parameters and result as :func:`gyrotest.noise.deviations.compute_deviation`; ``data``
    may contain NaN (inf is an error). ``segments`` (optional) are analysed separately and
    pooled, as if the gaps between them were longer than any τ. Raises :class:`InputError`
    for inf, an all-missing record or bad settings.
    """
    _angle._check_kind(input_kind)
    if not 0.0 < confidence < 1.0:
        raise InputError(f"confidence must be between 0 and 1 (e.g. 0.683), got {confidence!r}")
    arr = _angle._as_float_array(data)
    if arr.size == 0:
        raise InputError("empty record: no samples to analyse")
    if np.isinf(arr).any():
        i = int(np.flatnonzero(np.isinf(arr))[0])
        raise InputError(f"{input_kind} sample {i} is {arr[i]}: mark missing samples as NaN, "
                         "not inf")
    segs = _angle._normalise_segments(segments, arr.size)
    runs = [(a + r0, a + r1) for a, b in segs for r0, r1 in finite_runs(arr[a:b])]
    if not runs:
        raise InputError("every sample is missing (NaN): nothing to analyse")
    n_missing = int(sum(b - a for a, b in segs) - sum(b - a for a, b in runs))
    # the runs give the angle series used for noise identification and the EDF
    series = _angle.angle_series(arr, tau0, input_kind=input_kind, segments=runs)
    parts_runs = series.parts()
    # centre the data (the statistic is invariant to a constant rate / a straight angle line)
    work = []
    for a, b in segs:
        x = arr[a:b].astype(np.float64, copy=True)
        ok = np.isfinite(x)
        if input_kind == "angle":
            idx = np.flatnonzero(ok)
            if idx.size >= 2:
                i0, i1 = idx[0], idx[-1]
                slope = (x[i1] - x[i0]) / (i1 - i0)
                x -= x[i0] + slope * (np.arange(x.size) - i0)
        elif ok.any():
            x -= np.mean(x[ok])
        work.append(x)
    span = max(b - a for a, b in segs)
    grid = tau_grid(taus, n_data=span, tau0=series.tau0, kind="gapadev", stop_ratio=stop_ratio)
    notes = list(grid.notes)
    if n_missing:
        notes.append(f"gap-tolerant estimate: {n_missing} missing sample(s) in {len(runs)} "
                     "present run(s); only Allan differences with all their samples present "
                     "are used (n per τ counts them)")
    rows = []
    dropped = []
    for m in (int(v) for v in grid.m):
        ss, n = 0.0, 0
        for x in work:
            s1, n1 = gap_oadev_sums(x, m, input_kind)
            ss += s1
            n += n1
        if n < 1:
            dropped.append(m)
            continue
        tau = m * series.tau0
        if input_kind == "angle":
            var = ss / (2.0 * tau * tau * n)
        else:
            var = ss / (2.0 * m * m * n)
            if input_kind == "increment":
                var /= series.tau0**2
        rows.append((m, n, math.sqrt(var)))
    if dropped and grid.spec == "explicit":
        raise InputError(
            f"no complete Allan difference at τ = {', '.join(f'{mm * series.tau0:g}' for mm in dropped)} s "
            "(every window of 2m samples contains a gap); use a shorter τ")
    if dropped:
        notes.append(f"τ = {', '.join(f'{mm * series.tau0:g}' for mm in dropped)} s dropped: no "
                     "Allan difference without missing samples")
    if not rows:
        raise AnalysisError("no τ with a complete Allan difference: the gaps leave no run of "
                            "2m + 1 consecutive samples; record longer gap-free stretches")
    m_arr = np.array([r[0] for r in rows], dtype=np.int64)
    sigma = np.array([r[2] for r in rows])
    # noise type and EDF from the gap-free runs (the OADEV machinery)
    if alpha is not None:
        a_arr = np.broadcast_to(np.asarray(alpha, dtype=np.int64), m_arr.shape).copy()
        a_methods = ["forced"] * len(m_arr)
    elif noise_id:
        nids = _edf.identify_noise(parts_runs, m_arr,
                                   data_type="phase" if input_kind == "angle" else "frequency")
        a_arr = np.array([v.alpha for v in nids], dtype=np.int64)
        a_methods = [v.method for v in nids]
    else:
        a_arr = np.zeros(len(m_arr), dtype=np.int64)
        a_methods = ["assumed"] * len(m_arr)
        notes.append("noise identification off: α = 0 (white rate noise) assumed for the EDF")
    edfs = np.empty(len(m_arr))
    labels = []
    for i, (m, a) in enumerate(zip(m_arr, a_arr)):
        ns = [_dv._n_terms("oadev", p.size, int(m)) for p in parts_runs]
        if sum(ns) < 1:
            edfs[i] = math.nan
            continue
        e, lab = _dv._pooled_edf("oadev", int(a), int(m), parts_runs, ns)
        edfs[i] = e if (e > 0 and math.isfinite(e)) else math.nan
        labels.append(lab)
    lo, hi = _edf.chi2_interval(sigma, edfs, confidence)
    ci = "; ".join(dict.fromkeys(labels)) or _edf.CI_GREENHALL
    if input_kind != "rate":
        notes.append(f"{input_kind} input: σ in angle unit per second")
    return _dv.DeviationResult(
        kind="gapadev", input_kind=input_kind, tau0=series.tau0, m=m_arr, tau=m_arr * series.tau0,
        n=np.array([r[1] for r in rows], dtype=np.int64), alpha=a_arr, edf=edfs, sigma=sigma,
        sigma_lo=lo, sigma_hi=hi, confidence=float(confidence),
        ci_method=ci + " (pooled over the gap-free runs)", unit=unit, notes=notes,
        alpha_method=a_methods, n_samples=int(sum(b - a for a, b in runs)),
        segments=list(runs))
