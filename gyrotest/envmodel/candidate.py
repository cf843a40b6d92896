"""One candidate term of the workbench diagnosis (:mod:`gyrotest.envmodel.diagnose`) and the
helpers that compare candidates: the fold-to-fold scatter of a held-out gain, a term's
fitted contribution, its correlation with the base residual, and the candidates this log
cannot tell apart from the chosen one."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import numpy as np

from . import stats as st
from .chance import ChanceTest
from .fit import FitResult, WorkData
from .terms import TermSpec

#: candidates whose fitted contributions correlate at least this well are indistinguishable
EQUIVALENT_R = 0.995


@dataclass
class Candidate:
    """One candidate term and how much it helps."""

    term: str
    effect: str
    replaces: str | None
    rms_fit: float
    rms_holdout: float
    improvement_pct: float
    z: float
    p: float
    p_adj: float
    trials: int
    significant: bool
    coefficients: list[dict] = field(default_factory=list)
    n_params: int = 0
    spec: TermSpec | None = None
    error: str | None = None
    klass: str = "library"
    route: str | None = None  # strict | clear gain
    gain_scatter_pct: float = math.nan  # fold-to-fold scatter (sd over folds) of the gain
    rejected: str | None = None
    equivalents: list[str] = field(default_factory=list)
    custom: str | None = None  # the --term NAME:EXPR equivalent
    r_residual: float = math.nan  # correlation of its contribution with the base residual
    #: a sinusoid's period is that of these logged stimuli: [(channel or 'name²', R²)]
    period_match: list[tuple[str, float]] | None = None
    note: str | None = None
    #: named through a pair: (the other member, the pair's held-out RMS deg/h, consistency)
    pair: tuple[str, float, float] | None = None
    #: ... instead of this single term: (term, its held-out RMS deg/h)
    displaced: tuple[str, float] | None = None
    cv_t: float = math.nan  # gain / (fold scatter / √folds)
    spectral_z: float = math.nan  # Whittle z of its coefficients (weak routes only)
    hac_waived: bool = False  # qualified far above the floor on its spectral z, not HAC z
    #: its best partner in the step after it, when a lookahead fitted them: (held-out RMS
    #: deg/h, the partner's term)
    lookahead: tuple[float, str] | None = None
    #: a lag chosen for the step after it (:func:`gyrotest.envmodel.pairs.lag_or_plain`):
    #: its time constant fitted beside that partner, s (alone it may sit at the bottom of
    #: its range while the partner's effect is missing)
    pair_tau_s: float = math.nan
    #: the look-elsewhere surrogate test of a chosen nuisance term
    #: (:class:`gyrotest.envmodel.chance.ChanceTest`), when it was run
    chance: ChanceTest | None = None
    _fit: FitResult | None = None

    @property
    def p_trials(self) -> float:
        return min(1.0, self.p * self.trials) if math.isfinite(self.p) else math.nan

    @property
    def evidence(self) -> str:
        if self.error:
            return self.error
        z = f"z = {self.z:.1f}" if math.isfinite(self.z) else "z = n/a"
        sc = (f" ± {self.gain_scatter_pct:.1f} % fold scatter"
              if math.isfinite(self.gain_scatter_pct) else "")
        ev = (f"held-out {-self.improvement_pct:+.1f} %{sc}, {z} (HAC), "
              f"p_adj = {self.p_adj:.2g}" + (f" over {self.trials} trials"
                                             if self.trials > 1 else ""))
        if self.chance is not None:
            ev += f", surrogate p = {self.chance.p:.2f}"
        return ev

    @property
    def add_hint(self) -> str:
        """How to add it: ``--terms LABEL`` (and the custom ``--term`` equivalent)."""
        if self.spec is not None and self.spec.key == "custom":
            return f"--term '{self.spec.name}:{self.spec.expr}'"
        h = f"--terms '{self.term}'"
        if self.custom:
            h += f" (or --term '{self.custom}')"
        return h

    def to_dict(self) -> dict:
        return {"term": self.term, "effect": self.effect, "class": self.klass,
                "replaces": self.replaces,
                "rms_fit_dph": self.rms_fit, "rms_holdout_dph": self.rms_holdout,
                "improvement_pct": self.improvement_pct,
                "gain_fold_scatter_pct": self.gain_scatter_pct, "cv_t": self.cv_t,
                "spectral_z": self.spectral_z,
                "z": self.z, "p": self.p,
                "p_adj": self.p_adj, "trials": self.trials, "significant": self.significant,
                "route": self.route, "rejected": self.rejected,
                "chance": self.chance.to_dict() if self.chance is not None else None, "note": self.note,
                "equivalents": self.equivalents, "add": self.add_hint,
                "custom_term": self.custom, "r_residual": self.r_residual,
                "coefficients": self.coefficients, "n_params": self.n_params,
                "evidence": self.evidence, "error": self.error}


def uses_channel(spec: TermSpec, ch: str, frame) -> bool:
    """Does the term act through the logged channel ``ch``?"""
    if ch in spec.channels:
        return True
    if ch == "supply" and spec.key == "V":
        return True
    if spec.expr and re.search(rf"\b{re.escape(ch)}\b", spec.expr):
        return True
    return (not spec.channels and spec.key.startswith("H")
            and ch in getattr(frame, "field_uT", {}))


def gain_scatter(base: FitResult, r: FitResult) -> float:
    """Fold-to-fold scatter of the relative held-out gain: the standard deviation over the
    folds of 1 − rms_f/rms_base,f."""
    a = np.asarray(base.holdout_fold_rms, float)
    b = np.asarray(r.holdout_fold_rms, float)
    if len(a) != len(b) or len(a) < 2:
        return math.nan
    with np.errstate(divide="ignore", invalid="ignore"):
        g = 1.0 - b / a
    g = g[np.isfinite(g)]
    if len(g) < 2:
        return math.nan
    return float(np.std(g, ddof=1))


def held_out_gain(base: FitResult, r: FitResult, folds: int) -> tuple[float, float, float]:
    """The relative held-out gain of ``r`` over ``base``, its fold-to-fold scatter
    (:func:`gain_scatter`) and its fold consistency gain / (scatter/√folds) (∞ for a positive
    gain without scatter, 0 for none)."""
    gain = (base.rms_holdout - r.rms_holdout) / base.rms_holdout
    scatter = gain_scatter(base, r)
    t_cv = (gain * math.sqrt(folds) / scatter if math.isfinite(scatter) and scatter > 0
            else math.inf if gain > 0 else 0.0)
    return gain, scatter, t_cv


def contribution(r: FitResult, label: str) -> np.ndarray:
    from .fit import predict_blocks

    spec = next(s for s in r.specs if s.label == label)
    return predict_blocks(r, [spec])


def residual_corr(base: FitResult, r: FitResult, c: TermSpec) -> float:
    try:
        x = contribution(r, c.label)
    except (StopIteration, KeyError, ValueError):
        return math.nan
    e = base.resid
    if e is None or np.std(x) == 0 or np.std(e) == 0:
        return math.nan
    return float(np.corrcoef(x, e)[0, 1])


def own_contribution(c: Candidate) -> np.ndarray | None:
    """The candidate's fitted contribution in its own fit (block means, deg/h), or None."""
    if c._fit is None:
        return None
    try:
        return contribution(c._fit, c.term)
    except (StopIteration, KeyError, ValueError):
        return None


def abs_corr(x: np.ndarray | None, y: np.ndarray | None) -> float:
    """|r| of two contributions; NaN when either is missing or constant."""
    if x is None or y is None or not (np.std(x) > 0 and np.std(y) > 0):
        return math.nan
    return abs(float(np.corrcoef(x, y)[0, 1]))


def equivalents(chosen: Candidate, cands: list[Candidate], base: FitResult) -> list[str]:
    """Candidates with (nearly) the same held-out RMS whose fitted contribution is the
    chosen one's to |r| ≥ 0.995: explanations this log cannot tell apart."""
    x0 = own_contribution(chosen)
    if x0 is None:
        return []
    out = []
    for c in cands:
        if c is chosen or c._fit is None or not math.isfinite(c.rms_holdout):
            continue
        if not chosen.rms_holdout / 1.05 <= c.rms_holdout <= chosen.rms_holdout * 1.05:
            continue
        if abs_corr(own_contribution(c), x0) >= EQUIVALENT_R:
            out.append(c.term)
    return out


def with_terms(r: FitResult, wd: WorkData, keep: list[TermSpec] | None = None
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The design of the fitted model ``r`` with the blocks of the terms ``keep`` put back
    beside it (terms a candidate replaced), its least-squares coefficients and residual;
    without ``keep``, ``r``'s own."""
    X = r._fitter.X(r._thetas)  # type: ignore[attr-defined]
    if not keep:
        beta = np.array([cf.value for cf in r.coefficients if cf.kind == "linear"])
        return X, beta, r.resid
    d = r._fitter.d  # type: ignore[attr-defined]
    X = np.column_stack([X] + [d.block(s, None) for s in keep])
    beta, _ = st.lstsq(X, wd.y)
    return X, beta, wd.y - X @ beta


def spectral_z(r: FitResult, labels: list[str], wd: WorkData,
               keep: list[TermSpec] | None = None, red: bool = True) -> float:
    """Spectral (Whittle) z of the linear coefficients of the terms ``labels`` in the fitted
    model ``r``, against the spectrum of its own residual
    (:func:`gyrotest.envmodel.stats.whittle_z`).

    ``keep``: terms the candidate replaced in ``r``, put back beside it for the test
    (:func:`with_terms`). A lagged core temperature replaces the plain sensor temperature;
    its coefficient then carries the whole temperature effect the model already had, and
    only what T_core explains beyond T is evidence of a lag (the HAC test does the same).

    ``red``: the low-frequency floor of a red residual
    (:func:`gyrotest.envmodel.stats.red_floor`); False near the noise floor, where the
    residual is white/flicker noise and the bar is lower
    (:func:`gyrotest.envmodel.rules.spectral_bar`)."""
    idx = [i for i, cf in enumerate(r.coefficients) if cf.term in labels and cf.kind == "linear"]
    try:
        X, _, e = with_terms(r, wd, keep)
        return st.whittle_z(X, wd.y, e, idx, red=red)
    except (np.linalg.LinAlgError, ValueError):
        return math.nan


def kept_terms(c: TermSpec, replaces: str | None) -> list[TermSpec] | None:
    """The plain sensor temperature a lagged core temperature replaced, to be put back beside
    it when its coefficient is tested (a lag effect means T_core explains what T does not);
    None for every other candidate."""
    return [TermSpec("T", c.channels)] if c.key == "Tlag" and replaces else None


def significance(r: FitResult, c: TermSpec, replaces: str | None, wd: WorkData
                 ) -> tuple[float, float]:
    """HAC Wald test of the candidate's added coefficient(s) in the fitted candidate model
    (with a replaced plain temperature put back, :func:`kept_terms`), against a t/F reference
    with the effective degrees of freedom of the added regressor(s)
    (:func:`gyrotest.envmodel.stats.effective_df`)."""
    keep = kept_terms(c, replaces)
    idx = [i for i, cf in enumerate(r.coefficients) if cf.term == c.label and cf.kind == "linear"]
    X, beta, e = with_terms(r, wd, keep)
    if keep is None:
        cov = r.cov[np.ix_(idx, idx)]
    else:
        cov, _ = st.hac_covariance(X, e)
        cov = cov[np.ix_(idx, idx)]
    df = st.effective_df(X, idx, st.integrated_time(e))
    _, p, z = st.wald_t(beta[idx], cov, df)
    return z, p


__all__ = ["Candidate", "EQUIVALENT_R", "contribution", "equivalents", "gain_scatter",
           "held_out_gain", "kept_terms", "residual_corr", "significance", "spectral_z", "uses_channel",
           "with_terms"]
