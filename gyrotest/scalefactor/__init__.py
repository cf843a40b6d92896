"""Scale factor from rate-table runs (IEEE 952 §12.9.4, model equation ε_K of §8.3).

Pipeline (all pure: numpy/pandas in, dataclasses out)::

    from gyrotest.scalefactor import extract_plateaus, analyse, reduce_logs

    runs = [extract_plateaus(log) for log in logs]   # RunPlateaus per log (settling from the data)
    res = analyse(runs, output_kind="counts", nominal_scale_factor=0.5)
    res.scale_factor, res.scale_factor_sigma        # arcsec/pulse (mean over runs)
    res.model.f_ppm(I_dph)                           # f(I) of ε_K, ppm
    res.to_dict()                                    # JSON-ready, units in the key names

or simply ``reduce_logs(logs)`` (what ``gyrotest scale-factor`` and the spec-sheet
report call; ``reduce_table(path)`` for a ready plateau table). Modules:

* :mod:`.settling` — the settling time of each plateau, found from its data;
* :mod:`.plateaus` — plateau extraction (commanded column or step detection), batch-means
  standard errors, rate snapping, sweeps;
* :mod:`.tablefit` — weighted least squares, nonlinearity terms f(I), forward model selection
  (F-test + AICc), rate-periodic scan;
* :mod:`.characteristics` — linearity, asymmetry, lock-in (§5.3.2.1);
* :mod:`.analysis` — per-run and combined results: SF, bias, repeatability, stability,
  temperature sensitivity (the result types: :mod:`.sfresult`);
* :mod:`.points` — the plateau table on disk (``--points`` / ``--table``);
* :mod:`.plots` — residuals vs input rate and raw output vs time with the plateaus.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

from ..core.errors import InputError
from .analysis import (
    ASYMMETRY_SKIPPED,
    PULSE_KINDS,
    analyse,
    scale_factor_from_slope,
    sf_unit,
)
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
from .settling import SettlingFound, find_settling
from .sfresult import ScaleFactorResult
from .tablefit import TERMS, Points, fit_model, line_fit, select_model, wls

__all__ = [
    "ASYMMETRY_SKIPPED", "PULSE_KINDS", "Plateau", "Points", "RunPlateaus", "ScaleFactorResult",
    "SettlingFound", "TERMS", "find_settling",
    "allan_stderr", "analyse", "check_runs_match", "check_settings", "detect_steps",
    "extract_plateaus", "fit_model", "line_fit", "mean_stderr", "parse_rates",
    "parse_term_choice", "read_points_table", "reduce_logs", "reduce_table",
    "scale_factor_document", "scale_factor_from_slope", "run_name", "select_model", "sf_unit",
    "snap_rates", "write_points_csv", "wls",
]


def parse_rates(value: str | None) -> list[float] | None:
    """Commanded rates ``"1,2,5,10"`` (deg/s, ± implied; ``--rates``) → [1.0, 2.0, ...]."""
    if value is None:
        return None
    try:
        out = [abs(float(v)) for v in value.replace(";", ",").split(",") if v.strip()]
    except ValueError:
        raise InputError(f"--rates {value!r}: write rates in deg/s separated by commas, e.g. "
                         "1,2,5,10,20,50,100,200,500") from None
    if not out or not all(math.isfinite(v) for v in out):
        raise InputError(f"--rates {value!r}: no usable rate")
    return out


def parse_term_choice(value: str) -> str | list[str]:
    """``--terms``: ``auto``, ``linear`` (also ``none``) or a list of nonlinearity terms
    (``u1`` … ``u4``; their earlier names ``quadratic`` … ``quintic`` are read too)."""
    from .tablefit import canonical_terms

    v = value.strip().lower()
    if v in ("auto", "linear", "none"):
        return v if v != "none" else "linear"
    return canonical_terms(t for t in v.split(",") if t.strip())


def check_settings(*, settle_s: float = 0.0, trim_end_s: float = 0.0, min_dwell_s: float = 2.0,
                   alpha: float = 0.05, snap_tol: float = 3e-3,
                   full_scale_dps: float | None = None) -> None:
    """InputError for settings no reduction can use (the command checks them before it reads
    a log; :func:`reduce_logs` and :func:`reduce_table` check them again)."""
    if min(settle_s, trim_end_s, min_dwell_s) < 0:
        raise InputError("--settle, --trim-end and --min-dwell must not be negative")
    if not 0 < alpha < 1:
        raise InputError(f"--alpha {alpha} must be between 0 and 1")
    if not snap_tol > 0:
        raise InputError(f"--snap-tol {snap_tol} must be positive")
    if full_scale_dps is not None and not full_scale_dps > 0:
        raise InputError(f"--full-scale {full_scale_dps} must be a positive rate in deg/s")


def _check_asymmetry(result: ScaleFactorResult) -> None:
    """InputError when the reduction had no negative rates (asymmetry not computed)."""
    if any(n.startswith(ASYMMETRY_SKIPPED) for n in result.notes):
        raise InputError("no negative input rates: the asymmetry (IEEE 952 §12.9.4.2.2) cannot be "
                         "computed; add negative rates to the table sequence, or pass "
                         "--no-asymmetry to reduce without it")


def scale_factor_document(result: ScaleFactorResult, *, plot: str | None = None,
                          points_file: str | None = None) -> dict:
    """The JSON document of ``gyrotest scale-factor --json`` (with the files written)."""
    d = result.to_dict()
    d["command"] = "scale-factor"
    if plot:
        d["plot"] = str(plot)
    if points_file:
        d["points_file"] = str(points_file)
    return d


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


def reduce_logs(logs, *, settle_s: float = 0.0, auto_settle: bool = True,
                trim_end_s: float = 0.0,
                min_dwell_s: float = 2.0, detect: str = "auto",
                rates_dps: list[float] | None = None, snap_tol: float = 3e-3,
                stderr: str = "allan", require_asymmetry: bool = False,
                **analyse_kw) -> ScaleFactorResult:
    """Extract the plateaus of each log (one log = one run) and :func:`analyse` them: the
    reduction of ``gyrotest scale-factor LOGS``. Keyword arguments as in
    :func:`extract_plateaus` and :func:`analyse` (checked by :func:`check_settings`): the
    settling of each plateau is found from its data, at least ``settle_s``
    (``auto_settle=False``: exactly ``settle_s``). With
    ``require_asymmetry`` (the command's default; ``--no-asymmetry`` turns it off), runs
    without negative input rates are an InputError instead of a note."""
    if not logs:
        raise InputError("no log given")
    check_settings(settle_s=settle_s, trim_end_s=trim_end_s, min_dwell_s=min_dwell_s,
                   snap_tol=snap_tol, alpha=analyse_kw.get("alpha", 0.05),
                   full_scale_dps=analyse_kw.get("full_scale_dps"))
    check_runs_match(logs)
    runs = [extract_plateaus(lg, run_name(lg.source), settle_s=settle_s,
                             auto_settle=auto_settle, trim_end_s=trim_end_s,
                             min_dwell_s=min_dwell_s, detect=detect, rates_dps=rates_dps,
                             snap_tol=snap_tol, stderr=stderr) for lg in logs]
    g = logs[0].gyro
    result = analyse(runs, output_kind=g.output_kind, nominal_scale_factor=g.scale_factor,
                     **analyse_kw)
    if require_asymmetry:
        _check_asymmetry(result)
    return result


def reduce_table(path: str | Path, *, latitude_deg: float | None = None, ia: str | None = None,
                 scale_factor: float | None = None, require_asymmetry: bool = False,
                 on_note: Callable[[str], None] | None = None,
                 **analyse_kw) -> ScaleFactorResult:
    """:func:`analyse` a ready plateau table (``gyrotest scale-factor --table FILE``): the
    input is the table rate plus the earth rate along ``ia`` (default up) when
    ``latitude_deg`` is given. ``on_note`` receives the table reader's notes before the
    analysis; ``require_asymmetry`` as in :func:`reduce_logs`."""
    check_settings(alpha=analyse_kw.get("alpha", 0.05),
                   full_scale_dps=analyse_kw.get("full_scale_dps"))
    er = None
    if latitude_deg is not None:
        from ..core.earth import check_latitude, earth_rate_component, parse_ia

        az, el, _ = parse_ia(ia or "up")
        er = earth_rate_component(check_latitude(latitude_deg), az, el)
    runs, kind, s0, notes = read_points_table(path, earth_rate_dph=er, scale_factor=scale_factor)
    for n in notes:
        if on_note is not None:
            on_note(n)
    result = analyse(runs, output_kind=kind, nominal_scale_factor=s0, **analyse_kw)
    if require_asymmetry:
        _check_asymmetry(result)
    return result
