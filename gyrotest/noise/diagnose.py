"""Model vs measurement: where the noise model fails, and which missing term explains it.

Krobka (Allan-graph topology §6, misconception 4 / notes M6): the five-slope IEEE basis is incomplete, and
unmodelled noises turn into parameter error. So every fit is checked against the measurement:

1. **Residuals in CI units** at each τ (:func:`gyrotest.noise.noisefit.ci_residuals`): |r| ≤ 1 means
   the model lies inside the confidence interval of σ̂(τ).
2. **Misfit regions**: runs of consecutive fitted τ beyond ±2 CI units, named with their τ
   range, direction and size, and a hint from their shape ("τ 0.5–4 s: measured above model by
   3–5 CI: a hump — try markov").
3. **Goodness of fit**: Pearson χ²/dof with the EDF-based variances and its p-value with the
   correlation-corrected degrees of freedom (:class:`gyrotest.noise.noisefit.NoiseFit`).
4. **Diagnosis**: each candidate extra term (Markov, sinusoid, blue S(0)=0 noise, and Q, N, B,
   K (RRW), R (ramp) when the model lacks them — also a requested term the fit eliminated,
   e.g. N swamped by an unmodelled hump; such a restored term is taken before the model is
   extended) is added in turn and the model re-fitted; the
   candidates are ranked by ΔBIC (scaled deviance + k·ln n_eff, GMWM-style model selection;
   Guerrier et al. 2013) with ΔAIC and χ²/dof as further evidence. A candidate is **accepted**
   when ΔBIC ≤ −6 ("strong" on the Kass–Raftery scale) and the added term is itself identified
   in the new fit; when the current model is already consistent with the measurement (χ² test
   and no run beyond 3 CI), ΔBIC ≤ −20 ("very strong") is required instead. The ladder repeats
   from the improved model (at most ``max_steps`` additions),
   so the output shows the misfit falling step by step; "no missing term" when nothing is
   accepted and the base fit is consistent.

Sinusoid candidates are seeded with the lines of a Welch PSD (:func:`spectral.find_lines`):
the Allan graph only shows a lobe, the spectrum shows the frequency.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..core.errors import AnalysisError
from .fitmodel import LINEAR_KEYS
from .fitresult import NoiseFit
from .noisefit import fit_noise_model

__all__ = ["Candidate", "Diagnosis", "MisfitRegion", "diagnose", "misfit_regions"]

#: ΔBIC at or below which a candidate counts as a missing term (Kass & Raftery: "strong").
ACCEPT_DBIC = -6.0
#: ΔBIC needed when the current model is already consistent with the measurement ("very
#: strong"): a consistent fit is not extended on weak evidence
ACCEPT_DBIC_CONSISTENT = -20.0
#: residual (CI units) beyond which a τ counts as misfit
MISFIT_CI = 2.0
CANDIDATES = ("markov", "sine", "blue", "K", "R", "Q", "N", "B")


@dataclass
class MisfitRegion:
    """A run of consecutive fitted τ where the model misses the measurement.

    ``sign`` +1: measured above the model; −1: below. ``r_min``/``r_max``: the smallest and
    largest |residual| in CI units; ``hint``: what that shape usually means."""

    tau_lo: float
    tau_hi: float
    sign: int
    r_min: float
    r_max: float
    n_points: int
    position: str  # left | interior | right
    hint: str

    def text(self) -> str:
        where = "above" if self.sign > 0 else "below"
        rng = (f"{self.r_min:.0f}–{self.r_max:.0f}" if round(self.r_max) > round(self.r_min)
               else f"{self.r_max:.0f}")
        return (f"τ {_g(self.tau_lo)}–{_g(self.tau_hi)} s: measured {where} model by {rng} CI: "
                f"{self.hint}")

    def to_dict(self) -> dict[str, Any]:
        return {"tau_lo_s": self.tau_lo, "tau_hi_s": self.tau_hi,
                "direction": "measured above model" if self.sign > 0 else "measured below model",
                "residual_ci_min": self.r_min, "residual_ci_max": self.r_max,
                "n_points": self.n_points, "position": self.position, "hint": self.hint,
                "text": self.text()}


def _g(v: float) -> str:
    if v >= 100:
        return f"{v:.0f}"
    return f"{v:.2g}" if v < 10 else f"{v:.3g}"


def _hint(sign: int, position: str, alternating: bool) -> str:
    if alternating:
        return "alternating misfit, periodic content — try sine (see the PSD for the line)"
    if sign > 0:
        return {
            "interior": "a hump — try markov (or sine if the PSD shows a line)",
            "right": "rising tail — try K or R, or --detrend linear if it is a drift",
            "left": "excess at short τ — try Q (white angle noise) or markov/blue at short T_c",
        }[position]
    return {
        "interior": "a dip — a sinusoid null or band-limited noise: try sine or blue",
        "right": "falling tail below the model — the +½/+1 terms are too high, or a bounded "
                 "(S(0)=0) noise: try blue; check the CI at long τ",
        "left": "the model is too high at short τ (white noise screened by a hump?) — try "
                "markov or blue",
    }[position]


def misfit_regions(fit: NoiseFit, threshold: float = MISFIT_CI) -> list[MisfitRegion]:
    """Runs of consecutive fitted τ with |residual| > ``threshold`` CI units and the same sign,
    with a hint from the shape (see :func:`_hint`)."""
    r = fit.residuals()
    idx = np.flatnonzero(fit.used)
    if idx.size == 0:
        return []
    rr = r[idx]
    regions: list[tuple[int, int, int]] = []
    i = 0
    while i < idx.size:
        if not (math.isfinite(rr[i]) and abs(rr[i]) > threshold):
            i += 1
            continue
        sgn = 1 if rr[i] > 0 else -1
        j = i
        while j + 1 < idx.size and math.isfinite(rr[j + 1]) and abs(rr[j + 1]) > threshold and (
                (rr[j + 1] > 0) == (sgn > 0)):
            j += 1
        regions.append((i, j, sgn))
        i = j + 1
    alternating = len(regions) >= 5 and all(
        regions[k][2] != regions[k + 1][2] for k in range(len(regions) - 1))
    out = []
    for a, b, sgn in regions:
        pos = "left" if a == 0 else ("right" if b == idx.size - 1 else "interior")
        vals = np.abs(rr[a:b + 1])
        out.append(MisfitRegion(
            tau_lo=float(fit.tau[idx[a]]), tau_hi=float(fit.tau[idx[b]]), sign=sgn,
            r_min=float(vals.min()), r_max=float(vals.max()), n_points=b - a + 1, position=pos,
            hint=_hint(sgn, pos, alternating)))
    return out


@dataclass
class Candidate:
    """One candidate extra term, fitted together with the current model."""

    term: str
    fit: NoiseFit | None
    delta_aic: float
    delta_bic: float
    chi2_dof: float
    identified: bool
    accepted: bool
    error: str | None = None

    @property
    def params_text(self) -> str:
        if self.fit is None:
            return ""
        t = self.fit.terms[-1]
        return t.text()

    def evidence(self) -> str:
        if self.fit is None:
            return f"fit failed: {self.error}"
        return (f"ΔBIC = {self.delta_bic:+.1f}, ΔAIC = {self.delta_aic:+.1f}, "
                f"χ²/dof = {self.chi2_dof:.2f}")

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {"term": self.term, "delta_aic": _num(self.delta_aic),
                             "delta_bic": _num(self.delta_bic), "chi2_dof": _num(self.chi2_dof),
                             "identified": self.identified, "accepted": self.accepted,
                             "evidence": self.evidence()}
        if self.fit is not None:
            d["added_term"] = self.fit.terms[-1].to_dict()
        if self.error:
            d["error"] = self.error
        return d


def _num(v: float) -> float | None:
    return float(v) if math.isfinite(v) else None


@dataclass
class Diagnosis:
    """Result of :func:`diagnose`: the base fit's misfit regions, the ranked candidates of the
    first step, the ladder of accepted additions (``steps``), the suggested ``final`` model and
    a one-line ``verdict``."""

    base: NoiseFit
    regions: list[MisfitRegion]
    candidates: list[Candidate]
    steps: list[dict[str, Any]]
    final: NoiseFit
    verdict: str
    no_missing_term: bool
    line_hints: list[float] = field(default_factory=list)

    @property
    def suggested_terms(self) -> str:
        return self.final.label_string()

    def to_dict(self) -> dict[str, Any]:
        return {
            "method": "add each candidate term in turn, refit jointly, rank by ΔBIC (scaled "
                      "deviance + k ln n_eff); accept when ΔBIC <= -6 and the term is "
                      "identified; repeat from the improved model",
            "verdict": self.verdict,
            "no_missing_term": self.no_missing_term,
            "misfit_regions": [r.to_dict() for r in self.regions],
            "candidates": [c.to_dict() for c in self.candidates],
            "steps": self.steps,
            "suggested_terms": self.final.requested,
            "final_fit": None if self.final is self.base else self.final.to_dict(),
            "psd_line_hints_hz": list(self.line_hints),
        }


def _step_record(fit: NoiseFit, added: str | None, cand: Candidate | None = None
                 ) -> dict[str, Any]:
    r = fit.residuals()[fit.used]
    fin = np.isfinite(r)
    return {
        "terms": list(fit.requested),
        "added": added,
        "delta_bic": None if cand is None else _num(cand.delta_bic),
        "delta_aic": None if cand is None else _num(cand.delta_aic),
        "chi2_per_dof": _num(fit.chi2_dof),
        "p_value": _num(fit.p_value),
        "aic": _num(fit.aic),
        "bic": _num(fit.bic),
        "max_abs_residual_ci": _num(float(np.max(np.abs(r[fin]))) if fin.any() else math.nan),
        "fraction_beyond_2ci": _num(float(np.mean(np.abs(r[fin]) > 2.0)) if fin.any()
                                    else math.nan),
        "consistent": fit.consistent,
        "terms_fitted": [t.text() for t in fit.terms],
    }


def _candidates_for(requested: Sequence[str], allowed: Sequence[str],
                    current: NoiseFit | None = None) -> list[str]:
    """Candidate terms: those not in the model, plus requested linear terms (Q, N, B, K, R)
    that the current fit eliminated. A term the base fit dropped because an unmodelled hump
    swamped it (white noise N under a Markov hump, Krobka's central case) can so come back
    once the hump is modelled, instead of a blue or second Markov term standing in for it."""
    kept = {t.key for t in current.terms if t.coef > 0} if current is not None else set(requested)
    out = []
    for c in allowed:
        if c in LINEAR_KEYS and c in requested and c in kept:
            continue
        if c not in LINEAR_KEYS and sum(k == c for k in requested) >= 2:
            continue
        out.append(c)
    return out


def _try(fit_kwargs: dict[str, Any], base: NoiseFit, term: str) -> Candidate:
    # the terms the base model kept (after its backward elimination) plus the candidate
    terms = [t.key for t in base.terms if t.coef > 0] + [term]
    try:
        f = fit_noise_model(terms=terms, scan=True, **fit_kwargs)
    except AnalysisError as e:
        return Candidate(term, None, math.nan, math.nan, math.nan, False, False, str(e))
    added = f.terms[-1]
    k = 2 if term in ("markov", "sine", "blue") else 1
    dd = (f.deviance - base.deviance) / added.design_effect  # Rao-Scott corrected
    return Candidate(term, f, dd + 2.0 * k, dd + k * math.log(max(f.n_eff, 2.0)), f.chi2_dof,
                     added.identified, False)


def _shape_hints(found: NoiseFit, terms: Sequence[str]) -> dict[str, float]:
    """{label in a fit of ``terms``: shape} from the nonlinear terms of ``found`` (matched by
    key and order: the k-th Markov term of one to the k-th of the other)."""
    by_key: dict[str, list[float]] = {}
    for t in found.terms:
        if t.key not in LINEAR_KEYS and t.shape is not None and t.coef > 0:
            by_key.setdefault(t.key, []).append(float(t.shape))
    count = {k: sum(1 for x in terms if x == k) for k in set(terms)}
    seen: dict[str, int] = {}
    out: dict[str, float] = {}
    for k in terms:
        if k in LINEAR_KEYS:
            continue
        seen[k] = seen.get(k, 0) + 1
        i = seen[k] - 1
        if i < len(by_key.get(k, [])):
            out[k if count[k] == 1 else f"{k}[{seen[k]}]"] = by_key[k][i]
    return out


def diagnose(fit: NoiseFit, *, candidates: Sequence[str] = CANDIDATES,
             line_hints: Sequence[float] = (), max_steps: int = 3,
             accept_dbic: float = ACCEPT_DBIC) -> Diagnosis:
    """Diagnose a :class:`NoiseFit`: misfit regions, ranked candidate terms and the ladder of
    accepted additions (module docstring). ``line_hints``: sinusoid frequencies (Hz) from the
    PSD. The fits are redone on the same τ range and EDF floor as ``fit``.
    """
    kw: dict[str, Any] = {
        "tau": fit.tau, "sigma": fit.sigma, "edf": fit.edf, "sigma_lo": fit.sigma_lo,
        "sigma_hi": fit.sigma_hi, "tau0": fit.tau0, "min_edf": fit.min_edf,
        "bi_cutoff_hz": fit.bi_f0, "line_hints": list(line_hints),
        "tau_range": fit.fit_range, "quantity": fit.quantity,
    }
    regions = misfit_regions(fit)
    steps = [_step_record(fit, None)]
    current = fit
    first: list[Candidate] = []
    accepted_any = False
    added_terms: list[str] = []
    for step in range(max_steps):
        cands = [_try(kw, current, c) for c in _candidates_for(
            list(fit.requested) + added_terms, candidates, current)]
        cands.sort(key=lambda c: (math.inf if not math.isfinite(c.delta_bic) else c.delta_bic))
        need = accept_dbic if not current.consistent else min(accept_dbic, ACCEPT_DBIC_CONSISTENT)
        # a requested term the fit had eliminated is restored before the model is extended:
        # near-degenerate extensions (blue or a second Markov ≈ white noise) otherwise win
        # on a fraction of a BIC unit
        restored = [c for c in cands if c.fit is not None and c.term in fit.requested
                    and c.term in LINEAR_KEYS and c.delta_bic <= need and c.identified]
        best = restored[0] if restored else next((c for c in cands if c.fit is not None), None)
        if best is not None and best.delta_bic <= need and best.identified:
            best.accepted = True
        if step == 0:
            first = cands
        if best is None or not best.accepted:
            break
        accepted_any = True
        last = best
        added_terms.append(best.term)
        current = best.fit
        steps.append(_step_record(current, best.term, best))
    if accepted_any:
        # a restored requested term (e.g. N) is already in the requested list
        extra = [t for t in added_terms if not (t in LINEAR_KEYS and t in fit.requested)]
        terms = list(fit.requested) + extra
        # the full fit (elimination, bounds) of the accepted model, its shape search seeded
        # with the ladder's shapes so that it reaches (at least) the optimum the ladder found
        final = fit_noise_model(terms=terms, with_bounds=True,
                                shape_hints=_shape_hints(current, terms), **kw)
        # one model, one χ²: the last step of the ladder is this fit
        steps[-1] = _step_record(final, steps[-1]["added"], last)
        # restored requested terms are named when the final fit identifies them
        back = [t for t in final.terms[:len(fit.requested)]
                if t.key in added_terms and t.identified]
        added = [a for a in added_terms if a not in LINEAR_KEYS or a not in fit.requested] + [
            f"{t.key} (restored)" for t in back]
        lastfit = final.terms[len(fit.requested):] + back
        desc = "; ".join(t.text() for t in lastfit)
        verdict = (f"missing term{'s' if len(added) > 1 else ''}: {', '.join(added)} ({desc}); "
                   f"χ²/dof {fit.chi2_dof:.2f} → {final.chi2_dof:.2f}. "
                   f"Refit with --terms {','.join(final.requested)}")
        no_missing = False
    else:
        final = fit
        if fit.consistent:
            verdict = (f"no missing term: the model is consistent with the measurement "
                       f"(χ²/dof = {fit.chi2_dof:.2f}, p = {fit.p_value:.2g}); no candidate "
                       f"lowers BIC by {-accept_dbic:g} or more")
            no_missing = True
        else:
            verdict = (f"misfit (χ²/dof = {fit.chi2_dof:.2f}, p = {fit.p_value:.2g}) not explained "
                       f"by any single candidate ({', '.join(c.term for c in first)}); look for "
                       "data faults (steps, resets, temperature drift) in the rate record")
            no_missing = False
    return Diagnosis(base=fit, regions=regions, candidates=first, steps=steps, final=final,
                     verdict=verdict, no_missing_term=no_missing, line_hints=list(line_hints))
