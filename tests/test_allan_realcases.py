"""``gyrotest allan`` on the cases a new user tries first (issue: Allan analysis on real logs):
Krobka's central case (ARW + Markov hump + flicker at 100 Hz) must not crash, a bound-only
two-parameter term without a shape must not break the attitude prediction."""

from __future__ import annotations

import json

import pytest
from test_noise_fit import table_from_model

from gyrotest.noise.impact import attitude_impact, unshaped_bounds
from gyrotest.noise.noisefit import fit_noise_model
from gyrotest.simulation import simulate, write_log

from cliutil import run_cli

RATE = ["--rate-unit", "deg/h"]


@pytest.fixture(scope="module")
def krobka_log(tmp_path_factory):
    """Krobka's central case: 2 h at 100 Hz, N = 2e-4 deg/√h, Gauss–Markov q_c = 4 deg/h/√s
    (= 240 deg/h/√h), T_c = 0.2 s, flicker B = 0.003 deg/h."""
    d = tmp_path_factory.mktemp("krobka")
    sc = {"record": {"sample_rate_hz": 100.0, "duration_s": 7200},
          "gyro": {"output": "rate", "rate_unit": "deg/h",
                   "noise": {"N": 2e-4, "B": 0.003, "markov": [{"q_c": 240.0, "T_c": 0.2}]}}}
    w = write_log(simulate(sc, seed=1), d / "log.csv")
    return str(w.logs[0])


def test_krobka_central_case_runs_and_finds_the_hump(krobka_log):
    r = run_cli(["allan", krobka_log, *RATE, "--json", "--vehicle-rate", "10deg/s"])
    assert r.code == 0, r.err
    ax = json.loads(r.out)["logs"][0]["axes"][0]
    final = {t["label"]: t for t in ax["diagnosis"]["final_fit"]["terms"]}
    mk = final["markov"]
    assert mk["status"] == "identified"
    assert mk["params"]["T_c"] == pytest.approx(0.2, rel=0.1)
    assert mk["params"]["q_c"] == pytest.approx(240.0, rel=0.1)
    n = final["N"]
    # the white noise is screened by the hump: identified near 2e-4 or a bound that holds it
    assert (n["params"]["N"] == pytest.approx(2e-4, rel=0.2) if n["status"] == "identified"
            else n["upper_95"] >= 2e-4 * 0.95)
    assert ax["impact"]["platform"]["sigma_att_deg"] > 0


@pytest.mark.parametrize("extra", ["markov", "blue", "sine"])
def test_bound_only_two_parameter_term_does_not_break_the_impact(extra):
    """The reported crash: a two-parameter term dropped by backward elimination keeps no shape
    (T_c/β = None); the attitude prediction multiplied by it."""
    tau, sig, edf, lo, hi = table_from_model([("arw", {"N": 0.002}), ("rrw", {"K": 0.01})],
                                             tau0=0.01, n=720_000)
    f = fit_noise_model(tau, sig, edf, sigma_lo=lo, sigma_hi=hi, terms=["N", "K", extra],
                        tau0=0.01)
    t = f.term(extra)
    assert t.status == "upper bound"
    imp = attitude_impact(f, horizon_s=3600.0, vehicle_rates_rad_s=[0.2])
    assert imp.platform_sigma_deg > 0 and imp.conservative_platform_sigma_deg > 0
    if t.shape is None:
        assert extra in unshaped_bounds(f)
        assert any("left out" in a for a in imp.assumptions)


# ----------------------------------------------------------------------------- plain table
def test_plain_table_for_a_short_tau_list(krobka_log, tmp_path):
    """`--taus 1,10,100` (the Stable32/AllanTools habit): the table, a note, no fit."""
    png = tmp_path / "t.png"
    r = run_cli(["allan", krobka_log, *RATE, "--taus", "1,10,100", "--plot", png, "-v"])
    assert r.code == 0, r.err
    assert "sigma_lo" in r.out and "Noise model" not in r.out
    assert "noise model not fitted" in r.err and "only 3 τ" in r.err
    assert png.exists()
    r = run_cli(["allan", krobka_log, *RATE, "--taus", "1,10,100", "--json"])
    ax = json.loads(r.out)["logs"][0]["axes"][0]
    assert [row["tau"] for row in ax["table"]] == [1.0, 10.0, 100.0]
    assert ax["fit"] is None and ax["impact"] is None and ax["warnings"] == []
    # white-rate σ ∝ τ^-1/2 above the hump: the table carries real numbers with intervals
    assert all(row["sigma_lo"] < row["sigma"] < row["sigma_hi"] for row in ax["table"])


def test_no_fit_flag(krobka_log):
    r = run_cli(["allan", krobka_log, *RATE, "--taus", "decade", "--no-fit", "--json"])
    assert r.code == 0, r.err
    doc = json.loads(r.out)["logs"][0]
    assert doc["settings"]["fit"] is False
    ax = doc["axes"][0]
    assert ax["fit"] is None and ax["diagnosis"] is None and len(ax["table"]) >= 5
    assert "model" not in ax["table"][0]


# ----------------------------------------------------------------------------- intervals
def test_default_interval_is_stable32s_and_conservative_is_opt_in(krobka_log):
    r = run_cli(["allan", krobka_log, *RATE, "--taus", "octave", "--no-fit", "--json"])
    ax = json.loads(r.out)["logs"][0]["axes"][0]
    assert "Stable32" in ax["deviation"]["ci"] and "alpha_ci" not in ax["table"][0]
    r2 = run_cli(["allan", krobka_log, *RATE, "--taus", "octave", "--no-fit", "--json",
                  "--ci", "conservative"])
    ax2 = json.loads(r2.out)["logs"][0]["axes"][0]
    for a, b in zip(ax["table"], ax2["table"]):
        assert a["sigma_lo"] == b["sigma_lo"] and a["sigma_hi"] == b["sigma_hi"]
        assert b["edf_ci"] <= b["edf"] * (1 + 1e-12)
        assert b["sigma_hi_ci"] >= b["sigma_hi"] * (1 - 1e-12)
        if b["edf_ci_rule"] == "white-rate cap":
            assert b["alpha_ci"] == 0 and b["alpha"] > 0
    r3 = run_cli(["allan", krobka_log, *RATE, "--taus", "octave", "--ci", "wide"])
    assert r3.code == 2


def test_fit_states_its_weights(krobka_log):
    r = run_cli(["allan", krobka_log, *RATE, "--no-diagnose"])
    assert r.code == 0, r.err
    assert "conservative EDF" in r.out


# ----------------------------------------------------------------------------- environment
@pytest.fixture(scope="module")
def diurnal(tmp_path_factory):
    """3 days at 1 Hz: N = 0.005 deg/√h, flicker B = 0.003 deg/h, no RRW, and a 24 h sinusoid
    of 0.03 deg/h; the drift model from 'gyrotest model fit --terms sin'."""
    d = tmp_path_factory.mktemp("diurnal")
    sc = {"record": {"sample_rate_hz": 1.0, "duration_s": 3 * 86400},
          "gyro": {"output": "rate", "rate_unit": "deg/h",
                   "noise": {"N": 0.005, "B": 0.003,
                             "sinusoid": [{"amplitude_dph": 0.03, "freq_hz": 1 / 86400}]}}}
    log = str(write_log(simulate(sc, seed=3), d / "diurnal.csv").logs[0])
    m = d / "m.json"
    r = run_cli(["model", "fit", log, *RATE, "--terms", "sin", "-o", m])
    assert r.code == 0, r.err
    return log, str(m)


def _terms(ax):
    f = (ax["diagnosis"] or {}).get("final_fit") or ax["fit"]
    return {t["key"]: t for t in f["terms"]}


def test_diurnal_without_model_gets_the_long_period_advice(diurnal):
    log, _ = diurnal
    r = run_cli(["allan", log, *RATE, "--json"])
    assert r.code == 0, r.err
    ax = json.loads(r.out)["logs"][0]["axes"][0]
    w = {x["code"]: x for x in ax["warnings"]}
    assert "KROBKA-M5" in w
    m5 = w["KROBKA-M5"]["message"]
    assert "higher output rate cannot move it" in m5 and "--model m.json" in m5
    assert "slow hump" in w["KROBKA-M5"]["title"]


@pytest.mark.parametrize("how", [["--model"], ["--detrend", "sine:24h"]])
def test_diurnal_removed_first_gives_K_as_a_bound(diurnal, how):
    log, m = diurnal
    args = how + [m] if how == ["--model"] else how
    r = run_cli(["allan", log, *RATE, "--json", *args])
    assert r.code == 0, r.err
    doc = json.loads(r.out)["logs"][0]
    ax = doc["axes"][0]
    t = _terms(ax)
    assert t["K"]["status"] == "upper bound"  # the truth K = 0 lies inside the bound
    assert t["N"]["status"] == "identified"
    assert t["N"]["params"]["N"] == pytest.approx(0.005, rel=0.03)
    b = t["B"]  # flicker B = 0.003 deg/h is near the white-noise floor: a bound or a value
    assert (b["upper_95"] >= 0.003 * 0.9 if b["status"] == "upper bound"
            else b["params"]["B"] == pytest.approx(0.003, rel=0.5))
    assert "KROBKA-M5" not in {w["code"] for w in ax["warnings"]}
    if how == ["--model"]:
        assert doc["settings"]["model"]["terms"] == ["sin"]
        assert any("deterministic model removed" in n for n in doc["notes"])
    else:
        assert ax["detrend"]["amplitude_dph"] == pytest.approx(0.03, rel=0.15)


@pytest.mark.parametrize("spec,frag", [("sine:", "--detrend"), ("cubic", "unknown --detrend"),
                                       ("sine:-2h", "--detrend")])
def test_bad_detrend(krobka_log, spec, frag):
    run_cli(["allan", krobka_log, *RATE, "--detrend", spec]).assert_clean_error(frag)


def test_missing_model_file(krobka_log):
    run_cli(["allan", krobka_log, *RATE, "--model", "nope.json"]).assert_clean_error("nope.json")


def test_quadratic_detrend_removes_a_parabola(tmp_path):
    import numpy as np

    rng = np.random.default_rng(8)
    n = 36_000
    t = np.arange(n) * 0.1
    rate = 0.6 / np.sqrt(0.1) * rng.standard_normal(n) + 40.0 * ((t - t.mean()) / 1800) ** 2
    f = tmp_path / "q.csv"
    np.savetxt(f, np.column_stack([t, rate]), delimiter=",", header="t,rate", comments="")
    r = run_cli(["allan", str(f), *RATE, "--json", "--no-diagnose", "--detrend", "quadratic"])
    ax = json.loads(r.out)["logs"][0]["axes"][0]
    assert ax["detrend"]["method"] == "quadratic"
    assert ax["detrend"]["coefficients_dph"]["quadratic"] == pytest.approx(40.0, rel=0.05)
    assert "KROBKA-M7" not in {w["code"] for w in ax["warnings"]}
