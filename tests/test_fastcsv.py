"""The fast numeric CSV path (gyrotest.fastcsv): bit-exact values (identical to ``float()``),
the table the pyarrow path would give, and a clean hand-over to pyarrow for anything else."""

from __future__ import annotations

import math
import os
import struct
import subprocess
import sys
import textwrap
from decimal import Context, Decimal
from pathlib import Path

import numpy as np
import pyarrow as pa
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from gyrotest import fastcsv
from gyrotest.errors import InputError
from gyrotest.ingest import read_log, read_table

pytestmark = pytest.mark.skipif(not fastcsv._kernels(), reason="numba is not installed")

HSET = settings(deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


def bits(x: float) -> bytes:
    return struct.pack("<d", x)


def same(a: float, b: float) -> bool:
    """Bit-identical, any NaN matching any NaN of the same sign."""
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b) and math.copysign(1, a) == math.copysign(1, b)
    return bits(a) == bits(b)


def parse_column(tmp_path: Path, cells: list[str], **kw) -> np.ndarray:
    """The cells as one column through the fast parser (which must not hand over)."""
    p = tmp_path / "col.csv"
    p.write_bytes(("x\n" + "\n".join(cells) + "\n").encode())
    res = fastcsv.read_numeric(p, ",", 0, ["x"], **kw)
    assert res is not None, "fast path handed over"
    wanted, values, nulls, intlike = res
    assert values.shape == (1, len(cells))
    return values[0]


def long_integer(cell: str) -> bool:
    """More than 19 digits, no dot or exponent: left to pyarrow (int64 or double?)."""
    return cell.lstrip("+-").isdigit() and len(cell.lstrip("+-")) > 19


def assert_exact(cells: list[str], got: np.ndarray) -> None:
    bad = [(c, g, float(c)) for c, g in zip(cells, got.tolist()) if not same(g, float(c))]
    assert not bad, bad[:10]


# ----------------------------------------------------------------------------- exactness
EDGE = [
    "0", "-0", "0.0", "-0.0", "+0", "1", "-1", "+1", ".5", "-.5", "+.5", "5.", "-5.", "5.e3",
    "1e308", "1.7976931348623157e308", "1.7976931348623158e308", "1.7976931348623159e308",
    "2e308", "1e309", "-1e309", "1e-400", "-1e-400", "4.9e-324", "5e-324", "3e-324",
    "2.4703282292062328e-324", "2.4703282292062327e-324", "2.225073858507201e-308",
    "2.2250738585072011e-308", "2.2250738585072012e-308", "2.2250738585072014e-308",
    "9007199254740992", "9007199254740993", "9007199254740994", "9007199254740995",
    "18446744073709551615.5", "18446744073709551616.0", "9223372036854775807",
    "0.1", "0.2", "0.3", "1e22", "1e23", "1e-22", "1e-23", "123456789e-30",
    "7.2057594037927933e16", "1.00000000000000011102230246251565404236316680908203125",
    "1.00000000000000011102230246251565404236316680908203124",
    "1.000000000000000111022302462515654042363166809082031251",
    "0.000000000000000000000000000000000000000000001",
    "00000000000000000000000000000000000000012.5", "1." + "0" * 40, "0." + "0" * 400 + "1",
    "1" + "0" * 400 + ".0", "9" * 30 + ".9", "3.14159265358979323846264338327950288",
    "6.02214076e23", "1E5", "1e+05", "1E-05", "  2.5", "2.5  ", " -3 ",
    "nan", "NaN", "NAN", "-nan", "+nan", "inf", "-inf", "+inf", "Inf", "INF", "infinity",
    "Infinity", "-Infinity", "INFINITY", "iNfInItY",
]


def test_edge_values_bit_exact(tmp_path):
    assert_exact(EDGE, parse_column(tmp_path, EDGE))


def test_random_doubles_bit_exact(tmp_path):
    """Two million random doubles (random bit patterns: all exponents, subnormals) in
    repr() and other formats, plus random decimal strings of 1-30 digits."""
    rng = np.random.default_rng(12345)
    raw = rng.integers(0, 2**64, size=1_250_000, dtype=np.uint64, endpoint=False)
    d = raw.view(np.float64)
    d = d[np.isfinite(d)]
    cells = [repr(x) for x in d.tolist()]
    small = rng.normal(size=300_000) * 10.0 ** rng.integers(-30, 30, size=300_000)
    cells += [f"{x:.{p}e}" for x, p in zip(small.tolist(), rng.integers(0, 25, 300_000))]
    cells += [f"{x:.{p}g}" for x, p in zip(small.tolist(), rng.integers(1, 25, 300_000))]
    cells = [c for c in cells if not long_integer(c)]
    digits = rng.integers(0, 10, size=(200_000, 30)).astype(np.uint8) + 48
    lens = rng.integers(1, 31, 200_000)
    exps = rng.integers(-360, 330, 200_000)
    dots = rng.integers(0, 31, 200_000)
    for row, n, e, k in zip(digits, lens.tolist(), exps.tolist(), dots.tolist()):
        m = row[:n].tobytes().decode()
        k = min(k, n)
        cells.append(f"{m[:k]}.{m[k:]}e{e}" if k else f"{m}e{e}")
    assert len(cells) > 2_000_000
    assert_exact(cells, parse_column(tmp_path, cells, threads=2))


_MANTISSA = st.text("0123456789", min_size=1, max_size=45)


@st.composite
def decimal_text(draw):
    """A number in the formats numeric columns use: sign, digits around a dot, exponent."""
    sign = draw(st.sampled_from(["", "-", "+"]))
    digits = draw(_MANTISSA)
    k = draw(st.integers(0, len(digits)))
    form = draw(st.sampled_from(["int", "dot", "lead", "trail"]))
    if form == "int":
        body = digits
    elif form == "dot":
        body = f"{digits[:k] or '0'}.{digits[k:]}"
    elif form == "lead":
        body = f".{digits}"
    else:
        body = f"{digits}."
    if draw(st.booleans()):
        e = draw(st.integers(-400, 400))
        body += draw(st.sampled_from(["e", "E"])) + draw(st.sampled_from(["", "+"])) * (e >= 0) + str(e)
    return sign + body


def _formatted_float(x: float, how: str, p: int) -> str:
    if how == "repr":
        return repr(x)
    return format(x, f".{p}{how}")


float_text = st.builds(
    _formatted_float,
    st.floats(allow_nan=False, allow_infinity=False) | st.floats(min_value=-1e-300,
                                                                 max_value=1e-300),
    st.sampled_from(["repr", "e", "E", "g", "f"]),
    st.integers(0, 25),
)


@HSET
@given(cells=st.lists(decimal_text() | float_text, min_size=1, max_size=60))
def test_hypothesis_numbers_bit_exact(tmp_path, cells):
    cells = [c for c in cells if len(c) < 400 and not long_integer(c)]
    if cells:
        assert_exact(cells, parse_column(tmp_path, cells))


@HSET
@given(x=st.floats(allow_nan=False, allow_infinity=False))
def test_hypothesis_repr_roundtrip(tmp_path, x):
    got = parse_column(tmp_path, [repr(x), repr(-x), f"{x:.17e}", f"{x:.16e}", f"{x:.25e}"])
    assert same(got[0], x) and same(got[1], -x)
    assert_exact([repr(x), repr(-x), f"{x:.17e}", f"{x:.16e}", f"{x:.25e}"], got)


def test_many_digits_undecided_fall_to_python(tmp_path):
    """Halfway cases with more than 19 digits: w and w+1 round differently, float() decides."""
    cells = []
    rng = np.random.default_rng(3)
    ctx = Context(prec=80)
    for x in rng.normal(size=2000).tolist() + [1.0, 2.0, 1e300, 1e-300, 2.5e-308]:
        ulp = math.ulp(x)
        for delta in ("0.5", "0.4999999999999999999999", "0.5000000000000000000001"):
            # exactly halfway between two doubles, and just either side, written out long
            cells.append(str(ctx.add(Decimal(x), ctx.multiply(Decimal(ulp), Decimal(delta)))))
    assert_exact(cells, parse_column(tmp_path, cells))
    # (and these really took the float() route)
    buf = np.frombuffer(("\n".join(cells) + "\n").encode(), dtype=np.uint8)
    out = np.zeros((1, len(cells)))
    hard = np.zeros((fastcsv.HARD_CAP, 4), dtype=np.int64)
    rows, nhard, status, _ = fastcsv._parse_part(buf, 0, len(buf), ord(","), np.zeros(1, np.int64),
                                                 out, out.view(np.uint64), 0, hard,
                                                 np.zeros((1, 2), dtype=np.int64))
    assert (rows, status) == (len(cells), fastcsv.OK) and nhard > len(cells) // 2


# ----------------------------------------------------------------------------- table shape
def write(tmp_path: Path, text: str | bytes, name: str = "t.csv") -> Path:
    p = tmp_path / name
    p.write_bytes(text.encode() if isinstance(text, str) else text)
    return p


def grid(rows: int, cols: int, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).normal(size=(rows, cols)) * 100


def csv_text(a: np.ndarray, names: list[str], sep: str = ",", nl: str = "\n",
             final_newline: bool = True) -> str:
    lines = [sep.join(names)] + [sep.join(repr(v) for v in row) for row in a.tolist()]
    return nl.join(lines) + (nl if final_newline else "")


@pytest.mark.parametrize("sep", [",", "\t", ";", "|"])
@pytest.mark.parametrize("nl", ["\n", "\r\n"])
@pytest.mark.parametrize("final_newline", [True, False])
def test_rows_columns_delims_line_ends(tmp_path, sep, nl, final_newline):
    a = grid(257, 5)
    names = ["t", "a", "b", "c", "d"]
    p = write(tmp_path, "# bench 7\n#\n\n" + csv_text(a, names, sep, nl, final_newline))
    wanted, values, nulls, intlike = fastcsv.read_numeric(p, sep, 3, names, ["c", "a"])
    assert wanted == ["c", "a"] and values.shape == (2, 257) and not nulls and not intlike
    assert values[0].tobytes() == a[:, 3].tobytes() and values[1].tobytes() == a[:, 1].tobytes()


@pytest.mark.parametrize("part_bytes", [1, 3, 7, 8, 9, 17, 64, 1000, 1 << 20])
@pytest.mark.parametrize("threads", [1, 2, 3])
def test_part_boundaries_anywhere(tmp_path, part_bytes, threads):
    """Parts (thread chunks) end inside numbers and lines; every split gives the same rows."""
    a = grid(400, 3, seed=part_bytes)
    a[::7, 1] = np.round(a[::7, 1])  # some short fields
    text = csv_text(a, ["x", "y", "z"]).replace("\n", "\n\n", 3)  # and a few blank lines
    p = write(tmp_path, text)
    res = fastcsv.read_numeric(p, ",", 0, ["x", "y", "z"], part_bytes=part_bytes,
                               threads=threads)
    assert res[1].shape == (3, 400)
    assert res[1].T.tobytes() == a.tobytes()


def test_swar_tail_near_part_end(tmp_path):
    """Long digit runs right at the end of the data (scalar path) and everywhere else."""
    cells = ["1234567890123456.7", "0.12345678901234567", "12345678", "123456789", "1234567"]
    for pb in (1, 5, 11, 1 << 20):
        assert_exact(cells, parse_column(tmp_path, cells, part_bytes=pb))


def test_unused_columns_are_skipped_not_parsed(tmp_path):
    text = "t,label,rate,when\n" + "".join(
        f"{i * 0.1!r},run é{i},{i * 1.5!r},2026-03-01T10:00:{i:02d}\n" for i in range(50))
    p = write(tmp_path, text)
    wanted, values, _, _ = fastcsv.read_numeric(p, ",", 0, ["t", "label", "rate", "when"],
                                                ["rate", "t"])
    np.testing.assert_array_equal(values[0], [i * 1.5 for i in range(50)])
    np.testing.assert_array_equal(values[1], [i * 0.1 for i in range(50)])


def test_nulls_and_integer_typing(tmp_path):
    text = ("i,f,n,e,s\n"
            "1,1.5,,1, 7\n"
            "-2,NA,,2,-0\n"
            "3,-,,N/A,+5\n"
            "4,null,,NULL,12 \n"
            "5,nan,,-, 9\n")
    p = write(tmp_path, text)
    fast = read_table_fast(p)
    slow = read_table_arrow(p)
    assert fast.schema == slow.schema
    assert fast.column("i").type == pa.int64() and fast.column("n").type == pa.null()
    assert fast.column("e").type == pa.int64() and fast.column("s").type == pa.float64()
    assert fast.column("f").null_count == 3 and fast.column("e").null_count == 3
    assert_tables_identical(fast, slow)


# ----------------------------------------------------------------------------- vs pyarrow path
def read_table_fast(p: Path, columns=None) -> pa.Table:
    os.environ["GYROTEST_FASTCSV_MIN_BYTES"] = "0"
    os.environ["GYROTEST_FASTCSV"] = "strict"
    try:
        from gyrotest.ingest import _sniff_text

        delim, skip, names = _sniff_text(p.read_bytes()[:65536], str(p))
        table = fastcsv.read_numeric_table(p, delim, skip, names, columns)
        assert table is not None, "fast path handed over"
        return table
    finally:
        del os.environ["GYROTEST_FASTCSV_MIN_BYTES"], os.environ["GYROTEST_FASTCSV"]


def read_table_arrow(p: Path, columns=None) -> pa.Table:
    os.environ["GYROTEST_FASTCSV"] = "0"
    try:
        return read_table(p, columns=columns).table
    finally:
        del os.environ["GYROTEST_FASTCSV"]


def assert_tables_identical(a: pa.Table, b: pa.Table) -> None:
    assert a.schema == b.schema and a.num_rows == b.num_rows
    for name in a.column_names:
        x, y = a.column(name), b.column(name)
        assert x.null_count == y.null_count, name
        xv = x.to_numpy(zero_copy_only=False)
        yv = y.to_numpy(zero_copy_only=False)
        if xv.dtype.kind == "f":
            nan = np.isnan(xv)
            assert (nan == np.isnan(yv)).all(), name
            assert xv[~nan].tobytes() == yv[~nan].tobytes(), name
        else:
            assert xv.tolist() == yv.tolist(), name


_cellnum = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.floats(-1e6, 1e6).map(lambda x: f"{x:.6f}"),
    st.integers(-10**15, 10**15).map(str),
    st.sampled_from(["", "NA", "-", "nan", "-inf", ".5", "5.", "1e-310", "+3", " 4 "]),
)


@st.composite
def numeric_csv(draw):
    ncol = draw(st.integers(1, 5))
    names = [f"c{j}" for j in range(ncol)]
    nrow = draw(st.integers(1, 30))
    cols = [draw(st.lists(_cellnum, min_size=nrow, max_size=nrow)) for _ in range(ncol)]
    sep = draw(st.sampled_from([",", "\t", ";"]))
    nl = draw(st.sampled_from(["\n", "\r\n"]))
    rows = [sep.join(c[i] for c in cols) for i in range(nrow)]
    if draw(st.booleans()):
        rows.insert(draw(st.integers(0, nrow)), "")  # a blank line
    head = "".join(draw(st.lists(st.sampled_from(["# comment\n", "\n", "  # x, y\n"]),
                                 max_size=3)))
    text = head + nl.join([sep.join(names)] + rows) + draw(st.sampled_from(["", nl]))
    use = draw(st.lists(st.sampled_from(names), min_size=1, max_size=ncol, unique=True))
    return text, use


@settings(max_examples=200, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(case=numeric_csv())
def test_same_table_as_pyarrow(tmp_path, case):
    text, use = case
    p = write(tmp_path, text)
    try:
        slow = read_table_arrow(p, use)
    except InputError:  # e.g. no data rows: the fast path must hand over too
        with pytest.MonkeyPatch.context() as mp:
            mp.setenv("GYROTEST_FASTCSV_MIN_BYTES", "0")
            mp.setenv("GYROTEST_FASTCSV", "strict")
            assert fastcsv.read_numeric_table(p, *_sniffed(p), use) is None
        return
    assert_tables_identical(read_table_fast(p, use), slow)


def _sniffed(p: Path):
    from gyrotest.ingest import _sniff_text

    return _sniff_text(p.read_bytes()[:65536], str(p))


# ----------------------------------------------------------------------------- hand-over
FALLBACKS = {
    "quoted field": 't,rate\n0,"1.5"\n1,2\n',
    "quoted text with delimiter": 't,rate,note\n0,1,"a,b"\n1,2,c\n',
    "string in used column": "t,rate\n0,1.0\n0.1,abc\n",
    "iso timestamps": "t,rate\n2026-03-01T10:00:00,1\n2026-03-01T10:00:01,2\n",
    "mid-file comment": "t,rate\n0,1\n# operator touched the table\n1,2\n",
    "ragged long": "t,rate\n0,1\n1,2,3\n2,1\n",
    "ragged short": "t,rate\n0,1\n1\n2,1\n",
    "lone CR": "t,rate\r0,1\r1,2\r",
    "lone CR in data": "t,rate\n0,1\r1,2\n",
    "non-utf8 in used column": b"t,rate\n0,1\xff\n1,2\n",
    "bom": "\ufefft,rate\n0,1\n1,2\n",
    "exponent without digits": "t,rate\n0,1e\n1,2\n",
    "trailing garbage": "t,rate\n0,1.5x\n1,2\n",
    "long integer": "t,rate\n0,123456789012345678901234\n1,2\n",
    "spaces only": "t,rate\n0, \n1,2\n",
    "padded header": "t, rate\n0,1\n1,2\n",
    "whitespace-only line": "t,rate\n0,1\n   \n1,2\n",
    "hex": "t,rate\n0,0x10\n1,2\n",
    "bool": "t,rate\n0,true\n1,false\n",
}


@pytest.mark.parametrize("name", sorted(FALLBACKS))
def test_hands_over_to_pyarrow(tmp_path, name, monkeypatch):
    p = write(tmp_path, FALLBACKS[name])
    head = p.read_bytes()
    try:
        delim, skip, names = _sniffed(p)
    except InputError:
        return  # the sniffer already rejects it: the fast path is never asked
    cols = [n for n in names if n.strip() in ("rate", "t")]
    assert fastcsv.read_numeric(p, delim, skip, names, cols or None) is None, head
    # and through read_log: the same result or the same one-line error as the pyarrow path
    monkeypatch.setenv("GYROTEST_FASTCSV_MIN_BYTES", "0")
    monkeypatch.setenv("GYROTEST_FASTCSV", "strict")
    fast = _outcome(p)
    monkeypatch.setenv("GYROTEST_FASTCSV", "0")
    assert fast == _outcome(p)


def _outcome(p: Path):
    try:
        log = read_log(p, overrides={"gyro": {"rate_unit": "deg/h", "sample_rate_hz": 10.0}})
    except Exception as e:  # (a BOM or a padded header: pyarrow's KeyError, as before)
        return (type(e).__name__, str(e))
    return ("ok", log.rate.tobytes(), log.t.tobytes())


def test_read_log_same_result_fast_or_not(tmp_path, monkeypatch):
    """The whole ingest (roles, units, NaN/gap handling) is unchanged by the fast path."""
    n = 3000
    rng = np.random.default_rng(7)
    t = np.arange(n) * 0.01
    t = np.delete(t, range(1000, 1010))  # a gap
    rate = rng.normal(size=t.size)
    temp = 25 + rng.normal(size=t.size)
    lines = ["# bench", "time,rate_dph,temp_c,counts"]
    lines += [f"{a!r},{b!r},{c:.4f},{i % 17}" for i, (a, b, c) in enumerate(zip(t.tolist(), rate.tolist(), temp.tolist()))]
    lines[500] = lines[500].replace(f",{temp[498]:.4f},", ",,")  # a missing temperature
    p = write(tmp_path, "\r\n".join(lines) + "\r\n")
    ov = {"columns": {"rate": ["rate_dph"]}, "gyro": {"rate_unit": "deg/s"}}
    monkeypatch.setenv("GYROTEST_FASTCSV_MIN_BYTES", "0")
    monkeypatch.setenv("GYROTEST_FASTCSV", "strict")
    used = []
    real = fastcsv.read_numeric
    monkeypatch.setattr(fastcsv, "read_numeric", lambda *a, **k: used.append(real(*a, **k))
                        or used[-1])
    fast = read_log(p, overrides=ov, nan_policy="interpolate")
    assert used and used[-1] is not None, "the fast path was not taken"
    assert used[-1][3] == {"counts"}  # integer column, typed int64 like pyarrow does
    monkeypatch.setenv("GYROTEST_FASTCSV", "0")
    slow = read_log(p, overrides=ov, nan_policy="interpolate")
    assert fast.rate.tobytes() == slow.rate.tobytes() and fast.t.tobytes() == slow.t.tobytes()
    assert fast.temperature["temp_c"].tobytes() == slow.temperature["temp_c"].tobytes()
    assert fast.extra.keys() == slow.extra.keys()
    for k in fast.extra:
        assert fast.extra[k].tobytes() == slow.extra[k].tobytes()
    assert fast.notes == slow.notes and fast.timing == slow.timing


def test_threshold_and_switch(tmp_path, monkeypatch):
    p = write(tmp_path, "t,rate\n0,1\n1,2\n")
    assert fastcsv.read_numeric_table(p, ",", 0, ["t", "rate"]) is None  # below MIN_BYTES
    monkeypatch.setenv("GYROTEST_FASTCSV_MIN_BYTES", "0")
    assert fastcsv.read_numeric_table(p, ",", 0, ["t", "rate"]).num_rows == 2
    monkeypatch.setenv("GYROTEST_FASTCSV", "0")
    assert fastcsv.read_numeric_table(p, ",", 0, ["t", "rate"]) is None


def test_works_without_a_writable_numba_cache(tmp_path):
    """No place to write numba's cache: the kernels compile in memory and still work."""
    src = Path(fastcsv.__file__).read_text()
    mod = tmp_path / "mod"
    mod.mkdir()
    (mod / "fastcsv_copy.py").write_text(src)
    (mod / "__pycache__").write_text("a file, so no cache directory can be made here")
    blocked = tmp_path / "blocked"
    blocked.write_text("")
    data = write(tmp_path, "a,b\n1.5,2\n-0.25,1e-310\n")
    code = textwrap.dedent(f"""
        import sys
        sys.path.insert(0, {str(mod)!r})
        import fastcsv_copy as fc
        res = fc.read_numeric({str(data)!r}, ",", 0, ["a", "b"])
        assert res is not None and not fc._CACHED
        print(res[1].tolist())
    """)
    env = dict(os.environ, NUMBA_CACHE_DIR=str(blocked / "x"), HOME=str(blocked / "y"),
               XDG_CACHE_HOME=str(blocked / "z"), PYTHONDONTWRITEBYTECODE="1")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                       timeout=600)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == repr([[1.5, -0.25], [2.0, 1e-310]])
