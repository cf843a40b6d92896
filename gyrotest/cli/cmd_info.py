"""``gyrotest info``: summarise a log (duration, rate, channels, gaps, ranges)."""

from __future__ import annotations

import click
from rich.markup import escape

from ..axes import choose_axes
from ..units import format_duration
from .common import (
    console,
    emit_json,
    fmt_num,
    ingest_options,
    json_option,
    load_log,
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
@ingest_options
@json_option
@with_ingest
def command(log, axis, display_unit, as_json, ingest_opts):
    """Summarise LOG: duration, sample rate, gyro output, channels with ranges, gaps, spikes.

    Spikes in each rate axis are found with a Hampel filter (running median, robust scale) and
    reported with their times (warning on stderr; "outliers" in --json).

    LOG is a CSV/TSV/whitespace text file with a header (also gzip'd), a Parquet or Feather
    file, a MATLAB .mat, an HDF5 file, a ROS bag (.bag, .mcap, .db3 or a ROS 2 bag directory;
    sensor_msgs/Imu), or '-' for CSV on stdin. Shows which column was used for what
    ('gyrotest columns LOG' lists every column).

    \b
    Example:
      gyrotest info sample_data/multipos.csv --profile sample_data/multipos.profile.toml
    """
    from ..ingest import RoleError
    from ..noise.outliers import detect_outliers

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
    for r in reps:
        if r.found:
            warn(f"{g.source}: spikes: {r.summary()} (gyrotest allan/bias --outliers remove or "
                 "robust to treat them)")
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
    if summary.get("positions"):
        c.print("  positions      " + esc(", ".join(f"{k}: {v}"
                                                  for k, v in summary["positions"].items())))


def _list_columns(log: str, as_json: bool) -> None:
    """The columns of LOG with the role and unit gyrotest guesses from each name (on stdout)."""
    from ..ingest import column_guesses, column_names

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
