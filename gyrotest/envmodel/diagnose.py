"""Which physical effect is the model missing?

Every library term the log's channels allow and the model lacks is tried in turn (a lagged
temperature *replaces* the plain temperature of the same sensor when the model has one: the
core lags the sensor). Each candidate model is scored by

1. **held-out residual RMS** (blocked cross-validation, nonlinear parameters re-fitted per fold,
   see :func:`gyrotest.envmodel.fit.holdout_folds`): what matters is prediction of data the fit
   did not see, so a term that only follows noise does not help;
2. **significance robust to autocorrelation**: a HAC Wald test of the added coefficient(s)
   (for a lag replacement: of T_core(τ̂) in a model that keeps T), referred to a t/F
   distribution with the regressor's effective degrees of freedom (a transient that lives in a
   few blocks cannot be "significant" on the strength of 10⁴ blocks), the p-value multiplied
   by the number of candidates and by the effective number of trials of a searched nonlinear
   parameter (ln(τ_max/τ_min) for a time constant, (f_max − f_min)·T for a frequency):
   p_adj = min(1, p · M · n_candidates).

Ranking is by held-out RMS with a small complexity penalty, RMS_ho · (1 + p/n_blocks). A
candidate counts as a **missing effect** when p_adj < α (0.001) and it lowers the held-out RMS
by at least 1 %. With none, the verdict compares the held-out residual with the Allan-predicted
noise floor (white + flicker level of the residual at the working resolution, see
:func:`gyrotest.envmodel.stats.noise_floor`) and says "no missing effect found".
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import AnalysisError, InputError
from . import stats as st
from .fit import FitResult, WorkData, fit_model
from .prepare import prepare_log
from .terms import TermSpec, candidate_terms, describe, nonlinear_bounds, parse_terms, resolve_terms

ALPHA = 0.001
MIN_IMPROVEMENT = 0.01


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

    @property
    def evidence(self) -> str:
        if self.error:
            return self.error
        z = f"z = {self.z:.1f}" if math.isfinite(self.z) else "z = n/a"
        return (f"held-out {-self.improvement_pct:+.1f} %, {z} (HAC), "
                f"p_adj = {self.p_adj:.2g}" + (f" over {self.trials} trials"
                                               if self.trials > 1 else ""))

    def to_dict(self) -> dict:
        return {"term": self.term, "effect": self.effect, "replaces": self.replaces,
                "rms_fit_dph": self.rms_fit, "rms_holdout_dph": self.rms_holdout,
                "improvement_pct": self.improvement_pct, "z": self.z, "p": self.p,
                "p_adj": self.p_adj, "trials": self.trials, "significant": self.significant,
                "coefficients": self.coefficients, "n_params": self.n_params,
                "evidence": self.evidence, "error": self.error}


@dataclass
class Diagnosis:
    """Ranked candidates, the verdict, and the base fit."""

    base: FitResult
    candidates: list[Candidate]
    verdict: str
    noise_floor_dph: float
    ratio_to_floor: float
    alpha: float = ALPHA
    min_improvement_pct: float = 100 * MIN_IMPROVEMENT

    @property
    def found(self) -> list[Candidate]:
        return [c for c in self.candidates if c.significant]

    @property
    def top(self) -> Candidate | None:
        return self.candidates[0] if self.candidates else None

    def to_dict(self) -> dict:
        return {
            "base_terms": self.base.terms,
            "base_rms_fit_dph": self.base.rms_fit,
            "base_rms_holdout_dph": self.base.rms_holdout,
            "noise_floor_dph": self.noise_floor_dph,
            "ratio_to_floor": self.ratio_to_floor,
            "resolution_s": self.base.resolution_s,
            "resolution_note": self.base.resolution_note,
            "missing_effect": self.found[0].term if self.found else None,
            "verdict": self.verdict,
            "rule": {"alpha": self.alpha, "min_improvement_pct": self.min_improvement_pct,
                     "ranking": "held-out RMS x (1 + params/blocks)",
                     "significance": "HAC Wald test, p x trials x candidates"},
            "candidates": [c.to_dict() for c in self.candidates],
            "excursions": [e.to_dict() for e in self.base.excursions],
            "base": self.base.to_dict(),
        }


def _trials(spec: TermSpec, wd: WorkData) -> int:
    b = nonlinear_bounds(spec, wd.duration_s, wd.resolution_s)
    if not b:
        return 1
    (name, (lo, hi)), = b.items()
    if spec.effect.nonlinear[0].kind == "freq":
        return max(1, int(round((hi - lo) * wd.duration_s)))
    return max(1, int(round(math.log(hi / lo))))


def diagnose_log(log, specs: list[TermSpec], candidates: list[str] | None = None, *,
                 path: str | None = None, axis: str | None = None, skip: str | float = "0",
                 t_ref: float | None = None, v_ref: float | None = None,
                 resolution: str | None = "auto", smooth: str | None = "auto",
                 alpha: float | None = None, min_improvement_pct: float = 1.0,
                 folds: int = 5, progress=None) -> Diagnosis:
    """``gyrotest model diagnose``: prepare ``log`` with the command's options
    (:func:`gyrotest.envmodel.prepare.prepare_log`) and :func:`diagnose` the model ``specs``
    (``alpha`` default :data:`ALPHA`; ``min_improvement_pct`` in %). ``progress(i, n, label)``
    is called before each candidate term is tried."""
    wd = prepare_log(log, path, axis=axis, skip=skip, t_ref=t_ref, v_ref=v_ref,
                     resolution=resolution, smooth=smooth, specs=specs)
    return diagnose(wd, specs, candidates, alpha=ALPHA if alpha is None else alpha,
                    min_improvement=min_improvement_pct / 100.0, folds=folds,
                    progress=progress)


def diagnose(wd: WorkData, base_terms, candidates=None, *, alpha: float = ALPHA,
             min_improvement: float = MIN_IMPROVEMENT, folds: int = 5,
             base: FitResult | None = None, progress=None) -> Diagnosis:
    """Rank every candidate term the model ``base_terms`` lacks (see the module docstring).

    ``candidates``: term texts/specs to try (default: every applicable library term). Returns a
    :class:`Diagnosis` whose ``candidates`` are ranked best first.
    """
    if base is None:
        base = fit_model(wd, base_terms, folds=folds)
    base_specs = [s for s in base.specs if s.key != "bias"]
    if candidates is None:
        cands = candidate_terms(wd.frame, base.specs)
    else:
        cands = resolve_terms(parse_terms(candidates), wd.frame)
        have = {s.label for s in base.specs}
        cands = [c for c in cands if c.label not in have]
    thetas0 = dict(getattr(base, "_thetas", {}))
    n_c = max(1, len(cands))
    out: list[Candidate] = []
    for i, c in enumerate(cands):
        if progress:
            progress(i, len(cands), c.label)
        replaces = None
        specs = list(base_specs)
        if c.key == "Tlag":
            plain = TermSpec("T", c.channels)
            if any(s.label == plain.label for s in specs):
                specs = [s for s in specs if s.label != plain.label]
                replaces = plain.label
        specs.append(c)
        trials = _trials(c, wd)
        try:
            r = fit_model(wd, specs, folds=folds, thetas0=thetas0, light=True)
        except (InputError, AnalysisError, np.linalg.LinAlgError, ValueError) as e:
            out.append(Candidate(c.label, describe(c), replaces, math.nan, math.nan, math.nan,
                                 math.nan, math.nan, math.nan, trials, False, spec=c,
                                 error=f"could not fit: {e}"))
            continue
        z, p = _significance(r, c, replaces, wd)
        p_adj = min(1.0, p * trials * n_c) if math.isfinite(p) else math.nan
        impr = (base.rms_holdout - r.rms_holdout) / base.rms_holdout
        sig = bool(math.isfinite(p_adj) and p_adj < alpha and impr >= min_improvement)
        coefs = [c2.to_dict() for c2 in r.coefficients if c2.term == c.label]
        out.append(Candidate(c.label, describe(c) + (f" (replaces {replaces})" if replaces else ""),
                             replaces, r.rms_fit, r.rms_holdout, 100 * impr, z, p, p_adj, trials,
                             sig, coefs, r.n_params, spec=c))
    nb = wd.nb

    def score(c: Candidate) -> float:
        if not math.isfinite(c.rms_holdout):
            return math.inf
        return c.rms_holdout * (1 + c.n_params / nb)

    out.sort(key=score)
    floor = base.floor.rms_dph if base.floor else math.nan
    ratio = base.rms_holdout / floor if floor and math.isfinite(floor) and floor > 0 else math.nan
    found = [c for c in out if c.significant]
    if found:
        top = found[0]
        v = (f"missing effect: {top.term} — {top.effect}; held-out RMS "
             f"{base.rms_holdout:.4g} → {top.rms_holdout:.4g} deg/h "
             f"({-top.improvement_pct:+.1f} %), {top.evidence.split(', ', 1)[1]}")
        if len(found) > 1:
            v += "; also significant: " + ", ".join(c.term for c in found[1:4])
            v += " (add the top one and run diagnose again)"
    elif math.isfinite(ratio) and ratio <= 1.25:
        v = (f"no missing effect found: the held-out residual ({base.rms_holdout:.3g} deg/h) is "
             f"at the Allan-predicted noise floor ({floor:.3g} deg/h, ratio {ratio:.2f})")
    else:
        v = ("no missing effect found among the candidates"
             + (f"; the held-out residual is {ratio:.2g}x the Allan-predicted noise floor "
                f"({floor:.3g} deg/h): an effect outside the library or noise slower than "
                "white/flicker (random walk, Markov); see the excursions"
                if math.isfinite(ratio) else ""))
    return Diagnosis(base=base, candidates=out, verdict=v, noise_floor_dph=floor,
                     ratio_to_floor=ratio, alpha=alpha, min_improvement_pct=100 * min_improvement)


def _significance(r: FitResult, c: TermSpec, replaces: str | None, wd: WorkData
                  ) -> tuple[float, float]:
    """HAC Wald test of the candidate's added coefficient(s) in the fitted candidate model,
    against a t/F reference with the effective degrees of freedom of the added regressor(s)
    (:func:`gyrotest.envmodel.stats.effective_df`)."""
    fitter = r._fitter  # type: ignore[attr-defined]
    th = r._thetas  # type: ignore[attr-defined]
    X = fitter.X(th)
    if replaces is None:
        idx = [i for i, cf in enumerate(r.coefficients)
               if cf.term == c.label and cf.kind == "linear"]
        beta = np.array([r.coefficients[i].value for i in idx])
        cov = r.cov[np.ix_(idx, idx)]
        df = st.effective_df(X, idx, st.integrated_time(r.resid))
        _, p, z = st.wald_t(beta, cov, df)
        return z, p
    # lag replacement: test the core-temperature column in the model that also has the plain
    # sensor temperature (a lag effect means T_core explains what T does not)
    a, _b = fitter._offsets()[c.label]
    xb_plain = fitter.d.block(TermSpec("T", c.channels), None)
    Xa = np.column_stack([X, xb_plain])
    beta, _ = st.lstsq(Xa, wd.y)
    e = wd.y - Xa @ beta
    cov, info = st.hac_covariance(Xa, e)
    df = st.effective_df(Xa, [a], st.integrated_time(e))
    _, p, z = st.wald_t(beta[a:a + 1], cov[a:a + 1, a:a + 1], df)
    return z, p
