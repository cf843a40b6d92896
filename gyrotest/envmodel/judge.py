"""Judge one candidate term of the workbench diagnosis (:mod:`gyrotest.envmodel.diagnose`):
fit it beside the model, measure its held-out gain and fold consistency, test its coefficient
(HAC Wald test in the augmented model, the spectral test off the strict route) and decide
which route, if any, qualifies it as a missing effect. The routes and their thresholds are
described in :mod:`gyrotest.envmodel.diagnose` (steps 2-4) and set in
:mod:`gyrotest.envmodel.rules`."""

from __future__ import annotations

import math

import numpy as np

from ..errors import AnalysisError, InputError
from .candidate import (
    Candidate,
    held_out_gain,
    kept_terms,
    residual_corr,
    significance,
    spectral_z,
)
from .channel_terms import custom_text
from .fit import fit_model
from .rules import (
    ABOVE_FLOOR,
    AT_FLOOR,
    AT_FLOOR_GAIN,
    BIG_GAIN,
    CLEAR_GAIN,
    CLEAR_P,
    CV_STRONG,
    CV_T,
    CV_T_NUISANCE,
    FAR_GAIN,
    FAR_RATIO,
    FAR_T,
    FAR_T_NUISANCE,
    FAR_Z,
    HYST_CV_T,
    HYST_STRONG_CV_T,
    HYST_WEAK_CV_T,
    LAG_TOP,
    MIN_CV_T,
    SPECTRAL_REJECT,
    SPECTRAL_Z,
    STRONG_P,
    UNLAGGED,
    WARMUP_CLEAR_P,
    WARMUP_SPECTRAL_Z,
    WEAK_P,
    clear_p,
    red_floor_for,
    spectral_bar,
    spectral_exempt,
)
from .screen import period_matches, term_class
from .terms import TermSpec, describe, nonlinear_bounds
from .workdata import WorkData


def count_trials(spec: TermSpec, wd: WorkData) -> int:
    """Independent trials a candidate's nonlinear parameter search makes (the look-elsewhere
    factor of its p-value): the number of resolvable frequencies of a free sinusoid over the
    record (bandwidth x duration), the e-folds of a time-constant or width range, 1 for a
    linear term."""
    b = nonlinear_bounds(spec, wd.duration_s, wd.resolution_s, wd.refs)
    if not b:
        return 1
    (name, (lo, hi)), = b.items()
    if spec.effect.nonlinear[0].kind == "freq":
        return max(1, int(round((hi - lo) * wd.duration_s)))
    return max(1, int(round(math.log(hi / lo))))


def judge(wd, base, base_specs, c: TermSpec, thetas0, n_c, base_ratio, alpha,
          min_improvement, folds, replaces_labels: list[str] | None = None) -> Candidate:
    """Fit candidate ``c`` beside ``base_specs`` (in place of ``replaces_labels``, or of the
    plain temperature a lag replaces) and judge it: held-out gain against ``base``, fold
    consistency, HAC significance over ``trials`` x ``n_c`` candidates at ``alpha``, the
    spectral test, and the route (strict, clear gain, far above the floor) that qualifies
    it, if any. Returns the :class:`~gyrotest.envmodel.candidate.Candidate`."""
    replaces = None
    specs = list(base_specs)
    if replaces_labels:
        specs = [s for s in specs if s.label not in replaces_labels]
        replaces = "; ".join(replaces_labels)
    if c.key == "Tlag":
        plain = TermSpec("T", c.channels)
        if any(s.label == plain.label for s in specs):
            specs = [s for s in specs if s.label != plain.label]
            replaces = plain.label
    specs.append(c)
    trials = count_trials(c, wd)
    klass = term_class(c)
    try:
        r = fit_model(wd, specs, folds=folds, thetas0=thetas0, light=True, new_terms=[c])
    except (InputError, AnalysisError, np.linalg.LinAlgError, ValueError) as e:
        return Candidate(c.label, describe(c), replaces, math.nan, math.nan, math.nan,
                         math.nan, math.nan, math.nan, trials, False, spec=c,
                         error=f"could not fit: {e}", klass=klass)
    z, p = significance(r, c, replaces, wd)
    p_adj = min(1.0, p * trials * n_c) if math.isfinite(p) else math.nan
    impr, scatter, t_cv = held_out_gain(base, r, folds)
    p_tr = min(1.0, p * trials) if math.isfinite(p) else math.nan
    guard = clear_p(klass)
    # a hysteresis branch off the strict route (:data:`HYST_WEAK_CV_T`)
    hyst_weak = c.key != "hyst" or (t_cv >= HYST_WEAK_CV_T and math.isfinite(p_tr)
                                     and (p_tr < CLEAR_P
                                          or (t_cv >= HYST_STRONG_CV_T and p_tr < WEAK_P)))
    strict = bool(math.isfinite(p_adj) and p_adj < alpha
                  and impr >= (max(min_improvement, CLEAR_GAIN) if klass == "nuisance"
                               else min_improvement)
                  and t_cv >= MIN_CV_T
                  and (c.key != "hyst" or t_cv >= HYST_CV_T))
    above = base_ratio > ABOVE_FLOOR or impr >= BIG_GAIN
    cv_min = CV_T_NUISANCE if klass == "nuisance" else CV_T
    clear = bool(math.isfinite(p_tr) and above and impr >= CLEAR_GAIN and t_cv >= MIN_CV_T
                 and (p_tr < guard
                      or (impr >= BIG_GAIN and t_cv >= cv_min and p_tr < WEAK_P)
                      # a warm-up lives in the first chunks (:data:`WARMUP_CLEAR_P`)
                      or (c.key == "warmup" and impr >= FAR_GAIN and t_cv >= FAR_T
                          and p_tr < WARMUP_CLEAR_P)
                      or (impr >= BIG_GAIN and t_cv >= CV_STRONG * cv_min / CV_T
                          and p_tr < STRONG_P))
                 and hyst_weak)
    far = bool(math.isfinite(base_ratio) and base_ratio >= FAR_RATIO
               and (impr >= FAR_GAIN and t_cv >= FAR_T if klass != "nuisance"
                    else impr >= BIG_GAIN and t_cv >= FAR_T_NUISANCE)
               and hyst_weak)
    zw = math.nan
    if (not far and c.key == "warmup" and math.isfinite(base_ratio) and base_ratio >= FAR_RATIO
            and impr >= BIG_GAIN and t_cv >= FAR_T):
        # a warm-up lives in the first chunks: fold consistency understates it
        # (:data:`WARMUP_SPECTRAL_Z`)
        zw = spectral_z(r, [c.label], wd, keep=kept_terms(c, replaces), red=False)
        far = bool(zw >= WARMUP_SPECTRAL_Z)
    # the HAC guard, or (other missing effects inflating its error) the spectral z alone
    far_hac = far and math.isfinite(z) and abs(z) >= FAR_Z
    rejected = None
    waived = far and not (far_hac or clear or strict)
    if (waived or clear or far) and not strict and not math.isfinite(zw):
        # the red-residual floor only where the bar is the far one (a model near the noise
        # floor leaves white/flicker noise, and the red floor cost a true follow-up effect
        # there its z: seed 15000, dT/dt 5.8 -> 3.8 against a bar of 4)
        zw = spectral_z(r, [c.label], wd, keep=kept_terms(c, replaces),
                        red=((waived or spectral_bar(base_ratio) == SPECTRAL_Z)
                             and red_floor_for([c.key], z)))
    if waived:
        far = bool(zw >= SPECTRAL_Z)
    elif (clear or far) and not strict:
        post = (r.rms_holdout / base.rms_holdout * base_ratio
                if base.rms_holdout > 0 else math.nan)
        bar = spectral_bar(base_ratio, post)
        if not spectral_exempt(impr, t_cv, single=True) and not zw >= bar:
            rejected = (f"{SPECTRAL_REJECT} "
                        f"(spectral z {zw:.1f} < {bar:g}): the gain may be a fit to "
                        "the gyro's own drift")
    theta = r._thetas.get(c.label, {})  # type: ignore[attr-defined]
    if rejected is None and (clear or far) and not strict and c.key in UNLAGGED:
        tau = theta.get("tau_s")
        hi = nonlinear_bounds(c, wd.duration_s, wd.resolution_s,
                              wd.refs).get("tau_s", (0.0, math.inf))[1]
        if tau is not None and tau >= LAG_TOP * hi:
            rejected = (f"its time constant ({tau:.0f} s) is at the top of its range (the "
                        "record length): the log does not resolve the lag, and a channel "
                        "lagged that long is a slow trend that can fit the gyro's own drift")
    match = None
    if c.key == "sin" and (strict or clear or far):
        # judged in _step against the matched channel's own candidates
        match = period_matches(wd.frame, float(theta["f_Hz"])) or None
    floor_wrong = strict and impr >= AT_FLOOR_GAIN and t_cv >= CV_T
    if (rejected is None and (strict or clear) and base_ratio <= AT_FLOOR and impr < BIG_GAIN
            and not floor_wrong):
        # a model at the floor is complete: only a gain it could not give (>= 20 %, or a
        # strict >= 10 % consistent across the folds) says the floor is wrong
        rejected = (f"the model is at the noise floor (held-out/floor {base_ratio:.2f}) and "
                    f"the gain ({100 * impr:.1f} %) is below {100 * BIG_GAIN:.0f} % (or "
                    f"{100 * AT_FLOOR_GAIN:.0f} % on the strict test, consistent across the "
                    "folds)")
    sig = (strict or clear or far) and rejected is None
    route = (("strict" if strict else "clear gain" if clear else "far above the floor")
             if sig else None)
    coefs = [c2.to_dict() for c2 in r.coefficients if c2.term == c.label]
    try:
        custom = custom_text(c, theta, wd.frame)
    except InputError:
        custom = None
    cand = Candidate(c.label, describe(c) + (f" (replaces {replaces})" if replaces else ""),
                     replaces, r.rms_fit, r.rms_holdout, 100 * impr, z, p, p_adj, trials, sig,
                     coefs, r.n_params, spec=c, klass=klass, route=route,
                     gain_scatter_pct=100 * scatter, rejected=rejected, custom=custom)
    cand.r_residual = residual_corr(base, r, c)
    cand.cv_t = t_cv
    cand.spectral_z = zw
    cand.hac_waived = bool(waived and sig)
    cand._fit = r
    cand.period_match = match
    return cand


__all__ = ["count_trials", "judge"]
