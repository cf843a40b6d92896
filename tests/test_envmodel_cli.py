"""The workbench commands end to end: model fit/diagnose/history, thermal-fit, mag-fit,
compensate; and the bad-input contract (exit 2, one line naming term and channel, no
traceback, no output file)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from gyrotest.simulation import simulate, write_log

from cliutil import run_cli


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    d = tmp_path_factory.mktemp("envcli")
    out = {}
    for name, scen, seed, rate in (("rate1", "hidden_rate.toml", 31, 2.0),
                                   ("rate2", "hidden_rate.toml", 32, 2.0),
                                   ("mag", "magnetic_helmholtz.toml", 1, 2.0)):
        from test_envmodel_helpers import load_scenario_dict

        sc = load_scenario_dict(scen)
        sc["record"]["sample_rate_hz"] = rate
        w = write_log(simulate(sc, seed=seed), d / f"{name}.csv")
        out[name] = (str(w.logs[0]), str(w.profiles[0]))
    out["dir"] = d
    return out


def _small_csv(path, n=3000, *, temp="ramp", supply=12.0):
    rng = np.random.default_rng(0)
    with open(path, "w") as fh:
        fh.write("t_s,rate_dph,T_case,vsupply\n")
        for i in range(n):
            T = "" if temp == "nan" else f"{20 + 10 * i / n:.4f}"
            fh.write(f"{i * 0.1:.1f},{rng.standard_normal():.5f},{T},{supply}\n")
    return str(path)


def test_fit_history_diagnose_roundtrip(logs, tmp_path):
    log, prof = logs["rate1"]
    m = tmp_path / "model.json"
    r = run_cli(["model", "fit", log, "--profile", prof, "--terms", "T(T_case_C)", "--t-ref",
                 "21", "-o", m, "--json"])
    assert r.code == 0, r.err
    d = json.loads(r.out)
    assert d["terms"] == ["bias", "T(T_case_C)"]
    assert d["written"]["step"] == 1 and m.is_file()
    assert d["model"]["data"]["sha256"] and d["model"]["data"]["samples"] > 0
    assert d["noise_floor"]["rms_dph"] > 0 and d["residual_allan"]["tau_s"]
    r = run_cli(["model", "diagnose", log, "--profile", prof, "--terms", "T(T_case_C)",
                 "--t-ref", "21", "--json"])
    assert r.code == 0, r.err
    dg = json.loads(r.out)
    assert dg["missing_effect"] == "dTdt(T_case_C)"
    assert dg["candidates"][0]["improvement_pct"] > 50
    plot = tmp_path / "fit.png"
    r = run_cli(["model", "fit", log, "--profile", prof, "--terms", "T(T_case_C),dTdt(T_case_C)",
                 "--t-ref", "21", "-o", m, "--plot", plot])
    assert r.code == 0, r.err
    assert "coefficients" in r.out and "held-out" in r.out and "step 2" in r.out
    assert plot.is_file() and (tmp_path / "fit-allan.png").is_file()
    r = run_cli(["model", "history", m, "--json"])
    assert r.code == 0, r.err
    h = json.loads(r.out)["steps"]
    assert [s["added"] for s in h] == [["T(T_case_C)"], ["dTdt(T_case_C)"]]
    assert h[1]["rms_holdout_dph"] < 0.2 * h[0]["rms_holdout_dph"]
    r = run_cli(["model", "history", m, "--plot", tmp_path / "hist.png"])
    assert r.code == 0 and "dTdt" in r.out and (tmp_path / "hist.png").is_file()
    # TOML model and a session directory
    r = run_cli(["model", "fit", log, "--profile", prof, "--terms", "T(T_case_C)",
                 "--session", tmp_path / "sess", "--json"])
    assert r.code == 0, r.err
    assert (tmp_path / "sess" / "step-01.json").is_file()
    r = run_cli(["model", "fit", log, "--profile", prof, "--terms", "T(T_case_C)", "-o",
                 tmp_path / "m.toml", "--json"])
    assert r.code == 0 and (tmp_path / "m.toml").read_text().startswith("format =")


def test_compensate_writes_parquet_and_reports(logs, tmp_path):
    log1, prof1 = logs["rate1"]
    log2, prof2 = logs["rate2"]
    m = tmp_path / "model.json"
    r = run_cli(["model", "fit", log1, "--profile", prof1, "--terms",
                 "T(T_case_C),dTdt(T_case_C)", "--t-ref", "21", "-o", m, "--json"])
    assert r.code == 0, r.err
    out = tmp_path / "comp.parquet"
    r = run_cli(["compensate", log2, "--profile", prof2, "--model", m, "-o", out, "--json"])
    assert r.code == 0, r.err
    d = json.loads(r.out)
    assert d["reduction_factor"] > 5
    assert 0.8 <= d["achieved_over_predicted"] <= 1.2
    from gyrotest.io.ingest import read_log

    g = read_log(out)
    assert "model_drift_dph" in g.extra
    r = run_cli(["compensate", log2, "--profile", prof2, "--model", m, "--plot",
                 tmp_path / "c.png"])
    assert r.code == 0 and "drift RMS" in r.out and (tmp_path / "c.png").is_file()


def test_thermal_and_mag_commands(logs, tmp_path):
    sp = tmp_path / "sp.csv"
    sp.write_text("temperature,dw,sigma\n31,0.489,0.081\n35,0.346,0.051\n40,0.498,0.051\n"
                  "45,0.540,0.043\n50,0.919,0.043\n55,1.564,0.019\n")
    r = run_cli(["thermal-fit", "--setpoints", sp, "--json"])
    assert r.code == 0, r.err
    d = json.loads(r.out)["setpoints"]
    assert [c["name"] for c in d["coefficients"]] == ["w0", "w1", "w2"]
    log, prof = logs["rate1"]
    r = run_cli(["thermal-fit", log, "--profile", prof, "--json", "-o", tmp_path / "th.json"])
    assert r.code == 0, r.err
    ch = json.loads(r.out)["chamber"]
    assert ch["t0_degC"] == 21.0 and {c["name"] for c in ch["ieee_E_terms"]} >= {"D_T", "D_Tdot"}
    log, prof = logs["mag"]
    r = run_cli(["mag-fit", log, "--profile", prof, "--json"])
    assert r.code == 0, r.err
    mg = json.loads(r.out)
    w = {c["name"]: c["value"] for c in mg["coefficients"]}
    assert w["wy"] == pytest.approx(-0.576, abs=0.02)
    r = run_cli(["mag-fit", log, "--profile", prof])
    assert r.code == 0 and "reversal K" in r.out


def _no_files(d, before):
    after = {p.name for p in d.iterdir()}
    return after - before


@pytest.mark.parametrize("case", ["missing-channel", "constant-channel", "too-few-samples",
                                  "all-nan-temperature", "unsafe-expression"])
def test_bad_input_one_line_exit_2_no_output(tmp_path, case):
    out = tmp_path / "model.json"
    if case == "missing-channel":
        log = _small_csv(tmp_path / "a.csv")
        args, frags = ["--terms", "T(T_nope)"], ["T(T_nope)", "T_nope"]
    elif case == "constant-channel":
        log = _small_csv(tmp_path / "a.csv")
        args, frags = ["--terms", "T,V", "--supply-col", "vsupply"], ["'V'", "constant"]
    elif case == "too-few-samples":
        log = _small_csv(tmp_path / "a.csv", n=100)
        args, frags = ["--terms", "T,T2,T3,dTdt", "--resolution", "1s", "--smooth", "2s"], \
            ["T2(T_case)", "parameters"]
    elif case == "all-nan-temperature":
        log = _small_csv(tmp_path / "a.csv", temp="nan")
        args, frags = ["--terms", "T,dTdt"], ["term", "T_case", "no values"]
    else:
        log = _small_csv(tmp_path / "a.csv")
        args, frags = ["--term", "x:__import__('os').system('echo hi')"], ["expression", "plain function"]
    before = {p.name for p in tmp_path.iterdir()}
    r = run_cli(["model", "fit", log, "--temp-col", "T_case", *args, "-o", out])
    r.assert_clean_error(*frags)
    assert not out.exists()
    assert _no_files(tmp_path, before) == set()


def test_compensate_with_model_needing_missing_channel(logs, tmp_path):
    log, prof = logs["rate1"]
    m = tmp_path / "model.json"
    assert run_cli(["model", "fit", log, "--profile", prof, "--terms", "T(T_coil_C)", "-o",
                    m]).code == 0
    small = _small_csv(tmp_path / "b.csv")
    out = tmp_path / "o.parquet"
    r = run_cli(["compensate", small, "--temp-col", "T_case", "--model", m, "-o", out])
    r.assert_clean_error("T(T_coil_C)", "T_coil_C")
    assert not out.exists()


def test_diagnose_reference_floor_and_bad_reference(logs, tmp_path):
    """--reference: a static run of the same gyro fixes the noise model (its basis is printed in
    the JSON); a reference in another rate unit, or a missing file, is a one-line exit 2."""
    log, prof = logs["rate1"]
    rng = np.random.default_rng(5)
    good, bad = tmp_path / "static.csv", tmp_path / "static_dps.csv"
    for p, scale in ((good, 1.0), (bad, 3600.0)):
        with open(p, "w") as fh:
            fh.write("t_s,omega_dph\n")
            for i in range(20000):
                fh.write(f"{i * 0.5:.1f},{scale * 0.42 * rng.standard_normal():.6f}\n")
    common = ["model", "diagnose", log, "--profile", prof, "--terms", "T(T_case_C)",
              "--t-ref", "21"]
    r = run_cli(common + ["--reference", str(good), "--json"])
    assert r.code == 0, r.err
    d = json.loads(r.out)
    assert d["noise_model"]["from_reference"]
    assert "static reference run" in d["noise_model"]["basis"]
    assert "static.csv" in d["noise_model"]["basis"]
    assert d["missing_effect"] == "dTdt(T_case_C)" and d["add"]
    run_cli(common + ["--reference", str(bad)]).assert_clean_error(
        "--reference", "static_dps.csv", "rate unit")
    run_cli(common + ["--reference", str(tmp_path / "nope.csv")]).assert_clean_error(
        "--reference", "nope.csv")


def test_generic_channel_term_naming_a_missing_column(logs):
    log, prof = logs["rate1"]
    run_cli(["model", "diagnose", log, "--profile", prof, "--terms", "chan(nope)"]
            ).assert_clean_error("chan(nope)", "no channel 'nope'")


def test_thermal_and_mag_fit_reference_floor(logs, tmp_path):
    """thermal-fit and mag-fit take --reference like model fit/diagnose: the static run's noise
    is the floor stated in the JSON; a reference without a chamber log is a one-line exit 2."""
    rng = np.random.default_rng(9)
    good = tmp_path / "static.csv"
    with open(good, "w") as fh:
        fh.write("t_s,omega_dph\n")
        for i in range(20000):
            fh.write(f"{i * 0.5:.1f},{0.42 * rng.standard_normal():.6f}\n")
    log, prof = logs["rate1"]
    r = run_cli(["thermal-fit", log, "--profile", prof, "--reference", str(good), "--json"])
    assert r.code == 0, r.err
    am = json.loads(r.out)["chamber"]["am_fit"]
    assert "static.csv" in json.dumps(am["noise_floor"])
    log, prof = logs["mag"]
    r = run_cli(["mag-fit", log, "--profile", prof, "--reference", str(good), "--json"])
    assert r.code == 0, r.err
    assert "static.csv" in json.dumps(json.loads(r.out)["fit"]["noise_floor"])
    sp = tmp_path / "sp.csv"
    sp.write_text("temperature,dw\n31,0.49\n40,0.50\n55,1.56\n")
    run_cli(["thermal-fit", "--setpoints", sp, "--reference", str(good)]).assert_clean_error(
        "--reference", "chamber log")


def test_diagnose_magnetic_sample_names_hy_then_hz():
    """The bundled Helmholtz run (wx, wy, wz linear): Hy first, then Hz. A cross term tied
    with Hy plus Hz is not 'a pair of two other effects' -- Hy with Hz does as well -- so
    the pair redirect keeps Hy (it had named Hprod(Hy,Hz) first)."""
    from pathlib import Path

    s = Path(__file__).resolve().parent.parent / "sample_data"
    r = run_cli(["model", "diagnose", s / "magnetic.parquet", "--profile",
                 s / "magnetic.profile.toml", "--json"])
    assert r.code == 0, r.err
    d = json.loads(r.out)
    assert d["missing_effect"] == "Hy(Hy_uT)", d["verdict"]
    assert [p["term"] for p in d["path"]][:2] == ["Hy(Hy_uT)", "Hz(Hz_uT)"]


def test_diagnose_magnetic_sample_completes_the_field_vector_with_hx():
    """With Hy and Hz in the model, the third sensitivity (true w_x = -0.037 deg/h per
    100 µT, 7 % of |w|) is near the threshold: among the best candidates at the default
    α = 0.01 (family-wise p ≈ 0.012, the step's α being shared by its three tests) and the
    missing effect at α = 0.05; the cross terms that equal Hx in this sequence (one coil
    axis at a time) are named as indistinguishable; `model fit` with all three recovers w_x
    within 2σ."""
    from pathlib import Path

    s = Path(__file__).resolve().parent.parent / "sample_data"
    prof = ["--profile", s / "magnetic.profile.toml"]
    r = run_cli(["model", "diagnose", s / "magnetic.parquet", *prof, "--terms", "T,Hy,Hz",
                 "--json"])
    assert r.code == 0, r.err
    d = json.loads(r.out)
    top = next(c for c in d["candidates"] if c["term"] == "Hx(Hx_uT)")
    best = min(c["p_family"] for c in d["candidates"] if c["p_family"] is not None)
    assert top["p_family"] <= 0.05 and top["p_family"] <= best * 1.5, d["verdict"]
    r = run_cli(["model", "diagnose", s / "magnetic.parquet", *prof, "--terms", "T,Hy,Hz",
                 "--alpha", "0.05", "--json"])
    assert r.code == 0, r.err
    d = json.loads(r.out)
    assert d["missing_effect"] == "Hx(Hx_uT)", d["verdict"]
    r = run_cli(["model", "fit", s / "magnetic.parquet", *prof, "--terms", "Hx,Hy,Hz",
                 "--json"])
    assert r.code == 0, r.err
    wx = next(c for c in json.loads(r.out)["coefficients"] if c["term"] == "Hx(Hx_uT)")
    assert abs(wx["value"] - (-0.037)) <= 2 * wx["stderr"], wx


def test_diagnose_rules_prints_every_rule_without_a_log():
    """`model diagnose --rules` prints the decision rules (the man page's WORKBENCH VERDICT
    RULES) and exits 0 before any log is read; the text is generated from the decision
    constants the diagnosis uses (gyrotest.envmodel.workbench_rules)."""
    from gyrotest.envmodel import candidate, likelihood, lookelsewhere, selection
    from gyrotest.envmodel import workbench_rules as w

    res = run_cli(["model", "diagnose", "--rules"])
    assert res.code == 0, res.err
    for head, _ in w.RULES:
        assert head in res.out, head
    text = " ".join(t for _, t in w.RULES)
    for phrase in (f"default {w.ALPHA:g}", f"{w.MC_DRAWS} draws", f"ΔBIC {w.BIC_TIE:g}",
                   f"{w.TAU_POINTS} log-spaced", f"at most {w.NL_MAX} samples",
                   f"over {w.WHITE_LAGS} lags", f"≥ {w.VIF_MAX:g}"):
        assert phrase in text, phrase
    # one source: the engine uses these very constants
    assert selection.ALPHA is w.ALPHA and lookelsewhere.MC_DRAWS is w.MC_DRAWS
    assert candidate.MC_DRAWS is w.MC_DRAWS
    assert likelihood.NL_MAX is w.NL_MAX
    man = (Path(__file__).resolve().parents[1] / "man" / "gyrotest.1").read_text("utf-8")
    assert "WORKBENCH VERDICT RULES" in man
    # the diagnosis itself prints the one-line form and points to --rules
    s = Path(__file__).resolve().parents[1] / "sample_data"
    res = run_cli(["model", "diagnose", s / "magnetic.parquet", "--profile",
                   s / "magnetic.profile.toml", "--terms", "T,Hy,Hz"])
    assert res.code == 0, res.err
    flat = " ".join(res.out.split())
    assert "'model diagnose --rules' prints every rule" in flat
