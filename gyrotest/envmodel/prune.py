"""A term the model does better without (the backward check of
:mod:`gyrotest.envmodel.diagnose`).

The forward path adds one effect at a time, each judged on the model of its step. An effect
named early can stop being needed once later ones are in: far above the floor a flexible
term (a warm-up transient) may take part of a ramp and a temperature term that were both
still missing, and stay in the model after they are added, where its extra parameters only
cost held-out accuracy (seed 22078: warm-up, then T, then ramp; the model without the
warm-up has a held-out RMS 16 % lower, equal to the true model's). When the diagnosis finds
no missing effect, every term of the model is therefore left out once; a term whose removal
lowers the held-out RMS by at least :data:`DROP_GAIN` (with gain/(fold scatter/√folds) ≥
:data:`DROP_T`) is named for removal. The bar is lower than for adding a term: a term stays
only while the held-out data support it, and dropping one they need raises the held-out RMS.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import AnalysisError, InputError
from .candidate import held_out_gain
from .fit import FitResult, WorkData, fit_model

#: minimum held-out gain (fraction) of the model without the term
DROP_GAIN = 0.05
#: ... and more often a gain than not across the folds: gain / (fold scatter/√folds) at least
#: this (seed 22078: 1.9 -- two folds unchanged, three 23-43 % better without the warm-up)
DROP_T = 1.0


@dataclass
class Unneeded:
    """A term of the model that the held-out data do better without."""

    term: str
    rms_holdout_with_dph: float
    rms_holdout_without_dph: float
    gain_pct: float
    cv_t: float
    refitted: bool = False  # "with" is the model refitted from its own nonlinear parameters

    def to_dict(self) -> dict:
        return {"term": self.term, "rms_holdout_with_dph": self.rms_holdout_with_dph,
                "rms_holdout_without_dph": self.rms_holdout_without_dph,
                "gain_pct": self.gain_pct, "cv_t": self.cv_t, "refitted": self.refitted}

    @property
    def text(self) -> str:
        how = " (the model refitted)" if self.refitted else ""
        return (f"the model does better without {self.term}: held-out RMS{how} "
                f"{self.rms_holdout_with_dph:.4g} → {self.rms_holdout_without_dph:.4g} deg/h "
                f"({-self.gain_pct:.1f} %, gain/(fold scatter/sqrt(folds)) = {self.cv_t:.1f}); "
                f"remove it")


def unneeded_term(wd: WorkData, base: FitResult, folds: int = 5) -> Unneeded | None:
    """The term of ``base`` whose removal lowers the held-out RMS most, if that gain is at
    least :data:`DROP_GAIN` at fold consistency :data:`DROP_T`; None otherwise (or for a
    model without terms)."""
    specs = [s for s in (getattr(base, "specs", []) or []) if s.key != "bias"]
    if not specs or not math.isfinite(base.rms_holdout) or base.rms_holdout <= 0:
        return None
    thetas0 = dict(getattr(base, "_thetas", {}) or {})
    # the reference is the full model refitted the way each reduced model is (started from
    # the base's nonlinear parameters): a reduced model must not win by a better optimum of a
    # searched time constant alone (seed 22521n: the same terms held out 15 % better refitted)
    refitted = False
    try:
        full = fit_model(wd, specs, folds=folds, thetas0=thetas0, light=True)
        if math.isfinite(full.rms_holdout) and full.rms_holdout < base.rms_holdout:
            base, refitted = full, True
    except (InputError, AnalysisError, np.linalg.LinAlgError, ValueError):
        pass
    best: Unneeded | None = None
    for s in specs:
        rest = [o for o in specs if o is not s]
        try:
            r = fit_model(wd, rest, folds=folds, thetas0=thetas0, light=True)
        except (InputError, AnalysisError, np.linalg.LinAlgError, ValueError):
            continue
        if not math.isfinite(r.rms_holdout):
            continue
        gain, _, t_cv = held_out_gain(base, r, folds)
        if gain >= DROP_GAIN and t_cv >= DROP_T and (
                best is None or r.rms_holdout < best.rms_holdout_without_dph):
            best = Unneeded(term=s.label, rms_holdout_with_dph=base.rms_holdout,
                            rms_holdout_without_dph=r.rms_holdout, gain_pct=100 * gain,
                            cv_t=t_cv, refitted=refitted)
    return best
