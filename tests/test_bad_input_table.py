"""Inputs from the bad-input corpus (issue 15's table): each is either read correctly (mixed
time zones, ms/µs/ns epochs) or ends in exit 2 with one line naming the file, the row, column
or key, and the fix. Also unreadable files, FIFOs, devices, write failures and symlinked
outputs."""

from __future__ import annotations

import errno
import json
import os

import numpy as np
import pyarrow.parquet as pq
import pytest

from gyrotest.io.ingest import read_log

from cliutil import run_cli

N = 400


def _rate(n=N, seed=1) -> list[float]:
    return [float(v) for v in np.random.default_rng(seed).normal(0, 0.01, n)]


def _write(path, header, rows):
    path.write_text(header + "\n" + "\n".join(rows) + "\n")
    return path


def _epoch_csv(tmp_path, name, first, step, col="timestamp"):
    r = _rate()
    return _write(tmp_path / name, f"{col},gyro_x",
                  [f"{first + i * step},{r[i]!r}" for i in range(N)])


# ----------------------------------------------------------------------------- time axis
@pytest.mark.parametrize("unit,first,step", [
    ("ns", 1716200000000000000, 10_000_000),
    ("us", 1716200000000000, 10_000),
    ("ms", 1716200000000, 10),
    ("s", 1716200000.0, 0.01),
])
def test_epoch_timestamps_are_detected_from_magnitude_and_spacing(tmp_path, unit, first, step):
    p = _epoch_csv(tmp_path, f"{unit}.csv", first, step)
    r = run_cli(["info", p, "--rate-unit", "deg/s", "--json"])
    assert r.code == 0, r.err
    doc = json.loads(r.out)
    # float seconds near 1.7e9 carry ~1e-7 s rounding; integer epochs are exact
    assert doc["timing"]["sample_rate_hz"] == pytest.approx(100.0, rel=1e-5 if unit == "s" else 1e-12)
    assert doc["timing"]["samples"] == N
    if unit != "s":
        assert f"Unix epoch in {unit}" in " ".join(doc["notes"])
    log = read_log(p, overrides={"gyro": {"rate_unit": "deg/s"}})
    if unit != "s":  # int64 differencing keeps the ns resolution: the axis is exactly uniform
        assert np.ptp(np.diff(log.t)) < 1e-12
    assert log.timing.start.startswith("2024-05-20")


def test_time_unit_option_and_profile_key(tmp_path):
    # nanoseconds since boot: no epoch magnitude, read as seconds the rate is implausible
    p = _epoch_csv(tmp_path, "boot.csv", 0, 10_000_000, col="time")
    r = run_cli(["allan", p, "--rate-unit", "deg/s", "--json"])
    r.assert_clean_error("boot.csv", "implausible sample rate", "time column 'time'",
                         "--time-unit")
    r = run_cli(["info", p, "--rate-unit", "deg/s", "--time-unit", "ns", "--json"])
    assert r.code == 0, r.err
    assert json.loads(r.out)["timing"]["sample_rate_hz"] == pytest.approx(100.0)
    prof = tmp_path / "bench.toml"
    prof.write_text('[gyro]\nrate_unit = "deg/s"\ntime_unit = "ns"\n')
    r = run_cli(["info", p, "--profile", prof, "--json"])
    assert r.code == 0, r.err
    # a given sample rate picks the unit whose spacing matches it
    r = run_cli(["info", p, "--rate-unit", "deg/s", "--sample-rate", "100", "--json"])
    assert r.code == 0, r.err
    assert json.loads(r.out)["timing"]["sample_rate_hz"] == pytest.approx(100.0)


def test_sample_rate_with_a_time_column_is_checked(tmp_path):
    p = _epoch_csv(tmp_path, "t.csv", 0.0, 0.01, col="t")
    r = run_cli(["info", p, "--rate-unit", "deg/s", "--sample-rate", "100", "--json"])
    assert r.code == 0, r.err
    assert "agrees with the time column" in r.out
    r = run_cli(["info", p, "--rate-unit", "deg/s", "--sample-rate", "10"])
    r.assert_clean_error("t.csv", "sample rate 10 hz", "conflicts", "time column 't'", "100 Hz")


@pytest.mark.parametrize("fs", ["1e300", "1e-300", "0", "-5", "nan"])
def test_implausible_sample_rate_option(tmp_path, fs):
    p = _write(tmp_path / "r.csv", "rate", [repr(v) for v in _rate()])
    run_cli(["allan", p, "--rate-unit", "deg/h", "--sample-rate", fs]).assert_clean_error(
        "r.csv", "sample rate")


@pytest.mark.parametrize("cmd", ["info", "ingest", "allan", "bias"])
def test_huge_time_values(tmp_path, cmd):
    r = _rate()
    p = _write(tmp_path / "huge.csv", "time,rate", [f"{(i + 1) * 1e300!r},{r[i]!r}" for i in range(N)])
    extra = ["-o", tmp_path / "o.parquet"] if cmd == "ingest" else []
    run_cli([cmd, p, "--rate-unit", "deg/h", *extra]).assert_clean_error(
        "huge.csv", "implausible sample rate", "--time-unit")
    assert not (tmp_path / "o.parquet").exists()


def test_time_values_too_far_apart(tmp_path):
    p = _write(tmp_path / "far.csv", "time,rate", ["-1e308,1", "1e308,1", "1.5e308,1"])
    run_cli(["info", p, "--rate-unit", "deg/h"]).assert_clean_error("far.csv", "column 'time'")


@pytest.mark.parametrize("cmd", ["info", "ingest", "allan", "bias"])
def test_mixed_time_zones_are_read_as_utc(tmp_path, cmd):
    r = _rate()
    rows = []
    for i in range(N):
        stamp = f"2024-05-12T10:{i // 600:02d}:{(i % 600) / 10:04.1f}"
        rows.append(f"{stamp}{'+00:00' if i % 2 else ''},{r[i]!r}")
    p = _write(tmp_path / "tz.csv", "time,rate", rows)
    extra = ["-o", tmp_path / "o.parquet"] if cmd == "ingest" else []
    res = run_cli([cmd, p, "--rate-unit", "deg/h", "-v", *extra])
    assert res.code == 0, res.err
    assert "mixes time zones" in res.err
    log = read_log(p, overrides={"gyro": {"rate_unit": "deg/h"}})
    assert log.tau0 == pytest.approx(0.1) and not log.timing.gaps
    assert log.timing.start.startswith("2024-05-12T10:00:00")


# ----------------------------------------------------------------------------- ±inf
@pytest.mark.parametrize("cmd", ["info", "ingest", "allan", "bias"])
@pytest.mark.parametrize("col,value", [("rate", "inf"), ("rate", "-inf"), ("temp", "-inf"),
                                       ("temp", "inf")])
def test_inf_is_a_missing_value(tmp_path, cmd, col, value):
    r = _rate()
    rows = [f"{i * 0.1:.1f},{value if (col == 'rate' and i == 5) else repr(r[i])},"
            f"{value if (col == 'temp' and i == 5) else 20}" for i in range(N)]
    p = _write(tmp_path / "inf.csv", "time,rate,temp", rows)
    extra = ["-o", tmp_path / "o.parquet"] if cmd == "ingest" else []
    run_cli([cmd, p, "--rate-unit", "deg/h", *extra]).assert_clean_error(
        "inf.csv", f"'{col}'", "±inf", "row 6 (line 7)", "--nan gap")
    assert not (tmp_path / "o.parquet").exists()
    # the --nan policy applies to ±inf exactly as to NaN
    res = run_cli([cmd, p, "--rate-unit", "deg/h", "--nan", "gap", "-v", *extra])
    assert res.code == 0, res.err
    assert "dropped and treated as gaps" in res.err


# ----------------------------------------------------------------------------- own metadata
@pytest.fixture(scope="module")
def converted(tmp_path_factory):
    d = tmp_path_factory.mktemp("conv")
    r = _rate(2000)
    src = _write(d / "log.csv", "t,rate,temp", [f"{i * 0.1:.1f},{r[i]!r},{20 + i * 1e-3:.3f}"
                                                 for i in range(2000)])
    out = d / "log.parquet"
    res = run_cli(["ingest", src, "--rate-unit", "deg/h", "--latitude", "48", "-o", out])
    assert res.code == 0, res.err
    return out


def _damage(src, dst, fn):
    t = pq.read_table(src)
    meta = json.loads(t.schema.metadata[b"gyrotest"])
    new = fn(meta)
    raw = new if isinstance(new, bytes) else json.dumps(new).encode()
    pq.write_table(t.replace_schema_metadata({b"gyrotest": raw}), dst)
    return dst


DAMAGE = {
    "all strings": (lambda m: {k: "x" for k in m}, "'columns'"),
    "all nulls": (lambda m: {k: None for k in m}, "'columns'"),
    "negative numbers": (lambda m: {k: (-1 if isinstance(v, (int, float)) else v)
                                    for k, v in m.items()}, "'tau0_s'"),
    "wrong types": (lambda m: {"version": 1, "columns": 5, "timing": "x"}, "'columns'"),
    "tau0 text": (lambda m: {**m, "timing": {**m["timing"], "tau0_s": "x"}}, "'timing.tau0_s'"),
    "gap null": (lambda m: {**m, "timing": {**m["timing"], "gaps": [None]}}, "'timing.gaps[0]'"),
    "latitude 200": (lambda m: {**m, "site": {**m["site"], "latitude_deg": 200}},
                     "'site.latitude_deg'"),
    "unknown kind": (lambda m: {**m, "gyro": {**m["gyro"], "output_kind": "banana"}},
                     "'gyro.output_kind'"),
    "missing column": (lambda m: {**m, "columns": {**m["columns"], "rates": {"rate": "nope"}}},
                       "'columns.rates.rate'"),
    "sample count": (lambda m: {**m, "timing": {**m["timing"], "samples": 7}}, "'timing.samples'"),
    "a list": (lambda m: [1, 2], "not a JSON object"),
    "not JSON": (lambda m: b"{not json", "damaged"),
}


@pytest.mark.parametrize("case", sorted(DAMAGE))
@pytest.mark.parametrize("cmd", ["info", "allan", "bias"])
def test_damaged_metadata_is_reported_and_columns_still_read(tmp_path, converted, case, cmd):
    fn, key = DAMAGE[case]
    p = _damage(converted, tmp_path / "dmg.parquet", fn)
    r = run_cli([cmd, p, "-v"])
    assert r.code == 0, r.err
    assert "Traceback" not in r.err
    assert "gyrotest metadata is damaged" in r.err and key in r.err, r.err


def test_damaged_metadata_and_unreadable_columns(tmp_path, converted):
    t = pq.read_table(converted).rename_columns(["a", "b", "c"])
    meta = json.loads(pq.read_table(converted).schema.metadata[b"gyrotest"])
    p = tmp_path / "x.parquet"
    pq.write_table(t.replace_schema_metadata({b"gyrotest": json.dumps(meta).encode()}), p)
    run_cli(["info", p]).assert_clean_error("x.parquet", "metadata is damaged",
                                            "columns.rates", "gyrotest ingest")


# ----------------------------------------------------------------------------- files
def test_unreadable_file(tmp_path, monkeypatch, converted):
    import gyrotest.io.tables as tables

    p = _write(tmp_path / "secret.csv", "t,rate", ["0,1", "1,2"])

    def denied(*a, **k):
        raise PermissionError(errno.EACCES, "Permission denied", str(a[0]))

    monkeypatch.setattr(tables, "open", denied, raising=False)
    run_cli(["info", p, "--rate-unit", "deg/h"]).assert_clean_error("secret.csv",
                                                                    "permission denied")
    run_cli(["info", converted]).assert_clean_error("log.parquet", "permission denied")


def test_fifo_device_directory(tmp_path, monkeypatch):
    fifo = tmp_path / "pipe.csv"
    os.mkfifo(fifo)
    monkeypatch.setenv("GYROTEST_FIFO_WAIT", "0.3")  # no writer: refused after the wait
    run_cli(["info", fifo]).assert_clean_error("pipe.csv", "fifo", "no data", "'-'")
    if os.path.exists("/dev/zero"):
        run_cli(["info", "/dev/zero"]).assert_clean_error("/dev/zero", "device")
    run_cli(["info", tmp_path]).assert_clean_error("directory")
    run_cli(["info", "-"], stdin=b"\x00" * 200_000).assert_clean_error("<stdin>", "binary")


def test_write_failure_leaves_nothing(tmp_path, monkeypatch):
    import pyarrow.parquet as pqm

    src = _write(tmp_path / "log.csv", "t,rate", [f"{i},{i % 3}" for i in range(50)])
    out = tmp_path / "out.parquet"

    def full(table, where, **kw):
        with open(where, "wb") as fh:
            fh.write(b"PAR1 half")
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(pqm, "write_table", full)
    run_cli(["ingest", src, "--rate-unit", "deg/h", "-o", out]).assert_clean_error(
        "out.parquet", "no space left")
    assert sorted(x.name for x in tmp_path.iterdir()) == ["log.csv"]


def test_output_is_a_directory_or_in_a_missing_one(tmp_path):
    src = _write(tmp_path / "log.csv", "t,rate", [f"{i},{i % 3}" for i in range(50)])
    (tmp_path / "d.parquet").mkdir()
    run_cli(["ingest", src, "--rate-unit", "deg/h", "-o", tmp_path / "d.parquet"]
            ).assert_clean_error("directory")
    run_cli(["ingest", src, "--rate-unit", "deg/h", "-o", tmp_path / "no" / "x.parquet"]
            ).assert_clean_error("does not exist")


def test_symlinked_output_is_replaced_not_followed(tmp_path):
    src = _write(tmp_path / "log.csv", "t,rate", [f"{i},{i % 3}" for i in range(50)])
    victim = tmp_path / "victim.txt"
    victim.write_text("keep me")
    link = tmp_path / "out.parquet"
    link.symlink_to(victim)
    r = run_cli(["ingest", src, "--rate-unit", "deg/h", "-o", link])
    assert r.code == 0, r.err
    assert victim.read_text() == "keep me"
    assert not link.is_symlink() and link.read_bytes()[:4] == b"PAR1"


# ----------------------------------------------------------------------------- -q / --debug
def test_quiet_and_debug_anywhere(tmp_path):
    p = _write(tmp_path / "log.csv", "t,rate", [f"{i * 0.1:.1f},{v!r}" for i, v in enumerate(_rate())])
    loud = run_cli(["info", p, "--rate-unit", "deg/h", "-v"])
    quiet = run_cli(["info", p, "--rate-unit", "deg/h", "-q"])
    piped = run_cli(["info", p, "--rate-unit", "deg/h"])  # stderr not a terminal, no -v
    assert loud.code == quiet.code == piped.code == 0
    assert "auto-detected" in loud.err and quiet.err == "" and piped.err == ""
    assert run_cli(["-v", "info", p, "-q", "--rate-unit", "deg/h"]).err == "", "-q wins"
    assert run_cli(["info", p, "-q", "--rate-unit", "deg/h", "--quiet"]).err == ""
    bad = run_cli(["info", tmp_path / "nope.csv", "--debug"])
    assert bad.code == 2 and "Traceback" in bad.err


# ----------------------------------------------------------------------------- resources
def test_header_of_a_million_columns(tmp_path):
    p = tmp_path / "wide.csv"
    n = 10**6
    p.write_text(",".join(f"c{i}" for i in range(n)) + "\n" + ",".join("1" * n) + "\n")
    r = run_cli(["info", p, "--rate-unit", "deg/h"])
    r.assert_clean_error("wide.csv", "no complete line in the first 64 KiB")


def test_one_huge_line(tmp_path):
    p = tmp_path / "oneline.csv"
    with open(p, "wb") as fh:
        fh.write(b"time,rate\n" + b"1" * (12 << 20))
    run_cli(["info", p, "--rate-unit", "deg/h"]).assert_clean_error("oneline.csv",
                                                                    "line longer than")
    q = tmp_path / "noeol.csv"
    q.write_bytes(b"7" * (1 << 20))
    run_cli(["info", q]).assert_clean_error("noeol.csv", "no complete line")
