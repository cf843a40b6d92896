"""The workbench diagnosis: compare a model with the measurement, say which physical effect is
missing, or that nothing is.

:func:`diagnose` fits the model under the gyro's own noise model (:mod:`.likelihood`), runs one
step of the search (:func:`gyrotest.envmodel.selection.judge_step`: one likelihood-ratio test
per candidate at a family-wise α, look-elsewhere corrected) and follows the forward path: the
chosen term is added and the next step searched, up to ``path_steps`` times. When nothing is
missing it tests the residual against the noise model (Ljung–Box on the whitened residual) and
names a model term the data do not support. :func:`diagnose_log` does the same from a log and
the command's options (``gyrotest model diagnose``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from .candidate import Candidate, Removal, _fmt_p
from .likelihood import NoiseParams
from .lookelsewhere import Whiteness
from .modelfit import FitResult, WorkData, fit_model
from .pipeline import prepare_log
from .selection import (
    ALPHA,
    BIC_TIE,
    judge_step,
    removal,
    residual_whiteness,
    stimulus_note,
)
from .terms import TermSpec


@dataclass
class Diagnosis:
    """The candidates of the step (most significant first), the verdict, the chosen missing
    effect and the forward path, the base fit and its noise model."""

    base: FitResult
    candidates: list[Candidate]
    verdict: str
    alpha: float = ALPHA
    chosen: Candidate | None = None
    path: list[dict] = field(default_factory=list)
    remove: Removal | None = None
    whiteness: Whiteness | None = None

    @property
    def noise(self) -> NoiseParams:
        return self.base.noise.params

    @property
    def noise_floor_dph(self) -> float:
        return self.base.floor.rms_dph if self.base.floor is not None else math.nan

    @property
    def ratio_to_floor(self) -> float:
        fl = self.noise_floor_dph
        return self.base.rms_holdout / fl if fl and math.isfinite(fl) and fl > 0 else math.nan

    @property
    def floor_basis(self) -> str:
        return self.base.floor.basis if self.base.floor is not None else ""

    @property
    def found(self) -> list[Candidate]:
        """Missing effects, the chosen one first."""
        if self.chosen is None:
            return []
        return [self.chosen] + [c for c in self.candidates
                                if c.significant and c is not self.chosen]

    @property
    def possible(self) -> Candidate | None:
        """The most significant candidate when none passes (for the record)."""
        if self.chosen is not None:
            return None
        ok = [c for c in self.candidates if math.isfinite(c.log_p)]
        return ok[0] if ok else None

    @property
    def top(self) -> Candidate | None:
        return self.candidates[0] if self.candidates else None

    @property
    def rule(self) -> str:
        return rule_line(self.alpha)

    def to_dict(self) -> dict:
        ch = self.chosen
        return {
            "base_terms": self.base.terms,
            "base_rms_fit_dph": self.base.rms_fit,
            "base_rms_holdout_dph": self.base.rms_holdout,
            "base_loglik": self.base.loglik,
            "noise_model": self.noise.to_dict(),
            "noise_floor_dph": self.noise_floor_dph,
            "noise_floor_basis": self.floor_basis,
            "ratio_to_floor": self.ratio_to_floor,
            "residual_whiteness": self.whiteness.to_dict() if self.whiteness else None,
            "resolution_s": self.base.resolution_s,
            "resolution_note": self.base.resolution_note,
            "missing_effect": ch.term if ch else None,
            "replaces": ch.replaces if ch else None,
            "indistinguishable": ch.equivalents if ch else [],
            "remove_term": self.remove.to_dict() if self.remove else None,
            "add": ch.add_hint(self.base.specs) if ch else None,
            "verdict": self.verdict,
            "path": self.path,
            "rule": {"alpha_family_wise": self.alpha, "bic_tie": BIC_TIE,
                     "test": "likelihood ratio under the fitted noise model; family-wise "
                             "p-value by the min-P parametric bootstrap over every candidate "
                             "and searched value",
                     "text": self.rule},
            "candidates": [c.to_dict() for c in self.candidates],
            "excursions": [e.to_dict() for e in self.base.excursions],
            "base": self.base.to_dict(),
        }


def rule_line(alpha: float) -> str:
    """The decision rule in one line (``model diagnose`` prints it under the verdict)."""
    from .workbench_rules import SUMMARY

    return SUMMARY.format(alpha=alpha)


def diagnose_log(log, specs: list[TermSpec], candidates: list[str] | None = None, *,
                 path: str | None = None, axis: str | None = None, skip: str | float = "0",
                 t_ref: float | None = None, v_ref: float | None = None,
                 resolution: str | None = "auto", smooth: str | None = "auto",
                 alpha: float | None = None, folds: int = 5, progress=None, reference=None,
                 path_steps: int = 3, power_on: bool | None = None, **_ignored) -> Diagnosis:
    """``gyrotest model diagnose``: prepare ``log`` with the command's options
    (:func:`gyrotest.envmodel.pipeline.prepare_log`; ``reference``: a static reference log
    that fixes the noise model; ``power_on``: the log starts at the gyro's power-on) and
    :func:`diagnose` the model ``specs``. ``progress(i, n, label)`` is called before each
    candidate term is scored."""
    wd = prepare_log(log, path, axis=axis, skip=skip, t_ref=t_ref, v_ref=v_ref,
                     resolution=resolution, smooth=smooth, specs=specs, reference=reference,
                     power_on=power_on)
    return diagnose(wd, specs, candidates, alpha=ALPHA if alpha is None else alpha,
                    folds=folds, progress=progress, path_steps=path_steps)


def diagnose(wd: WorkData, base_terms, candidates=None, *, alpha: float = ALPHA,
             folds: int = 5, base: FitResult | None = None, progress=None,
             path_steps: int = 3, **_ignored) -> Diagnosis:
    """Judge every candidate the model ``base_terms`` lacks, choose the missing effect and
    follow the forward path (module docstring of :mod:`gyrotest.envmodel.selection`).
    ``candidates``: term texts/specs to try instead of the library and the channel screen."""
    if base is None:
        base = fit_model(wd, base_terms, folds=folds)
    cands, chosen = judge_step(wd, base, candidates, alpha=alpha, progress=progress)
    path: list[dict] = []
    if chosen is not None:
        chosen.note = chosen.note or stimulus_note(chosen, wd.frame)
        path.append(path_entry(chosen, base))
        cur = chosen._fit
        for _ in range(max(0, path_steps - 1)):
            if cur is None:
                break
            _, nxt = judge_step(wd, cur, candidates, alpha=alpha)
            if nxt is None:
                break
            path.append(path_entry(nxt, cur))
            cur = nxt._fit
    white = residual_whiteness(base)
    remove = removal(wd, base) if chosen is None else None
    verdict = verdict_text(base, cands, chosen, path, white, remove, alpha)
    return Diagnosis(base=base, candidates=cands, verdict=verdict, alpha=alpha, chosen=chosen,
                     path=path, remove=remove, whiteness=white)


def path_entry(c: Candidate, before: FitResult) -> dict:
    after = c._fit
    fl = after.floor.rms_dph if after is not None and after.floor is not None else math.nan
    return {"term": c.term, "effect": c.effect, "replaces": c.replaces,
            "add": c.add_hint(before.specs), "lr": c.lr, "p_family": c.p_family,
            "rms_holdout_before_dph": before.rms_holdout,
            "rms_holdout_after_dph": c.rms_holdout,
            "noise_after": after.noise.params.to_dict() if after is not None else None,
            "ratio_to_floor_after": (c.rms_holdout / fl if math.isfinite(fl) and fl > 0
                                     else math.nan),
            "evidence": c.evidence}


def _noise_text(p: NoiseParams) -> str:
    return p.text() + (" (from the reference run)" if p.fixed else "")


def verdict_text(base: FitResult, cands: list[Candidate], chosen: Candidate | None,
                 path: list[dict], white: Whiteness, remove: Removal | None,
                 alpha: float) -> str:
    """The verdict of a diagnosis step in words (see :func:`diagnose`)."""
    if chosen is not None:
        c = chosen
        v = (f"missing effect: {c.term} — {c.effect}"
             + (f", in place of {c.replaces}" if c.replaces else "")
             + f"; likelihood ratio {c.evidence}")
        if math.isfinite(c.rms_holdout):
            v += (f"; held-out RMS {base.rms_holdout:.4g} → {c.rms_holdout:.4g} deg/h "
                  f"({-c.improvement_pct:+.1f} %)")
        if c.note:
            v += f"; {c.note}"
        if c.equivalents:
            v += (f"; indistinguishable on this log (ΔBIC ≤ {BIC_TIE:g}) from "
                  + ", ".join(c.equivalents[:3])
                  + (f": to separate them, {c.advice}" if c.advice else ""))
        if c._fit is not None:
            v += f"; residual noise after it: {_noise_text(c._fit.noise.params)}"
        v += f"; add it with {c.add_hint(base.specs)}"
        if len(path) > 1:
            v += "; then " + ", then ".join(
                f"{p['term']} (→ {p['rms_holdout_after_dph']:.3g} deg/h)" for p in path[1:])
        return v
    best = next((c for c in cands if math.isfinite(c.log_p) and c.sensor_limited is None
                 and c.degenerate is None), None)
    bits = []
    for d in cands:
        if d.degenerate is not None and math.isfinite(d.log_p) and d.p_family <= alpha:
            bits.append(f"{d.term} passes (family-wise p = {_fmt_p(d.p_family)}) but would make "
                        f"the design degenerate: {d.degenerate}")
            break
    if best is not None:
        bits.append(f"best candidate {best.term}: family-wise p = {_fmt_p(best.p_family)} "
                    f"≥ α = {alpha:g}")
    noise = _noise_text(base.noise.params)
    if white is None or not math.isfinite(white.p) or white.consistent:
        v = (f"no missing effect: the residual is consistent with the gyro's noise model "
             f"({noise}; Ljung–Box p = {_fmt_p(white.p) if white else 'n/a'} over "
             f"{white.lags if white else 0} lags of the whitened residual)")
    else:
        v = (f"no candidate passes, but the residual is not consistent with the noise model "
             f"(Ljung–Box p = {_fmt_p(white.p)} < α over {white.lags} lags; {noise}): an "
             "effect outside the library and the channel screen, or noise the model lacks "
             "(a sinusoid, a step, a second Markov term); see the excursions, or try a --term")
    if bits:
        v += "; " + "; ".join(bits)
    lim = [c for c in cands if c.sensor_limited is not None]
    if lim:
        c = max(lim, key=lambda c: c.lr_fixed if math.isfinite(c.lr_fixed) else c.lr)
        v += (f"; limited by the sensors: {c.term} {c.sensor_reason}: a better reading, not a "
              f"new effect (to use it: {c.add_hint(base.specs)})")
    if remove is not None:
        v += "; " + remove.text
    return v


__all__ = ["Diagnosis", "diagnose", "diagnose_log", "rule_line", "verdict_text"]
