"""Krobka's checks: each rule fires on a purpose-built case and all stay silent on a clean
ARW + bias-instability + RRW log."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
from test_noise_fit import sim_rate, table_from_model

from gyrotest.core.data import GyroConstants, GyroLog, Timing
from gyrotest.noise.analysis import analyse_allan
from gyrotest.noise.diagnose import diagnose
from gyrotest.noise.noisefit import fit_noise_model, slope_readoffs
from gyrotest.noise.terms import mixture_avar
from gyrotest.noise.warnings import CODES, krobka_checks, local_slopes


def make_log(rates: dict, tau0: float, *, kind: str = "rate", s0: float | None = None,
             source: str = "sim") -> GyroLog:
    n = len(next(iter(rates.values())))
    return GyroLog(source=source, rates=rates, tau0=tau0,
                   timing=Timing(n=n, tau0=tau0, duration_s=n * tau0, source="test"),
                   gyro=GyroConstants(output_kind=kind, scale_factor=s0))


def checks(comps, terms, *, tau0=0.1, n=200_000, per_decade=10, stop=4, akdev=None,
           quantum=None, with_diagnosis=False):
    tau, sig, edf, lo, hi = table_from_model(comps, tau0=tau0, n=n, per_decade=per_decade,
                                             stop=stop)
    f = fit_noise_model(tau, sig, edf, sigma_lo=lo, sigma_hi=hi, terms=terms, tau0=tau0)
    dg = diagnose(f) if with_diagnosis else None
    ws = krobka_checks(f, slope_readoffs(tau, sig, edf), akdev=akdev, quantum_arcsec=quantum,
                       diagnosis=dg, record_s=n * tau0)
    return {w.code: w for w in ws}, f


HUMP = [("arw", {"N": 0.002}), ("markov", {"q_c": 30.0, "T_c": 1.0})]


def test_codes_are_stable():
    assert CODES == ("KROBKA-M1", "KROBKA-M4", "KROBKA-M5", "KROBKA-R11", "KROBKA-R12",
                     "KROBKA-M12", "KROBKA-M7", "KROBKA-M6", "KROBKA-R16")


def test_m1_minus_half_segment_not_anchored():
    w, _ = checks(HUMP, "N,markov")
    assert "KROBKA-M1" in w
    ev = w["KROBKA-M1"].evidence
    assert ev["N_slope"] > 3 * ev["N_upper"]
    assert "not white rate noise" in w["KROBKA-M1"].message


def test_m4_no_plateau_and_tangent_bound():
    w, _ = checks([("arw", {"N": 0.01}), ("rrw", {"K": 0.2})], "N,B,K")
    assert "KROBKA-M4" in w
    m = w["KROBKA-M4"].message
    assert "crossover" in m and "0.664" in m and "upper bound" in m


def test_m5_hump_reports_both_white_noise_numbers():
    w, _ = checks(HUMP, "N,markov")
    assert "KROBKA-M5" in w
    ev = w["KROBKA-M5"].evidence
    # long-τ effective ARW N_eq = √(N² + (q_c T_c)²): q_c T_c = 30/60·1 (deg/h)√s → /60
    assert ev["N_eq"] == pytest.approx(math.hypot(0.002 * 60, 30 / 60 * 1.0) / 60, rel=0.02)
    assert ev["N_leftmost"] > ev["N_fit"]


def test_r11_slopes_outside_plus_minus_one():
    w, _ = checks([("arw", {"N": 0.002}), ("sinusoid", {"Omega0": 1.0, "f0": 0.05})],
                  "N,sine", per_decade=40)
    assert "KROBKA-R11" in w
    assert "periodic" in w["KROBKA-R11"].message


def test_r12_minus_one_is_ambiguous_and_checks_the_quantum():
    comps = [("quantization", {"Q": 1.0}), ("arw", {"N": 0.001})]
    w, _ = checks(comps, "Q,N", tau0=0.01, n=1_000_000)
    assert w["KROBKA-R12"].severity == "warning"
    assert "cannot tell" in w["KROBKA-R12"].title or "not identifiable" in w["KROBKA-R12"].title
    w, _ = checks(comps, "Q,N", tau0=0.01, n=1_000_000, quantum=math.sqrt(12.0))
    assert w["KROBKA-R12"].severity == "info"
    w, _ = checks(comps, "Q,N", tau0=0.01, n=1_000_000, quantum=3 * math.sqrt(12.0))
    assert w["KROBKA-R12"].severity == "warning" and "differs" in w["KROBKA-R12"].message


def test_m12_too_few_clusters():
    w, f = checks([("arw", {"N": 0.01})], "N,K", stop=1.2)
    assert "KROBKA-M12" in w
    assert "fit stopped at" in w["KROBKA-M12"].message


def test_m7_deterministic_trend():
    comps = [("arw", {"N": 0.01}), ("rate_ramp", {"R": 0.5})]
    tau, sig, edf, lo, hi = table_from_model(comps, tau0=0.1, n=300_000)
    long = tau[-6:]
    ak = SimpleNamespace(tau=long, sigma=np.sqrt(mixture_avar(long, comps[:1])))
    w, _ = checks(comps, "N,K,R", n=300_000, akdev=ak)
    assert "KROBKA-M7" in w
    assert w["KROBKA-M7"].evidence["ramp_estimate_deg_h_per_h"] == pytest.approx(0.5, rel=0.05)
    assert "--detrend linear" in w["KROBKA-M7"].message


def test_m6_misfit_names_the_missing_term():
    w, _ = checks(HUMP, "N,B", with_diagnosis=True)
    assert "KROBKA-M6" in w
    assert "markov" in w["KROBKA-M6"].message
    assert "KROBKA-R16" not in w  # same root cause: not repeated


def test_r16_component_above_the_measurement():
    """A consistent fit in which one component alone exceeds the measured curve: the pinned
    flat B of a bias-instability template fitted as flat where the real one still rises."""
    comps = [("arw", {"N": 0.01}), ("bias_instability", {"B": 0.05, "f0": 1e9})]
    tau, sig, edf, lo, hi = table_from_model(comps, tau0=0.1, n=300_000)
    f = fit_noise_model(tau, sig, edf, sigma_lo=lo, sigma_hi=hi, terms="N,B", tau0=0.1)
    b = f.term("B")
    b.coef *= 9.0  # a B three times too large, as a trade-off with another term would give
    from gyrotest.noise.warnings import _component_checks

    f_consistent = f
    f_consistent.__class__ = type("C", (type(f),), {"consistent": property(lambda s: True)})
    out = []
    _component_checks(f_consistent, out)
    assert out and out[0].code == "KROBKA-R16" and "B" in out[0].title


def test_local_slopes_of_pure_power_laws():
    tau, sig, _, lo, hi = table_from_model([("arw", {"N": 0.01})])
    sl = local_slopes(tau, sig, lo, hi)
    assert all(abs(d["slope"] + 0.5) < 1e-6 for d in sl)


@pytest.mark.parametrize("seed", [6, 7])
def test_silent_on_clean_arw_bias_rrw_log(seed):
    r = sim_rate({"N": 0.005, "B": 0.02, "K": 0.005}, hours=8, fs=10.0, seed=seed)
    a = analyse_allan(make_log({"gyro": r.rate_dph}, 0.1))
    ax = a.axes[0]
    assert ax.warnings == [], [w.text() for w in ax.warnings]
    assert ax.fit.term("N").identified and ax.fit.term("B").identified
    assert ax.diagnosis.no_missing_term
