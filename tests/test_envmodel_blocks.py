"""Field terms that only work together: ``Hvec`` (first-order sensitivity along every field
axis) and ``Hquad`` (every H_i·H_j), for a gyro whose axes are not the coils'. Closed forms,
term parsing, the block-candidate screen, and a rotated-gyro Helmholtz run (plain numpy)
through the user loop."""

from __future__ import annotations

import numpy as np
import pytest
from test_envmodel_helpers import make_log
from workbench_cases import helmholtz, noise, user_loop

from gyrotest.envmodel import fit_model, prepare
from gyrotest.envmodel.channel_terms import field_quadratic, field_vector
from gyrotest.envmodel.screen import block_candidates
from gyrotest.envmodel.terms import TermSpec, parse_terms, resolve_terms
from gyrotest.errors import InputError

HOUR = 3600.0


def _rot(deg_z: float, deg_y: float) -> np.ndarray:
    a, b = np.radians(deg_z), np.radians(deg_y)
    rz = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    ry = np.array([[np.cos(b), 0, np.sin(b)], [0, 1, 0], [-np.sin(b), 0, np.cos(b)]])
    return rz @ ry


def test_field_vector_and_quadratic_closed_forms():
    hx, hy, hz = np.array([100.0, -200.0]), np.array([50.0, 0.0]), np.array([0.0, 300.0])
    v = field_vector([hx, hy, hz])
    assert np.allclose(v, np.column_stack([hx, hy, hz]) / 100.0)
    q = field_quadratic([hx, hy, hz])
    x, y, z = hx / 100, hy / 100, hz / 100
    assert np.allclose(q, np.column_stack([x * x, y * y, z * z, x * y, x * z, y * z]))
    # a rotated second-order term is exactly a combination of the six columns
    R = _rot(7.0, -4.0)
    a = R[0] @ np.vstack([x, y, z])
    b = R[1] @ np.vstack([x, y, z])
    coef, *_ = np.linalg.lstsq(q, a * b, rcond=None)
    assert np.allclose(q @ coef, a * b, atol=1e-12)


def _rotated_log(seed: int = 3):
    rng = np.random.default_rng(seed)
    n = int(6 * HOUR)
    H = helmholtz(n) + 0.05 * rng.normal(size=(3, n))
    w = _rot(5.0, 4.0).T @ np.array([0.6, 0.0, 0.0])  # deg/h per 100 uT, coil frame
    rate = 0.4 + w @ (H / 100.0) + noise(n, rng)
    log = make_log(rate, 1.0, field={"Bx": H[0], "By": H[1], "Bz": H[2]})
    return log, w


def test_terms_parse_and_name_their_coefficients():
    log, _ = _rotated_log()
    wd = prepare(log)
    (v,) = resolve_terms(parse_terms("Hvec"), wd.frame)
    assert v.channels == ("Bx", "By", "Bz")
    assert v.coef_labels() == ["Hvec(Bx,By,Bz).w[Bx]", "Hvec(Bx,By,Bz).w[By]",
                               "Hvec(Bx,By,Bz).w[Bz]"]
    (q,) = resolve_terms(parse_terms("Hquad(Bx,Bz)"), wd.frame)
    assert q.n_coef == 3 and q.coef_labels()[-1] == "Hquad(Bx,Bz).w[Bx*Bz]"
    with pytest.raises(InputError, match="no field channel 'Bq'"):
        resolve_terms(parse_terms("Hvec(Bx,Bq)"), wd.frame)
    with pytest.raises(InputError, match="named twice"):
        resolve_terms(parse_terms("Hquad(Bx,Bx)"), wd.frame)
    # the fit recovers the rotated sensitivity vector
    r = fit_model(wd, ["Hvec"])
    got = [r.coef(lab).value for lab in v.coef_labels()]
    assert np.allclose(got, _rotated_log()[1], atol=0.01), got


def test_block_candidates_replace_the_models_own_field_terms():
    log, _ = _rotated_log()
    wd = prepare(log)
    present = resolve_terms(parse_terms("Hx(Bx),Hsq(By),Hmag2"), wd.frame)
    got = {s.label: repl for s, repl in block_candidates(wd.frame, present)}
    assert got == {"Hvec(Bx,By,Bz)": ["Hx(Bx)"],
                   "Hquad(Bx,By,Bz)": ["Hsq(By)", "Hmag2"]}
    full = resolve_terms(parse_terms("Hx(Bx),Hy(By),Hz(Bz),Hquad"), wd.frame)
    assert block_candidates(wd.frame, full) == []
    assert block_candidates(wd.frame, [TermSpec("bias")])  # no field term: both offered


def test_rotated_gyro_reaches_the_floor_through_the_user_loop():
    log, w = _rotated_log()
    wd = prepare(log)
    steps, final = user_loop(wd, ["Hx(Bx)"])
    added = {s.key for _, s in steps if s is not None}
    assert added and added <= {"Hy", "Hz", "Hvec"}, [d.verdict for d, _ in steps]
    assert not steps[-1][0].found
    true = fit_model(wd, [f"w:({w[0] / 100:.8g}*field.Bx + {w[1] / 100:.8g}*field.By + "
                          f"{w[2] / 100:.8g}*field.Bz)"])
    got = fit_model(wd, final)
    assert got.rms_holdout <= 1.1 * true.rms_holdout, (got.rms_holdout, true.rms_holdout)
