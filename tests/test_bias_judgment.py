"""Judgment calls of bias and allan: the bias ±1σ from the accepted (diagnosed) noise model,
warm-up detection (randomized quick check with nulls). (KROBKA-M1's bound: test_allan_mems.py.)"""

from __future__ import annotations

import json

import numpy as np
import pytest

from gyrotest.simulation import simulate, write_log
from gyrotest.staticbias.analysis import mean_uncertainty
from gyrotest.staticbias.warmup import detect_warmup

from cliutil import run_cli


def _sim(noise, *, hours=4.0, fs=10.0, seed=0, warmup=None):
    sc = {"record": {"sample_rate_hz": fs, "duration_s": hours * 3600},
          "gyro": {"output": "rate", "rate_unit": "deg/h", "noise": noise}}
    if warmup:
        sc["effects"] = {"warmup": warmup}
    return sc, np.asarray(simulate(sc, seed=seed).rate_dph, float)


NULLS = [{"N": 0.01}, {"N": 0.01, "B": 0.02}, {"N": 0.01, "K": 0.05}, {"N": 0.01, "R": 0.05}]


@pytest.mark.parametrize("seed", [3000, 3001])
def test_warmup_nulls_do_not_fire(seed):
    for noise in NULLS:
        _, x = _sim(noise, seed=seed)
        r = detect_warmup(x, 0.1)
        assert r is not None and not r.detected, (noise, r)


@pytest.mark.parametrize("seed", [3000, 3001, 3002])
def test_warmup_is_found_with_its_time_constant(seed):
    rng = np.random.default_rng(seed)
    tau = float(rng.uniform(400, 1800))
    _, x = _sim({"N": 0.01, "B": 0.02}, seed=seed, warmup={"amplitude_dph": 0.5, "tau_s": tau})
    r = detect_warmup(x, 0.1)
    assert r.detected
    assert r.amplitude_dph == pytest.approx(0.5, rel=0.3)
    assert r.tau_s == pytest.approx(tau, rel=0.5)
    assert r.skip_s > r.tau_s


def test_bias_warns_about_an_included_warmup(tmp_path):
    sc, _ = _sim({"N": 0.01}, warmup={"amplitude_dph": 0.5, "tau_s": 900})
    log = str(write_log(simulate(sc, seed=4), tmp_path / "w.csv").logs[0])
    r = run_cli(["bias", log, "--rate-unit", "deg/h", "--json"])
    assert r.code == 0, r.err
    run = json.loads(r.out)["runs"][0]
    assert run["warmup"]["detected"] and any("warm-up" in n for n in run["notes"])
    r_txt = run_cli(["bias", log, "--rate-unit", "deg/h"])
    assert "warm-up transient" in r_txt.err and "--skip" in r_txt.err
    r2 = run_cli(["bias", log, "--rate-unit", "deg/h", "--json", "--skip", "1h"])
    run2 = json.loads(r2.out)["runs"][0]
    assert run2["warmup"] is None and not any("warm-up" in n for n in run2["notes"])


def test_bias_sigma_from_the_diagnosed_model_when_the_default_misfits():
    # a Markov hump the Q,N,B,K model cannot follow
    _, x = _sim({"N": 0.005, "markov": [{"q_c": 30.0, "T_c": 2.0}]}, hours=2.0, seed=5)
    u = mean_uncertainty(x, 0.1)
    assert u.default_rejected is not None and "diagnosed model" in u.default_rejected
    assert "markov" in u.model_terms and u.model_chi2_dof < 5
    # the truth: σ of the mean of N + Markov over T is N_eq·60/√T (white beyond T_c)
    n_eq = np.hypot(0.005, 30.0 * 2.0 / 3600.0)
    assert u.sigma_dph == pytest.approx(n_eq * 60 / np.sqrt(7200), rel=0.35)
    # a clean record keeps the default model, silently
    _, y = _sim({"N": 0.01}, hours=1.0, seed=6)
    v = mean_uncertainty(y, 0.1)
    assert v.default_rejected is None and v.model_terms == ["Q", "N", "B", "K"]
