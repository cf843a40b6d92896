"""Long Parquet logs streamed into θ (gyrotest.io.stream, gyrotest.noise.streamed; issue #13):
the streamed analysis must give the numbers of the whole-log analysis — deviations, noise
types, fit, spike events, PSD, ACF — across batch boundaries, gaps and spikes, for plain
Parquet tables and for files written by `gyrotest ingest`."""

from __future__ import annotations

import json
import math

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

import gyrotest.io.stream as st
from gyrotest.core.angle import angle_series
from gyrotest.io.ingest import read_log, write_log
from gyrotest.noise.analysis import analyse_allan
from gyrotest.noise.outliers import detect_outliers
from gyrotest.noise.spectral import welch_psd
from gyrotest.noise.streamed import detect_outliers_series, welch_psd_series

from cliutil import run_cli

N = 60_000
TAU0 = 0.01


def _record(seed: int = 3, spikes=(1234, 31_000, 31_001, 50_017), gaps=()) -> tuple:
    rng = np.random.default_rng(seed)
    t = (np.arange(N) + 1) * TAU0
    for i, d in gaps:  # a hole of d seconds before sample i
        t[i:] += d
    rw = np.cumsum(rng.standard_normal(N)) * 0.002
    x = rng.standard_normal(N) * 6.0 + rw + 0.35 + 2.0 * np.sin(2 * np.pi * 3.0 * t)
    for i in spikes:
        x[i] += 200.0
    return t, x


def _plain(path, t, x):
    pq.write_table(pa.table({"t_s": t, "omega_dph": x}), path, row_group_size=7_000)


@pytest.fixture
def small_batches(monkeypatch):
    """Batches of 4 096 rows: gaps and spikes fall on and across batch boundaries."""
    monkeypatch.setattr(st, "BATCH_ROWS", 4_096)
    monkeypatch.setattr("gyrotest.noise.streamed.BATCH", 5_000)


def _compare(a, b):
    """Streamed analysis ``b`` against the whole-log analysis ``a``."""
    assert a.n_samples == b.n_samples
    assert b.tau0 == pytest.approx(a.tau0, rel=1e-12)
    assert a.duration_s == pytest.approx(b.duration_s, rel=1e-12)
    for xa, xb in zip(a.axes, b.axes):
        da, db = xa.dev, xb.dev
        assert np.array_equal(da.m, db.m) and np.array_equal(da.n, db.n)
        assert np.array_equal(da.alpha, db.alpha)
        np.testing.assert_allclose(db.sigma, da.sigma, rtol=1e-9)
        np.testing.assert_allclose(db.sigma_lo, da.sigma_lo, rtol=1e-9)
        fa, fb = xa.best_fit.to_dict(), xb.best_fit.to_dict()
        assert json.dumps(fa["terms_requested"]) == json.dumps(fb["terms_requested"])
        for ta, tb in zip(xa.best_fit.terms, xb.best_fit.terms):
            assert ta.status == tb.status
            for k in ta.params:
                assert tb.params[k] == pytest.approx(ta.params[k], rel=1e-6, abs=1e-12)
        np.testing.assert_allclose(xb.psd.psd, xa.psd.psd, rtol=1e-9)
        assert xb.psd.n_used == xa.psd.n_used and xb.psd.nperseg == xa.psd.nperseg
        np.testing.assert_allclose(xb.acf.rho, xa.acf.rho, rtol=1e-7, atol=1e-12)
        oa, ob = xa.outliers, xb.outliers
        assert oa["n_outliers"] == ob["n_outliers"] and oa["n_events"] == ob["n_events"]
        assert [e["start_index"] for e in oa["events"]] == [e["start_index"]
                                                            for e in ob["events"]]
        assert ob["scale"] == pytest.approx(oa["scale"], rel=1e-12)
        assert ob["excess_kurtosis"] == pytest.approx(oa["excess_kurtosis"], rel=1e-6)
        assert [w.code for w in xa.warnings] == [w.code for w in xb.warnings]
        np.testing.assert_allclose(xb.akdev.sigma, xa.akdev.sigma, rtol=1e-9)


@pytest.mark.parametrize("gaps", [(), ((4_096, 0.5), (20_000, 3.0), (40_961, 0.05))])
def test_plain_parquet_streamed_equals_whole(tmp_path, small_batches, gaps):
    t, x = _record(gaps=gaps)
    p = tmp_path / "log.parquet"
    _plain(p, t, x)
    whole = read_log(p, overrides={"units": {}})
    s = st.stream_log(str(p), min_rows=1)
    assert s is not None and s.meta["streamed"]
    assert [(g.index, g.missing) for g in s.timing.gaps] == [(g.index, g.missing)
                                                             for g in whole.timing.gaps]
    assert s.segments == whole.segments
    a, b = analyse_allan(whole), analyse_allan(s)
    _compare(a, b)
    assert b.axes[0].outliers["n_events"] == 3  # two single spikes and one pair


def test_converted_parquet_streamed_equals_whole(tmp_path, small_batches):
    t, x = _record(gaps=((10_000, 1.0), (12_288, 0.2)))
    src = tmp_path / "log.csv"
    np.savetxt(src, np.column_stack([t, x]), delimiter=",", header="t_s,omega_dph",
               comments="", fmt="%.10g")
    conv = tmp_path / "conv.parquet"
    write_log(read_log(src), conv)
    whole = read_log(conv)
    s = st.stream_log(str(conv), min_rows=1)
    assert s is not None and len(s.timing.gaps) == 2
    _compare(analyse_allan(whole), analyse_allan(s))


def test_theta_equals_angle_series_and_scale_subsample(monkeypatch, tmp_path, small_batches):
    """θ differs from angle_series only by rounding; with a subsampled robust scale the
    spike events stay the same and the scale stays within 1 %."""
    t, x = _record(spikes=(77, 40_000))
    p = tmp_path / "log.parquet"
    _plain(p, t, x)
    s = st.stream_log(str(p), min_rows=1)
    ref = angle_series(x, TAU0, input_kind="rate")
    th = s.series["omega_dph"].theta
    assert th.size == ref.theta.size
    assert np.max(np.abs(th - ref.theta)) < 1e-9 * np.max(np.abs(ref.theta))
    full = detect_outliers(x, TAU0)  # every residual
    monkeypatch.setattr("gyrotest.noise.outliers.SCALE_SAMPLE", 5_000)
    monkeypatch.setattr("gyrotest.noise.outliers.SCALE_STRETCHES", 10)
    rep = detect_outliers_series(s.series["omega_dph"], s.means["omega_dph"], TAU0)
    whole = detect_outliers(x, TAU0)  # the same stretches, screened
    assert [e.start for e in rep.events] == [e.start for e in full.events] == [77, 40_000]
    assert [e.start for e in whole.events] == [77, 40_000]
    assert rep.scale == pytest.approx(full.scale, rel=0.01)
    assert rep.scale == pytest.approx(whole.scale, rel=1e-12)
    assert rep.excess_kurtosis == pytest.approx(whole.excess_kurtosis, rel=1e-6)
    assert "from 5000 residuals in 10 stretches" in rep.scale_method
    psd = welch_psd_series(s.series["omega_dph"], s.means["omega_dph"], TAU0)
    np.testing.assert_allclose(psd.psd, welch_psd(x, TAU0).psd, rtol=1e-9)


def test_short_or_unsupported_files_are_read_whole(tmp_path):
    t, x = _record()
    p = tmp_path / "log.parquet"
    _plain(p, t, x)
    assert st.stream_log(str(p)) is None  # shorter than STREAM_MIN_ROWS
    assert st.stream_log(str(p), min_rows=1, nan_policy="gap") is None
    csv = tmp_path / "log.csv"
    csv.write_text("t_s,omega_dph\n0.01,1\n0.02,2\n")
    assert st.stream_log(str(csv), min_rows=1) is None


def test_cli_streams_long_parquet_with_same_json(tmp_path, monkeypatch):
    t, x = _record()
    p = tmp_path / "log.parquet"
    _plain(p, t, x)
    r0 = run_cli(["allan", p, "--rate-unit", "deg/h", "--json"])
    assert r0.code == 0, r0.err
    monkeypatch.setattr(st, "STREAM_MIN_ROWS", 1)
    r1 = run_cli(["allan", p, "--rate-unit", "deg/h", "--json"])
    assert r1.code == 0, r1.err
    a, b = json.loads(r0.out)["logs"][0], json.loads(r1.out)["logs"][0]
    sa = [r["sigma"] for r in a["axes"][0]["table"]]
    sb = [r["sigma"] for r in b["axes"][0]["table"]]
    assert len(sa) == len(sb) and all(math.isclose(u, v, rel_tol=1e-9) for u, v in zip(sa, sb))
    assert a["axes"][0]["outliers"]["n_events"] == b["axes"][0]["outliers"]["n_events"] == 3
    # options that need the samples themselves read the log whole (same numbers as before)
    r2 = run_cli(["allan", p, "--rate-unit", "deg/h", "--json", "--outliers", "remove"])
    assert r2.code == 0, r2.err
    assert json.loads(r2.out)["logs"][0]["axes"][0]["outliers"]["mode"] == "remove"


def test_converted_file_with_contradicting_time_is_a_clean_error(tmp_path, small_batches):
    t, x = _record()
    src = tmp_path / "log.csv"
    np.savetxt(src, np.column_stack([t, x]), delimiter=",", header="t_s,omega_dph",
               comments="", fmt="%.10g")
    conv = tmp_path / "conv.parquet"
    write_log(read_log(src), conv)
    tab = pq.read_table(conv)
    tt = tab.column("time_s").to_numpy().copy()
    tt[30_000:] += 5.0  # a hole the metadata does not list
    bad = tab.set_column(tab.schema.get_field_index("time_s"), "time_s", pa.array(tt))
    pq.write_table(bad, tmp_path / "bad.parquet")
    with pytest.raises(Exception) as ei:
        st.stream_log(str(tmp_path / "bad.parquet"), min_rows=1)
    assert "row 30001" in str(ei.value) and "gyrotest ingest" in str(ei.value)


def test_pulse_output_streamed_as_increments(tmp_path, small_batches):
    """Counts (angle increments, S0 = 0.5 arcsec/pulse) stream into θ of increments."""
    rng = np.random.default_rng(2)
    t = (np.arange(30_000) + 1) * TAU0
    p = tmp_path / "cnt.parquet"
    pq.write_table(pa.table({"t_s": t, "pulses": rng.poisson(50, t.size).astype(float)}), p,
                   row_group_size=7_000)
    ov = {"gyro": {"output_kind": "counts", "scale_factor": 0.5}, "columns": {"output": "pulses"}}
    s = st.stream_log(str(p), overrides=ov, min_rows=1)
    assert s.series["pulses"].input_kind == "increment"
    a, b = analyse_allan(read_log(p, overrides=ov)), analyse_allan(s)
    assert a.axes[0].input_note == b.axes[0].input_note
    np.testing.assert_allclose(b.axes[0].dev.sigma, a.axes[0].dev.sigma, rtol=1e-9)
    assert np.array_equal(a.axes[0].dev.alpha, b.axes[0].dev.alpha)
