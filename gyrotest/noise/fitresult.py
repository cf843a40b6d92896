"""The result types of the joint noise fit (:mod:`.noisefit`): one :class:`FitTerm` per noise term
(its coefficient, the reported value in the data-sheet unit, 1σ, identification status) and the
:class:`NoiseFit` of a whole deviation (terms, covariance, goodness of fit, notes), with their
JSON form."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import special

from ..core.units import format_number
from .fitmodel import (
    FIT_METHOD,
    LINEAR_KEYS,
    MIN_EDF,
    REGISTRY,
    STATUS_RULE,
    UNCERTAINTY_METHOD,
    ZERO_DC,
    _basis,
    _component_psd,
    ci_residuals,
)
from .quantity import RATE, Quantity, quantity_of
from .terms import (
    BIAS_INSTABILITY_PLATEAU,
)

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
