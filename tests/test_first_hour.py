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


# ----------------------------------------------------------------------------- first command (9)
def test_bare_gyrotest_prints_the_help():
    r = run_cli([])
    assert r.code == 0 and r.err == ""
    assert r.out == run_cli(["--help"]).out
    assert len(r.out.splitlines()) > 20  # the normal help, not one squashed line


@pytest.mark.parametrize("typo,meant", [("bais", "bias"), ("alan", "allan"),
                                        ("thermal-fitt", "thermal-fit")])
def test_a_mistyped_command_gets_did_you_mean(typo, meant):
    r = run_cli([typo, "x.csv"])
    r.assert_clean_error(f"no such command '{typo}'", f"did you mean '{meant}'")


def test_readme_says_how_to_call_gyrotest_after_the_setup():
    first = (ROOT / "README.md").read_text(encoding="utf-8").split("\n---\n", 1)[0]
    assert ". .venv/bin/activate" in first or "source .venv/bin/activate" in first


# ----------------------------------------------------------------------------- notes (item 6)
def test_notes_reach_a_redirected_stderr_only_with_v(tmp_path):
    p = _rate_csv(tmp_path / "log.csv", "rate_dps")
    quiet = run_cli(["bias", p])  # stderr is not a terminal here: warnings and errors only
    assert quiet.code == 0 and "auto-detected" not in quiet.err
    loud = run_cli(["bias", p, "-v"])
    assert loud.code == 0 and "auto-detected" in loud.err
    assert quiet.out == loud.out
    bad = run_cli(["bias", p, "--axis", "nope"])  # the error alone, on one line
    assert bad.code == 2 and len(bad.err_lines) == 1, bad.err


# ----------------------------------------------------------------------------- messages (10)
def test_too_short_for_a_tau_names_the_file_and_the_option(tmp_path):
    p = _rate_csv(tmp_path / "short.csv", "rate_dps", n=2000)
    for dev in ("oadev", "theo1"):
        r = run_cli(["allan", p, "--taus", "1,10,100000", "--dev", dev])
        r.assert_clean_error("short.csv", "τ = 100000 s", "--taus")
        assert "--tau-max" not in r.err


def test_a_constant_log_prints_a_plain_number(tmp_path):
    p = tmp_path / "const.csv"
    p.write_text("time,rate_dph\n" + "".join(f"{i * 0.1:.1f},5.0\n" for i in range(3000)))
    for cmd in ("allan", "bias"):
        r = run_cli([cmd, p])
        r.assert_clean_error("const.csv", "constant (5 deg/h)")
        assert "np." not in r.err


def test_east_and_west_sense_no_earth_rate():
    from gyrotest.core.earth import OMEGA_E_DPH, earth_rate_component, ia_unit_vector

    for az in (90.0, 270.0, -90.0):
        assert earth_rate_component(48.137, az, 0.0) == 0.0
    assert ia_unit_vector(90.0, 0.0)[0] == 0.0 and ia_unit_vector(0.0, 90.0)[:2].tolist() == [0, 0]
    assert earth_rate_component(48.137, 0.0, 90.0) == pytest.approx(OMEGA_E_DPH * np.sin(
        np.radians(48.137)), rel=1e-12)


def test_simulate_prints_no_rounding_noise(tmp_path):
    r = run_cli(["simulate", SAMPLE / "scenarios" / "hidden_none.toml", "-o", tmp_path / "s.csv"])
    assert r.code == 0, r.err
    assert "e-1" not in r.out and "earth 0 deg/h" in r.out


def test_rate_unit_is_checked_and_an_unused_one_is_said(tmp_path):
    log = [SAMPLE / "multipos.csv", "--profile", SAMPLE / "multipos.profile.toml"]
    run_cli(["info", *log, "--rate-unit", "furlongs"]).assert_clean_error(
        "--rate-unit", "furlongs", "deg/h")
    r = run_cli(["info", *log, "--rate-unit", "deg/s"])
    assert r.code == 0 and "--rate-unit deg/s not used" in r.err and "counts" in r.err


def test_one_name_for_the_reference_temperature_and_the_field_columns():
    from gyrotest.cli.cmd_thermal_fit import command as thermal
    from gyrotest.cli.common import ingest_overrides

    names = {o for p in thermal.params if not getattr(p, "hidden", False) for o in p.opts}
    assert "--t-ref" in names and "--t0" not in names and "--field-col" in names
    assert "--field-cols" not in names
    # the old spellings still work (hidden); the new ones accept lists like --rate-col
    a = run_cli(["thermal-fit", "--setpoints", SAMPLE / "thermostat.csv", "--t-ref", "21", "--json"])
    b = run_cli(["thermal-fit", "--setpoints", SAMPLE / "thermostat.csv", "--t0", "21", "--json"])
    assert a.code == b.code == 0 and a.out == b.out
    ov = ingest_overrides({"temp_col": ("A,B", "C"), "field_cols": ("X,Y", "Z")})
    assert ov["columns"]["temperature"] == ["A", "B", "C"]
    assert ov["columns"]["field"] == ["X", "Y", "Z"]
    ov = ingest_overrides({"field_cols_alias": "X,Y,Z"})
    assert ov["columns"]["field"] == ["X", "Y", "Z"]


def test_durations_show_their_unit_in_help():
    for cmd in (["bias"], ["allan"], ["model", "fit"], ["thermal-fit"], ["export", "stable32"]):
        out = " ".join(run_cli([*cmd, "--help"]).out.split())
        assert "[default: 0]" not in out and "[default: 0s]" in out, cmd


def test_plots_of_several_figures_say_where_each_goes(tmp_path):
    out = run_cli(["thermal-fit", "--help"]).out
    assert "FILE-NAME.png" in " ".join(out.split())
    png = tmp_path / "th.png"
    r = run_cli(["thermal-fit", SAMPLE / "thermal.parquet", "--profile",
                 SAMPLE / "thermal.profile.toml", "--plot", png, "-v"])
    assert r.code == 0, r.err
    written = [ln for ln in r.err_lines if "written to" in ln]
    assert len(written) == 1 and written[0].startswith("plots written to ")
    files = sorted(p.name for p in tmp_path.iterdir())
    assert files and all(f in written[0] for f in files), (files, written)


def test_make_imu_files_lists_only_what_it_wrote(tmp_path):
    import subprocess
    import sys

    fake = tmp_path / "fake" / "rosbags"  # rosbags "not installed"
    fake.mkdir(parents=True)
    (fake / "__init__.py").write_text("raise ImportError('rosbags hidden by the test')\n")
    r = subprocess.run([sys.executable, SAMPLE / "make_imu_files.py", tmp_path / "imu",
                        "--minutes", "0.2"], capture_output=True, text=True,
                       env={"PYTHONPATH": str(fake.parent), "PATH": ""})
    assert r.returncode == 0, r.stderr
    assert "no bags written" in r.stdout and "imu.bag" not in r.stdout, r.stdout
    assert "imu.mat" in r.stdout and not (tmp_path / "imu" / "imu.bag").exists()


# ----------------------------------------------------------------------------- workbench hint (7)
def _cand(spec, replaces=None):
    from gyrotest.envmodel.selection import Candidate

    return Candidate(spec.label, "effect", spec, replaces=replaces)


def test_paste_hint_is_the_complete_model():
    """The verdict's hint is the whole model to paste: the base terms (custom ones with their
    expression), without those the new term replaces, plus the new term."""
    from gyrotest.envmodel.terms import TermSpec

    base = [TermSpec("bias"), TermSpec("T", ("T_case_C",)), TermSpec("dGdt", ("A", "B")),
            TermSpec("custom", (), "vib", "extra.vib_g**2")]
    new = TermSpec("hyst", ("T_case_C",))
    assert _cand(new).add_hint(base) == (
        "--terms 'T(T_case_C),dGdt(A,B),hyst(T_case_C)' --term 'vib:extra.vib_g**2'")
    lag = TermSpec("Tlag", ("T_case_C",))
    assert _cand(lag, replaces="T(T_case_C)").add_hint(base).startswith(
        "--terms 'dGdt(A,B),Tlag(T_case_C)' ")
    own = TermSpec("custom", (), "rh", "extra.RH_pct")
    assert _cand(own).add_hint(base[:2]) == "--terms 'T(T_case_C)' --term 'rh:extra.RH_pct'"
    assert _cand(own).add_hint(base[:1]) == "--term 'rh:extra.RH_pct'"


def test_pasting_the_workbench_hint_fits_the_model_it_judged(tmp_path):
    """The README's hidden-coil step: the options the verdict prints fit the model whose
    held-out RMS the verdict states (pasting only the new term dropped T(T_case_C))."""
    import re
    import shlex

    log = tmp_path / "coil.csv"
    assert run_cli(["simulate", SAMPLE / "scenarios" / "hidden_coil.toml", "-o", log,
                    "--seed", "1"]).code == 0
    prof = tmp_path / "coil.profile.toml"
    d = run_cli(["model", "diagnose", log, "--profile", prof, "--terms", "T(T_case_C)",
                 "--path", "1", "--json"])
    assert d.code == 0, d.err
    verdict = json.loads(d.out)["verdict"]
    m = re.search(r"add it with (--terms '[^']*')", verdict)
    assert m, verdict
    held = float(re.search(r"→ ([0-9.]+) deg/h", verdict).group(1))
    f = run_cli(["model", "fit", log, "--profile", prof, *shlex.split(m.group(1)), "--json"])
    assert f.code == 0, f.err
    assert json.loads(f.out)["rms_holdout_dph"] == pytest.approx(held, rel=2e-3)


# ----------------------------------------------------------------------------- thermal (item 5)
THERMAL = [SAMPLE / "thermal.parquet", "--profile", SAMPLE / "thermal.profile.toml"]


@pytest.fixture(scope="module")
def thermal_models(tmp_path_factory):
    d = tmp_path_factory.mktemp("thermal")
    am = d / "am.json"
    r = run_cli(["thermal-fit", *THERMAL, "--t-ref", "21", "-o", am])
    assert r.code == 0, r.err
    good = d / "good.json"
    r2 = run_cli(["model", "fit", *THERMAL, "--terms", "T(T_chamber_C),dTdt(T_chamber_C)",
                  "--t-ref", "21", "-o", good, "--no-history"])
    assert r2.code == 0, r2.err
    return r.out, am, good


def test_thermal_fit_leads_with_what_the_data_determine(thermal_models):
    out, _, _ = thermal_models
    lines = out.splitlines()
    lead = next(i for i, ln in enumerate(lines) if "determined by this log" in ln)
    assert lead == 1, lines[:3]
    det, undet = lines[lead].split("; not determined")
    undet = undet.split(":", 1)[1].split("(")[0]
    names = {n.strip(): True for n in det.split(":", 1)[1].split(",")}
    names.update({n.strip(): False for n in undet.split(",")})
    assert {"w0", "w1", "w2", "w_dV"} <= set(names) and not all(names.values())
    # the lead line says what the table marks: |value| < 2·1σ is "not determined"
    for name in ("w0", "w1", "w2", "w_dV"):
        row = next(ln for ln in lines if ln.strip("│┃ ").startswith(name + " "))
        assert ("not determined" in row) == (not names[name]), row
    assert out.index("IEEE 952 E terms") < out.index("Antonova–Matveev dw")
    assert out.index("D_T ") < out.index("w0 ")


def test_export_refuses_undetermined_terms_and_extrapolation(thermal_models, tmp_path):
    _, am, good = thermal_models
    lut = tmp_path / "lut.csv"
    r = run_cli(["export", "env-model", am, "-o", lut])
    r.assert_clean_error("am.json", "not determined", "T2(T_chamber_C)", "--force")
    assert not lut.exists()
    r = run_cli(["export", "env-model", am, "-o", lut, "--force"])
    assert r.code == 0 and "exported with --force" in r.err and lut.exists()
    # a model of determined terms exports; a grid beyond the fitted range does not
    r = run_cli(["export", "env-model", good, "-o", lut, "--temps", "21:55:1"])
    assert r.code == 0 and r.err == "", r.err
    r = run_cli(["export", "env-model", good, "-o", tmp_path / "x.csv", "--temps", "-40:85:5"])
    r.assert_clean_error("-40", "fitted on T_chamber_C", "extrapolate", "--force")
    assert not (tmp_path / "x.csv").exists()
    r = run_cli(["export", "env-model", good, "-o", tmp_path / "x.h"])
    assert r.code == 0, r.err


# ----------------------------------------------------------------------------- conveniences (11)
def test_info_plot_is_a_quick_look_of_the_raw_log(tmp_path):
    from gyrotest.core.profile import load_profile
    from gyrotest.io.ingest import read_log
    from gyrotest.io.quicklook import envelope, figure_quicklook

    png = tmp_path / "look.png"
    r = run_cli(["info", SAMPLE / "magnetic.parquet", "--profile", SAMPLE / "magnetic.profile.toml",
                 "--plot", png, "--json"])
    assert r.code == 0, r.err
    assert json.loads(r.out)["plot"] == str(png) and png.stat().st_size > 20_000
    g = read_log(SAMPLE / "magnetic.parquet", profile=load_profile(SAMPLE / "magnetic.profile.toml"))
    fig = figure_quicklook(g)
    labels = [ax.get_ylabel() for ax in fig.axes]
    assert labels == ["gyro output, deg/h", "temperatures, °C", "magnetic field, µT"]
    # the envelope keeps every sample's extremes (a spike survives) and the whole record
    t = np.arange(15_601) * 0.1
    x = np.zeros_like(t)
    x[12_345] = 40.0
    tb, mean, lo, hi = envelope(t, x)
    assert hi.max() == 40.0 and lo.min() == 0.0 and tb[-1] > t[-1] - 2 and len(tb) <= 4000


def test_info_plot_shades_gaps_and_marks_spikes_at_their_time(tmp_path):
    from gyrotest.io.ingest import read_log
    from gyrotest.io.quicklook import figure_quicklook
    from gyrotest.noise.outliers import detect_outliers

    rng = np.random.default_rng(3)
    t = np.arange(20_000) * 0.1
    t[8000:] += 30.0  # a 30 s gap
    x = 1 + 0.05 * rng.standard_normal(t.size)
    x[12_000] += 40.0  # a spike after the gap
    p = tmp_path / "gs.csv"
    np.savetxt(p, np.c_[t, x], delimiter=",", header="time,rate_dph", comments="", fmt="%.6g")
    g = read_log(p)
    reps = [detect_outliers(g.rates[a], g.tau0, segments=g.segments, channel=a) for a in g.axes]
    fig = figure_quicklook(g, outliers=reps)
    ax = fig.axes[0]
    spans = [pt for pt in ax.patches]  # the gap, shaded
    assert len(spans) == 1
    lines = [ln for ln in ax.get_lines() if ln.get_label().startswith("spike")]
    assert len(lines) == 1 and lines[0].get_xdata()[0] == pytest.approx(t[12_000] / 60)


@pytest.fixture
def lab_folder(tmp_path):
    d = tmp_path / "lab"
    d.mkdir()
    for p in list(SAMPLE.glob("*.parquet")) + list(SAMPLE.glob("*.profile.toml")) + [
            SAMPLE / "multipos.csv", SAMPLE / "thermostat.csv"]:
        (d / p.name).symlink_to(p)
    return d


def test_report_init_writes_a_campaign_of_the_logs_it_recognised(lab_folder):
    from gyrotest.specsheet.campaign import load_campaign

    r = run_cli(["report", "--init", lab_folder, "--json"])
    assert r.code == 0, r.err
    doc = json.loads(r.out)
    tests = {f["file"]: f["test"] for f in doc["logs"]}
    assert tests == {"static.parquet": "bias", "bias_run1.parquet": "bias",
                     "bias_run2.parquet": "bias", "bias_run3.parquet": "bias",
                     "ratetable_22a.parquet": "scale_factor",
                     "ratetable_22b.parquet": "scale_factor",
                     "ratetable_45.parquet": "scale_factor", "thermal.parquet": "thermal",
                     "magnetic.parquet": "magnetic", "multipos.csv": "multiposition",
                     "thermostat.csv": None}
    text = (lab_folder / "campaign.toml").read_text(encoding="utf-8")
    assert "FILL IN" in text and "# files not used" in text and "thermostat.csv" in text
    camp = load_campaign(str(lab_folder / "campaign.toml"))  # a valid campaign as written
    assert set(camp.tests) == {"bias", "allan", "scale_factor", "thermal", "magnetic",
                               "multiposition"}
    assert camp.tests["allan"].logs[0].name == "static.parquet"  # the longest static run
    # never over an existing file
    before = (lab_folder / "campaign.toml").read_bytes()
    run_cli(["report", "--init", lab_folder]).assert_clean_error("campaign.toml exists")
    assert (lab_folder / "campaign.toml").read_bytes() == before
    run_cli(["report", "--init", lab_folder / "nope"]).assert_clean_error("no such directory")


def test_allan_csv_names_its_units(tmp_path):
    import csv

    p = _rate_csv(tmp_path / "log.csv", "rate_dps")
    out = tmp_path / "a.csv"
    r = run_cli(["allan", p, "--csv", out, "--taus", "octave"])
    assert r.code == 0, r.err
    head = next(csv.reader(open(out)))
    assert head[:4] == ["source", "axis", "deviation", "tau_s"]
    assert {"sigma_deg_h", "sigma_lo_deg_h", "sigma_hi_deg_h", "model_deg_h"} <= set(head)
    assert not {"tau", "sigma"} & set(head)
