"""gyrotest: gyro test-bench logs to an IEEE-952-style specification sheet.

The public Python API (the command line is a client of it)::

    import gyrotest
    res = gyrotest.allan("static.parquet", profile="static.profile.toml", skip="30min")
    res.term("N").value, res.to_frame(), res.plot()

Every function takes a path, a pandas DataFrame or a numpy array with its sample interval and
unit (or a list of them where the command takes several logs), keyword-only options with the
command line's names, and returns a result with ``to_dict()`` (the ``--json`` document),
``to_frame()``, ``plot(ax=None)`` and an HTML view for notebooks. Errors are
:class:`GyrotestError` subclasses naming the file, row or column and the fix.

The names load on first use (module ``__getattr__``): ``import gyrotest`` imports neither
numpy nor pandas, so the command line starts fast.
"""

from __future__ import annotations

import importlib

from .core.errors import AnalysisError, GyrotestError, InputError, OptionError

__version__ = "0.1.0"

#: public name -> module (under gyrotest) that defines it
_LAZY: dict[str, str] = {
    "read": "api.analyses",
    "allan": "api.analyses",
    "bias": "api.analyses",
    "scale_factor": "api.analyses",
    "thermal_fit": "api.models",
    "mag_fit": "api.models",
    "Model": "api.models",
    "compensate": "api.models",
    "report": "api.campaign",
    "simulate": "api.campaign",
    "GyroLog": "core.data",
    "AllanResult": "api.results",
    "BiasResult": "api.results",
    "ScaleFactorResult": "api.results",
    "ThermalResult": "api.modelresults",
    "MagResult": "api.modelresults",
    "ModelFit": "api.modelresults",
    "ModelDiagnosis": "api.modelresults",
    "CompensationResult": "api.modelresults",
    "Report": "api.results",
    "Simulation": "api.results",
}

#: the public API (a test fails when it changes without a CHANGELOG line)
__all__ = [
    "read", "allan", "bias", "scale_factor", "thermal_fit", "mag_fit", "Model", "compensate",
    "report", "simulate",
    "GyroLog", "AllanResult", "BiasResult", "ScaleFactorResult", "ThermalResult", "MagResult",
    "ModelFit", "ModelDiagnosis", "CompensationResult", "Report", "Simulation",
    "GyrotestError", "InputError", "OptionError", "AnalysisError",
    "__version__",
]


def __getattr__(name: str):
    mod = _LAZY.get(name)
    if mod is None:
        raise AttributeError(f"module 'gyrotest' has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{mod}", __name__), name)
    globals()[name] = value  # the next access is a plain attribute
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
