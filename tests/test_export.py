"""``gyrotest export``: every deliverable read back by its peer's own loader and checked against
an independent value.

* Kalibr imu.yaml → ``yaml.safe_load``; densities = closed-form unit conversion of N, K, and
  end to end: a log simulated with Kalibr's own discrete model (σ_d = density/√Δt, bias
  walk step = random_walk·√Δt) comes back with the densities it was made with.
* Malformed inputs and unwritable outputs → one-line error, exit 2, nothing written.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

import numpy as np
import pytest

from cliutil import run_cli

yaml = pytest.importorskip("yaml")

SAMPLE = Path(__file__).parents[1] / "sample_data"


@pytest.fixture(scope="module")
def allan_json(tmp_path_factory) -> Path:
    """``gyrotest allan --json`` of the sample static run (10 Hz FOG, 6 h)."""
    out = tmp_path_factory.mktemp("allan") / "allan.json"
    r = run_cli(["allan", SAMPLE / "static.parquet", "--profile", SAMPLE / "static.profile.toml",
                 "--skip", "30min", "--json"])
    assert r.code == 0, r.err
    out.write_text(r.out)
    return out


def _axis(doc: dict) -> dict:
    return doc["logs"][0]["axes"][0]


def _term(ax: dict, key: str) -> tuple[float, str]:
    fit = (ax.get("diagnosis") or {}).get("final_fit") or ax["fit"]
    t = next(t for t in fit["terms"] if t["key"] == key)
    v = t["params"][key] if t["status"] == "identified" else t["upper_95"]
    return v, t["status"]


# ----------------------------------------------------------------------------- Kalibr
def test_kalibr_roundtrip_and_closed_form(allan_json, tmp_path):
    out = tmp_path / "imu.yaml"
    r = run_cli(["export", "kalibr", allan_json, "-o", out, "--rostopic", "/gyro/imu"])
    assert r.code == 0, r.err
    assert "PLACEHOLDER" in r.err  # accelerometer fields are flagged on stderr
    y = yaml.safe_load(out.read_text())
    doc = json.loads(allan_json.read_text())
    ax = _axis(doc)
    n, _ = _term(ax, "N")
    k, _ = _term(ax, "K")
    # closed form: 1 deg/sqrt(h) = (pi/180) rad / 60 sqrt(s); 1 deg/h/sqrt(h) = (pi/180)/216000
    assert y["gyroscope_noise_density"] == pytest.approx(n * math.pi / 180 / 60, rel=1e-7)
    assert y["gyroscope_random_walk"] == pytest.approx(k * math.pi / 180 / 216000, rel=1e-7)
    # the same numbers as the conversions the Allan analysis prints itself
    kal = ax["conversions"]["kalibr"]
    assert y["gyroscope_noise_density"] == pytest.approx(kal["gyroscope_noise_density"], rel=1e-7)
    assert y["gyroscope_random_walk"] == pytest.approx(kal["gyroscope_random_walk"], rel=1e-7)
    assert y["update_rate"] == pytest.approx(10.0) and isinstance(y["update_rate"], float)
    assert y["rostopic"] == "/gyro/imu"
    assert set(y) == {"accelerometer_noise_density", "accelerometer_random_walk",
                      "gyroscope_noise_density", "gyroscope_random_walk", "rostopic",
                      "update_rate"}


def test_kalibr_accel_options_and_inflate(allan_json, tmp_path):
    out = tmp_path / "imu.yml"
    r = run_cli(["export", "kalibr", allan_json, "-o", out, "--accel-noise-density", "1.5e-3",
                 "--accel-random-walk", "2e-4", "--inflate", "10", "--update-rate", "200",
                 "--json"])
    assert r.code == 0, r.err
    assert "PLACEHOLDER" not in out.read_text()
    y = yaml.safe_load(out.read_text())
    info = json.loads(r.out)
    assert info["output"] == str(out)
    n, _ = _term(_axis(json.loads(allan_json.read_text())), "N")
    assert y["gyroscope_noise_density"] == pytest.approx(10 * n * math.pi / 180 / 60, rel=1e-7)
    assert y["accelerometer_noise_density"] == 1.5e-3
    assert y["accelerometer_random_walk"] == 2e-4
    assert y["update_rate"] == 200.0


def test_kalibr_from_a_log_simulated_with_kalibrs_model(tmp_path):
    """Kalibr's discrete model (wiki "IMU Noise Model"): white σ_d = σ_c/√Δt, bias walk
    b_k+1 = b_k + σ_bc·√Δt·w. 4 h at 10 Hz; the export must give σ_c and σ_bc back."""
    rng = np.random.default_rng(20240612)
    fs, hours = 10.0, 4.0
    n = int(fs * 3600 * hours)
    dt = 1.0 / fs
    nd, rw = 1.0e-3, 2.0e-5  # rad/s/sqrt(Hz), rad/s^2/sqrt(Hz)
    white = nd / math.sqrt(dt) * rng.standard_normal(n)
    walk = np.cumsum(rw * math.sqrt(dt) * rng.standard_normal(n))
    t = np.arange(n) * dt
    log = tmp_path / "imu_log.csv"
    np.savetxt(log, np.column_stack([t, white + walk]), delimiter=",", header="time,rate",
               comments="", fmt="%.9g")
    out = tmp_path / "imu.yaml"
    r = run_cli(["export", "kalibr", log, "-o", out, "--rate-unit", "rad/s",
                 "--accel-noise-density", "1e-3", "--accel-random-walk", "1e-4"])
    assert r.code == 0, r.err
    y = yaml.safe_load(out.read_text())
    assert y["update_rate"] == pytest.approx(fs)
    assert y["gyroscope_noise_density"] == pytest.approx(nd, rel=0.03)
    assert y["gyroscope_random_walk"] == pytest.approx(rw, rel=0.35)


# ----------------------------------------------------------------------------- bad input
def _bad_inputs(tmp: Path, allan_json: Path) -> dict[str, tuple[Path, str]]:
    d = json.loads(allan_json.read_text())
    no_logs = dict(d)
    no_logs.pop("logs")
    no_tau = json.loads(allan_json.read_text())
    no_tau["logs"][0].pop("tau0_s")
    cases = {
        "not json": ("{not json", "cannot parse"),
        "a list": ("[1, 2]", "not a gyrotest result"),
        "scale-factor": (json.dumps({"command": "scale-factor", "epsilon_k": {},
                                     "nonlinearity_model": {}}), "scale-factor result"),
        "model file": (json.dumps({"format": "gyrotest-envmodel", "terms": []}),
                       "envmodel result"),
        "no logs": (json.dumps(no_logs), "'logs' missing"),
        "no tau0": (json.dumps(no_tau), "'tau0_s' missing"),
    }
    out = {}
    for i, (name, (text, frag)) in enumerate(cases.items()):
        p = tmp / f"bad{i}.json"
        p.write_text(text)
        out[name] = (p, frag)
    return out


@pytest.mark.parametrize("kind,suffix", [("kalibr", ".yaml"), ("gyroparams", ".mat"),
                                         ("stable32", ".txt"), ("allan-csv", ".csv")])
def test_malformed_allan_inputs(kind, suffix, allan_json, tmp_path):
    for name, (path, frag) in _bad_inputs(tmp_path, allan_json).items():
        out = tmp_path / f"out{suffix}"
        r = run_cli(["export", kind, path, "-o", out])
        r.assert_clean_error(str(path), frag)
        assert not out.exists(), name
    r = run_cli(["export", kind, tmp_path / "missing.json", "-o", tmp_path / f"o{suffix}"])
    r.assert_clean_error("missing.json", "not found")


def test_bad_outputs(allan_json, tmp_path):
    r = run_cli(["export", "kalibr", allan_json, "-o", tmp_path / "imu.txt"])
    r.assert_clean_error("imu.txt", ".yaml")
    r = run_cli(["export", "kalibr", allan_json, "-o", tmp_path / "nodir" / "imu.yaml"])
    r.assert_clean_error("does not exist")
    r = run_cli(["export", "kalibr", allan_json, "-o", tmp_path / "x", "--axis", "nope"])
    r.assert_clean_error(".yaml")
    r = run_cli(["export", "kalibr", allan_json, "-o", tmp_path / "imu.yaml", "--axis", "nope"])
    r.assert_clean_error("nope", "--axis")
    assert not (tmp_path / "imu.yaml").exists()


def test_unwritable_directory_leaves_nothing(allan_json, tmp_path):
    if os.name == "posix" and os.geteuid() == 0:  # root writes anywhere but /sys
        if not Path("/sys").is_dir():
            pytest.skip("no unwritable directory for root")
        r = run_cli(["export", "kalibr", allan_json, "-o", "/sys/imu.yaml"])
        r.assert_clean_error("/sys/imu.yaml", "permission denied")
        return
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    try:
        r = run_cli(["export", "kalibr", allan_json, "-o", ro / "imu.yaml"])
        r.assert_clean_error("permission denied")
        assert list(ro.iterdir()) == []
    finally:
        ro.chmod(0o700)


def test_existing_file_untouched_on_error(allan_json, tmp_path):
    out = tmp_path / "imu.yaml"
    out.write_text("keep me\n")
    r = run_cli(["export", "kalibr", allan_json, "-o", out, "--inflate", "-1"])
    r.assert_clean_error("--inflate")
    assert out.read_text() == "keep me\n"
    assert [p.name for p in tmp_path.iterdir()] == ["imu.yaml"]


# ----------------------------------------------------------------------------- MATLAB
def _parse_m(text: str) -> dict[str, object]:
    """Name/value pairs of the gyroparams(...) call of a .m script (MATLAB ignores the text
    after '...' and '%')."""
    import re

    out: dict[str, object] = {}
    for m in re.finditer(r"^\s+'(\w+)', (\[[^\]]*\]|[-+0-9.eE]+)", text, re.M):
        v = m.group(2)
        out[m.group(1)] = ([float(x) for x in v[1:-1].split()] if v.startswith("[")
                           else float(v))
    return out


@pytest.fixture(scope="module")
def thermal_model(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("thermal") / "thermal.json"
    r = run_cli(["thermal-fit", SAMPLE / "thermal.parquet", "--profile",
                 SAMPLE / "thermal.profile.toml", "-o", out, "--json"])
    assert r.code == 0, r.err
    return out


def test_gyroparams_m_and_mat(allan_json, thermal_model, tmp_path):
    from scipy.io import loadmat

    m_path, mat_path = tmp_path / "gyro.m", tmp_path / "gyro.mat"
    args = [allan_json, "--thermal", thermal_model, "--constant-bias", "1.8", "--range", "400"]
    for p in (m_path, mat_path):
        r = run_cli(["export", "gyroparams", *args[:1], "-o", p, *args[1:]])
        assert r.code == 0, r.err
    ax = _axis(json.loads(allan_json.read_text()))
    n, _ = _term(ax, "N")
    b, _ = _term(ax, "B")
    k, _ = _term(ax, "K")
    d2r = math.pi / 180
    model = json.loads(thermal_model.read_text())
    coef = {t["key"]: t["coefficients"][0]["value"] for t in model["terms"]}
    t_ref = model["references"]["T_ref_degC"]["T_chamber_C"]
    slope_25 = coef["T"] + 2 * coef["T2"] * (25.0 - t_ref)  # d/dT of w1·ΔT + w2·ΔT² at 25 °C
    want = {"NoiseDensity": n * d2r / 60, "BiasInstability": b * d2r / 3600,
            "RandomWalk": k * d2r / 216000, "ConstantBias": 1.8 * d2r / 3600,
            "TemperatureBias": slope_25 * d2r / 3600, "MeasurementRange": 400 * d2r}
    got_m = _parse_m(m_path.read_text())
    s = loadmat(mat_path, squeeze_me=True, struct_as_record=False)
    assert set(got_m) == set(want)
    for name, v in want.items():
        assert got_m[name] == pytest.approx(v, rel=1e-8), name
        assert float(getattr(s["gyroparams"], name)) == pytest.approx(v, rel=1e-12), name
    assert s["units"].NoiseDensity == "(rad/s)/sqrt(Hz)"
    assert "namedargs2cell" in s["usage"]
    assert m_path.read_text().count("gyroparams(") == 1


def test_gyroparams_scale_factor_json(allan_json, tmp_path):
    r = run_cli(["scale-factor", SAMPLE / "ratetable_22a.parquet", SAMPLE / "ratetable_45.parquet",
                 "--profile", SAMPLE / "ratetable_22a.profile.toml", "--json"])
    assert r.code == 0, r.err
    sf = tmp_path / "sf.json"
    sf.write_text(r.out)
    doc = json.loads(r.out)
    out = tmp_path / "g.m"
    r = run_cli(["export", "gyroparams", allan_json, "-o", out, "--sf-json", sf])
    assert r.code == 0, r.err
    got = _parse_m(out.read_text())
    eps_t = doc["epsilon_k"]["epsilon_T_ppm_per_degC"]
    assert got["TemperatureScaleFactor"] == pytest.approx(-eps_t * 1e-4, rel=1e-8)
    assert got["MeasurementRange"] == pytest.approx(doc["full_scale_dps"] * math.pi / 180)


def _three_axis_log(tmp_path: Path, minutes: float = 30.0) -> tuple[Path, dict[str, float]]:
    """White rate noise on gx, gy, gz (deg/s) with known densities N (deg/√h)."""
    rng = np.random.default_rng(7)
    fs = 10.0
    n = int(fs * 60 * minutes)
    dens = {"gx": 0.5, "gy": 1.0, "gz": 2.0}  # deg/sqrt(h)
    cols = [np.arange(n) / fs]
    for v in dens.values():
        sigma_dph = v * 60.0 * math.sqrt(fs)  # per-sample σ = N·60/√τ0 in deg/h
        cols.append(sigma_dph / 3600.0 * rng.standard_normal(n))
    p = tmp_path / "imu3.csv"
    np.savetxt(p, np.column_stack(cols), delimiter=",", header="time,gx,gy,gz", comments="",
               fmt="%.9g")
    return p, dens


def test_gyroparams_three_axes_from_a_log(tmp_path):
    from scipy.io import loadmat

    log, dens = _three_axis_log(tmp_path)
    out = tmp_path / "g3.mat"
    r = run_cli(["export", "gyroparams", log, "-o", out, "--rate-col", "gx,gy,gz",
                 "--rate-unit", "deg/s"])
    assert r.code == 0, r.err
    s = loadmat(out, squeeze_me=True, struct_as_record=False)
    nd = np.asarray(s["gyroparams"].NoiseDensity)
    assert nd.shape == (3,)
    want = np.array([v * math.pi / 180 / 60 for v in dens.values()])
    assert np.allclose(nd, want, rtol=0.05), (nd, want)
    assert list(s["axes"]) == ["gx", "gy", "gz"]
    r = run_cli(["export", "gyroparams", log, "-o", tmp_path / "g2.m", "--rate-col", "gx,gy,gz",
                 "--rate-unit", "deg/s", "--axis", "gx,gy"])
    r.assert_clean_error("one value or three", "--axis")
    assert not (tmp_path / "g2.m").exists()


def test_gyroparams_bad_inputs(allan_json, tmp_path):
    r = run_cli(["export", "gyroparams", allan_json, "-o", tmp_path / "bad-name.m"])
    r.assert_clean_error("bad-name.m", "MATLAB script name")
    r = run_cli(["export", "gyroparams", allan_json, "-o", tmp_path / "g.m", "--thermal",
                 allan_json])
    r.assert_clean_error(str(allan_json), "model file")
    r = run_cli(["export", "gyroparams", allan_json, "-o", tmp_path / "g.mat", "--sf-json",
                 allan_json])
    r.assert_clean_error(str(allan_json), "scale-factor")
    assert list(tmp_path.iterdir()) == []


# ----------------------------------------------------------------------------- Stable32, CSV
S32_REF = Path(__file__).parents[2] / "shared" / "reference" / "data" / "realdata" / "stable32"


def _read_stable32_blocks(text: str) -> list[tuple[dict[str, str], list[dict]]]:
    """Blocks of a Stable32 table file: header 'key: value' / 'key = value' lines and rows
    AF Tau # Alpha MinSigma Sigma MaxSigma (the parser the Stable32 conformance tests use)."""
    blocks: list[tuple[dict[str, str], list[dict]]] = []
    head: dict[str, str] = {}
    rows: list[dict] = []
    for line in text.splitlines():
        s = line.strip()
        if not s:
            continue
        if s.startswith("# STATISTICS FOR FILE:"):
            if rows:
                blocks.append((head, rows))
            head, rows = {"file": s.split(":", 1)[1].strip()}, []
            continue
        if s.startswith("#"):
            for sep in (":", "="):
                if sep in s:
                    k, v = s[1:].split(sep, 1)
                    head.setdefault(k.strip(), v.strip())
                    break
            continue
        p = s.split()
        rows.append(dict(m=int(p[0]), tau=float(p[1]), n=int(p[2]), alpha=int(p[3]),
                         lo=float(p[4]), sigma=float(p[5]), hi=float(p[6])))
    if rows:
        blocks.append((head, rows))
    return blocks


def _same_5_digits(a: float, b: float) -> bool:
    return abs(a - b) <= 0.5e-4 * abs(b) * 1.0001 + 1e-300


def test_stable32_table_parses_back(allan_json, tmp_path):
    out = tmp_path / "static_oadev.txt"
    r = run_cli(["export", "stable32", allan_json, "-o", out])
    assert r.code == 0, r.err
    blocks = _read_stable32_blocks(out.read_text())
    assert len(blocks) == 1
    head, rows = blocks[0]
    assert head["file"].endswith("static.parquet (axis pulses)")
    assert head["Tau0"] == "0.1 s"
    assert head["Sigma Type"] == "Overlapping Allan"
    assert head["Confidence Factor"] == "0.683"
    assert "frequency" in head["Data Type"]
    table = _axis(json.loads(allan_json.read_text()))["table"]
    assert len(rows) == len(table)
    for got, want in zip(rows, table):
        assert got["m"] == want["m"] and got["n"] == want["n"] and got["alpha"] == want["alpha"]
        for g, w in (("tau", "tau"), ("lo", "sigma_lo"), ("sigma", "sigma"), ("hi", "sigma_hi")):
            assert _same_5_digits(got[g], want[w]), (g, got[g], want[w])


@pytest.mark.skipif(not S32_REF.is_dir(), reason=f"Stable32 tables not found at {S32_REF}")
def test_stable32_layout_matches_stable32s_own_tables(allan_json, tmp_path):
    """Our table and a table printed by Stable32 go through the same parser, and their
    column-title lines and row layout (column positions) are identical."""
    ref = (S32_REF / "gps_OADEV_octave.txt").read_text()
    (ref_head, ref_rows), = _read_stable32_blocks(ref)
    out = tmp_path / "t.txt"
    assert run_cli(["export", "stable32", allan_json, "-o", out]).code == 0
    ours = out.read_text()
    title = next(ln for ln in ref.splitlines() if ln.startswith("#  AF"))
    assert title in ours.splitlines()
    ref_row = next(ln for ln in ref.splitlines() if ln and not ln.startswith("#"))
    our_row = next(ln for ln in ours.splitlines() if ln and not ln.startswith("#"))
    assert [i for i, c in enumerate(ref_row) if c == "e"] == \
        [i for i, c in enumerate(our_row) if c == "e"]
    our_head = _read_stable32_blocks(ours)[0][0]
    for key in ("file", "Sigma Type", "Confidence Factor", "Deadtime T/Tau"):
        assert key in ref_head and key in our_head, key


def test_allan_csv_units_in_header(allan_json, tmp_path):
    import pandas as pd

    out = tmp_path / "allan.csv"
    r = run_cli(["export", "allan-csv", allan_json, "-o", out])
    assert r.code == 0, r.err
    df = pd.read_csv(out)
    assert list(df.columns) == ["source", "axis", "deviation", "tau_s", "m", "n", "alpha", "edf",
                                "sigma_lo_deg_h", "sigma_deg_h", "sigma_hi_deg_h", "model_deg_h",
                                "residual_ci", "fitted"]
    table = _axis(json.loads(allan_json.read_text()))["table"]
    assert np.allclose(df["sigma_deg_h"], [t["sigma"] for t in table], rtol=1e-9)
    assert np.allclose(df["tau_s"], [t["tau"] for t in table], rtol=1e-9)
    assert df["fitted"].dtype == bool


def test_table_exports_reject_malformed_rows(allan_json, tmp_path):
    d = json.loads(allan_json.read_text())
    d["logs"][0]["axes"][0]["table"][3].pop("sigma")
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(d))
    r = run_cli(["export", "stable32", bad, "-o", tmp_path / "t.txt"])
    r.assert_clean_error("bad.json", "'sigma' missing", "row 4")
    r = run_cli(["export", "allan-csv", bad, "-o", tmp_path / "t.csv"])
    r.assert_clean_error("bad.json", "'sigma' missing", "row 4")
    r = run_cli(["export", "stable32", allan_json, "-o", tmp_path / "t.txt", "--digits", "1"])
    r.assert_clean_error("--digits")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.json"]


# ----------------------------------------------------------------------------- drift model
def _ramp_log(tmp_path: Path, rate_c_per_h: float = 36.0) -> tuple[object, np.ndarray]:
    """A 1 Hz log whose chamber temperature ramps 20 → 56 degC at ``rate_c_per_h``."""
    from gyrotest.cli.common import load_log

    n = int(36.0 / rate_c_per_h * 3600) + 1
    t = np.arange(n, dtype=float)
    temp = 20.0 + rate_c_per_h * t / 3600.0
    p = tmp_path / "ramp.csv"
    np.savetxt(p, np.column_stack([t, np.zeros(n), temp, temp, temp]), delimiter=",",
               header="time,rate,T_chamber_C,T_coil_a_C,T_coil_b_C", comments="", fmt="%.12g")
    log = load_log(str(p), {"rate_col": "rate", "rate_unit": "deg/h", "time_col": "time",
                            "temp_col": ("T_chamber_C", "T_coil_a_C", "T_coil_b_C")},
                   announce=False, dead="note")  # only the temperatures are used
    return log, temp


def _compile(header: Path, calls: str, tmp_path: Path) -> list[float]:
    import shutil
    import subprocess

    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        pytest.skip("no C compiler")
    src = tmp_path / "main.c"
    src.write_text(f'#include <stdio.h>\n#include "{header.name}"\nint main(void) {{\n{calls}\n'
                   "return 0; }\n")
    exe = tmp_path / "main"
    subprocess.run([cc, "-std=c99", "-Wall", "-Wextra", "-Werror", "-o", str(exe), str(src),
                    "-lm"], check=True, cwd=tmp_path, capture_output=True)
    out = subprocess.run([str(exe)], check=True, capture_output=True, text=True).stdout
    return [float(x) for x in out.split()]


def test_env_model_lut_and_header_reproduce_the_model(thermal_model, tmp_path):
    from gyrotest.envmodel.model import EnvModel

    lut, hdr = tmp_path / "lut.csv", tmp_path / "thermal_comp.h"
    r = run_cli(["export", "env-model", "--force", thermal_model, "-o", lut, "--temps", "20:56:1"])
    assert r.code == 0, r.err
    r = run_cli(["export", "env-model", "--force", thermal_model, "-o", hdr, "--prefix", "fog_comp"])
    assert r.code == 0, r.err
    import pandas as pd

    df = pd.read_csv(lut, comment="#")
    assert list(df.columns) == ["temperature_degC", "drift_dph", "bias_dph", "T_T_chamber_C_dph",
                                "T2_T_chamber_C_dph"]
    model = EnvModel.load(thermal_model)
    log, temp = _ramp_log(tmp_path)
    pred = model.predict(log)  # the model's own evaluation (as gyrotest compensate applies it)
    # rows at the samples where the ramp crosses each whole degree (every 100 s)
    idx = (np.round((df["temperature_degC"] - 20.0) * 100)).astype(int).to_numpy()
    inner = (idx > 200) & (idx < len(temp) - 200)  # away from the ends of the dT/dt smoother
    c_dtdt = model.coefficient("dTdt(T_chamber_C)")
    want = pred[idx[inner]]
    got_lut = df["drift_dph"].to_numpy()[inner] + c_dtdt * 36.0
    assert np.allclose(got_lut, want, rtol=1e-9, atol=1e-9)
    # closed form of the Antonova-Matveev polynomial with the stored coefficients
    dT = df["temperature_degC"] - 21.0
    closed = (model.coefficient("bias") + model.coefficient("T(T_chamber_C)") * dT
              + model.coefficient("T2(T_chamber_C)") * dT ** 2)
    assert np.allclose(df["drift_dph"], closed, rtol=1e-9, atol=1e-9)  # 10 digits in the CSV
    # the C function, compiled, at the same points
    calls = "\n".join(f'printf("%.17g\\n", fog_comp_dph({T!r}, 36.0));'
                      for T in df["temperature_degC"][inner])
    got_c = np.array(_compile(hdr, calls, tmp_path))
    assert np.max(np.abs(got_c - want)) < 1e-9 * np.max(np.abs(want))


def _edit_model(src: Path, dst: Path, add: list[dict]) -> Path:
    d = json.loads(src.read_text())
    d["terms"] += add
    dst.write_text(json.dumps(d))
    return dst


def test_env_model_dynamic_terms_and_channels(thermal_model, tmp_path):
    warm = {"key": "warmup", "label": "warmup",
            "coefficients": [{"name": "warmup", "value": 0.3, "stderr": 0.01, "unit": "deg/h"}],
            "nonlinear": [{"name": "tau_w_s", "value": 600.0, "stderr": 10.0, "unit": "s"}]}
    dyn = _edit_model(thermal_model, tmp_path / "dyn.json", [warm])
    r = run_cli(["export", "env-model", "--force", dyn, "-o", tmp_path / "d.h"])
    r.assert_clean_error("dyn.json", "warmup", "--static-only")
    r = run_cli(["export", "env-model", "--force", dyn, "-o", tmp_path / "d.h", "--static-only"])
    assert r.code == 0 and "left out: warmup" in r.err
    assert "Left out (--static-only): warmup" in (tmp_path / "d.h").read_text()
    coil = {"key": "T", "label": "T(T_coil_a_C)", "channels": ["T_coil_a_C"],
            "coefficients": [{"name": "T(T_coil_a_C)", "value": 0.5, "stderr": 0.1,
                              "unit": "deg/h/degC"}]}
    two = _edit_model(thermal_model, tmp_path / "two.json", [coil])
    r = run_cli(["export", "env-model", "--force", two, "-o", tmp_path / "two.csv"])
    r.assert_clean_error("two.json", "2 channels", ".h")
    hdr = tmp_path / "two.h"
    r = run_cli(["export", "env-model", "--force", two, "-o", hdr])
    assert r.code == 0, r.err
    # drift(T_chamber=30, dTdt=2, T_coil_a=25) by hand from the stored coefficients
    m = json.loads(two.read_text())
    c = [t["coefficients"][0]["value"] for t in m["terms"]]
    want = c[0] + c[1] * 9 + c[2] * 81 + c[3] * 2 + c[4] * 4
    got = _compile(hdr, 'printf("%.17g\\n", gyro_drift_dph(30.0, 2.0, 25.0));', tmp_path)
    assert got[0] == pytest.approx(want, rel=1e-13)


def test_env_model_bad_inputs(thermal_model, allan_json, tmp_path):
    r = run_cli(["thermal-fit", SAMPLE / "thermal.parquet", "--profile",
                 SAMPLE / "thermal.profile.toml", "--json"])
    rep = tmp_path / "report.json"
    rep.write_text(r.out)
    r = run_cli(["export", "env-model", rep, "-o", tmp_path / "x.h"])
    r.assert_clean_error("report.json", "thermal-fit LOG -o model.json")
    r = run_cli(["export", "env-model", allan_json, "-o", tmp_path / "x.h"])
    r.assert_clean_error("allan result", "model fit -o")
    r = run_cli(["export", "env-model", thermal_model, "-o", tmp_path / "x.csv", "--temps", "5:1:1"])
    r.assert_clean_error("--temps", "start:stop:step")
    r = run_cli(["export", "env-model", thermal_model, "-o", tmp_path / "x.h", "--prefix", "1x"])
    r.assert_clean_error("--prefix", "C identifier")
    broken = json.loads(thermal_model.read_text())
    del broken["terms"][1]["coefficients"]
    b = tmp_path / "broken.json"
    b.write_text(json.dumps(broken))
    r = run_cli(["export", "env-model", b, "-o", tmp_path / "x.h"])
    r.assert_clean_error("broken.json", "terms[1].coefficients", "missing")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["broken.json", "report.json"]
