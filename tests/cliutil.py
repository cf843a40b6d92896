"""Run the gyrotest CLI in-process and capture exit code, stdout and stderr.

Usage in tests (the tests directory is on sys.path)::

    from cliutil import run_cli
    r = run_cli(["info", str(path), "--json"])
    assert r.code == 0, r.err
"""

from __future__ import annotations

import io
import sys
from dataclasses import dataclass

from gyrotest.cli import main


@dataclass
class CliResult:
    code: int
    out: str
    err: str

    @property
    def err_lines(self) -> list[str]:
        return [ln for ln in self.err.splitlines() if ln.strip()]

    def assert_clean_error(self, *fragments: str) -> None:
        """Exit 2, one 'gyrotest: error:' line on stderr mentioning every fragment, no traceback."""
        assert self.code == 2, f"exit {self.code}; stderr: {self.err}"
        errs = [ln for ln in self.err_lines if ln.startswith("gyrotest: error:")]
        assert len(errs) == 1, self.err
        assert "Traceback" not in self.err, self.err
        for f in fragments:
            assert f.lower() in errs[0].lower(), f"{f!r} not in {errs[0]!r}"


def run_cli(args: list[str], stdin: bytes | str | None = None) -> CliResult:
    out, err = io.StringIO(), io.StringIO()
    old = sys.stdin, sys.stdout, sys.stderr
    if stdin is not None:
        data = stdin.encode() if isinstance(stdin, str) else stdin
        sys.stdin = io.TextIOWrapper(io.BytesIO(data), encoding="utf-8")
    sys.stdout, sys.stderr = out, err
    try:
        try:
            main([str(a) for a in args])
            code = 0
        except SystemExit as e:
            code = e.code if isinstance(e.code, int) else (0 if e.code is None else 1)
    finally:
        sys.stdin, sys.stdout, sys.stderr = old
    return CliResult(code, out.getvalue(), err.getvalue())
