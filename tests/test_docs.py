"""The README, the man page, the CHANGELOG and CI stay in step with the code."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

from gyrotest import __version__
from gyrotest.cli import COMMANDS

from cliutil import run_cli

ROOT = Path(__file__).resolve().parents[1]


def _first_screen_commands() -> list[str]:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    first = text.split("\n---\n", 1)[0]  # the first screen ends at the first rule
    blocks = re.findall(r"```(?:sh|bash|console)?\n(.*?)```", first, flags=re.S)
    return [ln.strip() for b in blocks for ln in b.strip().splitlines() if ln.strip()]


def test_readme_first_screen_has_exactly_two_setup_commands():
    cmds = _first_screen_commands()
    assert len(cmds) == 2, cmds
    main, tests = cmds
    assert "pip install ." in main and "gyrotest report sample_data/campaign.toml" in main
    assert "'.[test]'" in tests and "pytest" in tests
    assert len((ROOT / "README.md").read_text(encoding="utf-8").split("\n---\n", 1)[0]
               .splitlines()) <= 40, "the set-up commands must be on the first screen"


def test_ci_runs_the_readme_test_command():
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    assert _first_screen_commands()[1] in ci


def test_man_page_in_step_with_cli():
    r = subprocess.run([sys.executable, str(ROOT / "man" / "make_man.py"), "--check"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr


def test_every_command_documented():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    man = (ROOT / "man" / "gyrotest.1").read_text(encoding="utf-8")
    for name in COMMANDS:
        assert f"gyrotest {name}" in readme, name
        assert f"gyrotest {name}".replace("-", "\\-") in man, name
        r = run_cli([name, "--help"])
        assert r.code == 0 and "Usage:" in r.out, (name, r.err)


def test_version_and_changelog():
    r = run_cli(["--version"])
    assert r.code == 0 and __version__ in r.out
    log = (ROOT / "CHANGELOG.md").read_text(encoding="utf-8")
    assert "## [Unreleased]" in log and "### Added" in log
