"""``gyrotest ingest``: validate a log and convert it to Parquet/Feather with metadata."""

from __future__ import annotations

import time

import click

from ..core.output import LOG_SUFFIXES, check_output_path
from ..core.units import format_duration
from ..io.ingest import write_log
from .common import emit_json, ingest_options, json_option, load_log, note, with_ingest


@click.command("ingest")
@click.argument("log", type=str)
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False),
              help="Output file: .parquet or .feather (.arrow).")
@click.option("--force", is_flag=True,
              help="Allow the output to replace LOG itself (a Parquet/Feather log converted "
                   "in place); without it an output that is one of the inputs is refused.")
@ingest_options
@json_option
@with_ingest
def command(log, output, force, as_json, ingest_opts):
    """Validate LOG and convert it to Parquet (or Feather) in internal units.

    The file keeps the metadata (units, sample interval, site, gyro constants, timing, column
    roles), so later commands read it back fast without a profile. The output is written to a
    temporary file and renamed: never a half-written file.

    \b
    Example:
      gyrotest ingest sample_data/multipos.csv --profile sample_data/multipos.profile.toml \\
          -o multipos.parquet
    """
    check_output_path(output, LOG_SUFFIXES, "output file", formats=".parquet or .feather")
    t0 = time.perf_counter()
    g = load_log(log, ingest_opts, announce=not as_json, dead="note")
    t1 = time.perf_counter()
    path = write_log(g, output)
    t2 = time.perf_counter()
    result = {"output": str(path), "samples": g.n, "duration_s": g.duration_s,
              "tau0_s": g.tau0, "gaps": len(g.timing.gaps), "read_s": t1 - t0,
              "write_s": t2 - t1, "axes": g.axes}
    if as_json:
        emit_json(result)
    else:
        note(f"read {g.n:,} samples ({format_duration(g.duration_s)}) in {t1 - t0:.2f} s, "
             f"wrote {path} in {t2 - t1:.2f} s")
        click.echo(str(path))
