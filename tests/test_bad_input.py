"""Bad input: one line naming the problem, exit code 2, no traceback, no output file.

Also a property-based test throwing random CSV text at the reader: a clean result or a clean
InputError, never any other exception.
"""

from __future__ import annotations

import string

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from gyrotest.core.errors import InputError
from gyrotest.io.ingest import read_log

from cliutil import run_cli


def _ingest(tmp_path, src, *extra):
    out = tmp_path / "out.parquet"
    r = run_cli(["ingest", src, "-o", out, *extra])
    assert not out.exists(), "an output file was left behind"
    assert not list(tmp_path.glob(".out.parquet.*")), "a temporary file was left behind"
    return r


GOOD = "t,rate\n0,1.0\n0.1,1.1\n0.2,0.9\n0.3,1.0\n"


@pytest.mark.parametrize(
    "name,content,extra,fragments",
    [
        ("empty.csv", "", [], ["empty.csv", "empty"]),
        ("header.csv", "t,rate\n", ["--rate-unit", "deg/h"], ["header only"]),
        ("comments.csv", "# nothing here\n# really\n", [], ["no header"]),
        ("missing.csv", GOOD, ["--rate-col", "omega", "--rate-unit", "deg/h"],
         ["column 'omega'", "not found"]),
        ("misspelt.csv", GOOD, ["--rate-col", "rtae", "--rate-unit", "deg/h"],
         ["did you mean 'rate'"]),
        ("text.csv", "t,rate\n0,1.0\n0.1,abc\n0.2,0.9\n", ["--rate-unit", "deg/h"],
         ["non-numeric", "'abc'", "column 'rate'", "row 2 (line 3)"]),
        ("nanrun.csv", "t,rate\n0,1\n1,\n2,\n3,nan\n4,1\n", ["--rate-unit", "deg/h"],
         ["missing/nan", "row 2 (line 3) to row 4 (line 5)", "--nan gap"]),
        ("back.csv", "t,rate\n0,1\n1,1\n0.5,1\n2,1\n", ["--rate-unit", "deg/h"],
         ["backwards", "row 3 (line 4)"]),
        ("units.csv", GOOD, ["--rate-unit", "furlongs/fortnight"], ["unknown rate unit"]),
        ("ragged.csv", "t,rate\n0,1\n1,2,3\n2,1\n", ["--rate-unit", "deg/h"], ["fields"]),
        ("garbage.bin", None, [], ["binary"]),
        ("empty.parquet", "", [], ["empty"]),
        ("fake.parquet", "PAR1 this is not parquet at all PAR1", [], ["not a readable parquet"]),
        ("noout.csv", "t,temp_a\n0,1\n1,2\n", [], ["no gyro output column"]),
        ("nosf.csv", "t,counts\n0,1\n1,2\n", [], ["scale factor"]),
    ],
)
def test_bad_input_one_line_exit_2(tmp_path, name, content, extra, fragments):
    p = tmp_path / name
    if content is None:
        p.write_bytes(bytes(np.random.default_rng(0).integers(0, 256, 4096, dtype=np.uint8)))
    else:
        p.write_text(content)
    r = _ingest(tmp_path, p, *extra)
    r.assert_clean_error(*fragments)


def test_missing_file_and_directory(tmp_path):
    _ingest(tmp_path, tmp_path / "nope.csv").assert_clean_error("file not found")
    _ingest(tmp_path, tmp_path).assert_clean_error("directory")


def test_unknown_profile_key(tmp_path):
    p = tmp_path / "log.csv"
    p.write_text(GOOD)
    prof = tmp_path / "bench.toml"
    prof.write_text('[gyro]\nrate_unit = "deg/h"\nscale_factr = 1\n')
    _ingest(tmp_path, p, "--profile", prof).assert_clean_error("bench.toml", "scale_factr")


def test_bad_latitude_and_ia(tmp_path):
    p = tmp_path / "log.csv"
    p.write_text(GOOD)
    _ingest(tmp_path, p, "--rate-unit", "deg/h", "--latitude", "123").assert_clean_error("latitude")
    _ingest(tmp_path, p, "--rate-unit", "deg/h", "--latitude", "45", "--ia", "sideways")\
        .assert_clean_error("IA direction")


def test_usage_errors_exit_2(tmp_path):
    r = run_cli(["ingest"])
    assert r.code == 2 and "Traceback" not in r.err
    r = run_cli(["info", "x.csv", "--no-such-option"])
    assert r.code == 2 and "no such option" in r.err.lower()
    r = run_cli(["no-such-command"])
    assert r.code == 2


def test_output_directory_missing(tmp_path):
    p = tmp_path / "log.csv"
    p.write_text(GOOD)
    r = run_cli(["ingest", p, "-o", tmp_path / "nodir" / "x.parquet", "--rate-unit", "deg/h"])
    r.assert_clean_error("does not exist")


def test_debug_shows_traceback(tmp_path):
    r = run_cli(["--debug", "info", tmp_path / "nope.csv"])
    assert r.code == 2 and "Traceback" in r.err


# ----------------------------------------------------------------------------- property-based
_cell = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(-10**12, 10**12).map(str),
    st.text(alphabet=string.printable, max_size=8),
    st.just(""),
)


@st.composite
def csv_text(draw):
    ncol = draw(st.integers(1, 4))
    header = draw(st.lists(st.sampled_from(["t", "time", "rate", "counts", "temp", "x", "",
                                            "rate", "t s", "Hx"]), min_size=ncol, max_size=ncol))
    rows = draw(st.lists(st.lists(_cell, min_size=1, max_size=ncol + 1), max_size=12))
    sep = draw(st.sampled_from([",", "\t", ";", " "]))
    lines = [sep.join(header)] + [sep.join(r) for r in rows]
    if draw(st.booleans()):
        lines.insert(0, "# comment")
    return "\n".join(lines) + draw(st.sampled_from(["", "\n"]))


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(text=csv_text(), unit=st.sampled_from(["deg/h", "deg/s", None]))
def test_random_csv_never_tracebacks(tmp_path, text, unit):
    p = tmp_path / "h.csv"
    p.write_text(text)
    overrides = {"gyro": {"rate_unit": unit, "scale_factor": 0.5, "sample_rate_hz": 10.0}}
    try:
        log = read_log(p, overrides=overrides)
    except InputError as e:
        assert str(e) and "\n" not in str(e)
        return
    assert log.n >= 1
    assert np.all(np.isfinite(log.t))


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.binary(max_size=300))
def test_random_bytes_never_traceback(tmp_path, data):
    p = tmp_path / "b.csv"
    p.write_bytes(data)
    try:
        read_log(p, overrides={"gyro": {"rate_unit": "deg/h"}})
    except InputError:
        pass
