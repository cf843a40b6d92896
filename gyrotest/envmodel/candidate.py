"""The results of the workbench's term selection (:mod:`.selection`): a :class:`Candidate` term
with its test (likelihood ratio, p-value, held-out gain, what it replaces) and its formatting,
and a :class:`Removal` of a term the data do not support."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from .modelfit import FitResult
from .terms import TermSpec
from .workbench_rules import (  # the decision constants, one source
    MC_DRAWS,
)


# ============================================================================ results
@dataclass
class Candidate:
    """One candidate move (a term added, or a block in place of model terms) and its test."""

    term: str
    effect: str
    spec: TermSpec | None
    klass: str = "library"
    replaces: str | None = None
    lr: float = math.nan  # Λ = 2Δℓ, the noise shape re-estimated under both models
    df: int = 0  # coefficients added (net of those replaced)
    searched: str | None = None  # the nonlinear parameter searched and its range
    log_p: float = math.nan  # ln of its own (local) p-value, at the best searched value
    p_fw: float = math.nan  # family-wise p-value (min-P parametric bootstrap)
    tv: float = 0.0  # total variation of √Λ along its search (Davies' V)
    p_fw_full: float = math.nan  # family-wise p of the re-estimated-shape Λ (Bonferroni)
    #: (Λ the sensors' noise alone would give a better reading of the same nodes, its sd):
    #: set when the candidate's gain is no larger (errors in variables); or (its Λ on the
    #: model read through the reconstructed nodes, 0) when it does not pass there
    #: (regression calibration, :mod:`gyrotest.envmodel.calibration`)
    sensor_limited: tuple[float, float] | None = None
    #: why it is limited by the sensors, in words (set with ``sensor_limited``)
    sensor_reason: str | None = None
    trials: int = 1  # candidates in the family of the step
    dbic: float = math.nan  # BIC of the model with it minus the model's
    theta: dict = field(default_factory=dict)
    significant: bool = False
    degenerate: str | None = None
    error: str | None = None
    equivalents: list[str] = field(default_factory=list)
    note: str | None = None
    lr_fixed: float = math.nan  # Λ at the model's own noise shape (the screen)
    lr_refit: float = math.nan  # 2Δℓ of the refitted models (θ and noise optimised)
    rms_fit: float = math.nan
    rms_holdout: float = math.nan
    improvement_pct: float = math.nan  # held-out RMS gain of the refitted model, %
    z: float = math.nan  # the added coefficient's z in the refitted model
    n_params: int = 0
    coefficients: list[dict] = field(default_factory=list)
    advice: str | None = None  # what measurement separates it from its equivalents
    _fit: FitResult | None = None

    @property
    def p(self) -> float:
        return float(math.exp(self.log_p)) if math.isfinite(self.log_p) else math.nan

    @property
    def p_family(self) -> float:
        """Family-wise p-value over every candidate and searched value of the step (the
        min-P parametric bootstrap of :func:`family_p`)."""
        return self.p_fw if math.isfinite(self.log_p) else math.nan

    @property
    def p_adj(self) -> float:
        return self.p_family

    @property
    def evidence(self) -> str:
        if self.error:
            return self.error
        if self.degenerate:
            return self.degenerate
        if not math.isfinite(self.lr):
            return "not tested"
        s = f"Λ = {self.lr:.1f} on {self.df} coefficient{'s' if self.df != 1 else ''}"
        if self.searched:
            s += f" with {self.searched} searched"
        pf = self.p_family
        fw = (f"< {1.0 / MC_DRAWS:.2g}" if math.isfinite(pf) and pf <= 1.0 / (MC_DRAWS + 1) + 1e-15
              else f"= {_fmt_p(pf)}")
        s += (f", local p = {_fmt_p(self.p)}, family-wise p {fw} over {self.trials} "
              f"candidates and their searched values, ΔBIC = {self.dbic:+.1f}")
        return s

    def add_hint(self, base_terms: list | None = None) -> str:
        """The complete ``--terms`` (and ``--term``) to paste: the model's terms (labels, or
        the :class:`TermSpec` of each, which keeps a custom term's expression), without those
        it replaces, plus this one."""
        replaced = set((self.replaces or "").split("; "))
        lib: list[str] = []
        own: list[str] = []
        for t in base_terms or []:
            label = t.label if isinstance(t, TermSpec) else str(t)
            if label == "bias" or label in replaced:
                continue
            if isinstance(t, TermSpec) and t.key == "custom":
                own.append(f"{t.name}:{t.expr}")
            elif ":" in label:
                own.append(label)
            else:
                lib.append(label)
        if self.spec is not None and self.spec.key == "custom":
            own.append(f"{self.spec.name}:{self.spec.expr}")
        else:
            lib.append(self.term)
        parts = [f"--terms '{','.join(lib)}'"] if lib else []
        return " ".join(parts + [f"--term '{o}'" for o in own])

    def to_dict(self) -> dict:
        return {"term": self.term, "effect": self.effect, "class": self.klass,
                "replaces": self.replaces, "lr": self.lr, "df": self.df,
                "searched": self.searched, "p": self.p, "p_family": self.p_family,
                "trials": self.trials, "delta_bic": self.dbic, "theta": self.theta,
                "significant": self.significant, "degenerate": self.degenerate,
                "equivalents": self.equivalents, "separate_by": self.advice,
                "note": self.note, "limited_by_sensors": self.sensor_reason,
                "lr_at_model_noise_shape": self.lr_fixed, "lr_refitted": self.lr_refit, "rms_fit_dph": self.rms_fit,
                "rms_holdout_dph": self.rms_holdout, "improvement_pct": self.improvement_pct,
                "z": self.z, "coefficients": self.coefficients, "evidence": self.evidence,
                "error": self.error}


def _fmt_p(p: float) -> str:
    if not math.isfinite(p):
        return "n/a"
    if p < 1e-300:
        return "< 1e-300"
    return f"{p:.2g}"


@dataclass
class Removal:
    """A model term the data do not support: the model without it has the better BIC."""

    term: str
    lr: float
    df: int
    dbic: float

    @property
    def text(self) -> str:
        return (f"the data do not support {self.term} (Λ = {self.lr:.1f} on {self.df} "
                f"parameter{'s' if self.df != 1 else ''}, ΔBIC of removing it "
                f"{self.dbic:+.1f}): the model does as well without it; remove it")

    def to_dict(self) -> dict:
        return {"term": self.term, "lr": self.lr, "df": self.df, "delta_bic": self.dbic,
                "text": self.text}
