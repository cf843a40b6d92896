"""Which command-line parameters name files the command reads and which it writes.

:func:`guard_commands` wraps every command (``LazyGroup`` does it once per command object):
before the command's own code runs, a :func:`gyrotest.core.guard.io_guard` is opened, every input
parameter is declared, then every output parameter (and the files written beside an output,
:data:`BESIDE`), so that ``gyrotest allan in.csv --csv in.csv`` stops with one line before any
file is read or anything is computed. The tables here are the only per-command knowledge; a
test checks that every parameter of every command that names a file is in them.
"""

from __future__ import annotations

import functools
import os
import weakref
from collections.abc import Callable, Iterable

import click

from ..core.errors import InputError

#: parameter name -> what the file is (inputs)
INPUTS: dict[str, str] = {
    "log": "the log",
    "logs": "the log",
    "reference": "the reference log",
    "profile": "the profile",
    "model_path": "the model file",
    "setpoints": "the set-point table",
    "table_path": "the plateau table",
    "scenario": "the scenario",
    "campaign": "the campaign file",
    "campaigns": "the campaign file",
    "input": "the input file",
    "thermal_path": "the drift model file",
    "sf_path": "the scale-factor JSON",
    "model_file": "the model file",
    "sf_json": "the scale-factor JSON",
}
#: parameter name -> what the file is (outputs)
OUTPUTS: dict[str, str] = {
    "output": "the output file",
    "csv_path": "the --csv table",
    "psd_path": "the --psd figure",
    "plot_path": "the --plot figure",
    "points_path": "the --points table",
    "pdf_path": "the --pdf file",
    "html_path": "the --html file",
    "md_path": "the --md file",
}
#: (command path, parameter) whose meaning differs from the tables above
SPECIAL: dict[tuple[str, str], tuple[str, str]] = {
    ("model history", "path"): ("in", "the model history"),
    ("model fit", "session"): ("dir", "the --session directory"),
    # reads the logs in DIR, writes DIR/campaign.toml only when there is none
    ("report", "init_dir"): ("dir", "the --init directory"),
}
#: commands whose log may be replaced by their output with --force (a converted or
#: compensated version of the same log is something a user may mean)
REPLACEABLE_LOG = {"ingest", "compensate"}


def _model_history(params: dict) -> Iterable[tuple[str, str]]:
    out = params.get("output")
    if out and not params.get("no_history") and not params.get("session"):
        from ..envmodel.history import history_path_for

        yield str(history_path_for(out)), "the model history written beside the model"


#: command path -> files written beside the named outputs, known before any work
BESIDE: dict[str, Callable[[dict], Iterable[tuple[str, str]]]] = {
    "model fit": _model_history,
}


def _declare(cmd_path: str, params: dict) -> None:
    from ..core.guard import declare_input, declare_output

    outputs = []
    for name, value in params.items():
        if value is None or value == () or value is False:
            continue
        role, what = SPECIAL.get((cmd_path, name), (None, None))
        if role is None:
            if name in INPUTS:
                role, what = "in", INPUTS[name]
            elif name in OUTPUTS:
                role, what = "out", OUTPUTS[name]
            else:
                continue
        if role == "in":
            for v in (value if isinstance(value, (tuple, list)) else (value,)):
                declare_input(str(v), what, replaceable=(cmd_path in REPLACEABLE_LOG
                                                         and name == "log"))
        elif role == "out":
            outputs.append((str(value), what))
    for i, (path, what) in enumerate(outputs):  # two options naming one file
        for other, other_what in outputs[:i]:
            if os.path.realpath(path) == os.path.realpath(other):
                raise InputError(f"{path}: named both as {other_what} and as {what}; give each "
                                 "output its own file name")
    if cmd_path in BESIDE:
        outputs += list(BESIDE[cmd_path](params))
    for path, what in outputs:
        declare_output(path, what)


def _guarded(cmd_path: str, callback: Callable) -> Callable:
    @functools.wraps(callback)
    def run(*args, **kwargs):
        from ..core.guard import io_guard

        with io_guard(force=bool(kwargs.get("force"))):
            _declare(cmd_path, kwargs)
            return callback(*args, **kwargs)

    return run


#: the commands whose callbacks are wrapped already
_GUARDED: weakref.WeakSet[click.Command] = weakref.WeakSet()


def guard_commands(cmd: click.Command, path: str | None = None) -> click.Command:
    """Wrap the callbacks of ``cmd`` and of its sub-commands (once)."""
    path = path or cmd.name or ""
    if cmd in _GUARDED:
        return cmd
    if isinstance(cmd, click.Group):
        for name, sub in cmd.commands.items():
            guard_commands(sub, f"{path} {name}")
    elif cmd.callback is not None:
        cmd.callback = _guarded(path, cmd.callback)
    _GUARDED.add(cmd)
    return cmd


def path_parameters(cmd: click.Command, path: str | None = None):
    """(command path, parameter name) of every parameter of ``cmd`` and its sub-commands (for
    the test that keeps the tables complete)."""
    path = path or cmd.name or ""
    if isinstance(cmd, click.Group):
        for name, sub in cmd.commands.items():
            yield from path_parameters(sub, f"{path} {name}")
        return
    for p in cmd.params:
        yield path, p.name, p


def classify(path: str, name: str) -> str | None:
    """'in', 'out', 'dir' or None (not a file) for a parameter."""
    if (path, name) in SPECIAL:
        return SPECIAL[(path, name)][0]
    if name in INPUTS:
        return "in"
    if name in OUTPUTS:
        return "out"
    return None

