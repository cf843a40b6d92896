"""``gyrotest allan`` end to end: table, CSV, JSON, plots, multi-axis and multi-log runs,
pulse input, detrending, and bad input (one clear line, exit 2, never a NaN table)."""

from __future__ import annotations

import csv
import json
import math

import numpy as np
import pytest

from gyrotest.simulation import simulate, write_log

from cliutil import run_cli

RATE = ["--rate-unit", "deg/h"]


def write_csv(path, t, cols: dict, fmt="%.9g"):
    names = ["t"] + list(cols)
    data = np.column_stack([t] + [np.asarray(v) for v in cols.values()])
    np.savetxt(path, data, delimiter=",", header=",".join(names), comments="", fmt=fmt)
    return str(path)


@pytest.fixture(scope="module")
def hump_log(tmp_path_factory):
    """2 h at 10 Hz: ARW + a Markov hump (profile written by the simulator)."""
    d = tmp_path_factory.mktemp("allan")
    sc = {"record": {"sample_rate_hz": 10.0, "duration_s": 7200},
          "gyro": {"output": "rate", "rate_unit": "deg/h", "bias_dph": 0.3,
                   "noise": {"N": 0.005, "markov": [{"q_c": 30.0, "T_c": 2.0}]}}}
    w = write_log(simulate(sc, seed=5), d / "hump.csv")
    return str(w.logs[0]), str(w.profiles[0]), d


def test_table_csv_plots_and_explanations(hump_log):
    log, prof, d = hump_log
    out_csv, png, psd = d / "t.csv", d / "a.png", d / "p.png"
    r = run_cli(["allan", log, "--profile", prof, "--csv", out_csv, "--plot", png, "--psd", psd,
                 "--vehicle-rate", "10deg/s"])
    assert r.code == 0, r.err
    for frag in ("OADEV", "sigma_lo", "sigma_hi", "alpha", "Greenhall", "Noise model",
                 "diagnosis", "missing term: markov", "Diagnosed model", "SINS/INS",
                 "gyroscope_noise_density", "NoiseDensity"):
        assert frag in r.out, frag
    assert "KROBKA-M5" in r.err and "KROBKA-M6" in r.err
    rows = list(csv.DictReader(open(out_csv)))
    assert list(rows[0])[:9] == ["source", "axis", "deviation", "tau_s", "n", "alpha",
                                 "sigma_lo_deg_h", "sigma_deg_h", "sigma_hi_deg_h"]
    assert "model_deg_h" in rows[0] and "residual_ci" in rows[0]
    assert all(float(x["sigma_deg_h"]) > 0 for x in rows)
    for p in (png, psd):
        assert p.exists() and p.stat().st_size > 20_000


def test_json_document(hump_log):
    log, prof, _ = hump_log
    r = run_cli(["allan", log, "--profile", prof, "--json", "--terms", "+markov",
                 "--vehicle-rate", "10deg/s", "--vehicle-rate", "1rad/s", "--taus", "octave"])
    assert r.code == 0, r.err
    doc = json.loads(r.out)
    ax = doc["logs"][0]["axes"][0]
    assert ax["input_kind"] == "rate"
    assert all(row["sigma"] is not None and row["sigma_lo"] < row["sigma"] < row["sigma_hi"]
               for row in ax["table"])
    taus = [row["tau"] for row in ax["table"]]
    assert taus[:4] == pytest.approx([0.1, 0.2, 0.4, 0.8])
    keys = {t["key"]: t for t in ax["fit"]["terms"]}
    assert keys["markov"]["status"] == "identified"
    assert keys["markov"]["params"]["T_c"] == pytest.approx(2.0, rel=0.2)
    assert keys["R"]["status"] == "upper bound" and keys["R"]["display"].startswith("R ≤")
    assert ax["diagnosis"]["no_missing_term"] is True
    assert {w["code"] for w in ax["warnings"]} >= {"KROBKA-M5"}
    assert len(ax["impact"]["strapdown"]) == 2
    assert ax["conversions"]["kalibr"]["gyroscope_noise_density"] > 0
    assert ax["deviation"]["ci_method"].startswith("Greenhall")


def test_multi_axis_cross_correlation_and_overlay(tmp_path):
    rng = np.random.default_rng(0)
    n = 20_000
    t = np.arange(n) * 0.1
    c = rng.standard_normal(n)
    gx = 0.6 * (0.8 * c + 0.6 * rng.standard_normal(n))
    gy = 0.6 * (0.8 * c + 0.6 * rng.standard_normal(n))
    a = write_csv(tmp_path / "m.csv", t, {"gx": gx, "gy": gy})
    b = write_csv(tmp_path / "m2.csv", t[: n // 2], {"gx": gx[: n // 2], "gy": gy[: n // 2]})
    png = tmp_path / "overlay.png"
    r = run_cli(["allan", a, b, "--rate-col", "gx,gy", *RATE, "--json", "--plot", png,
                 "--no-diagnose"])
    assert r.code == 0, r.err
    doc = json.loads(r.out)
    assert len(doc["logs"]) == 2 and len(doc["logs"][0]["axes"]) == 2
    cc = doc["logs"][0]["cross_correlation"]
    assert cc["axes"] == ["gx", "gy"]
    assert cc["tau_s"][0] == pytest.approx(0.1)
    assert cc["matrices"][0][0][1] == pytest.approx(0.64, abs=0.05)
    assert png.exists()


def test_pulse_counts_are_angle_increments(tmp_path):
    sc = {"record": {"sample_rate_hz": 100.0, "duration_s": 1200},
          "gyro": {"output": "counts", "scale_factor": 0.2, "bias_dph": 0.3,
                   "noise": {"N": 0.01}},
          "site": {"latitude_deg": 48.1, "ia": "up"}}
    w = write_log(simulate(sc, seed=4), tmp_path / "p.csv")
    r = run_cli(["allan", str(w.logs[0]), "--profile", str(w.profiles[0]), "--json",
                 "--terms", "Q,N,B", "--no-diagnose"])
    assert r.code == 0, r.err
    ax = json.loads(r.out)["logs"][0]["axes"][0]
    assert ax["input_kind"] == "increment" and "pulse" in ax["input"]
    q = next(t for t in ax["fit"]["terms"] if t["key"] == "Q")
    assert q["params"]["Q"] == pytest.approx(0.2 / math.sqrt(12), rel=0.10)


def test_detrend_removes_a_ramp(tmp_path):
    rng = np.random.default_rng(2)
    n = 36_000
    t = np.arange(n) * 0.1
    rate = 0.6 / math.sqrt(0.1) * rng.standard_normal(n) + 5.0 * t / 3600.0  # R = 5 deg/h/h
    f = write_csv(tmp_path / "ramp.csv", t, {"rate": rate})
    r = run_cli(["allan", f, *RATE, "--json", "--no-diagnose"])
    ax = json.loads(r.out)["logs"][0]["axes"][0]
    assert "KROBKA-M7" in {w["code"] for w in ax["warnings"]}
    r2 = run_cli(["allan", f, *RATE, "--json", "--no-diagnose", "--detrend", "linear"])
    ax2 = json.loads(r2.out)["logs"][0]["axes"][0]
    assert "KROBKA-M7" not in {w["code"] for w in ax2["warnings"]}
    assert ax2["detrend"]["R_removed_deg_h_per_h"] == pytest.approx(5.0, rel=0.1)


def test_other_deviation_is_shown_and_oadev_is_fitted(hump_log):
    log, prof, _ = hump_log
    r = run_cli(["allan", log, "--profile", prof, "--dev", "mdev", "--json", "--no-diagnose",
                 "--taus", "decade"])
    assert r.code == 0, r.err
    ax = json.loads(r.out)["logs"][0]["axes"][0]
    assert ax["deviation"]["kind"] == "mdev" and ax["fit_deviation"] == "oadev"
    assert any("fitted to an OADEV" in n for n in ax["notes"])


# ----------------------------------------------------------------------------- bad input
@pytest.fixture()
def white_csv(tmp_path):
    rng = np.random.default_rng(1)
    n = 3000
    return write_csv(tmp_path / "w.csv", np.arange(n) * 0.1, {"rate": rng.standard_normal(n)})


def test_too_short_for_requested_tau(white_csv):
    r = run_cli(["allan", white_csv, *RATE, "--taus", "1,10,100000"])
    r.assert_clean_error("too short")


def test_record_too_short_for_any_fit(tmp_path):
    f = write_csv(tmp_path / "s.csv", np.arange(6) * 0.1, {"rate": [1, 2, 1, 3, 2, 1]})
    r = run_cli(["allan", f, *RATE, "-v"])
    # the one-τ table is printed; the fit is skipped with a note (no error, no traceback)
    assert r.code == 0 and "Traceback" not in r.err
    assert "noise model not fitted" in r.err and "0.8944" in r.out


def test_constant_signal(tmp_path):
    f = write_csv(tmp_path / "c.csv", np.arange(2000) * 0.1, {"rate": np.full(2000, 1.5)})
    run_cli(["allan", f, *RATE]).assert_clean_error("constant")


def test_nan_is_an_error_or_a_gap(tmp_path):
    rng = np.random.default_rng(3)
    x = rng.standard_normal(6000)
    x[2500:2510] = np.nan
    f = write_csv(tmp_path / "n.csv", np.arange(6000) * 0.1, {"rate": x})
    r = run_cli(["allan", f, *RATE])
    r.assert_clean_error("nan")
    r = run_cli(["allan", f, *RATE, "--nan", "gap", "--json", "--no-diagnose"])
    assert r.code == 0, r.err
    doc = json.loads(r.out)
    assert any("gap" in n for n in doc["logs"][0]["notes"])
    assert all(row["sigma"] is not None for row in doc["logs"][0]["axes"][0]["table"])


def test_gaps_in_time_are_pooled_with_a_note(tmp_path):
    rng = np.random.default_rng(4)
    t = np.arange(8000) * 0.1
    t[4000:] += 30.0  # a 30 s hole
    f = write_csv(tmp_path / "g.csv", t, {"rate": rng.standard_normal(8000)})
    r = run_cli(["allan", f, *RATE, "--json", "--no-diagnose"])
    assert r.code == 0, r.err
    doc = json.loads(r.out)
    notes = " ".join(doc["logs"][0]["notes"] + doc["logs"][0]["axes"][0]["deviation"]["notes"])
    assert "gap" in notes and "pooled" in notes


def test_non_uniform_time(tmp_path):
    rng = np.random.default_rng(5)
    dt = rng.uniform(0.05, 0.15, 5000)
    f = write_csv(tmp_path / "u.csv", np.cumsum(dt), {"rate": rng.standard_normal(5000)})
    run_cli(["allan", f, *RATE]).assert_clean_error("uniform sampling")
    r = run_cli(["allan", f, *RATE, "--allow-irregular", "--json", "--no-diagnose"])
    assert r.code == 0, r.err
    assert any("irregular" in n for n in json.loads(r.out)["logs"][0]["notes"])


@pytest.mark.parametrize("args,frag", [
    (["--terms", "N,wobble"], "unknown noise term"),
    (["--vehicle-rate", "fast"], "vehicle rate"),
    (["--plot", "x.gif"], "unknown format"),
    (["--taus", "often"], "--taus"),
    (["--skip", "10h"], "removes the whole record"),
    (["--axis", "zz"], "no axis"),
])
def test_bad_options(white_csv, args, frag):
    run_cli(["allan", white_csv, *RATE, *args]).assert_clean_error(frag)
