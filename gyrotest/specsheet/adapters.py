"""Section adapters: each test of a campaign through the SAME core calls as its command.

One small function per analysis. Each turns the campaign options into exactly the arguments
the command-line module would pass (``gyrotest/cli/cmd_<name>.py``), calls the core, and
returns an :class:`Analysis` holding

* ``result`` -- the document the command prints with ``--json`` (built by the same
  ``to_dict()`` calls, passed through :func:`gyrotest.core.output.jsonable`);
* ``argv`` -- the equivalent command line (paths relative to the campaign directory), so the
  sheet can be regenerated and checked number by number against the individual commands;
* ``obj`` -- the result objects, for the figures.

The command bodies themselves live in the core (``analyse_bias``, ``analyse_allan``,
``reduce_logs``, ``analyse_thermal``, ``analyse_mag``, ``fit_log``); an adapter only reads
the campaign's options with the commands' own parsers and calls them. Logs are read once per
(file, profile, ingest options) through :class:`LogCache`, with the CLI's own ingest path
(:func:`gyrotest.io.inputs.read_with_options`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..core.errors import InputError
from ..core.output import jsonable
from .campaign import TESTS, Campaign, Test


@dataclass
class Analysis:
    """One command's worth of analysis inside the report."""

    key: str  # "bias", "allan", "thermal", "thermal.step2", "info:static.parquet" ...
    test: str  # campaign test name
    command: str  # command name as typed: "bias", "model fit", "info" ...
    argv: list[str]  # equivalent command line without "--json"
    result: dict[str, Any]  # what the command prints with --json
    obj: Any = None
    logs: list = field(default_factory=list)
    seconds: float = 0.0

    def to_dict(self) -> dict[str, Any]:
        """JSON form (the argv starts with "gyrotest")."""
        return {"key": self.key, "test": self.test, "command": self.command,
                "argv": ["gyrotest", *self.argv], "seconds": self.seconds}


# ----------------------------------------------------------------------------- ingest
def _cli_flag(key: str) -> str:
    return {"nan_policy": "--nan", "field_cols": "--field-col"}.get(
        key, "--" + key.replace("_", "-"))


def thermal_t_ref(test: Test) -> float:
    """The thermal test's reference temperature, degC: ``t_ref`` (``t0``, its old name), 21."""
    return float(test.opt("t_ref", test.opt("t0", 21.0)))


def ingest_opts(test: Test, campaign: Campaign) -> tuple[dict[str, Any], list[str]]:
    """The shared ingest options of a test as :func:`load_log` takes them, and as argv."""
    opts: dict[str, Any] = {"nan_policy": "error"}
    argv: list[str] = []
    if test.profile is not None:
        opts["profile"] = str(test.profile)
        argv += ["--profile", campaign.rel(test.profile)]
    for k, v in test.ingest.items():
        if k == "temp_col":
            vals = [v] if isinstance(v, str) else list(v)
            opts["temp_col"] = tuple(vals)
            for x in vals:
                argv += ["--temp-col", x]
            continue
        opts[k] = v
        argv += [_cli_flag(k), f"{v:g}" if isinstance(v, float) else str(v)]
    lat = campaign.site.get("latitude_deg")
    if lat is not None:
        opts["latitude"] = float(lat)
        argv += ["--latitude", repr(float(lat))]
    return opts, argv


class LogCache:
    """Read each log once per (file, ingest options); the CLI's ingest path."""

    def __init__(self) -> None:
        self._logs: dict[tuple, Any] = {}
        self.seconds = 0.0

    def get(self, path: Path, opts: dict[str, Any], specs: list | None = None):
        """The :class:`~gyrotest.core.data.GyroLog` of ``path`` read with ``opts`` (like the
        commands: :func:`~gyrotest.io.inputs.read_with_options`, the errors about a channel a model
        term needs naming the term, :func:`~gyrotest.envmodel.pipeline.naming_terms`)."""
        key = (str(path), tuple(sorted((k, str(v)) for k, v in opts.items())))
        if key not in self._logs:
            t0 = time.perf_counter()
            from ..envmodel.pipeline import naming_terms
            from ..io.inputs import read_with_options

            log = naming_terms(lambda: read_with_options(str(path), opts), specs or [])
            self.seconds += time.perf_counter() - t0
            self._logs[key] = log
        return self._logs[key]


def option_argv(test: Test, keys: tuple[str, ...] | None = None) -> list[str]:
    """argv for the test's analysis options (those with a command-line option)."""
    spec = {**TESTS[test.name], "axis": ("str", "--axis", "")}
    argv: list[str] = []
    for k, v in test.options.items():
        if keys is not None and k not in keys:
            continue
        typ, flag, _ = spec.get(k, (None, None, None))
        if flag is None:
            continue
        if typ == "bool":
            if v:
                argv.append(flag)
        elif k == "gradient":
            argv += [flag, ",".join(v)]
        elif typ == "strs":
            for x in v:
                argv += [flag, x]
        elif isinstance(v, Path):
            continue  # paths are added by the adapter (relative to the campaign)
        elif isinstance(v, float):
            argv += [flag, repr(v)]
        else:
            argv += [flag, str(v)]
    return argv


def _timed(fn: Callable[[], tuple[dict, Any, list]]) -> tuple[dict, Any, list, float]:
    t0 = time.perf_counter()
    res, obj, logs = fn()
    return jsonable(res), obj, logs, time.perf_counter() - t0


# ----------------------------------------------------------------------------- bias
def run_bias(test: Test, campaign: Campaign, cache: LogCache, key: str = "bias") -> Analysis:
    """``gyrotest bias LOGS --skip ...`` (static runs: D_F, repeatability) or, for the
    multi-position test, ``gyrotest bias LOG --settle ...``: every gyro axis (or the test's
    ``axis``) with :func:`gyrotest.staticbias.multiaxis.analyse_bias_axes`, as the command does; the
    object kept is the first axis' :class:`~gyrotest.staticbias.analysis.BiasAnalysis`."""
    from ..core.units import parse_duration, parse_rate_dph
    from ..staticbias.multiaxis import analyse_bias_axes

    opts, iargv = ingest_opts(test, campaign)
    paths = test.logs

    def go():
        """The command body: returns (result, objects, logs)."""
        skip_s = parse_duration(test.opt("skip", "0"), what="--skip")
        settle_s = parse_duration(test.opt("settle", "0"), what="--settle")
        band = test.opt("warmup_band")
        logs = [cache.get(p, opts) for p in paths]
        res = analyse_bias_axes(logs, skip_s=skip_s, settle_s=settle_s, axis=test.opt("axis"),
                                earth_rate=not test.opt("no_earth_rate", False),
                                warmup_band_dph=(parse_rate_dph(band, what="warmup_band")
                                                 if band is not None else None),
                                warmup_block_s=parse_duration(test.opt("warmup_block", "60s"),
                                                              what="warmup_block"))
        return res.to_dict(), next(iter(res.per_axis.values())), logs

    res, obj, logs, dt = _timed(go)
    argv = ["bias", *[campaign.rel(p) for p in paths], *iargv, *option_argv(test)]
    return Analysis(key, test.name, "bias", argv, res, obj, logs, dt)


# ----------------------------------------------------------------------------- allan
def run_allan(test: Test, campaign: Campaign, cache: LogCache) -> Analysis:
    """``gyrotest allan LOG --skip ... --terms ... --vehicle-rate ... --horizon ...``
    (cli/cmd_allan.py): :func:`gyrotest.noise.analysis.analyse_allan`."""
    from ..noise.allanresult import allan_document
    from ..noise.analysis import analyse_allan, parse_taus
    from ..noise.impact import parse_horizon, parse_vehicle_rate
    from ..noise.noisefit import MIN_EDF, parse_terms

    opts, iargv = ingest_opts(test, campaign)

    def go():
        """The command body: returns (result, objects, logs)."""
        horizon_s = parse_horizon(test.opt("horizon", "1h"))
        rates = [parse_vehicle_rate(v) for v in test.opt("vehicle_rates", [])]
        env_model = None
        if test.opt("model"):
            from ..envmodel.model import EnvModel

            env_model = EnvModel.load(test.opt("model"))
        g = cache.get(test.logs[0], opts)
        axes = [test.opt("axis")] if test.opt("axis") else None
        r = analyse_allan(
            g, skip_s=test.opt("skip", "0"), dev="oadev",
            taus=parse_taus(test.opt("taus", "10/decade")),
            terms=parse_terms(test.opt("terms", "Q,N,B,K,R")), vehicle_rates=rates, axes=axes,
            confidence=0.683, stop_ratio=None, min_edf=MIN_EDF,
            detrend=test.opt("detrend", "none"),
            run_diagnosis=not test.opt("no_diagnose", False), impact_horizon_s=horizon_s,
            bi_cutoff_hz=test.opt("bi_cutoff_hz"), allow_irregular=False, env_model=env_model,
            accelerometers=False)  # the gyro section; [tests.accel] has the accelerometers
        _need_fits(r)
        return allan_document([r]), r, [g]

    res, obj, logs, dt = _timed(go)
    argv = ["allan", campaign.rel(test.logs[0]), *iargv, *option_argv(test)]
    if test.opt("model"):
        argv += ["--model", campaign.rel(test.opt("model"))]
    return Analysis("allan", test.name, "allan", argv, res, obj, logs, dt)


def _need_fits(r) -> None:
    """The report needs the noise model of every axis (the CLI may print a bare table)."""
    from ..core.errors import AnalysisError

    for ax in r.axes:
        if ax.fit is None:
            raise AnalysisError(f"{r.source} [{ax.axis}]: " + next(
                (n for n in ax.notes if n.startswith("noise model not fitted")),
                "noise model not fitted"))


# ----------------------------------------------------------------------------- accelerometers
def run_accel(test: Test, campaign: Campaign, cache: LogCache) -> Analysis:
    """``gyrotest allan LOG --axis ax,ay,az ...``: the Allan analysis of the log's accelerometer
    axes (:func:`gyrotest.io.accel.accel_channels`; IEEE Std 1293 terms). An error when the log
    has none."""
    from ..io.accel import accel_channels
    from ..noise.allanresult import allan_document
    from ..noise.analysis import analyse_allan, parse_taus
    from ..noise.noisefit import MIN_EDF, parse_terms

    opts, iargv = ingest_opts(test, campaign)

    def go():
        """The command body: returns (result, objects, logs)."""
        g = cache.get(test.logs[0], opts)
        acc = accel_channels(g)
        if not acc:
            raise InputError(f"{campaign.rel(test.logs[0])}: no accelerometer columns "
                             "(ax/ay/az, acc_x ... with a unit: ax_g, acc_x_mps2 or [units] in "
                             "the profile)" + (f"; {acc.notes[0]}" if acc.notes else ""))
        r = analyse_allan(
            g, skip_s=test.opt("skip", "0"), dev="oadev",
            taus=parse_taus(test.opt("taus", "10/decade")),
            terms=parse_terms(test.opt("terms", "Q,N,B,K,R")), axes=list(acc.data),
            confidence=0.683, stop_ratio=None, min_edf=MIN_EDF,
            detrend=test.opt("detrend", "none"))
        _need_fits(r)
        return allan_document([r]), r, [g]

    res, obj, logs, dt = _timed(go)
    argv = ["allan", campaign.rel(test.logs[0]), "--axis", ",".join(
        a.axis for a in obj.axes), *iargv, *option_argv(test)]
    return Analysis("accel", test.name, "allan", argv, res, obj, logs, dt)


# ----------------------------------------------------------------------------- scale factor
def run_scale_factor(test: Test, campaign: Campaign, cache: LogCache) -> Analysis:
    """``gyrotest scale-factor LOGS --settle ...`` (cli/cmd_scale_factor.py):
    :func:`gyrotest.scalefactor.reduce_logs` (plateaus of every run, then the analysis)."""
    from .. import scalefactor as sfm
    from ..core.units import parse_duration

    opts, iargv = ingest_opts(test, campaign)

    def go():
        """The command body: returns (result, objects, logs)."""
        loaded = [cache.get(p, opts) for p in test.logs]
        result = sfm.reduce_logs(
            loaded, settle_s=parse_duration(test.opt("settle", "0s"), what="--settle"),
            auto_settle=not test.opt("fixed_settle", False),
            trim_end_s=parse_duration(test.opt("trim_end", "0s"), what="--trim-end"),
            min_dwell_s=parse_duration(test.opt("min_dwell", "2s"), what="--min-dwell"),
            detect=test.opt("detect", "auto"), rates_dps=sfm.parse_rates(test.opt("rates")),
            snap_tol=3e-3, stderr="allan", full_scale_dps=test.opt("full_scale_dps"),
            terms=sfm.parse_term_choice(test.opt("terms", "auto")),
            alpha=test.opt("alpha", 0.05), weighted=True, weighted_line=False, lock_in=True,
            periodic=True, common_rates=bool(test.opt("common_rates", False)),
            require_asymmetry=not test.opt("no_asymmetry", False))
        return sfm.scale_factor_document(result), result, loaded

    res, obj, logs, dt = _timed(go)
    argv = ["scale-factor", *[campaign.rel(p) for p in test.logs], *iargv, *option_argv(test)]
    return Analysis("scale_factor", test.name, "scale-factor", argv, res, obj, logs, dt)


# ----------------------------------------------------------------------------- environment
def _prep_opts(test: Test) -> dict[str, Any]:
    """The log-preparation options (``--axis --skip --resolution --smooth``) of a test."""
    return {"axis": test.opt("axis"), "skip": test.opt("skip", "0"),
            "resolution": test.opt("resolution", "auto"), "smooth": test.opt("smooth", "auto")}


def run_thermal(test: Test, campaign: Campaign, cache: LogCache) -> Analysis:
    """``gyrotest thermal-fit LOG --t-ref ... [--sensor] [--gradient A,B] [--setpoints CSV]``
    (cli/cmd_thermal_fit.py): :func:`gyrotest.envmodel.domain.analyse_thermal`."""
    from ..envmodel.domain import analyse_thermal, thermal_terms

    opts, iargv = ingest_opts(test, campaign)
    t0 = thermal_t_ref(test)
    setpoints = test.opt("setpoints")

    def go():
        """The command body: returns (result, objects, logs)."""
        path = test.logs[0] if test.logs else None
        g = cache.get(path, opts, thermal_terms()) if path else None
        ta = analyse_thermal(g, path=str(path) if path else None, setpoints=setpoints,
                             t0_c=t0, sensor=test.opt("sensor"), gradient=test.opt("gradient"),
                             weighted=False, folds=5, **_prep_opts(test))
        return ta.to_dict(), ta, [g] if g is not None else []

    res, obj, logs, dt = _timed(go)
    argv = ["thermal-fit", *[campaign.rel(p) for p in test.logs]]
    if setpoints is not None:
        argv += ["--setpoints", campaign.rel(setpoints)]
    argv += [*iargv, "--t-ref", repr(t0), *option_argv(
        test, ("sensor", "gradient", "axis", "skip", "resolution", "smooth"))]
    return Analysis("thermal", test.name, "thermal-fit", argv, res, obj, logs, dt)


def run_model_fit(test: Test, campaign: Campaign, cache: LogCache, terms: str, key: str, *,
                  t_ref: float | None = None) -> Analysis:
    """``gyrotest model fit LOG --terms TERMS [--t-ref T]`` (cli/cmd_model.py): one step of
    the model workbench, :func:`gyrotest.envmodel.pipeline.fit_log`; ``obj`` is the
    :class:`~gyrotest.envmodel.modelfit.FitResult`."""
    from ..envmodel.modelfit import fit_document
    from ..envmodel.pipeline import collect_terms, fit_log

    opts, iargv = ingest_opts(test, campaign)
    path = test.logs[0]

    def go():
        """The command body: returns (result, objects, logs)."""
        specs = collect_terms((terms,), ())
        g = cache.get(path, opts, specs)
        res = fit_log(g, specs, path=str(path), t_ref=t_ref, folds=5, k_sigma=4.0,
                      **_prep_opts(test))
        return fit_document(res), res, [g]

    res, obj, logs, dt = _timed(go)
    argv = ["model", "fit", campaign.rel(path), "--terms", terms]
    if t_ref is not None:
        argv += ["--t-ref", repr(float(t_ref))]
    argv += [*iargv, *option_argv(test, ("axis", "skip", "resolution", "smooth"))]
    return Analysis(key, test.name, "model fit", argv, res, obj, logs, dt)


def history_steps(analyses: list[Analysis]) -> list:
    """:class:`~gyrotest.envmodel.history.HistoryStep` rows for successive model fits of one
    log, as ``gyrotest model fit -o model.json`` appends them (``model history``)."""
    from ..envmodel.history import make_step

    steps: list = []
    for a in analyses:
        steps.append(make_step(a.obj, steps))
    return steps


def run_magnetic(test: Test, campaign: Campaign, cache: LogCache) -> Analysis:
    """``gyrotest mag-fit LOG [--settle] [--with T]`` (cli/cmd_mag_fit.py):
    :func:`gyrotest.envmodel.domain.analyse_mag`."""
    from ..core.units import parse_duration
    from ..envmodel.domain import analyse_mag, mag_document, mag_terms

    opts, iargv = ingest_opts(test, campaign)
    path = test.logs[0]

    def go():
        """The command body: returns (result, objects, logs)."""
        _, specs = mag_terms(test.opt("with"))
        settle_s = parse_duration(test.opt("settle", "10s"), what="--settle")
        dwell_s = parse_duration(test.opt("min_dwell", "30s"), what="--min-dwell")
        g = cache.get(path, opts, specs)
        mg = analyse_mag(g, path=str(path), with_terms=test.opt("with"), settle_s=settle_s,
                         min_dwell_s=dwell_s, folds=5, **_prep_opts(test))
        return mag_document(mg), mg, [g]

    res, obj, logs, dt = _timed(go)
    argv = ["mag-fit", campaign.rel(path), *iargv, *option_argv(test)]
    return Analysis("magnetic", test.name, "mag-fit", argv, res, obj, logs, dt)


def run_info(path: Path, test: Test, campaign: Campaign, cache: LogCache) -> Analysis:
    """``gyrotest info LOG --profile ...``: the log summary (timing, channels and ranges)
    for the test-conditions section."""
    opts, iargv = ingest_opts(test, campaign)

    def go():
        """The command body: returns (result, objects, logs)."""
        g = cache.get(path, opts)
        return g.summary(), g, [g]

    res, obj, logs, dt = _timed(go)
    rel = campaign.rel(path)
    return Analysis(f"info:{rel}", test.name, "info", ["info", rel, *iargv], res, obj, logs,
                    dt)


def finite(x) -> bool:
    """True for a finite number."""
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)
