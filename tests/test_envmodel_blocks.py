"""Field terms that only work together: ``Hvec`` (first-order sensitivity along every field
axis) and ``Hquad`` (every H_i·H_j), for a gyro whose axes are not the coils'. Closed forms,
term parsing, the block-candidate screen, and a rotated-gyro Helmholtz run (plain numpy)
through the user loop."""

from __future__ import annotations

import numpy as np
import pytest
from test_envmodel_helpers import make_log
from workbench_cases import helmholtz, noise, user_loop

from gyrotest.core.errors import InputError
from gyrotest.envmodel import fit_model, prepare
from gyrotest.envmodel.channel_terms import field_quadratic, field_vector
from gyrotest.envmodel.screen import block_candidates
from gyrotest.envmodel.terms import TermSpec, parse_terms, resolve_terms

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


# ---------------------------------------------------------------- support-aware fold fits
def _old_rule(X, y, train, beta_full, frac=0.02):
    full = X - X.mean(axis=0)
    xt = X[train] - X[train].mean(axis=0)
    v_all, v_tr = (full * full).sum(0), (xt * xt).sum(0)
    fixed = (v_all > 0) & (v_tr < frac * v_all)
    if not fixed.any():
        return np.linalg.lstsq(X[train], y[train], rcond=None)[0]
    b = np.array(beta_full, float)
    yt = y[train] - X[train][:, fixed] @ beta_full[fixed]
    b[~fixed] = np.linalg.lstsq(X[train][:, ~fixed], yt, rcond=None)[0]
    return b


def testfold_coefficients_support_directions():
    """Fold coefficients are free only along directions the training blocks support: plain
    least squares when every direction is supported, the one-column rule (a transient living
    in the held-out chunk keeps its full-data coefficient) reproduced, and a *combination*
    of columns that moves only in the held-out chunk (two field axes swept together once)
    kept at its full-data value instead of being extrapolated."""
    from gyrotest.envmodel.modelfit import fold_coefficients

    rng = np.random.default_rng(3)
    n = 400
    t = np.arange(n, dtype=float)
    train = np.ones(n, bool)
    train[300:360] = False
    # 1. every direction supported: ordinary least squares on the training blocks
    X = np.column_stack([np.ones(n), rng.normal(size=n), np.sin(t / 30)])
    y = X @ [1.0, 2.0, -0.5] + rng.normal(scale=0.1, size=n)
    bf = np.linalg.lstsq(X, y, rcond=None)[0]
    np.testing.assert_allclose(fold_coefficients(X, y, train, bf),
                               np.linalg.lstsq(X[train], y[train], rcond=None)[0], atol=1e-10)
    # 2. a transient that lives only in the held-out chunk: the one-column rule
    tr = np.where((t >= 300) & (t < 350), np.exp(-(t - 300) / 5.0), 0.0)
    X2 = np.column_stack([np.ones(n), rng.normal(size=n), tr])
    y2 = X2 @ [0.3, 1.0, 4.0] + rng.normal(scale=0.1, size=n)
    bf2 = np.linalg.lstsq(X2, y2, rcond=None)[0]
    # (equal to the one-column rule up to the slight correlation of the columns, which
    # tilts the unsupported direction)
    np.testing.assert_allclose(fold_coefficients(X2, y2, train, bf2),
                               _old_rule(X2, y2, train, bf2), rtol=2e-3)
    assert fold_coefficients(X2, y2, train, bf2)[2] == pytest.approx(bf2[2], rel=2e-3)
    # 3. two columns that each vary in training, but their difference only in the held-out
    #    chunk: the combination keeps its full-data value
    a = np.sin(t / 7.0)
    b = a.copy()
    b[300:360] += 3.0 * np.hanning(60)
    X3 = np.column_stack([np.ones(n), a, b])
    y3 = X3 @ [0.0, 1.0, 2.0] + rng.normal(scale=0.05, size=n)
    bf3 = np.linalg.lstsq(X3, y3, rcond=None)[0]
    bfold = fold_coefficients(X3, y3, train, bf3)
    # along the supported direction (a + b move together) the training data decide; the
    # held-out prediction of the unsupported bump is the full-data one, not an extrapolation
    held = ~train
    bump = X3[held] - X3[held].mean(0)
    pred_fold = bump @ bfold
    pred_full = bump @ bf3
    assert np.sqrt(np.mean((pred_fold - pred_full) ** 2)) < 0.05 * np.sqrt(np.mean(pred_full ** 2))
    # the old one-column rule extrapolates the combination freely (ill-determined): the new
    # one is never worse on the held-out blocks here
    e_new = np.sqrt(np.mean((y3[held] - X3[held] @ bfold) ** 2))
    e_old = np.sqrt(np.mean((y3[held] - X3[held] @ _old_rule(X3, y3, train, bf3)) ** 2))
    assert e_new <= e_old + 1e-9


# ---------------------------------------------------------------- two effects hiding each other
