"""Generate man/gyrotest.1 from the click commands, so the man page and --help stay in step.

    python man/make_man.py            # rewrite man/gyrotest.1
    python man/make_man.py --check    # exit 1 if man/gyrotest.1 is out of date (used by the tests)
"""

from __future__ import annotations

import inspect
import sys
from pathlib import Path

import click

HERE = Path(__file__).resolve().parent
OUT = HERE / "gyrotest.1"

INTRO = """\
gyrotest reads gyro test-bench logs (pulse counts, analog voltage or rate, with thermocouples,
magnetometer or Helmholtz-coil currents, supply voltage and a rate table), strips earth rate and
gives the bias D_F, the scale factor, the thermal and magnetic sensitivities and the Allan noise
terms with honest uncertainties; it compares every model with the measurement, says where it
fails and which physical effect is missing, and writes an IEEE-952-style specification sheet.
"""

FILES = """\
A bench profile (TOML, --profile) names the columns and constants of one bench: sections
[columns] (time, rate|counts|up+down|counter|voltage, temperature, field, supply, table_rate,
position, extra), [units] (per-column units), [gyro] (scale_factor, offset_v, rate_unit,
counter_bits, sample_rate_hz, model, serial) and [site] (latitude_deg, ia or ia_azimuth_deg +
ia_elevation_deg). Command-line options override it key by key. A campaign file (TOML) lists the
tests of a campaign for gyrotest report; see sample_data/campaign.toml. Every file is checked
against its schema before use, one line per problem naming its key; no output is ever written
over an input. Any file argument may be a named pipe (FIFO), read to its end; with no data for
GYROTEST_FIFO_WAIT seconds (default 10) it is refused.
"""

UNITS = """\
Rates and bias in deg/h (1 deg/h = 1 arcsec/s); N in deg/sqrt(h); K in (deg/h)/sqrt(h); R in
(deg/h)/h; Q in arcsec; scale factor in arcsec/pulse or (deg/h)/V, errors in ppm; temperature in
degC, dT/dt in degC/h; magnetic field in uT, sensitivities per 100 uT; time in s (durations accept
40min, 2h, 90s).
"""


def esc(text: str) -> str:
    """Escape text for troff."""
    out = text.replace("\\", "\\e").replace("-", "\\-")
    lines = []
    for ln in out.splitlines():
        if ln.startswith((".", "'")):
            ln = "\\&" + ln
        lines.append(ln)
    return "\n".join(lines)


def _help_text(cmd: click.Command) -> str:
    text = inspect.cleandoc(cmd.help or "").replace("\b\n", "")
    return "\n".join(ln.rstrip() for ln in text.strip().splitlines())


def _options(cmd: click.Command, ctx: click.Context) -> list[tuple[str, str]]:
    rows = []
    for p in cmd.get_params(ctx):
        rec = p.get_help_record(ctx)
        if rec and rec[1]:
            rows.append(rec)
    return rows


def _section(name: str, cmd: click.Command, parent: click.Context, out: list[str]) -> None:
    ctx = click.Context(cmd, info_name=name, parent=parent)
    usage = " ".join(cmd.collect_usage_pieces(ctx))
    out.append(f".SS {esc(ctx.command_path)}")
    out.append(f".B {esc(ctx.command_path)}")
    out.append(esc(usage))
    out.append(".PP")
    body = _help_text(cmd)
    if body:
        out.append(".nf" if "\n    " in body or "\n  " in body else "")
        out.append(esc(body))
        out.append(".fi")
    for opt, help_ in _options(cmd, ctx):
        out.append(".TP")
        out.append(f".B {esc(opt)}")
        out.append(esc(help_))
    if isinstance(cmd, click.Group):
        for sub in cmd.list_commands(ctx):
            _section(sub, cmd.get_command(ctx, sub), ctx, out)


def render() -> str:
    from gyrotest import __version__
    from gyrotest.cli import cli

    root = click.Context(cli, info_name="gyrotest")
    out = [
        '.TH GYROTEST 1 "" "gyrotest ' + __version__ + '" "User Commands"',
        ".SH NAME",
        "gyrotest \\- gyro test\\-bench logs to an IEEE\\-952\\-style specification sheet",
        ".SH SYNOPSIS",
        ".B gyrotest",
        "[\\fIOPTIONS\\fR] \\fICOMMAND\\fR [\\fIARGS\\fR]...",
        ".SH DESCRIPTION",
        esc(INTRO),
        ".SH GLOBAL OPTIONS",
    ]
    for opt, help_ in _options(cli, root):
        out += [".TP", f".B {esc(opt)}", esc(help_)]
    out.append(".SH COMMANDS")
    for name in cli.list_commands(root):
        _section(name, cli.get_command(root, name), root, out)
    from gyrotest.envmodel.workbench_rules import RULES

    out.append(".SH WORKBENCH VERDICT RULES")
    out.append(esc("The decision rules of gyrotest model diagnose (also printed by its --rules "
                   "option), in the order they are applied."))
    for head, text in RULES:
        out += [".TP", f".B {esc(head)}", esc(text)]
    out += [
        ".SH FILES", esc(FILES),
        ".SH UNITS", esc(UNITS),
        ".SH EXIT STATUS",
        "0 success; 2 bad input or usage (one line on stderr naming the file, row or column and "
        "the fix); 1 internal error (\\-\\-debug shows the traceback).",
        ".SH EXAMPLES",
        ".nf",
        esc("gyrotest report sample_data/campaign.toml --pdf spec.pdf\n"
            "gyrotest allan sample_data/static.parquet --profile sample_data/static.profile.toml "
            "--skip 30min --plot allan.png\n"
            "gyrotest bias sample_data/bias_run1.parquet sample_data/bias_run2.parquet "
            "--profile sample_data/bias_run1.profile.toml --skip 30min --json\n"
            "gyrotest model diagnose sample_data/thermal.parquet "
            "--profile sample_data/thermal.profile.toml --terms T --candidates dTdt,Tlag,dGdt"),
        ".fi",
        ".SH SEE ALSO",
        "README.md and CHANGELOG.md in the gyrotest sources; IEEE Std 952\\-1997.",
    ]
    return "\n".join(ln for ln in out if ln != "") + "\n"


def main() -> int:
    text = render()
    if "--check" in sys.argv:
        if not OUT.exists() or OUT.read_text(encoding="utf-8") != text:
            print("man/gyrotest.1 is out of date: run python man/make_man.py", file=sys.stderr)
            return 1
        return 0
    OUT.write_text(text, encoding="utf-8")
    print(f"wrote {OUT}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
