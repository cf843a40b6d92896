"""Term library of the model workbench: effect formulas, term parsing, safe expressions."""

from __future__ import annotations

import inspect
import math

import numpy as np
import pytest

from gyrotest.core.errors import InputError
from gyrotest.envmodel import terms as tm
from gyrotest.envmodel.expr import parse_expression
from gyrotest.envmodel.terms import (
    EFFECTS,
    EnvFrame,
    TermSpec,
    parse_terms,
    resolve_terms,
    split_terms,
)


def frame(n=1000, dt=1.0, **ch):
    t = np.arange(n) * dt
    return EnvFrame(t=t, dt=dt, bounds=[(0, n)], rate=np.zeros(n), source="log.csv", **ch)


# ----------------------------------------------------------------------------- effect functions
def test_every_effect_documents_formula_units_source():
    for key, e in EFFECTS.items():
        if key == "custom":
            continue
        doc = inspect.getdoc(e.function) or ""
        assert "Formula" in doc, key
        assert "Source" in doc, key
        assert "nit" in doc, key  # Units / unit
        assert e.coef_unit and e.source and e.title


def test_temperature_offset_powers():
    T = np.array([20.0, 21.0, 23.0])
    assert np.allclose(tm.temperature_offset(T, 21.0, 1), [-1, 0, 2])
    assert np.allclose(tm.temperature_offset(T, 21.0, 2), [1, 0, 4])
    assert np.allclose(tm.temperature_offset(T, 21.0, 3), [-1, 0, 8])


def test_smoothed_rate_of_ramp_is_slope_in_degc_per_hour():
    t = np.arange(4000.0)
    T = 20 + 10.0 / 3600 * t  # 10 degC/h
    r = tm.temperature_rate(T, 1.0, 120.0)
    assert np.allclose(r[200:-200], 10.0, atol=1e-9)


def test_smoothed_rate_equals_smoothed_true_rate():
    """d(S_W T)/dt = S_W(dT/dt): the derivative regressor carries no smoothing bias against a
    gyro output smoothed by the same S_W."""
    t = np.arange(6000.0)
    T = 25 + 5 * np.sin(2 * np.pi * t / 1500.0)
    true_rate = 5 * 2 * np.pi / 1500.0 * np.cos(2 * np.pi * t / 1500.0) * 3600
    a = tm.smoothed_rate(T, 1.0, 100.0)
    b = tm.smooth(true_rate, 1.0, 100.0)
    assert np.max(np.abs(a - b)[300:-300]) < 2e-3 * np.max(np.abs(true_rate))


def test_first_order_lag_step_response_and_gap():
    t = np.arange(0, 2000.0)
    x = np.where(t >= 100, 1.0, 0.0)
    y = tm.first_order_lag(x, t, 300.0)
    k = 100 + 600
    assert y[k] == pytest.approx(1 - math.exp(-600 / 300), abs=2e-3)
    # across a gap the state relaxes with the gap length
    bounds = [(0, 1000), (1000, 2000)]
    t2 = t.copy()
    t2[1000:] += 3000.0  # 3000 s hole
    y2 = tm.first_order_lag(x, t2, 300.0, bounds)
    assert y2[1000] == pytest.approx(1 - math.exp(-(3000 + 1) / 300) * (1 - y2[999]), abs=1e-6)


def test_simple_effects():
    assert np.allclose(tm.magnetic_field(np.array([100.0, -300.0])), [1.0, -3.0])
    assert np.allclose(tm.supply_voltage(np.array([14.0, 16.0]), 15.0), [-1, 1])
    assert np.allclose(tm.time_ramp(np.array([0.0, 7200.0])), [0, 2])
    assert tm.warmup_transient(np.array([600.0]), 600.0)[0] == pytest.approx(math.exp(-1))
    s = tm.sinusoid(np.array([0.0, 0.25]), 1.0)
    assert np.allclose(s, [[1, 0], [0, 1]], atol=1e-12)
    assert tm.input_rate(np.array([3.6e6]))[0] == pytest.approx(3.6)
    assert tm.input_rate_temperature(np.array([1e6]), np.array([23.0]), 21.0)[0] == 2.0
    assert np.allclose(tm.acceleration_power(np.array([2.0]), 2), [4.0])


def test_thermal_branch_play_operator():
    t = np.arange(0, 20000.0)
    T = np.interp(t, [0, 3000, 8000, 12000, 20000], [20, 20, 40, 30, 30])
    s = tm.thermal_branch(T, 0.5)
    assert s[1000] == 0  # before any move
    assert s[5000] == pytest.approx(1)  # heating branch
    assert s[8200] == pytest.approx((T[8200] - (40 - 0.5)) / 0.5)  # reversing: in between
    assert s[10000] == pytest.approx(-1)  # cooling branch
    assert s[15000] == pytest.approx(-1)  # steady after cooling: keeps the branch


# ----------------------------------------------------------------------------- parsing
def test_split_terms_respects_parentheses():
    assert split_terms("T,T2(T_coil),dGdt(T_a,T_b), Hx") == ["T", "T2(T_coil)", "dGdt(T_a,T_b)",
                                                             "Hx"]


def test_parse_terms_groups_aliases_custom():
    specs = parse_terms("T,poly2,H,Tdot,vib:extra.vib_g**2")
    assert [s.key for s in specs] == ["T", "T", "T2", "Hx", "Hy", "Hz", "dTdt", "custom"]
    assert specs[-1].name == "vib" and specs[-1].expr == "extra.vib_g**2"
    with pytest.raises(InputError, match="unknown term 'bogus'"):
        parse_terms("bogus")
    with pytest.raises(InputError, match="takes no channel"):
        parse_terms("ramp(T_case)")
    with pytest.raises(InputError, match="built-in"):
        parse_terms("T:temp.T_case*2")


def test_resolve_terms_defaults_and_errors():
    n = 500
    fr = frame(n, temperature={"T_case": np.linspace(20, 30, n), "T_coil": np.linspace(21, 29, n)},
               field_uT={"Hx": np.sin(np.arange(n)), "Hy": np.cos(np.arange(n)),
                         "Hz": np.zeros(n) + np.arange(n) % 3},
               supply=np.full(n, 12.0))
    r = resolve_terms(parse_terms("T,dGdt,Hy"), fr)
    assert [s.label for s in r] == ["T(T_case)", "dGdt(T_case,T_coil)", "Hy(Hy)"]
    with pytest.raises(InputError, match=r"term 'T\(T_foo\)'.*no temperature channel 'T_foo'"):
        resolve_terms(parse_terms("T(T_foo)"), fr)
    with pytest.raises(InputError, match=r"term 'V'.*'supply'.*constant"):
        resolve_terms(parse_terms("V"), fr)
    fr.temperature["T_bad"] = np.full(n, np.nan)
    with pytest.raises(InputError, match=r"T_bad.*all NaN"):
        resolve_terms(parse_terms("T(T_bad)"), fr)
    with pytest.raises(InputError, match="given twice"):
        resolve_terms(parse_terms("T,T(T_case)"), fr)


# ----------------------------------------------------------------------------- safe expressions
def test_expression_evaluates_channels_and_functions():
    n = 100
    fr = frame(n, extra={"vib_g": np.full(n, 2.0)}, temperature={"T c": np.full(n, 3.0)})
    e = parse_expression("extra.vib_g**2 + sqrt(temp['T c']) * 2 - t_h")
    v = e.evaluate(fr, smoothing_s=60)
    assert np.allclose(v, 4 + 2 * math.sqrt(3) - fr.t / 3600)
    lagged = parse_expression("lag(extra.vib_g, 30)").evaluate(fr, smoothing_s=60)
    assert np.allclose(lagged, 2.0)


@pytest.mark.parametrize("bad, why", [
    ("__import__('os').system('true')", "plain function names"),
    ("extra.vib_g.__class__", "only allowed"),
    ("(lambda: 1)()", "plain function"),
    ("[x for x in extra.vib_g]", "not allowed"),
    ("open('x')", "not allowed"),
    ("sqrt(x=extra.vib_g)", "keyword"),
    ("'abc'", "numeric"),
    ("os.system", "unknown namespace"),
    ("extra.vib_g if 1 else 2", "not allowed"),
    ("2 ** 3", "names no channel"),
    ("extra.vib_g +", "syntax"),
])
def test_expression_rejects_unsafe(bad, why):
    with pytest.raises(InputError, match=why):
        parse_expression(bad)


def test_expression_huge_power_does_not_hang():
    n = 10
    fr = frame(n, extra={"a": np.full(n, 10.0)})
    v = parse_expression("extra.a ** 10 ** 10 ** 10").evaluate(fr, smoothing_s=60)
    assert np.all(np.isinf(v))


def test_termspec_dict_roundtrip():
    for s in parse_terms("T2(T_coil),dGdt(a,b),warmup,vib:extra.v*2"):
        assert TermSpec.from_dict(s.to_dict()) == s


def test_moving_mean_equals_the_direct_window_mean_with_shrinking_ends():
    """The cumulative-sum moving mean (full windows on slices, shrinking ones at each
    segment's ends) against the mean of each window written out, over segment lengths below,
    at and above the window, and over segment bounds."""
    from gyrotest.envmodel.effects import moving_mean

    rng = np.random.default_rng(3)
    for n in (1, 2, 5, 14, 15, 16, 40):
        for half in (1, 3, 7):
            x = 100.0 + rng.normal(size=n).cumsum()
            bounds = [(0, n // 3), (n // 3, n)] if n > 2 else None
            want = np.empty(n)
            for a, b in bounds or [(0, n)]:
                for i in range(a, b):
                    h = min(half, i - a, b - 1 - i)
                    want[i] = x[i - h:i + h + 1].mean()
            got = moving_mean(x, half, bounds)
            assert np.allclose(got, want, rtol=0, atol=1e-10), (n, half)
