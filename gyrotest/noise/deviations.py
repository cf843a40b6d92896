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

import numpy as np

from .. import _runtime
from ..core.angle import INPUT_KINDS, AngleSeries, _check_kind, angle_series
from ..core.errors import AnalysisError, InputError
from . import edf as _edf
from . import kinds as _kinds
from . import mtot as _mtot
from .devcore import (
    DeviationResult,
    _bias_factor,
    _d2_total,
    _n_terms,
    _pooled_edf,
    _raw_variance,
    assign_alpha,
)
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

DEVIATION_KINDS = _kinds.DEVIATION_KINDS
_EXTRA_KINDS = ("theo1", "theoh", "ttotdev", "htotdev", "gapadev")


# The result type, the streaming kernels and the pooled raw variances: :mod:`.devcore`.


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


#: below this many samples the τ loop runs in one thread (thread start-up would dominate)
PARALLEL_MIN_SAMPLES = 200_000


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
    hook = _runtime.PROGRESS
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


