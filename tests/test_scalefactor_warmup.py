"""Warm-up time (gyrotest/staticbias/warmup.py): the closed form τ_w·ln(A/band) of an exponential warm-up,
the simulator's warm-up truth with noise, nulls (no warm-up) and the bundled power-on runs."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from gyrotest.core.errors import AnalysisError
from gyrotest.simulation import simulate
from gyrotest.staticbias.warmup import warmup_time

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("A,tau,band", [(0.35, 600.0, 0.02), (2.0, 300.0, 0.05)])
def test_closed_form_noise_free(A, tau, band):
    t = np.arange(0, 4 * 3600.0, 1.0) + 0.5
    y = 5.0 + A * np.exp(-t / tau)
    r = warmup_time(y, 1.0, band_dph=band, block_s=60.0)
    # block means cross the band within one block of t = τ ln(A/band) (plus the block-mean lag)
    assert r.status == "ok"
    assert abs(r.warmup_s - tau * math.log(A / band)) <= 60.0 + 1e-9


def test_simulated_warmup_with_noise():
    """Simulator truth A·e^(−t/τ_w) with ARW: the time found is within two blocks of
    τ_w ln(A/band) for every seed; with no warm-up the time is 0 (nulls)."""
    A, tau, band = 0.35, 600.0, 0.05
    sc = {"record": {"sample_rate_hz": 1.0, "duration_s": 4 * 3600.0},
          "gyro": {"output": "rate", "bias_dph": 1.5, "noise": {"N": 0.002}},
          "effects": {"warmup": {"amplitude_dph": A, "tau_s": tau}}}
    truth = tau * math.log(A / band)
    for seed in range(5):
        run = simulate(sc, seed=seed).run
        r = warmup_time(run.rate_dph, run.tau0, band_dph=band, block_s=120.0)
        assert r.status == "ok" and r.resolvable
        assert abs(r.warmup_s - truth) <= 2 * r.block_s, (seed, r.warmup_s, truth)
    null = dict(sc, effects={})
    found = [warmup_time(simulate(null, seed=s).run.rate_dph, 1.0, band_dph=band,
                         block_s=120.0).warmup_s for s in range(5)]
    assert found == [0.0] * 5


def test_default_band_unresolvable_and_short():
    rng = np.random.default_rng(1)
    y = rng.normal(0, 1.0, 36000)
    r = warmup_time(y, 1.0, band_dph=0.01, block_s=60.0)
    assert not r.resolvable and "not resolvable" in r.status
    r = warmup_time(y, 1.0, block_s=60.0)  # default band: 3 σ of the block means
    assert r.band_source.startswith("3 sigma") and r.warmup_s <= 60.0
    with pytest.raises(AnalysisError, match="16"):
        warmup_time(y[:600], 1.0, block_s=60.0)
    # still drifting at the end: not reached
    t = np.arange(36000.0)
    r = warmup_time(1.0 * np.exp(-t / 20000.0), 1.0, band_dph=0.01)
    assert r.status.startswith("not reached") and math.isnan(r.warmup_s)
