"""Thêo1, ThêoH, TTOTDEV, HTOTDEV and the gap-tolerant OADEV: independent checks.

* Stable32 PHASE.DAT tables (../shared/reference/data/stable32/phasedat) to the printed digits.
* Howe (2006) Appendix A: Thêo1 of a 12-point record.
* AllanTools 2024.6 side by side on random data (theo1, ttotdev, htotdev, oadev, gradev).
* The fast Thêo1 kernel against its definition; the half convolution against brute force.
* Gap-tolerant OADEV against a brute-force reference and the pooled-segment OADEV.
* Thêo1 EDF formulas against a Monte Carlo simulation.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from gyrotest.core.errors import InputError
from gyrotest.noise import theo_kernels as tk
from gyrotest.noise.deviations import DEVIATION_KINDS, compute_deviation
from gyrotest.noise.gapdev import finite_runs
from gyrotest.noise.theo import edf_theo1

from cliutil import run_cli

S32 = Path(__file__).parents[2] / "shared" / "reference" / "data" / "stable32" / "phasedat"
needs_ref = pytest.mark.skipif(not S32.is_dir(), reason=f"Stable32 tables not found at {S32}")


def read_stable32(name: str) -> list[dict]:
    rows = []
    for line in (S32 / name).read_text().splitlines():
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        p = line.split()
        rows.append(dict(m=int(p[0]), tau=float(p[1]), n=float(p[2]), alpha=int(p[3]),
                         lo=float(p[4]), sigma=float(p[5]), hi=float(p[6])))
    return rows


def phase_dat() -> np.ndarray:
    txt = (S32 / "PHASE.DAT").read_text().splitlines()
    return np.array([float(v) for v in txt if v.strip() and not v.startswith("#")])


def assert_printed(ours: float, printed: float, digits: int = 5, slack: float = 1e-9):
    """ours rounds to the printed value (``slack``: relative allowance at a rounding boundary)."""
    exp = math.floor(math.log10(abs(printed)))
    half_ulp = 0.5 * 10.0 ** (exp - digits + 1)
    assert abs(ours - printed) <= half_ulp + slack * abs(printed), (ours, printed)


def test_kinds_registered():
    for k in ("theo1", "theoh", "ttotdev", "htotdev", "gapadev"):
        assert k in DEVIATION_KINDS


# ---------------------------------------------------------------------------------------------
# Stable32 conformance
# ---------------------------------------------------------------------------------------------


@needs_ref
@pytest.mark.parametrize("name", ["phase_dat_theo1_alpha0.txt", "phase_dat_theo1_alpha0_decade.txt"])
def test_theo1_stable32(name):
    """Stable32's Thêo1 with α = 0 (no bias correction): σ, τ = 0.75·m·τ0 and # = (N − m)m/2
    to the printed digits."""
    rows = read_stable32(name)
    taus = [r["tau"] for r in rows]
    res = compute_deviation(phase_dat(), 1.0, input_kind="angle", kind="theo1", taus=taus,
                            noise_id=False)
    assert res.m.tolist() == [r["m"] for r in rows]
    for r, s, n, t in zip(rows, res.sigma, res.n, res.tau):
        assert t == pytest.approx(r["tau"], rel=1e-12)
        assert_printed(s, r["sigma"])
        assert_printed(float(n), r["n"])


@needs_ref
def test_theo1_stable32_all_grid():
    """The "all" grid is every even m from 10: Stable32's all-τ table is a subset of ours."""
    rows = read_stable32("phase_dat_theo1_alpha0.txt")
    res = compute_deviation(phase_dat(), 1.0, input_kind="angle", kind="theo1", taus="all",
                            noise_id=False)
    assert res.m[0] == 10 and np.all(np.diff(res.m) == 2) and res.m[-1] == 1000
    got = dict(zip(res.m.tolist(), res.sigma))
    for r in rows:
        assert_printed(got[r["m"]], r["sigma"])


@needs_ref
def test_theo1_stable32_alpha1_is_a_constant_factor():
    """Stable32's Thêo1 table with α = 1 is our raw Thêo1 times one constant factor (its
    noise-type bias correction); we report raw Thêo1, so only the constancy is checked."""
    rows = read_stable32("phase_dat_theo1.txt")
    res = compute_deviation(phase_dat(), 1.0, input_kind="angle", kind="theo1",
                            taus=[r["tau"] for r in rows], noise_id=False)
    ratio = (np.array([r["sigma"] for r in rows]) / res.sigma) ** 2
    assert np.ptp(ratio) < 3e-4 * ratio.mean()
    assert 0.602 < ratio.mean() < 0.604


@needs_ref
def test_ttotdev_stable32():
    """Stable32's TTOTDEV table is MTOTDEV-bias-corrected with its α column (B = 0.73 for
    α = 0, 0.83 for α = 1): equal to the printed digits with that α forced."""
    rows = read_stable32("phase_dat_ttotdev_all.txt")
    x = phase_dat()
    res = compute_deviation(x, 1.0, input_kind="angle", kind="ttotdev",
                            taus=[r["tau"] for r in rows], alpha=[r["alpha"] for r in rows],
                            bias_correction=True)
    for r, s, n in zip(rows, res.sigma, res.n):
        # 1e-6: one row (AF 77, σ = 0.725805) sits 7e-8 past a rounding boundary — within
        # the rounding of the bias factor 0.73 that Stable32 applies
        assert_printed(s, r["sigma"], slack=1e-6)
        assert n == int(r["n"])
    assert res.unit == "(deg/h)·s"
    raw = compute_deviation(x, 1.0, input_kind="angle", kind="ttotdev", taus=[1.0, 10.0, 100.0],
                            noise_id=False)
    # NBS14 1000-point set, Stable32 1.60 without bias correction (AllanTools test suite)
    for s, ref in zip(raw.sigma, (1.1930e-01, 3.2060e-01, 1.1285e+00)):
        assert_printed(s, ref)


@needs_ref
@pytest.mark.parametrize("name,bias", [("phase_dat_htotdev_octave_nobias.txt", False),
                                       ("phase_dat_htotdev_octave.txt", True)])
def test_htotdev_stable32(name, bias):
    rows = read_stable32(name)
    res = compute_deviation(phase_dat(), 1.0, input_kind="angle", kind="htotdev",
                            taus=[r["tau"] for r in rows], alpha=[r["alpha"] for r in rows],
                            bias_correction=bias)
    for r, s, n in zip(rows, res.sigma, res.n):
        assert_printed(s, r["sigma"])
        assert n == int(r["n"])


def test_theo1_howe2006_appendix():
    """Howe, Metrologia 43 (2006) S322, Appendix A: 12 daily phase values (ns), Thêo1 at
    m = 10 is 7.66e-15."""
    x = np.array([-2.15, -0.99, 1, 2.5, 0.65, -3.71, -3.3, 1.08, 0.5, 2.2, 4.68, 3.29])
    res = compute_deviation(x, 86400.0, input_kind="angle", kind="theo1", taus=[7.5 * 86400],
                            noise_id=False)
    # ours 7.6665e-15: the paper's three digits are truncated, not rounded (0.09 %)
    assert res.sigma[0] * 1e-9 == pytest.approx(7.66e-15, abs=0.01e-15)


# ---------------------------------------------------------------------------------------------
# AllanTools side by side
# ---------------------------------------------------------------------------------------------


def test_theo1_ttotdev_htotdev_vs_allantools():
    at = pytest.importorskip("allantools")
    rng = np.random.default_rng(11)
    y = rng.standard_normal(240) + np.cumsum(rng.standard_normal(240)) * 0.05
    x = np.concatenate(([0.0], np.cumsum(y)))
    ms = np.array([10, 20, 40, 100])
    _, d_at, _, n_at = at.theo1(x, rate=1.0, data_type="phase", taus=ms.astype(float))
    ours = compute_deviation(x, 1.0, input_kind="angle", kind="theo1", taus=0.75 * ms,
                             noise_id=False)
    np.testing.assert_allclose(ours.sigma, d_at, rtol=1e-10)
    np.testing.assert_array_equal(ours.n, n_at)
    taus = [1.0, 2.0, 5.0, 10.0, 30.0]
    _, d_at, _, _ = at.ttotdev(x, rate=1.0, data_type="phase", taus=taus)
    ours = compute_deviation(x, 1.0, input_kind="angle", kind="ttotdev", taus=taus, noise_id=False)
    np.testing.assert_allclose(ours.sigma, d_at, rtol=1e-10)
    taus = [1.0, 2.0, 5.0, 10.0, 20.0]
    _, d_at, _, n_at = at.htotdev(y, rate=1.0, data_type="freq", taus=taus)
    ours = compute_deviation(y, 1.0, input_kind="rate", kind="htotdev", taus=taus, noise_id=False)
    np.testing.assert_allclose(ours.sigma, d_at, rtol=1e-10)
    np.testing.assert_array_equal(ours.n, n_at)


def test_gapadev_vs_allantools():
    at = pytest.importorskip("allantools")
    rng = np.random.default_rng(3)
    y = rng.standard_normal(4000)
    taus = [0.1, 0.2, 0.8, 3.2, 25.6, 80.0]
    ours = compute_deviation(y, 0.1, input_kind="rate", kind="gapadev", taus=taus, noise_id=False)
    _, d_at, _, n_at = at.oadev(y, rate=10.0, data_type="freq", taus=taus)
    np.testing.assert_allclose(ours.sigma, d_at, rtol=1e-12)
    np.testing.assert_array_equal(ours.n, n_at)
    # angle input with missing points: AllanTools' gap-resistant ADEV on phase
    x = np.cumsum(rng.standard_normal(4000))
    x[[10, 500, 501, 2000]] = np.nan
    x[3000:3100] = np.nan
    ours = compute_deviation(x, 1.0, input_kind="angle", kind="gapadev", taus="octave",
                             noise_id=False)
    _, d_at, _, n_at = at.gradev(x, rate=1.0, data_type="phase", taus=ours.tau)
    np.testing.assert_allclose(ours.sigma, d_at, rtol=1e-12)
    np.testing.assert_array_equal(ours.n, n_at)


# ---------------------------------------------------------------------------------------------
# Kernels
# ---------------------------------------------------------------------------------------------


def test_half_convolution_brute_force():
    rng = np.random.default_rng(0)
    for n in (1, 2, 7, 64, 65, 300):
        u, v = rng.standard_normal(n), rng.standard_normal(n)
        ref = np.zeros(max(2 * n - 1, 1))
        for a in range(n):
            for b in range(a + 1, n):
                ref[a + b] += u[a] * v[b]
        np.testing.assert_allclose(tk.half_convolution(u, v), ref, rtol=1e-10, atol=1e-10)


@pytest.mark.parametrize("N", [101, 400, 1001])
def test_theo1_fast_kernel_equals_definition(N):
    rng = np.random.default_rng(N)
    for x in (rng.standard_normal(N), np.cumsum(rng.standard_normal(N))):
        x = x - np.linspace(x[0], x[-1], N)
        eng = tk.Theo1Engine(x)
        for m in range(10, N - 1, max(2, 2 * (N // 40))):
            d = tk.theo1_sum_direct(x, m)
            assert eng._fast(m) == pytest.approx(d, rel=1e-9)


def test_theo1_fast_path_selection(monkeypatch):
    """The engine uses the expanded form on long records and falls back to the definition when
    the estimated rounding error is too large (random-walk rate angle)."""
    monkeypatch.setattr(tk, "DIRECT_MAX_WORK", 0)
    rng = np.random.default_rng(4)
    x = np.cumsum(np.cumsum(rng.standard_normal(3000)))
    x -= np.linspace(x[0], x[-1], x.size)
    eng = tk.Theo1Engine(x)
    for m in (10, 200, 2000):
        assert eng.sum(m) == pytest.approx(tk.theo1_sum_direct(x, m), rel=1e-10)


# ---------------------------------------------------------------------------------------------
# ThêoH
# ---------------------------------------------------------------------------------------------


def test_theoh_definition():
    """ThêoH = OADEV for τ < 0.1·T; beyond, Thêo1 × the mean AVAR/Thêo1 ratio over
    i = 0 … ⌊0.1N/3 − 3⌋ (AVAR at 9 + 3i, Thêo1 at 12 + 4i), recomputed here directly."""
    rng = np.random.default_rng(8)
    y = rng.standard_normal(600)
    h = compute_deviation(y, 1.0, input_kind="rate", kind="theoh", taus="octave", noise_id=False)
    T = 600.0
    short = h.tau < 0.1 * T
    assert short.any() and (~short).any()
    oa = compute_deviation(y, 1.0, input_kind="rate", kind="oadev", taus=list(h.tau[short]),
                           noise_id=False)
    np.testing.assert_allclose(h.sigma[short], oa.sigma, rtol=1e-12)
    x = np.concatenate(([0.0], np.cumsum(y - y.mean())))
    N = x.size
    n = int(math.floor(0.1 * N / 3 - 3))
    ratios = []
    for i in range(n + 1):
        ma, mt = 9 + 3 * i, 12 + 4 * i
        d = x[2 * ma:] - 2 * x[ma:-ma] + x[: N - 2 * ma]
        avar = np.dot(d, d) / (2 * ma * ma * (N - 2 * ma))
        th = tk.theo1_sum_direct(x, mt) / (0.75 * (N - mt) * mt * mt)
        ratios.append(avar / th)
    for m, s in zip(h.m[~short], h.sigma[~short]):
        th = tk.theo1_sum_direct(x, int(m)) / (0.75 * (N - m) * m * m)
        assert s == pytest.approx(math.sqrt(th * np.mean(ratios)), rel=1e-10)
    # white rate noise: Thêo1 is unbiased, so the ratio is close to 1
    assert 0.8 < np.mean(ratios) < 1.25


# ---------------------------------------------------------------------------------------------
# Gap-tolerant OADEV
# ---------------------------------------------------------------------------------------------


def brute_gap_oadev_rate(y: np.ndarray, m: int) -> tuple[float, int]:
    """Cluster averages of m complete samples; differences of adjacent complete clusters."""
    diffs = []
    for k in range(y.size - 2 * m + 1):
        a, b = y[k : k + m], y[k + m : k + 2 * m]
        if np.isfinite(a).all() and np.isfinite(b).all():
            diffs.append(b.mean() - a.mean())
    d = np.array(diffs)
    return math.sqrt(np.dot(d, d) / (2 * d.size)), d.size


def test_gapadev_brute_force_and_pooled_segments():
    rng = np.random.default_rng(5)
    y = rng.standard_normal(1500) + 3.0
    y[200:237] = np.nan
    y[900] = np.nan
    taus = [1.0, 2.0, 5.0, 20.0, 100.0]
    res = compute_deviation(y, 1.0, input_kind="rate", kind="gapadev", taus=taus, noise_id=False)
    for m, s, n in zip(res.m, res.sigma, res.n):
        s_ref, n_ref = brute_gap_oadev_rate(y, int(m))
        assert s == pytest.approx(s_ref, rel=1e-10)
        assert n == n_ref
    # for rate input it equals the OADEV pooled over the gap-free runs (and so its EDF)
    runs = finite_runs(y)
    assert runs == [(0, 200), (237, 900), (901, 1500)]
    pooled = compute_deviation(np.nan_to_num(y), 1.0, input_kind="rate", kind="oadev",
                               taus=taus, segments=runs, noise_id=False)
    np.testing.assert_allclose(res.sigma, pooled.sigma, rtol=1e-12)
    np.testing.assert_array_equal(res.n, pooled.n)
    np.testing.assert_allclose(res.edf, pooled.edf, rtol=1e-12)
    assert any("38 missing sample" in n for n in res.notes)


def test_gapadev_angle_spans_gaps():
    """Angle input: a difference straddling missing points is used when its three angles are
    present, so n exceeds the run-pooled count."""
    rng = np.random.default_rng(6)
    x = np.cumsum(rng.standard_normal(1000))
    x[[100, 400, 401]] = np.nan
    res = compute_deviation(x, 1.0, input_kind="angle", kind="gapadev", taus=[50.0],
                            noise_id=False)
    m = 50
    d = x[2 * m:] - 2 * x[m:-m] + x[:-2 * m]
    d = d[np.isfinite(d)]
    assert res.n[0] == d.size
    assert res.sigma[0] == pytest.approx(math.sqrt(np.dot(d, d) / (2 * m * m * d.size)), rel=1e-12)
    assert res.n[0] > 1000 - 2 * m - 3 * 2 * m


def test_gapadev_bad_input():
    with pytest.raises(InputError, match="NaN, not inf"):
        compute_deviation(np.array([1.0, np.inf, 2.0] * 10), 1.0, input_kind="rate",
                          kind="gapadev")
    with pytest.raises(InputError, match="every sample is missing"):
        compute_deviation(np.full(10, np.nan), 1.0, input_kind="rate", kind="gapadev")
    y = np.random.default_rng(1).standard_normal(100)
    y[::7] = np.nan
    with pytest.raises(InputError, match="no complete Allan difference"):
        compute_deviation(y, 1.0, input_kind="rate", kind="gapadev", taus=[10.0])


def test_theo1_bad_input():
    y = np.random.default_rng(1).standard_normal(50)
    with pytest.raises(InputError, match="record too short"):
        compute_deviation(y, 1.0, input_kind="rate", kind="theo1", taus=[200.0])
    with pytest.raises(InputError, match="bias correction"):
        compute_deviation(y, 1.0, input_kind="rate", kind="theo1", bias_correction=True)


# ---------------------------------------------------------------------------------------------
# EDF
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("alpha,m", [(2, 40), (0, 40), (-2, 40)])
def test_theo1_edf_monte_carlo(alpha, m):
    """SP1065's Thêo1 EDF vs the EDF of simulated estimates, 2·E[S]²/Var[S] (400 runs: the
    empirical EDF has ≈ 10 % sampling error; 25 % tolerance)."""
    rng = np.random.default_rng(100 + alpha)
    N = 257
    v = []
    for _ in range(400):
        w = rng.standard_normal(N)
        x = w if alpha == 2 else (np.cumsum(w) if alpha == 0 else np.cumsum(np.cumsum(w)))
        v.append(tk.theo1_sum_direct(x, m))
    v = np.array(v)
    emp = 2 * v.mean() ** 2 / v.var()
    assert emp == pytest.approx(edf_theo1(alpha, m, N), rel=0.25)


def test_new_kinds_have_intervals():
    rng = np.random.default_rng(2)
    y = rng.standard_normal(3000)
    for k in ("theo1", "theoh", "ttotdev", "htotdev", "gapadev"):
        r = compute_deviation(y, 0.1, input_kind="rate", kind=k, taus="octave")
        assert np.all(np.isfinite(r.edf)) and np.all(r.sigma_lo < r.sigma) and np.all(r.sigma < r.sigma_hi), k
        assert r.to_dict()["kind"] == k


# ---------------------------------------------------------------------------------------------
# CLI
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("kind", ["theo1", "theoh", "ttotdev", "htotdev", "gapadev"])
def test_cli_dev_kinds(tmp_path, kind):
    rng = np.random.default_rng(9)
    n = 6000
    t = np.arange(n) * 0.1
    w = rng.standard_normal(n) * 2.0 + np.cumsum(rng.standard_normal(n)) * 0.002
    p = tmp_path / "log.csv"
    np.savetxt(p, np.column_stack([t, w]), delimiter=",", header="time,gyro_x", comments="",
               fmt="%.6f")
    r = run_cli(["allan", str(p), "--rate-unit", "deg/h", "--dev", kind, "--no-diagnose",
                 "--json"])
    assert r.code == 0, r.err
    import json

    doc = json.loads(r.out)
    ax = doc["logs"][0]["axes"][0]
    assert ax["deviation"]["kind"] == kind if "deviation" in ax else kind in r.out
