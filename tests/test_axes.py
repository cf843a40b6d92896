"""Multi-axis logs: every analysis command analyses every gyro axis (or the ``--axis`` chosen)
and names it in its tables, headings and JSON.

Checked on a simulated 3-axis CSV with known per-axis biases and on the real ADIS16405 log in
``../shared/reference/data/realdata`` (skipped when absent) against numpy means of its columns.
"""

from __future__ import annotations

import gzip
import json
from pathlib import Path

import numpy as np
import pytest

from gyrotest.core.axes import choose_axes, parse_axis_option
from gyrotest.core.errors import InputError

from cliutil import run_cli

ADIS = (Path(__file__).parents[2] / "shared" / "reference" / "data" / "realdata" / "data"
        / "adis16405_imu1.csv.gz")

TRUE_BIAS = {"gx": 5.0, "gy": -3.0, "gz": 12.0}  # deg/h
WHITE = 2.0  # deg/h per sample (1σ)


@pytest.fixture(scope="module")
def xyz_csv(tmp_path_factory) -> Path:
    """A 3-axis static log, 10 Hz, 2 h, white rate noise around known biases (deg/h)."""
    rng = np.random.default_rng(1201)
    n = 72_000
    t = np.arange(n) * 0.1
    cols = {a: b + WHITE * rng.standard_normal(n) for a, b in TRUE_BIAS.items()}
    path = tmp_path_factory.mktemp("axes") / "xyz.csv"
    with open(path, "w") as fh:
        fh.write("t_s,gx,gy,gz\n")
        for i in range(n):
            fh.write(f"{t[i]:.1f},{cols['gx'][i]:.6f},{cols['gy'][i]:.6f},{cols['gz'][i]:.6f}\n")
    return path


BASE = ["--rate-unit", "deg/h", "--rate-col", "gx,gy,gz"]


def test_parse_axis_option():
    assert parse_axis_option(None) is None
    assert parse_axis_option(" ,") is None
    assert parse_axis_option("gx, gz") == ["gx", "gz"]
    assert parse_axis_option(["gy"]) == ["gy"]


def test_choose_axes_common_and_errors(xyz_csv):
    from gyrotest.io.ingest import read_log

    g = read_log(str(xyz_csv), overrides={"gyro": {"rate_unit": "deg/h"},
                                          "columns": {"rate": ["gx", "gy", "gz"]}})
    assert choose_axes([g], None) == ["gx", "gy", "gz"]
    assert choose_axes([g], "gz,gx") == ["gz", "gx"]
    with pytest.raises(InputError, match="no axis 'wz'; axes are gx, gy, gz"):
        choose_axes([g], "wz")


def test_bias_every_axis_by_default(xyz_csv):
    r = run_cli(["bias", xyz_csv, *BASE, "--json"])
    assert r.code == 0, r.err
    doc = json.loads(r.out)
    assert doc["axes"] == ["gx", "gy", "gz"]
    assert [d["axis"] for d in doc["per_axis"]] == ["gx", "gy", "gz"]
    # the top level stays the single-axis document of the first axis (old scripts)
    assert doc["axis"] == "gx" and [run["axis"] for run in doc["runs"]] == ["gx"]
    for d in doc["per_axis"]:
        run = d["runs"][0]
        assert run["axis"] == d["axis"]
        # white noise: σ of the mean ≈ 2/√72000 = 0.0075 deg/h; the estimate within 5σ
        assert run["bias_D_F_dph"] == pytest.approx(TRUE_BIAS[d["axis"]], abs=0.04)


def test_bias_single_axis_keeps_old_shape_and_earth_rate(xyz_csv):
    r = run_cli(["bias", xyz_csv, *BASE, "--axis", "gy", "--latitude", "45", "--ia", "up",
                 "--json"])
    assert r.code == 0, r.err
    doc = json.loads(r.out)
    assert set(doc) >= {"analysis", "runs", "repeatability", "multi_position", "units"}
    assert "per_axis" not in doc and doc["axes"] == ["gy"] and doc["axis"] == "gy"
    run = doc["runs"][0]
    assert run["axis"] == "gy"
    er = 15.041067 * np.sin(np.radians(45.0))  # Ω_E sin φ along an up IA, deg/h
    assert run["earth_rate_ia_dph"] == pytest.approx(er, rel=1e-6)
    assert run["bias_D_F_dph"] == pytest.approx(run["mean_output_dph"] - run["earth_rate_ia_dph"],
                                                abs=1e-9)


def test_bias_several_axes_do_not_remove_one_ia_earth_rate(xyz_csv):
    r = run_cli(["bias", xyz_csv, *BASE, "--latitude", "45", "--ia", "up", "--json"])
    assert r.code == 0, r.err
    doc = json.loads(r.out)
    assert all(run["earth_rate_ia_dph"] is None for d in doc["per_axis"] for run in d["runs"])
    assert any("earth rate is NOT removed" in n for n in doc["notes"])


def test_bias_multi_position_uses_one_named_axis(xyz_csv):
    r = run_cli(["bias", xyz_csv, xyz_csv, *BASE, "--positions", "up,down", "--latitude", "45",
                 "--json"])
    assert r.code == 0, r.err
    doc = json.loads(r.out)
    assert doc["axes"] == ["gx"] and "per_axis" not in doc
    assert doc["multi_position"] is not None
    assert any("multi-position test: analysing axis gx" in n for n in doc["notes"])
    r = run_cli(["bias", xyz_csv, xyz_csv, *BASE, "--positions", "up,down", "--latitude", "45",
                 "--axis", "gz", "--json"])
    doc = json.loads(r.out)
    assert doc["axes"] == ["gz"] and not doc["notes"]
    assert {run["axis"] for run in doc["runs"]} == {"gz"}


def test_bias_table_and_plots_name_each_axis(xyz_csv, tmp_path):
    plot = tmp_path / "b.png"
    r = run_cli(["bias", xyz_csv, *BASE, "--axis", "gx,gz", "--plot", plot])
    assert r.code == 0, r.err
    assert "axis gx" in r.out and "axis gz" in r.out and "axis gy" not in r.out
    assert (tmp_path / "b_gx.png").stat().st_size > 10_000
    assert (tmp_path / "b_gz.png").exists() and not plot.exists()


def test_bias_unknown_axis_is_a_clean_error(xyz_csv):
    run_cli(["bias", xyz_csv, *BASE, "--axis", "wz"]).assert_clean_error(
        "xyz.csv", "no axis 'wz'", "gx, gy, gz")


def test_info_lists_and_filters_axes(xyz_csv):
    r = run_cli(["info", xyz_csv, *BASE, "--json"])
    assert r.code == 0, r.err
    doc = json.loads(r.out)
    assert doc["axes"] == ["gx", "gy", "gz"]
    r = run_cli(["info", xyz_csv, *BASE, "--axis", "gz", "--json"])
    doc = json.loads(r.out)
    assert doc["axes"] == ["gz"]
    assert [k for k in doc["channels"] if k.startswith("rate:")] == ["rate:gz"]
    assert doc["channels"]["rate:gz"]["mean"] == pytest.approx(TRUE_BIAS["gz"], abs=0.04)
    r = run_cli(["info", xyz_csv, *BASE])
    assert "gyro axes      gx, gy, gz" in r.out
    run_cli(["info", xyz_csv, *BASE, "--axis", "q"]).assert_clean_error("no axis 'q'")


def test_allan_every_axis_named(xyz_csv):
    r = run_cli(["allan", xyz_csv, *BASE, "--json", "--terms", "N", "--no-diagnose"])
    assert r.code == 0, r.err
    axes = json.loads(r.out)["logs"][0]["axes"]
    assert [a["axis"] for a in axes] == ["gx", "gy", "gz"]


# ----------------------------------------------------------------------------- real ADIS log
@pytest.fixture(scope="module")
def adis_csv(tmp_path_factory) -> Path:
    if not ADIS.exists():
        pytest.skip(f"real ADIS16405 log not found at {ADIS} (../shared beside the repo)")
    path = tmp_path_factory.mktemp("adis") / "adis16405.csv"
    with gzip.open(ADIS, "rt") as src, open(path, "w") as dst:
        for i, line in enumerate(src):
            if i > 60_000:  # 10 min at 100 Hz
                break
            dst.write(line)
    return path


def test_adis_bias_every_axis_against_numpy(adis_csv):
    r = run_cli(["bias", adis_csv, "--json"])
    assert r.code == 0, r.err
    doc = json.loads(r.out)
    names = ["gyro_x_dps", "gyro_y_dps", "gyro_z_dps"]
    assert doc["axes"] == names
    data = np.loadtxt(adis_csv, delimiter=",", skiprows=1)
    for k, d in enumerate(doc["per_axis"]):
        assert d["axis"] == names[k]
        mean_dph = data[:, k + 1].mean() * 3600.0  # deg/s column → deg/h
        assert d["runs"][0]["bias_D_F_dph"] == pytest.approx(mean_dph, rel=1e-9)
    # the Z axis (down, ≈ −1 g) differs from X: three different answers, not one copied
    biases = [d["runs"][0]["bias_D_F_dph"] for d in doc["per_axis"]]
    assert len({round(b, 3) for b in biases}) == 3


def test_adis_allan_and_info_name_every_axis(adis_csv):
    r = run_cli(["info", adis_csv])
    assert r.code == 0, r.err
    assert "gyro axes      gyro_x_dps, gyro_y_dps, gyro_z_dps" in r.out
    r = run_cli(["allan", adis_csv, "--terms", "N,B", "--no-diagnose", "--taus", "octave"])
    assert r.code == 0, r.err
    for a in ("gyro_x_dps", "gyro_y_dps", "gyro_z_dps"):
        assert f"axis {a}" in r.out


# ----------------------------------------------------------------------------- report
def test_report_tables_every_axis_and_numbers_match_the_commands(xyz_csv, tmp_path):
    import os
    import shutil

    from test_report import dig, numbers

    shutil.copy(xyz_csv, tmp_path / "xyz.csv")
    (tmp_path / "xyz.profile.toml").write_text(
        '[columns]\ntime = "t_s"\nrate = ["gx", "gy", "gz"]\n[gyro]\nrate_unit = "deg/h"\n')
    camp = tmp_path / "camp.toml"
    camp.write_text('[campaign]\noperator = "T"\ndate = "2024-01-01"\n'
                    '[gyro]\nmodel = "M"\nserial = "1"\nnominal_scale_factor = 1\n'
                    'scale_factor_unit = "1"\n[site]\nlatitude_deg = 48.137\n'
                    '[tests.bias]\nlogs = ["xyz.csv"]\nprofile = "xyz.profile.toml"\n'
                    'skip = "5min"\n[tests.allan]\nlog = "xyz.csv"\n'
                    'profile = "xyz.profile.toml"\nterms = "N,B,K"\n', encoding="utf-8")
    md = tmp_path / "sheet.md"
    r = run_cli(["-q", "report", camp, "--json", "--md", md])
    assert r.code == 0, r.err
    sheet = json.loads(r.out)
    text = md.read_text(encoding="utf-8")
    assert "Bias items (axis gx of gx, gy, gz)" in text
    assert "Allan-variance coefficients of every gyro axis" in text
    for a in ("gx", "gy", "gz"):
        assert f"| {a} | xyz.csv |" in text
    # every number of the sheet is the one `gyrotest bias/allan --json` prints ("—" cells,
    # value None, carry no number to compare)
    cmds = {c["key"]: c["argv"] for c in sheet["provenance"]["commands"]}
    old = os.getcwd()
    os.chdir(tmp_path)
    try:
        outputs = {k: json.loads(run_cli([*argv[1:], "--json"]).out) for k, argv in cmds.items()}
    finally:
        os.chdir(old)
    checked = set()
    for n in numbers(sheet):
        if n["value"] is None:
            continue
        src = n["source"]
        assert dig(outputs[src["analysis"]], src["path"]) == n["value"], src
        checked.add(src["analysis"])
    assert {"bias", "allan"} <= checked
    paths = [n["source"]["path"] for n in numbers(sheet) if n.get("source")]
    assert ["per_axis", 2, "runs", 0, "bias_D_F_dph"] in paths
    assert any(p[:4] == ["logs", 0, "axes", 2] for p in paths)
    by_path = {tuple(n["source"]["path"]): n["value"] for n in numbers(sheet) if n.get("source")}
    for i, a in enumerate(("gx", "gy", "gz")):
        assert by_path[("per_axis", i, "runs", 0, "bias_D_F_dph")] == pytest.approx(
            TRUE_BIAS[a], abs=0.05)
