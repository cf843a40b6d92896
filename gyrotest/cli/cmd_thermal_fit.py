"""``gyrotest thermal-fit``: the Antonova–Matveev thermal model and the IEEE E terms."""

from __future__ import annotations

import math

import click
from rich.markup import escape

from ..core.errors import InputError
from .cmd_model import (
    check_output,
    domain_fit_options,
    load_reference,
    render_fit,
    write_plot,
)
from .common import (
    FiniteRange,
    console,
    emit_json,
    fmt_num,
    ingest_options,
    json_option,
    load_for_terms,
    note,
    warn,
    with_ingest,
)

#: |value / 1σ| below which a coefficient is "not determined by this log" (the fit's "not
#: significant", :attr:`gyrotest.envmodel.modelfit.Coefficient.significance`)
DETERMINED_Z = 2.0


def _z(c) -> float:
    return abs(c.value / c.stderr) if math.isfinite(c.stderr) and c.stderr > 0 else math.nan


def _coef_table(title, coefs):
    from rich.table import Table

    t = Table(title=title)
    for col, just in (("coefficient", "left"), ("value ± 1σ", "right"), ("unit", "left"),
                      ("|value/σ|", "right")):
        t.add_column(col, justify=just)
    for c in coefs:
        err = fmt_num(c.stderr, 2) if math.isfinite(c.stderr) else "—"
        z = _z(c)
        zt = "—" if not math.isfinite(z) else (
            fmt_num(z, 3) + ("" if z >= DETERMINED_Z else " not determined"))
        t.add_row(c.name, f"{fmt_num(c.value)} ± {err}", c.unit, zt)
    return t


def determined_line(coefs) -> str:
    """One line that leads the output: the coefficients this log determines (|z| ≥ 2) and
    those it does not."""
    good = [c.name for c in coefs if _z(c) >= DETERMINED_Z]
    weak = [c.name for c in coefs if not _z(c) >= DETERMINED_Z]
    line = "  determined by this log: " + (", ".join(good) or "none")
    if weak:
        line += (f"; not determined (|value| < {DETERMINED_Z:g}·1σ): {', '.join(weak)} "
                 "(export a model of the determined terms: gyrotest model fit --terms ... -o)")
    return line


@click.command("thermal-fit")
@click.argument("log", type=str, required=False)
@click.option("--setpoints", type=click.Path(dir_okay=False), default=None,
              help="Table of steady-state set-points (CSV: temperature, dw[, sigma][, dTdt]).")
@click.option("--t-ref", "t_ref", type=FiniteRange(-273.15, 1000.0), default=None,
              help="Reference temperature T_ref, degC (ΔT = T − T_ref; default 21, the "
                   "paper's lab), as in 'gyrotest model fit --t-ref'.")
@click.option("--t0", "t0_alias", type=FiniteRange(-273.15, 1000.0), default=None, hidden=True,
              help="Old name of --t-ref.")
@click.option("--sensor", default=None,
              help="Temperature channel of the model (default: the one that fits held-out "
                   "data best).")
@click.option("--gradient", default=None,
              help="Two temperature channels A,B for D_gradTdot = d(T_A − T_B)/dt.")
@click.option("--weighted", is_flag=True,
              help="Weight set-points by 1/sigma² (default: equal weights).")
@domain_fit_options(smooth_help="Smoother window W for dT/dt or 'auto'.",
                    plot_help="Drift vs temperature and residual plots (.png/.svg/.pdf).",
                    figures="thermal, then the fit's time, channels and allan; setpoints")
@ingest_options
@json_option
@with_ingest
def command(log, setpoints, t_ref, t0_alias, sensor, gradient, weighted, axis, skip, resolution, smooth,
            folds, reference, output, plot_path, as_json, ingest_opts):
    """Thermal drift model of Antonova & Matveev: dw = w0 + w1·ΔT + w2·ΔT² + w_ΔV·dT/dt.

    From a continuous chamber run LOG (ΔT = T − t0, dT/dt in degC/h; w0 deg/h, w1 deg/(h·degC),
    w2 deg/(h·degC²), w_ΔV deg/degC) with the IEEE 952 E terms D_T, D_Tdot and, with two
    temperature channels, D_gradTdot; plus a heating-vs-cooling hysteresis check. And/or from a
    table of steady-state set-points (--setpoints), like the paper's 31…55 °C thermostat test;
    there dT/dt = 0, so w_ΔV needs a chamber run.

    \b
    Examples:
      gyrotest thermal-fit sample_data/thermal.parquet --profile sample_data/thermal.profile.toml \\
          --t-ref 21 -o thermal.json
      gyrotest thermal-fit --setpoints sample_data/thermostat.csv --t-ref 21
    """
    from ..api.models import thermal_fit
    from ..envmodel.domain import check_thermal_input, parse_gradient, thermal_terms

    check_thermal_input(log is not None, setpoints)
    if t_ref is not None and t0_alias is not None and t_ref != t0_alias:
        raise InputError("--t-ref and --t0 (its old name) disagree; give --t-ref only")
    t0 = next((v for v in (t_ref, t0_alias) if v is not None), 21.0)
    out_path = check_output(output, (".json", ".toml"), "model file")
    if output and log is None:
        raise InputError("-o needs a chamber log (a set-point table gives no full model)")
    if plot_path:
        from ..core.plotting import check_plot_path

        check_plot_path(plot_path)
    parse_gradient(gradient)  # a bad --gradient fails before the log is read
    g = ref = None
    if log is not None:
        g = load_for_terms(log, ingest_opts, thermal_terms(), announce=not as_json)
        ref = load_reference(reference, ingest_opts, as_json)
    elif reference:
        raise InputError("--reference needs a chamber log (it sets the noise floor of the "
                         "chamber-run fit)")
    ta = thermal_fit(g, setpoints=setpoints, t0=t0, sensor=sensor, gradient=gradient,
                     weighted=weighted, axis=axis, skip=skip, resolution=resolution,
                     smooth=smooth, folds=folds, reference=ref)
    th, sp = ta.chamber, ta.setpoints
    if th and out_path:
        th.am.model.save(out_path)
    if plot_path:
        from ..envmodel.plots import setpoint_figures, thermal_figures

        figs = (thermal_figures(th) if th else []) + (setpoint_figures(sp) if sp else [])
        write_plot(figs, plot_path)
    if as_json:
        emit_json(ta.to_dict(model_file=str(out_path) if out_path else None))
        return
    c = console()
    if th:
        c.print(f"[bold]thermal-fit[/bold]: Antonova–Matveev model on {th.sensor}, "
                f"ΔT from T_ref = {th.t0_c:g} °C")
        for n in th.notes:
            note(n)
        c.print(escape(determined_line(th.ieee_coefficients + th.coefficients)))
        c.print(_coef_table("IEEE 952 E terms (± 1σ)", th.ieee_coefficients))
        c.print(_coef_table("Antonova–Matveev dw = w0 + w1·ΔT + w2·ΔT² + w_ΔV·dT/dt (± 1σ; "
                            "-o saves this model)", th.coefficients))
        h = th.hysteresis
        if "heating_minus_cooling_dph" in h:
            c.print(f"  heating − cooling residual: {fmt_num(h['heating_minus_cooling_dph'])} ± "
                    f"{fmt_num(h['stderr_dph'], 2)} deg/h — {h['verdict']}")
        else:
            c.print(f"  hysteresis check: {h.get('note')}")
        render_fit(th.am, title="fit details")
        if out_path:
            c.print(f"  model written to {escape(str(out_path))}")
    if sp:
        c.print(f"[bold]set-points[/bold]: {len(sp.points)} points, ΔT from T_ref = {sp.t0_c:g} °C"
                + (" (weighted by 1/σ²)" if sp.weighted else ""))
        c.print(_coef_table("dw = w0 + w1·ΔT + w2·ΔT² (± 1σ from the scatter)",
                            sp.coefficients))
        from rich.table import Table

        t = Table(title="points")
        for col in ("T, °C", "ΔT", "dw, deg/h", "model", "residual"):
            t.add_column(col, justify="right")
        for p in sp.points:
            t.add_row(f"{p['temperature_degC']:g}", f"{p['dT_degC']:g}", fmt_num(p["dw_dph"]),
                      fmt_num(p["model_dph"]), fmt_num(p["residual_dph"], 2))
        c.print(t)
        c.print(f"  residual RMS {fmt_num(sp.rms_dph)} deg/h, {sp.dof} degrees of freedom")
        for n in sp.notes:
            warn(n) if "not identifiable" in n else note(n)
