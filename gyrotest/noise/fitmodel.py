"""The model the joint noise fit (:mod:`.noisefit`) fits, and its statistics: the term keys and
their basis functions g(τ) and component PSDs, the log-χ² likelihood of Allan-variance
estimates given their EDF, the model-implied correlation of those estimates, and the methods
in words that every fit result quotes. The formulas are in :mod:`.noisefit`'s docstring."""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence

import numpy as np
from scipy import special

from ..core.errors import AnalysisError, InputError
from . import kinds as _kinds
from .quantity import ACCEL
from .terms import (
    BIAS_INSTABILITY_PLATEAU,
    blue_markov_derivative_avar,
    markov_avar,
    sinusoid_avar,
)
from .terms import (
    bias_instability_avar as _bi_template,
)

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
