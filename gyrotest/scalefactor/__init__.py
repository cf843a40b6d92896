"""Scale factor from rate-table runs (IEEE 952 §12.9.4, model equation ε_K of §8.3).

Pipeline (all pure: numpy/pandas in, dataclasses out)::

    from gyrotest.scalefactor import extract_plateaus, analyse, reduce_logs

    runs = [extract_plateaus(log, settle_s=10) for log in logs]   # RunPlateaus per log
    res = analyse(runs, output_kind="counts", nominal_scale_factor=0.5)
    res.scale_factor, res.scale_factor_sigma        # arcsec/pulse (mean over runs)
    res.model.f_ppm(I_dph)                           # f(I) of ε_K, ppm
    res.to_dict()                                    # JSON-ready, units in the key names

or simply ``reduce_logs(logs, settle_s=10)``. Modules:

* :mod:`.plateaus` — plateau extraction (commanded column or step detection), batch-means
  standard errors, rate snapping, sweeps;
* :mod:`.fit` — weighted least squares, nonlinearity terms f(I), forward model selection
  (F-test + AICc), rate-periodic scan, linearity, asymmetry, lock-in;
* :mod:`.analysis` — per-run and combined results: SF, bias, repeatability, stability,
  temperature sensitivity;
* :mod:`.points` — the plateau table on disk (``--points`` / ``--table``);
* :mod:`.plot` — residuals vs input rate and raw output vs time with the plateaus.
"""

from __future__ import annotations

from pathlib import Path

from ..errors import InputError
from .analysis import PULSE_KINDS, ScaleFactorResult, analyse, scale_factor_from_slope, sf_unit
from .fit import TERMS, Points, fit_model, line_fit, select_model, wls
from .plateaus import (
    Plateau,
    RunPlateaus,
    allan_stderr,
    detect_steps,
    extract_plateaus,
    mean_stderr,
    snap_rates,
)
from .points import read_points_table, write_points_csv

__all__ = [
    "PULSE_KINDS", "Plateau", "Points", "RunPlateaus", "ScaleFactorResult", "TERMS",
    "allan_stderr", "analyse",
    "check_runs_match", "detect_steps", "extract_plateaus", "fit_model", "line_fit",
    "mean_stderr", "read_points_table", "reduce_logs", "scale_factor_from_slope",
    "run_name", "select_model", "sf_unit", "snap_rates", "write_points_csv", "wls",
]


def check_runs_match(logs) -> None:
    """Runs reduced together must come from the same kind of output, nominal scale factor and
    gyro serial: raise :class:`InputError` naming the first mismatch."""
    g0 = logs[0].gyro
    for lg in logs[1:]:
        g = lg.gyro
        if g.output_kind != g0.output_kind:
            raise InputError(f"mismatched runs: {logs[0].source} has {g0.output_kind} output, "
                             f"{lg.source} has {g.output_kind}; reduce them separately")
        s0, s1 = g0.scale_factor, g.scale_factor
        if (s0 is None) != (s1 is None) or (s0 is not None and abs(s1 / s0 - 1) > 1e-12):
            raise InputError(f"mismatched runs: nominal scale factor {s0} in {logs[0].source} but "
                             f"{s1} in {lg.source}; use the same S0 for every run")
        if g0.serial and g.serial and g0.serial != g.serial:
            raise InputError(f"mismatched runs: gyro serial {g0.serial} in {logs[0].source} but "
                             f"{g.serial} in {lg.source}")


def run_name(source: str) -> str:
    """Run label from a log path: its file stem."""
    return Path(source).stem if source not in ("-", "<stdin>") else "stdin"


def reduce_logs(logs, *, settle_s: float = 10.0, trim_end_s: float = 0.0,
                min_dwell_s: float = 2.0, detect: str = "auto",
                rates_dps: list[float] | None = None, snap_tol: float = 3e-3,
                stderr: str = "allan", **analyse_kw) -> ScaleFactorResult:
    """Extract the plateaus of each log (one log = one run) and :func:`analyse` them.
    Keyword arguments as in :func:`extract_plateaus` and :func:`analyse`."""
    if not logs:
        raise InputError("no log given")
    check_runs_match(logs)
    runs = [extract_plateaus(lg, run_name(lg.source), settle_s=settle_s, trim_end_s=trim_end_s,
                             min_dwell_s=min_dwell_s, detect=detect, rates_dps=rates_dps,
                             snap_tol=snap_tol, stderr=stderr) for lg in logs]
    g = logs[0].gyro
    return analyse(runs, output_kind=g.output_kind, nominal_scale_factor=g.scale_factor,
                   **analyse_kw)
