"""``gyrotest simulate`` command line."""

from __future__ import annotations

import json
from pathlib import Path

from cliutil import run_cli

ROOT = Path(__file__).resolve().parents[1]
SCEN = ROOT / "sample_data" / "scenarios"


def test_simulate_writes_log_truth_profile(tmp_path):
    out = tmp_path / "c.csv"
    r = run_cli(["simulate", SCEN / "counter16.toml", "-o", out, "--seed", "5"])
    assert r.code == 0, r.err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.csv", "c.profile.toml",
                                                          "c.truth.json"]
    assert "c.truth.json" in r.out
    truth = json.loads((tmp_path / "c.truth.json").read_text())
    assert truth["seed"] == 5 and truth["output"]["kind"] == "counter"
    # the written profile lets the other commands read the log
    r2 = run_cli(["info", out, "--profile", tmp_path / "c.profile.toml", "--json"])
    assert r2.code == 0, r2.err
    assert json.loads(r2.out)["timing"]["samples"] == truth["samples"]


def test_simulate_json_and_format_option(tmp_path):
    r = run_cli(["simulate", SCEN / "six_position.toml", "-o", tmp_path / "s", "--format",
                 "feather", "--json"])
    assert r.code == 0, r.err
    doc = json.loads(r.out)
    assert doc["files"]["logs"] == [str(tmp_path / "s.feather")]
    assert doc["truth"]["earth"]["positions"][0]["label"] == "up"
    assert doc["seed"] == 5  # from the scenario
    assert (tmp_path / "s.feather").exists()


def test_simulate_same_seed_same_file(tmp_path):
    for name in ("a.csv", "b.csv"):
        assert run_cli(["simulate", SCEN / "counter16.toml", "-o", tmp_path / name,
                        "--seed", "9"]).code == 0
    assert (tmp_path / "a.csv").read_bytes() == (tmp_path / "b.csv").read_bytes()


def test_simulate_errors(tmp_path):
    run_cli(["simulate", tmp_path / "none.toml", "-o", tmp_path / "x.csv"]).assert_clean_error(
        "none.toml", "not found")
    bad = tmp_path / "bad.toml"
    bad.write_text('[gyro]\noutput = "counts"\n[record]\nduration_s = 10\n')
    run_cli(["simulate", bad, "-o", tmp_path / "x.csv"]).assert_clean_error("scale_factor")
    run_cli(["simulate", SCEN / "counter16.toml", "-o",
             tmp_path / "nodir" / "x.csv"]).assert_clean_error("does not exist")
    run_cli(["simulate", SCEN / "counter16.toml", "-o", tmp_path / "x.csv", "--seed",
             "-1"]).assert_clean_error("seed")
    assert not any(p.suffix == ".tmp" for p in tmp_path.iterdir())
