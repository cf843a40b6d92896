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

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import special

from ..core.errors import AnalysisError, InputError
from ..core.units import format_number
from . import kinds as _kinds
from .numerics import minimize_bounded, nelder_mead, nnls, root_bracketed  # no scipy.optimize
from .quantity import ACCEL, RATE, Quantity, quantity_of
from .terms import (
    BIAS_INSTABILITY_PLATEAU,
    blue_markov_derivative_avar,
    markov_avar,
    sinusoid_avar,
)
from .terms import (
    bias_instability_avar as _bi_template,
)

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

DEFAULT_TERMS: tuple[str, ...] = ("Q", "N", "B", "K", "R")
LINEAR_KEYS = ("Q", "N", "B", "K", "R")
NONLINEAR_KEYS = ("markov", "sine", "blue")
KNOWN_TERMS = LINEAR_KEYS + NONLINEAR_KEYS
_ALIASES = {
    "q": "Q", "quantization": "Q", "n": "N", "arw": "N", "b": "B", "bi": "B",
    "bias_instability": "B", "k": "K", "rrw": "K", "r": "R", "ramp": "R", "rate_ramp": "R",
    "markov": "markov", "gm": "markov", "gauss-markov": "markov", "sine": "sine",
    "sinusoid": "sine", "sin": "sine", "blue": "blue",
}
#: registry key (gyrotest.noise.terms.TERMS) of each fit term
REGISTRY = {"Q": "quantization", "N": "arw", "B": "bias_instability", "K": "rrw",
            "R": "rate_ramp", "markov": "markov", "sine": "sinusoid",
            "blue": "blue_markov_derivative"}
#: S(0) = 0 ("platform-benign / strapdown-critical") terms
ZERO_DC = {"Q", "sine", "blue"}
#: default fitting floor (:data:`gyrotest.noise.kinds.MIN_EDF`, where it is explained)
MIN_EDF = _kinds.MIN_EDF
_LRT_P = 0.95
FIT_METHOD = ("maximum likelihood of the Allan variance estimates given their chi-square(EDF) "
              "distribution, log-normal form with exact ln-chi2 moments: minimise "
              "sum (ln s_hat - b(EDF) - ln s_model)^2 / trigamma(EDF/2) (~ sum[(s_model - "
              "s_hat)/delta]^2, delta = s*sqrt(2/EDF)); non-negative coefficients (Gauss-Newton "
              "NNLS); nonlinear parameters by log-grid search + bounded refinement")
UNCERTAINTY_METHOD = ("1 sigma from the sandwich covariance A^-1 B A^-1 of that likelihood "
                      "(weighted Jacobian A; B with the model-implied correlation of the Allan "
                      "variance estimates between tau); upper bounds: 95 % one-sided profile "
                      "likelihood with the Rao-Scott design-effect correction")
#: degrees of freedom a term needs where it is carried (:func:`carry_edf`) to be identified:
#: from ν = 10 on, the log of σ̂² ~ σ²·χ²_ν/ν, whose normal form the fit's likelihood, its
#: sandwich covariance and the χ²₁ reference of the likelihood-ratio test rest on, has a
#: skewness below 0.5 in magnitude (ψ''(ν/2)/ψ'(ν/2)^1.5: −0.47 at ν = 10, −0.78 at 4, −1.14
#: at 2) and σ̂² is within ±45 % (1σ, √(2/ν)) of σ²; a term seen only through fewer degrees of
#: freedom is an upper bound
MIN_EDF_IDENTIFY = 10.0
STATUS_RULE = ("identified when dropping the term raises -2 log-likelihood/design effect by >= "
               "chi2_k(0.95) (k = 1, or 2 for markov/sine/blue) and the tau that carry the term "
               "(where its share of the model variance is at least half its largest share) "
               f"hold an estimate with at least {MIN_EDF_IDENTIFY:g} degrees of freedom; else "
               "upper bound only (printed with '<=')")


def carry_edf(tau, nu, comp, total) -> tuple[float, tuple[float, float]]:
    """(ν, (τ_lo, τ_hi)): the largest EDF among the τ that carry a term, and their span.

    A term is carried by the fitted τ where its share of the model variance, comp/total, is
    at least half of its largest share (where it is the dominant term, or near its largest
    contribution when it never dominates). Its evidence comes from there: when no estimate
    there has :data:`MIN_EDF_IDENTIFY` degrees of freedom, the χ² asymptotics of the fit do not
    hold for it and it is not identified (STATUS_RULE)."""
    t = np.asarray(tau, float)
    e = np.asarray(nu, float)
    with np.errstate(invalid="ignore", divide="ignore"):
        share = np.where(np.asarray(total, float) > 0, np.asarray(comp, float)
                         / np.asarray(total, float), 0.0)
    if t.size == 0 or not np.any(share > 0):
        return 0.0, (math.nan, math.nan)
    sel = share >= 0.5 * float(np.max(share))
    return float(np.max(e[sel])), (float(t[sel].min()), float(t[sel].max()))


def parse_terms(spec: str | Sequence[str] | None) -> list[str]:
    """Parse a term list like ``"Q,N,B,K,R,markov,sine"`` (case-insensitive aliases: arw, rrw,
    ramp, gm, sinusoid; ``markov*2`` or repeating ``markov`` gives two Markov terms; ``+x``
    adds x to the default Q,N,B,K,R). Returns canonical keys; raises InputError for unknown
    names. Linear terms may appear once."""
    if spec is None:
        return list(DEFAULT_TERMS)
    items = [s.strip() for s in spec.split(",")] if isinstance(spec, str) else [
        str(s).strip() for s in spec]
    items = [s for s in items if s]
    out: list[str] = []
    if items and all(s.startswith("+") for s in items):
        out = list(DEFAULT_TERMS)
    for s in items:
        s = s.lstrip("+")
        count = 1
        if "*" in s:
            s, _, cnt = s.partition("*")
            try:
                count = int(cnt)
            except ValueError:
                raise InputError(f"bad term count in {s}*{cnt!r}; use e.g. markov*2") from None
        key = _ALIASES.get(s.lower(), s)
        if key not in KNOWN_TERMS:
            raise InputError(f"unknown noise term {s!r}; use any of Q, N, B, K, R, markov, sine, "
                             "blue (comma-separated)")
        if key in LINEAR_KEYS and (key in out or count > 1):
            raise InputError(f"term {key} listed twice; only markov, sine and blue can repeat")
        out.extend([key] * count)
    if not out:
        raise InputError("empty --terms list; e.g. --terms Q,N,B,K,R")
    if sum(k in NONLINEAR_KEYS for k in out) > 4:
        raise InputError("at most 4 markov/sine/blue terms can be fitted at once")
    return out


# ---------------------------------------------------------------------------------------------
# Basis functions
# ---------------------------------------------------------------------------------------------


def _basis(key: str, tau: np.ndarray, shape: float | None, bi_f0: float | None) -> np.ndarray:
    if key == "Q":
        return 3.0 / tau**2
    if key == "N":
        return 1.0 / tau
    if key == "B":
        if bi_f0 is None:
            return np.full_like(tau, BIAS_INSTABILITY_PLATEAU**2)
        return _bi_template(tau, 1.0, bi_f0)
    if key == "K":
        return tau / 3.0
    if key == "R":
        return tau**2 / 2.0
    if key == "markov":
        return markov_avar(tau, 1.0 / shape, shape)
    if key == "sine":
        return sinusoid_avar(tau, 1.0, shape)
    if key == "blue":
        return blue_markov_derivative_avar(tau, 1.0, shape)
    raise KeyError(key)


def _component_psd(key: str, c: float, shape: float | None, f: np.ndarray, tau0: float,
                   bi_f0: float | None) -> np.ndarray:
    """Two-sided rate PSD (deg/h)²/Hz of one fitted term (internal coefficient c); zero for the
    deterministic ramp and sinusoid (IEEE 952 Annex C; Krobka (Allan-graph topology) eqs. 5.2-5.7, Table 7.3)."""
    if c <= 0 or key in ("R", "sine"):
        return np.zeros_like(f)
    if key == "N":
        return np.full_like(f, c)
    if key == "Q":
        return np.where(f < 0.5 / tau0, (2 * np.pi * f) ** 2 * tau0 * c, 0.0)
    if key == "B":
        f0 = 0.5 / tau0 if bi_f0 is None else bi_f0
        return np.where(f <= f0, c / (2 * np.pi * f), 0.0)
    if key == "K":
        return c / (2 * np.pi * f) ** 2
    if key == "markov":
        return c / (1.0 + (2 * np.pi * f * shape) ** 2)
    if key == "blue":
        return c * f**2 / (shape**2 + f**2)
    raise KeyError(key)


def _model_psd(cols, coefs, f, tau0, bi_f0) -> np.ndarray:
    out = np.zeros_like(np.asarray(f, float))
    for col, c in zip(cols, coefs):
        out = out + _component_psd(col.key, float(c), col.shape, f, tau0, bi_f0)
    return out


def log_chi2_moments(x, nu) -> tuple[np.ndarray, np.ndarray]:
    """Unbiased log estimate and its variance for σ̂² ~ σ²·χ²_ν/ν (NIST SP1065 §5.3):
    ``y = ln σ̂² − (ψ(ν/2) − ln(ν/2))`` has mean ln σ² and variance ``v = ψ₁(ν/2)`` (ψ digamma,
    ψ₁ trigamma; v ≈ 2/ν for large ν)."""
    x = np.asarray(x, float)
    h = 0.5 * np.asarray(nu, float)
    return np.log(x) - (special.digamma(h) - np.log(h)), special.polygamma(1, h)


def log_chi2_objective(x, s, nu) -> float:
    """The fit objective ``L = Σ (ln σ̂² − b(ν) − ln s)²/ψ₁(ν/2)`` (b(ν) = ψ(ν/2) − ln(ν/2)):
    −2 log-likelihood of the estimates under the log-normal approximation of their χ²_ν/ν
    distribution with its exact log-moments (:func:`log_chi2_moments`). Symmetric in
    ln(σ̂²/s), so a model that is too high costs as much as one that is too low."""
    y, v = log_chi2_moments(x, nu)
    r = y - np.log(np.asarray(s, float))
    return float(np.sum(r * r / v))


@functools.lru_cache(maxsize=8)
def _allan_kernels(tau: tuple[float, ...], tau0: float, n_freq: int):
    """The frequency grid f, its weights, and the kernels K_τ(f) and K_τ(f)² of
    :func:`estimate_correlation` on it: they depend on the τ grid only, not on the model, so
    the fits of one table (the requested model and the diagnosis' candidates, ≈ 14 calls)
    share them (read-only arrays)."""
    t = np.asarray(tau, float)
    f = np.geomspace(1e-3 / float(t.max()), 0.5 / tau0, n_freq)
    w = np.gradient(f)
    x = np.pi * f[None, :] * t[:, None]
    far = x > 40.0
    s2 = np.sin(x)
    s2 *= s2
    s4 = s2 * s2
    x2 = x * x
    K = np.where(far, 0.375, s4) / x2
    K8 = np.where(far, 35.0 / 128.0, s4 * s4) / (x2 * x2)
    for a in (f, w, K, K8):
        a.flags.writeable = False
    return f, w, K, K8


def estimate_correlation(tau, psd, tau0: float, *, n_freq: int = 1200) -> np.ndarray:
    """Model-implied correlation matrix ρ of overlapping Allan-variance estimates at ``tau``.

    Large-sample covariance of quadratic estimators: Cov(σ̂²_i, σ̂²_j) ∝ ∫ S(f)² K_i(f) K_j(f) df,
    K_τ(f) = sin⁴(πfτ)/(πfτ)² (the Allan variance is 4∫S K df; IEEE 952 Annex C; Percival &
    Walden 1993 §8), so ρ_ij = M_ij/√(M_ii M_jj). ``psd(f)`` is the two-sided rate PSD of the
    model ((deg/h)²/Hz); integration on a log grid from 10⁻³/τ_max to the Nyquist frequency
    1/(2τ0); where πfτ > 40 the oscillating sin⁴ is replaced by its mean 3/8 (sin⁸ by 35/128 on
    the diagonal). Deterministic terms (ramp, sinusoid) have no PSD here. Returns the identity
    when the PSD is zero."""
    t = np.asarray(tau, float)
    f, w, K, K8 = _allan_kernels(tuple(t.tolist()), float(tau0), int(n_freq))
    S = np.asarray(psd(f), float)
    S = np.where(np.isfinite(S) & (S > 0), S, 0.0)
    q = S * S * w
    M = (K * q) @ K.T
    d = np.sqrt(np.maximum(K8 @ q, 0.0))
    if not np.all(d > 0):
        return np.eye(t.size)
    R = M / np.outer(d, d)
    R = np.clip(R, 0.0, 1.0)
    np.fill_diagonal(R, 1.0)
    return R


def sanitize_edf(edf) -> tuple[np.ndarray, list[int]]:
    """Make the EDF non-increasing in τ (running minimum from short to long τ).

    With a fixed record, the equivalent degrees of freedom of an Allan-variance estimate fall
    as τ grows; an isolated jump up (e.g. a lag-1 noise identification returning α = +1 at one
    long τ from a few dozen averages, whose Greenhall EDF is ~10× its neighbours') would make
    that single point dominate the fit and shrink its confidence interval. Returns the cleaned
    EDF and the indices that were lowered."""
    e = np.asarray(edf, float).copy()
    changed: list[int] = []
    run = math.inf
    for i, v in enumerate(e):
        if not math.isfinite(v):
            continue
        if v > run * 1.0000001:
            e[i] = run
            changed.append(i)
        run = min(run, e[i])
    return e, changed


def ci_residuals(sigma: np.ndarray, sigma_lo: np.ndarray, sigma_hi: np.ndarray,
                 model_sigma: np.ndarray) -> np.ndarray:
    """Residual of the model at each τ in units of the confidence interval of σ̂:
    ``(σ̂ − σ_m)/(σ̂ − σ_lo)`` when the measurement is above the model, ``(σ̂ − σ_m)/(σ_hi − σ̂)``
    when below. |r| ≤ 1: the model is inside the interval (at the table's confidence, 68.3 % by
    default, so r is roughly in standard deviations). NaN where there is no interval."""
    s = np.asarray(sigma, float)
    m = np.asarray(model_sigma, float)
    lo = np.asarray(sigma_lo, float)
    hi = np.asarray(sigma_hi, float)
    with np.errstate(invalid="ignore", divide="ignore"):
        up = (s - m) / (s - lo)
        dn = (s - m) / (hi - s)
    r = np.where(s >= m, up, dn)
    return np.where(np.isfinite(r), r, np.nan)


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
# Result types
# ---------------------------------------------------------------------------------------------

_UNITS = RATE.units  # the gyro units; an accelerometer fit's are ACCEL.units
_TITLES = RATE.titles
_MAIN = {"Q": "Q", "N": "N", "B": "B", "K": "K", "R": "R", "markov": "q_c", "sine": "Omega0",
         "blue": "alpha"}


def _reported(key: str, c: float, shape: float | None, q: Quantity = RATE) -> dict[str, float]:
    """The reported parameters of a term from its coefficient c (gyro formulas, each times
    ``q.factor`` for an accelerometer: :mod:`gyrotest.noise.quantity`)."""
    rc = math.sqrt(max(c, 0.0))
    if key == "Q":
        out = {"Q": rc}
    elif key == "N":
        out = {"N": rc / 60.0}
    elif key == "B":
        out = {"B": rc}
    elif key == "K":
        out = {"K": rc * 60.0}
    elif key == "R":
        out = {"R": rc * 3600.0}
    elif key == "markov":
        out = {"q_c": 60.0 * rc / shape, "T_c": shape}
    elif key == "sine":
        out = {"Omega0": rc, "f0": shape}
    elif key == "blue":
        out = {"alpha": max(c, 0.0), "beta": shape}
    else:
        raise KeyError(key)
    if q is not RATE:
        out = {k: v * q.factor(k) if v is not None else v for k, v in out.items()}
    return out


def _derived(key: str, c: float, shape: float | None, q: Quantity = RATE) -> dict[str, float]:
    """Derived quantities users ask for (all from the same coefficients)."""
    if q is not RATE:
        if key == "markov":
            return {"N_eq": _reported("N", c, None, q)["N"], "peak_tau_s": 1.89262 * shape}
        if key == "sine":
            return {"period_s": 1.0 / shape, "first_lobe_tau_s": 0.37101 / shape}
        if key == "N":
            return {"sigma_1s_m_s2": math.sqrt(max(c, 0.0))}
        if key == "B":
            return {"allan_floor_m_s2": math.sqrt(max(c, 0.0)) * BIAS_INSTABILITY_PLATEAU}
        return {}
    if key == "markov":
        q_int = math.sqrt(max(c, 0.0)) / shape
        return {"N_eq_deg_rt_h": math.sqrt(max(c, 0.0)) / 60.0,
                "sigma_dph": q_int * math.sqrt(shape / 2.0),
                "peak_tau_s": 1.89262 * shape,
                "S0_dph2_per_hz": max(c, 0.0)}
    if key == "sine":
        return {"period_s": 1.0 / shape, "first_lobe_tau_s": 0.37101 / shape}
    if key == "blue":
        return {"T_c_s": 1.0 / (2 * math.pi * shape),
                "angle_rms_arcsec": math.sqrt(max(c, 0.0) / (4 * math.pi * shape))}
    if key == "N":
        return {"sigma_1s_dph": math.sqrt(max(c, 0.0))}
    if key == "B":
        return {"allan_floor_dph": math.sqrt(max(c, 0.0)) * BIAS_INSTABILITY_PLATEAU}
    return {}


@dataclass
class FitTerm:
    """One fitted noise term.

    ``key`` (Q, N, B, K, R, markov, sine, blue), ``label`` (e.g. "markov[2]"), ``registry``
    (key in :data:`gyrotest.noise.terms.TERMS`), ``params`` in reported IEEE units (see
    ``units``), ``sigma`` their 1σ uncertainty (None for upper bounds), ``upper`` the 95 %
    one-sided upper limit of the main coefficient, ``status`` "identified" or "upper bound",
    ``delta_deviance`` the likelihood-ratio statistic (scaled), ``coef`` the internal variance
    coefficient c and ``shape`` the nonlinear parameter, ``dominant_tau`` the τ range (s) where
    this term is the largest component of the model, ``zero_dc_psd`` S(0) = 0.
    """

    key: str
    label: str
    params: dict[str, float]
    sigma: dict[str, float | None]
    upper: float | None
    status: str
    delta_deviance: float
    coef: float
    shape: float | None
    derived: dict[str, float] = field(default_factory=dict)
    dominant_tau: tuple[float, float] | None = None
    bi_f0: float | None = None
    design_effect: float = 1.0
    notes: list[str] = field(default_factory=list)
    carry_edf: float | None = None
    #: why the status is what it is when a rule beyond the likelihood-ratio test set it
    #: (e.g. "spike-driven": identified only because of flagged spikes)
    status_note: str = ""
    #: what the fitted table measures: "rate" (gyro, IEEE 952) or "acceleration" (IEEE 1293)
    quantity: str = "rate"

    @property
    def registry(self) -> str:
        return REGISTRY[self.key]

    @property
    def units(self) -> dict[str, str]:
        return dict(quantity_of(self.quantity).units[self.key])

    @property
    def title(self) -> str:
        return quantity_of(self.quantity).titles[self.key]

    @property
    def identified(self) -> bool:
        return self.status == "identified"

    @property
    def zero_dc_psd(self) -> bool:
        return self.key in ZERO_DC

    @property
    def main(self) -> str:
        """Name of the amplitude parameter (N, B, q_c, Omega0 …)."""
        return _MAIN[self.key]

    @property
    def value(self) -> float:
        """The amplitude parameter's value (point estimate)."""
        return self.params[self.main]

    def avar(self, tau) -> np.ndarray:
        """This term's Allan variance (deg/h)² at τ (s)."""
        t = np.asarray(tau, float)
        if self.coef <= 0:
            return np.zeros_like(t)
        return self.coef * _basis(self.key, t, self.shape, self.bi_f0)

    def psd(self, f, tau0: float) -> np.ndarray:
        """This term's two-sided rate PSD (deg/h)²/Hz at f > 0 (zero for ramp and sinusoid)."""
        return _component_psd(self.key, self.coef, self.shape, np.asarray(f, float), tau0,
                              self.bi_f0)

    def registry_params(self) -> dict[str, float]:
        """Parameters for :data:`gyrotest.noise.terms.TERMS` (reported units)."""
        p = dict(self.params)
        if self.key == "B":
            p.setdefault("f0", self.bi_f0 if self.bi_f0 is not None else math.inf)
        return p

    def text(self, digits: int = 3) -> str:
        """e.g. ``N = 0.01003 ± 0.00012 deg/sqrt(h)`` or ``R ≤ 0.0021 deg/h/h``."""
        u = self.units[self.main]
        if self.status == "not tested":
            return f"{self.main} ≈ {format_number(self.value, digits)} {u} (not tested)"
        if self.status != "identified":
            if self.upper is None:
                return f"{self.main} not identified (bound not computed) {u}"
            return f"{self.main} ≤ {format_number(self.upper, digits)} {u}"
        s = self.sigma.get(self.main)
        txt = f"{self.main} = {format_number(self.value, digits + 1)}"
        if s is not None and math.isfinite(s):
            txt += f" ± {format_number(s, 2)}"
        txt += f" {u}"
        for k in self.params:
            if k != self.main:
                sk = self.sigma.get(k)
                txt += f", {k} = {format_number(self.params[k], digits + 1)}"
                if sk is not None and math.isfinite(sk):
                    txt += f" ± {format_number(sk, 2)}"
                txt += f" {self.units[k]}"
        return txt

    def to_dict(self) -> dict[str, Any]:
        return {
            "key": self.key,
            "label": self.label,
            "title": self.title,
            "registry_key": self.registry,
            "status": self.status,
            "status_note": self.status_note,
            "params": dict(self.params),
            "units": self.units,
            "sigma": dict(self.sigma),
            "upper_95": self.upper,
            "display": self.text(),
            "delta_deviance": self.delta_deviance,
            "design_effect": self.design_effect,
            "carry_edf": self.carry_edf,
            "derived": dict(self.derived),
            "dominant_tau_s": list(self.dominant_tau) if self.dominant_tau else None,
            "zero_dc_psd": self.zero_dc_psd,
            "label_impact": "platform-benign / strapdown-critical" if self.zero_dc_psd else "",
            "internal": {"coef": self.coef, "shape": self.shape,
                         "bi_cutoff_hz": self.bi_f0},
            "notes": list(self.notes),
        }


@dataclass
class NoiseFit:
    """A joint noise-model fit (see the module docstring for the method).

    Arrays ``tau``, ``sigma``, ``sigma_lo``, ``sigma_hi``, ``edf`` cover the whole deviation
    table; ``used`` marks the τ that entered the fit. Goodness of fit: ``deviance`` = ``chi2`` =
    the objective L = Σ (y − ln s)²/v at its minimum (−2 log-likelihood; ≈ Σ[(s − σ̂²)/δ]²,
    module docstring), ``dof`` (used τ − free
    parameters), ``chi2_dof``; ``n_eff`` = n²/Σρ (effective number of independent τ) and
    ``design_effect`` = n/n_eff from the model-implied correlation ``corr`` of the estimates;
    ``p_value`` of χ² against a Satterthwaite-scaled χ² (scale tr(ρ²)/n); ``aic``/``bic`` =
    deviance/design_effect + 2k / + k ln n_eff. ``cov``: sandwich covariance of the active
    coefficients and log shapes (``cov_labels``).
    """

    terms: list[FitTerm]
    requested: list[str]
    tau: np.ndarray
    sigma: np.ndarray
    sigma_lo: np.ndarray
    sigma_hi: np.ndarray
    edf: np.ndarray
    used: np.ndarray
    deviance: float
    chi2: float
    dof: int
    n_free: int
    n_eff: float
    satterthwaite: float
    tau0: float
    bi_f0: float | None = None
    min_edf: float = MIN_EDF
    notes: list[str] = field(default_factory=list)
    cov: np.ndarray | None = None
    cov_labels: list[str] = field(default_factory=list)
    #: "rate" (a gyro's Allan table, σ in deg/h) or "acceleration" (σ in m/s²)
    quantity: str = "rate"

    @property
    def q(self) -> Quantity:
        """The :class:`~gyrotest.noise.quantity.Quantity` of the table (units, scales)."""
        return quantity_of(self.quantity)

    # ---- evaluation ---------------------------------------------------------------------
    def model_avar(self, tau=None) -> np.ndarray:
        """σ²_model(τ) in (deg/h)², τ in s (default: the table's τ)."""
        t = self.tau if tau is None else np.asarray(tau, float)
        out = np.zeros_like(t, dtype=float)
        for term in self.terms:
            out = out + term.avar(t)
        return out

    def model_sigma(self, tau=None) -> np.ndarray:
        """σ_model(τ) = √(Σ c_j g_j(τ)) in deg/h (IEEE 952 Annex C mixture, Krobka (Allan-graph topology) eq. 5.9)."""
        return np.sqrt(self.model_avar(tau))

    def component_avar(self, tau=None) -> dict[str, np.ndarray]:
        """Each term's Allan variance c_j g_j(τ), (deg/h)², keyed by label."""
        t = self.tau if tau is None else np.asarray(tau, float)
        return {term.label: term.avar(t) for term in self.terms}

    def predict_avar(self, tau, *, conservative: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """σ²_model(τ) at any τ (s), (deg/h)², with its 1σ uncertainty from the sandwich
        covariance of the coefficients (delta method: var = ∇ᵀ Σ ∇, ∇ = ∂σ²/∂(c, ln shape)).

        Use it to extrapolate, e.g. the variance of a mean over a record of length T is
        σ²_A(T) for white, Markov (T ≫ T_c) and random-walk rate noise (IEEE 952 Annex C): the
        bias uncertainty of :mod:`gyrotest.staticbias.analysis` is ``sqrt(predict_avar(T)[0])``. With
        ``conservative`` the terms that are upper bounds only add their bound (no variance)."""
        t = np.atleast_1d(np.asarray(tau, float))
        val = self.model_avar(t)
        var = np.zeros_like(t)
        if self.cov is not None and self.cov_labels:
            grads = []
            for lab in self.cov_labels:
                kind, name = lab.split(":", 1)
                term = next(tt for tt in self.terms if tt.label == name)
                g = _basis(term.key, t, term.shape, term.bi_f0)
                if kind == "c":
                    grads.append(g)
                else:
                    h = 1e-4
                    gp = _basis(term.key, t, term.shape * math.exp(h), term.bi_f0)
                    gm = _basis(term.key, t, term.shape * math.exp(-h), term.bi_f0)
                    grads.append(term.coef * (gp - gm) / (2 * h))
            D = np.array(grads)  # (p, n)
            var = np.einsum("in,ij,jn->n", D, self.cov, D)
        if conservative:
            from .impact import _coef_from_value

            for term in self.terms:
                if not term.identified and term.upper and term.key in LINEAR_KEYS:
                    cu = _coef_from_value(term.key, term.upper, term.shape, self.q)
                    val = val + max(cu - term.coef, 0.0) * _basis(term.key, t, None, term.bi_f0)
        return val, np.sqrt(np.maximum(var, 0.0))

    def psd(self, f) -> np.ndarray:
        """Two-sided rate PSD of the model (deg/h)²/Hz; deterministic terms excluded."""
        f = np.asarray(f, float)
        out = np.zeros_like(f)
        for t in self.terms:
            out = out + t.psd(f, self.tau0)
        return out

    def residuals(self) -> np.ndarray:
        """Residual per τ of the table in CI units (:func:`ci_residuals`)."""
        return ci_residuals(self.sigma, self.sigma_lo, self.sigma_hi, self.model_sigma())

    def term(self, label: str) -> FitTerm | None:
        """The term with this label (e.g. "markov[2]") or key (first match), or None."""
        for t in self.terms:
            if t.label == label or (t.key == label and label != "markov"):
                return t
        for t in self.terms:
            if t.key == label:
                return t
        return None

    # ---- statistics ---------------------------------------------------------------------
    @property
    def n_used(self) -> int:
        """Number of τ that entered the fit."""
        return int(np.count_nonzero(self.used))

    @property
    def design_effect(self) -> float:
        """n/n_eff ≥ 1: variance inflation of a mean over the correlated τ (Kish)."""
        return max(self.n_used / self.n_eff, 1.0)

    @property
    def chi2_dof(self) -> float:
        """χ²/dof = L/(n − k) with the EDF-based variances of ln σ̂² (≈ 1 for a good model)."""
        return self.chi2 / self.dof if self.dof > 0 else math.nan

    @property
    def p_value(self) -> float:
        """P(χ² ≥ observed) with the Satterthwaite approximation for correlated terms:
        χ² ~ a·χ²_{(n−k)/a}, a = tr(ρ²)/n (Satterthwaite 1946)."""
        a = max(self.satterthwaite, 1.0)
        d = self.dof / a
        if d <= 0:
            return math.nan
        return float(special.chdtrc(d, self.chi2 / a))  # χ² survival

    @property
    def aic(self) -> float:
        """Akaike: L/design_effect + 2k (k free parameters)."""
        return self.deviance / self.design_effect + 2.0 * self.n_free

    @property
    def bic(self) -> float:
        """Schwarz: L/design_effect + k·ln n_eff."""
        return self.deviance / self.design_effect + self.n_free * math.log(max(self.n_eff, 2.0))

    @property
    def fit_range(self) -> tuple[float, float]:
        """(τ_min, τ_max) of the fitted τ, s."""
        t = self.tau[self.used]
        return float(t.min()), float(t.max())

    @property
    def consistent(self) -> bool:
        """χ² test passes (p ≥ 0.01) and no two adjacent fitted τ are beyond 3 CI units."""
        r = self.residuals()[self.used]
        big = np.abs(r) > 3.0
        run = bool(np.any(big[1:] & big[:-1])) if big.size > 1 else bool(big.any())
        return (not math.isfinite(self.p_value) or self.p_value >= 0.01) and not run

    def label_string(self) -> str:
        """The fitted terms' labels, comma-separated (for --terms)."""
        return ",".join(t.label for t in self.terms)

    def to_dict(self) -> dict[str, Any]:
        r = self.residuals()
        lo, hi = self.fit_range
        return {
            "quantity": self.quantity,
            "terms_requested": list(self.requested),
            "method": FIT_METHOD,
            "uncertainty_method": UNCERTAINTY_METHOD,
            "status_rule": STATUS_RULE,
            "bias_instability_shape": (
                "IEEE 952 flat level (2 ln2/pi) B^2" if self.bi_f0 is None
                else f"full eq. 5.3 template with cut-off f0 = {self.bi_f0:g} Hz"),
            "fit_range_s": [lo, hi],
            "min_edf": self.min_edf,
            "excluded_tau_s": [float(t) for t in self.tau[~self.used]],
            "n_tau_used": self.n_used,
            "n_free_params": self.n_free,
            "n_eff": self.n_eff,
            "design_effect": self.design_effect,
            "satterthwaite_scale": self.satterthwaite,
            "deviance": self.deviance,
            "chi2": self.chi2,
            "dof": self.dof,
            "chi2_per_dof": self.chi2_dof,
            "p_value": self.p_value,
            "aic": self.aic,
            "bic": self.bic,
            "consistent": self.consistent,
            "terms": [t.to_dict() for t in self.terms],
            "model_sigma": self.model_sigma().tolist(),
            "components_sigma": {k: np.sqrt(v).tolist() for k, v in self.component_avar().items()},
            "residual_ci": [None if not math.isfinite(v) else float(v) for v in r],
            "notes": list(self.notes),
        }


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


#: noise-identification methods that rest on few averages (B1 ratio, or an α reused from a
#: shorter τ): an angle-noise α > 0 from them is not trusted for the EDF
_WEAK_ID = ("b1", "b1+rn", "reused")


def fit_alpha(dev) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """(α, EDF, methods) the noise-model fit starts from: the deviation's statistical
    identification (``alpha_fit``, ``edf_fit``) when it carries one, else its printed α/EDF."""
    if getattr(dev, "alpha_fit", None) is not None and getattr(dev, "edf_fit", None) is not None:
        return (np.asarray(dev.alpha_fit, int), np.asarray(dev.edf_fit, float),
                list(dev.alpha_fit_method or []) or [""] * len(dev.alpha_fit))
    methods = list(getattr(dev, "alpha_method", [])) or [""] * len(dev.edf)
    return np.asarray(dev.alpha, int), np.asarray(dev.edf, float), methods


def _n_averages(segs, m: int) -> int:
    """Non-overlapping m-sample averages over the segments: the points of a noise
    identification at averaging factor m."""
    return int(sum((b - a) // max(m, 1) for a, b in segs))


def robust_edf(dev) -> tuple[np.ndarray, list[str]]:
    """(edf, notes) of :func:`robust_edf_rules`."""
    e, _, notes = robust_edf_rules(dev)
    return e, notes


def robust_edf_rules(dev) -> tuple[np.ndarray, list[str], list[str]]:
    """The EDF of a deviation table made safe for fitting and for the residuals.

    1. Where the noise type was identified from few averages (B1 ratio or reused, typically the
       longest τ, or the lag-1 ACF from fewer than
       :data:`~gyrotest.noise.edf.ACF_DECISIVE_POINTS` points; Riley & Greenhall 2004) and
       came out as angle noise (α > 0), the EDF is capped
       at the white-rate (α = 0) value: an α = +1 at τ = T/10 gives a Greenhall EDF ~10× too
       large when the estimate is really a scattered rate-random-walk point.
    2. :func:`sanitize_edf`: non-increasing in τ.

    The starting point is the statistical identification (``dev.alpha_fit``/``dev.edf_fit``,
    B1 theory at the number of averages) where the table carries one, else the table's α/EDF.

    Returns (edf, rules, notes): ``rules[i]`` is "" (the identified α's EDF), "white-rate cap"
    or "running minimum"."""
    from .edf import ACF_DECISIVE_POINTS, edf_for

    alpha, e, methods = fit_alpha(dev)
    e = e.copy()
    notes: list[str] = []
    segs = getattr(dev, "segments", None) or [(0, int(getattr(dev, "n_samples", 0)))]
    n_longest = max(b - a for a, b in segs) + (0 if dev.input_kind == "angle" else 1)
    kind = "mdev" if dev.kind == "tdev" else dev.kind
    capped = []
    for i, (a, meth) in enumerate(zip(alpha, methods)):
        weak = meth in _WEAK_ID or (meth == "acf" and _n_averages(segs, int(dev.m[i]))
                                    < ACF_DECISIVE_POINTS)
        if a > 0 and weak and math.isfinite(e[i]) and n_longest > 1:
            try:
                cap, _ = edf_for(kind, 0, int(dev.m[i]), n_longest)
            except (InputError, AnalysisError):
                continue
            if cap < e[i]:
                e[i] = cap
                capped.append(float(dev.tau[i]))
    if capped:
        notes.append("EDF capped at the white-rate value at τ = "
                     + ", ".join(f"{t:.4g}" for t in capped)
                     + " s (angle-noise type identified from too few averages to be decisive)")
    e2, changed = sanitize_edf(e)
    if changed:
        notes.append("EDF lowered to the running minimum at τ = "
                     + ", ".join(f"{dev.tau[i]:.4g}" for i in changed) + " s")
    rules = ["white-rate cap" if float(t) in capped else "" for t in np.asarray(dev.tau)]
    for i in changed:
        rules[i] = "running minimum"
    return e2, rules, notes


def table_quantity(dev) -> str:
    """"acceleration" for a deviation table in m/s² (an accelerometer), else "rate"."""
    return "acceleration" if str(getattr(dev, "unit", "")) == ACCEL.sigma_unit else "rate"


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


# ---------------------------------------------------------------------------------------------
# Classic read-offs and unit conversions
# ---------------------------------------------------------------------------------------------


#: family-wise level of Krobka's white-noise bound N_upper (:func:`slope_readoffs`)
N_UPPER_LEVEL = 0.95


def n_upper_bound(tau, sigma, edf, *, level: float = N_UPPER_LEVEL) -> tuple[float, float, int]:
    """Krobka's bound on white rate noise as a statistical upper limit: (N_upper deg/√h, the τ
    that sets it, the number of τ it was taken over).

    White rate noise N adds N²/τ to the Allan variance of any mixture of independent noises
    (Krobka (Allan-graph topology) eq. 5.9), so σ²(τ) ≥ N²/τ at every τ: the −½ ray through the
    leftmost point, lowered until it touches the graph. Read on the estimates σ̂(τ) this
    construction is biased low (at long τ a few clusters scatter σ̂ far below σ), so each
    σ̂(τ) is replaced by its one-sided upper confidence limit σ_U(τ) = σ̂·√(ν/χ²_ν(α/k)) from
    its EDF ν (σ̂²ν/σ² ~ χ²_ν, NIST SP1065 §5.3), at the Bonferroni level α/k over the k τ
    with an EDF: all k limits hold together with probability ≥ ``level`` = 1 − α, hence

        N_upper = min_τ σ_U(τ)·√τ / 60   deg/√h (σ in deg/h, τ in s)

    is an upper bound of N at that confidence. Without EDF it is the graph reading
    min σ̂√τ/60."""
    t = np.asarray(tau, float)
    s = np.asarray(sigma, float)
    ok = np.isfinite(t) & np.isfinite(s) & (s > 0) & (t > 0)
    if edf is None:
        v = np.where(ok, s * np.sqrt(t), np.inf)
        i = int(np.argmin(v))
        return float(v[i] / 60.0), float(t[i]), int(np.count_nonzero(ok))
    e = np.asarray(edf, float)
    ok &= np.isfinite(e) & (e > 0)
    k = int(np.count_nonzero(ok))
    if k == 0:
        return math.nan, math.nan, 0
    q = (1.0 - level) / k
    with np.errstate(invalid="ignore", divide="ignore"):
        chi = special.chdtri(np.where(ok, e, 1.0), 1.0 - q)  # lower q-quantile of χ²_ν
        s_up = s * np.sqrt(np.where(ok, e, 1.0) / chi)
    v = np.where(ok & np.isfinite(s_up), s_up * np.sqrt(t), np.inf)
    i = int(np.argmin(v))
    return float(v[i] / 60.0), float(t[i]), k


def slope_readoffs(tau, sigma, edf=None, *, min_edf: float = 10.0,
                   quantity: str = "rate") -> dict[str, Any]:
    """The slope-line read-offs other tools report, for comparison (not fits).

    Local log–log slope by central differences (MATLAB "allanvar" example; allan_variance_ros),
    searched only where the EDF ≥ ``min_edf`` (noisy slopes at long τ would otherwise win):

    * ``N_slope`` = σ(τ_i)·√τ_i/60 deg/√h at the point whose slope is closest to −½ (the −½ line
      through it read at τ = 1 s, /60 for deg/√h; IEEE 952 Annex C);
    * ``K_slope`` = 60·σ(τ_i)·√(3/τ_i) deg/h/√h at the slope closest to +½ (line read at τ = 3 s);
    * ``B_slope`` = σ(τ_i)/0.6643 deg/h at the slope closest to 0;
    * ``N_upper``: Krobka's bound on white rate noise, the −½ ray through the leftmost
      point lowered until it touches the graph (Krobka (Allan-graph topology) §5, rule 5),
      taken on the upper 95 % confidence limits of σ̂ (family-wise over the τ, from ``edf``;
      :func:`n_upper_bound`), so that it is an upper bound of N at 95 %; ``N_upper_graph`` =
      min σ̂√τ/60, the same construction on the estimates (biased low where few clusters
      scatter σ̂);
    * ``B_tangent`` = σ_min/0.6643 deg/h: the zero-slope tangent at the minimum with the
      IEEE factor (an upper bound in a mixture; Krobka (Allan-graph topology) M3/M4); ``allan_floor`` = σ_min and
      its τ (what tools that omit 0.664 report as B).

    The formulas are the gyro's (σ in deg/h); an accelerometer table (``quantity``
    "acceleration", σ in m/s²) gets N, K in its units and B in µg
    (:mod:`gyrotest.noise.quantity`).
    """
    q = quantity_of(quantity)
    fN, fK, fB = q.factor("N"), q.factor("K"), q.factor("B")
    t = np.asarray(tau, float)
    s = np.asarray(sigma, float)
    ok = np.isfinite(s) & (s > 0)
    e = np.full(t.shape, np.inf) if edf is None else np.asarray(edf, float)
    t, s, e = t[ok], s[ok], e[ok]
    out: dict[str, Any] = {"method": "slope-line read-offs (MATLAB allanvar example style, slopes "
                           f"only where EDF >= {min_edf:g}) and Krobka bounds; for comparison "
                           "only"}
    if t.size < 3:
        return out
    lt, ls = np.log(t), np.log(s)
    slope = np.gradient(ls, lt)
    rel = e >= min_edf
    if np.count_nonzero(rel) < 3:
        rel = np.ones_like(rel)
    big = np.where(rel, 0.0, np.inf)
    iN = int(np.argmin(np.abs(slope + 0.5) + big))
    iK = int(np.argmin(np.abs(slope - 0.5) + big))
    iB = int(np.argmin(np.abs(slope) + big))
    imin = int(np.argmin(s))
    n_graph, t_graph, _ = n_upper_bound(t, s, None)
    n_up, t_up, k_up = n_upper_bound(t, s, None if edf is None else e)
    out.update({
        "N_slope": float(s[iN] * math.sqrt(t[iN]) / 60.0) * fN, "N_slope_tau_s": float(t[iN]),
        "N_slope_local_slope": float(slope[iN]),
        "K_slope": float(60.0 * s[iK] * math.sqrt(3.0 / t[iK])) * fK,
        "K_slope_tau_s": float(t[iK]),
        "K_slope_local_slope": float(slope[iK]),
        "B_slope": float(s[iB] / BIAS_INSTABILITY_PLATEAU) * fB, "B_slope_tau_s": float(t[iB]),
        "N_upper": n_up * fN, "N_upper_tau_s": t_up,
        "N_upper_rule": (f"min over {k_up} τ of the one-sided upper confidence limit of σ (EDF, "
                         f"χ², Bonferroni) × √τ/60: {100 * N_UPPER_LEVEL:g} % upper bound of N"
                         if edf is not None else "min σ√τ/60 (graph reading, no EDF)"),
        "N_upper_graph": n_graph * fN, "N_upper_graph_tau_s": t_graph,
        "N_leftmost": float(s[0] * math.sqrt(t[0]) / 60.0) * fN, "leftmost_tau_s": float(t[0]),
        "B_tangent": float(s[imin] / BIAS_INSTABILITY_PLATEAU) * fB,
        "allan_floor": float(s[imin]), "allan_floor_tau_s": float(t[imin]),
        "units": {"N": q.unit("N"), "K": q.unit("K"), "B": q.unit("B"),
                  "allan_floor": q.sigma_unit},
    })
    if q is RATE:
        out["allan_floor_dph"] = out["allan_floor"]
    else:
        out["allan_floor_m_s2"] = out["allan_floor"]
    return out


_D2R = math.pi / 180.0


def conversions(fit: NoiseFit) -> dict[str, Any]:
    """Coefficients in the units and names of other tools (continuous-time convention).

    * N: deg/√h → deg/s/√Hz = N/60; rad/s/√Hz = N/60·π/180 (N_int/3600 deg/s·√s). Discrete
      per-sample σ at the log rate: N_c/√τ0 (Kalibr: σ_gd = σ_g/√Δt).
    * K: deg/h/√h → (deg/s)·√Hz = K/(60·3600); rad/s²/√Hz likewise ×π/180. Discrete per-sample
      bias-walk σ: K_c·√τ0 (Kalibr σ_bgd = σ_bg·√Δt).
    * B: deg/h → deg/s = B/3600, rad/s.
    * Kalibr ``gyroscope_noise_density`` = N [rad/s/√Hz], ``gyroscope_random_walk`` = K
      [rad/s²/√Hz] (ethz-asl/kalibr wiki "IMU-Noise-Model"); MATLAB ``gyroparams``
      ``NoiseDensity`` = N [(rad/s)/√Hz], ``BiasInstability`` = B [rad/s] (IEEE B, i.e. the
      floor/0.664), ``RandomWalk`` = K [(rad/s)·√Hz]. All are continuous-time densities of the
      two-sided IEEE PSD (white S = N²); upper-bound terms are exported at their bound.
    """
    def val(key):
        t = fit.term(key)
        if t is None:
            return None, None
        return (t.value if t.identified else t.upper), t.status

    if fit.quantity == "acceleration":
        return _accel_conversions(fit, val)
    N, Ns = val("N")
    K, Ks = val("K")
    B, Bs = val("B")
    tau0 = fit.tau0
    out: dict[str, Any] = {"convention": "continuous-time densities (two-sided IEEE 952 PSD: "
                           "white rate S = N^2); discrete per-sample sigma = density/sqrt(tau0) "
                           "for white noise, density*sqrt(tau0) for the bias random walk",
                           "tau0_s": tau0}
    if N is not None:
        nd = N / 60.0
        out["N"] = {"status": Ns, "deg_per_rt_h": N, "deg_s_per_rt_hz": nd,
                    "rad_s_per_rt_hz": nd * _D2R,
                    "discrete_sigma_deg_s": nd / math.sqrt(tau0),
                    "discrete_sigma_rad_s": nd * _D2R / math.sqrt(tau0)}
    if K is not None:
        kd = K / (60.0 * 3600.0)
        out["K"] = {"status": Ks, "deg_h_per_rt_h": K, "deg_s2_per_rt_hz": kd,
                    "rad_s2_per_rt_hz": kd * _D2R,
                    "discrete_sigma_rad_s": kd * _D2R * math.sqrt(tau0)}
    if B is not None:
        out["B"] = {"status": Bs, "deg_h": B, "deg_s": B / 3600.0, "rad_s": B / 3600.0 * _D2R}
    out["kalibr"] = {
        "gyroscope_noise_density": None if N is None else N / 60.0 * _D2R,
        "gyroscope_random_walk": None if K is None else K / (60.0 * 3600.0) * _D2R,
        "units": {"gyroscope_noise_density": "rad/s/sqrt(Hz)",
                  "gyroscope_random_walk": "rad/s^2/sqrt(Hz)"},
        "note": "Kalibr's update_rate must be the log rate 1/tau0; it derives the discrete "
                "sigma itself. The maintainers suggest inflating these for unmodelled effects.",
    }
    out["matlab_gyroparams"] = {
        "NoiseDensity": None if N is None else N / 60.0 * _D2R,
        "BiasInstability": None if B is None else B / 3600.0 * _D2R,
        "RandomWalk": None if K is None else K / (60.0 * 3600.0) * _D2R,
        "units": {"NoiseDensity": "(rad/s)/sqrt(Hz)", "BiasInstability": "rad/s",
                  "RandomWalk": "(rad/s)*sqrt(Hz)"},
    }
    return out


def _accel_conversions(fit: NoiseFit, val) -> dict[str, Any]:
    """:func:`conversions` of an accelerometer table (IEEE Std 1293 terms; N = VRW in m/s/√h,
    B in µg, K = acceleration random walk in m/s/h/√h):

    * VRW → m/s²/√Hz = N/60 (1 m/s/√h = 1/60 m/s/√s, and m/s/√s = (m/s²)/√Hz), µg/√Hz =
      that / 9.80665e-6; Kalibr ``accelerometer_noise_density`` (m/s²/√Hz), MATLAB
      ``accelparams.NoiseDensity`` ((m/s²)/√Hz); discrete per-sample σ = density/√τ0.
    * K → m/s³/√Hz = K/216000 (1 m/s/h/√h = 1/(3600·60) m/s²/√s); Kalibr
      ``accelerometer_random_walk`` (m/s³/√Hz), MATLAB ``accelparams.RandomWalk``
      ((m/s²)·√Hz); µg/√h = K/3600·60/9.80665e-6… as m/s²/√h: K/3600.
    * B (µg) → m/s² (MATLAB ``accelparams.BiasInstability``, IEEE B, the flat level/0.664).
    """
    from ..core.units import G0

    ug = G0 * 1e-6
    N, Ns = val("N")
    K, Ks = val("K")
    B, Bs = val("B")
    tau0 = fit.tau0
    out: dict[str, Any] = {"quantity": "acceleration",
                           "convention": "continuous-time densities (two-sided PSD: white "
                           "acceleration S = VRW^2); discrete per-sample sigma = "
                           "density/sqrt(tau0) for white noise, density*sqrt(tau0) for the "
                           "bias random walk", "tau0_s": tau0}
    if N is not None:
        nd = N / 60.0
        out["N"] = {"status": Ns, "m_s_per_rt_h": N, "m_s2_per_rt_hz": nd,
                    "ug_per_rt_hz": nd / ug, "discrete_sigma_m_s2": nd / math.sqrt(tau0)}
    if K is not None:
        kd = K / 216000.0
        out["K"] = {"status": Ks, "m_s_per_h_rt_h": K, "m_s3_per_rt_hz": kd,
                    "ug_per_rt_h": K / 3600.0 / ug,
                    "discrete_sigma_m_s2": kd * math.sqrt(tau0)}
    if B is not None:
        out["B"] = {"status": Bs, "ug": B, "m_s2": B * ug}
    out["kalibr"] = {
        "accelerometer_noise_density": None if N is None else N / 60.0,
        "accelerometer_random_walk": None if K is None else K / 216000.0,
        "units": {"accelerometer_noise_density": "m/s^2/sqrt(Hz)",
                  "accelerometer_random_walk": "m/s^3/sqrt(Hz)"},
        "note": "Kalibr's update_rate must be the log rate 1/tau0; it derives the discrete "
                "sigma itself. The maintainers suggest inflating these for unmodelled effects.",
    }
    out["matlab_accelparams"] = {
        "NoiseDensity": None if N is None else N / 60.0,
        "BiasInstability": None if B is None else B * ug,
        "RandomWalk": None if K is None else K / 216000.0,
        "units": {"NoiseDensity": "(m/s^2)/sqrt(Hz)", "BiasInstability": "m/s^2",
                  "RandomWalk": "(m/s^2)*sqrt(Hz)"},
    }
    return out
