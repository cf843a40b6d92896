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


@pytest.mark.parametrize("kind,suffix", [("kalibr", ".yaml")])
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
