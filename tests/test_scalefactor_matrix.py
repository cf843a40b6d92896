"""3-axis scale-factor/misalignment matrix (gyrotest/scalefactor/matrix.py) against an
independent numpy generator: a triad with a known K = I + M on a rate table turned about each
case axis (+x, +y, +z; the z position mounted upside down as −z), ±10…±200 deg/s, with a
first-order table lag, earth rate + bias per position and white noise. M comes back within its
stated uncertainty (z-scores over seeds), and the command prints/serialises it."""

from __future__ import annotations

import json

import numpy as np
import pytest

from gyrotest.core.errors import InputError
from gyrotest.core.profile import load_profile
from gyrotest.io.ingest import read_log
from gyrotest.scalefactor.matrix import misalignment_matrix, parse_axis_label

from cliutil import run_cli

RATES = (10, -10, 50, -50, 100, -100, 200, -200)


def make_triad(path, seed, *, M, lag_s=0.5, sigma_dph=20.0, dwell_s=20.0, fs=10.0,
               positions=("+x", "+y", "-z")):
    rng = np.random.default_rng(seed)
    K = np.eye(3) + M
    rows = []
    t = 0.0
    bias = rng.normal(0, 5.0, 3)
    w_prev = 0.0
    n = int(dwell_s * fs)
    for p in positions:
        a, sign = {"x": 0, "y": 1, "z": 2}[p[-1]], -1.0 if p[0] == "-" else 1.0
        earth = rng.normal(0, 10.0, 3)  # earth-rate projection of this mounting, deg/h
        for c in RATES:
            tt = (np.arange(n) + 0.5) / fs
            w = c * 3600 + (w_prev - c * 3600) * np.exp(-tt / lag_s)  # table rate, deg/h
            w_prev = float(w[-1])
            inp = np.zeros((n, 3))
            inp[:, a] = sign * w
            out = (inp + earth) @ K.T + bias + rng.normal(0, sigma_dph, (n, 3))
            for k in range(n):
                rows.append((t + (k + 1) / fs, *out[k], c, p))
            t += n / fs
    with open(path, "w") as f:
        f.write("t_s,gx_dph,gy_dph,gz_dph,table_dps,pos\n")
        for r in rows:
            f.write(f"{r[0]:.1f},{r[1]:.4f},{r[2]:.4f},{r[3]:.4f},{r[4]:g},{r[5]}\n")
    prof = path.with_suffix(".toml")
    prof.write_text('[columns]\ntime = "t_s"\nrate = ["gx_dph", "gy_dph", "gz_dph"]\n'
                    'table_rate = "table_dps"\nposition = "pos"\n\n[units]\n'
                    'table_dps = "deg/s"\ngx_dph = "deg/h"\ngy_dph = "deg/h"\ngz_dph = "deg/h"\n')
    return path, prof


M_TRUE = np.array([[300e-6, 1.2e-3, -0.4e-3],
                   [-0.8e-3, -150e-6, 0.6e-3],
                   [0.2e-3, -1.5e-3, 80e-6]])


def test_axis_labels():
    assert parse_axis_label("+x") == (0, 1.0) and parse_axis_label("-Y") == (1, -1.0)
    assert parse_axis_label("z") == (2, 1.0) and parse_axis_label("nz") == (2, -1.0)
    assert parse_axis_label("up") is None


def test_matrix_within_stated_uncertainty(tmp_path):
    zs = []
    for seed in range(4):
        path, prof = make_triad(tmp_path / f"imu{seed}.csv", seed, M=M_TRUE)
        res = misalignment_matrix(read_log(path, profile=load_profile(prof)))
        assert res.n_plateaus == [8, 8, 8]
        z = (res.M - M_TRUE) / res.K_sigma
        zs.append(z.ravel())
        assert np.all(np.abs(z) < 4), z
        assert res.settling_worst_s > 0.5  # the 0.5 s lag was found
    zs = np.concatenate(zs)
    assert 0.5 < np.sqrt(np.mean(zs ** 2)) < 1.6
    assert np.mean(np.abs(zs) < 2) >= 0.85


def test_matrix_cli_and_bad_input(tmp_path):
    path, prof = make_triad(tmp_path / "imu.csv", 7, M=M_TRUE)
    r = run_cli(["scale-factor", str(path), "--profile", str(prof), "--matrix", "--json"])
    assert r.code == 0, r.err
    d = json.loads(r.out)["matrix"]
    assert d["scale_factor_error_ppm"][0] == pytest.approx(300, abs=5 * d[
        "scale_factor_error_sigma_ppm"][0])
    assert d["misalignment_urad"][0][1] == pytest.approx(1200, abs=5 * d[
        "misalignment_sigma_urad"][0][1])
    r = run_cli(["scale-factor", str(path), "--profile", str(prof), "--matrix"])
    assert r.code == 0 and "misalignment" in r.out
    one = tmp_path / "one.csv"
    one.write_text("\n".join(ln.split(",", 2)[0] + "," + ln.split(",")[1] + ","
                             + ",".join(ln.split(",")[4:]) for ln in path.read_text().splitlines()))
    lg = read_log(one, overrides={"columns": {"time": "t_s", "rate": "gx_dph",
                                              "table_rate": "table_dps", "position": "pos"},
                                  "units": {"table_dps": "deg/s", "gx_dph": "deg/h"}})
    with pytest.raises(InputError, match="three gyro rate columns"):
        misalignment_matrix(lg)
