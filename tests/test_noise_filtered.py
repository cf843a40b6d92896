"""Filtered white noise (a Markov term with T_c < τ0 is the sensor's filter): N is reported as
N_eq = √(N² + (q_c·T_c)²); checked on a closed-form table and on the real ADIS16405 log."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest
from test_noise_fit import table_from_model

from gyrotest.core.data import GyroConstants, GyroLog, Timing
from gyrotest.noise.analysis import analyse_allan
from gyrotest.noise.filtered import FILTER_STATUS, fold_filter
from gyrotest.noise.noisefit import fit_noise_model

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from bench_conformance import REAL  # noqa: E402

ADIS = REAL / "data" / "adis16405_imu1.csv.gz"


def test_fold_filter_closed_form():
    # q_c = 3600·N_M/T_c (q_c deg/h/√h, T_c s): N_M = 2.0 deg/√h carried by a 3 ms filter, N = 0.5 white beyond it
    T_c, n_m, n_w = 0.003, 2.0, 0.5
    comps = [("arw", {"N": n_w}), ("markov", {"q_c": 3600.0 * n_m / T_c, "T_c": T_c}),
             ("bias_instability", {"B": 5.0, "f0": 1e9})]
    tau, sig, edf, lo, hi = table_from_model(comps, tau0=0.01, n=1_000_000)
    f = fit_noise_model(tau, sig, edf, sigma_lo=lo, sigma_hi=hi, terms=["N", "B", "markov"],
                        tau0=0.01)
    g, info = fold_filter(f, 0.01)
    assert info is not None
    n = g.term("N")
    assert n.identified and n.value == pytest.approx(math.hypot(n_w, n_m), rel=0.02)
    assert g.term("markov").status == FILTER_STATUS
    # the model is unchanged; the original fit object too
    assert np.allclose(g.model_sigma(), f.model_sigma())
    assert f.term("markov").status == "identified"
    # a Markov term slower than τ0 is a real hump: not folded
    comps2 = [("arw", {"N": n_w}), ("markov", {"q_c": 60.0, "T_c": 2.0})]
    tau, sig, edf, lo, hi = table_from_model(comps2, tau0=0.01, n=1_000_000)
    f2 = fit_noise_model(tau, sig, edf, sigma_lo=lo, sigma_hi=hi, terms=["N", "markov"],
                         tau0=0.01)
    assert fold_filter(f2, 0.01)[1] is None


@pytest.mark.skipif(not ADIS.is_file(), reason=f"real ADIS16405 log not found at {ADIS}")
def test_adis16405_reports_the_datasheet_arw():
    import gzip

    with gzip.open(ADIS, "rt") as fh:
        data = np.loadtxt(fh, delimiter=",", skiprows=1, usecols=(1,))
    rate = data * 3600.0  # deg/s -> deg/h
    log = GyroLog(source="adis16405_imu1", rates={"gyro_x": rate}, tau0=0.01,
                  timing=Timing(n=rate.size, tau0=0.01, duration_s=rate.size * 0.01,
                                source="test"),
                  gyro=GyroConstants(output_kind="rate"))
    a = analyse_allan(log, spectral=False, trend_check=False).axes[0]
    n = a.best_fit.term("N")
    assert n.identified and n.value == pytest.approx(2.4, rel=0.05)
    assert any("filtered white noise" in s and "output filter" in s for s in a.notes)
    assert not {"KROBKA-M1", "KROBKA-M5"} & {w.code for w in a.warnings}
    assert a.conversions["N"]["deg_per_rt_h"] == pytest.approx(n.value)
