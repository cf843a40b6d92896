"""Platform vs strapdown attitude-error prediction, checked against Monte Carlo (notes-
platform-vs-strapdown §3.1: 300 runs, dt = 0.01 s, T = 600 s) and against the exceptions of
Krobka's effect (no rotation, white rate noise)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_noise_fit import table_from_model

from gyrotest.core.errors import InputError
from gyrotest.noise.impact import (
    Component,
    attitude_impact,
    axial_variance,
    monte_carlo_attitude,
    parse_vehicle_rate,
    predict_attitude_variance,
    transverse_variance,
)
from gyrotest.noise.noisefit import fit_noise_model

A = 180.0 / math.pi * 3600.0  # arcsec per rad (internal angles are arcsec)
T, DT = 600.0, 0.01


def pred(comps, omega):
    return predict_attitude_variance(comps, T, omega, tau0=DT, record_s=T)


def test_mc_white_rate_noise_equal_for_platform_and_strapdown():
    comps = [Component("N", (1e-5 * A) ** 2)]
    mc = monte_carlo_attitude(comps, duration_s=T, dt=DT, omega=1.0, runs=300, seed=1)
    p = pred(comps, 1.0)
    assert p["platform"] / A**2 == pytest.approx(1.8e-7, rel=1e-9)  # 3 N² T
    assert p["strapdown"] == pytest.approx(p["platform"], rel=1e-12)
    assert mc["platform"] == pytest.approx(p["platform"], rel=0.15)
    assert mc["strapdown"] == pytest.approx(p["strapdown"], rel=0.15)


def test_mc_white_angle_noise_bounded_on_platform_growing_in_strapdown():
    comps = [Component("Q", (1e-4 * A) ** 2)]
    mc = monte_carlo_attitude(comps, duration_s=T, dt=DT, omega=1.0, runs=300, seed=2)
    p = pred(comps, 1.0)
    assert p["platform"] / A**2 == pytest.approx(6e-8, rel=1e-9)  # 6 σ_w², bounded
    assert p["strapdown"] / A**2 == pytest.approx(1.8e-7, rel=1e-9)  # + 2 σ_w² dt Ω² T
    assert mc["platform"] == pytest.approx(p["platform"], rel=0.15)
    assert mc["strapdown"] == pytest.approx(p["strapdown"], rel=0.15)


def test_mc_markov_strapdown_better():
    comps = [Component("markov", 2.5e-11 * A * A, 5.0)]
    mc = monte_carlo_attitude(comps, duration_s=T, dt=DT, omega=[0.1, 1.0], runs=300, seed=3)
    notes = {"platform": 4.5e-8, 0.1: 3.90e-8, 1.0: 1.615e-8}
    assert pred(comps, 0.0)["platform"] / A**2 == pytest.approx(notes["platform"], rel=0.02)
    for w, mcv in zip((0.1, 1.0), mc["strapdown"]):
        p = pred(comps, w)["strapdown"]
        assert p / A**2 == pytest.approx(notes[w], rel=0.02)
        assert mcv == pytest.approx(p, rel=0.15)
    assert mc["platform"] == pytest.approx(pred(comps, 0.0)["platform"], rel=0.15)


@pytest.mark.parametrize("comp", [
    Component("N", 1.0), Component("Q", 1.0), Component("markov", 1.0, 5.0),
    Component("K", 1e-6), Component("R", 1e-9), Component("sine", 1.0, 0.3),
    Component("blue", 1.0, 0.5), Component("B", 1e-4, f_hi=50.0),
])
def test_no_rotation_strapdown_equals_platform(comp):
    """Exception 1 (seed 003 §1.2): without vehicle rotation both laws coincide."""
    p = predict_attitude_variance([comp], 3600.0, 0.0, tau0=0.01, record_s=8 * 3600)
    assert p["strapdown"] == pytest.approx(p["platform"], rel=1e-9)


def test_closed_forms():
    K = Component("K", 4.0)
    assert axial_variance(K, 10.0, tau0=0.1, record_s=100) == pytest.approx(4.0 * 1000 / 3)
    w = 0.5
    assert transverse_variance(K, 10.0, w, tau0=0.1, record_s=100) == pytest.approx(
        2 * 4.0 / w**2 * (10.0 - math.sin(w * 10.0) / w))
    # a transverse sinusoid at the vehicle rate grows secularly (resonance)
    s = Component("sine", 1.0, 1.0 / (2 * math.pi))
    assert transverse_variance(s, 1000.0, 1.0, tau0=0.01, record_s=1e4) > 1e4 * \
        axial_variance(s, 1000.0, tau0=0.01, record_s=1e4)


def test_flicker_angle_variance_closed_form_vs_quadrature():
    """The flicker (B) angle variance 2∫ c/(2πf)·sin²(πft)/(πf)² df in closed form (Ci) against
    a direct adaptive quadrature of the defining integral at rel. tolerance 1e-13, over t from
    10 ms to 10⁶ s, records from 10 s to 10⁷ s and cut-offs f_hi on both sides of 20/t."""
    from scipy import integrate

    from gyrotest.noise.impact import _flicker_angle_var

    def direct(c, t, f_lo, f_hi):
        def g(u):  # in ln f
            f = math.exp(u)
            return 2.0 * c / (2 * math.pi) * (math.sin(math.pi * f * t) / (math.pi * f)) ** 2

        cuts = sorted({math.log(f_lo), math.log(f_hi)} | {
            math.log(k / t) for k in (0.25, 0.5, 1, 2, 4, 8, 16, 32) if f_lo < k / t < f_hi})
        return sum(integrate.quad(g, a, b, epsabs=0.0, epsrel=1e-13, limit=2000)[0]
                   for a, b in zip(cuts[:-1], cuts[1:]))

    for t in (0.01, 1.0, 100.0, 3600.0, 1e6):
        for rec in (10.0, 1e3, 1e5, 1e7):
            for f_hi in (0.5, 50.0, 5000.0):
                if f_hi > 20.0 / t:  # the closed form's analytic tail is the sin² → ½ limit
                    f_hi = 20.0 / t
                if f_hi <= 1.0 / rec:
                    continue
                assert _flicker_angle_var(2.0, t, 1.0 / rec, f_hi) == pytest.approx(
                    direct(2.0, t, 1.0 / rec, f_hi), rel=1e-11), (t, rec, f_hi)
    assert _flicker_angle_var(2.0, 10.0, 1.0, 1.0) == 0.0


def test_white_angle_diffusion_example_from_the_notes():
    """Q = 1 arcsec, τ0 = 0.01 s, Ω = 10 deg/s ⇒ diffusion 2·0.01·(4.848e-6)²·(0.1745)² rad²/s."""
    comps = [("quantization", {"Q": 1.0}), ("arw", {"N": 0.01})]
    tau, sig, edf, lo, hi = table_from_model(comps, tau0=0.01, n=1_000_000)
    f = fit_noise_model(tau, sig, edf, sigma_lo=lo, sigma_hi=hi, terms="Q,N", tau0=0.01)
    w = parse_vehicle_rate("10deg/s")
    imp = attitude_impact(f, horizon_s=3600, vehicle_rates_rad_s=[w], record_s=1e4)
    flag = next(fl for fl in imp.flags if fl["term"] == "Q")
    assert flag["label"] == "platform-benign / strapdown-critical"
    expect = 2 * 0.01 * (math.radians(1 / 3600)) ** 2 * math.radians(10.0) ** 2
    assert flag["strapdown_diffusion_rad2_per_s"][0] == pytest.approx(expect, rel=0.01)
    assert imp.ratio[0] > 1.0
    d = imp.to_dict()
    assert d["strapdown"][0]["sins_to_ins_ratio"] == pytest.approx(imp.ratio[0])
    assert d["platform"]["sigma_att_deg"] > 0


def test_parse_vehicle_rate():
    assert parse_vehicle_rate("10deg/s") == pytest.approx(math.radians(10))
    assert parse_vehicle_rate("0.5 rad/s") == pytest.approx(0.5)
    assert parse_vehicle_rate("60rpm") == pytest.approx(2 * math.pi)
    assert parse_vehicle_rate("5") == pytest.approx(math.radians(5))
    with pytest.raises(InputError):
        parse_vehicle_rate("fast")
    with pytest.raises(InputError):
        parse_vehicle_rate("10 furlongs/s")


def test_markov_and_bias_strapdown_better_at_high_rate():
    comps = [("arw", {"N": 0.001}), ("markov", {"q_c": 30.0, "T_c": 20.0}),
             ("bias_instability", {"B": 0.05, "f0": 1e9})]
    tau, sig, edf, lo, hi = table_from_model(comps, tau0=0.1, n=300_000)
    f = fit_noise_model(tau, sig, edf, sigma_lo=lo, sigma_hi=hi, terms="N,B,markov", tau0=0.1)
    imp = attitude_impact(f, vehicle_rates_rad_s=[math.radians(1), math.radians(100)])
    assert imp.strapdown_sigma_deg[1] < imp.strapdown_sigma_deg[0] < imp.platform_sigma_deg
    assert np.all(np.isfinite(imp.ratio))
