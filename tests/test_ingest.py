"""Ingest layer: every output kind, units, profiles and overrides, timing, formats, errors."""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from gyrotest.core.earth import OMEGA_E_DPH
from gyrotest.core.errors import InputError
from gyrotest.core.profile import Profile, load_profile, merge, profile_from_dict
from gyrotest.io.ingest import read_log, write_log

from cliutil import run_cli

DEG = math.pi / 180


def write_csv(path, df: pd.DataFrame, comment: str | None = None, sep=","):
    text = df.to_csv(index=False, sep=sep, lineterminator="\n")
    if comment:
        text = "".join(f"# {ln}\n" for ln in comment.splitlines()) + text
    path.write_text(text)
    return path


def ov(**kw):
    """Overrides in the profile's shape from flat keyword arguments."""
    sections = {"columns": {}, "gyro": {}, "site": {}, "units": {}}
    colkeys = {"time", "rate", "counts", "up", "down", "counter", "voltage", "temperature",
               "field", "supply", "table_rate", "position", "extra"}
    sitekeys = {"latitude_deg", "ia", "ia_azimuth_deg", "ia_elevation_deg"}
    for k, v in kw.items():
        if k in colkeys:
            sections["columns"][k] = v
        elif k in sitekeys:
            sections["site"][k] = v
        else:
            sections["gyro"][k] = v
    return sections


@pytest.fixture
def rng():
    return np.random.default_rng(1)


# ----------------------------------------------------------------------------- output kinds
@pytest.mark.parametrize("unit,factor", [("deg/h", 1.0), ("deg/s", 3600.0), ("rad/s", 3600 / DEG),
                                         ("mrad/s", 3.6 / DEG), ("deg/min", 60.0),
                                         ("arcsec/s", 1.0)])
def test_rate_units(tmp_path, rng, unit, factor):
    v = rng.normal(size=200)
    p = write_csv(tmp_path / "r.csv", pd.DataFrame({"t": np.arange(200) * 0.01, "w": v}))
    log = read_log(p, overrides=ov(rate="w", rate_unit=unit))
    np.testing.assert_allclose(log.rate, v * factor, rtol=1e-12)
    assert log.tau0 == pytest.approx(0.01)
    assert log.gyro.output_kind == "rate"


def test_counts_to_rate(tmp_path, rng):
    counts = rng.integers(-5, 50, size=500)
    p = write_csv(tmp_path / "c.csv", pd.DataFrame({"time": np.arange(500) * 0.1, "pulses": counts}))
    log = read_log(p, overrides=ov(counts="pulses", scale_factor=0.2))
    # counts x S0 [arcsec] / tau0 [s] = arcsec/s = deg/h
    np.testing.assert_allclose(log.rate, counts * 0.2 / 0.1, rtol=1e-12)
    assert log.gyro.angle_quantum_arcsec == 0.2


def test_updown_pairs(tmp_path, rng):
    up = rng.integers(1000, 1100, size=300)
    down = rng.integers(1000, 1100, size=300)
    p = write_csv(tmp_path / "ud.csv", pd.DataFrame({"t": np.arange(300) * 0.5, "up": up, "down": down}))
    log = read_log(p, overrides=ov(scale_factor=1.5))  # up/down auto-detected
    np.testing.assert_allclose(log.rate, (up - down) * 1.5 / 0.5)
    assert log.gyro.output_kind == "updown"


@pytest.mark.parametrize("bits", [16, 32])
def test_counter_rollover(tmp_path, rng, bits):
    net = rng.integers(-3000, 9000, size=1000)
    start = 2 ** bits - 5000
    cum = (start + np.concatenate([[0], np.cumsum(net)])) % (2 ** bits)
    t = np.arange(1001) * 0.01
    p = write_csv(tmp_path / "k.csv", pd.DataFrame({"t": t, "cnt": cum}))
    log = read_log(p, overrides=ov(counter="cnt", counter_bits=bits, scale_factor=0.1))
    assert log.n == 1000
    np.testing.assert_allclose(log.rate, net * 0.1 / 0.01)
    assert log.t[0] == 0.0


def test_counter_out_of_range(tmp_path):
    p = write_csv(tmp_path / "k.csv", pd.DataFrame({"t": [0, 1, 2], "cnt": [1, 70000, 3]}))
    with pytest.raises(InputError, match="counter"):
        read_log(p, overrides=ov(counter="cnt", counter_bits=16, scale_factor=1))


def test_voltage(tmp_path, rng):
    v = 2.5 + rng.normal(scale=0.01, size=100)
    p = write_csv(tmp_path / "v.csv", pd.DataFrame({"t": np.arange(100.0), "v_out": v}))
    log = read_log(p, overrides=ov(voltage="v_out", scale_factor=400.0, offset_v=2.5))
    np.testing.assert_allclose(log.rate, (v - 2.5) * 400.0, rtol=1e-12, atol=1e-12)
    assert log.gyro.scale_factor_unit == "(deg/h)/V"


def test_multi_axis_rate(tmp_path, rng):
    d = pd.DataFrame({"t": np.arange(50) * 0.1, "gx": rng.normal(size=50),
                      "gy": rng.normal(size=50), "gz": rng.normal(size=50)})
    p = write_csv(tmp_path / "m.csv", d)
    log = read_log(p, overrides=ov(rate=["gx", "gy", "gz"], rate_unit="deg/s"))
    assert log.axes == ["gx", "gy", "gz"]
    np.testing.assert_allclose(log.rates["gz"], d.gz * 3600)


# ----------------------------------------------------------------------------- aux channels and units
def test_aux_channels_units(tmp_path, rng):
    n = 100
    d = pd.DataFrame({
        "t_s": np.arange(n) * 1.0,
        "rate_dph": rng.normal(size=n),
        "T_case_K": 300 + rng.normal(size=n),
        "T_coil_F": 70 + rng.normal(size=n),
        "Hx": np.full(n, 0.5), "Hy": np.full(n, 0.1), "Hz": np.full(n, -0.2),
        "vsupply": 15000 + rng.normal(size=n),
        "table_dps": np.full(n, 10.0),
        "vib": rng.normal(size=n),
    })
    p = write_csv(tmp_path / "a.csv", d)
    prof = profile_from_dict({
        "columns": {"temperature": ["T_case_K", "T_coil_F"], "field": ["Hx", "Hy", "Hz"],
                    "supply": "vsupply", "table_rate": "table_dps"},
        "units": {"Hx": "G", "Hy": "G", "Hz": "G", "vsupply": "mV"},
    })
    log = read_log(p, profile=prof)
    np.testing.assert_allclose(log.temperature["T_case_K"], d.T_case_K - 273.15)
    np.testing.assert_allclose(log.temperature["T_coil_F"], (d.T_coil_F - 32) * 5 / 9)
    np.testing.assert_allclose(log.field_uT["Hx"], 50.0)  # 0.5 G = 50 uT
    np.testing.assert_allclose(log.supply, d.vsupply / 1000)
    np.testing.assert_allclose(log.table_rate, 36000.0)  # 10 deg/s in deg/h
    assert "vib" in log.extra
    assert log.units["rate_dph"] == "deg/h"


def test_autodetect_obvious_columns(tmp_path, rng):
    d = pd.DataFrame({"time": np.arange(20) * 0.1, "counts": rng.integers(0, 9, 20),
                      "temp1": 20 + rng.normal(size=20), "temp2": 21 + rng.normal(size=20)})
    p = write_csv(tmp_path / "x.csv", d)
    log = read_log(p, overrides=ov(scale_factor=0.5))
    assert log.column_map["time"] == "time"
    assert log.gyro.output_kind == "counts"
    assert list(log.temperature) == ["temp1", "temp2"]
    assert any("auto-detected" in n for n in log.notes)


def test_rate_unit_required(tmp_path):
    p = write_csv(tmp_path / "x.csv", pd.DataFrame({"t": [0, 1, 2.0], "rate": [1, 2, 3.0]}))
    with pytest.raises(InputError, match="--rate-unit"):
        read_log(p)


# ----------------------------------------------------------------------------- profile precedence
def test_profile_and_override_precedence(tmp_path, rng):
    d = pd.DataFrame({"ts": np.arange(10.0), "a": rng.normal(size=10), "b": rng.normal(size=10)})
    p = write_csv(tmp_path / "x.csv", d)
    prof_path = tmp_path / "bench.toml"
    prof_path.write_text(
        '[columns]\ntime = "ts"\nrate = "a"\n[gyro]\nrate_unit = "deg/h"\n'
        '[site]\nlatitude_deg = 50.0\nia = "north"\n'
    )
    prof = load_profile(prof_path)
    log = read_log(p, profile=prof)
    np.testing.assert_allclose(log.rate, d.a)
    assert log.site.earth_rate_dph() == pytest.approx(OMEGA_E_DPH * math.cos(50 * DEG))
    # the command line wins key by key
    log2 = read_log(p, profile=prof, overrides=ov(rate="b", rate_unit="deg/s", ia="up"))
    np.testing.assert_allclose(log2.rate, d.b * 3600)
    assert log2.site.latitude_deg == 50.0
    assert log2.site.earth_rate_dph() == pytest.approx(OMEGA_E_DPH * math.sin(50 * DEG))
    # naming another output kind on the command line replaces the profile's
    merged = merge(prof, ov(counts="b", scale_factor=1.0))
    assert merged.output_kind() == "counts"


def test_profile_unknown_key(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text('[columns]\ntime = "t"\nrtae = "x"\n')
    with pytest.raises(InputError, match="unknown key 'rtae'"):
        load_profile(bad)
    bad.write_text('[colums]\ntime = "t"\n')
    with pytest.raises(InputError, match="unknown section"):
        load_profile(bad)
    bad.write_text('[gyro]\nscale_factor = "big"\n')
    with pytest.raises(InputError, match="must be"):
        load_profile(bad)
    bad.write_text('[gyro\nscale_factor = 1\n')
    with pytest.raises(InputError, match="invalid TOML"):
        load_profile(bad)


def test_profile_two_outputs_rejected():
    with pytest.raises(InputError, match="more than one gyro output"):
        profile_from_dict({"columns": {"rate": "a", "counts": "b"}})


# ----------------------------------------------------------------------------- timing
def test_gaps_reported_and_segmented(tmp_path, rng):
    t = np.concatenate([np.arange(100) * 0.1, 20 + np.arange(50) * 0.1])
    p = write_csv(tmp_path / "g.csv", pd.DataFrame({"t": t, "rate": rng.normal(size=150)}))
    log = read_log(p, overrides=ov(rate_unit="deg/h"))
    assert len(log.timing.gaps) == 1
    g = log.timing.gaps[0]
    assert g.index == 100 and g.duration_s == pytest.approx(20 - 9.9)
    assert log.segments == [(0, 100), (100, 150)]
    assert any("gap" in n for n in log.notes)


def test_sample_rate_without_time(tmp_path, rng):
    p = write_csv(tmp_path / "s.csv", pd.DataFrame({"rate": rng.normal(size=40)}))
    log = read_log(p, overrides=ov(rate_unit="deg/s", sample_rate_hz=200.0))
    assert log.tau0 == pytest.approx(0.005)
    assert log.time is None and log.t[-1] == pytest.approx(39 * 0.005)
    with pytest.raises(InputError, match="no time column and no sample rate"):
        read_log(p, overrides=ov(rate_unit="deg/s"))


def test_iso_timestamps(tmp_path, rng):
    ts = pd.date_range("2026-03-01T10:00:00", periods=30, freq="500ms")
    p = write_csv(tmp_path / "iso.csv", pd.DataFrame({"timestamp": ts.strftime("%Y-%m-%dT%H:%M:%S.%f"),
                                                       "rate": rng.normal(size=30)}))
    log = read_log(p, overrides=ov(rate_unit="deg/h"))
    assert log.tau0 == pytest.approx(0.5)
    assert log.timing.start.startswith("2026-03-01T10:00:00")


def test_stray_text_in_a_seconds_time_column_is_named(tmp_path):
    """A column of seconds with one text cell is read as text; the error names that cell
    (row 2), not the first row, whose '1' is a fine number."""
    p = tmp_path / "garb.csv"
    p.write_text("time,rate\n1,2\nabc,def\n3,4\n")
    with pytest.raises(InputError, match=r"cannot read time 'abc' in column 'time', row 2"):
        read_log(p, overrides=ov(rate_unit="deg/h"))
    q = tmp_path / "iso.csv"
    q.write_text("time,rate\n2024-01-01T00:00:00,1\nxx,2\n2024-01-01T00:00:02,3\n")
    with pytest.raises(InputError, match=r"cannot read time 'xx' in column 'time', row 2"):
        read_log(q, overrides=ov(rate_unit="deg/h"))


def test_duplicate_identical_rows_dropped(tmp_path):
    d = pd.DataFrame({"t": [0, 1, 1, 2, 3.0], "rate": [1, 2, 2, 3, 4.0]})
    log = read_log(write_csv(tmp_path / "d.csv", d), overrides=ov(rate_unit="deg/h"))
    assert log.n == 4 and log.timing.duplicates_dropped == 1


def test_duplicate_conflicting_rows_error(tmp_path):
    d = pd.DataFrame({"t": [0, 1, 1, 2, 3.0], "rate": [1, 2, 5, 3, 4.0]})
    with pytest.raises(InputError, match="duplicated timestamp"):
        read_log(write_csv(tmp_path / "d.csv", d), overrides=ov(rate_unit="deg/h"))


def test_jitter_flagged(tmp_path, rng):
    t = np.arange(1000) * 0.01 + rng.uniform(-0.002, 0.002, 1000)
    p = write_csv(tmp_path / "j.csv", pd.DataFrame({"t": t, "rate": rng.normal(size=1000)}))
    log = read_log(p, overrides=ov(rate_unit="deg/h"))
    assert log.timing.irregular and log.timing.jitter_rel > 0.05


def test_nan_policies(tmp_path, rng):
    r = rng.normal(size=50)
    r[10:13] = np.nan
    temp = 20 + rng.normal(size=50)
    temp[30] = np.nan
    d = pd.DataFrame({"t": np.arange(50.0), "rate": r, "temp": temp})
    p = write_csv(tmp_path / "n.csv", d)
    with pytest.raises(InputError, match=r"3 missing/NaN/±inf value\(s\), first at row 11 \(line 12\) to row 13 \(line 14\)"):
        read_log(p, overrides=ov(rate_unit="deg/h"))
    log = read_log(p, overrides=ov(rate_unit="deg/h"), nan_policy="gap")
    assert log.n == 46 and len(log.timing.gaps) == 2
    log = read_log(p, overrides=ov(rate_unit="deg/h"), nan_policy="interpolate")
    assert log.n == 47  # gyro NaNs still become gaps; the temperature is filled
    assert np.isfinite(log.temperature["temp"]).all()


# ----------------------------------------------------------------------------- formats
def test_delimiters_and_comments(tmp_path, rng):
    d = pd.DataFrame({"t": np.arange(30) * 0.1, "rate": rng.normal(size=30)})
    for sep, name in ((",", "c.csv"), ("\t", "c.tsv"), (";", "c.txt")):
        p = write_csv(tmp_path / name, d, comment="bench 3\noperator: X", sep=sep)
        log = read_log(p, overrides=ov(rate_unit="deg/h"))
        np.testing.assert_allclose(log.rate, d.rate)
    ws = tmp_path / "w.dat"
    ws.write_text("# whitespace table\n t   rate\n" + "".join(f"{a:.3f}   {b:.9f}\n" for a, b in zip(d.t, d.rate)))
    log = read_log(ws, overrides=ov(rate_unit="deg/h"))
    np.testing.assert_allclose(log.rate, d.rate, atol=1e-9)


def test_mid_file_comment_skipped(tmp_path):
    p = tmp_path / "m.csv"
    p.write_text("t,rate\n0,1\n1,2\n# operator touched the table\n2,3\n3,4\n")
    log = read_log(p, overrides=ov(rate_unit="deg/h"))
    np.testing.assert_allclose(log.rate, [1, 2, 3, 4])


def test_parquet_round_trip_with_metadata(tmp_path, rng):
    n = 500
    d = pd.DataFrame({"t_s": np.arange(n) * 0.1, "pulses": rng.integers(0, 30, n),
                      "T_case_C": 25 + rng.normal(size=n), "vsupply": 15 + rng.normal(size=n) * 0.01})
    d = d.drop(index=range(200, 220)).reset_index(drop=True)  # a gap
    p = write_csv(tmp_path / "run.csv", d)
    prof = profile_from_dict({"columns": {"counts": "pulses", "supply": "vsupply"},
                              "gyro": {"scale_factor": 0.2, "model": "FOG-7", "serial": "42"},
                              "site": {"latitude_deg": 55.75, "ia": "east"}})
    log = read_log(p, profile=prof)
    out = write_log(log, tmp_path / "run.parquet")
    meta = json.loads(pq.read_schema(out).metadata[b"gyrotest"])
    assert meta["tau0_s"] == pytest.approx(0.1) and meta["gyro"]["scale_factor"] == 0.2
    assert meta["units"]["rate_dph"] == "deg/h"
    back = read_log(out)
    np.testing.assert_array_equal(back.rate, log.rate)
    np.testing.assert_array_equal(back.t, log.t)
    np.testing.assert_array_equal(back.temperature["T_case_C"], log.temperature["T_case_C"])
    np.testing.assert_array_equal(back.supply, log.supply)
    assert back.gyro.output_kind == "counts" and back.gyro.angle_quantum_arcsec == 0.2
    assert back.gyro.model == "FOG-7"
    assert back.site == log.site
    assert [g.index for g in back.timing.gaps] == [200]
    assert back.segments == log.segments
    # feather too
    f = write_log(log, tmp_path / "run.feather")
    back_f = read_log(f)
    np.testing.assert_array_equal(back_f.rate, log.rate)


def test_plain_parquet_without_metadata(tmp_path, rng):
    t = pa.table({"t": np.arange(100) * 0.01, "gyro_z": rng.normal(size=100)})
    p = tmp_path / "plain.parquet"
    pq.write_table(t, p)
    log = read_log(p, overrides=ov(rate="gyro_z", rate_unit="rad/s"))
    np.testing.assert_allclose(log.rate, t.column("gyro_z").to_numpy() * 3600 / DEG)


def test_stdin(rng):
    d = pd.DataFrame({"t": np.arange(100) * 0.1, "rate": rng.normal(size=100)})
    r = run_cli(["info", "-", "--rate-unit", "deg/s", "--json"], stdin=d.to_csv(index=False))
    assert r.code == 0, r.err
    out = json.loads(r.out)
    assert out["timing"]["samples"] == 100
    assert out["channels"]["rate:rate"]["unit"] == "deg/h"
    assert out["channels"]["rate:rate"]["mean"] == pytest.approx(d.rate.mean() * 3600)


def test_ingest_cli_round_trip(tmp_path, rng):
    d = pd.DataFrame({"t": np.arange(100) * 0.1, "rate": rng.normal(size=100)})
    p = write_csv(tmp_path / "in.csv", d)
    out = tmp_path / "out.parquet"
    r = run_cli(["ingest", p, "-o", out, "--rate-unit", "deg/h", "--latitude", "45", "--ia", "up"])
    assert r.code == 0, r.err
    r2 = run_cli(["info", out, "--json"])
    info = json.loads(r2.out)
    assert info["site"]["earth_rate_ia_dph"] == pytest.approx(OMEGA_E_DPH * math.sin(45 * DEG))


def test_profile_dataclass_roundtrip():
    p = Profile(columns={"rate": ["a"]}, gyro={"rate_unit": "deg/h"})
    assert p.output_kind() == "rate"


def test_atomic_write_permissions(tmp_path):
    import os

    from gyrotest.core.output import write_text

    old = os.umask(0o022)
    try:
        write_text(tmp_path / "a.txt", "x")
    finally:
        os.umask(old)
    assert (os.stat(tmp_path / "a.txt").st_mode & 0o777) == 0o644


def test_streaming_reader_matches_whole_file_reader(tmp_path, rng, monkeypatch):
    """Large text files are read block by block into float64 arrays: same values, NaN for
    empty cells, mid-file comments skipped; text in a column falls back to the whole-file reader
    (and its row-naming errors)."""
    import gyrotest.io.tables as tables

    n = 20_000
    d = pd.DataFrame({"t": np.arange(n) * 0.01, "rate": rng.normal(size=n),
                      "temp": 20 + rng.normal(size=n), "vsupply": 15 + rng.normal(size=n)})
    text = d.to_csv(index=False, lineterminator="\n", float_format="%.17g")
    lines = text.splitlines(keepends=True)
    lines.insert(5000, "# operator note in the middle\n")
    p = tmp_path / "big.csv"
    p.write_text("".join(lines))
    ov_ = ov(rate_unit="deg/h", supply="vsupply")
    whole = read_log(p, overrides=ov_)
    monkeypatch.setattr(tables, "STREAM_MIN_BYTES", 0)
    streamed = read_log(p, overrides=ov_)
    np.testing.assert_array_equal(streamed.rate, whole.rate)
    np.testing.assert_array_equal(streamed.temperature["temp"], whole.temperature["temp"])
    np.testing.assert_array_equal(streamed.supply, whole.supply)
    np.testing.assert_array_equal(streamed.t, whole.t)
    # text in a used column: the whole-file reader reports the row
    lines[7000] = "70.0,abc,20,15\n"
    p.write_text("".join(lines))
    with pytest.raises(InputError, match=r"non-numeric value 'abc' in column 'rate'"):
        read_log(p, overrides=ov_)
    # padded header names are matched after stripping
    q = tmp_path / "pad.csv"
    q.write_text("t , rate \n0,1\n1,2\n2,3\n")
    log = read_log(q, overrides=ov(rate="rate", rate_unit="deg/h"))
    np.testing.assert_array_equal(log.rate, [1, 2, 3])
