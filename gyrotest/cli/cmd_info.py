"""``gyrotest info``: summarise a log (duration, rate, channels, gaps, ranges)."""

from __future__ import annotations

import click
from rich.markup import escape

from ..core.axes import choose_axes
from ..core.units import format_duration
from .common import (
    console,
    emit_json,
    fmt_num,
    ingest_options,
    json_option,
    load_log,
    note,
    plot_option,
    warn,
    with_ingest,
)
from .common_display import resolve_display_unit, unit_option


def esc(x) -> str:
    """Text for rich markup: brackets in names (``gx [deg/s]``) printed as they are."""
    return escape("" if x is None else str(x))


@click.command("info")
@click.argument("log", type=str)
@click.option("--axis", default=None,
              help="Gyro axis (rate column) to list, comma-separated for several; default every axis.")
@unit_option
@plot_option("Quick look on one page: the gyro output of every axis, the temperatures, the "
             "magnetic field, supply and rate table against time, gaps shaded and spikes "
             "marked (.png/.svg/.pdf).")
@ingest_options
@json_option
@with_ingest
def command(log, axis, display_unit, plot_path, as_json, ingest_opts):
    """Summarise LOG: duration, sample rate, gyro output, channels with ranges, gaps, spikes.

    Also the gap map (gaps by missed samples, the longest gap-free stretch before and after
    allan's --fill), the accelerometer axes and their units, and the output quantisation of
    every axis read from its values (LSB, levels used, the rounding's share of the sample
    noise, and the white rate noise N_q it adds).

    Spikes in each rate axis are found with a Hampel filter (running median, robust scale) and
    reported with their times (warning on stderr; "outliers" in --json).

    LOG is a CSV/TSV/whitespace text file with a header (also gzip'd), a Parquet or Feather
    file, a MATLAB .mat, an HDF5 file, a ROS bag (.bag, .mcap, .db3 or a ROS 2 bag directory;
    sensor_msgs/Imu), or '-' for CSV on stdin. Shows which column was used for what
    ('gyrotest columns LOG' lists every column).

    \b
    Examples:
      gyrotest info sample_data/multipos.csv --profile sample_data/multipos.profile.toml
      gyrotest info sample_data/thermal.parquet --profile sample_data/thermal.profile.toml \\
          --plot thermal_look.png                 # a quick look: output, temperatures, gaps
    """
    from ..io.ingest import RoleError
    from ..noise.outliers import detect_outliers

    if plot_path:
        from ..core.plotting import check_plot_path

        check_plot_path(plot_path)
    unit = resolve_display_unit(display_unit, ingest_opts)
    try:
        g = load_log(log, ingest_opts, announce=not as_json, dead="note")
    except RoleError:
        _list_columns(log, as_json)  # the columns and the guesses, then the error itself
        raise
    summary = g.summary()
    axes = choose_axes([g], axis)
    summary["axes"] = axes
    summary["channels"] = {k: v for k, v in summary["channels"].items()
                           if not k.startswith("rate:") or k[5:] in axes}
    reps = [detect_outliers(g.rates[a], g.tau0, t0=float(g.t[0]) if g.n else 0.0, channel=a,
                            segments=g.segments, unit="deg/h") for a in axes if g.n >= 3]
    summary["outliers"] = {r.channel: r.to_dict() for r in reps}
    from ..io.gapfill import gap_map

    gmap = gap_map(g) if g.timing.gaps else None
    summary["gap_map"] = gmap
    from ..io.accel import accel_channels
    from ..noise.resolution import output_resolution

    acc = accel_channels(g)
    summary["accelerometers"] = acc.to_dict() if (acc or acc.notes) else None
    res = {a: output_resolution(g.rates[a], tau0=g.tau0, unit="deg/h") for a in axes}
    res.update({a: output_resolution(v, unit="m/s^2") for a, v in acc.data.items()})
    summary["resolution"] = {k: v for k, v in res.items() if v is not None}
    for r in reps:
        if r.found:
            warn(f"{g.source}: spikes: {r.summary()} (gyrotest allan/bias --outliers remove or "
                 "robust to treat them)")
    if plot_path:
        from ..io.quicklook import plot_quicklook

        summary["plot"] = str(plot_quicklook(g, plot_path, axes=axes, unit=unit, outliers=reps))
        if not as_json:
            note(f"plot written to {plot_path}")
    if as_json:
        emit_json(summary)
        return
    from rich.table import Table

    tm = g.timing
    c = console()
    c.print(f"[bold]{esc(g.source)}[/bold]")
    c.print(f"  samples        {tm.n:,}   ({esc(tm.source)})")
    c.print(f"  sample rate    {fmt_num(tm.sample_rate_hz, 6)} Hz  (tau0 = {fmt_num(tm.tau0, 6)} s)")
    c.print(f"  duration       {format_duration(tm.duration_s)}  ({tm.duration_s:.6g} s)")
    if tm.start:
        c.print(f"  start          {tm.start}")
    gy = g.gyro
    kind = {"rate": f"rate ({esc(gy.rate_unit)})", "counts": "pulse counts per sample",
            "updown": "up/down pulse pairs", "counter": f"cumulative {gy.counter_bits}-bit counter",
            "voltage": "analog voltage",
            "delta-angle": f"angle increments per sample ({esc(gy.rate_unit)})",
            "angle": f"cumulative angle ({esc(gy.rate_unit)})"}[gy.output_kind]
    c.print(f"  gyro output    {kind}")
    c.print(f"  gyro axes      {', '.join(axes)}"
            + (f"  (of {', '.join(g.axes)})" if len(axes) < len(g.axes) else ""))
    if gy.scale_factor is not None:
        c.print(f"  scale factor   {gy.scale_factor:g} {gy.scale_factor_unit}"
                + (f", offset {gy.offset_v:g} V" if gy.offset_v is not None else ""))
    if g.site:
        s = g.site
        c.print(f"  site           latitude {s.latitude_deg:g}°, IA {esc(s.ia_label)} "
                f"(earth rate along IA {fmt_num(s.earth_rate_dph() * unit.f, 5)} {unit.rate})")
    if tm.gaps:
        c.print(f"  gaps           {len(tm.gaps)}: " + "; ".join(
            f"at {gp.time_s:.6g} s for {gp.duration_s:.4g} s" for gp in tm.gaps[:5])
            + (" ..." if len(tm.gaps) > 5 else ""))
        sizes = ", ".join(f"{v} × {k} missed" for k, v in gmap["by_missing_samples"].items())
        c.print(f"  gap map        {sizes} ({gmap['missing_samples']} samples, "
                f"{100 * gmap['missing_fraction']:.2g} %); longest gap-free stretch "
                f"{format_duration(gmap['longest_gap_free_s'])}"
                + (f"; allan --fill {gmap['fill_max_missing']} (default) bridges "
                   f"{gmap['bridged_by_fill']} of them → longest "
                   f"{format_duration(gmap['longest_after_fill_s'])}"
                   if gmap["bridged_by_fill"] else ""))
    else:
        c.print("  gaps           none")
    if tm.irregular:
        c.print(f"  [yellow]irregular sampling: jitter {100 * tm.jitter_rel:.2g}% of tau0[/yellow]")
    t = Table(title="channels", show_lines=False)
    for col in ("channel", "unit", "min", "mean", "max", "std"):
        t.add_column(col, justify="right" if col not in ("channel", "unit") else "left")
    for name, st in summary["channels"].items():
        f, u = (unit.f, unit.rate) if name.startswith("rate:") else (1.0, st["unit"])
        t.add_row(esc(name), esc(u), fmt_num(st["min"] * f), fmt_num(st["mean"] * f),
                  fmt_num(st["max"] * f), fmt_num(st["std"] * f))
    c.print(t)
    if acc:
        c.print("  accelerometers " + ", ".join(f"{esc(k)} ({esc(acc.units[k])})" for k in acc.data)
                + ": read as m/s² (gyrotest allan analyses them: IEEE Std 1293 terms)")
    for n_ in acc.notes:
        c.print(f"  [yellow]{esc(n_)}[/yellow]")
    from ..noise.resolution import resolution_text

    for a, r in summary["resolution"].items():
        if r["unit"] == "deg/h":
            txt = resolution_text(r, unit.f, unit.rate)
        else:
            txt = resolution_text(r, 1e6 / 9.80665, "µg")
        c.print(f"  {esc(a):<14} {esc(txt)}")
    if summary.get("positions"):
        c.print("  positions      " + esc(", ".join(f"{k}: {v}"
                                                  for k, v in summary["positions"].items())))


def _list_columns(log: str, as_json: bool) -> None:
    """The columns of LOG with the role and unit gyrotest guesses from each name (on stdout)."""
    from ..io.ingest import column_guesses, column_names

    guesses = column_guesses(column_names(log))
    if not guesses:
        return
    if as_json:
        emit_json({"source": log, "columns": guesses})
        return
    from rich.table import Table

    t = Table(title=f"columns of {esc(log)} (guessed from the names)")
    for col in ("column", "guessed role", "unit in header"):
        t.add_column(col)
    for g in guesses:
        t.add_row(esc(g["column"]), esc(g["role"] or "—"), esc(g["unit"] or "—"))
    console().print(t)
