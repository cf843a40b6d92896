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

from .compensate import CompensationResult, compensate
from .diagnose import Candidate, Diagnosis, diagnose
from .domain import (
                     MagResult,
                     SetpointResult,
                     ThermalResult,
                     mag_fit,
                     thermal_fit,
                     thermal_fit_setpoints,
)
from .fit import FitResult, WorkData, choose_resolution, choose_smoothing, fit_model, prepare
from .history import append_history, load_history
from .model import EnvModel
from .terms import EFFECTS, EnvFrame, TermSpec, parse_terms

__all__ = ["EFFECTS", "Candidate", "CompensationResult", "Diagnosis", "EnvFrame", "EnvModel",
           "FitResult", "MagResult", "SetpointResult", "TermSpec", "ThermalResult", "WorkData",
           "append_history", "choose_resolution", "choose_smoothing", "compensate", "diagnose",
           "fit_model", "load_history", "mag_fit", "parse_terms", "prepare", "thermal_fit",
           "thermal_fit_setpoints"]
