"""``gyrotest bias``: D_F with honest uncertainty, repeatability, multi-position tests."""

from __future__ import annotations

import os

import click

from ..api.analyses import bias
from ..core.errors import InputError
from ..core.units import format_duration, parse_duration, parse_rate_dph
from ..staticbias.analysis import parse_positions
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
from .common_axes import axis_plot_path
from .common_display import resolve_display_unit, unit_option


@click.command("bias")
@click.argument("logs", nargs=-1, required=True)
@click.option("--skip", default="0s", show_default=True,
              help="Warm-up trim at the start of each run: a duration, e.g. 40min, 2h, 90s (a "
                   "plain number is seconds).")
@click.option("--axis", default=None,
              help="Gyro axis (rate column) to analyse, comma-separated for several; default "
                   "every axis (one IA: the earth rate is removed only with a single axis).")
@click.option("--positions", default=None,
              help="IA direction of each file in order (multi-position test), e.g. up,down,north,south.")
@click.option("--settle", default="0s", show_default=True,
              help="Time dropped after every position change in a log with a position column: "
                   "a duration, e.g. 30s, 2min.")
@click.option("--no-earth-rate", is_flag=True, help="Do not subtract the earth-rate component.")
@click.option("--outliers", type=click.Choice(["flag", "remove", "robust"]), default="flag",
              show_default=True,
              help="Spikes (Hampel filter): flag = warn with their times, mean as recorded; "
                   "remove = replace each by its running median; robust = clip each.")
@click.option("--warmup-band", "warmup_band", default=None, metavar="RATE",
              help="Report the warm-up time of each run (IEEE 952 §5.3.3; the log starts at "
                   "power-on): the time until the bias stays within ± RATE of its final value, "
                   "e.g. 0.05deg/h (a bare number is deg/h).")
@click.option("--warmup-block", default="60s", show_default=True,
              help="Block length for the warm-up time (its resolution).")
@plot_option("Plot the rate with D_F and its 2σ band (.png/.svg/.pdf).")
@unit_option
@ingest_options
@json_option
@with_ingest
def command(logs, skip, axis, positions, settle, no_earth_rate, outliers, warmup_band,
            warmup_block, plot_path, display_unit, as_json, ingest_opts):
    """Bias D_F (in --unit, default deg/h) of static runs, with an uncertainty honest for correlated noise.

    D_F = mean(rate) − earth-rate component along the IA (from --latitude and --ia or the
    profile's [site]), after the --skip warm-up trim. The 1σ uncertainty is the Allan
    deviation at the record length from a fitted noise model, not σ/√n.

    Several LOGS with the same IA: run-to-run repeatability (1σ and max − min spread).
    Several IA directions (--positions, per-file profiles, or a position column): a
    multi-position fit separates D_F from earth rate and checks latitude and IA alignment.

    --warmup-band RATE: warm-up time of each run from power-on (the start of the log, before
    --skip): the end of the last --warmup-block block whose mean lies outside ± RATE of the
    final bias (mean of the last quarter); "not resolvable" when RATE is below 2σ of the
    block means.

    \b
    Examples:
      gyrotest bias sample_data/static.parquet --profile sample_data/static.profile.toml \\
          --skip 30min
      gyrotest bias sample_data/bias_run1.parquet sample_data/bias_run2.parquet \\
          sample_data/bias_run3.parquet --profile sample_data/bias_run1.profile.toml --skip 30min
      gyrotest bias sample_data/multipos.csv --profile sample_data/multipos.profile.toml \\
          --settle 30s                                 # positions from the log's column
    """
    skip_s = parse_duration(skip, what="--skip")
    unit = resolve_display_unit(display_unit, ingest_opts)
    settle_s = parse_duration(settle, what="--settle")
    band = parse_rate_dph(warmup_band, what="--warmup-band") if warmup_band is not None else None
    wblock = parse_duration(warmup_block, what="--warmup-block")
    if wblock <= 0:
        raise InputError(f"--warmup-block must be > 0, got {warmup_block!r}")
    if plot_path:
        from ..core.plotting import check_plot_path

        check_plot_path(plot_path)
    pos_list = parse_positions(positions, len(logs))  # before reading: a count error is cheap
    glogs = load_logs(logs, ingest_opts, announce=not as_json)
    res = bias(glogs, skip=skip_s, settle=settle_s, axis=axis, positions=pos_list,
               earth_rate=not no_earth_rate, outliers=outliers, warmup_band=band,
               warmup_block=wblock)
    if plot_path:
        from ..staticbias.plots import plot_bias

        for name, ba in res.per_axis.items():
            path = axis_plot_path(plot_path, name, len(res.per_axis))
            plot_bias(ba, path, unit=unit)
            if not as_json:
                note(f"plot of axis {name} written to {path}")
    if as_json:
        emit_json(res.to_dict())
        return
    for n in res.notes:
        note(n)
    for name, ba in res.per_axis.items():
        _render(ba.runs, ba.repeatability, ba.multi, axis=name, unit=unit)


def run_name(label: str) -> str:
    """A run's label for tables and notes: the file name without its directory, and a
    position of a multi-position log with its file (``up (multipos.csv)``)."""
    pos, sep, path = label.partition(" (")
    if sep and path.endswith(")"):
        return f"{pos} ({os.path.basename(path[:-1])})"
    return os.path.basename(label)


def _render(runs, rep, multi, axis: str = "", unit=None):
    from rich.table import Table

    from ..core.display import DEFAULT

    u = unit or DEFAULT
    f = u.f  # display rate per deg/h
    c = console()
    t = Table(title=f"Bias D_F (IEEE 952 §12.11.4.1.1), axis {axis}, rates in {u.rate}",
              caption="±1σ: Allan deviation at the record length from a fitted noise model "
                      "(honest for correlated noise); σ/√n only for comparison")
    for col in ("run", "used", "mean output", "Ω_IA", "D_F", "±1σ", "σ/√n"):
        t.add_column(col, justify="left" if col == "run" else "right")
    for r in runs:
        label = run_name(r.label)
        t.add_row(label, format_duration(r.duration_s), fmt_num(r.mean_output_dph * f, 6),
                  fmt_num(r.earth_rate_ia_dph * f, 6) if r.earth_rate_ia_dph is not None else "—",
                  fmt_num(r.bias_dph * f, 6) if not multi else "(fit)",
                  fmt_num(r.sigma_dph * f, 3), fmt_num(r.uncertainty.naive_sigma_dph * f, 2))
    c.print(t)
    _render_warmup(runs, u)
    for r in runs:
        for n in r.notes:
            (note if n.startswith("noise term(s)") else warn)(f"{run_name(r.label)}: {n}")
    if rep:
        c.print(f"\n[bold]Repeatability over {len(rep.runs)} runs, axis {axis}[/bold]: D_F mean "
                f"{fmt_num(rep.mean_dph * f, 6)} {u.rate}, 1σ {fmt_num(rep.sigma_1_dph * f, 3)} "
                f"{u.rate}, max spread {fmt_num(rep.spread_dph * f, 3)} {u.rate} "
                f"(within-run σ {fmt_num(rep.within_run_sigma_dph * f, 3)} {u.rate})")
        for n in rep.notes:
            warn(n)
    if multi:
        m = multi
        c.print(f"\n[bold]Multi-position fit, axis {axis}[/bold] ({len(m.positions)} positions): "
                f"D_F = {fmt_num(m.bias_dph * f, 6)} ± {fmt_num(m.bias_sigma_dph * f, 3)} {u.rate} (1σ)")
        for k in ("north", "east", "up"):
            v = m.earth_rate_fit_dph[k]
            if v is not None:
                c.print(f"  earth rate {k:5s} fitted {fmt_num(v * f, 6)} ± "
                        f"{fmt_num(m.earth_rate_fit_sigma_dph[k] * f, 3)} {u.rate}")
        if m.latitude_est_deg is not None:
            c.print(f"  latitude check: {m.latitude_est_deg:.4f} ± {m.latitude_est_sigma_deg:.4f}° "
                    f"(given {m.latitude_deg if m.latitude_deg is not None else '—'}°)")
        if m.azimuth_misalignment_deg is not None:
            c.print(f"  azimuth misalignment: {m.azimuth_misalignment_deg:+.4f} ± "
                    f"{m.azimuth_misalignment_sigma_deg:.4f}°")
        if m.ia_tilt_deg is not None:
            c.print(f"  apparent IA tilt towards north: {m.ia_tilt_deg:+.4f}°")
        if m.chi2_dof is not None:
            c.print(f"  χ²/dof of the position fit: {m.chi2_dof:.2f}")
        for n in m.notes:
            note(n)


def _render_warmup(runs, u) -> None:
    """One line per run: the warm-up time from power-on (when --warmup-band was given)."""
    if not runs or runs[0].warmup_time is None:
        return
    w0 = runs[0].warmup_time
    c = console()
    c.print(f"\n[bold]Warm-up time[/bold] (IEEE 952 §5.3.3 / IEEE 528; from power-on until the "
            f"bias stays within ± {fmt_num(w0['band_dph'] * u.f, 3)} {u.rate} of its final value; "
            f"{format_duration(w0['block_s'])} blocks)")
    for r in runs:
        w = r.warmup_time
        name = run_name(r.label)
        if w["warmup_time_s"] == w["warmup_time_s"]:  # finite
            c.print(f"  {name}: warm-up time {fmt_num(w['warmup_time_s'], 5)} s "
                    f"({format_duration(w['warmup_time_s'])}; ± {fmt_num(w['block_s'], 3)} s "
                    f"block resolution), initial offset {fmt_num(w['initial_offset_dph'] * u.f, 3)} "
                    f"{u.rate}, block noise {fmt_num(w['block_noise_dph'] * u.f, 3)} {u.rate}")
        else:
            c.print(f"  {name}: {w['status']}")
