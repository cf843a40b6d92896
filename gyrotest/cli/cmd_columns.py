"""``gyrotest columns``: every column of a log with its guessed and assigned role and unit."""

from __future__ import annotations

import click

from .common import console, emit_json, ingest_options, json_option, warn, with_ingest


@click.command("columns")
@click.argument("log", type=str)
@ingest_options
@json_option
@with_ingest
def command(log, as_json, ingest_opts):
    """List every column of LOG without reading its data: the role its name suggests, the
    unit its header (or the file: ROS message, HDF5 attribute) states, and the role gyrotest
    gives it with the options and profile given ("used as").

    Works when the gyro output cannot be found (the problem is printed as a warning, exit 0),
    so it is the first thing to run on a new logger's file. LOG: CSV/TSV/whitespace text
    (also gzip'd), Parquet, Feather, MATLAB .mat, HDF5, a ROS bag (.bag, .mcap, .db3 or a
    ROS 2 bag directory) or '-' for CSV on stdin.

    \b
    Example:
      gyrotest columns sample_data/multipos.csv
    """
    from rich.markup import escape
    from rich.table import Table

    from ..core.profile import load_profile
    from ..io.ingest import describe_columns
    from .common import ingest_overrides

    prof = load_profile(ingest_opts["profile"]) if ingest_opts.get("profile") else None
    info = describe_columns(log, profile=prof, overrides=ingest_overrides(ingest_opts))
    if info["problem"]:
        warn(info["problem"])
    if as_json:
        emit_json(info)
        return
    t = Table(title=f"columns of {escape(info['source'])} ({info['format']})")
    for col in ("column", "guessed from the name", "unit", "used as"):
        t.add_column(col)
    for g in info["columns"]:
        t.add_row(escape(g["column"]), escape(g["role"] or "—"), escape(g["unit"] or "—"),
                  escape(g["assigned"] or "—"))
    c = console()
    c.print(t)
    for n in info["notes"]:
        c.print(f"  {escape(n)}")
