"""CSVs other programs write: Excel's byte-order mark, decimal commas, units in the header
(recognised and used), common IMU column names, and `info` listing the columns and its guesses
when it cannot pick the gyro output."""

from __future__ import annotations

import json

import numpy as np
import pytest

from gyrotest.io.ingest import column_guesses, read_log

from cliutil import run_cli


def test_excel_bom_does_not_hide_the_time_column(tmp_path):
    p = tmp_path / "bom.csv"
    p.write_bytes(b"\xef\xbb\xbftime,rate\n0,1.5\n0.1,1.6\n0.2,1.4\n")
    log = read_log(p, overrides={"gyro": {"rate_unit": "deg/h"}})
    assert log.column_map["time"] == "time" and log.tau0 == pytest.approx(0.1)
    # a BOM in front of a comment line
    p.write_bytes(b"\xef\xbb\xbf# logger v2\ntime,rate\n0,1.5\n0.1,1.6\n0.2,1.4\n")
    assert read_log(p, overrides={"gyro": {"rate_unit": "deg/h"}}).n == 3


@pytest.mark.parametrize("sep,name", [(";", "euro.csv"), ("\t", "euro.tsv"), (" ", "euro.txt")])
def test_decimal_commas(tmp_path, sep, name):
    rng = np.random.default_rng(2)
    r = rng.normal(5, 0.1, 50)
    lines = [sep.join(["time", "rate", "temp"])]
    lines += [sep.join([f"{i / 10:.1f}".replace(".", ","), f"{v:.6f}".replace(".", ","),
                        "21,5"]) for i, v in enumerate(r)]
    p = tmp_path / name
    p.write_text("\n".join(lines) + "\n")
    log = read_log(p, overrides={"gyro": {"rate_unit": "deg/h"}})
    np.testing.assert_allclose(log.rate, np.round(r, 6))
    assert log.tau0 == pytest.approx(0.1)
    np.testing.assert_allclose(log.temperature["temp"], 21.5)


def test_decimal_commas_streaming_reader(tmp_path, monkeypatch):
    import gyrotest.io.tables as tables

    n = 5000
    lines = ["t;rate"] + [f"{i},{i % 10};{(i % 7) / 4:.2f}".replace(".", ",") for i in range(n)]
    p = tmp_path / "big.csv"
    p.write_text("\n".join(lines) + "\n")
    whole = read_log(p, overrides={"gyro": {"rate_unit": "deg/h"}})
    monkeypatch.setattr(tables, "STREAM_MIN_BYTES", 0)
    streamed = read_log(p, overrides={"gyro": {"rate_unit": "deg/h"}})
    np.testing.assert_array_equal(whole.rate, streamed.rate)
    np.testing.assert_allclose(whole.rate[:8], [(i % 7) / 4 for i in range(8)])


def test_units_in_the_header_are_recognised_and_used(tmp_path):
    p = tmp_path / "units.csv"
    p.write_text("time [s],gx [deg/s],gy [rad/s],gz [deg/h],temp (degF)\n"
                 "0,1,0.001,3,68\n0.1,1,0.001,3,68\n0.2,1,0.001,3,86\n")
    log = read_log(p)
    assert log.column_map["time"] == "time [s]"
    assert log.axes == ["gx [deg/s]", "gy [rad/s]", "gz [deg/h]"]
    np.testing.assert_allclose(log.rates["gx [deg/s]"], 3600.0)
    np.testing.assert_allclose(log.rates["gy [rad/s]"], 0.001 * 3600 * 180 / np.pi)
    np.testing.assert_allclose(log.rates["gz [deg/h]"], 3.0)
    np.testing.assert_allclose(log.temperature["temp (degF)"], [20, 20, 30])
    assert log.units["temp (degF)"] == "degF"
    # --rate-col names the column without its unit
    one = read_log(p, overrides={"columns": {"rate": ["gx"]}})
    assert one.axes == ["gx [deg/s]"]
    # an unknown unit in the header is a clean error naming the column
    p.write_text("time,rate [furlong/s]\n0,1\n1,2\n")
    r = run_cli(["info", p])
    r.assert_clean_error("units.csv", "rate [furlong/s]", "unknown rate unit")


def test_bracketed_text_survives_rich_markup(tmp_path):
    p = tmp_path / "units.csv"
    p.write_text("time [s],gx [deg/s],temp (degC)\n0,1,20\n0.1,1,20\n0.2,1,21\n")
    r = run_cli(["info", p, "-v"])
    assert r.code == 0, r.err
    assert "time column 'time [s]'" in r.out
    assert "gx [deg/s]" in r.out and "temp (degC)" in r.out
    assert "gx [deg/s]" in r.err  # the auto-detection note


@pytest.mark.parametrize("header,unit", [
    ("t,gx,gy,gz", None), ("t,wx,wy,wz", None), ("t,gyro_x_rps,gyro_y_rps,gyro_z_rps", "rad/s"),
    ("t,gyro_x_dps,gyro_y_dps,gyro_z_dps", "deg/s"), ("t,omega_x,omega_y,omega_z", None),
])
def test_imu_column_names_are_detected(tmp_path, header, unit):
    p = tmp_path / "imu.csv"
    p.write_text(header + "\n" + "\n".join(f"{i * 0.01:.2f},1,2,3" for i in range(20)) + "\n")
    ov = {} if unit else {"gyro": {"rate_unit": "deg/s"}}
    log = read_log(p, overrides=ov)
    assert log.axes == header.split(",")[1:]
    assert log.gyro.rate_unit == (unit or "deg/s")
    # magnetometer / temperature names next to them are not taken for gyro axes
    p.write_text(header + ",mag_x,mag_y,mag_z,temp\n"
                 + "\n".join(f"{i * 0.01:.2f},1,2,3,40,41,42,20" for i in range(20)) + "\n")
    log = read_log(p, overrides=ov)
    assert log.axes == header.split(",")[1:]
    assert list(log.field_uT) == ["mag_x", "mag_y", "mag_z"]


def test_info_lists_columns_and_guesses_without_a_gyro_column(tmp_path):
    p = tmp_path / "nogyro.csv"
    p.write_text("time,temp (degC),supply,mystery\n0,20,15,1\n1,20,15,2\n")
    r = run_cli(["info", p])
    r.assert_clean_error("nogyro.csv", "no gyro output column", "--rate-col")
    for frag in ("time", "temperature", "supply voltage", "mystery", "degC"):
        assert frag in r.out
    r = run_cli(["info", p, "--json"])
    assert r.code == 2
    doc = json.loads(r.out)
    assert {c["column"]: c["role"] for c in doc["columns"]} == {
        "time": "time", "temp (degC)": "temperature", "supply": "supply voltage", "mystery": None}
    # a rate column without a unit: listed too, then the error asks for --rate-unit
    q = tmp_path / "w.csv"
    q.write_text("t,wx\n0,1\n1,2\n")
    r = run_cli(["info", q])
    r.assert_clean_error("w.csv", "'wx'", "--rate-unit")
    assert "rate" in r.out


def test_column_guesses():
    g = {d["column"]: (d["role"], d["unit"]) for d in column_guesses(
        ["timestamp", "gx [deg/s]", "Hx_uT", "T_case_C", "vcc", "foo"])}
    assert g == {"timestamp": ("time", None), "gx [deg/s]": ("rate", "deg/s"),
                 "Hx_uT": ("magnetic field", "uT"), "T_case_C": ("temperature", "degC"),
                 "vcc": ("supply voltage", None), "foo": (None, None)}


def test_integer_column_beyond_float64_digits(tmp_path):
    """An int64 column with values past 2^53 (a counter, say) reads as float64 rounded like
    numpy would, not as an internal error (found by the Parquet fuzz test)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    p = tmp_path / "big.parquet"
    big = 2 ** 53 + 1
    pq.write_table(pa.table({"t": np.arange(200) * 0.1,
                             "rate": pa.array([big + i for i in range(200)], pa.int64())}), p)
    log = read_log(p, overrides={"gyro": {"rate_unit": "deg/h"}})
    x = next(iter(log.rates.values()))
    np.testing.assert_array_equal(x, np.array([big + i for i in range(200)], dtype=np.float64))
