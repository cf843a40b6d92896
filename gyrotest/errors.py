"""Error types shared by the core and the CLI.

The core raises these; the CLI turns them into a one-line message on stderr and an exit code
(2 for bad input or usage, 1 for an internal error). Messages name the file, row or column and
the fix, e.g. ``"log.csv: column 'rate' not found (columns: t, gx); use --rate-col NAME"``.
"""

from __future__ import annotations


class GyrotestError(Exception):
    """Base class for errors that gyrotest reports to the user without a traceback."""

    exit_code = 1


class InputError(GyrotestError):
    """Bad input data, file, option or configuration: the user can fix it. Exit code 2."""

    exit_code = 2

    def __init__(self, message: str, *, source: str | None = None):
        self.source = source
        super().__init__(f"{source}: {message}" if source else message)


class AnalysisError(InputError):
    """The data cannot support the requested analysis (too short, constant, no negative
    rates for asymmetry, ...). Exit code 2, because the fix is in the data or the options."""
