"""Scale factor: acceptance against the simulator's truth (issue #4).

Simulated rate-table logs (±1…±500 deg/s, three runs, pulse and analog output, earth rate and
noise present) with known scale factor, nonlinearity, asymmetry and run-to-run changes:

* SF of each run within its reported 2σ of the truth (noise-free plateau means, IEEE line);
* asymmetry within 2 ppm of the truth, linearity max within 5 ppm, repeatability within 20 %;
* plateaus found without a commanded-rate column (unequal dwells, reversed order);
* over many seeds: the SF z-scores are calibrated, the model finds the true terms;
* lock-in (RLG dead band) and SF temperature sensitivity.
"""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

import numpy as np
import pytest

from gyrotest.core.profile import load_profile
from gyrotest.io.ingest import read_log
from gyrotest.scalefactor import extract_plateaus, reduce_logs
from gyrotest.simulation import simulate, write_log

SCEN = Path(__file__).resolve().parents[1] / "sample_data" / "scenarios"


def scenario(name: str, **over) -> dict:
    sc = tomllib.loads((SCEN / f"ratetable_{name}.toml").read_text())
    for key, val in over.items():
        sec, _, k = key.rpartition("__")
        d = sc
        for part in sec.split("__") if sec else []:
            d = d.setdefault(part, {})
        d[k] = val
    return sc


def run_sim(sc: dict, tmp: Path, stem: str, seed: int | None = None):
    res = simulate(sc, seed=seed)
    w = write_log(res, tmp / f"{stem}.parquet")
    logs = [read_log(p, profile=load_profile(q)) for p, q in zip(w.logs, w.profiles)]
    truths = [json.loads(Path(t).read_text()) for t in w.truths]
    summary = json.loads(Path(w.summary).read_text()) if w.summary else None
    return logs, truths, summary


@pytest.fixture(scope="module", params=["pulse", "analog"])
def acceptance(request, tmp_path_factory):
    kind = request.param
    sc = scenario(kind, record__sample_rate_hz=50.0)
    logs, truths, summary = run_sim(sc, tmp_path_factory.mktemp(kind), kind)
    res = reduce_logs(logs, settle_s=8)
    return kind, res, truths, summary


def test_sf_within_2_sigma(acceptance):
    kind, res, truths, _ = acceptance
    key = "sf_arcsec_per_pulse" if kind == "pulse" else "sf_dph_per_v"
    assert res.sf_unit == ("arcsec/pulse" if kind == "pulse" else "(deg/h)/V")
    for r, t in zip(res.runs, truths):
        true = t["scale_factor"][key]
        assert abs(r.scale_factor - true) < 2 * r.scale_factor_sigma, (
            r.run, r.scale_factor, true, r.scale_factor_sigma)
        assert r.scale_factor_sigma / r.scale_factor < 1e-6  # sub-ppm, not a blanket error


def test_asymmetry_linearity_repeatability(acceptance):
    _, res, truths, summary = acceptance
    a = res.asymmetry
    assert a.status == "ok" and a.method.startswith("separate lines")
    for i, t in enumerate(truths):
        sf = t["scale_factor"]
        assert abs(a.per_run_ppm[i] - sf["asymmetry_ppm"]) < 2.0
        lin = res.runs[i].linearity
        assert abs(lin.max_ppm_fs - sf["linearity_max_ppm_fs"]) < 5.0
        assert abs(lin.sigma_ppm_fs - sf["linearity_1sigma_ppm_fs"]) < 2.0
    assert abs(a.asymmetry_ppm - np.mean([t["scale_factor"]["asymmetry_ppm"] for t in truths])) < 2
    assert abs(a.common_intercept_ppm - truths[0]["scale_factor"]["asymmetry_ppm_common_intercept"]) < 2
    rep = summary["sf_repeatability"]
    assert res.repeatability.sigma_ppm == pytest.approx(rep["one_sigma_ppm"], rel=0.2)
    assert res.repeatability.max_spread_ppm == pytest.approx(rep["max_spread_ppm"], rel=0.2)


def test_model_terms_and_bias(acceptance):
    _, res, truths, _ = acceptance
    # c1 (even output term) and c2 (odd) are in the scenario; the periodic 1 ppm at P = 7 deg/s
    # cannot be resolved on log-spaced rates, so only the dominant terms are asserted
    assert {"asymmetry", "u2"} <= set(res.model.terms)
    assert res.model.history[0].rms_ppm_fs > 5 * res.model.residual_rms_ppm_fs
    cubic = next(c for c in res.model.coefficients if c.name == "u2")
    assert cubic.coef_ppm == pytest.approx(-25.0, abs=2.0)
    d_f = truths[0]["bias"]["D_F_dph"]
    assert abs(res.bias_dph - d_f) < 0.2  # model intercept (absorbs the unresolved periodic)
    # model-free IEEE §12.11.4.1.1 bias at the zero-rate plateaus
    assert abs(res.bias_zero_rate_dph - d_f) < 3 * res.bias_zero_rate_sigma_dph


def test_plateaus_without_commanded_column(tmp_path):
    sc = scenario("nocmd", record__sample_rate_hz=50.0)
    logs, truths, _ = run_sim(sc, tmp_path, "nocmd")
    lg = logs[0]
    assert lg.table_rate is None
    rp = extract_plateaus(lg, settle_s=8)
    tp = truths[0]["scale_factor"]["plateaus"]
    assert [p.table_rate_dph / 3600 for p in rp.plateaus] == [t["rate_dps"] for t in tp]
    for p, t in zip(rp.plateaus, tp):
        assert t["start_s"] + 8 - 1.0 <= p.t_start_s <= t["start_s"] + 8 + 2.0
        assert t["end_s"] - 1.0 <= p.t_end_s <= t["end_s"] + 1e-6
    res = reduce_logs(logs, settle_s=8)
    t = truths[0]["scale_factor"]
    assert abs(res.runs[0].scale_factor - t["sf_arcsec_per_pulse"]) < 2 * res.runs[0].scale_factor_sigma
    assert abs(res.asymmetry.asymmetry_ppm - t["asymmetry_ppm"]) < 2.0
    # the same scenario with the commanded column gives the same answer
    sc2 = scenario("nocmd", record__sample_rate_hz=50.0, rate_table__column="table_dps")
    logs2, _, _ = run_sim(sc2, tmp_path, "withcmd")
    res2 = reduce_logs(logs2, settle_s=8)
    assert res2.run_plateaus[0].method == "table column"
    diff = abs(res2.runs[0].scale_factor - res.runs[0].scale_factor)
    assert diff < 2 * res.runs[0].scale_factor_sigma


@pytest.mark.slow
def test_sf_uncertainty_calibrated_over_seeds(tmp_path):
    """Over 10 seeds × 3 runs: SF z-scores with RMS ≈ 1 and ≥ 85 % within 2σ; without the
    unresolvable periodic term the model keeps exactly the true terms."""
    sc = scenario("pulse", record__sample_rate_hz=20.0, effects__scale_factor__periodic_ppm=0.0)
    z, terms, za = [], [], []
    for seed in range(10):
        logs, truths, _ = run_sim(sc, tmp_path, f"s{seed}", seed=200 + seed)
        res = reduce_logs(logs, settle_s=8, periodic=False)
        for r, t in zip(res.runs, truths):
            z.append((r.scale_factor - t["scale_factor"]["sf_arcsec_per_pulse"])
                     / r.scale_factor_sigma)
        terms.append(set(res.model.terms))
        za.append((res.asymmetry.model_ppm + 35.0) / res.asymmetry.model_sigma_ppm)  # scenario −35
    z = np.array(z)
    assert 0.6 < np.sqrt(np.mean(z ** 2)) < 1.3
    assert np.mean(np.abs(z) < 2) >= 0.85
    assert sum(t == {"asymmetry", "u1", "u2"} for t in terms) >= 8
    assert np.sqrt(np.mean(np.array(za) ** 2)) < 1.6


def test_rlg_lock_in(tmp_path):
    sc = scenario("rlg", record__sample_rate_hz=25.0)
    logs, truths, _ = run_sim(sc, tmp_path, "rlg")
    res = reduce_logs(logs, settle_s=5)
    assert res.lock_in.detected and res.lock_in.locked_rates_dps == [0.2]
    assert "lockin" in res.model.terms
    assert res.lock_in.fitted_dps == pytest.approx(0.3, rel=0.005)
    sf_nom = truths[0]["scale_factor"]["sf_nominal"]  # 1/(1 + 1e-6 eps0), output per input
    assert res.runs[0].scale_factor_model == pytest.approx(1.5 / sf_nom, rel=2e-6)


def test_temperature_sensitivity(tmp_path):
    """Three runs at 10, 30, 50 degC with eps_T = 2 ppm/degC (SF = input per output)."""
    logs = []
    for i, temp in enumerate((10.0, 30.0, 50.0)):
        sc = scenario("pulse", record__sample_rate_hz=20.0)
        sc["rate_table"]["rates_dps"] = [0, 10, -10, 100, -100, 500, -500]
        sc["runs"] = {"count": 1}
        sc["gyro"]["serial"] = "T-1"
        sc["environment"] = {"temperature": {"initial_c": temp, "sensors": [
            {"column": "T_case_C", "node": "ambient", "noise_c": 0.01}]}}
        sc["effects"]["scale_factor"].update(temp_ppm_per_c=2.0, t_ref_c=21.0, periodic_ppm=0.0)
        lg, _, _ = run_sim(sc, tmp_path, f"t{i}", seed=50 + i)
        logs += lg
    res = reduce_logs(logs, settle_s=8)
    ts = res.temperature
    assert ts.status == "ok" and ts.t_max_degC - ts.t_min_degC == pytest.approx(40, abs=0.5)
    assert ts.slope_ppm_per_degC == pytest.approx(2.0, abs=max(0.1, 3 * ts.slope_sigma_ppm_per_degC))
    assert res.epsilon_k()["epsilon_T_ppm_per_degC"] == ts.slope_ppm_per_degC
