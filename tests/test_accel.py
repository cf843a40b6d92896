"""Accelerometers beside the gyros (issue 58, items 6–7): columns in g are accelerations, the
Allan analysis of the accelerometer axes with IEEE Std 1293 terms (closed forms, a simulated
IMU with Kalibr's model, AllanTools), the Kalibr/accelparams/Stable32 exports and the
spec-sheet section; output quantisation in ``info``; thermal-fit on a real log with no
temperature effect finds none."""

from __future__ import annotations

import gzip
import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from test_noise_fit import table_from_model

from gyrotest.io.accel import accel_channels, is_accel_name
from gyrotest.noise.noisefit import fit_noise_model
from gyrotest.noise.resolution import output_resolution

from cliutil import run_cli

G0 = 9.80665
ADIS = (Path(__file__).parents[2] / "shared" / "reference" / "data" / "realdata" / "data"
        / "adis16405_imu1.csv.gz")


@pytest.fixture(scope="module")
def imu_log(tmp_path_factory):
    """4 h at 10 Hz: a gyro (white, deg/s) and three accelerometers in g with Kalibr's model
    (ethz-asl/kalibr wiki "IMU Noise Model"): white σ_d = n_a/√Δt and a bias random walk
    b_{k+1} = b_k + b_a·√Δt·w, n_a = 1e-3 m/s²/√Hz, b_a = 2e-5 m/s³/√Hz; gravity on z."""
    d = tmp_path_factory.mktemp("imu")
    rng = np.random.default_rng(58)
    fs, n = 10.0, 144_000
    dt = 1.0 / fs
    na, ba = 1.0e-3, 2.0e-5
    t = np.arange(n) * dt
    cols = [t, rng.normal(0.0, 0.01, n)]
    for mean in (0.0, 0.0, -G0):
        a = mean + na / math.sqrt(dt) * rng.standard_normal(n) + np.cumsum(
            ba * math.sqrt(dt) * rng.standard_normal(n))
        cols.append(a / G0)
    p = d / "imu.csv"
    np.savetxt(p, np.column_stack(cols), delimiter=",", header="time,gx_dps,ax_g,ay_g,az_g",
               comments="", fmt="%.10g")
    r = run_cli(["allan", str(p), "--json", "--no-diagnose"])
    assert r.code == 0, r.err
    j = d / "allan.json"
    j.write_text(r.out)
    return p, j, na, ba


def test_accelerometer_names_and_units(tmp_path):
    for name in ("ax", "ay_g", "acc_z", "accel_x_mps2", "a_y", "linear_acceleration_z",
                 "lin_acc_x", "ax [g]"):
        assert is_accel_name(name), name
    for name in ("gx", "gyro_x_dps", "hx_g", "axis", "alpha", "temp_ax"):
        assert not is_accel_name(name), name
    n = 500
    p = tmp_path / "g.csv"
    rng = np.random.default_rng(1)
    np.savetxt(p, np.column_stack([np.arange(n) * 0.01, rng.normal(size=n),
                                   0.01 + 1e-3 * rng.normal(size=n), np.full(n, 0.2),
                                   np.full(n, 0.1), np.full(n, 0.4)]),
               delimiter=",", header="time,gx_dps,az_g,hx_g,hy_g,hz_g", comments="")
    r = run_cli(["info", str(p), "--json"])
    assert r.code == 0, r.err
    d = json.loads(r.out)
    assert d["accelerometers"]["units_read"] == {"az_g": "g"}  # _g: standard gravity
    assert d["channels"]["field:hx_g"]["mean"] == pytest.approx(20.0)  # a field's _g: gauss
    # no unit and no gravity to read it from: named, not analysed
    from gyrotest.core.data import GyroConstants, GyroLog, Timing

    log = GyroLog("x", {"g": np.zeros(n)}, 0.01, Timing(n, 0.01, n * 0.01, "t"),
                  GyroConstants("rate"), extra={"ax": np.zeros(n), "ay": np.ones(n)})
    acc = accel_channels(log)
    assert not acc and "unit unknown" in acc.notes[0]
    log.extra["az"] = np.full(n, 9.8)
    acc = accel_channels(log)
    assert acc.units == {"ax": "m/s^2", "ay": "m/s^2", "az": "m/s^2"}
    assert "gravity" in acc.notes[0]


def test_ieee1293_terms_from_closed_forms():
    """A noise-free Allan table in m/s² (σ² = n²/τ + 0.664² b² + k²τ/3, the registry's white,
    flicker and random-walk forms): the fit reports VRW = 60·n m/s/√h, B = b/9.80665e-6 µg,
    K = 216000·k m/s/h/√h."""
    n_s, b, k = 1.0e-3, 2.0e-4, 5.0e-6  # m/s²·√s, m/s², m/s²/√s
    comps = [("arw", {"N": n_s / 60.0}), ("bias_instability", {"B": b, "f0": 1e9}),
             ("rrw", {"K": k * 60.0})]
    tau, sig, edf, lo, hi = table_from_model(comps, tau0=0.01, n=4_000_000)
    kw = dict(sigma_lo=lo, sigma_hi=hi, terms="N,B,K", tau0=0.01)
    f = fit_noise_model(tau, sig, edf, quantity="acceleration", **kw)
    gyro = fit_noise_model(tau, sig, edf, **kw)  # the same numbers read as a gyro's
    assert f.term("N").value == pytest.approx(60.0 * n_s, rel=1e-3)
    assert f.term("B").value == pytest.approx(b / (G0 * 1e-6), rel=1e-2)
    # K sits where the EDF is small: the log-χ² likelihood's small-EDF terms bias a
    # noise-free table by a few %; the conversion itself is exact
    assert f.term("K").value == pytest.approx(216000.0 * k, rel=0.06)
    for key, factor in (("N", 3600.0), ("B", 1 / (G0 * 1e-6)), ("K", 3600.0)):
        assert f.term(key).value == pytest.approx(factor * gyro.term(key).value, rel=1e-9)
        assert f.term(key).sigma[key] == pytest.approx(factor * gyro.term(key).sigma[key],
                                                       rel=1e-9)
    assert f.term("N").units == {"N": "m/s/sqrt(h)"} and f.term("B").units == {"B": "ug"}
    assert f.term("N").title == "VRW"


def test_allan_of_the_accelerometers_and_the_exports(imu_log, tmp_path):
    log, allan_json, na, ba = imu_log
    doc = json.loads(allan_json.read_text())
    axes = {a["axis"]: a for a in doc["logs"][0]["axes"]}
    assert set(axes) == {"gx_dps", "ax_g", "ay_g", "az_g"}
    ax = axes["ax_g"]
    assert ax["quantity"] == "acceleration" and ax["deviation"]["unit"] == "m/s^2"
    assert ax["impact"] is None and axes["gx_dps"]["impact"] is not None
    n = next(t for t in ax["fit"]["terms"] if t["key"] == "N")
    assert n["params"]["N"] == pytest.approx(60.0 * na, rel=0.03)  # VRW m/s/√h
    kal = ax["conversions"]["kalibr"]
    assert kal["accelerometer_noise_density"] == pytest.approx(na, rel=0.03)
    assert ax["conversions"]["N"]["ug_per_rt_hz"] == pytest.approx(na / (G0 * 1e-6), rel=0.03)
    # Kalibr: measured, not placeholders
    out = tmp_path / "imu.yaml"
    r = run_cli(["export", "kalibr", str(allan_json), "-o", str(out)])
    assert r.code == 0, r.err
    assert "PLACEHOLDER" not in out.read_text() + r.err
    y = yaml.safe_load(out.read_text())
    assert y["accelerometer_noise_density"] == pytest.approx(na, rel=0.03)
    assert y["accelerometer_random_walk"] == pytest.approx(ba, rel=0.35)
    assert y["gyroscope_noise_density"] > 0
    # accelparams (.m and .mat) and gyroparams of the same document
    m = tmp_path / "accel.m"
    r = run_cli(["export", "accelparams", str(allan_json), "-o", str(m)])
    assert r.code == 0, r.err
    txt = m.read_text()
    assert "accelparams(" in txt and "'Accelerometer'" in txt
    from scipy.io import loadmat

    mat = tmp_path / "accel.mat"
    assert run_cli(["export", "accelparams", str(allan_json), "-o", str(mat)]).code == 0
    s = loadmat(mat, squeeze_me=True)["accelparams"]
    assert np.allclose(s["NoiseDensity"].item(), [kal["accelerometer_noise_density"]] + [
        axes[a]["conversions"]["kalibr"]["accelerometer_noise_density"]
        for a in ("ay_g", "az_g")], rtol=1e-9)
    r = run_cli(["export", "gyroparams", str(allan_json), "-o", str(tmp_path / "g.m")])
    assert r.code == 0, r.err  # the gyro axis alone
    s32 = tmp_path / "s.txt"
    assert run_cli(["export", "stable32", str(allan_json), "-o", str(s32),
                    "--axis", "az_g"]).code == 0
    assert "acceleration; sigma in m/s^2" in s32.read_text()


def test_accelerometer_table_matches_allantools(imu_log):
    at = pytest.importorskip("allantools")
    from gyrotest.io.ingest import read_log
    from gyrotest.noise.analysis import analyse_allan

    log, _, _, _ = imu_log
    g = read_log(log)
    a = analyse_allan(g, axes=["ay_g"], fit_model=False, spectral=False).axes[0]
    x = accel_channels(g).data["ay_g"]
    _, ad, _, _ = at.oadev(x, rate=10.0, data_type="freq", taus=a.dev.tau)
    assert np.allclose(a.dev.sigma, ad, rtol=1e-9)


def test_spec_sheet_section_when_the_campaign_asks(tmp_path):
    rng = np.random.default_rng(7)
    n, na = 12_000, 1.0e-3  # 20 min at 10 Hz, white acceleration noise of density na
    log = tmp_path / "imu.csv"
    np.savetxt(log, np.column_stack([np.arange(n) * 0.1, rng.normal(0, 0.01, n)]
                                    + [(m + na / math.sqrt(0.1) * rng.standard_normal(n)) / G0
                                       for m in (0.0, 0.0, -G0)]),
               delimiter=",", header="time,gx_dps,ax_g,ay_g,az_g", comments="", fmt="%.10g")
    camp = tmp_path / "c.toml"
    camp.write_text(f'''[campaign]
title = "IMU"
operator = "t"
date = 2024-05-12
[gyro]
model = "IMU-1"
serial = "1"
[tests.accel]
log = "{log}"
limits = {{ N = {2 * 60 * na}, B = 500 }}
''')
    r = run_cli(["report", str(camp)])
    assert r.code == 0, r.err
    assert "Accelerometer noise (IEEE Std 1293)" in r.out
    assert "velocity random walk VRW, ax_g" in r.out and "µg/√Hz" in r.out
    rows = [ln for ln in r.out.splitlines() if ln.startswith("| velocity random walk VRW")]
    assert len(rows) >= 3 and all(ln.rstrip(" |").endswith("PASS") for ln in rows), rows


# ----------------------------------------------------------------------------- item 6
def test_info_reports_the_output_quantisation(tmp_path):
    """The LSB and its share of the noise: an MPU-6050-like output (27.5 deg/h per count, noise
    ≈ 127 deg/h) and a coarse one with 5 levels."""
    rng = np.random.default_rng(6)
    x = np.round((50.0 + rng.normal(0, 127.0, 20_000)) / 27.5) * 27.5
    r = output_resolution(x, tau0=0.01)
    assert r["lsb"] == pytest.approx(27.5) and not r["coarse"]
    assert r["share"] == pytest.approx(27.5**2 / 12 / 127.0**2, rel=0.1)
    assert r["N_q_deg_rt_h"] == pytest.approx(27.5 * math.sqrt(0.01 / 12) / 60)
    assert output_resolution(rng.normal(size=5000)) is None  # a float output
    y = np.round(rng.normal(0, 0.45, 5000))
    r = output_resolution(y, tau0=1.0)
    assert r["levels"] <= 7 and r["coarse"]
    p = tmp_path / "coarse.csv"
    np.savetxt(p, np.column_stack([np.arange(y.size) * 0.1, y]), delimiter=",",
               header="time,rate_dps", comments="")
    out = run_cli(["info", str(p)])
    assert out.code == 0, out.err
    assert "output quantised: LSB" in out.out and "coarse" in out.out


@pytest.mark.skipif(not ADIS.exists(), reason="shared real records not available")
def test_real_adis_lsb_and_no_thermal_effect_found():
    """The real ADIS16405 gyro: values are multiples of 0.05 °/s = 180 °/h (the provenance's
    LSB); with a room temperature that cycles ±0.5 °C (10 min HVAC period) independently of
    the gyro, thermal-fit finds no temperature term on any axis."""
    from gyrotest.core.data import GyroConstants, GyroLog, Timing
    from gyrotest.envmodel.domain import analyse_thermal

    with gzip.open(ADIS, "rt") as fh:
        a = np.loadtxt(fh, delimiter=",", skiprows=1, usecols=(1, 2, 3), max_rows=360_000)
    for j in range(3):
        x = a[:, j] * 3600.0
        r = output_resolution(x, tau0=0.01)
        assert r["lsb"] == pytest.approx(180.0) and r["uniform_model"]
        n = x.size
        t = np.arange(n) * 0.01
        temp = 22 + 0.5 * np.sin(2 * np.pi * t / 600) + 0.05 * np.random.default_rng(j).normal(
            size=n)
        log = GyroLog("adis", {"g": x}, 0.01, Timing(n, 0.01, n * 0.01, "t"),
                      GyroConstants("rate"), temperature={"T_C": temp})
        coefs = analyse_thermal(log).chamber.to_dict()["am_fit"]["coefficients"]
        assert all(c["significance"] == "not significant" for c in coefs
                   if c["name"] != "bias"), coefs
