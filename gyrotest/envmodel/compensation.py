"""Applying a fitted model to another run: the transfer test a lab does before trusting a
compensation.

``compensated rate = rate − model drift`` (the model's bias is kept out of the subtraction with
``keep_bias``). Before/after are compared at the model's own working resolution (same block
length and smoother), so the achieved improvement can be set against the one the model
predicts: its held-out residual RMS on the fitting run.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from . import stats as st
from .model import EnvModel
from .modelfit import prepare


@dataclass
class CompensationResult:
    """Before/after drift and Allan deviation of a compensated run."""

    source: str
    axis: str
    rms_before_dph: float
    rms_after_dph: float
    p2p_before_dph: float
    p2p_after_dph: float
    predicted_rms_after_dph: float
    resolution_s: float
    adev_tau: np.ndarray
    adev_before: np.ndarray
    adev_after: np.ndarray
    warnings: list[str] = field(default_factory=list)
    model_terms: list[str] = field(default_factory=list)
    log: Any = None  # compensated GyroLog
    prediction: np.ndarray | None = None
    t_blocks: np.ndarray | None = None
    y_before: np.ndarray | None = None
    y_after: np.ndarray | None = None

    @property
    def factor(self) -> float:
        """Achieved drift reduction, RMS before / RMS after."""
        return self.rms_before_dph / self.rms_after_dph if self.rms_after_dph > 0 else math.inf

    @property
    def predicted_factor(self) -> float:
        """The reduction the model predicts: RMS before / the model's held-out RMS."""
        p = self.predicted_rms_after_dph
        return self.rms_before_dph / p if p and p > 0 else math.nan

    def to_dict(self) -> dict:
        return {"source": self.source, "axis": self.axis, "model_terms": self.model_terms,
                "resolution_s": self.resolution_s,
                "drift_rms_before_dph": self.rms_before_dph,
                "drift_rms_after_dph": self.rms_after_dph,
                "drift_p2p_before_dph": self.p2p_before_dph,
                "drift_p2p_after_dph": self.p2p_after_dph,
                "reduction_factor": self.factor,
                "predicted_rms_after_dph": self.predicted_rms_after_dph,
                "predicted_reduction_factor": self.predicted_factor,
                "achieved_over_predicted": (self.factor / self.predicted_factor
                                            if math.isfinite(self.predicted_factor) else None),
                "allan": {"tau_s": self.adev_tau, "sigma_before_dph": self.adev_before,
                          "sigma_after_dph": self.adev_after},
                "warnings": self.warnings}


def compensate(log, model: EnvModel, *, keep_bias: bool = False) -> CompensationResult:
    """Subtract ``model``'s drift from ``log`` and compare before/after.

    Drift RMS and peak-to-peak (deg/h) are taken of the smoothed block means at the model's
    working resolution (mean removed); the Allan deviation (overlapping, octave τ) of the full
    rate before and after. The predicted RMS after compensation is the model's held-out RMS.
    A log without a channel the model needs is an InputError naming the term and channel
    (raised when :meth:`EnvModel.predict` resolves the terms, as :meth:`EnvModel.check_log`).
    This is the whole analysis of ``gyrotest compensate``.
    """
    axis = model.axis if model.axis in log.rates else log.axes[0]
    pred = model.predict(log, include_bias=not keep_bias)
    out = copy.copy(log)
    out.rates = dict(log.rates)
    out.rates[axis] = np.asarray(log.rates[axis], float) - pred
    out.extra = dict(log.extra)
    out.extra["model_drift_dph"] = pred
    out.units = dict(log.units)
    out.units["model_drift_dph"] = "deg/h"
    labels = [s.label for s in model.specs]
    out.notes = list(log.notes) + [f"compensated with a gyrotest model ({', '.join(labels)})"]
    kw = dict(axis=axis, resolution=model.resolution_s, smoothing_s=model.refs.smoothing_s,
              fine_dt=model.fine_dt_s)
    wb = prepare(log, **kw)
    wa = prepare(out, **kw)
    yb, ya = wb.y - wb.y.mean(), wa.y - wa.y.mean()
    rate_b = np.asarray(log.rates[axis], float)
    if log.table_rate is not None:
        rate_b = rate_b - log.table_rate
    rate_a = rate_b - pred
    tau, sb = st.oadev(rate_b, log.tau0, segments=log.segments)
    tau2, sa = st.oadev(rate_a, log.tau0, segments=log.segments)
    n = min(len(tau), len(tau2))
    return CompensationResult(
        source=log.source, axis=axis, rms_before_dph=float(np.sqrt(np.mean(yb ** 2))),
        rms_after_dph=float(np.sqrt(np.mean(ya ** 2))), p2p_before_dph=float(np.ptp(yb)),
        p2p_after_dph=float(np.ptp(ya)),
        predicted_rms_after_dph=float(model.fit.get("rms_holdout_dph", math.nan)),
        resolution_s=wb.resolution_s, adev_tau=tau[:n], adev_before=sb[:n], adev_after=sa[:n],
        warnings=model.domain_warnings(log), model_terms=labels,
        log=out, prediction=pred, t_blocks=wb.t, y_before=wb.y, y_after=wa.y)
