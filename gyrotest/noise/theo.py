"""Thêo1, ThêoH, TTOTDEV and HTOTDEV: the long-τ deviations of Stable32 (pure numpy).

Statistics (N angle points θ, τ0 the sample interval; input kinds and units as in
:mod:`gyrotest.noise.deviations`):

========= ===================================================================================
theo1     Thêo1 (Howe & Tasset, "Theo1: characterization of very long-term frequency
          stability", Proc. 18th EFTF 2004; NIST SP1065 eq. 30), at even m, 10 ≤ m ≤ N − 1,
          τ = 0.75·m·τ0:
          σ² = Σ_{i=0}^{N−m−1} Σ_{δ=0}^{m/2−1} [(θ_i − θ_{i−δ+m/2}) + (θ_{i+m} − θ_{i+δ+m/2})]²
               / ((m/2 − δ)·0.75·(N − m)·(mτ0)²).
          Reaches τ = 0.75·T (OADEV: T/2 at best, T/4 by Stable32's stop ratio) with more
          degrees of freedom at long τ. No bias correction (Stable32's α = 0 setting; Thêo1
          equals the Allan variance in expectation for white rate noise). Stable32's "#" is
          (N − m)·m/2. Computed exactly in O(N + m log² m) per τ
          (:mod:`gyrotest.noise.theo_kernels`).
theoh     ThêoH (Howe, "ThêoH: a hybrid, high-confidence statistic that improves on the Allan
          deviation", Metrologia 43 (2006) S322; Howe, Taylor & Tasset, "ThêoH bias-removal
          method", Proc. 2006 IEEE IFCS): the overlapping Allan deviation for τ < k = 0.1·T and
          ThêoBR for τ ≥ k, with the bias-removed Thêo1
          ThêoBR(m) = Thêo1(m) · 1/(n+1) Σ_{i=0}^{n} AVAR(9+3i)/Thêo1(12+4i),
          n = ⌊0.1·N/3 − 3⌋ (the AVAR/Thêo1 ratio averaged over τ = 9τ0 … 0.1·T, where both
          are computed at the same τ). Data-driven: no noise-type table is needed, so
          long-τ K and R from a record of a few hours are unbiased relative to the Allan
          variance whatever the noise mix.
ttotdev   Time total deviation (NIST SP1065 eq. 28): σ_x = τ/√3 · MTOTDEV (angle unit, like
          TDEV). The MTOTDEV kernel of :mod:`~gyrotest.noise.deviations` (O(N) per τ).
htotdev   Hadamard total deviation (NIST SP1065 eq. 29; Howe et al., "Total Hadamard
          variance: application to clock steering by Kalman filtering", Proc. 2001 EFTF): for
          each of the N_y − 3m + 1 subsequences of 3m rate samples remove the half-average
          slope, extend to 9m points by even (uninverted) reflection and average the 6m
          squared second differences of m-sample means; σ² = that average / 6 over the
          subsequences. At m = 1 the overlapping Hadamard deviation, as Stable32 does. No bias
          correction unless ``bias_correction=True`` (Riley's factors 0.995, 0.851, 0.771,
          0.717, 0.679 for α = 0 … −4).
========= ===================================================================================

Gaps: as in :mod:`gyrotest.noise.deviations` (sums and term counts pooled over gap-free
segments; the τ grid is built on the longest segment).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..core import angle as _angle
from ..core.errors import AnalysisError, InputError
from . import devcore as _dv
from . import edf as _edf
from .taus import STOP_RATIOS, m_from_taus, tau_grid
from .theo_kernels import Theo1Engine, theo1_terms

__all__ = [
    "HTOT_BIAS",
    "THEO_KINDS",
    "compute_theo_deviation",
    "edf_htotdev",
    "edf_theo1",
    "theo1_m_grid",
]

THEO_KINDS = ("theo1", "theoh", "ttotdev", "htotdev")
LONG_NAMES = {
    "theo1": "Thêo1 deviation",
    "theoh": "ThêoH deviation (Allan deviation, then bias-removed Thêo1)",
    "ttotdev": "time total deviation",
    "htotdev": "Hadamard total deviation",
}
MIN_POINTS_TEXT = {
    "theo1": "m + 1 angle points at an even m ≥ 10 (τ = 0.75·m·τ0)",
    "theoh": "2m + 1 angle points (Allan part) or m + 1 (ThêoBR part)",
    "ttotdev": "3m angle points",
    "htotdev": "3m rate samples",
}
#: Thêo1 needs an even m of at least 10 (NIST SP1065 §5.2.14)
THEO1_MIN_M = 10
#: ThêoH switches from the Allan variance to ThêoBR at τ = THEOH_SPLIT·T
THEOH_SPLIT = 0.1
#: at most this many AVAR/Thêo1 ratios (evenly spaced in i) are averaged for the ThêoBR bias
THEOBR_MAX_RATIOS = 32
#: HTOTDEV variance bias E[Htot var]/Hadamard var (Riley, "Confidence intervals and bias
#: corrections for the Stable32 variance functions", Hamilton Technical Services); α ≥ 1: 1.
HTOT_BIAS = {0: 0.995, -1: 0.851, -2: 0.771, -3: 0.717, -4: 0.679}

CI_THEO1 = "NIST SP1065 Thêo1 EDF (Howe & Tasset), chi-square"
CI_HTOT = "OHDEV Greenhall-Riley EDF (lower bound for HTOTDEV), chi-square"


# ---------------------------------------------------------------------------------------------
# EDF
# ---------------------------------------------------------------------------------------------


def edf_theo1(alpha: int, m: int, n_phase: int) -> float:
    """Thêo1 EDF (NIST SP1065 §5.2.14, from Howe & Tasset 2004), r = 0.75·m, N angle points:

    α=2:  0.86(N+1)(N − 4r/3)/(N − r) · r/(r + 1.14)
    α=1:  (4.798N² − 6.374Nr + 12.387r)/(√(r + 36.6)(N − r)(r + 0.3)) · r/(r + 0.3)
    α=0:  [(4.1N + 0.8)/r − (3.1N + 6.5)/N] · r^1.5/(r^1.5 + 5.2)
    α=−1: (2N² − 1.3Nr − 3.5r)/(N r) · r³/(r³ + 2.3)
    α=−2: (4.4N − 2)/(2.9r) · [(4.4N − 1)² − 8.6r(4.4N − 1) + 11.4r²]/(4.4N − 3)²

    The tests check each against a Monte Carlo simulation of the power-law noise."""
    N = float(n_phase)
    r = 0.75 * float(m)
    a = int(alpha)
    if a >= 2:
        return 0.86 * (N + 1) * (N - 4.0 * r / 3.0) / (N - r) * r / (r + 1.14)
    if a == 1:
        return ((4.798 * N * N - 6.374 * N * r + 12.387 * r)
                / (math.sqrt(r + 36.6) * (N - r) * (r + 0.3)) * r / (r + 0.3))
    if a == 0:
        return ((4.1 * N + 0.8) / r - (3.1 * N + 6.5) / N) * r**1.5 / (r**1.5 + 5.2)
    if a == -1:
        return (2 * N * N - 1.3 * N * r - 3.5 * r) / (N * r) * r**3 / (r**3 + 2.3)
    n4 = 4.4 * N
    return (n4 - 2) / (2.9 * r) * ((n4 - 1) ** 2 - 8.6 * r * (n4 - 1) + 11.4 * r * r) / (n4 - 3) ** 2


def edf_htotdev(alpha: int, m: int, n_phase: int) -> float:
    """EDF used for HTOTDEV: the Greenhall–Riley EDF of the overlapping Hadamard deviation at
    the same m. HTOTDEV has at least as many degrees of freedom (that is its purpose), so the
    interval is conservative; SP1065 gives no closed form for HTOTDEV."""
    try:
        return _edf.edf_greenhall(alpha, 3, m, n_phase, overlapping=True, modified=False)
    except AnalysisError:
        return _edf.edf_simple(n_phase, m, alpha)


# ---------------------------------------------------------------------------------------------
# τ grids
# ---------------------------------------------------------------------------------------------


def _even(v: np.ndarray) -> np.ndarray:
    return (2 * np.rint(np.asarray(v, float) / 2.0)).astype(np.int64)


def theo1_m_grid(spec, *, n_phase: int, tau0: float, stop_ratio: float | None = None,
                 m_min: int = THEO1_MIN_M) -> tuple[np.ndarray, list[str]]:
    """Averaging factors of Thêo1 (even, m_min ≤ m ≤ N − 1) and notes.

    Generated grids place their factors on the Thêo1 τ = 0.75·m·τ0 axis: the grid's τ values
    (``tau_grid`` with stop ratio 1 by default: τ up to 0.75·T) become m = even(τ/(0.75τ0)).
    "all" is every even m. Explicit τ lists are rounded to the nearest even m (noted)."""
    notes: list[str] = []
    m_top = n_phase - 1 if (n_phase - 1) % 2 == 0 else n_phase - 2
    if stop_ratio is not None:
        m_top = min(m_top, int(2 * math.floor((n_phase - 1) / stop_ratio / 2)))
    if isinstance(spec, str):
        key = spec.strip().lower()
        if key == "all":
            m = np.arange(m_min, m_top + 1, 2, dtype=np.int64)
        else:
            g = tau_grid(key, n_data=int(0.75 * n_phase) + 1, tau0=1.0, kind="theo1", stop_ratio=1)
            m = np.unique(np.clip(_even(g.m / 0.75), m_min, m_top)) if m_top >= m_min else \
                np.zeros(0, np.int64)
        return m[(m >= m_min) & (m <= m_top)], notes
    arr = np.asarray(spec, dtype=float).ravel()
    m_lin, _ = m_from_taus(arr, tau0)  # validation of the list (finite, > 0)
    del m_lin
    m = _even(arr / (0.75 * tau0))
    low = m < m_min
    if low.any():
        notes.append(f"τ = {', '.join(f'{t:g}' for t in arr[low])} s below the shortest Thêo1 τ "
                     f"(0.75·{m_min}·τ0 = {0.75 * m_min * tau0:g} s): raised to it")
        m[low] = m_min
    moved = (np.abs(0.75 * m * tau0 - arr) > 1e-3 * arr) & ~low
    if moved.any():
        pairs = ", ".join(f"{t:g} s → {0.75 * mm * tau0:g} s" for t, mm in zip(arr[moved], m[moved]))
        notes.append(f"τ moved to the Thêo1 grid τ = 0.75·m·τ0 (m even): {pairs}")
    return np.unique(m), notes


# ---------------------------------------------------------------------------------------------
# Raw sums (pooled over segments)
# ---------------------------------------------------------------------------------------------


class _Theo1Pool:
    """Thêo1 variance (in θ units², before the 1/τ0² scaling) pooled over segments."""

    def __init__(self, parts: Sequence[np.ndarray]):
        self.engines = [Theo1Engine(p) for p in parts]
        self.sizes = [p.size for p in parts]
        self.max_rel_error = 0.0

    def var(self, m: int) -> tuple[float, int, list[int]]:
        S = 0.0
        den = 0.0
        ns = []
        for eng, L in zip(self.engines, self.sizes):
            if m % 2 or m < 2 or L - m < 1:
                ns.append(0)
                continue
            S += eng.sum(m)
            self.max_rel_error = max(self.max_rel_error, eng.last_rel_error)
            den += 0.75 * (L - m) * m * m
            ns.append(theo1_terms(L, m))
        n = int(sum(ns))
        return (S / den if n else math.nan), n, ns


def _avar_raw(parts, m: int) -> float:
    return _dv._raw_variance("oadev", parts, m)[0] / (m * m)


def _theobr_ratio(pool: _Theo1Pool, parts, n_longest: int, notes: list[str]) -> float:
    """ThêoBR's mean AVAR/Thêo1 ratio over i = 0 … n, n = ⌊0.1·N/3 − 3⌋ (AVAR at 9 + 3i,
    Thêo1 at 12 + 4i: the same τ). Long records: at most THEOBR_MAX_RATIOS evenly spaced i."""
    n = int(math.floor(0.1 * n_longest / 3.0 - 3.0))
    if n < 0:
        raise AnalysisError(
            f"record too short for ThêoH: {n_longest} angle points give no AVAR/Thêo1 ratio "
            "(ThêoBR needs at least 120 points); use theo1 or oadev")
    idx = np.arange(n + 1)
    if idx.size > THEOBR_MAX_RATIOS:
        idx = np.unique(np.rint(np.linspace(0, n, THEOBR_MAX_RATIOS)).astype(int))
        notes.append(f"ThêoBR bias: mean AVAR/Thêo1 ratio from {idx.size} of the {n + 1} τ "
                     "(evenly spaced between 9τ0 and 0.1·T) to bound the cost")
    ratios = []
    for i in idx:
        av = _avar_raw(parts, 9 + 3 * int(i))
        th, _, _ = pool.var(12 + 4 * int(i))
        ratios.append(av / th)
    return float(np.mean(ratios))


# ---------------------------------------------------------------------------------------------
# The dispatcher
# ---------------------------------------------------------------------------------------------


def compute_theo_deviation(
    data,
    tau0: float,
    *,
    input_kind: str,
    kind: str,
    taus="decade10",
    confidence: float = _edf.DEFAULT_CONFIDENCE,
    stop_ratio: float | None = None,
    segments=None,
    unit: str = "deg/h",
    noise_id: bool = True,
    alpha=None,
    bias_correction: bool = False,
) -> _dv.DeviationResult:
    """Thêo1, ThêoH, TTOTDEV or HTOTDEV with noise identification, EDF and χ² interval.

    Parameters and result as :func:`gyrotest.noise.deviations.compute_deviation` (which calls
    this for these kinds). Thêo1/ThêoBR τ are 0.75·m·τ0 with even m. ``bias_correction``:
    TTOTDEV (MTOTDEV's B(α)) and HTOTDEV (:data:`HTOT_BIAS`) only; ThêoH is bias-removed by
    construction and Thêo1 is reported raw (Stable32's α = 0 setting).
    """
    if kind not in THEO_KINDS:
        raise InputError(f"unknown deviation {kind!r}; choose one of {', '.join(THEO_KINDS)}")
    if not 0.0 < confidence < 1.0:
        raise InputError(f"confidence must be between 0 and 1 (e.g. 0.683), got {confidence!r}")
    if bias_correction and kind not in ("ttotdev", "htotdev"):
        raise InputError(f"bias correction is defined for totdev, mtotdev, ttotdev and htotdev, "
                         f"not {kind}")
    series = _angle.angle_series(data, tau0, input_kind=input_kind, segments=segments)
    parts = series.parts()
    t0 = series.tau0
    longest = max(p.size for p in parts)
    notes = list(series.notes)
    explicit = not isinstance(taus, str)

    # --- grid and raw variances (θ units², ×scale²/τ0² later; tau = τ in s) -----------------
    rows: list[tuple[int, float, float, int, list[int], str]] = []  # m, tau, var, n, ns, part
    dropped: list[float] = []
    if kind in ("ttotdev", "htotdev"):
        n_grid = series.n_longest
        grid = tau_grid(taus, n_data=n_grid, tau0=t0, kind=kind, stop_ratio=stop_ratio)
        notes += list(grid.notes)
        for m in (int(v) for v in grid.m):
            if kind == "ttotdev":
                var, n, ns = _dv._raw_variance("mtotdev", parts, m)
                part = "mtotdev"
            else:
                var, n, ns = _htot_raw(parts, m, series.scale, t0)
                part = "ohdev" if m == 1 else "htotdev"
            if n < 1:
                dropped.append(m * t0)
                continue
            rows.append((m, m * t0, var, n, ns, part))
    else:
        pool = _Theo1Pool(parts)
        if kind == "theo1":
            ms, g_notes = theo1_m_grid(taus, n_phase=longest, tau0=t0, stop_ratio=stop_ratio)
            notes += g_notes
            for m in (int(v) for v in ms):
                var, n, ns = pool.var(m)
                if n < 1:
                    dropped.append(0.75 * m * t0)
                    continue
                rows.append((m, 0.75 * m * t0, var, n, ns, "theo1"))
        else:  # theoh
            T = (longest - 1) * t0
            k_tau = THEOH_SPLIT * T
            if explicit:
                arr = np.asarray(taus, dtype=float).ravel()
                m_from_taus(arr, t0)  # validation
                short = arr[arr < k_tau]
                long_ = arr[arr >= k_tau]
                ma = m_from_taus(short, t0)[0] if short.size else np.zeros(0, np.int64)
                mb, g_notes = (theo1_m_grid(long_, n_phase=longest, tau0=t0) if long_.size
                               else (np.zeros(0, np.int64), []))
                notes += g_notes
            else:
                ga = tau_grid(taus, n_data=series.n_longest, tau0=t0, kind="oadev",
                              stop_ratio=1.0 / THEOH_SPLIT)
                ma = ga.m[ga.m * t0 < k_tau]
                mb, _ = theo1_m_grid(taus, n_phase=longest, tau0=t0, stop_ratio=stop_ratio)
                mb = mb[0.75 * mb * t0 >= k_tau]
            for m in (int(v) for v in ma):
                var, n, ns = _dv._raw_variance("oadev", parts, m)
                if n < 1:
                    dropped.append(m * t0)
                    continue
                rows.append((m, m * t0, var, n, ns, "oadev"))
            if mb.size:
                ratio = _theobr_ratio(pool, parts, longest, notes)
                for m in (int(v) for v in mb):
                    var, n, ns = pool.var(m)
                    if n < 1:
                        dropped.append(0.75 * m * t0)
                        continue
                    rows.append((m, 0.75 * m * t0, var * ratio, n, ns, "theobr"))
                notes.append(f"ThêoH: overlapping Allan deviation for τ < {k_tau:g} s (0.1·T), "
                             f"ThêoBR (Thêo1 × mean AVAR/Thêo1 ratio {ratio:.4g}) beyond")
        if pool.max_rel_error > 0:
            notes.append(f"Thêo1 sums carry an estimated relative rounding error up to "
                         f"{pool.max_rel_error:.1g} (expanded form on a long record)")
    if dropped and explicit:
        raise InputError(
            f"record too short for τ = {', '.join(f'{t:g}' for t in dropped)} s: the longest "
            f"segment has {longest} angle points and {kind} needs {MIN_POINTS_TEXT[kind]}; "
            "drop the longer τ from --taus")
    if dropped:
        notes.append(f"τ = {', '.join(f'{t:g}' for t in dropped)} s dropped: fewer than one "
                     f"{kind} term ({MIN_POINTS_TEXT[kind]} needed)")
    if not rows:
        ratio_txt = STOP_RATIOS.get(kind, 1) if stop_ratio is None else stop_ratio
        raise AnalysisError(
            f"record too short for {kind}: {series.n_longest} samples in the longest segment give "
            f"no τ (stop ratio {ratio_txt:g}; {kind} needs {MIN_POINTS_TEXT[kind]}); record a "
            "longer log or use a smaller stop ratio")
    rows.sort(key=lambda r: r[1])

    m_arr = np.array([r[0] for r in rows], dtype=np.int64)
    tau = np.array([r[1] for r in rows])
    n_arr = np.array([r[3] for r in rows], dtype=np.int64)
    part_of = [r[5] for r in rows]
    raw = np.array([r[2] for r in rows])
    if kind == "htotdev":
        sigma = np.sqrt(raw)  # already in the rate unit
    elif kind in ("theo1", "theoh"):
        # theo1/theobr raw is Σ/(0.75(N−m)m²): ×scale²/τ0²; oadev raw ×scale²/τ²
        sig = np.empty(len(rows))
        for i, (_m, tt, var, _, _, part) in enumerate(rows):
            if part == "oadev":
                sig[i] = math.sqrt(var) * series.scale / tt
            else:
                sig[i] = math.sqrt(var) * series.scale / t0
        sigma = sig
    else:  # ttotdev: MTOTDEV·τ/√3
        sigma = np.sqrt(raw) * series.scale / tau * tau / math.sqrt(3.0)
    out_unit = f"({unit})·s" if kind == "ttotdev" else unit

    # --- noise identification (at the Allan-equivalent averaging factor τ/τ0) ---------------
    hadamard = kind == "htotdev"
    m_id = np.maximum(1, np.rint(tau / t0)).astype(np.int64)
    a_arr, a_methods = _dv.assign_alpha(parts, m_id, alpha=alpha, noise_id=noise_id,
                                        input_kind=input_kind, hadamard=hadamard, notes=notes)

    if bias_correction:
        if kind == "ttotdev":
            factor = np.array([_dv._MTOT_BIAS[int(a)] for a in a_arr])
            notes.append("bias correction applied: TTOTDEV / √B(α), B = 0.94, 0.83, 0.73, 0.70, "
                         "0.69 for α = 2 … −2 (Howe & Vernotte 1999)")
        else:
            factor = np.array([1.0 if (p == "ohdev" or a > 0) else HTOT_BIAS[int(a)]
                               for a, p in zip(a_arr, part_of)])
            notes.append("bias correction applied: HTOTDEV / √B(α), B = 0.995, 0.851, 0.771, "
                         "0.717, 0.679 for α = 0 … −4 (Riley)")
        sigma = sigma / np.sqrt(factor)

    # --- EDF and interval --------------------------------------------------------------------
    edfs = np.empty(len(m_arr))
    methods: list[str] = []
    for i, (m, a, r) in enumerate(zip(m_arr, a_arr, rows)):
        part, ns = r[5], r[4]
        if part in ("theo1", "theobr"):
            used = [p.size for p, nk in zip(parts, ns) if nk > 0]
            e = _pool_edf([(edf_theo1(int(a), int(m), L), nk) for L, nk in
                           zip(used, [nk for nk in ns if nk > 0])])
            lab = CI_THEO1
        elif part == "htotdev":
            used = [(p.size, nk) for p, nk in zip(parts, ns) if nk > 0]
            e = _pool_edf([(edf_htotdev(int(a), int(m), L), nk) for L, nk in used])
            lab = CI_HTOT
        else:
            ekind = {"mtotdev": "mtotdev", "ohdev": "ohdev", "oadev": "oadev"}[part]
            e, lab = _dv._pooled_edf(ekind, int(a), int(m), parts, ns)
        edfs[i] = e if (e > 0 and math.isfinite(e)) else math.nan
        methods.append(lab)
    lo, hi = _edf.chi2_interval(sigma, edfs, confidence)
    uniq_m = list(dict.fromkeys(methods))
    if series.input_kind != "rate":
        notes.append(f"{series.input_kind} input: σ in angle unit per second")
    return _dv.DeviationResult(
        kind=kind, input_kind=input_kind, tau0=t0, m=m_arr, tau=tau, n=n_arr, alpha=a_arr,
        edf=edfs, sigma=np.asarray(sigma, float), sigma_lo=lo, sigma_hi=hi,
        confidence=float(confidence), ci_method="; ".join(uniq_m), unit=out_unit, notes=notes,
        alpha_method=a_methods, n_samples=series.n_data, segments=list(series.segments))


def _pool_edf(items: list[tuple[float, int]]) -> float:
    """1/Σ w²/edf, w = n_s/Σn (one item: its EDF)."""
    if not items:
        return math.nan
    if len(items) == 1:
        return items[0][0]
    tot = float(sum(n for _, n in items))
    inv = 0.0
    for e, n in items:
        if not (e > 0 and math.isfinite(e)):
            return math.nan
        inv += (n / tot) ** 2 / e
    return 1.0 / inv


def _htot_raw(parts, m: int, scale: float, tau0: float) -> tuple[float, int, list[int]]:
    """HTOT variance in rate units² (pooled), term count and per-segment counts. m = 1: OHVAR."""
    if m == 1:
        var, n, ns = _dv._raw_variance("ohdev", parts, 1)
        return var * (scale / tau0) ** 2, n, ns
    ss = 0.0
    ns = []
    for p in parts:
        y = np.diff(p)  # rate samples × τ0/scale
        n_sub = y.size - 3 * m + 1
        if n_sub < 1:
            ns.append(0)
            continue
        ss += _dv._mtot_sum(y, m)[0]
        ns.append(n_sub)
    n = int(sum(ns))
    if n < 1:
        return math.nan, 0, ns
    return ss / (36.0 * m**3 * n) * (scale / tau0) ** 2, n, ns
