"""End-to-end: the cases of the workbench issue's table, simulated with plain numpy (not the
project's simulator), go through the plain user loop (diagnose → add the named effect, in
place of what it replaces → repeat) and come out right; the noise model the loop ends with is
the gyro's.

The verdict's statistics are tested as properties in ``test_envmodel_selection.py`` and
``test_envmodel_likelihood.py``; the randomized campaign with sealed seeds and real-noise
nulls is ``benchmarks/bench_workbench.py``.
"""

from __future__ import annotations

import math

import pytest
from workbench_cases import CASES, case, user_loop

from gyrotest.envmodel import fit_model, prepare
from gyrotest.envmodel.floor import floor_rms
from gyrotest.envmodel.workbench import diagnose


@pytest.fixture(scope="module")
def prepared():
    cache = {}

    def get(name):
        if name not in cache:
            c = case(name)
            wd = prepare(c.log)
            # the warm-up case's log starts at power-on (bench metadata the user states)
            wd.power_on = name == "warmup"
            cache[name] = (c, wd)
        return cache[name]

    return get


@pytest.mark.parametrize("name", CASES)
def test_issue_case_through_the_user_loop(prepared, name):
    c, wd = prepared(name)
    steps, final = user_loop(wd, c.base)
    added = [s for _, s in steps if s is not None]
    keys = [s.key for s in added]
    todo = [set(m) for m in c.missing]
    for k in keys:
        hit = next((m for m in todo if k in m), None)
        if hit is not None:
            todo.remove(hit)
        else:
            assert k in c.extra_ok, (name, keys, steps[0][0].verdict)
    assert not todo, (name, keys, [d.verdict for d, _ in steps])
    last = steps[-1][0]
    assert not last.found and last.verdict.startswith("no missing effect"), last.verdict
    true = fit_model(wd, c.true_terms)
    got = fit_model(wd, final)
    assert got.rms_holdout <= 1.1 * true.rms_holdout, (got.rms_holdout, true.rms_holdout)
    # the noise model of the final model is the gyro's white noise
    assert got.noise.params.N * 60 == pytest.approx(c.white, rel=0.1)


def test_tumble_is_earth_rate_not_g(prepared):
    c, wd = prepared("tumble")
    d = diagnose(wd, c.base)
    top = d.found[0]
    assert top.spec.key == "earth"
    assert top.coefficients[0]["value"] == pytest.approx(1.0, abs=0.02)


def test_the_verdict_pastes_the_whole_model_and_names_its_evidence(prepared):
    c, wd = prepared("rh")
    d = diagnose(wd, c.base, path_steps=1)
    top = d.found[0]
    assert top.spec.key == "chan" and top.spec.channels == ("RH_pct",)
    hint = top.add_hint(d.base.terms)
    for t in d.base.terms:
        assert t == "bias" or t in hint
    assert "likelihood ratio" in d.verdict and "family-wise p" in d.verdict
    assert "residual noise after it: N =" in d.verdict


def test_floor_rms_closed_form():
    # white only: N²/T_eff; random walk adds K²T/6; flicker B²·ln(T/2T_eff)/(2 ln 2)
    assert floor_rms(0.3, 0, 0, 100, 1e4) == pytest.approx(0.03)
    assert floor_rms(0, 0, 0.001, 100, 6e4) == pytest.approx(0.1)
    assert floor_rms(0, 0.05, 0, 50, 1e4 * 2 * 50 / 1e4 * math.e) ** 2 == pytest.approx(
        0.0025 / (2 * math.log(2)))


def test_bad_reference_run_is_refused_in_one_line(prepared):
    import numpy as np
    from test_envmodel_helpers import make_log

    from gyrotest.core.errors import InputError
    from gyrotest.envmodel.floor import check_reference
    from gyrotest.envmodel.likelihood import reference_noise

    c, wd = prepared("hyhz")
    rng = np.random.default_rng(11)
    ref = make_log(0.3 * rng.normal(size=4 * 3600), 1.0, source="static.csv")
    p = reference_noise(ref, wd)
    assert p.N * 60 == pytest.approx(0.3, rel=0.1)
    check_reference(ref, c.log, wd, p)
    wrong = make_log(0.3 * 3600 * rng.normal(size=4 * 3600), 1.0, source="static_dps.csv")
    with pytest.raises(InputError, match="static_dps.csv.*different rate unit"):
        check_reference(wrong, c.log, wd, reference_noise(wrong, wd))


def test_acceleration_names_do_not_catch_gyro_axes():
    from gyrotest.envmodel.terms import _G_PATTERN

    for name in ("gx", "g_y", "acc_x", "accel_z", "acc_ia_g", "ax_g", "g"):
        assert _G_PATTERN.search(name), name
    for name in ("gyro_y_dps", "gyro_x", "tilt_x", "T_amb"):
        assert not _G_PATTERN.search(name), name
