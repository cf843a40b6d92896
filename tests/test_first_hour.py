"""A lab engineer's first hour (issue 61): the first command, the messages, the column names a
logger writes, the notes on a redirected stderr, the conveniences a lab expects."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from cliutil import run_cli

ROOT = Path(__file__).resolve().parents[1]
SAMPLE = ROOT / "sample_data"


def _rate_csv(path: Path, header: str, n: int = 3000, seed: int = 0) -> Path:
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 0.01
    x = 0.01 * rng.standard_normal(n)
    temp = 20 + 1e-3 * np.arange(n)
    np.savetxt(path, np.c_[t, x, temp], delimiter=",", header=f"time,{header},temp",
               comments="", fmt="%.6g")
    return path


# ----------------------------------------------------------------------------- columns (item 8)
@pytest.mark.parametrize("header,unit", [("Gyro Z (deg/s)", "deg/s"), ("gyro_rate_dps", "deg/s"),
                                         ("Gyro-Rate X [rad/s]", "rad/s"), ("rate_dps", "deg/s")])
def test_logger_column_names_are_found(tmp_path, header, unit):
    p = _rate_csv(tmp_path / "log.csv", header)
    r = run_cli(["info", p, "--json"])
    assert r.code == 0, r.err
    doc = json.loads(r.out)
    assert doc["columns"]["gyro_output"] == [header] and doc["gyro"]["rate_unit"] == unit
    r = run_cli(["columns", p])
    assert r.code == 0 and header in r.out and "rate" in r.out


def test_multiposition_notes_keep_the_position(tmp_path):
    r = run_cli(["bias", SAMPLE / "multipos.csv", "--profile", SAMPLE / "multipos.profile.toml",
                 "--settle", "30s", "-v"])
    assert r.code == 0, r.err
    lines = [ln for ln in r.err_lines if "noise term(s)" in ln]
    assert lines, r.err
    starts = {ln.split(":", 1)[0] for ln in lines}
    assert starts <= {f"{p} (multipos.csv)" for p in
                      ("up", "down", "north", "south", "east", "west")}, starts
    assert "up (multipos.csv)" in r.out and str(SAMPLE) not in r.out
