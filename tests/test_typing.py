"""The package passes its type check (mypy, configured in pyproject.toml ``[tool.mypy]``;
docs/architecture.md says what it checks and what is not on yet)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_mypy_is_clean():
    run = subprocess.run(
        [sys.executable, "-m", "mypy", "--config-file", str(ROOT / "pyproject.toml"),
         "--cache-dir", str(ROOT / ".mypy_cache"), "--no-error-summary", "gyrotest"],
        capture_output=True, text=True, cwd=ROOT, timeout=600)
    errors = [ln for ln in run.stdout.splitlines() if ": error:" in ln]
    assert run.returncode == 0 and not errors, run.stdout + run.stderr
