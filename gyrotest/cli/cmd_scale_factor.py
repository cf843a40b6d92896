"""``gyrotest scale-factor``: scale factor from rate-table runs (IEEE 952 §12.9.4)."""

from __future__ import annotations

import math

import click

from ..core.errors import InputError
from .common import (
    console,
    emit_json,
    fmt_num,
    ingest_options,
    json_option,
    load_logs,
    note,
    plot_option,
    warn,
    with_ingest,
)


def _duration(ctx, param, value):
    if value is None:
        return None
    from ..core.units import parse_duration

    try:
        return parse_duration(value, what=f"--{param.name.replace('_', '-')}")
    except InputError as e:
        raise click.BadParameter(str(e)) from None


@click.command("scale-factor")
@click.argument("logs", nargs=-1, type=str)
@click.option("--table", "table_path", type=click.Path(dir_okay=False), default=None,
              help="Ready plateau table (CSV: table_rate_dps, output_dph|output_pps|output_v "
                   "[, stderr_*, temperature_degC, run]) instead of logs.")
@click.option("--settle", default="0s", show_default=True, callback=_duration,
              help="Minimum settling time after each rate change (e.g. 10s, 1min); the "
                   "settling of each plateau is found from its data and can only be longer.")
@click.option("--fixed-settle", is_flag=True,
              help="Use --settle exactly after every rate change (no settling from the data).")
@click.option("--trim-end", default="0s", show_default=True, callback=_duration,
              help="Time excluded before the end of each plateau.")
@click.option("--min-dwell", default="2s", show_default=True, callback=_duration,
              help="Constant stretches shorter than this are transitions, not plateaus.")
@click.option("--detect", type=click.Choice(["auto", "table", "output"]), default="auto",
              show_default=True,
              help="Plateaus from the commanded-rate column (table) or from steps in the output.")
@click.option("--rates", "rates", default=None,
              help="Commanded rates, deg/s (comma-separated, ± implied) for plateaus detected in "
                   "the output; default: snap to round values.")
@click.option("--stderr", "stderr_method", type=click.Choice(["allan", "batch"]), default="allan",
              show_default=True,
              help="Plateau standard error: Allan deviation at the plateau length (pooled noise "
                   "model) or batch means.")
@click.option("--snap-tol", type=float, default=3e-3, show_default=True,
              help="Relative tolerance when matching detected levels to rates.")
@click.option("--full-scale", type=float, default=None,
              help="Full-scale input rate, deg/s (default: the largest |rate| tested).")
@click.option("--terms", default="auto", show_default=True,
              help="Nonlinearity terms of f(I): auto (chosen by the data), linear, or a list "
                   "of asymmetry,u1,u2,u3,u4,lockin,periodic (uk: the term c_k·(I/FS)^k, "
                   "∝ I^(k+1) in the output).")
@click.option("--alpha", type=float, default=0.05, show_default=True,
              help="Significance level for adding a term (F-test, Bonferroni-corrected).")
@click.option("--weighted-line", is_flag=True,
              help="Weight the IEEE straight line by 1/SE² (default: unweighted, as §12.9.4.1).")
@click.option("--unweighted", is_flag=True, help="Do not weight the nonlinearity model fit.")
@click.option("--no-lock-in", is_flag=True, help="Do not look for a low-rate dead band.")
@click.option("--no-periodic", is_flag=True, help="Do not look for a rate-periodic error.")
@click.option("--no-asymmetry", is_flag=True,
              help="Accept a table without negative rates (asymmetry is then not computed).")
@click.option("--common-rates", is_flag=True,
              help="Runs tested at different rate sets: keep only the rates all runs share.")
@click.option("--matrix", is_flag=True,
              help="3-axis log turned about each case axis (position column +x, -y, z …): the "
                   "scale-factor/misalignment matrix K = I + M instead of the single-axis "
                   "reduction.")
@click.option("--points", "points_path", type=click.Path(dir_okay=False), default=None,
              help="Write the plateau table (CSV) to this file.")
@plot_option("Residuals vs input rate and output vs time (.png, .svg or .pdf).")
@ingest_options
@json_option
@with_ingest
def command(logs, table_path, settle, fixed_settle, trim_end, min_dwell, detect, rates, stderr_method,
            snap_tol, full_scale,
            terms, alpha, weighted_line, unweighted, no_lock_in, no_periodic, no_asymmetry,
            common_rates, matrix, points_path, plot_path, as_json, ingest_opts):
    """Scale factor, linearity, asymmetry and nonlinearity from rate-table LOGS (IEEE 952 §12.9.4).

    Each LOG is one run (a continuous rate-table log); several runs give repeatability,
    stability and, at different temperatures, the temperature sensitivity. Plateaus come from
    the commanded-rate column (--table-col) or are detected in the output; each plateau's
    settling time is found from its own data (transient against its noise floor; --settle is
    a minimum) and excluded. The input is the table rate plus the earth rate along the IA (--latitude,
    --ia). The scale factor is in the log's units: arcsec/pulse for pulse output, (deg/h)/V for
    analog, 1 for rate output (input per unit output).

    \b
    Examples:
      gyrotest scale-factor sample_data/ratetable_22a.parquet sample_data/ratetable_22b.parquet \\
          sample_data/ratetable_45.parquet --profile sample_data/ratetable_22a.profile.toml
      gyrotest scale-factor sample_data/ratetable_22a.parquet --counts-col pulses \\
          --table-col table_dps --scale-factor 0.2 --latitude 48.137 --ia up \\
          --points points.csv --plot sf.png             # no profile: every column named
      gyrotest scale-factor --table points.csv --scale-factor 0.2 --json   # a saved table
    """
    from .. import scalefactor as sfm
    from ..api.analyses import scale_factor

    if plot_path:
        from ..core.plotting import check_plot_path

        check_plot_path(plot_path)
    if points_path:
        from ..core.output import check_output_path

        check_output_path(points_path, (".csv", ".txt"), "points file", formats=".csv or .txt")
    sfm.check_settings(settle_s=settle, trim_end_s=trim_end, min_dwell_s=min_dwell, alpha=alpha,
                       snap_tol=snap_tol, full_scale_dps=full_scale)
    rate_list = sfm.parse_rates(rates)
    sfm.parse_term_choice(terms)
    kw = dict(full_scale=full_scale, terms=terms, alpha=alpha, weighted=not unweighted,
              weighted_line=weighted_line, lock_in=not no_lock_in, periodic=not no_periodic,
              common_rates=common_rates, asymmetry=not no_asymmetry)
    loaded = []
    if matrix:
        if table_path or len(logs) != 1:
            raise InputError("--matrix reduces one 3-axis log (no --table)")
        _matrix(logs[0], ingest_opts, settle, not fixed_settle, min_dwell, as_json)
        return
    if table_path:
        if logs:
            raise InputError("give either rate-table logs or --table FILE, not both")
        result = scale_factor(table=table_path, latitude=ingest_opts.get("latitude"),
                              ia=ingest_opts.get("ia"),
                              scale_factor=ingest_opts.get("scale_factor"), on_note=note, **kw)
    else:
        if not logs:
            raise InputError("no input: give one rate-table log per run, or --table FILE")
        loaded = load_logs(logs, ingest_opts, announce=not as_json)
        result = scale_factor(loaded, settle=settle, fixed_settle=fixed_settle,
                              trim_end=trim_end, min_dwell=min_dwell, detect=detect,
                              rates=rate_list, snap_tol=snap_tol, stderr=stderr_method, **kw)
    # files last, so that an error leaves nothing behind
    if plot_path:
        from ..scalefactor.plots import plot_scale_factor

        plot_scale_factor(result.core, plot_path, logs=loaded or None)
    if points_path:
        sfm.write_points_csv(result.core, points_path)
    if as_json:
        emit_json(result.to_dict(plot=plot_path, points_file=points_path))
        for n in result.notes:
            if n.startswith(sfm.ASYMMETRY_SKIPPED):
                warn(n)
        return
    for n in result.notes:
        (warn if ("χ²/dof" in n or "asymmetry not" in n or "lock-in" in n) else note)(n)
    _render(result.core, plot_path, points_path)


def _matrix(path, ingest_opts, settle, auto_settle, min_dwell, as_json) -> None:
    from ..scalefactor.matrix import misalignment_matrix

    lg = load_logs([path], ingest_opts, announce=not as_json)[0]
    res = misalignment_matrix(lg, settle_s=settle, auto_settle=auto_settle,
                              min_dwell_s=min_dwell)
    if as_json:
        emit_json({"command": "scale-factor", "source": lg.source, "matrix": res.to_dict()})
        return
    for n in res.notes:
        note(n)
    from rich.table import Table

    c = console()
    t = Table(title="K = I + M (row: gyro output, column: case axis on the table); diagonal: "
                    "SF error ppm, off-diagonal: µrad (±1σ)", title_justify="left")
    t.add_column("gyro", justify="left")
    for a in "xyz":
        t.add_column(f"case {a}", justify="right")
    M, S = res.M, res.K_sigma
    for i, name in enumerate(res.axes):
        t.add_row(name, *[_pm(M[i, a] * 1e6, S[i, a] * 1e6) for a in range(3)])
    c.print(t)
    c.print(f"  plateaus per case axis {res.n_plateaus}; settling worst case "
            f"{res.settling_worst_s:.3g} s; misalignment M_ia = sensitivity of gyro i to rotation "
            "about case axis a (small angle)")


# ----------------------------------------------------------------------------- rendering
def _render_lowrate(c, res) -> None:
    """Threshold, resolution and input range (IEEE 952 §5.3.1/§5.3.2, IEEE Std 528 terms)."""
    for name, r in (("threshold", res.threshold), ("resolution", res.resolution)):
        if r is None:
            continue
        if r.status == "ok":
            txt = f"≤ {r.value_dps:g} deg/s"
            if math.isfinite(r.lower_dps):
                txt = f"between {r.lower_dps:g} and {r.value_dps:g} deg/s"
            else:
                txt += " (the smallest tried already responds)"
            c.print(f"  {name} (50 % of the expected output, {len(r.steps)} tried): {txt}")
        else:
            c.print(f"  {name}: {r.status}")
    ir = res.input_range
    if ir is not None:
        if ir.saturated:
            c.print(f"  input range: +{ir.positive_dps:g} / −{ir.negative_dps:g} deg/s; the output "
                    f"saturates at {', '.join(f'{v:+g}' for v in ir.saturated_rates_dps)} deg/s "
                    "(excluded from the fits)")
        else:
            c.print(f"  input range: at least +{ir.positive_dps:g} / −{ir.negative_dps:g} deg/s "
                    "(no saturation at the rates tested)")

def _render_repeatability(c, rp) -> None:
    """Repeatability within each temperature group, then the spread of all runs (labelled)."""
    for g in rp.groups:
        if len(g.runs) < 2:
            continue
        c.print(f"  repeatability (§12.9.4.2.3, {g.kind}) at {fmt_num(g.temperature_degC, 3)} °C, "
                f"{len(g.runs)} runs ({', '.join(g.runs)}): 1σ "
                f"{_pm(g.sigma_ppm, g.sigma_uncertainty_ppm)} ppm, max spread "
                f"{fmt_num(g.max_spread_ppm, 4)} ppm")
    multi = [g for g in rp.groups if len(g.runs) > 1]
    if len(multi) > 1:
        c.print(f"  repeatability pooled over {len(multi)} temperatures: 1σ "
                f"{_pm(rp.sigma_ppm, rp.sigma_uncertainty_ppm)} ppm, max spread "
                f"{fmt_num(rp.max_spread_ppm, 4)} ppm")
    if len(rp.groups) > 1:
        c.print(f"  all {rp.n_runs} runs together (different temperatures, includes ε_T·ΔT; not "
                f"the repeatability): 1σ {fmt_num(rp.all_runs_sigma_ppm, 4)} ppm, max spread "
                f"{fmt_num(rp.all_runs_max_spread_ppm, 4)} ppm")
    elif not multi:
        c.print("  repeatability: not measured (no two runs share a condition)")

def _render_settling(c, res) -> None:
    """Settling found per rate step (runs side by side) and the worst case."""
    from rich.table import Table

    runs = [rp for rp in res.run_plateaus if rp.settling]
    if not runs:
        return
    auto = any(rp.auto_settle for rp in runs)
    t = Table(title="settling time found in the data per plateau, s after the rate change" + (
        "" if auto else " (not used: --fixed-settle)"), title_justify="left")
    t.add_column("rate deg/s", justify="right")
    for rp in runs:
        t.add_column(rp.run, justify="right")
    rows: dict[float, list[str]] = {}
    for i, rp in enumerate(runs):
        for st in rp.settling:
            row = rows.setdefault(round(st.to_rate_dps, 9), [""] * len(runs))
            v = f"{st.found_s:.3g}"
            if math.isfinite(st.tau_s):
                v += f" (τ {st.tau_s:.2g})"
            row[i] = v if not row[i] else row[i] + ", " + v
    for rate, row in rows.items():
        t.add_row(f"{rate:+g}", *row)
    c.print(t)
    worst = max((st for rp in runs for st in rp.settling), key=lambda s: s.found_s)
    run = next(rp.run for rp in runs if worst in rp.settling)
    c.print(f"  settling worst case {worst.found_s:.3g} s ({run}, step {worst.from_rate_dps:+g} → "
            f"{worst.to_rate_dps:+g} deg/s); τ = fitted time constant of the transient"
            + ("" if auto else f"; window started {runs[0].settle_s:g} s after each change "
                               "(--fixed-settle)"))

def _pm(v: float, s: float, digits: int = 6) -> str:
    if v is None or not math.isfinite(v):
        return "—"
    if s is None or not math.isfinite(s) or s == 0:
        return fmt_num(v, digits)
    # digits to show: two significant digits of the uncertainty
    e = max(0, -int(math.floor(math.log10(abs(s)))) + 1)
    return f"{v:.{e}f} ± {s:.{e}f}" if e < 12 else f"{v:.6g} ± {s:.2g}"


def _render(res, plot_path, points_path) -> None:
    from rich.table import Table

    c = console()
    u = res.sf_unit
    kinds = {"counts": "pulse counts", "updown": "up/down pulses", "counter": "pulse counter",
             "voltage": "analog voltage", "rate": "rate"}
    c.print(f"[bold]Scale factor (IEEE 952 §12.9.4)[/bold] — {len(res.runs)} run(s), "
            f"{kinds.get(res.output_kind, res.output_kind)} output, nominal S0 = "
            f"{res.nominal_scale_factor:g} {u}, full scale ±{res.full_scale_dph / 3600:g} deg/s")
    t = Table(title=f"scale factor SF ({u}), least-squares line §12.9.4.1", title_justify="left")
    have_t = any(math.isfinite(r.temperature_mean_degC) for r in res.runs)
    cols = ["run", "pts"] + (["T °C"] if have_t else []) + ["SF", "σ ppm", "ε0 ppm", "ε0 model",
                                                             "bias deg/h"]
    for col in cols:
        t.add_column(col, justify="left" if col == "run" else "right",
                     overflow="fold" if col == "run" else "ellipsis", no_wrap=col != "run")

    def sfrow(name, n, temp, sf, ssf, e0, sfm, bias, sbias):
        digits = max(6, int(-math.floor(math.log10(abs(ssf / sf)))) + 2) if ssf and sf else 9
        row = [name, n] + ([temp] if have_t else [])
        return row + [f"{sf:.{digits}g}", fmt_num(ssf / abs(sf) * 1e6, 2), f"{e0:.2f}",
                      f"{(sfm / res.nominal_scale_factor - 1) * 1e6:.2f}",
                      _pm(bias, sbias).replace(" ± ", "±")]

    for r in res.runs:
        t.add_row(*sfrow(r.run, str(r.n_used), fmt_num(r.temperature_mean_degC, 4),
                         r.scale_factor, r.scale_factor_sigma, r.scale_factor_error_ppm,
                         r.scale_factor_model, r.bias_model_dph, r.bias_model_sigma_dph))
    if len(res.runs) > 1:
        t.add_row(*sfrow("[bold]all[/bold]", "", "", res.scale_factor, res.scale_factor_sigma,
                         res.scale_factor_error_ppm, res.scale_factor_model, res.bias_dph,
                         res.bias_sigma_dph))
    c.print(t)
    _render_settling(c, res)
    c.print("  ε0 = (SF/S0 − 1)·1e6; ε0 model: linear coefficient with f(I) fitted; bias D_F "
            "input-referred, earth rate removed")
    if math.isfinite(res.bias_zero_rate_dph):
        c.print(f"  bias at the zero-rate plateaus (§12.11.4.1.1, model-free): "
                f"{_pm(res.bias_zero_rate_dph, res.bias_zero_rate_sigma_dph)} deg/h")
    # linearity per rate (pooled over runs)
    import numpy as np

    pt = res.point_table
    tab = np.array([p.table_rate_dph for p in res.points]) / 3600.0
    locked = np.array([p.locked for p in res.points], dtype=bool)
    lt = Table(title="linearity error per rate, ppm FS unless noted (§12.9.4.2.1; mean of runs)",
               title_justify="left")
    for col in ("rate deg/s", "n", "ppm FS", "± SE", "ppm output", "after model"):
        lt.add_column(col, justify="right")
    for rate in sorted(set(np.round(tab, 9).tolist())):
        m = np.isclose(tab, rate) & np.isfinite(pt["model_residual_ppm_fs"])
        if not m.any():
            lk = np.isclose(tab, rate) & locked
            lt.add_row(f"{rate:+g}", str(int(lk.sum())), "locked", "", "", "")
            continue
        se = pt["stderr_ppm_fs"][m]
        lt.add_row(f"{rate:+g}", str(int(m.sum())), fmt_num(float(np.mean(pt["linearity_ppm_fs"][m])), 3),
                   fmt_num(float(np.sqrt(np.sum(se ** 2)) / m.sum()), 2),
                   fmt_num(float(np.nanmean(pt["linearity_ppm_output"][m])), 3)
                   if np.any(np.isfinite(pt["linearity_ppm_output"][m])) else "—",
                   fmt_num(float(np.mean(pt["model_residual_ppm_fs"][m])), 3))
    c.print(lt)
    li = res.linearity
    c.print(f"  linearity: max {fmt_num(li.max_ppm_fs, 4)} ppm FS (at {li.max_at_input_dps:+.4g} "
            f"deg/s), 1σ {fmt_num(li.sigma_ppm_fs, 4)} ppm FS; max {fmt_num(li.max_ppm_output, 4)} "
            f"ppm of output, 1σ {fmt_num(li.sigma_ppm_output, 4)}; after the model: max "
            f"{fmt_num(res.linearity_after_model.max_ppm_fs, 3)} ppm FS")
    # model history
    ht = Table(title="nonlinearity model: add a term, watch the residual fall",
               title_justify="left")
    for col in ("step", "RMS ppm FS", "χ²/dof", "ΔAICc", "p (F-test)", "kept"):
        ht.add_column(col, justify="left" if col == "step" else "right")
    for h in res.model.history:
        kept = "[dim]no[/dim]"
        if h.accepted:
            kept = "lower order" if "lower order" in h.note else "[green]yes[/green]"
        ht.add_row(("+ " + h.added) if h.terms else "straight line", fmt_num(h.rms_ppm_fs, 3),
                   fmt_num(h.chi2_per_dof, 3), fmt_num(h.delta_aicc, 3), fmt_num(h.p_value, 2),
                   kept)
    c.print(ht)
    if res.model.coefficients:
        from ..scalefactor.tablefit import OUTPUT_POWER_NOTE

        ct = Table(title=f"f(I) of ε_K, ppm; {OUTPUT_POWER_NOTE}", title_justify="left")
        for col in ("term", "f(I)", "coefficient, ppm", "kept"):
            ct.add_column(col, justify="right" if col == "coefficient, ppm" else "left")
        for cf in res.model.coefficients:
            extra = ""
            if "period_dps" in cf.extra:
                extra = f" (P {cf.extra['period_dps']:.4g} deg/s, φ {cf.extra['phase_deg']:.3g}°)"
            if "lock_in_rate_dps" in cf.extra:
                extra = (f" (Ω_L {_pm(cf.extra['lock_in_rate_dps'], cf.extra['lock_in_rate_sigma_dps'])}"
                         " deg/s)")
            formula = cf.formula.split(" (")[0]
            value = _pm(cf.coef_ppm, cf.sigma_ppm) + extra
            if "lock_in_rate_dps" in cf.extra:  # Ω_L says more than e_L
                formula = "Adler √(I²−Ω_L²)"
                value = extra.strip(" ()")
            ct.add_row(cf.name, formula, value, "yes" if cf.supported else "no")
        c.print(ct)
    c.print(f"  [bold]{res.model.statement}[/bold]")
    a = res.asymmetry
    if a.status == "ok":
        c.print(f"  asymmetry (SF+ − SF−)/SF̄ (§12.9.4.2.2, SF in {u} as in the table above, "
                f"{a.method.split(' (')[0]}): "
                f"{_pm(a.asymmetry_ppm, a.asymmetry_sigma_ppm)} ppm; through the common "
                f"intercept {_pm(a.common_intercept_ppm, a.common_intercept_sigma_ppm)} ppm; "
                f"model term A {_pm(a.model_ppm, a.model_sigma_ppm)} ppm "
                f"({'supported' if a.supported else 'not supported'} by the data)")
    else:
        c.print(f"  asymmetry: {a.status}")
    p = res.periodic
    c.print("  rate-periodic error: " + (
        f"A = {_pm(p.amplitude_ppm, p.amplitude_sigma_ppm)} ppm, period {p.period_dps:.4g} deg/s "
        f"(p = {p.p_value:.2g})" if p.supported else p.status))
    if res.repeatability:
        _render_repeatability(c, res.repeatability)
    for r in res.runs:
        if r.stability:
            s = r.stability
            c.print(f"  stability {r.run} (§12.9.4.2.4, {s.n_sweeps} sweeps): 1σ "
                    f"{fmt_num(s.sigma_ppm, 3)} ppm, max spread {fmt_num(s.max_spread_ppm, 3)} ppm, "
                    f"last − first {fmt_num(s.last_minus_first_ppm, 3)} ppm, drift "
                    f"{_pm(s.drift_ppm_per_h, s.drift_sigma_ppm_per_h)} ppm/h")
    ts = res.temperature
    if ts.status == "ok":
        c.print(f"  temperature sensitivity (§12.9.4.3.1, {ts.t_min_degC:.3g}…{ts.t_max_degC:.3g} °C): "
                f"{_pm(ts.slope_ppm_per_degC, ts.slope_sigma_ppm_per_degC)} ppm/°C (max change / "
                f"range {fmt_num(ts.max_change_per_range_ppm_per_degC, 3)} ppm/°C)")
    else:
        c.print(f"  temperature sensitivity: {ts.status}")
    if res.lock_in.detected:
        li2 = res.lock_in
        c.print(f"  lock-in dead band: output collapsed up to {li2.dead_band_below_dps:g} deg/s"
                + (f", free from {li2.dead_band_above_dps:g} deg/s" if math.isfinite(
                    li2.dead_band_above_dps) else "")
                + (f"; Adler fit Ω_L = {_pm(li2.fitted_dps, li2.fitted_sigma_dps)} deg/s"
                   if math.isfinite(li2.fitted_dps) else ""))
    _render_lowrate(c, res)
    if plot_path:
        note(f"plot written to {plot_path}")
    if points_path:
        note(f"plateau table written to {points_path}")
