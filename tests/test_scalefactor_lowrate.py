"""Threshold, resolution and input range (gyrotest/scalefactor/lowrate.py; IEEE Std 528
definitions, IEEE 952 §5.3.1/§5.3.2): closed forms on hand-made points, then the simulator's
``ratetable_lowrate.toml`` scenario (lock-in 0.05 deg/s, saturation at 450 deg/s) against its
truth, and "not tested" on a plain rate-table campaign."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from gyrotest.scalefactor.lowrate import detect_saturation, resolution, threshold
from gyrotest.scalefactor.tablefit import DPS, Points

from cliutil import run_cli

ROOT = Path(__file__).resolve().parents[1]


def _pts(table_dps, y_dph, se=0.01):
    tab = np.asarray(table_dps, float) * DPS
    return Points(I=tab.copy(), y=np.asarray(y_dph, float), se=np.full(len(tab), se),
                  run=np.zeros(len(tab), int), runs=["r"], table=tab)


def test_threshold_dead_zone_closed_form():
    """A hard dead zone at 0.03 deg/s: outputs 0 below, k·I above; the bracket is the tested
    rates on either side of it, and an Adler band L gives 50 % at I = L·2/√3."""
    rates = [0.01, -0.01, 0.02, -0.02, 0.05, -0.05, 0.1, -0.1, 1, -1, 10, -10, 100, -100]
    y = [0.0 if abs(r) < 0.03 else 1.0001 * r * DPS for r in rates]
    P = _pts(rates, y)
    t = threshold(P, np.zeros(P.n, bool), 100 * DPS)
    assert t.status == "ok" and t.value_dps == pytest.approx(0.05) and t.lower_dps == 0.02
    L = 0.05
    y2 = [np.sign(r) * math.sqrt(max(r * r - L * L, 0.0)) * DPS for r in rates]
    t2 = threshold(_pts(rates, y2), np.zeros(P.n, bool), 100 * DPS)
    # Adler output reaches 50 % at |I| = 2L/√3 = 0.0577: 0.05 fails, 0.1 responds
    assert t2.lower_dps == 0.05 and t2.value_dps == 0.1


def test_threshold_not_tested_and_noise_limited():
    rates = [1, -1, 10, -10, 100, -100]
    P = _pts(rates, [r * DPS for r in rates])
    assert threshold(P, np.zeros(6, bool), 100 * DPS).status.startswith("not tested")
    # a low rate whose output is below 2 SE does not count as a response
    rates = [0.01, -0.01, 1, -1, 10, -10, 100, -100]
    P = _pts(rates, [r * DPS for r in rates], se=30.0)  # 0.01 deg/s = 36 deg/h < 2·30
    t = threshold(P, np.zeros(P.n, bool), 100 * DPS)
    assert t.status.startswith("not reached") and t.lower_dps == 0.01


def test_resolution_steps_and_saturation():
    base = [20, 20.001, 20.003, 20.01, 20.03, 1, -1, 100, -100, 300, -300, 500, -500]
    lim = 450 * DPS
    y = [float(np.clip(r * DPS, -lim, lim)) for r in base]
    y[1] = y[0]  # the 0.001 deg/s step does not come through
    P = _pts(base, y, se=0.1)
    sat, rng = detect_saturation(P)
    assert rng.saturated and rng.saturated_rates_dps == [-500.0, 500.0]
    assert rng.positive_dps == 300 and rng.negative_dps == 300
    r = resolution(P, sat)
    assert r.status == "ok" and r.lower_dps == pytest.approx(0.001)
    assert r.value_dps == pytest.approx(0.002)
    assert not detect_saturation(_pts(base[5:11], [b * DPS for b in base[5:11]]))[1].saturated


def test_simulated_lowrate_campaign(tmp_path):
    """Simulator truth: lock-in 0.05 deg/s (Adler: 50 % output at 0.0577 deg/s), saturation at
    450 deg/s, SF error 50 ppm on the plateaus inside the range."""
    r = run_cli(["simulate", str(ROOT / "sample_data/scenarios/ratetable_lowrate.toml"),
                 "-o", str(tmp_path / "lr.csv")])
    assert r.code == 0, r.err
    truth = json.loads((tmp_path / "lr.truth.json").read_text())
    r = run_cli(["scale-factor", str(tmp_path / "lr.csv"), "--profile",
                 str(tmp_path / "lr.profile.toml"), "--no-asymmetry", "--no-periodic", "--json"])
    assert r.code == 0, r.err
    d = json.loads(r.out)
    L = truth["scale_factor"]["model"]["lock_in_dph"] / 3600.0
    th = d["threshold"]
    assert th["status"] == "ok" and th["above_dps"] < 2 * L / math.sqrt(3) <= th["at_most_dps"]
    sat = truth["scale_factor"]["model"]["saturation_dps"]
    ir = d["input_range"]
    assert ir["saturation_detected"] and ir["input_range_positive_dps"] < sat
    assert all(abs(v) > sat for v in ir["saturated_rates_dps"])
    assert d["resolution"]["status"] == "ok" and d["resolution"]["at_most_dps"] <= 0.001 + 1e-9
    assert d["scale_factor_error_ppm"] == pytest.approx(-truth["scale_factor"]["sf_error_ppm"],
                                                        abs=1.0)
    r = run_cli(["scale-factor", str(tmp_path / "lr.csv"), "--profile",
                 str(tmp_path / "lr.profile.toml"), "--no-asymmetry", "--no-periodic"])
    assert r.code == 0 and "threshold" in r.out and "saturates at" in r.out


def test_plain_campaign_not_tested():
    root = ROOT / "sample_data"
    r = run_cli(["scale-factor", str(root / "ratetable_22a.parquet"), "--profile",
                 str(root / "ratetable_22a.profile.toml"), "--json"])
    assert r.code == 0, r.err
    d = json.loads(r.out)
    assert d["threshold"]["status"].startswith("not tested")
    assert d["resolution"]["status"].startswith("not tested")
    assert not d["input_range"]["saturation_detected"]
    assert d["input_range"]["input_range_positive_dps"] == 500
