"""The workbench's spectral (Whittle) z against closed forms and simulations with known truth."""

from __future__ import annotations

import numpy as np

from gyrotest.envmodel import stats as st


def _ols_z(X, y, j):
    b = np.linalg.lstsq(X, y, rcond=None)[0]
    e = y - X @ b
    return abs(b[j]) / np.sqrt(st.ols_covariance(X, e)[j, j]), e


def test_smoothed_periodogram_of_white_noise_is_its_variance():
    e = np.random.default_rng(1).normal(0.0, 2.0, 4096)
    S = st.smoothed_periodogram(e)
    assert S.size == 2049
    # E|E_k|²/n = σ² per bin for white noise; smoothing over ≥ 9 bins keeps the mean
    assert 3.2 < np.median(S[1:]) < 4.8
    assert abs(S[1:].mean() - 4.0) < 0.2


def test_whittle_z_equals_ols_z_on_white_noise():
    rng = np.random.default_rng(2)
    n = 1200
    ratios, zs = [], []
    for _ in range(200):
        X = np.column_stack([np.ones(n), rng.normal(size=n)])
        y = X @ [0.5, 0.08] + rng.normal(size=n)
        z_ols, e = _ols_z(X, y, 1)
        z_w = st.whittle_z(X, y, e, [1])
        ratios.append(z_w / z_ols)
        zs.append(z_w)
    assert 0.9 < np.median(ratios) < 1.1
    # noise alone: the z of a coefficient that is zero is about |N(0, 1)|
    null = []
    for _ in range(300):
        X = np.column_stack([np.ones(n), rng.normal(size=n)])
        y = rng.normal(size=n)
        _, e = _ols_z(X, y, 1)
        null.append(st.whittle_z(X, y, e, [1]))
    assert 0.02 < np.mean(np.array(null) > 1.96) < 0.09


def test_whittle_z_discounts_a_smooth_channel_fitted_to_slow_wander():
    """Random-walk noise and a slow channel with no effect: the OLS z is large (spurious
    regression), the spectral z much smaller; a true effect of the same channel keeps a
    large spectral z."""
    rng = np.random.default_rng(3)
    n, t = 800, np.arange(800)
    spur_ols, spur_w, true_w = [], [], []
    for _ in range(150):
        x = np.sin(2 * np.pi * t / n * rng.uniform(0.5, 2.0) + rng.uniform(0, 6))
        X = np.column_stack([np.ones(n), x])
        wander = np.cumsum(rng.normal(size=n)) * 0.15
        y = wander + rng.normal(size=n)
        z_ols, e = _ols_z(X, y, 1)
        spur_ols.append(z_ols)
        spur_w.append(st.whittle_z(X, y, e, [1]))
        y2 = 3.0 * x + rng.normal(size=n)  # a true effect, white noise
        _, e2 = _ols_z(X, y2, 1)
        true_w.append(st.whittle_z(X, y2, e2, [1]))
    assert np.median(spur_ols) > 3 * np.median(spur_w)
    assert np.mean(np.array(spur_w) >= 8.0) < 0.15
    assert np.mean(np.array(true_w) >= 8.0) > 0.99


def _null_and_true_z(x: np.ndarray, y_null: np.ndarray, y_true: np.ndarray
                     ) -> tuple[float, float]:
    """Spectral z of the channel ``x`` (with an intercept) fitted to a record without its
    effect and to one with it."""
    X = np.column_stack([np.ones(x.size), x])
    out = []
    for y in (y_null, y_true):
        _, e = _ols_z(X, y, 1)
        out.append(st.whittle_z(X, y, e, [1]))
    return out[0], out[1]


def test_whittle_z_is_not_fooled_by_the_end_to_end_jump():
    """A channel that settles over the record (1 − e^(−t/τ)) and a residual that wanders
    (random walk): both jump from their last value back to their first in the FFT's periodic
    extension, and without a taper that shared sawtooth gave the coefficient spectral z of
    tens. Tapered, a coefficient with no effect behind it stays below the bar of 8 in ≥ 85 %
    of the records; a true effect of the same channel still passes it."""
    rng = np.random.default_rng(5)
    n, t = 900, np.arange(900)
    spur, true = [], []
    for _ in range(120):
        x = 1.0 - np.exp(-t / rng.uniform(100, 600))
        y = np.cumsum(rng.normal(size=n)) * 0.2 + rng.normal(size=n)
        z_spur, z_true = _null_and_true_z(x, y, 20.0 * x + rng.normal(size=n))
        spur.append(z_spur)
        true.append(z_true)
    assert np.mean(np.array(spur) >= 8.0) < 0.15, np.percentile(spur, [50, 90])
    assert np.mean(np.array(true) >= 8.0) > 0.95, np.percentile(true, [10, 50])


def test_cosine_taper_shape():
    w = st.cosine_taper(np.ones(100), 0.2)
    assert w[0] < 0.05 and w[-1] < 0.05 and np.all(w[10:90] == 1.0)
    assert np.allclose(w[:10], w[::-1][:10])  # symmetric
    assert np.all(np.diff(w[:10]) > 0)
    X = np.ones((100, 3))
    assert np.allclose(st.cosine_taper(X, 0.2)[:, 1], w)


def test_red_floor_leaves_a_white_residual_alone_and_raises_the_lowest_bins_of_a_red_one():
    rng = np.random.default_rng(11)
    S = st.smoothed_periodogram(rng.normal(size=4000))
    assert np.array_equal(st.red_floor(S), S)
    rw = np.cumsum(rng.normal(size=4000))
    Sr = st.smoothed_periodogram(rw)
    Fr = st.red_floor(Sr)
    k0 = st.RED_BAND[0]
    assert np.array_equal(Fr[k0:], Sr[k0:]) and np.all(Fr[1:k0] >= Sr[1:k0])
    # a random walk: S ∝ k⁻²; at k = 1 the smoothed periodogram averages bins 1 … 5 and
    # reads low (by 3.4x in expectation), the floor extrapolates the power law from k ≥ 6
    assert Fr[1] > 1.5 * Sr[1]


def test_whittle_z_of_a_slow_channel_fitted_to_a_random_walk_is_near_its_null_distribution():
    """A slow sinusoidal channel (0.5-2 cycles per record) with no effect, in white noise plus
    a random walk: with the low-frequency floor of a red residual (:func:`red_floor`) the
    spectral z exceeds 4 in about 5 % of records (15 % without it); a true effect of the same
    channel in white noise keeps its z (median about 12.7, as without the floor)."""
    rng = np.random.default_rng(7)
    n, t = 900, np.arange(900)
    spur, true = [], []
    for _ in range(150):
        x = np.sin(2 * np.pi * t / n * rng.uniform(0.5, 2.0) + rng.uniform(0, 6))
        x = (x - x.mean()) / x.std()
        y = np.cumsum(rng.normal(size=n)) * rng.choice([0.05, 0.15, 0.3]) + rng.normal(size=n)
        z_spur, z_true = _null_and_true_z(x, y, 0.4 * x + rng.normal(size=n))
        spur.append(z_spur)
        true.append(z_true)
    assert np.mean(np.array(spur) >= 4.0) < 0.09, np.percentile(spur, [50, 90])
    assert np.median(true) > 11.0 and np.mean(np.array(true) >= 8.0) > 0.9
