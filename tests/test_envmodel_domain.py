"""Domain fits: Antonova–Matveev thermal model (chamber run and the paper's set-point table),
magnetic sensitivities from a Helmholtz sequence, and the compensation transfer test."""

from __future__ import annotations

import numpy as np
import pytest
from test_envmodel_helpers import simulated

from gyrotest.core.errors import InputError
from gyrotest.envmodel import fit_model, prepare
from gyrotest.envmodel.compensation import compensate
from gyrotest.envmodel.domain import (
    ANTONOVA_MATVEEV_PAPER,
    ANTONOVA_MATVEEV_SETPOINTS,
    mag_fit,
    read_setpoints,
    thermal_fit,
    thermal_fit_setpoints,
)


@pytest.fixture(scope="module")
def simdir(tmp_path_factory):
    return tmp_path_factory.mktemp("envdom")


def test_thermal_fit_recovers_paper_coefficients_from_chamber_run(simdir):
    """Simulated chamber run with the paper's w0, w1, w2, w_dV: recovered within 5 %."""
    res, log, _ = simulated("thermal_antonova.toml", 1, simdir)
    truth = res.truth["thermal"][0]
    wd = prepare(log, t_ref=21.0)
    th = thermal_fit(wd)
    for name in ("w0", "w1", "w2", "w_dV"):
        c = th.coef(name)
        # within 3 of its own standard errors (GLS under the fitted noise model) and 15 %
        assert abs(c.value - truth[name]) <= max(3 * c.stderr, 0.15 * abs(truth[name])), \
            (name, c.value, c.stderr)
    assert th.ieee_coefficients[0].name == "D_T"
    assert "heating_minus_cooling_dph" in th.hysteresis
    assert abs(th.hysteresis["z"]) < 4  # no hysteresis simulated


def test_thermal_fit_picks_the_sensor_that_sees_the_driving_temperature(simdir):
    """The team's antonova_thermal.toml logs two lagging coil thermocouples and a control
    sensor on the ambient air (the paper's model is in ambient temperature)."""
    res, log, _ = simulated("antonova_thermal.toml", 6, simdir)
    wd = prepare(log, t_ref=21.0)
    th = thermal_fit(wd)
    assert th.sensor == "T_ctrl_C"
    assert th.coef("w_dV").value == pytest.approx(1.997, rel=0.05)
    assert th.coef("w2").value == pytest.approx(0.004, rel=0.1)
    assert any("sensor chosen" in n for n in th.notes)


def test_setpoint_table_of_the_paper(tmp_path):
    """GYRO_REFERENCE §6: thermostat 31...55 degC, deviations from the unheated value. A
    quadratic in ΔT = T − 21 reproduces the published w0, w1, w2 within 10 %."""
    p = tmp_path / "thermostat.csv"
    p.write_text("thermostat_C,dw_dph,sigma_dph\n" + "".join(
        f"{T},{dw},{s}\n" for T, dw, s in ANTONOVA_MATVEEV_SETPOINTS))
    tab = read_setpoints(p)
    sp = thermal_fit_setpoints(tab["temp"], tab["drift"], tab["sigma"], t0_c=21.0)
    # independent reference: numpy polyfit
    T = np.array([r[0] for r in ANTONOVA_MATVEEV_SETPOINTS], float)
    dw = np.array([r[1] for r in ANTONOVA_MATVEEV_SETPOINTS])
    ref = np.polyfit(T - 21.0, dw, 2)[::-1]
    for i, name in enumerate(("w0", "w1", "w2")):
        assert sp.coef(name).value == pytest.approx(ref[i], rel=1e-9)
        assert sp.coef(name).value == pytest.approx(ANTONOVA_MATVEEV_PAPER[name], rel=0.10)
    assert sp.coef("w1").value < 0 < sp.coef("w2").value
    assert sp.dof == 3 and sp.rms_dph < 0.1
    assert any("not identifiable" in n for n in sp.notes)
    wsp = thermal_fit_setpoints(tab["temp"], tab["drift"], tab["sigma"], weighted=True)
    assert wsp.weighted and wsp.coef("w2").value == pytest.approx(0.00393, rel=0.01)
    bad = tmp_path / "bad.csv"
    bad.write_text("x,y\n1,2\n")
    with pytest.raises(InputError, match="no temperature column"):
        read_setpoints(bad)


def test_mag_fit_recovers_helmholtz_sensitivities(simdir):
    res, log, _ = simulated("magnetic_helmholtz.toml", 1, simdir)
    true = res.truth["magnetic"]["w_dph_per_100uT"]
    mg = mag_fit(prepare(log))
    got = {c.name: c.value for c in mg.coefficients}
    for ax, w in zip("xyz", true):
        assert abs(got[f"w{ax}"] - w) <= 0.01, (ax, got[f"w{ax}"], w)
    # plateaus: 25 levels per axis (the zero levels between axes merge)
    assert 70 <= len(mg.plateaus) <= 76
    assert {p.axis for p in mg.plateaus if p.level_uT} == {"x", "y", "z"}
    # the paper's reversal K agrees with the fitted slope
    assert mg.reversal["y"]["signed_dph_per_100uT"] == pytest.approx(true[1], abs=0.03)
    assert mg.reversal["y"]["levels_uT"][0] == pytest.approx(300, abs=1)
    for ax in "xyz":
        h = mg.hysteresis[ax]
        assert h["pairs"] >= 10 and abs(h["up_minus_down_dph"]) < 4 * h["stderr_dph"]


def test_compensation_transfers_with_predicted_factor(simdir):
    """Fit on one run, apply to a second run with the same physics: the drift RMS falls by the
    factor the model predicts (±20 %)."""
    _, log1, _ = simulated("hidden_rate.toml", 21, simdir)
    _, log2, _ = simulated("hidden_rate.toml", 22, simdir)
    fit = fit_model(prepare(log1, t_ref=21.0), ["T(T_case_C)", "dTdt(T_case_C)"])
    cp = compensate(log2, fit.model)
    assert cp.factor > 5
    assert 0.8 <= cp.factor / cp.predicted_factor <= 1.2, (cp.factor, cp.predicted_factor)
    assert cp.adev_after[-1] < cp.adev_before[-1]
    assert np.allclose(cp.log.rates[cp.axis] + cp.prediction, log2.rates[cp.axis])
    assert not cp.warnings
