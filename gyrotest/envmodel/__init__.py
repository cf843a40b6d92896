"""The model workbench: fit environmental drift models, see where they fail, find the missing
physical effect, keep a history of the steps, and apply a model to another run.

Core API (arrays / GyroLog in, dataclasses out; the CLI and the spec-sheet report call these):

* :func:`prepare` — a log at the working resolution (block means; see :mod:`.fit`);
* :func:`fit_model` — coefficients ± HAC uncertainty, held-out RMS, AIC/BIC, collinearity,
  residual Allan deviation, noise floor, excursions → :class:`FitResult` (``.model`` is the
  portable :class:`EnvModel`);
* :func:`diagnose` — rank the candidate terms the model lacks → :class:`Diagnosis`;
* :func:`thermal_fit`, :func:`thermal_fit_setpoints`, :func:`mag_fit` — domain fits;
* :func:`compensate` — apply a model to another run → :class:`CompensationResult`;
* :mod:`.terms` — the library of physical effects (one documented function per effect).
"""

from .fit import FitResult, WorkData, choose_resolution, fit_model, prepare
from .model import EnvModel
from .terms import EFFECTS, EnvFrame, TermSpec, parse_terms

__all__ = ["EFFECTS", "EnvFrame", "EnvModel", "FitResult", "TermSpec", "WorkData",
           "choose_resolution", "fit_model", "parse_terms", "prepare"]
