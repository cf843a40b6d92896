"""The ``gyrotest`` command line.

Thin layer: each command lives in ``gyrotest/cli/cmd_<name>.py`` and exposes a click command
object named ``command``; it parses options, calls the core, and renders (rich tables on a
terminal, ``--json`` for scripts). Commands are imported lazily so ``gyrotest --help`` and
pipelines stay fast.

Exit codes: 0 ok, 2 bad input or usage, 1 internal error. Errors are one line on stderr
(``gyrotest: error: ...``); ``--debug`` adds the traceback.
"""

from __future__ import annotations

import importlib
import importlib.util
import os
import sys
import traceback
import warnings

# Single-threaded BLAS unless the user says otherwise (set before numpy is imported): our
# matrices are small (τ × frequency grids, a few dozen columns) and OpenBLAS' worker threads
# cost 4–10× in CPU and wall time on a loaded 2-core machine (benchmarks/README.md, start-up)
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
# No transparent-huge-page advice on numpy's large arrays unless the user says otherwise:
# where the kernel compacts memory on such a fault (THP defrag "madvise", the common default),
# first touching a fresh 80 MB array cost 0.22 s instead of 0.03 s, and `allan` on a 10⁷-row
# CSV spent 0.3-0.5 s more system time (benchmarks/README.md, fifth pass); our arrays are
# streamed through, not randomly accessed, so huge pages buy nothing back
os.environ.setdefault("NUMPY_MADVISE_HUGEPAGE", "0")

import click  # noqa: E402

from .. import __version__  # noqa: E402
from ..core.errors import GyrotestError  # noqa: E402

# command name -> module (in the order shown by --help)
COMMANDS: dict[str, str] = {
    "info": "cmd_info",
    "columns": "cmd_columns",
    "ingest": "cmd_ingest",
    "bias": "cmd_bias",
    "allan": "cmd_allan",
    "scale-factor": "cmd_scale_factor",
    "model": "cmd_model",
    "thermal-fit": "cmd_thermal_fit",
    "mag-fit": "cmd_mag_fit",
    "compensate": "cmd_compensate",
    "report": "cmd_report",
    "export": "cmd_export",
    "fleet": "cmd_fleet",
    "simulate": "cmd_simulate",
}

# one line per command for `gyrotest --help` (the full text is `gyrotest CMD --help`)
SHORT_HELP: dict[str, str] = {
    "info": "Summarise a log: duration, rate, channels, gaps.",
    "columns": "List a log's columns, the role and unit of each.",
    "ingest": "Validate a log, convert it to Parquet/Feather.",
    "bias": "Bias D_F with honest uncertainty, repeatability, positions.",
    "allan": "Allan deviations with CIs, noise-model fit and diagnosis.",
    "scale-factor": "Scale factor, linearity, asymmetry from rate-table runs.",
    "model": "Model workbench: fit drift models, find the missing effect.",
    "thermal-fit": "Thermal drift model (Antonova–Matveev; IEEE D_T, D_Ṫ, D_∇Ṫ).",
    "mag-fit": "Magnetic sensitivities wx, wy, wz from Helmholtz-coil runs.",
    "compensate": "Apply a drift model to another run: drift before and after.",
    "report": "IEEE-952-style spec sheet of a campaign (Markdown/HTML/PDF).",
    "export": "Deliverables as files: Kalibr, MATLAB, Stable32, firmware tables.",
    "fleet": "Lot summary of many serials: table, control charts, outliers.",
    "simulate": "Simulate a bench log with known truth from a scenario TOML.",
}


class SuggestingGroup(click.Group):
    """A click group that answers a mistyped sub-command with the nearest names ("No such
    command 'bais'. Did you mean 'bias'?"), as click already does for options."""

    def resolve_command(self, ctx, args):
        try:
            return super().resolve_command(ctx, args)
        except click.UsageError as e:
            name = click.utils.make_str(args[0]) if args else ""
            if not name or name.startswith("-") or self.get_command(ctx, name) is not None:
                raise
            import difflib

            close = difflib.get_close_matches(name, self.list_commands(ctx), n=3, cutoff=0.6)
            if not close:
                raise
            hint = " or ".join(repr(c) for c in close)
            raise click.UsageError(f"No such command {name!r}. Did you mean {hint}?",
                                   ctx) from e


class LazyGroup(SuggestingGroup):
    """A click group whose sub-commands are imported on first use."""

    def list_commands(self, ctx):
        return [name for name, mod in COMMANDS.items() if _module_exists(mod)]

    def get_command(self, ctx, name):
        mod = COMMANDS.get(name)
        if mod is None or not _module_exists(mod):
            return None
        module = importlib.import_module(f"{__name__}.{mod}")
        from .io_roles import guard_commands

        return guard_commands(module.command)

    def format_commands(self, ctx, formatter):
        # the one-liners come from SHORT_HELP so that `gyrotest --help` imports no command
        # module (and none of numpy/scipy/pyarrow); a command without one is imported
        rows = []
        for name in self.list_commands(ctx):
            if name in SHORT_HELP:
                rows.append((name, SHORT_HELP[name]))
                continue
            cmd = self.get_command(ctx, name)
            if cmd is not None and not cmd.hidden:
                rows.append((name, cmd.get_short_help_str(limit=70)))
        if rows:
            with formatter.section("Commands"):
                formatter.write_dl(rows)


def _module_exists(mod: str) -> bool:
    return importlib.util.find_spec(f"{__name__}.{mod}") is not None


@click.group(cls=LazyGroup, invoke_without_command=True,
             context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, "--version", prog_name="gyrotest")
@click.option("--debug", is_flag=True, help="Show the Python traceback on errors.")
@click.option("-q", "--quiet", is_flag=True, help="No progress or notes on stderr.")
@click.option("-v", "--verbose", is_flag=True,
              help="Notes on stderr also when it is not a terminal (a file, a pipe); "
                   "without -v they are shown on a terminal only.")
@click.pass_context
def cli(ctx, debug, quiet, verbose):
    """gyrotest: gyro test-bench logs to an IEEE-952-style specification sheet.

    Ingest bench logs (CSV/TSV, Parquet, Feather, stdin), strip earth rate and estimate the
    bias D_F, reduce rate-table runs to scale factor, fit thermal and magnetic models, run
    Allan noise analysis, and write a spec sheet. Every analysis command takes --json for
    scripts; units are explicit everywhere (deg/h, deg/sqrt(h), arcsec/pulse ...).

    Exit codes: 0 ok, 2 bad input or usage, 1 internal error. Notes go to stderr on a
    terminal only (-v: also to a file or pipe; -q: never); warnings and errors always.
    """
    from .common import Settings

    ctx.obj = Settings(debug=debug, quiet=quiet, verbose=verbose)
    if ctx.invoked_subcommand is None:  # a bare `gyrotest`: the help, as `gyrotest --help`
        click.echo(ctx.get_help())


def _err(msg: str) -> None:
    try:
        sys.stderr.write(f"gyrotest: error: {msg}\n")
        sys.stderr.flush()
    except Exception:  # pragma: no cover - stderr closed
        pass


GLOBAL_FLAGS = ("-q", "--quiet", "-v", "--verbose", "--debug")


def hoist_global_flags(args: list[str]) -> list[str]:
    """``-q``/``--quiet``/``-v``/``--verbose``/``--debug`` are accepted anywhere on the command line (``gyrotest
    allan log.csv -q``): they are moved in front of the sub-command; after ``--`` nothing is
    moved."""
    stop = args.index("--") if "--" in args else len(args)
    flags = [a for a in args[:stop] if a in GLOBAL_FLAGS]
    rest = [a for a in args[:stop] if a not in GLOBAL_FLAGS]
    return flags + rest + args[stop:]


def main(argv: list[str] | None = None) -> None:
    """Console-script entry point."""
    args = hoist_global_flags(list(sys.argv[1:] if argv is None else argv))
    debug = "--debug" in args or os.environ.get("GYROTEST_DEBUG") == "1"
    with warnings.catch_warnings():
        _route_warnings(debug)
        code = _run(args, debug)
    if argv is None and os.environ.get("GYROTEST_FAST_EXIT", "1") != "0":
        _fast_exit(code)
    sys.exit(code)


def _fast_exit(code: int) -> None:
    """End the process without the interpreter's teardown: every output file is closed by
    then (written atomically by the commands, worker pools and threads joined), so only the
    standard streams are flushed. Freeing the modules and arrays of a run is otherwise
    0.05-0.1 s of a command's time, which lab scripts pay once per file (benchmarks/README.md,
    eleventh pass). Console script only (``main()`` without ``argv``); ``GYROTEST_FAST_EXIT=0``
    keeps the normal exit."""
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe downstream (`| head`): nothing to do
            pass
    os._exit(code)


def _route_warnings(debug: bool) -> None:
    """Library warnings (numpy/pandas/scipy) never reach the terminal as Python warnings:
    gyrotest turns the meaningful ones into notes or errors itself; the rest are silenced, or
    shown as one-line notes with --debug. ``python -W ...`` or ``PYTHONWARNINGS`` (as the
    tests use: warnings as errors) leave Python's own handling in place."""
    if sys.warnoptions or os.environ.get("PYTHONWARNINGS"):
        return
    if not debug:
        warnings.simplefilter("ignore")
        return
    warnings.simplefilter("always")

    def show(message, category, filename, lineno, file=None, line=None):
        try:
            sys.stderr.write(f"gyrotest: debug: {category.__name__} at "
                             f"{os.path.basename(filename)}:{lineno}: {message}\n")
        except Exception:  # pragma: no cover - stderr closed
            pass

    warnings.showwarning = show


def _run(args: list[str], debug: bool) -> int:
    try:
        rv = cli.main(args=args, prog_name="gyrotest", standalone_mode=False)
        code = rv if isinstance(rv, int) else 0
    except click.exceptions.Exit as e:
        code = e.exit_code
    except click.exceptions.Abort:
        _err("aborted")
        code = 1
    except click.ClickException as e:
        if debug:
            traceback.print_exc()
        # usage errors (unknown option, missing argument, bad value): one line + hint
        msg = e.format_message().replace("\n", " ")
        ctx = getattr(e, "ctx", None)
        hint = f" (see '{ctx.command_path} --help')" if ctx is not None else ""
        _err(msg + hint)
        code = 2
    except GyrotestError as e:
        if debug:
            traceback.print_exc()
        problems = getattr(e, "problems", None) or [str(e)]  # a DocumentError: one per line
        for line in problems[:20]:
            _err(line.replace("\n", " "))
        if len(problems) > 20:
            _err(f"... and {len(problems) - 20} more problems")
        code = e.exit_code
    except BrokenPipeError:
        # downstream closed the pipe (e.g. `| head`): not an error
        try:
            sys.stdout = open(os.devnull, "w")
        except OSError:
            pass
        code = 0
    except OSError as e:
        if debug:
            traceback.print_exc()
        if e.filename is None or e.errno is None:
            _err(f"internal error: {type(e).__name__}: {e} (run with --debug for the traceback; "
                 "please report it)")
            code = 1
        else:  # a path the user named that cannot be read or written
            _err(f"{e.filename}: {e.strerror}; check the path, its permissions and free space")
            code = 2
    except KeyboardInterrupt:
        _err("interrupted")
        code = 130
    except MemoryError:
        if debug:
            traceback.print_exc()
        _err("out of memory; analyse a shorter part of the log (--skip/--duration) or convert it "
             "to Parquet first with 'gyrotest ingest'")
        code = 1
    except Exception as e:  # internal error: a bug
        if debug:
            traceback.print_exc()
        _err(f"internal error: {type(e).__name__}: {e} (run with --debug for the traceback; "
             "please report it)")
        code = 1
    return code
