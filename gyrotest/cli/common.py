"""Shared CLI plumbing: ingest options, --json, human output on stderr/stdout, progress.

Conventions for command modules (``gyrotest/cli/cmd_<name>.py``, exposing ``command``):

* decorate with :func:`ingest_options` to get every column/profile option and call
  :func:`load_log` (or :func:`load_logs`) with the collected kwargs: one ingest path for all;
* :func:`json_option` adds ``--json``; with it, print exactly one JSON document to stdout via
  :func:`emit_json` and nothing else on stdout;
* human output goes through :func:`console` (stdout, rich) and notes/warnings through
  :func:`note` / :func:`warn` (stderr, suppressed by ``-q``);
* files are written atomically with :mod:`gyrotest.core.output` helpers;
* raise :class:`gyrotest.core.errors.InputError` for anything the user can fix (exit code 2).
"""

from __future__ import annotations

import contextlib
import functools
import os
import sys
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

import click

from ..core.console import (
    err_console,
    escape_markup,
    warn,  # noqa: F401 (the commands import it from here)
)
from ..core.errors import InputError
from ..core.units import format_number
from ..io.inputs import ingest_overrides as _api_ingest_overrides
from ..io.inputs import read_with_options


class FiniteRange(click.FloatRange):
    """``click.FloatRange`` that also refuses NaN (which compares false with both bounds)."""

    def convert(self, value, param, ctx):
        v = super().convert(value, param, ctx)
        if v != v:
            self.fail(f"{value!r} is not a number", param, ctx)
        return v


@dataclass
class Settings:
    debug: bool = False
    quiet: bool = False
    verbose: bool = False


def settings() -> Settings:
    ctx = click.get_current_context(silent=True)
    while ctx is not None:
        if isinstance(ctx.obj, Settings):
            return ctx.obj
        ctx = ctx.parent
    return Settings()


_console = None


def console():
    """Rich console on stdout (plain text when piped)."""
    global _console
    from rich.console import Console

    if _console is None or _console.file is not sys.stdout:
        # piped or captured: plain text at least 120 wide (a wider COLUMNS wins: an 80-column
        # terminal's COLUMNS would truncate table headers in a file), long lines are not broken
        # (paths, notes), so that logs and `grep` see whole lines
        width = None
        if not sys.stdout.isatty():
            try:
                width = max(120, int(os.environ.get("COLUMNS", 120)))
            except ValueError:
                width = 120
        _console = _quiet_pipe_console(Console)(file=sys.stdout, highlight=False,
                                                soft_wrap=not sys.stdout.isatty(), width=width)
    return _console


@functools.cache
def _quiet_pipe_console(base):
    """``base`` (rich's Console) whose closed-pipe handling hands back to the command line:
    rich's own ``on_broken_pipe`` raises SystemExit(1), so ``gyrotest … | head`` exited 1;
    this one silences the console and raises BrokenPipeError, which ``gyrotest.cli`` turns
    into exit 0 (downstream closing the pipe is not an error)."""

    class QuietPipeConsole(base):
        def on_broken_pipe(self) -> None:
            self.quiet = True
            raise BrokenPipeError

    return QuietPipeConsole


def notes_shown() -> bool:
    """Notes and progress reach stderr when it is a terminal, or with ``-v`` on any stderr
    (a log file, ``2>err``); ``-q`` silences them. A redirected stderr then holds the
    warnings and the error only."""
    s = settings()
    if s.quiet:
        return False
    if s.verbose:
        return True
    try:
        return sys.stderr.isatty()
    except (AttributeError, ValueError):  # a closed or odd stream
        return False


def note(msg: str) -> None:
    """An informational line on stderr: on a terminal, or anywhere with -v (-q: never)."""
    if notes_shown():
        err_console().print(f"[dim]{escape_markup(msg)}[/dim]")


def emit_json(obj: Any) -> None:
    """Write one JSON document to stdout."""
    from ..core.output import dumps  # numpy: only when JSON is written

    sys.stdout.write(dumps(obj) + "\n")
    sys.stdout.flush()


@contextlib.contextmanager
def progress(description: str, total: float | None = None) -> Iterator[Callable[..., None]]:
    """A progress bar on stderr when it is a terminal (and not -q); otherwise silent.
    Yields ``advance(amount=1, total=None, description=None)`` (``total`` may be set late)."""
    if settings().quiet or not sys.stderr.isatty():
        yield lambda amount=1, total=None, description=None: None
        return
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    with Progress(TextColumn("{task.description}"), BarColumn(), TimeElapsedColumn(),
                  console=err_console(), transient=True) as prog:
        task = prog.add_task(description, total=total)

        def advance(amount: float = 1, total: float | None = None,
                    description: str | None = None) -> None:
            kw = {}
            if total is not None:
                kw["total"] = total
            if description is not None:
                kw["description"] = description
            prog.update(task, advance=amount, **kw)

        yield advance


# ----------------------------------------------------------------------------- options
def plot_option(help: str, figures: str | None = None):
    """The ``--plot FILE`` option (.png/.svg/.pdf) with a command's own help text; ``figures``
    names the figures of a command that draws several, and the help says where each goes."""
    if figures:
        help += (f" Several figures ({figures}): the first is FILE, each other one is written "
                 "beside it as FILE-NAME.png (.svg); a .pdf holds them all, one per page.")
    return click.option("--plot", "plot_path", type=click.Path(dir_okay=False), default=None,
                        help=help)


def plots_written(paths) -> None:
    """The one note for written plot files: "plot written to a.png" or "plots written to
    a.png, a-channels.png"."""
    paths = [str(p) for p in paths]
    if paths:
        note(("plot written to " if len(paths) == 1 else "plots written to ")
             + ", ".join(paths))


def json_option(f):
    return click.option("--json", "as_json", is_flag=True,
                        help="Print the result as one JSON document on stdout (for scripts).")(f)


INGEST_OPTION_NAMES = (
    "profile", "time_col", "rate_col", "rate_unit", "counts_col", "up_col", "down_col",
    "counter_col", "counter_bits", "voltage_col", "scale_factor", "offset", "sample_rate",
    "time_unit",
    "temp_col", "field_cols", "field_cols_alias", "supply_col", "table_col", "position_col", "latitude", "ia",
    "nan_policy", "topic", "delta_angle_col", "angle_col", "angle_unit", "output_kind",
)


def _check_rate_unit(ctx, param, value):
    """--rate-unit names a rate unit gyrotest knows, whatever the log holds."""
    if value is None:
        return None
    from ..core.units import factor

    try:
        factor(value, "rate")
    except InputError as e:
        raise click.BadParameter(str(e)) from None
    return value


def ingest_options(f):
    """Add the ingest options shared by every command that reads a log."""
    opts = [
        click.option("--profile", type=click.Path(dir_okay=False), default=None,
                     help="Bench profile TOML naming columns and constants; options below override it."),
        click.option("--time-col", default=None, help="Time column (seconds or ISO-8601)."),
        click.option("--rate-col", default=None,
                     help="Rate column(s), comma-separated for several axes."),
        click.option("--rate-unit", default=None, callback=_check_rate_unit,
                     help="Unit of the rate column: deg/h, deg/s, rad/s, mrad/s, urad/s, deg/min."),
        click.option("--counts-col", default=None, help="Pulse counts per sample column."),
        click.option("--up-col", default=None, help="Up-pulse column (with --down-col)."),
        click.option("--down-col", default=None, help="Down-pulse column (with --up-col)."),
        click.option("--counter-col", default=None, help="Cumulative counter column (rolls over)."),
        click.option("--counter-bits", type=int, default=None, help="Counter width, bits (16, 32)."),
        click.option("--voltage-col", default=None, help="Analog output voltage column."),
        click.option("--delta-angle-col", default=None,
                     help="Angle-increment (delta-angle) column(s) per sample; rate = Δθ/τ0."),
        click.option("--angle-col", default=None,
                     help="Cumulative-angle column(s); rate = Δθ/Δt between samples."),
        click.option("--angle-unit", default=None,
                     help="Unit of angle columns: rad, deg, arcsec, mrad, urad."),
        click.option("--output-kind", type=click.Choice(["rate", "delta-angle", "angle"]),
                     default=None,
                     help="Read the gyro columns (auto-detected or --rate-col) as rates, angle "
                          "increments per sample or a cumulative angle."),
        click.option("--scale-factor", type=float, default=None,
                     help="S0: arcsec/pulse for pulse outputs, (deg/h)/V for voltage."),
        click.option("--offset", type=float, default=None, help="Voltage offset, V."),
        click.option("--sample-rate", type=float, default=None,
                     help="Sample rate, Hz: the time axis when the log has no time column, "
                          "else checked against it."),
        click.option("--time-unit", type=click.Choice(["s", "ms", "us", "ns"]), default=None,
                     help="Unit of a numeric time column (default: seconds, or a ms/us/ns Unix "
                          "epoch recognised from its magnitude and spacing)."),
        click.option("--temp-col", multiple=True,
                     help="Temperature column(s), degC: comma-separated or repeated."),
        click.option("--field-col", "field_cols", multiple=True,
                     help="Magnetic field columns X,Y,Z, uT: comma-separated or repeated."),
        click.option("--field-cols", "field_cols_alias", default=None, hidden=True,
                     help="Old spelling of --field-col."),
        click.option("--supply-col", default=None, help="Supply-voltage column, V."),
        click.option("--table-col", default=None, help="Commanded rate-table rate column (deg/s)."),
        click.option("--position-col", default=None, help="Multi-position label column."),
        click.option("--latitude", type=float, default=None, help="Site latitude, degrees."),
        click.option("--ia", default=None,
                     help="Input-axis direction: up/down/north/south/east/west or AZ/EL degrees."),
        click.option("--topic", default=None,
                     help="ROS bag: the sensor_msgs/Imu topic (needed when there are several); "
                          "HDF5: the group; MATLAB: the struct holding the columns."),
        click.option("--nan", "nan_policy", type=click.Choice(["error", "gap", "interpolate"]),
                     default="error", show_default=True,
                     help="Missing values: stop, drop rows as gaps, or interpolate channels."),
    ]
    for o in reversed(opts):
        f = o(f)
    return f


def pop_ingest_kwargs(kwargs: dict) -> dict:
    """Remove the ingest options from a command's kwargs and return them."""
    return {k: kwargs.pop(k) for k in INGEST_OPTION_NAMES if k in kwargs}


#: the ingest options as profile overrides: one function for the API and the CLI
ingest_overrides = _api_ingest_overrides


def load_log(path: str, opts: dict, *, announce: bool = True, stream: bool = False,
             dead: str = "error"):
    """Read one log with the shared ingest options (:func:`gyrotest.io.inputs.read_with_options`);
    prints the column choices as notes when ``announce``. ``dead="note"``: a dead or stuck gyro
    output is a note, not an error (``info``, ``ingest``: they describe and convert, they do
    not fit)."""
    return read_with_options(path, opts, note=note if announce else None, stream=stream,
                             dead=dead)


def load_for_terms(path: str, opts: dict, specs: list, *, announce: bool = True):
    """:func:`load_log` for a model with term ``specs``: an ingest error about a channel a
    term needs names the term too (:func:`gyrotest.envmodel.pipeline.naming_terms`)."""
    from ..envmodel.pipeline import naming_terms

    return naming_terms(lambda: load_log(path, opts, announce=announce), specs)


def load_logs(paths: tuple[str, ...] | list[str], opts: dict, *, announce: bool = True,
              stream: bool = False) -> list:
    if not paths:
        raise InputError("no log file given")
    if sum(1 for p in paths if p == "-") > 1:
        raise InputError("stdin ('-') can be read only once")
    return [load_log(p, opts, announce=announce, stream=stream) for p in paths]


def with_ingest(func):
    """Decorator for commands: collects the ingest options into ``ingest_opts``."""
    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        kwargs["ingest_opts"] = pop_ingest_kwargs(kwargs)
        return func(*args, **kwargs)

    return wrapper


#: compact number formatting for tables ('—' for None/NaN), :func:`gyrotest.core.units.format_number`
fmt_num = format_number
