"""Every path a user is shown in an example (README, man-page generator, each command's
--help) exists in the repository, or is written by an earlier example; no placeholder logs."""

from __future__ import annotations

import re
from pathlib import Path

from gyrotest.cli import COMMANDS

from cliutil import run_cli

ROOT = Path(__file__).resolve().parents[1]
PLACEHOLDERS = ("run.csv", "bench.toml", "thermostat.csv", "chamber.csv", "helmholtz.csv")


def _examples() -> dict[str, str]:
    out = {"README.md": (ROOT / "README.md").read_text(encoding="utf-8"),
           "man/make_man.py": (ROOT / "man" / "make_man.py").read_text(encoding="utf-8")}
    for name in COMMANDS:
        r = run_cli([name, "--help"])
        assert r.code == 0, r.err
        out[f"gyrotest {name} --help"] = r.out
    return out


def test_example_paths_exist():
    for where, text in _examples().items():
        for path in set(re.findall(r"sample_data/[\w./-]+\.\w+", text)):
            path = path.rstrip(".")
            assert (ROOT / path).exists(), f"{where}: {path} does not exist"
        for ph in PLACEHOLDERS:
            hits = [m for m in re.finditer(r"(?<![\w/])" + re.escape(ph), text)]
            assert not hits, f"{where}: placeholder {ph} (use a file in sample_data/)"
