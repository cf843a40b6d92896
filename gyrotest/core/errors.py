"""Error types shared by the core, the Python API and the CLI.

The core and the API (:mod:`gyrotest`) raise these; the CLI turns them into a one-line message
on stderr and an exit code (2 for bad input or usage, 1 for an internal error). Messages name
the file, row or column and the fix, e.g. ``"log.csv: column 'rate' not found (columns: t,
gx); use --rate-col NAME"``.

Every error carries what it is about as attributes as well as in its text, so that a script
can act on it without parsing the message: ``file``, ``row`` (1-based data row), ``column``
and ``fix`` (what to change), each None when it does not apply.

Kinds (catch :class:`GyrotestError` for all of them):

* :class:`InputError` -- bad input data, file, option or configuration (exit code 2);
* :class:`OptionError` -- an option or keyword argument with a wrong value or type;
* :class:`AnalysisError` -- the data cannot support the requested analysis (too short,
  constant, no negative rates for asymmetry, ...).

A column that cannot be found or assigned a role is a
:class:`gyrotest.io.columns.RoleError`, also an :class:`InputError`.
"""

from __future__ import annotations


class GyrotestError(Exception):
    """Base class for errors that gyrotest reports to the user without a traceback.

    Parameters
    ----------
    message : str
        What is wrong, in one line.
    file : str, optional
        The file the error is about; the message is prefixed with it (``"log.csv: ..."``).
    row : int, optional
        1-based data row of the file.
    column : str, optional
        Column name.
    fix : str, optional
        What the user can change; appended to the message after ``"; "``.
    source : str, optional
        The older name of ``file``.

    Attributes
    ----------
    exit_code : int
        The command line's exit status for this error (1: internal, 2: input or usage).
    file, row, column, fix : str, int or None
        As given (None when they do not apply).
    """

    exit_code = 1

    def __init__(self, message: str = "", *, file: str | None = None, row: int | None = None,
                 column: str | None = None, fix: str | None = None,
                 source: str | None = None):
        file = file if file is not None else source
        self.file = file
        self.row = row
        self.column = column
        self.fix = fix
        text = f"{file}: {message}" if file else message
        if fix:
            text += f"; {fix}"
        super().__init__(text)

    @property
    def source(self) -> str | None:
        """The file the error is about (the same as :attr:`file`; older name)."""
        return self.file


class InputError(GyrotestError):
    """Bad input data, file, option or configuration: the user can fix it. Exit code 2."""

    exit_code = 2


class OptionError(InputError):
    """An option (a command-line option or a keyword argument of the Python API) has a value
    or type that gyrotest cannot use; the message names the option and the values it takes.
    Exit code 2."""


class AnalysisError(InputError):
    """The data cannot support the requested analysis (too short, constant, no negative
    rates for asymmetry, ...). Exit code 2, because the fix is in the data or the options."""
