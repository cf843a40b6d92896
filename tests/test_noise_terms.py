"""Tests of the noise-term registry (gyrotest.noise.terms).

Reference values: notes-allan-topology.md §2.5-2.8 (seed 001, Krobka, with the errata applied)
and GYRO_REFERENCE §4.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy import optimize

from gyrotest.noise.terms import (
    BIAS_INSTABILITY_PLATEAU,
    EARTH_RATE_DPH,
    PLATFORM_BENIGN_LABEL,
    TERMS,
    arw_from_sigma,
    avar_from_psd,
    get_term,
    mixture_avar,
    quantization_from_scale_factor,
    sigma_from_arw,
)

TAUS = np.array([0.003, 0.03, 0.3, 3.0, 30.0, 300.0])

# (key, params in reported units, tau0 for band-limited quantization)
CONVERGENT_CASES = [
    ("arw", {"N": 0.01}),
    ("bias_instability", {"B": 0.05, "f0": 0.2}),
    ("bias_instability", {"B": 2.0, "f0": 50.0}),
    ("rrw", {"K": 0.3}),
    ("markov", {"q_c": 2.0, "T_c": 5.0}),
    ("markov", {"q_c": 0.5, "T_c": 0.002}),
    ("sinusoid", {"Omega0": 3.0, "f0": 0.7}),
    ("blue_markov_derivative", {"alpha": 2.0, "beta": 1.5}),
    ("blue_exp", {"alpha": 1.3, "beta": 0.7, "n": 1}),
    ("blue_exp", {"alpha": 1.3, "beta": 0.7, "n": 1.5}),
    ("blue_exp", {"alpha": 1.3, "beta": 0.7, "n": 2}),
    ("blue_exp", {"alpha": 1.3, "beta": 0.7, "n": 3}),
    ("blue_exp", {"alpha": 1.3, "beta": 0.7, "n": 4.5}),
    ("blue_gauss", {"alpha": 0.8, "beta": 0.4, "n": 1.5}),
    ("blue_gauss", {"alpha": 0.8, "beta": 0.4, "n": 2}),
    ("blue_gauss", {"alpha": 0.8, "beta": 0.4, "n": 3}),
    ("blue_gauss", {"alpha": 0.8, "beta": 0.4, "n": 4.5}),
]


@pytest.mark.parametrize(("key", "params"), CONVERGENT_CASES)
def test_closed_form_matches_numeric_psd_integral(key, params):
    term = TERMS[key]
    closed = term.avar(TAUS, **params)
    numeric = avar_from_psd(
        lambda f: term.psd(f, **params), TAUS, f_max=term.f_max(**params), lines=term.lines(**params)
    )
    np.testing.assert_allclose(numeric, closed, rtol=1e-7)


def test_quantization_psd_gives_3q2_over_tau2_at_even_m():
    term = TERMS["quantization"]
    tau0 = 0.01
    taus = tau0 * np.array([2, 10, 100, 1000])
    numeric = avar_from_psd(
        lambda f: term.psd(f, tau0=tau0, Q=0.7), taus, f_max=term.f_max(tau0=tau0, Q=0.7)
    )
    np.testing.assert_allclose(numeric, 3 * 0.7**2 / taus**2, rtol=1e-9)
    assert term.f_max(tau0=tau0, Q=0.7) == pytest.approx(50.0)


def test_rate_ramp_closed_form_and_divergent_psd():
    term = TERMS["rate_ramp"]
    # sigma(sqrt(2) h) = R, R in deg/h/h
    assert term.adev(math.sqrt(2) * 3600.0, R=0.25) == pytest.approx(0.25)
    assert term.deterministic
    # the formal PSD R^2/(2 pi f)^3 grows without bound as f -> 0 (eq. 5.1 diverges)
    assert term.psd(1e-6, R=1.0) > 1e6 * term.psd(1e-2, R=1.0)


# ---- reference values (notes §2.7) ---------------------------------------------------------

BI_TABLE = [
    (0.01, 0.0056418),
    (0.1, 0.056325),
    (0.3, 0.166745),
    (1, 0.480441),
    (2, 0.646802),
    (3, 0.656355),
    (5, 0.661046),
    (10, 0.663296),
    (30, 0.664184),
    (100, 0.664274),
]


@pytest.mark.parametrize(("x", "ratio"), BI_TABLE)
def test_bias_instability_sigma_over_b_table(x, ratio):
    f0 = 0.5
    tau = x / (np.pi * f0)
    assert TERMS["bias_instability"].adev(tau, B=3.0, f0=f0) / 3.0 == pytest.approx(ratio, rel=2e-5)


def test_bias_instability_plateau_from_below_and_small_x():
    assert BIAS_INSTABILITY_PLATEAU == pytest.approx(0.66428, abs=1e-5)
    x = np.logspace(-3, 4, 4000)
    ratio = TERMS["bias_instability"].adev(x / np.pi, B=1.0, f0=1.0)
    assert np.all(ratio <= BIAS_INSTABILITY_PLATEAU + 1e-12)  # no overshoot
    assert ratio[-1] == pytest.approx(BIAS_INSTABILITY_PLATEAU, rel=1e-4)
    # small x: sigma ~ (x / sqrt(pi)) B
    assert ratio[0] == pytest.approx(1e-3 / math.sqrt(math.pi), rel=1e-5)
    # 99 % of the plateau at x ~ 4.2 (tau ~ 1.34/f0)
    x99 = optimize.brentq(
        lambda xx: TERMS["bias_instability"].adev(xx / np.pi, B=1.0, f0=1.0)
        - 0.99 * BIAS_INSTABILITY_PLATEAU,
        2.5,
        4.6,
    )
    assert x99 == pytest.approx(4.2, abs=0.1)


def test_bias_instability_series_branch_is_continuous():
    term = TERMS["bias_instability"]
    x = np.array([0.5 - 1e-9, 0.5 + 1e-9])
    v = term.avar(x / np.pi, B=1.0, f0=1.0)
    assert v[0] == pytest.approx(v[1], rel=1e-8)


MARKOV_G = [(0.01, 0.0575191), (0.1, 0.175915), (1, 0.409989), (10, 0.291549), (100, 0.0992472)]


@pytest.mark.parametrize(("u", "g"), MARKOV_G)
def test_markov_g_values(u, g):
    # q_c = 60 deg/h/sqrt(h) = 1 (deg/h)/sqrt(s) internally; T_c = 4 s
    T_c = 4.0
    sigma = TERMS["markov"].adev(u * T_c, q_c=60.0, T_c=T_c)
    assert sigma / math.sqrt(T_c) == pytest.approx(g, abs=6e-7)


def test_markov_peak_and_asymptotes():
    term = TERMS["markov"]
    res = optimize.minimize_scalar(
        lambda u: -term.adev(u, q_c=60.0, T_c=1.0), bounds=(0.5, 5), method="bounded",
        options={"xatol": 1e-9},
    )
    assert res.x == pytest.approx(1.89262, abs=2e-5)
    assert -res.fun == pytest.approx(0.436542, abs=1e-6)
    # u << 1: q_c^2 tau / 3 ; u >> 1: (q_c T_c)^2 / tau (ARW with N_eq = q_c T_c)
    assert term.avar(1e-4, q_c=60.0, T_c=1.0) == pytest.approx(1e-4 / 3, rel=1e-3)
    assert term.avar(1e5, q_c=60.0, T_c=1.0) == pytest.approx(1e-5, rel=1e-4)
    # series branch continuity at u = 0.02
    v = term.avar(np.array([0.02 - 1e-10, 0.02 + 1e-10]), q_c=60.0, T_c=1.0)
    assert v[0] == pytest.approx(v[1], rel=1e-8)


def test_sinusoid_lobes_and_nulls():
    term = TERMS["sinusoid"]
    f0, om = 2.5, 4.0
    res = optimize.minimize_scalar(
        lambda t: -term.adev(t, Omega0=om, f0=f0), bounds=(0.05, 0.35), method="bounded",
        options={"xatol": 1e-10},
    )
    assert res.x * f0 == pytest.approx(0.37101, abs=2e-5)
    assert -res.fun / om == pytest.approx(0.724611, abs=1e-6)
    res2 = optimize.minimize_scalar(
        lambda t: -term.adev(t, Omega0=om, f0=f0), bounds=(1.1 / f0, 1.9 / f0), method="bounded",
        options={"xatol": 1e-10},
    )
    assert res2.x * f0 == pytest.approx(1.46557, abs=2e-5)
    assert -res2.fun / om == pytest.approx(0.214661, abs=1e-6)
    assert np.all(term.adev(np.arange(1, 6) / f0, Omega0=om, f0=f0) < 1e-12)


BLUE_TABLE = [
    ("blue_exp", {"n": 1}, (0.98561, 0.4965714, 0.07708331)),
    ("blue_exp", {"n": 2}, (1.622911, 0.3837895, 0.03897867)),
    ("blue_exp", {"n": 3}, (2.907398, 0.3955071, 0.03899101)),
    ("blue_gauss", {"n": 2}, (0.4726267, 0.3669892, 0.03670018)),
    ("blue_gauss", {"n": 3}, (0.5703705, 0.28621, 0.02757519)),
    ("blue_markov_derivative", {}, (3.025994, 0.4879941, 0.04886025)),
]


@pytest.mark.parametrize(("key", "extra", "expected"), BLUE_TABLE)
def test_blue_families_reference_values(key, extra, expected):
    sig = TERMS[key].adev(np.array([0.1, 1.0, 10.0]), alpha=1.0, beta=1.0, **extra)
    np.testing.assert_allclose(sig, expected, rtol=5e-6)


def test_table_7_2_corrected_rows():
    tau = np.array([0.05, 0.3, 2.0])
    a, b = 1.7, 0.6
    t2 = 4 * np.pi**2 * tau**2
    # f^2 e^-bf: 96 alpha (not alpha^2)
    row2 = 96 * a * np.pi**2 * tau**2 / (b * (b**2 + t2) * (b**2 + 4 * t2))
    np.testing.assert_allclose(TERMS["blue_exp"].avar(tau, alpha=a, beta=b, n=2), row2, rtol=1e-10)
    # f^3 e^-bf: 64 pi^4 tau^4 (printed 60)
    row3 = (
        96 * a * np.pi**2 * tau**2 * (5 * b**4 + 60 * b**2 * np.pi**2 * tau**2
                                      + 64 * np.pi**4 * tau**4)
        / (b**2 * (b**2 + t2) ** 2 * (b**2 + 4 * t2) ** 2)
    )
    np.testing.assert_allclose(TERMS["blue_exp"].avar(tau, alpha=a, beta=b, n=3), row3, rtol=1e-9)


def test_blue_exp_n1_is_limit_of_general_formula():
    tau = np.array([0.1, 1.0, 10.0])
    v1 = TERMS["blue_exp"].avar(tau, alpha=1.0, beta=1.0, n=1)
    v = TERMS["blue_exp"].avar(tau, alpha=1.0, beta=1.0, n=1 + 1e-6)
    np.testing.assert_allclose(v, v1, rtol=1e-4)


def test_table_7_3_is_white_minus_markov():
    alpha, beta = 2.0, 0.3
    f = np.logspace(-3, 2, 50)
    T_c = 1 / (2 * np.pi * beta)
    q_int = math.sqrt(alpha) / T_c  # (q_c T_c)^2 = alpha
    markov = TERMS["markov"].psd(f, q_c=q_int * 60.0, T_c=T_c)
    np.testing.assert_allclose(
        TERMS["blue_markov_derivative"].psd(f, alpha=alpha, beta=beta), alpha - markov, rtol=1e-10
    )
    # long tau: white angle noise of variance alpha/(4 pi beta) -> sigma^2 = 3 var / tau^2
    tau = 1e4
    assert TERMS["blue_markov_derivative"].avar(tau, alpha=alpha, beta=beta) == pytest.approx(
        3 * alpha / (4 * np.pi * beta) / tau**2, rel=1e-9
    )


# ---- slopes and flags ----------------------------------------------------------------------

SLOPE_CASES = [
    ("quantization", {"Q": 1.0}, 1e-3, 1e3),
    ("arw", {"N": 1.0}, 1e-3, 1e3),
    ("bias_instability", {"B": 1.0, "f0": 1.0}, 1e-4, 1e5),
    ("rrw", {"K": 1.0}, 1e-3, 1e3),
    ("rate_ramp", {"R": 1.0}, 1e-3, 1e3),
    ("markov", {"q_c": 1.0, "T_c": 1.0}, 1e-5, 1e6),
    ("blue_markov_derivative", {"alpha": 1.0, "beta": 1.0}, 1e-5, 1e5),
    ("blue_exp", {"alpha": 1.0, "beta": 1.0, "n": 2}, 1e-4, 1e4),
    ("blue_gauss", {"alpha": 1.0, "beta": 1.0, "n": 3}, 1e-4, 1e4),
]


@pytest.mark.parametrize(("key", "params", "t_short", "t_long"), SLOPE_CASES)
def test_asymptotic_slopes(key, params, t_short, t_long):
    term = TERMS[key]

    def slope(t):
        s = term.adev(np.array([t, 1.1 * t]), **params)
        return math.log(s[1] / s[0]) / math.log(1.1)

    assert slope(t_short) == pytest.approx(term.slope_short, abs=0.01)
    assert slope(t_long) == pytest.approx(term.slope_long, abs=0.01)


def test_zero_dc_flags():
    benign = {k for k, t in TERMS.items() if t.platform_benign}
    assert benign == {
        "quantization", "sinusoid", "blue_markov_derivative", "blue_exp", "blue_gauss"
    }
    assert TERMS["quantization"].label == PLATFORM_BENIGN_LABEL
    assert TERMS["markov"].label == ""
    assert TERMS["markov"].psd(1e-9, q_c=60.0, T_c=2.0) == pytest.approx(4.0)  # (q_c T_c)^2
    for key, p in [("blue_exp", {"alpha": 1, "beta": 1, "n": 2}),
                   ("blue_gauss", {"alpha": 1, "beta": 1, "n": 2}),
                   ("blue_markov_derivative", {"alpha": 1, "beta": 1})]:
        assert TERMS[key].psd(1e-8, **p) < 1e-12


# ---- units ---------------------------------------------------------------------------------


def test_arw_unit_conversion():
    term = TERMS["arw"]
    # N[deg/sqrt(h)] = sigma(1 s)[deg/h] / 60
    N = 0.02
    assert term.adev(1.0, N=N) == pytest.approx(60 * N)
    assert term.adev(3600.0, N=N) == pytest.approx(N)
    assert term.to_internal(N=N) == {"N": pytest.approx(1.2)}
    assert term.from_internal(N=1.2) == {"N": pytest.approx(N)}
    assert term.psd(1.0, N=N) == pytest.approx((60 * N) ** 2)
    assert arw_from_sigma(term.adev(1.0, N=N), 1.0) == pytest.approx(N)
    assert sigma_from_arw(N, 1.0) == pytest.approx(60 * N)


def test_optolink_n_upper():
    assert arw_from_sigma(1.0, 1.0 / 2000.0) == pytest.approx(3.727e-4, rel=1e-3)


def test_other_unit_conversions():
    # K: sigma(3 h) = K ; R: sigma(sqrt 2 h) = R ; Q: sigma(sqrt 3 s) = Q
    assert TERMS["rrw"].adev(3 * 3600.0, K=0.07) == pytest.approx(0.07)
    assert TERMS["rrw"].to_internal(K=60.0)["K"] == pytest.approx(1.0)
    assert TERMS["rate_ramp"].to_internal(R=3600.0)["R"] == pytest.approx(1.0)
    assert TERMS["quantization"].adev(math.sqrt(3), Q=0.4) == pytest.approx(0.4)
    assert quantization_from_scale_factor(0.2) == pytest.approx(0.2 / math.sqrt(12))
    # Markov: long-tau equivalent ARW N_eq = q_c T_c (internal) -> /60 in deg/sqrt(h)
    q_c, T_c = 3.0, 10.0
    tau = 1e6
    n_eq = q_c / 60 * T_c / 60
    assert TERMS["markov"].adev(tau, q_c=q_c, T_c=T_c) == pytest.approx(
        TERMS["arw"].adev(tau, N=n_eq), rel=1e-4
    )
    for key, term in TERMS.items():
        params = {p.name: 1.7 for p in term.params}
        back = term.from_internal(**term.to_internal(**params))
        assert back == pytest.approx(params), key


def test_mixture_and_registry_api():
    tau = np.array([0.1, 1.0, 10.0])
    total = mixture_avar(tau, [("arw", {"N": 0.01}), ("rrw", {"K": 0.1})])
    np.testing.assert_allclose(
        total, TERMS["arw"].avar(tau, N=0.01) + TERMS["rrw"].avar(tau, K=0.1)
    )
    with pytest.raises(KeyError, match="known"):
        get_term("flicker")
    with pytest.raises(TypeError, match="missing"):
        TERMS["markov"].avar(1.0, q_c=1.0)
    with pytest.raises(TypeError, match="unknown"):
        TERMS["arw"].avar(1.0, N=1.0, K=2.0)
    with pytest.raises(ValueError):
        TERMS["arw"].avar(0.0, N=1.0)
    json.dumps({k: t.to_dict() for k, t in TERMS.items()})
    assert EARTH_RATE_DPH == pytest.approx(15.041067, abs=1e-6)


@pytest.mark.parametrize("n", [1.5, 2, 3, 4.5])
def test_blue_gauss_series_branch_is_continuous(n):
    t0 = math.sqrt(0.05) / math.pi  # z = pi^2 tau^2 / beta = 0.05 with beta = 1
    v = TERMS["blue_gauss"].avar(np.array([t0 * (1 - 1e-9), t0 * (1 + 1e-9)]), alpha=1.0, beta=1.0, n=n)
    assert v[0] == pytest.approx(v[1], rel=1e-7)
