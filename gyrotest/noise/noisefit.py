"""Joint noise-model fit of an Allan variance: all terms at once, in quadrature, weighted by
the estimator's confidence.

Model (IEEE Std 952-1997 Annex C, Krobka (Allan-graph topology) eq. 5.9: independent noises add in
quadrature)::

    σ²_model(τ) = Σ_j c_j · g_j(τ; θ_j)

with the basis g_j and coefficient c_j of each term (internal units: deg/h, s):

=========  ===============================================  =====================  ==========
term       g(τ)                                             c                      reported
=========  ===============================================  =====================  ==========
Q          3/τ²                                             Q² (arcsec²)           Q arcsec
N          1/τ                                              N_int² ((deg/h)²·s)    N = √c/60 deg/√h
B          2 ln2/π (IEEE flat level; or the full template   B² ((deg/h)²)          B deg/h
           of eq. 5.3 with a given cut-off f0)
K          τ/3                                              K_int²                 K = 60√c deg/h/√h
R          τ²/2                                             R_int²                 R = 3600√c deg/h/h
markov     (1/τ)[1 − (T/2τ)(3 − 4e^(−τ/T) + e^(−2τ/T))]      (q_c·T_c)² = S(0)      q_c = 60√c/T deg/h/√h, T_c s
sine       (sin²(πf0τ)/(πf0τ))²                              Ω0² ((deg/h)²)         Ω0 deg/h, f0 Hz
blue       (3 − 4e^(−2πβτ) + e^(−4πβτ))/(4πβτ²)             α ((deg/h)²/Hz)        α, β Hz (S = αf²/(β²+f²))
=========  ===============================================  =====================  ==========

Estimation: **maximum likelihood of σ̂²(τ) given its χ² distribution**. Each Allan variance
estimate is modelled as σ̂² ~ σ²·χ²_ν/ν with ν the equivalent degrees of freedom from
:mod:`gyrotest.noise.edf` (Greenhall & Riley, noise type identified per τ; NIST SP1065 §5.3),
used through the log-normal approximation with the exact moments of ln(χ²_ν/ν): with
y = ln σ̂² − (ψ(ν/2) − ln(ν/2)) (unbiased for ln σ²) and v = ψ₁(ν/2) (≈ 2/ν), −2·log-likelihood is

    L = Σ_i (y_i − ln s_i)² / v_i,   s_i = σ²_model(τ_i)

(= Σ[(s − σ̂²)/δ]² to first order, δ = s·√(2/ν): the confidence-weighted form; symmetric in
ln(σ̂²/s), so it neither lets the model float above the data, as the raw χ² likelihood of a
misspecified model does, nor ignores the confidence of each point, as relative-error fits
do). L is minimised over c ≥ 0 by Gauss–Newton steps that are each a non-negative least
squares problem (scipy NNLS), and over the nonlinear shape parameters (T_c, f0, β) by a
log-grid search then bounded refinement of the profile objective. Not unweighted σ², not slope
lines (those are reported separately by :func:`slope_readoffs`, for comparison).

Uncertainty: the estimates at neighbouring τ come from the same record and are strongly
correlated (overlapping estimates at τ and 2τ: ρ ≈ 0.5 for white rate noise, ≈ 0.9 for rate
random walk), so the naive inverse Fisher information is far too optimistic. The covariance of
the fitted parameters is the **sandwich** A⁻¹ B A⁻¹ with A = JᵀWJ (W = diag ν/(2s²), J the
Jacobian of σ²_model in the coefficients and log shape parameters) and B = JᵀW C W J, where
C = diag(δ)·ρ·diag(δ) and ρ is the model-implied correlation of the Allan-variance estimates,
ρ_ij ∝ ∫ S(f)² K_i(f) K_j(f) df with K_τ(f) = sin⁴(πfτ)/(πfτ)² the Allan transfer function and S
the fitted model's PSD (large-sample covariance of quadratic estimators, e.g. Percival & Walden
1993 §8; the same idea as GMWM's wavelet-variance covariance). Likelihood-ratio statistics are
divided by each term's design effect (sandwich / naive variance: first-order Rao–Scott
correction), the χ² goodness of fit uses a Satterthwaite-scaled reference distribution, and
BIC uses n_eff = n²/Σρ_ij.

Identified vs upper bound (Krobka's rule: "a coefficient the graph cannot establish is an upper
bound", Krobka (Allan-graph topology) §6): terms are tested by likelihood ratio — the increase of L when a term is
dropped (the others re-fitted), divided by the term's design effect, against χ²_k(0.95) (k = 1
for Q, N, B, K, R; 2 for the two-parameter terms): its contribution must be significant
somewhere and its confidence interval must exclude 0. Non-significant terms are removed by
backward elimination (weakest first, while the reduced model stays consistent with the full
one), so collinear pairs such as K and R do not hide each other. Remaining significant terms
are *identified*; the others are *upper bounds*: the value printed after "≤" is the 95 %
one-sided profile-likelihood limit (L + 2.71 × design effect, every other coefficient
re-fitted); for a two-parameter term that was not found, the largest over its shape range.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import special

from ..core.errors import AnalysisError, InputError
from .fitmodel import (
    _LRT_P,
    DEFAULT_TERMS,
    KNOWN_TERMS,
    LINEAR_KEYS,
    MIN_EDF,
    MIN_EDF_IDENTIFY,
    NONLINEAR_KEYS,
    _basis,
    _model_psd,
    carry_edf,
    ci_residuals,
    estimate_correlation,
    fit_alpha,
    log_chi2_moments,
    log_chi2_objective,
    parse_terms,
    robust_edf,
    robust_edf_rules,
    sanitize_edf,
    table_quantity,
)
from .fitresult import _MAIN, FitTerm, NoiseFit, _derived, _reported
from .numerics import minimize_bounded, nelder_mead, nnls, root_bracketed  # no scipy.optimize
from .quantity import RATE, Quantity, quantity_of
from .readoffs import conversions, n_upper_bound, slope_readoffs

__all__ = [
    "DEFAULT_TERMS",
    "KNOWN_TERMS",
    "FitTerm",
    "NoiseFit",
    "ci_residuals",
    "conversions",
    "estimate_correlation",
    "fit_deviation",
    "fit_noise_model",
    "log_chi2_moments",
    "log_chi2_objective",
    "parse_terms",
    "fit_alpha",
    "robust_edf",
    "robust_edf_rules",
    "sanitize_edf",
    "slope_readoffs",
    "carry_edf",
    "MIN_EDF_IDENTIFY",
    "n_upper_bound",
]


# The model (basis functions, likelihood, correlation): :mod:`.fitmodel`; the result types:
# :mod:`.fitresult`; the classic read-offs and unit conversions: :mod:`.readoffs`.


# ---------------------------------------------------------------------------------------------
# The fitting engine
# ---------------------------------------------------------------------------------------------


@dataclass
class _Col:
    key: str
    label: str
    shape: float | None = None  # T_c (s), f0 (Hz) or beta (Hz)
    lo: float = 0.0  # shape search range
    hi: float = 0.0


class _Engine:
    """σ̂² data on the fit range and the Gauss–Newton NNLS solver of the log-χ² objective."""

    def __init__(self, tau, x, nu, bi_f0, q: Quantity = RATE):
        self.q = q
        self.tau = np.asarray(tau, float)
        self.x = np.asarray(x, float)
        self.nu = np.asarray(nu, float)
        self.bi_f0 = bi_f0
        self.floor = 1e-12 * self.x
        self.y, self.v = log_chi2_moments(self.x, self.nu)
        self.w = 1.0 / np.sqrt(self.v)
        self._lin: dict[str, np.ndarray] = {}

    def objective(self, s: np.ndarray) -> float:
        r = (self.y - np.log(s)) * self.w
        return float(np.dot(r, r))

    def column(self, c: _Col) -> np.ndarray:
        if c.key in LINEAR_KEYS:
            col = self._lin.get(c.key)
            if col is None:
                col = self._lin[c.key] = _basis(c.key, self.tau, None, self.bi_f0)
            return col
        return _basis(c.key, self.tau, c.shape, self.bi_f0)

    def design(self, cols: list[_Col]) -> np.ndarray:
        G = np.empty((self.tau.size, len(cols)))
        for j, c in enumerate(cols):
            G[:, j] = self.column(c)
        return G

    def solve(self, G: np.ndarray, offset: np.ndarray | None = None, max_iter: int = 60,
              s0: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, float]:
        """min over c ≥ 0 of L = Σ (y − ln s)²/v with s = G c + offset: Gauss–Newton on the
        linearisation ln s ≈ ln s0 + (s − s0)/s0 (each step an NNLS, scipy), step-halving on
        increase; ``s0`` warm-starts. Returns (c, s, L)."""
        y, w = self.y, self.w
        off = np.zeros_like(y) if offset is None else offset
        p = G.shape[1]
        if p == 0:
            s = np.maximum(off, self.floor)
            return np.zeros(0), s, self.objective(s)
        s = np.maximum(self.x if s0 is None else s0, self.floor)
        c_old: np.ndarray | None = None
        L_old = math.inf
        c = np.zeros(p)
        for _ in range(max_iter):
            ws = w / s
            A = G * ws[:, None]
            scale = np.sqrt(np.sum(A * A, axis=0))
            scale[scale == 0] = 1.0
            rhs = (y - np.log(s) + 1.0) * w - off * ws
            try:
                c_new, _ = nnls(A / scale, rhs, maxiter=50 * p)
            except RuntimeError:
                c_new = c if c_old is not None else np.zeros(p)
            else:
                c_new = c_new / scale
            s_new = np.maximum(G @ c_new + off, self.floor)
            L_new = self.objective(s_new)
            if c_old is not None and L_new > L_old:
                for _ in range(12):
                    c_new = 0.5 * (c_new + c_old)
                    s_new = np.maximum(G @ c_new + off, self.floor)
                    L_new = self.objective(s_new)
                    if L_new <= L_old:
                        break
            done = c_old is not None and abs(L_old - L_new) <= 1e-7 * max(L_new, 1.0)
            c, s = c_new, s_new
            if L_new <= L_old:
                c_old, L_old = c, L_new
            if done:
                break
        if c_old is None:
            return c, s, self.objective(s)
        s_best = np.maximum(G @ c_old + off, self.floor)
        return c_old, s_best, L_old


def _shape_range(key: str, tau_lo: float, tau_hi: float, tau0: float) -> tuple[float, float]:
    if key == "markov":  # hump peak 1.89 T_c inside [tau_lo/2, tau_hi]
        return tau_lo / 4.0, tau_hi / 2.0
    if key == "sine":  # first lobe 0.371/f0 up to tau_hi; below Nyquist
        return 0.2 / tau_hi, 0.5 / tau0
    if key == "blue":  # asymptote crossover tau*beta = 3/(4 pi)
        return 0.03 / tau_hi, 3.0 / tau_lo
    raise KeyError(key)


@dataclass
class _State:
    cols: list[_Col]
    c: np.ndarray
    s: np.ndarray
    D: float


def _solve_state(eng: _Engine, cols: list[_Col], s0: np.ndarray | None = None,
                 max_iter: int = 60) -> _State:
    G = eng.design(cols)
    c, s, D = eng.solve(G, s0=s0, max_iter=max_iter)
    return _State([_Col(k.key, k.label, k.shape, k.lo, k.hi) for k in cols], c, s, D)


def _optimise_shapes(eng: _Engine, cols: list[_Col], line_hints: Sequence[float],
                     shape_hints: dict[str, float] | None = None) -> _State:
    """Place each nonlinear term by a log-grid search of the profile deviance (one at a time,
    others fixed), then refine all shapes jointly (Nelder–Mead on log-shapes, clipped to their
    ranges). ``shape_hints`` (label → shape) join the grid of their term (the shapes of a
    model already found, so that a refit of it reaches at least that optimum)."""
    nl = [i for i, c in enumerate(cols) if c.key in NONLINEAR_KEYS]
    placed: list[int] = []
    lin = [i for i in range(len(cols)) if i not in nl]
    for i in nl:
        col = cols[i]
        n_grid = 240 if col.key == "sine" else 48
        grid = list(np.geomspace(col.lo, col.hi, n_grid))
        hint = (shape_hints or {}).get(col.label)
        if hint is not None and col.lo <= hint <= col.hi:
            grid.append(float(hint))
        if col.key == "sine":
            for f in line_hints:
                if col.lo <= f <= col.hi:
                    grid.extend(f * np.linspace(0.97, 1.03, 13))
        active = lin + placed + [i]
        best = (math.inf, None)
        s_prev = None
        for g in sorted(grid):
            cols[i].shape = float(g)
            st = _solve_state(eng, [cols[j] for j in active], s_prev, max_iter=4)
            s_prev = st.s
            if st.D < best[0]:
                best = (st.D, float(g))
        cols[i].shape = best[1]
        # local 1-D refinement between the neighbouring grid points
        lg = math.log(best[1])
        step = math.log(col.hi / col.lo) / max(n_grid - 1, 1)

        def f1(v: float, i=i, active=active) -> float:
            cols[i].shape = math.exp(v)
            return _solve_state(eng, [cols[j] for j in active]).D

        rx, rf = minimize_bounded(f1, max(lg - step, math.log(col.lo)),
                                  min(lg + step, math.log(col.hi)), xatol=1e-4)
        cols[i].shape = math.exp(rx) if rf <= best[0] else best[1]
        placed.append(i)
    if len(nl) > 1:
        x0 = np.array([math.log(cols[i].shape) for i in nl])
        lo = np.array([math.log(cols[i].lo) for i in nl])
        hi = np.array([math.log(cols[i].hi) for i in nl])

        def fm(v: np.ndarray) -> float:
            v = np.clip(v, lo, hi)
            for k, i in enumerate(nl):
                cols[i].shape = float(math.exp(v[k]))
            return _solve_state(eng, cols).D

        D0 = fm(x0)
        rx, rf = nelder_mead(fm, x0, xatol=1e-4, fatol=1e-6, maxiter=400)
        v = np.clip(rx, lo, hi) if rf < D0 else x0
        for k, i in enumerate(nl):
            cols[i].shape = float(math.exp(v[k]))
    return _solve_state(eng, cols)


def _refine_shapes(eng: _Engine, cols_in: list[_Col]) -> _State:
    """Local re-optimisation of the nonlinear shapes (copies of ``cols_in``) around their
    current values (±1 in log), for likelihood-ratio tests of a reduced model."""
    cols = [_Col(c.key, c.label, c.shape, c.lo, c.hi) for c in cols_in]
    nl = [i for i, c in enumerate(cols) if c.key in NONLINEAR_KEYS]
    lo = np.array([max(math.log(cols[i].shape) - 1.0, math.log(cols[i].lo)) for i in nl])
    hi = np.array([min(math.log(cols[i].shape) + 1.0, math.log(cols[i].hi)) for i in nl])

    def fm(v) -> float:
        v = np.clip(np.atleast_1d(v), lo, hi)
        for k, i in enumerate(nl):
            cols[i].shape = float(math.exp(v[k]))
        return _solve_state(eng, cols).D

    x0 = np.array([math.log(cols[i].shape) for i in nl])
    D0 = fm(x0)
    if len(nl) == 1:
        rx, rf = minimize_bounded(lambda v: fm(np.array([v])), lo[0], hi[0], xatol=1e-3)
        best = np.array([rx]) if rf < D0 else x0
    else:
        rx, rf = nelder_mead(fm, x0, xatol=1e-3, fatol=1e-4, maxiter=200)
        best = np.clip(rx, lo, hi) if rf < D0 else x0
    fm(best)
    return _solve_state(eng, cols)


class _Analysis:
    """Correlation-aware statistics of a solved state: the model-implied correlation ρ of the
    estimates, n_eff, the Satterthwaite scale, the sandwich covariance of the active
    coefficients and log shapes, design effects and Rao–Scott likelihood-ratio statistics."""

    def __init__(self, eng: _Engine, st: _State, tau0: float, bi_f0: float | None):
        self.eng, self.st = eng, st
        tu = eng.tau
        n = tu.size
        R = estimate_correlation(tu, lambda f: _model_psd(st.cols, st.c, f, tau0, bi_f0), tau0)
        self.n_eff = float(n * n / np.sum(R))
        self.satt = float(np.sum(R * R) / n)
        delta = st.s * np.sqrt(eng.v)  # sd of σ̂² implied by the log-χ² variance
        self.W = 1.0 / delta**2
        self.C = R * np.outer(delta, delta)
        self.G = eng.design(st.cols)
        act = [j for j in range(len(st.cols)) if st.c[j] > 0]
        shape_cols: dict[int, np.ndarray] = {}
        for j in act:
            col = st.cols[j]
            if col.key in NONLINEAR_KEYS:
                h = 1e-4
                gp = _basis(col.key, tu, col.shape * math.exp(h), None)
                gm = _basis(col.key, tu, col.shape * math.exp(-h), None)
                shape_cols[j] = st.c[j] * (gp - gm) / (2 * h)
        self.labels = [f"c:{st.cols[j].label}" for j in act] + [
            f"ln:{st.cols[j].label}" for j in shape_cols]
        self.base = [self.G[:, j] for j in act] + [shape_cols[j] for j in shape_cols]
        self.cov = None
        self.deff: dict[int, float] = {}
        if self.base:
            naive, self.cov = self._sandwich(self.base)
            for k, j in enumerate(act):
                self.deff[j] = max(self.cov[k, k] / naive[k, k], 1.0) if naive[k, k] > 0 else 1.0
        for j in range(len(st.cols)):
            if j not in self.deff:
                self.deff[j] = self.extra_deff(self.G[:, j])
        self.var_of = {lab: (self.cov[i, i] if self.cov is not None else math.nan)
                       for i, lab in enumerate(self.labels)}
        self.idx_of = {lab: i for i, lab in enumerate(self.labels)}
        self._dD: dict[int, float] = {}

    def _sandwich(self, cols_: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        J = np.column_stack(cols_)
        JW = J * self.W[:, None]
        A = J.T @ JW
        d = np.sqrt(np.diag(A))
        d[d == 0] = 1.0
        Ai = np.linalg.pinv(A / np.outer(d, d), rcond=1e-12) / np.outer(d, d)
        return Ai, Ai @ (JW.T @ self.C @ JW) @ Ai

    def extra_deff(self, g: np.ndarray) -> float:
        """Design effect of an extra amplitude column g added to the current model."""
        naive, cov = self._sandwich(self.base + [g])
        return max(cov[-1, -1] / naive[-1, -1], 1.0) if naive[-1, -1] > 0 else 1.0

    def delta_deviance(self, j: int) -> float:
        """Rao–Scott-corrected deviance increase when term j is dropped (other amplitudes
        re-fitted; other shapes re-optimised locally)."""
        if j in self._dD:
            return self._dD[j]
        st, eng = self.st, self.eng
        if st.c[j] <= 0:
            self._dD[j] = 0.0
            return 0.0
        others = [k for k in range(len(st.cols)) if k != j]
        _, _, D_wo = eng.solve(self.G[:, others])
        if any(st.cols[k].key in NONLINEAR_KEYS and st.c[k] > 0 for k in others):
            D_wo = min(D_wo, _refine_shapes(eng, [st.cols[k] for k in others]).D)
        self._dD[j] = max(D_wo - st.D, 0.0) / self.deff[j]
        return self._dD[j]


# ---------------------------------------------------------------------------------------------
# Fit
# ---------------------------------------------------------------------------------------------


def fit_noise_model(
    tau, sigma, edf, *, sigma_lo=None, sigma_hi=None, terms: str | Sequence[str] | None = None,
    tau0: float | None = None, min_edf: float = MIN_EDF, bi_cutoff_hz: float | None = None,
    line_hints: Sequence[float] = (), tau_range: tuple[float, float] | None = None,
    with_bounds: bool = True, confidence: float = 0.683, scan: bool = False,
    shape_hints: dict[str, float] | None = None, quantity: str = "rate",
) -> NoiseFit:
    """Fit σ²_model(τ) = Σ c_j g_j(τ) jointly to an Allan deviation table (module docstring).

    Parameters
    ----------
    tau, sigma, edf : the table (s, deg/h, equivalent degrees of freedom per τ).
    sigma_lo, sigma_hi : its confidence interval (for the residuals in CI units); default
        from the χ² interval at 68.3 % of ``edf``.
    terms : e.g. ``"Q,N,B,K,R,markov"`` (:func:`parse_terms`); default Q, N, B, K, R.
    tau0 : sample interval (s); sets the sinusoid search limit (Nyquist). Default min τ.
    min_edf : τ with EDF below this are not fitted (Krobka: do not fit where the CI blows up).
    bi_cutoff_hz : use the full bias-instability template (eq. 5.3) with this f0 instead of the
        flat IEEE level.
    line_hints : candidate sinusoid frequencies (Hz), e.g. from :func:`spectral.find_lines`.
    tau_range : (τ_lo, τ_hi) s: fit only inside.
    with_bounds : compute profile-likelihood upper bounds (slower; off for diagnosis scans).
    confidence : of ``sigma_lo``/``sigma_hi`` (used where they are recomputed).
    scan : fast mode for the diagnosis: no backward elimination, no bounds, and only the last
        term is tested (the others get status "not tested").
    shape_hints : {term label: shape} tried with the shape search (e.g. the T_c of a Markov
        term the diagnosis found), so that refitting a found model reaches its optimum.
    quantity : "rate" (gyro; σ in deg/h) or "acceleration" (accelerometer; σ in m/s²): the
        units the coefficients are reported in (:mod:`gyrotest.noise.quantity`).

    The EDF is first made non-increasing in τ (:func:`sanitize_edf`).

    Returns a :class:`NoiseFit`. Raises :class:`AnalysisError` when fewer τ are usable than the
    model has parameters.
    """
    keys = parse_terms(terms)
    tau = np.asarray(tau, float)
    sigma = np.asarray(sigma, float)
    edf = np.asarray(edf, float)
    if not (tau.shape == sigma.shape == edf.shape):
        raise InputError("tau, sigma and edf must have the same length")
    from .edf import chi2_interval

    if sigma_lo is None or sigma_hi is None:
        sigma_lo, sigma_hi = chi2_interval(sigma, edf, confidence)
    sigma_lo = np.asarray(sigma_lo, float).copy()
    sigma_hi = np.asarray(sigma_hi, float).copy()
    edf, changed = sanitize_edf(edf)
    notes: list[str] = []
    if changed:
        lo_c, hi_c = chi2_interval(sigma[changed], edf[changed], confidence)
        sigma_lo[changed], sigma_hi[changed] = lo_c, hi_c
        notes.append("EDF lowered to the running minimum at τ = "
                     + ", ".join(f"{tau[i]:.4g}" for i in changed)
                     + " s (an isolated noise-type identification raised it above the EDF at "
                     "shorter τ); confidence intervals recomputed there")
    ok = np.isfinite(tau) & np.isfinite(sigma) & (sigma > 0) & np.isfinite(edf) & (tau > 0)
    used = ok & (edf >= min_edf)
    if tau_range is not None:
        used &= (tau >= tau_range[0] * (1 - 1e-9)) & (tau <= tau_range[1] * (1 + 1e-9))
    n_par = sum(1 if k in LINEAR_KEYS else 2 for k in keys)
    if np.count_nonzero(used) < n_par + 1:
        raise AnalysisError(
            f"only {int(np.count_nonzero(used))} τ value(s) with EDF ≥ {min_edf:g} to fit "
            f"{n_par} parameter(s) ({','.join(keys)}): record a longer log, use a denser τ grid "
            "(--taus 10/decade) or fewer --terms")
    low_edf = ok & ~used & (edf < min_edf)
    if np.any(low_edf):
        notes.append(
            f"fit stopped at τ = {tau[used].max():.4g} s: {int(np.count_nonzero(low_edf))} longer "
            f"τ have EDF < {min_edf:g} (too few clusters: the confidence interval blows up) and are shown only")
    tu, xu, nuu = tau[used], sigma[used] ** 2, edf[used]
    tau0 = float(tau0) if tau0 else float(tu.min())
    if bi_cutoff_hz is not None and not 0.0 < bi_cutoff_hz <= 0.5 / tau0:
        raise AnalysisError(f"--bi-cutoff f0 = {bi_cutoff_hz:g} Hz: the cut-off must be a "
                            f"frequency above 0 and at most the Nyquist frequency 1/(2τ0) = "
                            f"{0.5 / tau0:.4g} Hz")
    q = quantity_of(quantity)
    eng = _Engine(tu, xu, nuu, bi_cutoff_hz, q)
    lo_t, hi_t = float(tu.min()), float(tu.max())
    cols: list[_Col] = []
    counts: dict[str, int] = {}
    for k in keys:
        counts[k] = counts.get(k, 0) + 1
    seen: dict[str, int] = {}
    for k in keys:
        seen[k] = seen.get(k, 0) + 1
        label = k if counts[k] == 1 else f"{k}[{seen[k]}]"
        col = _Col(k, label)
        if k in NONLINEAR_KEYS:
            col.lo, col.hi = _shape_range(k, lo_t, hi_t, tau0)
            col.shape = math.sqrt(col.lo * col.hi)
        cols.append(col)
    thr = {k: special.chdtri(2 if k in NONLINEAR_KEYS else 1, 1 - _LRT_P) for k in KNOWN_TERMS}
    active = list(cols)
    dropped: dict[str, tuple[_Col, float, float]] = {}  # label -> (col, dD, coef) at drop time
    st = (_optimise_shapes(eng, active, line_hints, shape_hints)
          if any(c.key in NONLINEAR_KEYS for c in active) else _solve_state(eng, active))
    # terms at zero leave the model unchanged
    zero = [j for j in range(len(active)) if st.c[j] <= 0]
    if zero and len(zero) < len(active):
        for j in zero:
            dropped[active[j].label] = (st.cols[j], 0.0, 0.0)
        active = [c for j, c in enumerate(st.cols) if j not in zero]
        st = _solve_state(eng, active)
    D_full = st.D
    an = _Analysis(eng, st, tau0, bi_cutoff_hz)
    if scan:
        with_bounds = False
    # backward elimination: drop the weakest non-significant term while the reduced model stays
    # consistent with the full one (joint Rao-Scott LRT of everything dropped)
    dropped_pos: list[tuple[int, float]] = []  # (n params, design effect) of dropped terms
    while len(active) > 1 and not scan:
        score = [an.delta_deviance(j) / thr[active[j].key] for j in range(len(active))]
        weak = [k for k in range(len(active)) if score[k] < 1.0]
        if not weak:
            break
        # among the non-significant terms, drop the one whose removal costs the least fit
        j = min(weak, key=lambda k: an.delta_deviance(k) * an.deff[k])
        cand = [c for k, c in enumerate(st.cols) if k != j]
        st_c = (_refine_shapes(eng, cand) if any(c.key in NONLINEAR_KEYS for c in cand)
                else _solve_state(eng, cand))
        k_par = sum(n for n, _ in dropped_pos) + (2 if active[j].key in NONLINEAR_KEYS else 1)
        deffs = [d for _, d in dropped_pos] + [an.deff[j]]
        joint = (st_c.D - D_full) / float(np.mean(deffs))
        if joint >= special.chdtri(k_par, 1 - _LRT_P):
            break
        dropped[active[j].label] = (st.cols[j], score[j] * thr[active[j].key], float(st.c[j]))
        dropped_pos.append((2 if active[j].key in NONLINEAR_KEYS else 1, an.deff[j]))
        st = st_c
        active = list(st.cols)
        zero = [k for k in range(len(active)) if st.c[k] <= 0]
        if zero and len(zero) < len(active):
            for k in zero:
                dropped[active[k].label] = (st.cols[k], 0.0, 0.0)
            active = [c for k, c in enumerate(st.cols) if k not in zero]
            st = _solve_state(eng, active)
        an = _Analysis(eng, st, tau0, bi_cutoff_hz)
    n_u = tu.size
    chi2 = st.D  # Σ standardized log residuals² (the objective at its minimum)
    n_free = len(an.labels)
    fit = NoiseFit(
        terms=[], requested=list(keys), tau=tau, sigma=sigma, sigma_lo=sigma_lo,
        sigma_hi=sigma_hi, edf=edf, used=used, deviance=st.D, chi2=chi2,
        dof=max(n_u - n_free, 0), n_free=n_free, n_eff=an.n_eff, satterthwaite=an.satt,
        tau0=tau0, bi_f0=bi_cutoff_hz, min_edf=min_edf, notes=notes, cov=an.cov,
        cov_labels=an.labels, quantity=q.key,
    )
    pos = {c.label: j for j, c in enumerate(st.cols)}
    for col in cols:
        if col.label in pos:
            j = pos[col.label]
            c = float(st.c[j])
            fc = st.cols[j]
            if scan and col is not cols[-1]:
                dD = math.nan
                identified = False
            else:
                dD = an.delta_deviance(j)
                identified = c > 0 and dD >= thr[col.key]
            nu_j, span_j = carry_edf(eng.tau, eng.nu, an.G[:, j] * c, st.s)
            thin = identified and nu_j < MIN_EDF_IDENTIFY
            if thin:
                identified = False
            params = _reported(col.key, c, fc.shape, q)
            sig: dict[str, float | None] = {p: None for p in params}
            if identified and an.cov is not None:
                sig = _param_sigma(fc, c, an.cov, an.idx_of, an.var_of, q)
            upper = None if identified or not with_bounds else _upper_bound(
                eng, st, j, an.deff[j])
            term = FitTerm(key=col.key, label=col.label, params=params, sigma=sig, upper=upper,
                           status=("identified" if identified else
                                   "not tested" if math.isnan(dD) else "upper bound"),
                           delta_deviance=dD, coef=c, shape=fc.shape,
                           derived=_derived(col.key, c, fc.shape, q), bi_f0=bi_cutoff_hz,
                           design_effect=an.deff[j], carry_edf=nu_j, quantity=q.key)
            if thin:
                term.status_note = f"EDF < {MIN_EDF_IDENTIFY:g}"
                term.notes.append(
                    f"significant by the likelihood ratio (Δ = {dD:.3g}) but carried only by τ "
                    f"{span_j[0]:.4g}–{span_j[1]:.4g} s, where no estimate has "
                    f"{MIN_EDF_IDENTIFY:g} degrees of freedom (at most {nu_j:.3g}): not "
                    "identified; the value shown is the 95 % upper bound")
        else:
            dcol, dD, c_drop = dropped[col.label]
            shape = dcol.shape if (c_drop > 0 or col.key not in NONLINEAR_KEYS) else None
            params = _reported(col.key, 0.0, shape if shape is not None else (dcol.shape or 1.0),
                               q)
            if col.key in NONLINEAR_KEYS and shape is None:
                params[[k for k in params if k != _MAIN[col.key]][0]] = math.nan
            upper = None
            deff_j = 1.0
            if with_bounds:
                ext = [_Col(c.key, c.label, c.shape, c.lo, c.hi) for c in st.cols]
                ext.append(_Col(dcol.key, dcol.label, dcol.shape, dcol.lo, dcol.hi))
                st2 = _solve_state(eng, ext)
                if shape is None and st2.c[-1] > 0:
                    st2 = _State(st2.cols, np.append(st.c, 0.0), st.s, st.D)
                # design effect with the term's own PSD in the correlation model
                deff_j = _Analysis(eng, st2, tau0, bi_cutoff_hz).deff[len(ext) - 1]
                upper = _upper_bound(eng, st2, len(ext) - 1, deff_j)
            derived = {"estimate_in_full_model": _reported(col.key, c_drop, dcol.shape, q)[
                _MAIN[col.key]] if c_drop > 0 else 0.0}
            term = FitTerm(key=col.key, label=col.label, params=params,
                           sigma={p: None for p in params}, upper=upper, status="upper bound",
                           delta_deviance=dD, coef=0.0, shape=shape, derived=derived,
                           bi_f0=bi_cutoff_hz, design_effect=deff_j, quantity=q.key)
            term.notes.append("not significant: removed from the model (backward elimination); "
                              "the value shown is the 95 % upper bound")
        if col.key in NONLINEAR_KEYS and term.status != "identified" and term.coef <= 0:
            term.notes.append(
                f"{col.key} not identified: bound for {term.main} is the largest over the "
                f"shape range {col.lo:.3g}–{col.hi:.3g} {'s' if col.key == 'markov' else 'Hz'}")
        fit.terms.append(term)
    _dominance(fit)
    return fit


def _param_sigma(col: _Col, c: float, cov: np.ndarray, idx_of: dict[str, int],
                 var_of: dict[str, float], q: Quantity = RATE) -> dict[str, float | None]:
    """Delta-method 1σ of the reported parameters from cov(c, ln shape)."""
    ic = idx_of.get(f"c:{col.label}")
    il = idx_of.get(f"ln:{col.label}")
    vc = var_of.get(f"c:{col.label}", math.nan)
    rc = math.sqrt(c)
    out: dict[str, float | None] = {}

    def amp_sigma(k: float) -> float:
        return k * math.sqrt(max(vc, 0.0)) / (2.0 * rc)

    if col.key == "Q":
        out["Q"] = amp_sigma(1.0)
    elif col.key == "N":
        out["N"] = amp_sigma(1.0 / 60.0)
    elif col.key == "B":
        out["B"] = amp_sigma(1.0)
    elif col.key == "K":
        out["K"] = amp_sigma(60.0)
    elif col.key == "R":
        out["R"] = amp_sigma(3600.0)
    else:
        T = col.shape
        vl = var_of.get(f"ln:{col.label}", math.nan)
        cl = cov[ic, il] if (ic is not None and il is not None) else 0.0
        if col.key == "markov":
            # q = 60 sqrt(c)/T: dq/dc = 60/(2 sqrt(c) T), dq/dlnT = -60 sqrt(c)/T
            g = np.array([60.0 / (2 * rc * T), -60.0 * rc / T])
            V = np.array([[vc, cl], [cl, vl]])
            out["q_c"] = float(math.sqrt(max(g @ V @ g, 0.0)))
            out["T_c"] = T * math.sqrt(max(vl, 0.0))
        elif col.key == "sine":
            out["Omega0"] = amp_sigma(1.0)
            out["f0"] = T * math.sqrt(max(vl, 0.0))
        elif col.key == "blue":
            out["alpha"] = math.sqrt(max(vc, 0.0))
            out["beta"] = T * math.sqrt(max(vl, 0.0))
    return {k: (v * q.factor(k) if v is not None and math.isfinite(v) else None)
            for k, v in out.items()}


def _upper_bound(eng: _Engine, st: _State, j: int, deff: float) -> float:
    """95 % one-sided profile-likelihood upper limit of term j's amplitude (reported unit)."""
    col = st.cols[j]
    shapes = [col.shape]
    if col.key in NONLINEAR_KEYS and st.c[j] <= 0:
        shapes = list(np.geomspace(col.lo, col.hi, 16))
    best = 0.0
    target = special.chdtri(1, 2 * (1 - _LRT_P))  # 2.71: one-sided 95 %
    others = [k for k in range(len(st.cols)) if k != j]
    for shp in shapes:
        cols = [_Col(c.key, c.label, c.shape, c.lo, c.hi) for c in st.cols]
        cols[j].shape = shp
        G = eng.design(cols)
        g = G[:, j]
        Go = G[:, others]
        c0 = float(st.c[j]) if shp == col.shape else 0.0
        D0 = st.D if shp == col.shape else eng.solve(Go)[2]
        pos = g > 0
        if not np.any(pos):
            continue
        c_hard = 4.0 * float(np.min(eng.x[pos] / g[pos]))

        def excess(logc: float, g=g, Go=Go, D0=D0) -> float:
            cc = math.exp(logc)
            _, _, D = eng.solve(Go, offset=cc * g)
            return (D - D0) / deff - target

        lo = math.log(max(c0, c_hard * 1e-12))
        hi = math.log(c_hard)
        try:
            if excess(hi) < 0:
                cu = c_hard
            elif excess(lo) > 0:  # only if c0 is not the optimum: fall back to it
                cu = max(c0, c_hard * 1e-12)
            else:
                cu = math.exp(root_bracketed(excess, lo, hi, xtol=1e-5))
        except (ValueError, RuntimeError):
            cu = c_hard
        val = _reported(col.key, cu, shp, eng.q)[_MAIN[col.key]]
        best = max(best, val)
    return best


def _dominance(fit: NoiseFit) -> None:
    """τ range (s) where each term is the largest component of the model (within the table)."""
    if not fit.terms:
        return
    comp = np.array([t.avar(fit.tau) for t in fit.terms])
    big = np.argmax(comp, axis=0)
    for i, t in enumerate(fit.terms):
        sel = (big == i) & (comp[i] > 0)
        if np.any(sel):
            t.dominant_tau = (float(fit.tau[sel].min()), float(fit.tau[sel].max()))


def fit_deviation(dev, *, terms=None, min_edf: float = MIN_EDF, bi_cutoff_hz=None,
                  line_hints=(), tau_range=None, with_bounds: bool = True) -> NoiseFit:
    """:func:`fit_noise_model` on a :class:`~gyrotest.noise.devcore.DeviationResult`
    (its τ, σ, EDF made robust by :func:`robust_edf`, the χ² interval recomputed from that EDF,
    and τ0). The closed forms are those of the Allan variance: use an OADEV/ADEV/TOTDEV (or
    Allan–Krobka) table."""
    from .edf import chi2_interval

    edf, notes = robust_edf(dev)
    lo, hi = chi2_interval(dev.sigma, edf, dev.confidence)
    f = fit_noise_model(dev.tau, dev.sigma, edf, sigma_lo=lo, sigma_hi=hi, terms=terms,
                        tau0=dev.tau0, min_edf=min_edf, bi_cutoff_hz=bi_cutoff_hz,
                        line_hints=line_hints, tau_range=tau_range, with_bounds=with_bounds,
                        confidence=dev.confidence, quantity=table_quantity(dev))
    f.notes[:0] = notes
    return f
