"""Simulator: deterministic effects, encodings, files, ingest round trips, errors.

Statistical (Allan-deviation) checks of the noise terms are in test_simulate_stats.py.
"""

from __future__ import annotations

import copy
import glob
import json
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from gyrotest.core.errors import InputError
from gyrotest.core.output import jsonable
from gyrotest.core.profile import load_profile
from gyrotest.io.ingest import read_log
from gyrotest.noise.terms import EARTH_RATE_DPH
from gyrotest.simulation import ANTONOVA_MATVEEV, load_scenario, simulate, write_log
from gyrotest.simulation import environment as env

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = sorted(glob.glob(str(ROOT / "sample_data" / "scenarios" / "*.toml")))


def base(**over) -> dict:
    """A small noise-free scenario; ``over`` replaces top-level sections."""
    d = {
        "record": {"sample_rate_hz": 10.0, "duration_s": 60.0},
        "gyro": {"output": "rate", "bias_dph": 1.5},
        "site": {"latitude_deg": 48.137, "ia": "east"},
    }
    d.update(copy.deepcopy(over))
    return d


def window_mean(t, v, a, b):
    m = (t - 0.5 * (t[1] - t[0]) >= a) & (t <= b)
    return float(np.mean(v[m]))


# ------------------------------------------------------------------ reproducibility


def test_same_seed_same_output_and_independent_streams():
    sc = base(gyro={"output": "rate", "noise": {"N": 0.1, "K": 0.01}})
    a, b = simulate(sc, seed=11), simulate(sc, seed=11)
    c = simulate(sc, seed=12)
    np.testing.assert_array_equal(a.rate_dph, b.rate_dph)
    assert not np.array_equal(a.rate_dph, c.rate_dph)
    assert a.truth["seed"] == 11
    # adding a term leaves the other terms' random streams untouched
    sc2 = copy.deepcopy(sc)
    sc2["gyro"]["noise"]["sinusoid"] = [{"amplitude_dph": 1.0, "freq_hz": 0.3}]
    d = simulate(sc2, seed=11)
    np.testing.assert_array_equal(a.run.components["noise.arw"], d.run.components["noise.arw"])
    np.testing.assert_array_equal(a.run.components["noise.rrw"], d.run.components["noise.rrw"])
    # scenario seed is used when none is given
    sc3 = base(scenario={"seed": 5}, gyro={"noise": {"N": 0.1}})
    np.testing.assert_array_equal(simulate(sc3).rate_dph, simulate(sc3, seed=5).rate_dph)


def test_components_sum_to_the_output():
    sc = base(gyro={"output": "rate", "bias_dph": 0.3,
                    "noise": {"N": 0.05, "B": 0.02, "B_f0_hz": 1.0, "K": 0.01, "R": 0.5,
                              "Q": 0.2, "markov": [{"q_c": 2.0, "T_c": 3.0}],
                              "sinusoid": [{"amplitude_dph": 0.1, "freq_hz": 0.2}],
                              "blue": [{"family": "blue_exp", "alpha": 1e-3, "beta": 1.0,
                                        "n": 2}]}},
              effects={"warmup": {"amplitude_dph": 2.0, "tau_s": 10.0}})
    r = simulate(sc, seed=1).run
    total = sum(np.broadcast_to(v, (r.n,)) for v in r.components.values())
    np.testing.assert_allclose(r.rate_dph, total, rtol=1e-12, atol=1e-12)
    assert set(r.components) >= {"earth", "bias", "warmup", "rate_ramp", "noise.arw",
                                 "noise.bias_instability", "noise.rrw", "noise.white_angle",
                                 "noise.markov[0]", "noise.sinusoid[0]", "noise.blue[0]"}


# ------------------------------------------------------------------ earth rate


def test_earth_rate_six_positions_hand_values():
    # 48.137 N: Omega_E sin(phi) = 11.201724, Omega_E cos(phi) = 10.037683 deg/h (by hand)
    expected = {"up": 11.201724, "down": -11.201724, "north": 10.037683,
                "south": -10.037683, "east": 0.0, "west": 0.0}
    pos = [{"ia": k, "dwell_s": 20.0} for k in expected]
    sc = base(site={"latitude_deg": 48.137, "positions": pos}, record={"sample_rate_hz": 10.0},
              gyro={"output": "rate", "rate_unit": "deg/s", "bias_dph": 1.5})
    r = simulate(sc, seed=1).run
    assert EARTH_RATE_DPH == pytest.approx(15.041067, abs=1e-6)
    labels = r.columns["pos"]
    for i, (name, val) in enumerate(expected.items()):
        m = labels == name
        assert m.sum() == 200
        assert np.mean(r.rate_dph[m]) - 1.5 == pytest.approx(val, abs=1e-6)
        w = r.truth["earth"]["positions"][i]
        assert w["label"] == name and w["earth_rate_ia_dph"] == pytest.approx(val, abs=1e-6)
        assert (w["start_s"], w["end_s"]) == (20.0 * i, 20.0 * (i + 1))
    # the rate column is in deg/s
    np.testing.assert_allclose(r.columns["omega_dps"] * 3600.0, r.rate_dph)
    assert r.profile["columns"]["position"] == "pos"


def test_earth_rate_arbitrary_azimuth_elevation():
    sc = base(site={"latitude_deg": 48.137, "ia_azimuth_deg": 30.0, "ia_elevation_deg": 20.0})
    r = simulate(sc, seed=1)
    # by hand: 15.041067 (cos 48.137 cos 20 cos 30 + sin 48.137 sin 20) = 11.999858
    assert r.truth["earth"]["earth_rate_ia_dph"] == pytest.approx(11.999858, abs=1e-5)
    assert np.allclose(r.rate_dph, 1.5 + 11.999858, atol=1e-5)
    assert r.profile["site"] == {"latitude_deg": 48.137, "ia_azimuth_deg": 30.0,
                                 "ia_elevation_deg": 20.0}


# ------------------------------------------------------------------ temperature


def test_temperature_profile_segments():
    spec = load_scenario(base(environment={"temperature": {
        "initial_c": 21.0,
        "profile": [
            {"kind": "hold", "duration_s": 100},
            {"kind": "ramp", "to_c": 31.0, "rate_c_per_h": 360.0},  # 100 s
            {"kind": "staircase", "levels_c": [35.0, 40.0], "dwell_s": 200, "ramp_c_per_h": 0},
            {"kind": "step", "to_c": 30.0},
            {"kind": "sine", "amplitude_c": 5.0, "period_s": 100, "cycles": 2},
        ]}})).temperature
    tm = np.array([50.0, 150.0, 250.0, 450.0, 625.0, 700.0, 900.0])
    T, dT = env.ambient_temperature(spec, tm)
    np.testing.assert_allclose(T, [21.0, 26.0, 35.0, 40.0, 35.0, 30.0, 30.0], atol=1e-9)
    w = 5.0 * 2 * math.pi / 100 * 3600.0  # sine: A omega, degC/h
    np.testing.assert_allclose(dT, [0.0, 360.0, 0.0, 0.0, 0.0, w, 0.0], atol=1e-9)
    assert env.profile_end(spec) == pytest.approx(800.0)
    _, dT_sine = env.ambient_temperature(spec, np.array([600.0]))
    assert dT_sine[0] == pytest.approx(5.0 * 2 * math.pi / 100 * 3600.0)


def test_thermal_terms_reproduce_coefficients_exactly():
    temp = {"initial_c": 20.0,
            "profile": [{"kind": "hold", "duration_s": 200},
                        {"kind": "ramp", "to_c": 40.0, "rate_c_per_h": 60.0},
                        {"kind": "hold", "duration_s": 600},
                        {"kind": "ramp", "to_c": 25.0, "rate_c_per_h": 90.0}],
            "nodes": [{"name": "core", "tau_s": 300.0},
                      {"name": "coil", "tau_s": 120.0, "input": "core"}],
            "sensors": [{"column": "T_amb_C", "node": "ambient"},
                        {"column": "T_core_C", "node": "core"}]}
    eff = {"thermal": [
        {"kind": "poly", "node": "core", "t_ref_c": 21.0, "D_T": 0.05, "D_T2": -0.002,
         "D_T3": 1e-4},
        {"kind": "rate", "node": "ambient", "D_Tdot": 0.8},
        {"kind": "gradient_rate", "nodes": ["core", "coil"], "D_gradTdot": -0.3},
    ]}
    sc = base(record={"sample_rate_hz": 1.0}, environment={"temperature": temp}, effects=eff)
    r = simulate(sc, seed=1).run
    e = r.env
    dT = e["T.core"] - 21.0
    X = np.column_stack([np.ones(r.n), dT, dT**2, dT**3, e["dTdt.ambient"],
                         e["dTdt.core"] - e["dTdt.coil"]])
    coef, *_ = np.linalg.lstsq(X, r.rate_dph, rcond=None)
    np.testing.assert_allclose(coef, [1.5, 0.05, -0.002, 1e-4, 0.8, -0.3], rtol=1e-9, atol=1e-11)
    # ambient ramp is 60 degC/h, the lagged core follows with d T/dt = (T_amb - T_core)/tau
    assert e["dTdt.ambient"][400] == pytest.approx(60.0)
    grad = np.gradient(e["T.core"], 1.0) * 3600.0
    np.testing.assert_allclose(grad[300:-10], e["dTdt.core"][300:-10], atol=0.2)
    # sensors with tau 0 and no noise read their node exactly
    np.testing.assert_allclose(r.columns["T_core_C"], e["T.core"])
    assert r.profile["columns"]["temperature"] == ["T_amb_C", "T_core_C"]
    assert r.truth["thermal"][2]["nodes"] == ["core", "coil"]


def test_antonova_matveev_preset():
    temp = {"initial_c": 21.0,
            "profile": [{"kind": "hold", "duration_s": 600},
                        {"kind": "staircase", "levels_c": [31.0, 35.0], "dwell_s": 1200,
                         "ramp_c_per_h": 60.0}]}
    sc = base(record={"sample_rate_hz": 1.0}, gyro={"output": "rate", "bias_dph": 0.0},
              environment={"temperature": temp},
              effects={"thermal": [{"kind": "antonova-matveev"}]})
    r = simulate(sc, seed=1).run
    am = ANTONOVA_MATVEEV
    assert (am["w0"], am["w1"], am["w2"], am["w_dV"], am["t0_c"]) == (1.197, 0.108, 0.004,
                                                                      1.997, 21.0)
    t = r.truth["thermal"][0]
    assert (t["w0"], t["w1"], t["w2"], t["w_dV"], t["t0_c"]) == (1.197, 0.108, 0.004, 1.997, 21.0)
    T, dT = r.env["T.ambient"], r.env["dTdt.ambient"]
    model = 1.197 + 0.108 * (T - 21) + 0.004 * (T - 21) ** 2 + 1.997 * dT
    np.testing.assert_allclose(r.rate_dph, model, rtol=1e-12)
    # on the 31 degC set-point: 1.197 + 1.08 + 0.4 ; on the ramp to it (60 degC/h): + 119.82
    assert window_mean(r.t, r.rate_dph, 1300, 1800) == pytest.approx(2.677)
    dT700 = (700.5 - 600.0) / 60.0  # interval 700 has its midpoint at 700.5 s, on the ramp
    assert r.rate_dph[700] == pytest.approx(1.197 + 0.108 * dT700 + 0.004 * dT700**2
                                            + 1.997 * 60.0)


def test_hysteresis_heating_minus_cooling():
    temp = {"initial_c": 20.0,
            "profile": [{"kind": "sine", "amplitude_c": 10.0, "period_s": 2000, "cycles": 2}]}
    sc = base(record={"sample_rate_hz": 1.0}, gyro={"output": "rate", "bias_dph": 0.0},
              environment={"temperature": temp},
              effects={"thermal": [{"kind": "hysteresis", "node": "ambient",
                                    "amplitude_dph": 0.4, "width_c": 1.0}]})
    r = simulate(sc, seed=1).run
    heating = r.env["dTdt.ambient"] > 5.0
    cooling = r.env["dTdt.ambient"] < -5.0
    # away from the reversals the branches are +-amplitude/2
    assert np.median(r.rate_dph[heating]) == pytest.approx(0.2)
    assert np.median(r.rate_dph[cooling]) == pytest.approx(-0.2)
    assert np.all(np.abs(r.rate_dph) <= 0.2 + 1e-12)


# ------------------------------------------------------------------ field, supply, warm-up


def test_helmholtz_sequence_and_reversal_coefficients():
    w = [-0.037, -0.576, -0.253]
    sc = base(environment={"field": {"helmholtz": {}}},
              effects={"magnetic": {"w_dph_per_100uT": w}},
              gyro={"output": "rate", "bias_dph": 0.2}, record={"sample_rate_hz": 1.0})
    res = simulate(sc, seed=1)
    r = res.run
    helm = r.truth["magnetic"]["helmholtz"]
    levels = [h["level_uT"] for h in helm if h["axis"] == "x"]
    assert levels[:8] == [0, 50, 100, 150, 200, 250, 300, 250]
    assert len(levels) == 25 and levels[-1] == 0 and min(levels) == -300
    assert r.n == 3 * 25 * 180  # duration from the sequence
    for ax, wi in zip("xyz", w):
        plus = next(h for h in helm if h["axis"] == ax and h["level_uT"] == 300)
        minus = next(h for h in helm if h["axis"] == ax and h["level_uT"] == -300)
        d = window_mean(r.t, r.rate_dph, plus["start_s"], plus["end_s"]) - window_mean(
            r.t, r.rate_dph, minus["start_s"], minus["end_s"])
        assert abs(d) / 6 == pytest.approx(abs(wi), rel=1e-9)  # K = dw/6 (seed 002)
    i = {"x": 0, "y": 1, "z": 2}
    H = r.env["H_uT"]
    np.testing.assert_allclose(r.rate_dph - 0.2, sum(w[i[a]] * H[i[a]] / 100 for a in "xyz"),
                               atol=1e-12)
    np.testing.assert_allclose(r.columns["Hy_uT"], H[1])


def test_supply_steps_and_warmup():
    sc = base(record={"sample_rate_hz": 10.0, "duration_s": 200.0},
              gyro={"output": "rate", "bias_dph": 0.0},
              environment={"supply": {"nominal_v": 15.0, "steps": [[100.0, 14.0]],
                                      "ripple_v": 0.5, "ripple_hz": 50.0}},
              effects={"supply": {"dph_per_v": 0.25},
                       "warmup": {"amplitude_dph": 3.0, "tau_s": 20.0}})
    r = simulate(sc, seed=1).run
    # 50 Hz ripple averaged over 0.1 s intervals vanishes; step of -1 V -> -0.25 deg/h
    assert window_mean(r.t, r.rate_dph, 150, 200) == pytest.approx(-0.25 + 3 * math.exp(-175 / 20),
                                                                   abs=1e-3)
    # interval k = 200 has its midpoint at 20.05 s
    assert r.components["warmup"][200] == pytest.approx(3.0 * math.exp(-20.05 / 20.0), rel=1e-12)
    np.testing.assert_allclose(r.columns["vsupply"][:999], 15.0, atol=1e-9)


# ------------------------------------------------------------------ scale factor / rate table


def _table(rates, **sf):
    return base(record={"sample_rate_hz": 20.0},
                gyro={"output": "rate", "bias_dph": 0.5},
                rate_table={"rates_dps": rates, "dwell_s": 30.0, "settle_tau_s": 0.3,
                            "exclude_s": 5.0},
                effects={"scale_factor": sf})


def test_sf_offset_and_asymmetry_truth():
    r = simulate(_table([0, 10, -10, 50, -50], offset_ppm=100.0, asymmetry_ppm=40.0),
                 seed=1)
    sf = r.truth["scale_factor"]
    sp, sm = 1 / (1 + 20e-6 + 100e-6), 1 / (1 - 20e-6 + 100e-6)  # ε_K += ½A·sgn(I)
    assert sf["asymmetry_method"] == "separate lines"
    assert sf["sf_plus"] == pytest.approx(sp, rel=1e-8)
    assert sf["sf_minus"] == pytest.approx(sm, rel=1e-8)
    # SF column convention: SF = 1/slope (input per output), A = (SF+ − SF−)/SF̄
    assert sf["asymmetry_ppm"] == pytest.approx((1 / sp - 1 / sm) / (0.5 * (1 / sp + 1 / sm)) * 1e6,
                                                abs=2e-3)
    assert sf["asymmetry_ppm"] == pytest.approx(40.0, rel=1e-3)
    # the table column is the commanded rate in deg/s
    assert r.profile["columns"]["table_rate"] == "table_dps"
    assert set(np.unique(r.columns["table_dps"])) == {0.0, 10.0, -10.0, 50.0, -50.0}


def test_sf_linear_gyro_has_zero_linearity_error_and_known_sf():
    r = simulate(_table([1, -1, 10, -10, 100, -100], offset_ppm=-50.0), seed=1)
    sf = r.truth["scale_factor"]
    assert sf["sf"] == pytest.approx(1 / (1 - 50e-6), rel=1e-8)  # settling leaves < 1e-9
    assert sf["linearity_max_ppm_fs"] < 1e-3
    assert abs(sf["asymmetry_ppm"]) < 1e-3
    # plateau means settle: noise-free mean = SF * (input + earth + bias)
    for p in sf["plateaus"]:
        assert p["noise_free_mean_dph"] == pytest.approx(
            (p["input_dph"] + 0.5) / (1 - 50e-6), rel=1e-7, abs=1e-6)


def test_sf_nonlinearity_residuals_follow_definition():
    r = simulate(_table([100, -100, 50, -50, 25, -25, 0], nonlinearity_ppm=[0.0, 0.0, 200.0],
                        full_scale_dps=100.0), seed=1)
    sf = r.truth["scale_factor"]
    x = np.array([p["input_dph"] for p in sf["plateaus"]])
    y = np.array([p["noise_free_mean_dph"] for p in sf["plateaus"]])
    slope, icpt = np.polyfit(x, y, 1)
    res = y - (slope * x + icpt)
    assert sf["sf"] == pytest.approx(slope, rel=1e-12)
    assert sf["linearity_max_ppm_fs"] == pytest.approx(
        np.max(np.abs(res)) / (slope * 360000.0) * 1e6, rel=1e-9)
    assert sf["linearity_1sigma_ppm_fs"] == pytest.approx(
        np.sqrt(np.mean(res**2)) / (slope * 360000.0) * 1e6, rel=1e-9)
    assert 10 < sf["linearity_max_ppm_fs"] < 200


def test_sf_runs_and_reversed_unequal_plateaus():
    sc = _table([-100, -10, 10, 100], offset_ppm=0.0)
    sc["rate_table"]["dwell_s"] = [40.0, 20.0, 25.0, 60.0]
    sc["runs"] = {"count": 3, "sf_offsets_ppm": [0.0, 10.0, -20.0],
                  "bias_offsets_dph": [0.0, 0.1, -0.1]}
    res = simulate(sc, seed=3)
    assert len(res.runs) == 3
    sfs = np.array(res.summary["sf_repeatability"]["sf"])
    np.testing.assert_allclose(sfs, 1 / (1 + np.array([0.0, 10.0, -20.0]) * 1e-6), rtol=1e-8)
    assert res.runs[1].truth["bias"]["D_F_dph"] == pytest.approx(0.6)
    assert res.summary["sf_repeatability"]["max_spread_ppm"] == pytest.approx(30.0, rel=1e-3)
    assert res.runs[0].n == 145 * 20


def test_lock_in_dead_band():
    sc = _table([0.001, 0.01, 0.1], lock_in_dph=20.0)
    sc["gyro"]["bias_dph"] = 0.0
    sc["site"] = {"latitude_deg": 0.0, "ia": "east"}
    r = simulate(sc, seed=1).run
    p = r.truth["scale_factor"]["plateaus"]
    assert p[0]["noise_free_mean_dph"] == 0.0  # 3.6 deg/h < 20 deg/h: locked
    assert p[1]["noise_free_mean_dph"] == pytest.approx(math.sqrt(36.0**2 - 20.0**2), rel=1e-6)
    assert p[2]["noise_free_mean_dph"] == pytest.approx(math.sqrt(360.0**2 - 20.0**2), rel=1e-6)


# ------------------------------------------------------------------ output encodings


def test_pulse_quantization_with_remainder_carry():
    sc = base(gyro={"output": "counts", "scale_factor": 0.5, "bias_dph": 3.3,
                    "noise": {"N": 0.05}})
    r = simulate(sc, seed=4).run
    counts = r.columns["pulses"]
    assert counts.dtype.kind == "i"
    # the accumulated angle error stays within one pulse: remainder carried, never lost
    err = np.cumsum(r.ideal_rate_dph * r.tau0) - np.cumsum(counts) * 0.5
    assert err.min() > -0.5 - 1e-9 and err.max() < 0.5 + 1e-9
    np.testing.assert_allclose(r.rate_dph, counts * 0.5 / r.tau0)
    assert r.truth["noise"]["Q"] == pytest.approx(0.5 / math.sqrt(12))


@pytest.mark.parametrize("bits", [16, 32])
@pytest.mark.parametrize("ia", ["up", "down"])
def test_counter_rolls_over_and_unwraps_to_the_counts(bits, ia):
    sc = base(record={"sample_rate_hz": 50.0, "duration_s": 120.0},
              gyro={"output": "counter", "scale_factor": 0.01, "counter_bits": bits,
                    "bias_dph": 500.0 if ia == "up" else -500.0, "noise": {"N": 0.5}},
              site={"latitude_deg": 48.137, "ia": ia})
    r = simulate(sc, seed=2).run
    cnt = r.columns["cnt"]
    assert cnt.size == r.n + 1 and cnt.min() >= 0 and cnt.max() < 2**bits
    assert r.truth["output"]["rollovers"] >= 1
    d = np.mod(np.diff(cnt) + 2 ** (bits - 1), 2**bits) - 2 ** (bits - 1)
    np.testing.assert_array_equal(d, np.round(r.rate_dph * r.tau0 / 0.01))
    assert np.max(np.abs(d)) > 0
    # the time column has the extra origin row
    assert r.columns["t_s"][0] == 0.0 and r.columns["t_s"][1] == pytest.approx(r.tau0)


def test_counter_overflow_is_an_input_error():
    sc = base(gyro={"output": "counter", "scale_factor": 0.001, "counter_bits": 16,
                    "bias_dph": 1e7})
    with pytest.raises(InputError, match="counter_bits"):
        simulate(sc, seed=1)


def test_updown_pairs_carry_common_dither():
    sc = base(gyro={"output": "updown", "scale_factor": 1.0, "dither_counts": 40.0,
                    "bias_dph": 0.0, "noise": {"N": 2.0}},
              record={"sample_rate_hz": 100.0, "duration_s": 60.0})
    r = simulate(sc, seed=1).run
    up, down = r.columns["up"], r.columns["down"]
    np.testing.assert_array_equal(up - down, np.round(r.rate_dph * r.tau0))
    assert np.mean(np.minimum(up, down)) == pytest.approx(40.0, rel=0.05)
    assert r.profile["columns"]["up"] == "up" and r.profile["columns"]["down"] == "down"


def test_voltage_adc_grid():
    sc = base(gyro={"output": "voltage", "scale_factor": 100.0, "offset_v": 2.5,
                    "adc_bits": 12, "adc_range_v": [0.0, 5.0], "bias_dph": 30.0,
                    "noise": {"N": 0.2}})
    r = simulate(sc, seed=1).run
    v = r.columns["v_out"]
    lsb = 5.0 / 4096
    np.testing.assert_allclose(v / lsb, np.round(v / lsb), atol=1e-9)
    np.testing.assert_allclose(r.rate_dph, (v - 2.5) * 100.0)
    assert np.max(np.abs(r.rate_dph - r.ideal_rate_dph)) <= 0.5 * lsb * 100.0 + 1e-9
    assert r.truth["noise"]["N_adc"] == pytest.approx(lsb * 100 * math.sqrt(0.1 / 12) / 60)


# ------------------------------------------------------------------ files and ingest


KINDS = [
    {"output": "rate", "rate_unit": "deg/h"},
    {"output": "rate", "rate_unit": "rad/s"},
    {"output": "rate", "rate_unit": "mrad/s"},
    {"output": "counts", "scale_factor": 0.2},
    {"output": "updown", "scale_factor": 1.5, "dither_counts": 20.0},
    {"output": "counter", "scale_factor": 0.05, "counter_bits": 16},
    {"output": "counter", "scale_factor": 0.05, "counter_bits": 32},
    {"output": "voltage", "scale_factor": 50.0, "offset_v": 2.5, "adc_bits": 16},
]


@pytest.mark.parametrize("fmt", ["csv", "parquet", "feather"])
@pytest.mark.parametrize("gyro", KINDS, ids=lambda g: f"{g['output']}-{g.get('rate_unit', '')}"
                         f"{g.get('counter_bits', '')}")
def test_write_and_ingest_round_trip(tmp_path, gyro, fmt):
    g = {**gyro, "bias_dph": 20.0, "noise": {"N": 0.5}, "model": "X1", "serial": "7"}
    sc = base(gyro=g, record={"sample_rate_hz": 50.0, "duration_s": 40.0},
              environment={"temperature": {"sensors": [{"column": "T_case_C",
                                                        "noise_c": 0.01}]}})
    res = simulate(sc, seed=3)
    w = write_log(res, tmp_path / f"log.{fmt}")
    assert w.logs == [tmp_path / f"log.{fmt}"]
    assert w.truths == [tmp_path / "log.truth.json"]
    assert w.profiles == [tmp_path / "log.profile.toml"]
    log = read_log(w.logs[0], profile=load_profile(w.profiles[0]))
    rate = next(iter(log.rates.values()))
    np.testing.assert_allclose(rate, res.rate_dph, rtol=1e-12, atol=1e-9)
    assert log.tau0 == pytest.approx(0.02)
    np.testing.assert_allclose(log.temperature["T_case_C"],
                               res.columns["T_case_C"][-res.run.n:])
    assert log.site.earth_rate_dph() == pytest.approx(res.truth["earth"]["earth_rate_ia_dph"])
    assert log.gyro.model == "X1"
    # truth JSON round trip
    truth = json.loads(w.truths[0].read_text())
    expect = jsonable(res.truth)
    expect["files"] = {"log": f"log.{fmt}", "profile": "log.profile.toml", "format": fmt}
    assert truth == expect
    # no temporary files left behind
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        [f"log.{fmt}", "log.truth.json", "log.profile.toml"])


def test_truth_units_and_profile_keys(tmp_path):
    sc = base(gyro={"output": "counts", "scale_factor": 0.1,
                    "noise": {"N": 0.01, "B": 0.02, "B_f0_hz": 0.5, "K": 0.003, "R": 0.01,
                              "Q": 0.05}})
    res = simulate(sc, seed=1)
    n = res.truth["noise"]
    assert n["units"] == {"N": "deg/sqrt(h)", "B": "deg/h", "B_f0_hz": "Hz",
                          "K": "deg/h/sqrt(h)", "R": "deg/h/h", "Q": "arcsec"}
    assert (n["N"], n["B"], n["B_f0_hz"], n["K"], n["R"]) == (0.01, 0.02, 0.5, 0.003, 0.01)
    assert n["Q"] == pytest.approx(math.hypot(0.05, 0.1 / math.sqrt(12)))
    keys = [c[0] for c in n["components"]]
    assert keys == ["arw", "bias_instability", "rrw", "rate_ramp", "quantization"]
    prof = tomllib.loads((write_log(res, tmp_path / "x.csv").profiles[0]).read_text())
    assert prof["columns"] == {"time": "t_s", "counts": "pulses"}
    assert prof["gyro"] == {"scale_factor": 0.1}
    assert prof["site"] == {"latitude_deg": 48.137, "ia": "east"}


def test_multi_run_files(tmp_path):
    sc = base(runs={"count": 2, "sf_sigma_ppm": 5.0, "bias_sigma_dph": 0.01},
              gyro={"output": "rate", "noise": {"N": 0.1}})
    w = write_log(simulate(sc, seed=1), tmp_path / "r.parquet")
    assert [p.name for p in w.logs] == ["r_run1.parquet", "r_run2.parquet"]
    assert [p.name for p in w.truths] == ["r_run1.truth.json", "r_run2.truth.json"]
    summary = json.loads((tmp_path / "r.truth.json").read_text())
    assert len(summary["runs"]) == 2 and summary["files"][1]["log"] == "r_run2.parquet"
    assert summary["bias_repeatability"]["one_sigma_dph"] > 0
    res = simulate(sc, seed=1)
    d = json.loads(json.dumps(res.to_dict(include_data=True), allow_nan=False))
    assert d["runs"][1]["run"] == 2 and len(d["runs"][0]["data"]["omega_dph"]) == 600


def test_faults_gaps_duplicates_iso_time(tmp_path):
    sc = base(record={"sample_rate_hz": 20.0, "duration_s": 120.0},
              gyro={"output": "counts", "scale_factor": 0.2, "noise": {"N": 0.05}},
              file={"time": "iso", "start_iso": "2024-05-01T08:00:00",
                    "faults": {"drop": [[30.0, 5.0]], "drop_random": 1, "jitter_s": 1e-4,
                               "duplicate_rows": 2}})
    res = simulate(sc, seed=2)
    f = res.truth["file"]
    assert f["dropped_rows"] == 100 + 1
    assert f["rows"] == 2400 - 101 + 2
    assert any(g["duration_s"] == pytest.approx(5.05) for g in f["gaps"])
    assert len(f["duplicated_rows"]) == 2
    ts = res.columns["timestamp"]
    assert ts[0].startswith("2024-05-01T08:00:00.0")
    w = write_log(res, tmp_path / "f.csv")
    log = read_log(w.logs[0], profile=load_profile(w.profiles[0]))
    assert log.timing.duplicates_dropped == 2
    assert len(log.timing.gaps) == 2
    assert log.timing.start.startswith("2024-05-01T08:00:00")


def test_no_time_column_profile_has_sample_rate(tmp_path):
    sc = base(file={"time": "none"}, gyro={"output": "rate", "noise": {"N": 0.1}})
    res = simulate(sc, seed=1)
    assert list(res.columns) == ["omega_dph"]
    w = write_log(res, tmp_path / "n.csv")
    prof = load_profile(w.profiles[0])
    assert prof.gyro["sample_rate_hz"] == 10.0
    log = read_log(w.logs[0], profile=prof)
    np.testing.assert_allclose(log.rates["omega_dph"], res.rate_dph)


# ------------------------------------------------------------------ scenario files and errors


@pytest.mark.parametrize("path", SCENARIOS, ids=lambda p: Path(p).stem)
def test_sample_scenarios_load(path):
    sc = load_scenario(path)
    assert sc.name
    for table in ("six_position", "counter16", "helmholtz", "antonova_thermal"):
        if Path(path).stem == table:
            res = simulate(path)
            assert res.run.n > 0


def test_docstring_example_parses_and_runs():
    import gyrotest.simulation as S

    block = S.__doc__.split(".. code-block:: toml")[1].split("Files written beside")[0]
    text = "\n".join(ln[4:] if ln.startswith("    ") else ln for ln in block.splitlines())
    data = tomllib.loads(text)
    data["record"]["sample_rate_hz"] = 4.0
    data["record"]["duration_s"] = 600
    res = simulate(data, seed=1)
    assert len(res.runs) == 3


@pytest.mark.parametrize(("patch", "fragments"), [
    ({"gyro": {"outptu": "rate"}}, ["unknown key 'outptu'", "[gyro]"]),
    ({"gyro": {"output": "pulses"}}, ["[gyro] output", "rate, counts"]),
    ({"gyro": {"output": "counts"}}, ["scale_factor", "arcsec/pulse"]),
    ({"gyro": {"noise": {"B": 0.1, "B_f0_hz": 20.0}}}, ["B_f0_hz", "Nyquist"]),
    ({"effects": {"thermal": [{"kind": "poly", "node": "core", "D_T": 1.0}]}},
     ["node 'core'", "nodes"]),
    ({"file": {"time": "none", "faults": {"drop_random": 1}}}, ["faults", "time column"]),
    ({"record": {"duration_s": "ten minutes"}}, ["duration"]),
    ({"site": {"latitude_deg": 95.0}}, ["latitude"]),
    ({"site": {"ia": "northeast"}}, ["ia", "northeast"]),
    ({"rate_table": {"rates_dps": [1, 2], "dwell_s": [10, 20, 30]}}, ["dwell_s"]),
    ({"gyro": {"noise": {"markov": [{"q_c": 1.0}]}}}, ["T_c", "missing"]),
    ({"bogus": {}}, ["unknown key 'bogus'"]),
])
def test_scenario_errors_are_input_errors(patch, fragments):
    sc = base()
    for k, v in patch.items():
        sc[k] = {**sc.get(k, {}), **v} if isinstance(v, dict) else v
    with pytest.raises(InputError) as ei:
        simulate(sc, seed=1)
    msg = str(ei.value)
    assert "\n" not in msg
    for f in fragments:
        assert f.lower() in msg.lower(), msg


def test_missing_duration_and_bad_file(tmp_path):
    with pytest.raises(InputError, match="duration_s"):
        simulate({"gyro": {"output": "rate"}}, seed=1)
    with pytest.raises(InputError, match="not found"):
        simulate(tmp_path / "nope.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[gyro\n")
    with pytest.raises(InputError, match="invalid TOML"):
        simulate(bad)


def test_readme_format_block_matches_the_module_docstring():
    import gyrotest.simulation as S

    readme = (ROOT / "sample_data" / "scenarios" / "README.md").read_text()
    block = readme.split("```toml\n")[1].split("```")[0]
    doc = S.__doc__.split(".. code-block:: toml")[1].split("Files written beside")[0]
    doc = "\n".join(ln[4:] if ln.startswith("    ") else ln for ln in doc.splitlines())
    assert tomllib.loads(block) == tomllib.loads(doc)
