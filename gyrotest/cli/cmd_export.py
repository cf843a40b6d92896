"""``gyrotest export KIND INPUT -o FILE``: deliverables as files (:mod:`gyrotest.export`)."""

from __future__ import annotations

from pathlib import Path

import click

from ..core.errors import InputError
from .common import emit_json, ingest_options, json_option, load_log, note, warn, with_ingest


@click.group("export")
def command():
    """Write results as files other tools and firmware read.

    Every kind reads a result gyrotest saved (or, for the Allan-based kinds, a log) and writes
    one file atomically (nothing half-written on error):

    \b
      kalibr       Kalibr imu.yaml (noise density, random walk, update rate, topic)
      gyroparams   MATLAB gyroparams as a .m script or a .mat struct
      accelparams  MATLAB accelparams of the accelerometer axes (.m or .mat)
      stable32     Stable32-style deviation table (AF, tau, n, alpha, min/sigma/max)
      allan-csv    the Allan deviation table as CSV, units in the header
      env-model    drift model (thermal-fit/model fit -o) as .csv look-up table or .h C header
      scale-factor scale-factor model eps_K(I, T) as .csv look-up table or .h C header

    \b
    Examples:
      gyrotest allan sample_data/static.parquet --profile sample_data/static.profile.toml \\
          --skip 30min --json > allan.json
      gyrotest export kalibr allan.json -o imu.yaml --rostopic /imu0
      gyrotest export stable32 sample_data/static.parquet \\
          --profile sample_data/static.profile.toml -o static_oadev.txt --skip 30min
      gyrotest model fit sample_data/thermal.parquet --profile sample_data/thermal.profile.toml \\
          --terms "T(T_chamber_C),dTdt(T_chamber_C)" --t-ref 21 -o thermal.json
      gyrotest export gyroparams allan.json -o gyro.m --thermal thermal.json
      gyrotest export env-model thermal.json -o thermal_lut.csv --temps 21:55:1
      gyrotest scale-factor sample_data/ratetable_22a.parquet \\
          --profile sample_data/ratetable_22a.profile.toml --json > sf.json
      gyrotest export scale-factor sf.json -o sf_comp.h
    """


def _axes_option(f):
    return click.option("--axis", "axes", default=None,
                        help="Axes to export (comma-separated); default all.")(f)


def _allan_input_options(f):
    f = click.option("--skip", default="0s", show_default=True,
                     help="Warm-up trim when INPUT is a log: a duration, e.g. 30min, 90s (a "
                          "plain number is seconds).")(f)
    f = ingest_options(f)
    return f


def _split(v: str | None) -> list[str] | None:
    if not v:
        return None
    return [x.strip() for x in v.split(",") if x.strip()] or None


def _allan_document(inp: str, skip: str, ingest_opts: dict, as_json: bool,
                    log_meta: dict | None = None):
    """The Allan document of INPUT: read it (.json) or analyse the log with the defaults
    (its ``meta`` — format, ROS topic — copied into ``log_meta`` when given)."""
    from ..export.common import Document, read_document

    if Path(inp).suffix.lower() == ".json":
        return read_document(inp, "allan")
    from ..api.analyses import allan
    from ..core.units import parse_duration

    parse_duration(skip, what="--skip")
    g = load_log(inp, ingest_opts, announce=not as_json)
    if log_meta is not None:
        log_meta.update(g.meta)
    return Document("allan", allan(g, skip=skip).to_dict(), inp)


def _check_suffix(output: str, suffixes: tuple[str, ...], kind: str) -> str:
    suf = Path(output).suffix.lower()
    if suf not in suffixes:
        raise InputError(f"-o {output}: 'export {kind}' writes {' or '.join(suffixes)} files; "
                         f"got {suf or 'no suffix'!r}")
    parent = Path(output).parent
    if str(parent) and not parent.is_dir():
        raise InputError(f"cannot write {output}: directory {parent} does not exist")
    return suf


def _done(output: str, as_json: bool, summary: dict, warnings: list[str]) -> None:
    for w in warnings:
        warn(w)
    if as_json:
        emit_json({"output": str(output), **summary, "warnings": warnings})
    else:
        note(f"written to {output}")


# ----------------------------------------------------------------------------- kalibr
@command.command("kalibr")
@click.argument("input", type=str)
@click.option("-o", "--output", required=True, help="The imu.yaml to write.")
@click.option("--rostopic", default=None,
              help="IMU ROS topic (default: the bag's Imu topic when INPUT is a ROS bag, "
                   "else /imu0).")
@click.option("--update-rate", type=float, default=None,
              help="IMU rate, Hz (default: the log's sample rate 1/tau0).")
@click.option("--inflate", type=float, default=1.0, show_default=True,
              help="Multiply the measured densities (gyro, and accelerometer when measured) "
                   "by this factor (unmodelled effects).")
@click.option("--accel-noise-density", type=float, default=None,
              help="Accelerometer noise density, m/s^2/sqrt(Hz) (default: measured from the "
                   "log's accelerometer axes, else a marked placeholder).")
@click.option("--accel-random-walk", type=float, default=None,
              help="Accelerometer bias random walk, m/s^3/sqrt(Hz) (default: measured from "
                   "the log's accelerometer axes, else a marked placeholder).")
@_axes_option
@_allan_input_options
@json_option
@with_ingest
def kalibr_cmd(input, output, rostopic, update_rate, inflate, accel_noise_density,
               accel_random_walk, axes, skip, as_json, ingest_opts):
    """Kalibr imu.yaml from the Allan noise model.

    gyroscope_noise_density = N·(π/180)/60 rad/s/√Hz, gyroscope_random_walk =
    K·(π/180)/216000 rad/s²/√Hz (continuous-time densities, Kalibr wiki "IMU Noise Model");
    the largest over the axes; upper-bound terms at their bound. update_rate is the log rate.
    accelerometer_noise_density = VRW/60 m/s²/√Hz and accelerometer_random_walk = K/216000
    m/s³/√Hz come from the log's accelerometer axes (IEEE Std 1293 terms), or from the
    options (which win); only without either they are marked PLACEHOLDER.

    INPUT is the --json output of 'gyrotest allan' (allan.json), or a log, which is then
    analysed with the default Allan settings (--skip and the ingest options apply).
    """
    from ..export.common import allan_axes, write_output
    from ..export.kalibr import kalibr_yaml

    _check_suffix(output, (".yaml", ".yml"), "kalibr")
    meta: dict = {}
    doc = _allan_document(input, skip, ingest_opts, as_json, meta)
    rostopic = rostopic or meta.get("ros_topic") or "/imu0"
    text, p, warnings = kalibr_yaml(allan_axes(doc, _split(axes)), rostopic=rostopic,
                                    update_rate=update_rate, inflate=inflate,
                                    accel_noise_density=accel_noise_density,
                                    accel_random_walk=accel_random_walk)
    write_output(output, text)
    _done(output, as_json, {"kind": "kalibr", "values": vars(p)}, warnings)



# ----------------------------------------------------------------------------- gyroparams
@command.command("gyroparams")
@click.argument("input", type=str)
@click.option("-o", "--output", required=True, help="The .m script or .mat file to write.")
@click.option("--thermal", "thermal_path", type=str, default=None,
              help="Drift model file (thermal-fit -o) for TemperatureBias.")
@click.option("--sf-json", "sf_path", type=str, default=None,
              help="'gyrotest scale-factor --json' output for TemperatureScaleFactor and "
                   "MeasurementRange.")
@click.option("--constant-bias", type=float, default=None, help="ConstantBias, deg/h.")
@click.option("--range", "range_dps", type=float, default=None,
              help="MeasurementRange, deg/s (default: the --sf-json full scale).")
@_axes_option
@_allan_input_options
@json_option
@with_ingest
def gyroparams_cmd(input, output, thermal_path, sf_path, constant_bias, range_dps, axes, skip,
                   as_json, ingest_opts):
    """MATLAB gyroparams (imuSensor) as a .m script or a .mat struct.

    NoiseDensity = N·(π/180)/60 (rad/s)/√Hz, BiasInstability = B·(π/180)/3600 rad/s,
    RandomWalk = K·(π/180)/216000 (rad/s)·√Hz from the Allan model (upper bounds at their
    bound); TemperatureBias (rad/s)/°C = the drift model's slope at 25 °C (--thermal);
    TemperatureScaleFactor %/°C = −ε_T·1e-4 and MeasurementRange from --sf-json. One
    axis gives scalars, three axes 1×3 vectors. In MATLAB: run gyro.m, or
    s = load('gyro.mat'); c = namedargs2cell(s.gyroparams); p = gyroparams(c{:}).

    INPUT is the --json output of 'gyrotest allan' (allan.json), or a log, which is then
    analysed with the default Allan settings (--skip and the ingest options apply).
    """
    from ..export.common import allan_axes, read_document
    from ..export.matlab import build_gyroparams

    suf = _matlab_suffix(output, "gyroparams")
    thermal = read_document(thermal_path, "envmodel") if thermal_path else None
    sf = read_document(sf_path, "scale-factor") if sf_path else None
    doc = _allan_document(input, skip, ingest_opts, as_json)
    gp = build_gyroparams(allan_axes(doc, _split(axes)), constant_bias_dph=constant_bias,
                          thermal=thermal, scale_factor=sf, range_dps=range_dps)
    _write_matlab(output, suf, gp, as_json)


def _matlab_suffix(output: str, kind: str) -> str:
    """.m or .mat (a script's name must be a MATLAB identifier)."""
    suf = _check_suffix(output, (".m", ".mat"), kind)
    if suf == ".m" and not Path(output).stem.replace("_", "a").isalnum():
        raise InputError(f"-o {output}: a MATLAB script name must be letters, digits and _ "
                         "(it is called by its name)")
    return suf


def _write_matlab(output: str, suf: str, gp, as_json: bool) -> None:
    """Write gyroparams/accelparams as a .m script or a .mat struct, and report it."""
    from ..export.common import write_output
    from ..export.matlab import m_script, write_mat

    if suf == ".m":
        write_output(output, m_script(gp))
    else:
        write_output(output, writer=lambda tmp: write_mat(tmp, gp))
    _done(output, as_json, {"kind": gp.kind, "axes": gp.axes, "values": gp.values,
                            "units": {k: gp.units[k] for k in gp.values}}, [])


@command.command("accelparams")
@click.argument("input", type=str)
@click.option("-o", "--output", required=True, help="The .m script or .mat file to write.")
@click.option("--constant-bias", type=float, default=None, help="ConstantBias, m/s^2.")
@click.option("--range", "range_m_s2", type=float, default=None,
              help="MeasurementRange, m/s^2.")
@_axes_option
@_allan_input_options
@json_option
@with_ingest
def accelparams_cmd(input, output, constant_bias, range_m_s2, axes, skip, as_json,
                    ingest_opts):
    """MATLAB accelparams (imuSensor) from the accelerometer axes, as .m or .mat.

    NoiseDensity = VRW/60 (m/s²)/√Hz, BiasInstability = B·9.80665e-6 m/s² (B in µg),
    RandomWalk = K/216000 (m/s²)·√Hz from the Allan model of the accelerometer axes (IEEE
    Std 1293 terms; upper bounds at their bound). One axis gives scalars, three axes 1×3
    vectors. In MATLAB: run accel.m, or s = load('accel.mat'); c =
    namedargs2cell(s.accelparams); p = accelparams(c{:}).

    INPUT is the --json output of 'gyrotest allan' (allan.json), or a log with accelerometer
    columns (ax/ay/az, acc_x ... with a unit), analysed with the default Allan settings.
    """
    from ..export.common import allan_axes
    from ..export.matlab import build_accelparams

    suf = _matlab_suffix(output, "accelparams")
    doc = _allan_document(input, skip, ingest_opts, as_json)
    gp = build_accelparams(allan_axes(doc, _split(axes)), constant_bias_m_s2=constant_bias,
                           range_m_s2=range_m_s2)
    _write_matlab(output, suf, gp, as_json)


# ----------------------------------------------------------------------------- tables
@command.command("stable32")
@click.argument("input", type=str)
@click.option("-o", "--output", required=True, help="The table to write (.txt).")
@click.option("--digits", type=int, default=5, show_default=True,
              help="Significant digits of τ and σ (Stable32 prints 5).")
@_axes_option
@_allan_input_options
@json_option
@with_ingest
def stable32_cmd(input, output, digits, axes, skip, as_json, ingest_opts):
    """Stable32-style deviation table: AF, τ, n, α, min σ, σ, max σ.

    A header names the file, the data points, the data type, τ0, the sigma type, the
    confidence factor and the dead time, as Stable32 prints it; one block per axis. σ in the
    unit of the analysis (deg/h for gyros, m/s² for accelerometer axes).

    INPUT is the --json output of 'gyrotest allan' (allan.json), or a log, which is then
    analysed with the default Allan settings (--skip and the ingest options apply).
    """
    from ..export.common import allan_axes, write_output
    from ..export.stable32 import stable32_tables

    _check_suffix(output, (".txt", ".dat", ".s32"), "stable32")
    doc = _allan_document(input, skip, ingest_opts, as_json)
    ax = allan_axes(doc, _split(axes))
    write_output(output, stable32_tables(ax, digits))
    _done(output, as_json, {"kind": "stable32", "axes": [a.axis for a in ax]}, [])


@command.command("allan-csv")
@click.argument("input", type=str)
@click.option("-o", "--output", required=True, help="The CSV file to write.")
@_axes_option
@_allan_input_options
@json_option
@with_ingest
def allan_csv_cmd(input, output, axes, skip, as_json, ingest_opts):
    """The Allan deviation table as CSV with units in the header.

    Columns: source, axis, deviation, tau_s, m, n, alpha, edf, sigma_lo_deg_h, sigma_deg_h,
    sigma_hi_deg_h, model_deg_h, residual_ci (residual in CI half-widths), fitted.

    INPUT is the --json output of 'gyrotest allan' (allan.json), or a log, which is then
    analysed with the default Allan settings (--skip and the ingest options apply).
    """
    from ..export.common import allan_axes, write_output
    from ..export.table import allan_csv

    _check_suffix(output, (".csv",), "allan-csv")
    doc = _allan_document(input, skip, ingest_opts, as_json)
    ax = allan_axes(doc, _split(axes))
    write_output(output, allan_csv(ax))
    _done(output, as_json, {"kind": "allan-csv", "axes": [a.axis for a in ax]}, [])


# ----------------------------------------------------------------------------- models
@command.command("env-model")
@click.argument("model_file", type=str)
@click.option("-o", "--output", required=True,
              help="The look-up table (.csv) or C header (.h) to write.")
@click.option("--temps", default=None,
              help="Temperature grid of the .csv, degC: start:stop:step or a list "
                   "(default: the fitted range in 1 degC steps).")
@click.option("--prefix", default="gyro_drift", show_default=True,
              help="Prefix of the C function and macros (.h).")
@click.option("--static-only", is_flag=True,
              help="Leave out terms with memory or time dependence (named in the file).")
@click.option("--force", is_flag=True,
              help="Export terms the fit did not determine (|value| < 2·1σ) and --temps "
                   "outside the fitted range, with a warning, instead of refusing.")
@json_option
def env_model_cmd(model_file, output, temps, prefix, static_only, force, as_json):
    """A drift model as a firmware look-up table (.csv) or C header (.h).

    MODEL_FILE is a model written by 'gyrotest thermal-fit -o' or 'gyrotest model fit -o'.
    The .csv tabulates the temperature terms (bias, T, T2, T3 of one channel) on --temps, a
    column per term and their sum drift_dph, evaluated by the model's own term functions;
    terms linear in other inputs (dT/dt, gradient rate, field, supply) are listed in its
    header. The .h holds every coefficient with unit and 1σ, the equation in a comment and
    an inline function <prefix>_dph(inputs...) returning the drift in deg/h. Firmware
    subtracts it: compensated rate = rate − drift.

    A term whose coefficient the fit did not determine (|value| < 2·1σ; the constant is not
    judged) would put its error into firmware, and --temps outside the fitted temperature
    range extrapolates: both are refused, naming the terms and the range, unless --force
    (then they are written, with a warning). Refit with the terms the log determines.

    \b
    Examples:
      gyrotest model fit sample_data/thermal.parquet \\
          --profile sample_data/thermal.profile.toml --terms "T(T_chamber_C),dTdt(T_chamber_C)" \\
          --t-ref 21 -o thermal.json
      gyrotest export env-model thermal.json -o thermal_lut.csv --temps 21:55:1
      gyrotest export env-model thermal.json -o thermal_comp.h
    """
    from ..export import envlut
    from ..export.common import read_document, write_output

    suf = _check_suffix(output, (".csv", ".h"), "env-model")
    grid = envlut.parse_grid(temps) if temps else None
    doc = read_document(model_file, "envmodel")
    if suf == ".h":
        envlut.check_prefix(prefix)
    concerns = []
    weak = envlut.weak_terms(doc, static_only=static_only)
    if weak:
        concerns.append(f"not determined by the fit: {'; '.join(weak)}")
    far = envlut.outside_range(doc, grid, static_only=static_only) if grid is not None else None
    if far:
        concerns.append(far)
    if concerns and not force:
        raise InputError(f"{model_file}: " + "; ".join(concerns) + "; refit with the terms the "
                         "log determines (gyrotest model fit --terms ... -o), keep --temps in "
                         "the fitted range, or pass --force to export anyway")
    if suf == ".csv":
        text, summary = envlut.lut_csv(doc, grid, static_only=static_only)
    else:
        if temps:
            raise InputError("--temps applies to the .csv look-up table, not the .h header")
        text, summary = envlut.c_header(doc, prefix=prefix, static_only=static_only)
    write_output(output, text)
    warnings = [f"left out: {', '.join(summary['left_out'])}"] if summary["left_out"] else []
    warnings += [f"exported with --force: {c}" for c in concerns]
    _done(output, as_json, {"kind": "env-model", **summary}, warnings)


@command.command("scale-factor")
@click.argument("sf_json", type=str)
@click.option("-o", "--output", required=True,
              help="The look-up table (.csv) or C header (.h) to write.")
@click.option("--rates", default=None,
              help="Input-rate grid of the .csv, deg/s: start:stop:step or a list "
                   "(default: -FS to +FS in 101 rows).")
@click.option("--prefix", default="gyro_sf", show_default=True,
              help="Prefix of the C functions and macros (.h).")
@json_option
def scale_factor_cmd(sf_json, output, rates, prefix, as_json):
    """The scale-factor model as a firmware look-up table (.csv) or C header (.h).

    SF_JSON is the --json output of 'gyrotest scale-factor'. Model (IEEE 952 §8.3):
    rate = (I + D)/(1 + 1e-6 eps_K), eps_K = eps_0 + eps_T (T - T_ref) + f(I), with f(I) the
    rate-dependent terms the data support (asymmetry, powers of I/FS, periodic, lock-in) and
    T_ref the mean temperature of the runs. The .csv tabulates f, eps_K and the bias-free model
    output over --rates; the .h holds the coefficients and inline functions
    <prefix>_eps_k_ppm(I, T) and <prefix>_input_dps(rate, T), the compensated input rate.
    """
    from ..export import sflut
    from ..export.common import read_document, write_output
    from ..export.envlut import parse_grid

    suf = _check_suffix(output, (".csv", ".h"), "scale-factor")
    grid = parse_grid(rates, "--rates") if rates else None
    doc = read_document(sf_json, "scale-factor")
    if suf == ".csv":
        text, summary = sflut.lut_csv(doc, grid)
    else:
        if rates:
            raise InputError("--rates applies to the .csv look-up table, not the .h header")
        text, summary = sflut.c_header(doc, prefix=prefix)
    write_output(output, text)
    _done(output, as_json, {"kind": "scale-factor", **summary}, [])
