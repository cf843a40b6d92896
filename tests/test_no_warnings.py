"""No Python warning reaches the user's terminal: every command runs on the sample data with
warnings turned into errors (as ``python -W error -m gyrotest ...``), so a numpy/pandas/scipy/
matplotlib warning anywhere on these paths fails the test instead of leaking to stderr."""

from __future__ import annotations

import shutil
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

from cliutil import run_cli

ROOT = Path(__file__).resolve().parents[1]
S = ROOT / "sample_data"


def _commands(tmp: Path) -> list[list[str]]:
    st, stp = S / "static.parquet", S / "static.profile.toml"
    return [
        ["info", S / "multipos.csv", "--profile", S / "multipos.profile.toml"],
        ["info", st, "--profile", stp, "--json"],
        ["ingest", S / "multipos.csv", "--profile", S / "multipos.profile.toml",
         "-o", tmp / "mp.parquet"],
        ["info", tmp / "mp.parquet"],
        ["bias", st, S / "bias_run1.parquet", "--profile", stp, "--skip", "30min",
         "--plot", tmp / "bias.png"],
        ["bias", S / "multipos.csv", "--profile", S / "multipos.profile.toml", "--settle", "30s"],
        ["allan", st, "--profile", stp, "--skip", "30min", "--vehicle-rate", "10deg/s",
         "--plot", tmp / "allan.png", "--csv", tmp / "allan.csv"],
        ["allan", st, "--profile", stp, "--dev", "mdev", "--taus", "octave", "--json"],
        ["scale-factor", S / "ratetable_22a.parquet", S / "ratetable_22b.parquet",
         S / "ratetable_45.parquet", "--profile", S / "ratetable_22a.profile.toml",
         "--settle", "10s", "--plot", tmp / "sf.png"],
        ["thermal-fit", S / "thermal.parquet", "--profile", S / "thermal.profile.toml",
         "--t-ref", "21", "-o", tmp / "thermal.json"],
        ["mag-fit", S / "magnetic.parquet", "--profile", S / "magnetic.profile.toml",
         "--plot", tmp / "mag.png"],
        ["model", "fit", S / "thermal.parquet", "--profile", S / "thermal.profile.toml",
         "--terms", "T,dTdt", "-o", tmp / "model.json"],
        ["model", "diagnose", S / "thermal.parquet", "--profile", S / "thermal.profile.toml",
         "--terms", "T"],
        ["model", "history", tmp / "model.json"],
        ["compensate", S / "thermal.parquet", "--profile", S / "thermal.profile.toml",
         "--model", tmp / "model.json", "-o", tmp / "comp.parquet"],
        ["simulate", S / "scenarios" / "fog_static.toml", "-o", tmp / "fog.csv", "--seed", "1"],
        ["report", S / "campaign.toml", "--md", tmp / "spec.md", "--html", tmp / "spec.html"],
    ]


def test_every_command_without_warnings(tmp_path, monkeypatch):
    """In-process: warnings are errors; gyrotest's own warning routing steps aside because
    PYTHONWARNINGS is set (as it does for ``python -W``)."""
    monkeypatch.setenv("PYTHONWARNINGS", "error")
    monkeypatch.setenv("MPLBACKEND", "Agg")
    failures = []
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for args in _commands(tmp_path):
            r = run_cli(args)
            if r.code != 0 or "Warning" in r.err:
                failures.append(f"{' '.join(map(str, args[:2]))}: exit {r.code}: {r.err[-400:]}")
    assert not failures, "\n".join(failures)


@pytest.mark.skipif(shutil.which("true") is None, reason="no POSIX tools")
def test_python_W_error_subprocess(tmp_path):
    """The literal form: ``python -W error -m gyrotest`` on one reading and one analysis."""
    for args in (["info", S / "multipos.csv", "--profile", S / "multipos.profile.toml"],
                 ["allan", S / "static.parquet", "--profile", S / "static.profile.toml",
                  "--taus", "octave", "--json"]):
        p = subprocess.run([sys.executable, "-W", "error", "-m", "gyrotest", *map(str, args)],
                           capture_output=True, text=True, cwd=ROOT, timeout=300,
                           env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin",
                                "MPLBACKEND": "Agg"})
        assert p.returncode == 0, p.stderr
        assert "Warning" not in p.stderr, p.stderr
