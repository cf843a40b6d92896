"""Spike detection (Hampel filter, robust scale) as a classifier, and its use in info, allan and
bias: quick randomized check (the long one is benchmarks/bench_outliers.py), the real XSens log's
spikes reported, and the treatments."""

from __future__ import annotations

import json
import sys
import zlib
from pathlib import Path

import numpy as np
import pytest

from gyrotest.noise.outliers import apply_outliers, detect_outliers, threshold_k

from cliutil import run_cli

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import bench_outliers as bo  # noqa: E402

XSENS = bo.ADIS.parent / "cont_imu1.csv.gz"


def test_randomized_recall_and_false_alarms():
    """40 cases outside the tuning range (seeds 0–99) over every base noise incl. nulls."""
    cases = [bo.run_case(s) for s in range(2000, 2040)]
    s = bo.summarise(cases)
    assert s["null_cases"] >= 10
    assert s["null_cases_flagged"] == 0
    assert s["false_alarms_per_1e6"] < 5
    for b in ("12-20σ", "20-60σ"):
        r, n = s["recall"][b]
        assert n >= 20 and r >= 0.98, (b, r, n)
    r, n = s["recall"]["8-12σ"]
    assert r >= 0.8, r
    # the final answer: N from σ(1 s) after --outliers remove within 2 % of the clean record
    assert s["N_err_clean_max"] < 0.02 and s["N_err_clean_median"] < s["N_err_raw_median"]


def test_threshold_and_treatments():
    assert threshold_k(100) == 6.0 and threshold_k(10**12) > 7.0
    rng = np.random.default_rng(1)
    x = rng.standard_normal(20_000)
    x[[500, 9000]] += [30.0, -25.0]
    rep = detect_outliers(x, 0.01, t0=100.0)
    assert [e.start for e in rep.events] == [500, 9000]
    assert rep.events[0].t_s == pytest.approx(105.0) and rep.events[1].peak_z < -20
    assert np.array_equal(apply_outliers(x, rep, "flag"), x)
    rem = apply_outliers(x, rep, "remove")
    assert abs(rem[500]) < 3 and abs(rem[9000]) < 3
    rob = apply_outliers(x, rep, "robust")
    assert 3 < rob[500] <= rep.k * rep.scale + 3
    assert np.array_equal(rem[rep.mask == 0], x[rep.mask == 0])
    # coarse quantization (MAD = 0) and constants do not raise false alarms
    q = np.round(rng.standard_normal(50_000) / 3.0) * 3.0
    assert not detect_outliers(q, 0.01).found
    assert not detect_outliers(np.zeros(100), 0.01).found


@pytest.fixture(scope="module")
def xsens_csv(tmp_path_factory):
    if not XSENS.is_file():
        pytest.skip(f"real XSens log not found at {XSENS}")
    import gzip

    p = tmp_path_factory.mktemp("xsens") / "xsens.csv"
    with gzip.open(XSENS, "rt") as fh:
        p.write_text(fh.read())
    return str(p)


XS = ["--rate-col", "gyro_x_rps", "--rate-unit", "rad/s"]


def test_xsens_spikes_are_reported_everywhere(xsens_csv):
    r = run_cli(["info", xsens_csv, *XS])
    assert r.code == 0, r.err
    assert "spike event(s)" in r.err and "t = 12.97 s" in r.err
    r = run_cli(["allan", xsens_csv, *XS, "--json", "--no-diagnose", "--taus", "decade"])
    assert r.code == 0, r.err
    ax = json.loads(r.out)["logs"][0]["axes"][0]
    assert ax["outliers"]["n_events"] >= 50 and ax["outliers"]["mode"] == "flag"
    assert "OUTLIERS" in {w["code"] for w in ax["warnings"]}
    assert "OUTLIERS" in r.err
    r2 = run_cli(["allan", xsens_csv, *XS, "--json", "--no-diagnose", "--taus", "decade",
                  "--outliers", "remove"])
    ax2 = json.loads(r2.out)["logs"][0]["axes"][0]
    # removing 0.03 % of the samples lowers σ at τ0 noticeably
    assert ax2["table"][0]["sigma"] < 0.97 * ax["table"][0]["sigma"]
    r3 = run_cli(["bias", xsens_csv, *XS, "--json"])
    assert r3.code == 0, r3.err
    assert json.loads(r3.out)["runs"][0]["outliers"]["n_events"] >= 50


def test_bad_outliers_value(xsens_csv):
    run_cli(["allan", xsens_csv, *XS, "--outliers", "drop"]).assert_clean_error("--outliers")


def test_running_median_numpy_equals_scipy_median_filter():
    """The numpy running median (small records: no scipy import in `info`) equals
    scipy.ndimage.median_filter(mode="nearest"), the one used for long records."""
    from scipy.ndimage import median_filter

    from gyrotest.noise import outliers as o

    rng = np.random.default_rng(11)
    for n, w in ((5, 3), (7, 7), (1000, 51), (20001, 101)):
        x = rng.standard_normal(n)
        assert np.array_equal(o._running_median(x, w), median_filter(x, size=w, mode="nearest"))


def test_running_median_in_pieces_equals_one_call(monkeypatch):
    """Long records get scipy's running median in pieces (so another thread gets the GIL
    between them): the same numbers as one call, for windows shorter and longer than a
    piece, pieces cut anywhere, and the record's ends padded as in one call."""
    from scipy.ndimage import median_filter

    from gyrotest.noise import outliers as o

    monkeypatch.setattr(o, "NUMPY_MEDIAN_MAX", 100)
    rng = np.random.default_rng(12)
    for piece in (1, 50, 997, 1 << 18):
        monkeypatch.setattr(o, "MEDIAN_PIECE", piece)
        for n, w in ((101, 3), (3001, 51), (3001, 2001), (12345, 101)):
            x = rng.standard_normal(n)
            x[:: 97] += 40.0  # spikes
            assert np.array_equal(o._running_median(x, w),
                                  median_filter(x, size=w, mode="nearest")), (piece, n, w)


def test_median_and_quantile_equal_numpy(monkeypatch):
    """The spike check's scale takes the median and the 99 % quantile of |residual| from
    order statistics selected in brackets: exactly np.median and np.quantile, with ties
    (quantized data, half the values zero), sorted input, heavy tails; NaN ranks last as in a
    partition."""
    from gyrotest.noise import outliers as o

    rng = np.random.default_rng(13)
    for bracket_min in (1 << 18, 64):
        monkeypatch.setattr(o, "BRACKET_MIN", bracket_min)
        for n in (5, 64, 1001, 300_001):
            cases = [np.abs(rng.standard_normal(n)), np.abs(rng.standard_cauchy(n)),
                     np.round(np.abs(rng.standard_normal(n)) * 2) / 2, np.zeros(n),
                     np.sort(np.abs(rng.standard_normal(n)))]
            half = np.abs(rng.standard_normal(n))
            half[: n // 2] = 0.0
            cases.append(half)
            for a in cases:
                got = o._median_quantile(a.copy(), 0.99)
                assert got == (float(np.median(a)), float(np.quantile(a, 0.99))), (n, got)
        a = np.abs(rng.standard_normal(300_001))
        a[::7] = np.nan
        ref = a.copy()
        ref.partition([150_000])
        assert o._median_quantile(a.copy(), 0.99)[0] == ref[150_000]


def _reference_outliers(x, segs, window, scale, kk):
    """Outlier indices and z with the running median computed at every sample (the plain
    Hampel filter) for a given scale: what the screened long-record check must reproduce."""
    from gyrotest.noise import outliers as o

    r = np.zeros_like(x)
    for a, b in segs:
        w = min(window, (b - a) | 1) if b - a >= 3 else 1
        if w >= 3:
            r[a:b] = x[a:b] - o._running_median(x[a:b], w)
    idx = np.flatnonzero(np.abs(r / scale) > kk) if scale > 0 else np.zeros(0, int)
    return idx, r[idx] / scale if idx.size else np.zeros(0)


@pytest.mark.parametrize("kind", ["white", "spikes", "cluster", "rrw", "student", "quant",
                                  "gaps", "adis"])
def test_screened_long_record_finds_exactly_the_hampel_outliers(monkeypatch, kind):
    """Long records: the scale from the stretches' residuals, and the outliers from the running
    median at the samples the block screen cannot clear — exactly the samples and z of the
    running median everywhere (for that scale), with short and odd segments, clustered
    spikes, heavy tails, coarse quantization (the screen gives up: median everywhere) and
    real ADIS16405 noise; the scale within 2 % of the exact one from every residual (8 % with
    Student-t tails)."""
    from gyrotest.noise import outliers as o

    monkeypatch.setattr(o, "SCALE_SAMPLE", 1 << 14)
    monkeypatch.setattr(o, "SCALE_STRETCHES", 16)
    monkeypatch.setattr(o, "SCREEN_BLOCKS", 1000)
    rng = np.random.default_rng(zlib.crc32(kind.encode()))  # (str hash is salted per run)
    n = 120_000
    segs = [(0, n)]
    if kind == "adis":
        a = bo._adis_rates()
        if a is None:
            pytest.skip("the shared ADIS16405 log is not present")
        x = a[:n, 0].copy()
    elif kind == "rrw":
        x = rng.standard_normal(n) + np.cumsum(rng.standard_normal(n)) * 0.05
    elif kind == "student":
        x = rng.standard_t(3, n)
    elif kind == "quant":
        x = np.round(rng.standard_normal(n) * 0.3)  # MAD = 0 for most windows
    else:
        x = rng.standard_normal(n) * 2.0 + 5.0
    if kind in ("spikes", "gaps", "adis", "rrw", "student"):
        i = rng.choice(n, 60, replace=False)
        x[i] += rng.choice([-1, 1], 60) * np.exp(rng.uniform(np.log(3), np.log(60), 60)) * \
            np.std(np.diff(x)) / np.sqrt(2)
    if kind == "cluster":
        x[5000:5030] += 25.0  # longer than half the window: masks itself, as in the filter
        x[7000:7010] -= 30.0
        x[0] += 40.0
        x[n - 1] -= 40.0
    if kind == "gaps":
        segs = [(0, 2), (2, 40), (40, 10_001), (10_001, 10_003), (10_003, 60_000),
                (60_000, 60_051), (60_051, n)]
    rep = detect_outliers(x, 0.01, segments=segs)
    assert "stretches" in rep.scale_method
    idx, z = _reference_outliers(x, segs, rep.window, rep.scale, rep.k)
    assert np.array_equal(np.flatnonzero(rep.mask), idx)
    got_z = np.array([e.peak_z for e in rep.events])
    ref_ev = o.outlier_events(idx, z, 0.0, 0.01)
    assert [(e.start, e.stop) for e in rep.events] == [(e.start, e.stop) for e in ref_ev]
    np.testing.assert_array_equal(got_z, [e.peak_z for e in ref_ev])
    if kind in ("spikes", "gaps", "cluster"):
        assert rep.found
    monkeypatch.setattr(o, "SCALE_SAMPLE", 1 << 30)  # the exact check, every residual
    exact = detect_outliers(x, 0.01, segments=segs)
    # a 99 % quantile of heavy-tailed residuals from 16 k samples (2²⁰ in use) scatters more
    assert rep.scale == pytest.approx(exact.scale, rel=0.08 if kind == "student" else 0.02)
    # the other scale only moves samples at the threshold's edge
    diff = np.flatnonzero(rep.mask != exact.mask)
    _, z_all = _reference_outliers(x, segs, rep.window, exact.scale, 0.0)
    i_all, _ = _reference_outliers(x, segs, rep.window, exact.scale, 0.0)
    z_of = dict(zip(i_all.tolist(), np.abs(z_all).tolist()))
    tol = 0.08 if kind == "student" else 0.02
    assert all(abs(z_of.get(i, 0.0) / exact.k - 1) <= tol for i in diff.tolist()), kind
    assert diff.size <= max(2, 0.05 * exact.n_outliers) or kind == "student"
