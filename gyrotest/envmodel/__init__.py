"""The model workbench: fit environmental drift models, see where they fail, find the missing
physical effect, keep a history of the steps, and apply a model to another run.

Core API (arrays / GyroLog in, dataclasses out; the CLI and the spec-sheet report call these):

* :func:`prepare` — a log at the working resolution (block means; see :mod:`.modelfit`);
* :func:`fit_model` — coefficients ± 1σ (GLS under the gyro's own noise model, fitted by
  maximum likelihood: :mod:`.likelihood`), held-out RMS, log-likelihood, AIC/BIC,
  collinearity, residual Allan deviation, excursions → :class:`FitResult` (``.model`` is
  the portable :class:`EnvModel`);
* :func:`diagnose` — test every candidate term the model lacks by its likelihood ratio at a
  family-wise α (:mod:`.selection`) → :class:`Diagnosis` (:mod:`.workbench`);
* :func:`thermal_fit`, :func:`thermal_fit_setpoints`, :func:`mag_fit` — domain fits;
* :func:`compensate` — apply a model to another run → :class:`CompensationResult`;
* the commands' analyses from a loaded log and their options: :func:`fit_log` (``model
  fit``), :func:`diagnose_log` (``model diagnose``), :func:`analyse_thermal`
  (``thermal-fit``), :func:`analyse_mag` (``mag-fit``); :mod:`.pipeline` holds the shared
  steps (:func:`naming_terms`, :func:`prepare_log`, :func:`collect_terms`);
* :mod:`.terms` — the library of physical effects (one documented function per effect).
"""

# the effects defined in their own module (channel_terms) register themselves in
# terms.EFFECTS when it is imported: here, so that any import of the package completes the
# registry
from . import channel_terms  # noqa: F401
from .candidate import Candidate
from .compensation import CompensationResult, compensate
from .domain import (
    MagResult,
    SetpointResult,
    ThermalAnalysis,
    ThermalResult,
    analyse_mag,
    analyse_thermal,
    mag_fit,
    thermal_fit,
    thermal_fit_setpoints,
)
from .history import append_history, load_history
from .model import EnvModel
from .modelfit import (
    FitResult,
    WorkData,
    choose_resolution,
    choose_smoothing,
    fit_model,
    prepare,
)
from .pipeline import collect_terms, fit_log, naming_terms, prepare_log
from .terms import EFFECTS, EnvFrame, TermSpec, parse_terms
from .workbench import Diagnosis, diagnose, diagnose_log

__all__ = ["EFFECTS", "Candidate", "CompensationResult", "Diagnosis", "EnvFrame", "EnvModel",
           "FitResult", "MagResult", "SetpointResult", "TermSpec", "ThermalAnalysis",
           "ThermalResult", "WorkData", "analyse_mag", "analyse_thermal", "append_history",
           "choose_resolution", "choose_smoothing", "collect_terms", "compensate", "diagnose",
           "diagnose_log", "fit_log", "fit_model", "naming_terms", "load_history", "mag_fit",
           "parse_terms", "prepare", "prepare_log", "thermal_fit", "thermal_fit_setpoints"]
