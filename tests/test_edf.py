"""EDF, χ² intervals and noise identification: independent checks.

* Greenhall–Riley EDF against the exact χ² EDF (tr Σ)²/tr(Σ²) of the estimator, with Σ built
  as a full matrix from the generalised autocovariance of the averaged phase (the paper's noise
  model), and against AllanTools 2024.6 (1e-9).
* The white-angle-noise closed form (Greenhall case 4, including ⌈r⌉ ≤ d, which AllanTools
  does not implement) against the exact covariance sum.
* SP1065 Tables 5/7/8 and the χ² interval against AllanTools; Stable32's PHASE.DAT interval.
* Lag-1 ACF and noise identification against AllanTools' loop implementation; identification
  of synthetic power-law noises; B1 theory.
"""

from __future__ import annotations

import contextlib
import io
import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import bench_noise_id  # noqa: E402

from gyrotest.core.angle import angle_series
from gyrotest.core.errors import AnalysisError, InputError  # noqa: E402
from gyrotest.noise import edf as E


def _quiet(fn, *args, **kwargs):
    """Call an AllanTools function with its diagnostic prints swallowed."""
    with contextlib.redirect_stdout(io.StringIO()):
        return fn(*args, **kwargs)


# ---------------------------------------------------------------------------------------------
# Greenhall-Riley: exact covariance model
# ---------------------------------------------------------------------------------------------


def gen_cov(t: np.ndarray, alpha: int) -> np.ndarray:
    """Generalised autocovariance of the integrated phase for power-law noise α
    (|t|^p or t^p·ln|t|, p = 3 − α; the sign is irrelevant for the EDF)."""
    a = np.abs(t).astype(float)
    p = 3 - alpha
    if alpha % 2 == 0:
        return a**p
    with np.errstate(divide="ignore", invalid="ignore"):
        v = a**p * np.log(a)
    return np.where(a > 0, v, 0.0)


def exact_edf(
    alpha: int, d: int, m: int, n_phase: int, overlapping: bool, modified: bool, truncate: bool = False
) -> float:
    """(tr Σ)²/tr(Σ²) for Q = Σ_k z_k², z_k the d-th difference (lag m) of the phase averaged
    over w = τ (modified) or τ0 (unmodified), terms at stride 1 (overlapping) or m. Σ is
    Toeplitz, so tr(Σ²) = M·ρ_0² + 2·Σ_j (M − j)·ρ_j². With ``truncate`` the lag sum stops at
    J = min(M, (d+1)·S) with half weight at J, as in Greenhall & Riley's BasicSum."""
    w = float(m) if modified else 1.0
    stride = 1 if overlapping else m
    S = m if overlapping else 1
    span = (m if modified else 1) + m * d  # Greenhall's L = m/F + m·d
    M = 1 + (n_phase - span) // stride
    coef = np.array([(-1) ** (d - i) * math.comb(d, i) for i in range(d + 1)], dtype=float)
    pos = np.arange(d + 1) * m

    def K(s):  # covariance of the w-averaged phase: second difference of gen_cov, step w
        return (gen_cov(s + w, alpha) + gen_cov(s - w, alpha) - 2.0 * gen_cov(s, alpha)) / (w * w)

    j = np.arange(M)
    rho = np.zeros(M)
    for a in range(d + 1):
        for b in range(d + 1):
            rho += coef[a] * coef[b] * K(j * stride + pos[a] - pos[b])
    weight = 2.0 * (M - j)
    weight[0] = M
    if truncate:
        J = min(M, (d + 1) * S)
        weight[j > J] = 0.0
        if J < M:
            weight[J] = M - J
    return float((M * rho[0]) ** 2 / np.sum(weight * rho**2))


@pytest.mark.parametrize("d", [1, 2, 3])
@pytest.mark.parametrize("overlapping,modified", [(True, False), (False, False), (True, True)])
def test_greenhall_exact_small(d, overlapping, modified):
    """Where J ≤ J_max the algorithm is the covariance sum truncated at J = (d+1)·S: equal to
    1e-9 for every α. For even α the covariance vanishes beyond J, so it is the exact EDF; for
    flicker (odd α) the neglected tail changes the EDF by < 3 % here (2 % for d = 1)."""
    checked = 0
    for alpha in range(-4, 3):
        if alpha + 2 * d <= 1:
            continue
        for m, n in ((1, 40), (2, 61), (3, 47), (5, 90), (8, 150), (30, 200)):
            S = m if overlapping else 1
            if (d + 1) * S > 100 or (not modified and alpha <= 0 and m * (d + 1) > 100):
                continue  # J > J_max (asymptotic branch) or the F = ∞ variant
            if n < (m if modified else 1) + m * d + 2 * (1 if overlapping else m):
                continue
            ours = E.edf_greenhall(alpha, d, m, n, overlapping=overlapping, modified=modified)
            trunc = exact_edf(alpha, d, m, n, overlapping, modified, truncate=True)
            full = exact_edf(alpha, d, m, n, overlapping, modified)
            assert ours == pytest.approx(trunc, rel=1e-9), (alpha, d, m, n)
            if alpha % 2 == 0:
                assert ours == pytest.approx(full, rel=1e-9), (alpha, d, m, n)
            else:
                assert ours == pytest.approx(full, rel=3e-2), (alpha, d, m, n)
            checked += 1
    assert checked >= 8


def test_greenhall_white_pm_closed_form():
    """Case 4 (α = 2, unmodified) is the exact white-noise covariance sum, also for ⌈r⌉ ≤ d
    (few terms), which AllanTools raises NotImplementedError for."""

    def white_exact(d, m, n, overlapping):
        stride = 1 if overlapping else m
        M = 1 + (n - 1 - m * d) // stride
        h = np.zeros(m * d + 1)
        h[::m] = [(-1) ** i * math.comb(d, i) for i in range(d + 1)]
        R = np.correlate(h, h, "full")
        c = h.size - 1
        k = np.arange(M)
        lag = np.abs(k[:, None] - k[None, :]) * stride
        S = np.where(lag <= c, R[c + np.minimum(lag, c)], 0.0)
        return float(np.trace(S) ** 2 / np.sum(S * S)), M

    seen_small_r = False
    for d in (1, 2, 3):
        for m in (1, 2, 4, 7, 16):
            for n in range(m * d + 2, m * d + 2 + 5 * m, max(1, m // 2)):
                for ov in (True, False):
                    ref, M = white_exact(d, m, n, ov)
                    r = M / (m if ov else 1)
                    seen_small_r |= math.ceil(r) <= d
                    ours = E.edf_greenhall(2, d, m, n, overlapping=ov, modified=False)
                    assert ours == pytest.approx(ref, rel=1e-12), (d, m, n, ov)
    assert seen_small_r


def test_greenhall_large_m_precision():
    """sx for large filter factors F = m: our cancellation-free second difference equals the
    direct formula evaluated in extended precision (np.longdouble)."""
    for alpha in (1, 0, -1, -2, -3, -4):
        for F in (10.0, 1000.0, 20000.0):
            t = np.array([0.0, 1.0 / F, 0.5, 1.0, 1.0 + 3.0 / F, 2.5, 4.0])
            h = np.longdouble(1) / np.longdouble(F)
            tl = t.astype(np.longdouble)

            def sw(x, alpha=alpha):
                a = np.abs(x)
                p = 3 - alpha
                if alpha % 2 == 0:
                    return a**p
                return np.where(a > 0, a**p * np.log(np.where(a > 0, a, 1)), 0)

            direct = (sw(tl + h) + sw(tl - h) - 2 * sw(tl)).astype(float)
            ours = E._sw_second_difference(t, 1.0 / F, alpha) * (
                -1.0 if alpha in (-1, -2) else 1.0
            )
            tol = 1e-19 * F * F * 10 + 1e-12  # long double still cancels ~F²
            np.testing.assert_allclose(ours, direct, rtol=tol, atol=1e-300)


def test_greenhall_against_allantools():
    at = pytest.importorskip("allantools")
    worst = 0.0
    count = 0
    for d in (1, 2, 3):
        for alpha in range(-4, 3):
            if alpha + 2 * d <= 1:
                continue
            for ov in (False, True):
                for mod in (False, True):
                    for n in (30, 1001, 19983, 10**5):
                        for m in (1, 2, 3, 8, 13, 64, 256, 1000, 4096):
                            if n < m / (1 if mod else m) + m * d:
                                continue
                            try:
                                ref = _quiet(at.edf_greenhall, alpha=alpha, d=d, m=m, N=n,
                                             overlapping=ov, modified=mod)
                            except (NotImplementedError, AssertionError):
                                continue  # AllanTools: alpha = 2 with few terms; alpha = -4 table bug
                            ours = E.edf_greenhall(alpha, d, m, n, overlapping=ov, modified=mod)
                            worst = max(worst, abs(ours / ref - 1))
                            count += 1
    assert count > 1500
    # the largest differences (~6e-10) are alpha = 1, unmodified, m >= 1000, where AllanTools'
    # direct second difference loses ~eps·m²; ours is cancellation-free (see the next test)
    assert worst < 1e-9


def test_greenhall_errors():
    with pytest.raises(AnalysisError, match="does not converge"):
        E.edf_greenhall(-3, 2, 4, 1000, overlapping=True, modified=False)
    with pytest.raises(AnalysisError, match="record too short"):
        E.edf_greenhall(0, 2, 100, 150, overlapping=True, modified=False)
    with pytest.raises(InputError):
        E.edf_greenhall(0, 4, 1, 100, overlapping=True, modified=False)


# ---------------------------------------------------------------------------------------------
# SP1065 tables and the chi-square interval
# ---------------------------------------------------------------------------------------------


def test_sp1065_tables_against_allantools():
    at = pytest.importorskip("allantools")
    for n in (100, 1001, 19983):
        for m in (1, 2, 5, 10, 33):
            for alpha in (2, 1, 0, -1, -2):
                assert E.edf_simple(n, m, alpha) == pytest.approx(at.edf_simple(n, m, alpha), rel=1e-12)
                assert E.edf_mtotdev(n, m, alpha) == pytest.approx(_quiet(at.edf_mtotdev, n, m, alpha), rel=1e-12)
                if alpha <= 0:
                    assert E.edf_totdev(n, m, alpha) == pytest.approx(at.edf_totdev(n, m, alpha), rel=1e-12)
    # Table 7 values: b·N/m − c
    assert E.edf_totdev(1001, 1, 0) == pytest.approx(1.5 * 1001)
    assert E.edf_totdev(1001, 10, -2) == pytest.approx(0.93 * 100.1 - 0.36)
    assert E.edf_mtotdev(1001, 10, 2) == pytest.approx(1.90 * 100.1 - 2.1)


def test_chi2_interval():
    at = pytest.importorskip("allantools")
    # Stable32 PHASE.DAT OADEV tau = 1 s: sigma 2.9223e-01, edf (Greenhall, alpha 0) -> 2.8515e-01, 2.9987e-01
    e = E.edf_greenhall(0, 2, 1, 1001, overlapping=True, modified=False)
    lo, hi = E.chi2_interval(0.29223, e, 0.683)
    assert float(lo) == pytest.approx(2.8515e-01, rel=2e-4)
    assert float(hi) == pytest.approx(2.9987e-01, rel=2e-4)
    for edf in (1.3, 4.0, 55.5, 782.0, 1e5):
        for ci in (0.683, 0.9, 0.95):
            ref = at.confidence_interval(1.0, edf, ci=ci)
            ours = E.chi2_interval(1.0, edf, ci)
            np.testing.assert_allclose([float(ours[0]), float(ours[1])], ref, rtol=1e-12)
    lo, hi = E.chi2_interval(np.array([1.0, 2.0]), np.array([np.nan, 10.0]))
    assert np.isnan(lo[0]) and np.isnan(hi[0]) and lo[1] < 2.0 < hi[1]
    with pytest.raises(InputError):
        E.chi2_interval(1.0, 10.0, 1.5)


def test_edf_for_methods():
    e, lab = E.edf_for("oadev", 0, 4, 1000)
    assert lab == E.CI_GREENHALL
    assert E.edf_for("tdev", 0, 4, 1000)[0] == E.edf_for("mdev", 0, 4, 1000)[0]
    assert E.edf_for("akdev", 0, 4, 1000)[0] == pytest.approx(e - 1.0)
    assert E.edf_for("totdev", -1, 4, 1000) == (E.edf_totdev(1000, 4, -1), E.CI_TOTDEV)
    assert E.edf_for("totdev", 1, 4, 1000) == (E.edf_simple(1000, 4, 1), E.CI_SIMPLE)
    assert E.edf_for("mtotdev", 1, 4, 1000) == (E.edf_mtotdev(1000, 4, 1), E.CI_MTOTDEV)
    assert E.edf_for("oadev", -3, 4, 1000)[1] == E.CI_SIMPLE  # Allan family diverges at -3
    assert E.edf_for("ohdev", -3, 4, 1000)[1] == E.CI_GREENHALL


# ---------------------------------------------------------------------------------------------
# Noise identification
# ---------------------------------------------------------------------------------------------


def power_law_rate(alpha: int, n: int, seed: int) -> np.ndarray:
    """Rate samples with PSD ∝ f^α (the noise-identification campaign's generator)."""
    return bench_noise_id.power_law_rate(alpha, n, np.random.default_rng(seed))


def test_lag1_acf_against_allantools():
    at = pytest.importorskip("allantools")
    for seed in range(3):
        x = np.cumsum(np.random.default_rng(seed).standard_normal(2500)) + 0.3
        assert E.lag1_acf(x) == pytest.approx(at.ci.lag1_acf(x), rel=1e-12)


@pytest.mark.parametrize("alpha", [2, 1, 0, -1, -2])
def test_noise_id_against_allantools(alpha):
    at = pytest.importorskip("allantools")
    y = power_law_rate(alpha, 3000, seed=10 + alpha)
    s = angle_series(y, 1.0, input_kind="rate")
    for m in (1, 3, 10, 40):
        ours_f = E.identify_noise(s.parts(), [m], data_type="frequency")[0]
        ai, af, d, rho = at.autocorr_noise_id(y, m, data_type="freq", dmin=0, dmax=2)
        assert (ours_f.alpha, ours_f.d) == (ai, d)
        assert ours_f.alpha_float == pytest.approx(af, rel=1e-9, abs=1e-12)
        assert ours_f.rho == pytest.approx(rho, rel=1e-9, abs=1e-12)
        ours_p = E.identify_noise(s.parts(), [m], data_type="phase")[0]
        ai, af, d, rho = at.autocorr_noise_id(s.theta, m, data_type="phase", dmin=0, dmax=2)
        assert (ours_p.alpha, ours_p.d) == (ai, d)
        assert ours_p.alpha_float == pytest.approx(af, rel=1e-9, abs=1e-12)


@pytest.mark.parametrize("alpha", [2, 1, 0, -1, -2])
def test_noise_id_synthetic(alpha):
    """Each power-law noise is identified with >= 1000 averages (m = 1, 4, and for the exact
    even-α generators m = 16 too); flicker estimates sit near ±1.35 and drift at large m."""
    y = power_law_rate(alpha, 1 << 14, seed=100 + 10 * alpha)
    s = angle_series(y, 0.01, input_kind="rate")
    ms = [1, 4, 16] if alpha % 2 == 0 else [1, 4]
    for data_type in ("frequency", "phase"):
        ids = E.identify_noise(s.parts(), ms, data_type=data_type)
        assert [i.alpha for i in ids] == [alpha] * len(ms), data_type
        assert all(i.method == "acf" for i in ids)
        assert all(abs(i.alpha_float - alpha) < 0.45 for i in ids)


def test_noise_id_hadamard_reaches_minus_four():
    y = np.cumsum(np.cumsum(np.random.default_rng(1).standard_normal(1 << 14)))  # α = −4
    s = angle_series(y, 1.0, input_kind="rate")
    assert E.identify_noise(s.parts(), [4], data_type="frequency", dmax=3, alpha_min=-4)[0].alpha == -4
    # the Allan family stops at -2 (clipped)
    assert E.identify_noise(s.parts(), [4], data_type="frequency", dmax=2)[0].alpha == -2


def test_noise_id_rules_short_records():
    y = np.random.default_rng(0).standard_normal(200)
    s = angle_series(y, 1.0, input_kind="rate")
    ids = E.identify_noise(s.parts(), [1, 10, 40], data_type="frequency")
    assert [i.method for i in ids] == ["acf", "b1", "reused"]  # 200, 20, 5 averages
    assert ids[2].alpha == ids[1].alpha
    first = E.identify_noise(s.parts(), [50], data_type="frequency")[0]
    assert (first.method, first.alpha) == ("assumed", 0)


def test_b1_theory():
    at = pytest.importorskip("allantools")
    for n in (5, 20, 29):
        for mu in (-2, -1, 0, 1, 2):
            assert E.b1_theory(n, mu) == pytest.approx(at.ci.b1_theory(n, mu), rel=1e-12)
    assert E.b1_theory(10, -1) == pytest.approx(1.0)
    assert E.b1_theory(10, 1) == pytest.approx(5.0)
    assert E.b1_theory(10, 2) == pytest.approx(10 * 11 / 6)


def test_b1_noise_id_statistics():
    """With 20 averages B1 is a weak but useful test: white rate is called white in most
    records, random-walk rate is called red (α = −1 or −2) almost always, −2 most often."""
    white = {}
    rw = {}
    for seed in range(100):
        rng = np.random.default_rng(seed)
        a = E.b1_noise_id(rng.standard_normal(20), 10).alpha
        white[a] = white.get(a, 0) + 1
        b = E.b1_noise_id(np.cumsum(rng.standard_normal(20)), 10).alpha
        rw[b] = rw.get(b, 0) + 1
    assert white.get(0, 0) >= 60, white
    assert rw.get(-2, 0) + rw.get(-1, 0) >= 90 and rw.get(-2, 0) > rw.get(-1, 0), rw


def test_identify_noise_pair_rules():
    """Stable32's rule (printed α) vs the statistical rule (fit weights) on random-walk rate
    noise with 20 averages: the statistical rule is identify_noise itself and calls α = −2 in
    most records; Stable32's (B1 theory at the OADEV term count) almost never does — the reason
    the fit keeps its own α. With ≥ 30 averages both are the lag-1 ACF."""
    m = 64
    s32_hits = fit_hits = 0
    for seed in range(40):
        y = power_law_rate(-2, 20 * m, seed=500 + seed)
        parts = angle_series(y, 1.0, input_kind="rate").parts()
        s32, fit = E.identify_noise_pair(parts, [m], [y.size + 1 - 2 * m], kind="oadev",
                                         data_type="frequency")
        plain = E.identify_noise(parts, [m], data_type="frequency")
        assert (fit[0].alpha, fit[0].method) == (plain[0].alpha, plain[0].method)
        s32_hits += s32[0].alpha == -2
        fit_hits += fit[0].alpha == -2
    assert fit_hits >= 20 and s32_hits <= 2, (fit_hits, s32_hits)
    y = power_law_rate(-2, 40 * m, seed=1)
    parts = angle_series(y, 1.0, input_kind="rate").parts()
    s32, fit = E.identify_noise_pair(parts, [m], [y.size], kind="oadev", data_type="frequency")
    assert s32[0] == fit[0] and s32[0].method == "acf"


def test_totdev_b1_from_six_averages():
    """Stable32's TOTDEV tables identify by B1 at 6–7 averages where OADEV reuses α."""
    y = np.random.default_rng(3).standard_normal(6 * 100 + 5)
    parts = angle_series(y, 1.0, input_kind="rate").parts()
    tot, _ = E.identify_noise_pair(parts, [1, 100], [y.size - 1] * 2, kind="totdev",
                                   data_type="frequency")
    oad, fit = E.identify_noise_pair(parts, [1, 100], [y.size - 1] * 2, kind="oadev",
                                     data_type="frequency")
    assert tot[1].method == "b1" and oad[1].method == "reused" and fit[1].method == "reused"


def test_deviation_carries_both_identifications():
    """compute_deviation prints Stable32's α and keeps the statistical one (alpha_fit, edf_fit)
    for the fit; the fit starts from alpha_fit (fit_alpha), the JSON has both."""
    from gyrotest.noise.deviations import compute_deviation
    from gyrotest.noise.noisefit import fit_alpha

    y = power_law_rate(-2, 1 << 14, seed=7)
    d = compute_deviation(y, 1.0, input_kind="rate", taus="octave")
    assert d.alpha_fit is not None and d.edf_fit is not None
    differ = np.flatnonzero(d.alpha_fit != d.alpha)
    assert differ.size >= 1  # B1 regime: Stable32 calls the random walk something else
    assert np.all(d.edf_fit[differ] != d.edf[differ])
    same = np.flatnonzero(d.alpha_fit == d.alpha)
    assert np.array_equal(d.edf_fit[same], d.edf[same])
    a, e, _ = fit_alpha(d)
    assert np.array_equal(a, d.alpha_fit) and np.array_equal(e, d.edf_fit, equal_nan=True)
    js = d.to_dict()
    assert js["alpha_fit"] == [int(v) for v in d.alpha_fit] and "edf_fit" in js
    assert any("Stable32's B1 identification" in n for n in d.notes)
    forced = compute_deviation(y, 1.0, input_kind="rate", taus="octave", alpha=0)
    assert forced.alpha_fit is None and "alpha_fit" not in forced.to_dict()
