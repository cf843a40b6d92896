"""No command ever writes over one of its inputs (issue 62, item 0).

Every case names, as an output, a file the command reads (the log, the profile, the scenario,
a file of the campaign) directly, through a symbolic link or through a hard link: exit 2, one
line naming both, and every file byte for byte as before. ``--force`` replaces the log only
where that is meaningful (ingest, compensate). The tables of
:mod:`gyrotest.cli.io_roles` cover every parameter of every command that names a file.
"""

from __future__ import annotations

import hashlib
import os
import shutil
from pathlib import Path

import click
import pytest

from gyrotest.cli import COMMANDS, cli
from gyrotest.cli.io_roles import classify, path_parameters

from cliutil import run_cli

SAMPLE = Path(__file__).resolve().parents[1] / "sample_data"


def _snapshot(d: Path) -> dict[str, str]:
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(d.iterdir())
            if p.is_file() and not p.is_symlink()}


def _copy(d: Path, *names: str) -> None:
    for n in names:
        shutil.copy(SAMPLE / n, d / n)


@pytest.fixture
def bench(tmp_path):
    _copy(tmp_path, "static.parquet", "static.profile.toml", "thermal.parquet",
          "thermal.profile.toml", "magnetic.parquet", "magnetic.profile.toml",
          "ratetable_22a.parquet", "ratetable_22a.profile.toml", "thermostat.csv")
    shutil.copy(SAMPLE / "scenarios" / "fog_static.toml", tmp_path / "s.toml")
    (tmp_path / "model.json").write_text("{}")  # never read: the guard stops first
    return tmp_path


# (command line, the input named as output) — the table, first row, and more
CASES = [
    (["allan", "static.parquet", "--profile", "static.profile.toml", "--csv", "static.parquet"],
     "static.parquet"),
    (["allan", "static.parquet", "--profile", "static.profile.toml", "--plot",
      "static.profile.toml"], "static.profile.toml"),
    (["allan", "static.parquet", "--profile", "static.profile.toml", "--psd", "static.parquet"],
     "static.parquet"),
    (["scale-factor", "ratetable_22a.parquet", "--profile", "ratetable_22a.profile.toml",
      "--points", "ratetable_22a.parquet"], "ratetable_22a.parquet"),
    (["scale-factor", "--table", "thermostat.csv", "--points", "thermostat.csv"],
     "thermostat.csv"),
    (["model", "fit", "thermal.parquet", "--profile", "thermal.profile.toml", "--terms", "T",
      "-o", "thermal.profile.toml"], "thermal.profile.toml"),
    (["model", "fit", "thermal.parquet", "--profile", "thermal.profile.toml", "--terms", "T",
      "--plot", "thermal.parquet"], "thermal.parquet"),
    (["model", "diagnose", "thermal.parquet", "--profile", "thermal.profile.toml", "--terms",
      "T", "--plot", "thermal.profile.toml"], "thermal.profile.toml"),
    (["thermal-fit", "thermal.parquet", "--profile", "thermal.profile.toml", "-o",
      "thermal.profile.toml"], "thermal.profile.toml"),
    (["thermal-fit", "--setpoints", "thermostat.csv", "--plot", "thermostat.csv"],
     "thermostat.csv"),
    (["mag-fit", "magnetic.parquet", "--profile", "magnetic.profile.toml", "-o",
      "magnetic.profile.toml"], "magnetic.profile.toml"),
    (["compensate", "static.parquet", "--profile", "static.profile.toml", "--model",
      "model.json", "-o", "static.parquet"], "static.parquet"),
    (["compensate", "static.parquet", "--profile", "static.profile.toml", "--model",
      "model.json", "--plot", "model.json"], "model.json"),
    (["ingest", "static.parquet", "--profile", "static.profile.toml", "-o", "static.parquet"],
     "static.parquet"),
    (["bias", "static.parquet", "--profile", "static.profile.toml"], None),
    (["simulate", "s.toml", "-o", "s.toml"], "s.toml"),
    (["export", "stable32", "static.parquet", "--profile", "static.profile.toml", "-o",
      "static.profile.toml"], "static.profile.toml"),
]


@pytest.mark.parametrize("args,victim", [c for c in CASES if c[1]],
                         ids=lambda v: " ".join(v[:2]) if isinstance(v, list) else str(v))
@pytest.mark.parametrize("how", ["same", "symlink", "hardlink"])
def test_output_over_an_input_is_refused(bench, monkeypatch, args, victim, how):
    monkeypatch.chdir(bench)
    args = list(args)
    i = len(args) - 1 - args[::-1].index(victim)  # the output option's value
    if how == "symlink":
        os.symlink(victim, bench / ("link_" + victim))
        args[i] = "link_" + victim
    elif how == "hardlink":
        os.link(victim, bench / ("hard_" + victim))
        args[i] = "hard_" + victim
    before = _snapshot(bench)
    r = run_cli(args)
    r.assert_clean_error("refusing to write", victim, "name another output file")
    assert _snapshot(bench) == before


def test_force_replaces_the_log_where_meaningful(bench, monkeypatch):
    monkeypatch.chdir(bench)
    before = _snapshot(bench)
    r = run_cli(["ingest", "static.parquet", "--profile", "static.profile.toml", "-o",
                 "static.parquet"])
    r.assert_clean_error("--force")
    assert _snapshot(bench) == before
    r = run_cli(["ingest", "static.parquet", "--profile", "static.profile.toml", "-o",
                 "static.parquet", "--force"])
    assert r.code == 0, r.err
    assert run_cli(["info", "static.parquet"]).code == 0  # a gyrotest Parquet, metadata inside
    # --force never lets a model or a profile go: compensate's -o must be a log anyway, and
    # a plot over the profile stays refused
    r = run_cli(["compensate", "static.parquet", "--model", "model.json", "--plot",
                 "static.profile.toml", "--profile", "static.profile.toml", "--force"])
    r.assert_clean_error("refusing to write", "static.profile.toml")


def test_simulate_keeps_a_foreign_profile_beside_the_output(bench, monkeypatch):
    monkeypatch.chdir(bench)
    mine = '[gyro]\nrate_unit = "deg/h"   # my own bench profile\n'
    (bench / "s.profile.toml").write_text(mine)
    r = run_cli(["simulate", "s.toml", "-o", "s.csv"])
    r.assert_clean_error("s.profile.toml", "not written by 'gyrotest simulate'", "--force")
    assert (bench / "s.profile.toml").read_text() == mine
    assert not (bench / "s.csv").exists() and not (bench / "s.truth.json").exists()
    # a scenario named like the profile simulate writes beside the log: never replaced
    shutil.copy(bench / "s.toml", bench / "t.profile.toml")
    r = run_cli(["simulate", "t.profile.toml", "-o", "t.csv", "--force"])
    r.assert_clean_error("refusing to write", "t.profile.toml")


def test_simulate_replaces_its_own_files(bench, monkeypatch):
    monkeypatch.chdir(bench)
    small = bench / "small.toml"
    small.write_text('[record]\nsample_rate_hz = 10.0\nduration_s = "60s"\n'
                     '[gyro]\noutput = "rate"\n[gyro.noise]\nN = 0.01\n')
    for seed in ("1", "2"):  # a re-run replaces the truth and profile it wrote
        r = run_cli(["simulate", "small.toml", "-o", "small.csv", "--seed", seed])
        assert r.code == 0, r.err
    assert '"seed": 2' in (bench / "small.truth.json").read_text()


def test_report_output_over_a_file_of_the_campaign(bench, monkeypatch):
    monkeypatch.chdir(bench)
    shutil.copy(bench / "static.profile.toml", bench / "bench.md")  # a profile, any name
    camp = ('[campaign]\ntitle = "T"\noperator = "A"\ndate = 2024-05-12\n'
            '[gyro]\nmodel = "M"\nserial = "1"\n'
            '[tests.bias]\nlogs = ["static.parquet"]\nprofile = "bench.md"\n')
    (bench / "c.toml").write_text(camp)
    (bench / "c.html").write_text(camp)
    before = _snapshot(bench)
    for args, victim in ((["c.toml", "--md", "bench.md"], "bench.md"),
                         (["c.html", "--html", "c.html"], "c.html")):
        r = run_cli(["report", *args])
        r.assert_clean_error("refusing to write", victim)
        r = run_cli(["fleet", *args])
        r.assert_clean_error("refusing to write", victim)
    assert _snapshot(bench) == before


def test_two_outputs_one_file(bench, monkeypatch):
    monkeypatch.chdir(bench)
    r = run_cli(["allan", "static.parquet", "--profile", "static.profile.toml", "--plot",
                 "a.png", "--psd", "a.png"])
    r.assert_clean_error("a.png", "named both")


def _all_commands():
    ctx = click.Context(cli)
    for name in COMMANDS:
        cmd = cli.get_command(ctx, name)
        if cmd is not None:
            yield from path_parameters(cmd, name)


FILE_HINTS = ("path", "log", "file", "output", "profile", "model", "campaign", "scenario",
              "setpoints", "reference", "input", "session", "json")


def test_every_file_parameter_has_a_role():
    """A new file option must be put in gyrotest.cli.io_roles (or the guard would not see it)."""
    missing = []
    for path, name, param in _all_commands():
        looks_like_file = isinstance(param.type, click.Path) or any(
            h in name for h in FILE_HINTS) or (param.metavar or "") in ("FILE", "LOG")
        if looks_like_file and classify(path, name) is None and name not in (
                "as_json", "output_kind", "no_history", "force", "path_steps"):
            missing.append(f"{path}: {name}")
    assert not missing, missing
