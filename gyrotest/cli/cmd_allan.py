"""``gyrotest allan``: Allan noise analysis that explains itself.

Deviation table with confidence intervals (Stable32 columns), joint noise-model fit with
identified/upper-bound status, model vs measurement with the diagnosis of missing terms,
Krobka's warnings, platform vs strapdown impact, unit conversions for other tools, plots.
All numbers come from :func:`gyrotest.noise.analysis.analyse_allan`.
"""

from __future__ import annotations

import csv
import io
import math

import click
from rich.markup import escape

from ..core.display import DEFAULT as DEFAULT_UNIT
from ..core.errors import InputError
from ..core.output import atomic_open
from ..core.units import format_duration, parse_duration
from ..noise.kinds import DEVIATION_KINDS, MIN_EDF  # no numpy/scipy: see command()
from .common import (
    console,
    emit_json,
    fmt_num,
    ingest_options,
    json_option,
    load_for_terms,
    note,
    plot_option,
    warn,
    with_ingest,
)
from .common_display import resolve_display_unit, unit_option
from .pool import deviation_progress, jobs_option, map_logs, prefetch_log

_TABLE_COLS = ("tau", "n", "alpha", "sigma_lo", "sigma", "sigma_hi")
_CI_COLS = ("alpha_ci", "edf_ci", "edf_ci_rule", "sigma_lo_ci", "sigma_hi_ci")


@click.command("allan")
@click.argument("logs", nargs=-1, required=True)
@click.option("--dev", "dev_kind", type=click.Choice(DEVIATION_KINDS), default="oadev",
              show_default=True,
              help="Deviation of the table (the model is always fitted to an Allan-type one).")
@click.option("--taus", default="10/decade", show_default=True,
              help="τ grid: octave, decade, N/decade, all, or a list of τ in s (0.1,1,10).")
@click.option("--stop-ratio", type=float, default=None,
              help="Longest τ = T/ratio for generated grids (default Stable32's, 4 for OADEV).")
@click.option("--terms", default="Q,N,B,K,R", show_default=True,
              help="Noise terms to fit: Q,N,B,K,R,markov,sine,blue (markov*2 for two; "
                   "+markov adds to the default).")
@click.option("--axis", "axes", default=None,
              help="Axes to analyse (comma-separated: gyro rate columns and accelerometer "
                   "columns); default all.")
@click.option("--confidence", type=float, default=0.683, show_default=True,
              help="Confidence of the χ² intervals.")
@click.option("--ci", "ci_kind", type=click.Choice(["stable32", "conservative"]),
              default="stable32", show_default=True,
              help="Interval columns: Stable32's (α identified by Stable32's rule and its "
                   "EDF, as Stable32 prints them), or also a conservative one (the noise "
                   "fit's own α, EDF capped at the white-rate value where α > 0 came from "
                   "few averages, non-increasing in τ) in its own "
                   "alpha_ci/edf_ci/sigma_lo_ci/sigma_hi_ci columns.")
@click.option("--min-edf", type=float, default=MIN_EDF, show_default=True,
              help="Do not fit τ with fewer equivalent degrees of freedom.")
@click.option("--detrend", default="none", show_default=True,
              help="Remove a least-squares trend first: none, linear, quadratic, or sine:PERIOD "
                   "(e.g. sine:24h for a diurnal term).")
@click.option("--model", "model_path", type=click.Path(dir_okay=False), default=None,
              help="Drift model from 'gyrotest model fit -o m.json' (or thermal-fit/mag-fit): "
                   "its deterministic drift is removed before the noise analysis, as "
                   "'gyrotest compensate' does.")
@click.option("--skip", default="0s", show_default=True,
              help="Warm-up trim: a duration, e.g. 30min, 2h, 90s (a plain number is seconds).")
@click.option("--outliers", "outliers", type=click.Choice(["flag", "remove", "robust"]),
              default="flag", show_default=True,
              help="Spikes (Hampel filter, robust scale): flag = warn with their times and "
                   "analyse as recorded; remove = replace each by its running median; robust = "
                   "clip each to the threshold.")
@click.option("--fill", "fill", type=click.IntRange(0, 1000), default=1, show_default=True,
              help="Bridge gaps of at most this many missed samples before the analysis "
                   "(rate: linear interpolation, its effect on σ stated in a note; counter/"
                   "angle: the gap's exact mean rate); 0 never bridges. Longer gaps split the "
                   "record.")
@click.option("--vehicle-rate", "vehicle_rates", multiple=True,
              help="Strapdown vehicle rate for the impact prediction, e.g. 10deg/s (repeatable).")
@click.option("--horizon", default="1h", show_default=True,
              help="Time at which the attitude error is reported.")
@click.option("--bi-cutoff", type=float, default=None,
              help="Fit the full bias-instability template with this cut-off f0 (Hz).")
@click.option("--no-diagnose", is_flag=True, help="Skip the search for missing terms.")
@click.option("--no-fit", is_flag=True,
              help="Plain deviation table only (no noise model, diagnosis, warnings or impact). "
                   "Without it the fit is skipped with a note when the τ list is too short.")
@click.option("--allow-irregular", is_flag=True,
              help="Analyse on the nominal τ0 even if the sample interval jitters > 10 %.")
@click.option("--csv", "csv_path", type=click.Path(dir_okay=False), default=None,
              help="Write the deviation table(s) to this CSV file, units in the column names "
                   "(tau_s, sigma_deg_h, model_deg_h ...; as 'gyrotest export allan-csv').")
@plot_option("σ(τ) with fit, components and residuals (.png/.svg/.pdf).")
@unit_option
@click.option("--psd", "psd_path", type=click.Path(dir_okay=False), default=None,
              help="Welch PSD and autocorrelation figure (.png/.svg/.pdf).")
@jobs_option
@ingest_options
@json_option
@with_ingest
def command(logs, dev_kind, taus, stop_ratio, terms, axes, confidence, ci_kind, min_edf, detrend,
            skip, outliers, model_path, fill,
            vehicle_rates, horizon, bi_cutoff, no_diagnose, no_fit, allow_irregular, csv_path,
            plot_path, psd_path, display_unit, jobs, as_json, ingest_opts):
    """Allan noise analysis that explains its answers.

    Overlapping Allan deviation (or --dev) with χ² confidence intervals from the EDF (noise
    type identified per τ), a joint noise-model fit weighted by the estimator's confidence
    (Q, N, B, K, R by default; markov, sine, blue on request), each coefficient identified or
    an upper bound ("≤"), residuals in CI units, the missing-term diagnosis, Krobka's warnings,
    and the platform vs strapdown attitude error. Units: σ deg/h, N deg/√h, B deg/h,
    K deg/h/√h, R deg/h/h, Q arcsec; --unit deg/s (or rad/s, mdps) shows σ and B in deg/s,
    N in deg/s/√Hz, K in deg/s/√s, R in deg/s², Q in deg (JSON keeps the IEEE units).

    Pulse-output logs are analysed as angle increments, rate logs as rate samples (from the
    ingest layer). Several LOGS (or axes) overlay on one τ axis in --plot.

    Accelerometer axes of the log (ax/ay/az, acc_x ... with a unit: ax_g, acc_y_mps2) are
    analysed beside the gyros, σ in m/s², with the IEEE Std 1293 terms: N = velocity random
    walk (m/s/√h), B bias instability (µg), K acceleration random walk (m/s/h/√h), R (m/s/h/h),
    Q (m/s); their plots go to NAME_accel.png.

    A coefficient is identified only when its likelihood-ratio test passes and the τ that
    carry it hold an estimate with at least 10 degrees of freedom; a prediction past the
    record is marked extrapolated; gaps of ≤ --fill missed samples are bridged (the effect on
    σ is stated); with --outliers flag a term identified only because of the flagged spikes
    becomes an upper bound ("spike-driven").

    \b
    Examples:
      gyrotest allan sample_data/static.parquet --profile sample_data/static.profile.toml \\
          --plot allan.png
      gyrotest allan sample_data/static.parquet --profile sample_data/static.profile.toml \\
          --terms +markov --vehicle-rate 10deg/s --json
      gyrotest allan sample_data/static.parquet sample_data/bias_run1.parquet \\
          --profile sample_data/static.profile.toml --skip 30min --plot overlay.png  # overlaid
      gyrotest allan sample_data/static.parquet --profile sample_data/static.profile.toml \\
          --taus 1,10,100 --no-fit                      # the plain deviation table
    """
    parse_duration(skip, what="--skip")  # a bad --skip fails before any log is read
    # a single text log is read on a thread while the analysis modules are imported (their
    # numpy/scipy imports take ≈ 0.2 s); errors of either kind surface in the serial order
    early = None if model_path else prefetch_log(logs, ingest_opts)
    from ..api.analyses import allan
    from ..api.results import AllanResult
    from ..noise.analysis import STREAM_DEVS, parse_detrend, parse_taus
    from ..noise.impact import parse_horizon, parse_vehicle_rate
    from ..noise.noisefit import parse_terms

    unit = resolve_display_unit(display_unit, ingest_opts)
    parse_horizon(horizon)
    for v in vehicle_rates:
        parse_vehicle_rate(v)
    parse_taus(taus)
    parse_terms(terms)
    if not 0.0 < confidence < 1.0:
        raise InputError(f"--confidence must be between 0 and 1, got {confidence}")
    for p in (plot_path, psd_path):
        if p:
            from ..core.plotting import check_plot_path

            check_plot_path(p)
    if csv_path:
        from ..core.output import check_output_path

        check_output_path(csv_path, (".csv", ".txt"), "--csv table", formats=".csv or .txt")
    axis_list = [a.strip() for a in axes.split(",") if a.strip()] if axes else None
    parse_detrend(detrend)
    kw = dict(skip=skip, dev=dev_kind, taus=taus, terms=terms, vehicle_rate=vehicle_rates,
              axis=axis_list, confidence=confidence, stop_ratio=stop_ratio, min_edf=min_edf,
              detrend=detrend, diagnose=not no_diagnose,
              horizon=horizon, bi_cutoff=bi_cutoff, allow_irregular=allow_irregular,
              fit=not no_fit, ci=ci_kind, outliers=outliers, fill=fill)
    with deviation_progress():  # a bar on a terminal for τ loops longer than 2 s
        if model_path:
            from ..envmodel.model import EnvModel

            env_model = EnvModel.load(model_path)
            glogs = [load_for_terms(p, ingest_opts, env_model.specs, announce=not as_json)
                     for p in logs]
            res = allan(glogs, model=env_model, **kw)
        else:
            # long Parquet logs are streamed into θ when no option needs the samples themselves
            stream = (detrend in (None, "none") and outliers == "flag"
                      and parse_duration(skip, what="--skip") <= 0
                      and dev_kind in STREAM_DEVS)
            res = AllanResult.concat(map_logs(  # one process per log with --jobs (identical)
                allan, logs, ingest_opts, jobs=jobs, announce=not as_json,
                stream=stream, loaded=early, **kw))
    results = res.logs
    items = [(r.source, a) for r in results for a in r.axes]
    if csv_path:
        _write_csv(csv_path, results)
    written = []
    if plot_path or psd_path:
        from ..noise.plots import plot_allan, plot_psd, split_by_quantity

        for path, fn, what in ((plot_path, plot_allan, "plot"), (psd_path, plot_psd, "PSD plot")):
            if not path:
                continue
            for group, p in split_by_quantity(items, path):  # gyros and accelerometers apart
                fn(group, p, unit=unit)
                written.append((p, what))
    if as_json:
        _warnings(results, as_json)
        emit_json(res.to_dict(csv=csv_path, plot=plot_path, psd=psd_path))
        return
    for r in results:
        _render(r, unit)
    _warnings(results, as_json)
    for p, what in [(csv_path, "table")] + written:
        if p:
            note(f"{what} written to {p}")


def _warnings(results, as_json: bool) -> None:
    """Krobka's warnings on stderr (info-level ones as notes, not with --json)."""
    for r in results:
        for a in r.axes:
            for w in a.warnings:
                if w.severity == "warning":
                    warn(f"{r.source} [{a.axis}] {w.code}: {w.title}: {w.message}")
                elif not as_json:
                    note(f"{r.source} [{a.axis}] {w.code}: {w.message}")


def _table_rows(r):
    for a in r.axes:
        tab = a.table()
        for i in range(len(tab["tau"])):
            row = {"source": r.source, "axis": a.axis, "deviation": a.dev.kind}
            row.update({k: tab[k][i] for k in _TABLE_COLS})
            row["edf"] = tab["edf"][i]
            for k in _CI_COLS:
                if k in tab:
                    row[k] = tab[k][i]
            if "model" in tab:
                row["model"] = tab["model"][i]
                row["residual_ci"] = tab["residual_ci"][i]
                row["fitted"] = bool(tab["fitted"][i])
            yield row


#: columns of --csv that carry σ (named with its unit: sigma_deg_h) and τ (tau_s)
_SIGMA_COLS = ("sigma_lo", "sigma", "sigma_hi", "sigma_lo_ci", "sigma_hi_ci", "model")


def csv_header(cols, unit: str) -> list[str]:
    """The --csv column names with their units, as 'gyrotest export allan-csv' writes them:
    ``tau_s``, ``sigma_deg_h``, ``model_deg_h`` (σ in the deviation's own unit)."""
    from ..export.table import _unit_tag

    u = _unit_tag(unit)
    return ["tau_s" if c == "tau" else f"{c}_{u}" if c in _SIGMA_COLS else c for c in cols]


def _write_csv(path, results) -> None:
    units = {str(a.dev.unit or "deg/h") for r in results for a in r.axes}
    if len(units) > 1:  # one header for every row
        raise InputError(f"--csv {path}: the logs' deviations have different units "
                         f"({', '.join(sorted(units))}); write one log at a time")
    buf = io.StringIO()
    cols = ["source", "axis", "deviation", *_TABLE_COLS, "edf", *_CI_COLS, "model",
            "residual_ci", "fitted"]
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(csv_header(cols, units.pop() if units else "deg/h"))
    for r in results:
        for row in _table_rows(r):
            out = []
            for k in cols:
                v = row.get(k, "")
                if isinstance(v, float) or hasattr(v, "dtype"):
                    v = float(v)
                    v = "" if not math.isfinite(v) else f"{v:.8g}"
                out.append(v)
            w.writerow(out)
    with atomic_open(path, "w", encoding="utf-8", newline="") as fh:
        fh.write(buf.getvalue())


def axis_display(a, unit=DEFAULT_UNIT):
    """The display unit of an analysed axis: ``unit`` for a gyro, the accelerometer's own
    (σ in m/s², terms in IEEE 1293 units, unchanged) for an accelerometer."""
    from ..core.display import ACCEL_DISPLAY

    return ACCEL_DISPLAY if getattr(a, "quantity", "rate") == "acceleration" else unit


def _render(r, unit=DEFAULT_UNIT) -> None:
    from rich.table import Table

    gyro_unit = unit
    c = console()
    for a in r.axes:
        unit = axis_display(a, gyro_unit)
        f = unit.f  # σ: display rate per deg/h (1 for an accelerometer: m/s²)
        d = a.dev
        c.print(f"\n[bold]{escape(r.source)}[/bold] — axis {escape(str(a.axis))}: {len(a.dev.tau)} τ, "
                f"{r.n_samples} samples at τ0 = {r.tau0:g} s ({format_duration(r.duration_s)})")
        c.print(f"  input: {a.input_note}")
        t = Table(title=f"{d.kind.upper()} (σ in {unit.rate}); CI {100 * d.confidence:.1f} % from "
                        f"the EDF of the identified α (as Stable32): {d.ci_method}",
                  title_justify="left")
        tab = a.table()
        cols = ["tau s", "n", "alpha", "edf", "sigma_lo", "sigma", "sigma_hi"]
        cons = "edf_ci" in tab
        if cons:
            cols += ["alpha_ci", "edf_ci", "lo_ci", "hi_ci"]
        if "model" in tab:
            cols += ["model", "resid CI"]
        for col in cols:
            t.add_column(col, justify="right")
        for i in range(len(tab["tau"])):
            row = [fmt_num(float(tab["tau"][i])), str(int(tab["n"][i])),
                   str(int(tab["alpha"][i])), fmt_num(float(tab["edf"][i]), 4),
                   fmt_num(float(tab["sigma_lo"][i]) * f),
                   fmt_num(float(tab["sigma"][i]) * f), fmt_num(float(tab["sigma_hi"][i]) * f)]
            if cons:
                rule = {"white-rate cap": " cap", "running minimum": " min"}.get(
                    tab["edf_ci_rule"][i], "")
                row += [str(int(tab["alpha_ci"][i])), fmt_num(float(tab["edf_ci"][i]), 4) + rule,
                        fmt_num(float(tab["sigma_lo_ci"][i]) * f),
                        fmt_num(float(tab["sigma_hi_ci"][i]) * f)]
            if "model" in tab:
                rv = float(tab["residual_ci"][i])
                res = "—" if not math.isfinite(rv) else f"{rv:+.1f}"
                if not tab["fitted"][i]:
                    res += " nf"
                row += [fmt_num(float(tab["model"][i]) * f), res]
            t.add_row(*row)
        c.print(t)
        gf = (r.settings or {}).get("gap_fill")
        if gf and (gf.get("filled_gaps") or gf.get("skipped")):
            c.print(f"  gaps: {escape(gf['note'])}")
        if "residual_ci" in tab:
            c.print("  alpha: noise type per τ for the EDF (2 white angle … 0 white rate … −2 RRW); "
                    "nf = not fitted (EDF < floor)")
        if cons:
            c.print("  *_ci: conservative interval (--ci conservative), the fit's weights: alpha_ci "
                    "from the B1 ratio at the number of averages, cap = EDF capped at the "
                    "white-rate value (α > 0 from few averages), min = running minimum in τ")
        if a.fit is not None:
            _render_fit(a, unit)
        else:
            for n in a.notes:  # a fit asked for and not made is a warning, not a note
                (warn if n.startswith("noise model not fitted") else note)(n)
    if r.cross is not None:
        ct = Table(title="Axis cross-correlation ρ of τ-averaged rates (zero within ±b, 95 %)",
                   title_justify="left")
        ct.add_column("τ s", justify="right")
        ct.add_column("±b", justify="right")
        k = len(r.cross.axes)
        pairs = [(i, j) for i in range(k) for j in range(i + 1, k)]
        for i, j in pairs:
            ct.add_column(f"ρ {r.cross.axes[i]}/{r.cross.axes[j]}", justify="right")
        for tau, m, b in zip(r.cross.tau, r.cross.matrices, r.cross.band):
            ct.add_row(fmt_num(tau), f"{b:.3f}", *[f"{m[i, j]:+.3f}" for i, j in pairs])
        c.print(ct)
    for n in r.notes:
        note(f"{r.source}: {n}")


def _term_value(term, unit=DEFAULT_UNIT) -> str:
    """'0.005 ± 8.1e-06' or '≤ 0.035'; two-parameter terms list both (in the display unit)."""
    if term.status == "upper bound":
        return "≤ " + fmt_num(unit.convert(term.upper, term.units[term.main])[0], 3)
    parts = []
    for k, v in term.params.items():
        sg = term.sigma.get(k)
        v, lab = unit.convert(v, term.units[k])
        sg = unit.convert(sg, term.units[k])[0]
        txt = fmt_num(v, 4) + (f" ± {fmt_num(sg, 2)}" if sg is not None else "")
        parts.append(txt if len(term.params) == 1 else f"{k} {txt} {lab}")
    return "; ".join(parts)


def _fit_table(f, title: str, unit=DEFAULT_UNIT):
    from rich.table import Table

    lo, hi = f.fit_range
    t = Table(title=f"{title} (τ {fmt_num(lo)}–{fmt_num(hi)} s; χ²/dof = {f.chi2_dof:.2f}, "
                    f"p = {f.p_value:.2g}, n_eff = {f.n_eff:.1f})", title_justify="left")
    for col in ("term", "value", "unit", "status", "dominates τ s"):
        t.add_column(col)
    for term in f.terms:
        dom = "" if not term.dominant_tau else (f"{fmt_num(term.dominant_tau[0])}–"
                                                f"{fmt_num(term.dominant_tau[1])}")
        lab = unit.convert(1.0, term.units[term.main])[1] if len(term.params) == 1 else ""
        status = term.status + (f" ({term.status_note})" if term.status_note else "")
        t.add_row(f"{term.label} {term.title}", _term_value(term, unit), lab, status, dom)
    return t


def _render_fit(a, unit=DEFAULT_UNIT) -> None:
    from ..noise.allanresult import FIT_WEIGHTS

    c = console()
    f = a.fit
    c.print(_fit_table(f, "Noise model, requested terms", unit))
    c.print("  ≤: upper bound only (95 % profile likelihood); ±: 1σ (sandwich covariance); "
            "weights: " + FIT_WEIGHTS)
    if a.diagnosis is not None and a.diagnosis.final is not f:
        c.print(_fit_table(a.diagnosis.final, "Diagnosed model", unit))
    ro = a.readoffs
    if "N_upper" in ro and a.quantity == "acceleration":
        c.print(f"  classic read-offs (for comparison): VRW slope-line {fmt_num(ro['N_slope'])} "
                f"m/s/√h at τ {fmt_num(ro['N_slope_tau_s'])} s, N_upper (95 % bound of white "
                f"noise) = {fmt_num(ro['N_upper'])} m/s/√h; acceleration-RW slope-line "
                f"{fmt_num(ro['K_slope'])} m/s/h/√h; B tangent σ_min/0.664 = "
                f"{fmt_num(ro['B_tangent'])} µg (Allan floor {fmt_num(ro['allan_floor'])} m/s² "
                f"at τ {fmt_num(ro['allan_floor_tau_s'])} s)")
    elif "N_upper" in ro:
        u = unit
        c.print(f"  classic read-offs (for comparison): N slope-line "
                f"{fmt_num(u.n_value(ro['N_slope']))} at "
                f"τ {fmt_num(ro['N_slope_tau_s'])} s, N_upper (95 % bound of white noise) = "
                f"{fmt_num(u.n_value(ro['N_upper']))} {u.n}; K slope-line "
                f"{fmt_num(u.k_value(ro['K_slope']))} {u.k}; B tangent σ_min/0.664 = "
                f"{fmt_num(u.rate_value(ro['B_tangent']))} {u.rate} (Allan floor "
                f"{fmt_num(u.rate_value(ro['allan_floor_dph']))} {u.rate} at τ "
                f"{fmt_num(ro['allan_floor_tau_s'])} s)")
    dg = a.diagnosis
    if dg is not None:
        for reg in dg.regions:
            c.print(f"  misfit: {reg.text()}")
        if dg.candidates:
            c.print("  candidates: " + "; ".join(
                f"{cd.term} {cd.evidence()}{' ✓' if cd.accepted else ''}"
                for cd in dg.candidates[:5]))
        if len(dg.steps) > 1:
            c.print("  ladder: " + " → ".join(
                f"{s['added'] or 'base'} χ²/dof {s['chi2_per_dof']:.2f}" for s in dg.steps))
        c.print(f"  [bold]diagnosis:[/bold] {dg.verdict}")
    conv = a.conversions
    if "N" in conv and conv.get("quantity") == "acceleration":
        n, kal, mat = conv["N"], conv["kalibr"], conv["matlab_accelparams"]
        c.print(f"  conversions: VRW = {fmt_num(n['m_s2_per_rt_hz'])} m/s²/√Hz = "
                f"{fmt_num(n['ug_per_rt_hz'])} µg/√Hz; Kalibr accelerometer_noise_density "
                f"{fmt_num(kal['accelerometer_noise_density'])}, accelerometer_random_walk "
                f"{fmt_num(kal['accelerometer_random_walk'])}; MATLAB accelparams NoiseDensity "
                f"{fmt_num(mat['NoiseDensity'])}, BiasInstability {fmt_num(mat['BiasInstability'])}"
                f", RandomWalk {fmt_num(mat['RandomWalk'])} (continuous-time; bounds exported as "
                "bounds)")
    elif "N" in conv:
        n = conv["N"]
        kal = conv["kalibr"]
        mat = conv["matlab_gyroparams"]
        c.print(f"  conversions: N = {fmt_num(n['deg_s_per_rt_hz'])} °/s/√Hz = "
                f"{fmt_num(n['rad_s_per_rt_hz'])} rad/s/√Hz; Kalibr gyroscope_noise_density "
                f"{fmt_num(kal['gyroscope_noise_density'])}, gyroscope_random_walk "
                f"{fmt_num(kal['gyroscope_random_walk'])}; MATLAB gyroparams NoiseDensity "
                f"{fmt_num(mat['NoiseDensity'])}, BiasInstability {fmt_num(mat['BiasInstability'])}, "
                f"RandomWalk {fmt_num(mat['RandomWalk'])} (continuous-time; bounds exported as "
                "bounds)")
    imp = a.impact
    if imp is not None:
        hz = format_duration(imp.horizon_s)
        line = (f"  attitude error after {hz} (3 gyros, first order): platform "
                f"{fmt_num(imp.platform_sigma_deg * 3600)}″")
        for w, s, q in zip(imp.rates_rad_s, imp.strapdown_sigma_deg, imp.ratio):
            line += (f"; strapdown at {math.degrees(w):g} deg/s {fmt_num(s * 3600)}″ "
                     f"(SINS/INS {q:.2f})")
        if imp.extrapolated:
            line += f" — extrapolated: {imp.extrapolation}"
        c.print(line)
        for fl in imp.flags:
            c.print(f"    {fl['text']}")
    for n in a.notes:
        note(n)
