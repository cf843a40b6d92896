"""Statistical verification of the simulator: the overlapping Allan variance of simulated
records matches the closed forms of gyrotest.noise.terms.

Each case simulates K independent records (seeds), estimates the overlapping AVAR at several
tau = m*tau0 and compares the mean over seeds with the closed form of the noises listed in
the truth (``truth["noise"]["components"]``): |mean/theory - 1| must lie within 4 standard
errors (the spread over seeds) plus a small allowance for the FFT synthesis grid, and the
standard error must be small enough for the check to mean something.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from gyrotest.noise.terms import TERMS, mixture_avar
from gyrotest.simulation import simulate


def oavar(rate: np.ndarray, tau0: float, ms) -> np.ndarray:
    """Overlapping Allan variance of rate samples (IEEE 952 Annex C / SP1065 eq. 11)."""
    th = np.concatenate(([0.0], np.cumsum(rate - rate.mean()) * tau0))
    out = []
    for m in ms:
        d = th[2 * m:] - 2 * th[m:-m] + th[:-2 * m]
        out.append(np.mean(d * d) / (2.0 * (m * tau0) ** 2))
    return np.array(out)


def run_case(scenario: dict, ms, seeds, extract=None, components=None):
    ests = []
    truth = None
    tau0 = None
    for s in seeds:
        r = simulate(scenario, seed=s).run
        tau0 = r.tau0
        truth = r.truth
        y = r.rate_dph if extract is None else extract(r)
        ests.append(oavar(y, tau0, ms))
    ests = np.array(ests)
    taus = np.asarray(ms) * tau0
    comps = truth["noise"]["components"] if components is None else components
    theory = mixture_avar(taus, comps)
    mean = ests.mean(axis=0)
    se = ests.std(axis=0, ddof=1) / math.sqrt(len(seeds)) if len(seeds) > 1 else None
    return taus, mean, se, theory


def assert_matches(mean, se, theory, allowance=0.005, max_rel_se=0.12):
    ratio = mean / theory
    rel_se = se / theory
    assert np.all(rel_se < max_rel_se), rel_se
    bad = np.abs(ratio - 1) > 4 * rel_se + allowance
    assert not bad.any(), f"ratio {ratio}, rel SE {rel_se}"


def scen(fs, n, noise, **gyro):
    return {"record": {"sample_rate_hz": fs, "duration_s": n / fs},
            "gyro": {"output": "rate", "bias_dph": 0.7, "noise": noise, **gyro}}


SEEDS = range(8)


def test_arw():
    taus, mean, se, th = run_case(scen(100.0, 2**16, {"N": 0.01}),
                                  [1, 4, 16, 64, 256, 1024], SEEDS)
    np.testing.assert_allclose(th, TERMS["arw"].avar(taus, N=0.01))
    assert_matches(mean, se, th)


def test_bias_instability():
    taus, mean, se, th = run_case(scen(10.0, 2**16, {"B": 0.05, "B_f0_hz": 0.5}),
                                  [1, 3, 10, 30, 100, 300], SEEDS)
    # the curve rises with slope +1 and reaches the 0.664 B plateau within this tau range
    assert th[-1] == pytest.approx((0.6643 * 0.05) ** 2, rel=0.01)
    assert_matches(mean, se, th)


def test_rate_random_walk():
    taus, mean, se, th = run_case(scen(10.0, 2**16, {"K": 0.1}), [1, 4, 16, 64, 256], SEEDS)
    assert_matches(mean, se, th, max_rel_se=0.15)


def test_markov():
    taus, mean, se, th = run_case(scen(20.0, 2**16, {"markov": [{"q_c": 60.0, "T_c": 2.0}]}),
                                  [1, 4, 16, 76, 300, 1200], SEEDS)
    assert th[3] == pytest.approx((0.436542 * math.sqrt(2.0)) ** 2, rel=1e-3)  # peak 3.8 s
    assert_matches(mean, se, th)


def test_sinusoid_single_record():
    f0 = 0.37
    sc = scen(20.0, 2**16, {"sinusoid": [{"amplitude_dph": 2.0, "freq_hz": f0}]})
    ms = [1, 5, 20, 40, 60]  # includes the first lobe at 0.371/f0 = 1.0 s (m = 20)
    taus, mean, _, th = run_case(sc, ms, [3])
    np.testing.assert_allclose(mean, th, rtol=0.01)
    assert math.sqrt(th[2]) == pytest.approx(0.7246 * 2.0, rel=1e-3)


def test_blue_markov_derivative():
    sc = scen(20.0, 2**16, {"blue": [{"family": "blue_markov_derivative", "alpha": 1.0,
                                      "beta": 0.5}]})
    taus, mean, se, th = run_case(sc, [1, 4, 16, 64, 256, 1024], SEEDS)
    assert_matches(mean, se, th)


def test_blue_exp_fft_shaped():
    sc = scen(20.0, 2**16, {"blue": [{"family": "blue_exp", "alpha": 1.0, "beta": 2.0,
                                      "n": 2}]})
    taus, mean, se, th = run_case(sc, [1, 4, 16, 64, 256], SEEDS)
    assert_matches(mean, se, th)


def test_quantization_by_pulse_integration():
    # S0 = 2 arcsec; ARW large enough (3 arcsec per sample) to make the angle error uniform
    s0, fs = 2.0, 100.0
    sc = {"record": {"sample_rate_hz": fs, "duration_s": 2**15 / fs},
          "gyro": {"output": "counts", "scale_factor": s0, "bias_dph": 5.3,
                   "noise": {"N": 0.5}}}
    ms = [1, 2, 8, 32, 128]
    # (a) the quantization error alone: sigma^2 = 3 Q^2/tau^2 with Q = S0/sqrt(12)
    taus, mean, se, th = run_case(sc, ms, range(4),
                                  extract=lambda r: r.rate_dph - r.ideal_rate_dph,
                                  components=[("quantization", {"Q": s0 / math.sqrt(12)})])
    np.testing.assert_allclose(mean / th, 1.0, atol=0.01)
    # (b) the whole pulse output against ARW + quantization from the truth
    taus, mean, se, th = run_case(sc, ms, SEEDS)
    assert ["quantization", {"Q": pytest.approx(s0 / math.sqrt(12))}] in [
        [c[0], c[1]] for c in simulate(sc, seed=0).truth["noise"]["components"]]
    assert_matches(mean, se, th)


def test_fog_mixture_from_truth_components():
    sc = scen(50.0, 2**17, {"N": 0.005, "B": 0.01, "B_f0_hz": 1.0, "K": 0.003})
    taus, mean, se, th = run_case(sc, [1, 10, 100, 1000, 6000], range(6))
    assert_matches(mean, se, th, max_rel_se=0.15)


def test_oavar_helper_matches_allantools():
    allantools = pytest.importorskip("allantools")
    r = simulate(scen(10.0, 5000, {"N": 0.1, "K": 0.05}), seed=1).run
    ms = [1, 3, 10, 30, 100]
    _, devs, _, _ = allantools.oadev(r.rate_dph, rate=10.0, data_type="freq",
                                     taus=np.array(ms) / 10.0)
    np.testing.assert_allclose(np.sqrt(oavar(r.rate_dph, 0.1, ms)), devs, rtol=1e-9)


def test_single_record_within_deviation_confidence_intervals():
    """One FOG record: the closed form lies inside the chi-square interval (95 %) that
    gyrotest.noise.deviations gives, at most tau up to T/10."""
    dev = pytest.importorskip("gyrotest.noise.deviations")
    r = simulate(scen(50.0, 2**17, {"N": 0.005, "B": 0.01, "B_f0_hz": 1.0, "K": 0.003}),
                 seed=1).run
    d = dev.compute_deviation(r.rate_dph, r.tau0, input_kind="rate", kind="oadev",
                              taus="decade", confidence=0.95)
    keep = d.tau <= r.n * r.tau0 / 10
    th = np.sqrt(mixture_avar(d.tau[keep], r.truth["noise"]["components"]))
    inside = (th >= d.sigma_lo[keep]) & (th <= d.sigma_hi[keep])
    assert inside.mean() >= 0.8, (d.sigma[keep] / th, inside)
    np.testing.assert_allclose(d.sigma[keep], np.sqrt(oavar(r.rate_dph, r.tau0, d.m[keep])),
                               rtol=1e-9)
