"""The stderr console every layer shares: notes, warnings and progress of the command line,
and the data warnings of a log read for a spec sheet (:func:`warn`). Rich is imported on first
use only (start-up time)."""

from __future__ import annotations

import sys

_err_console = None


def err_console():
    """Rich console on stderr for notes, warnings and progress."""
    global _err_console
    from rich.console import Console

    if _err_console is None or _err_console.file is not sys.stderr:
        _err_console = Console(file=sys.stderr, highlight=False, soft_wrap=True)
    return _err_console


def warn(msg: str) -> None:
    """A warning on stderr (always shown, also with --json: stdout stays clean)."""
    err_console().print(f"[yellow]warning:[/yellow] {escape_markup(msg)}")


def escape_markup(msg: str) -> str:
    """``msg`` with rich's markup characters escaped (a file name with ``[...]``)."""
    from rich.markup import escape

    return escape(msg)
