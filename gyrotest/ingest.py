"""Reading bench logs: one place for every command.

:func:`read_log` turns a file (CSV/TSV/semicolon/whitespace text with a header, Parquet,
Feather/Arrow IPC, or ``-`` for CSV on stdin) plus an optional bench profile and command-line
overrides into a :class:`~gyrotest.data.GyroLog` in internal units (rate deg/h, time s,
temperature degC, field uT, supply V).

Gyro output kinds (IEEE 952 §8.3 model equation, S0 = scale factor):

* ``rate``: an angular-rate column in any unit (deg/h, deg/s, rad/s, mrad/s ...);
* ``counts``: pulses per sample; rate = counts · S0[arcsec/pulse] / τ0[s] (1 arcsec/s = 1 deg/h);
* ``updown``: up/down pulse pairs, net = up − down, then as counts;
* ``counter``: a cumulative pulse counter that rolls over at 2^bits; unwrapped modulo 2^bits
  (the first sample only sets the origin and is dropped);
* ``voltage``: analog output; rate = S0[(deg/h)/V] · (V − offset).

Text is parsed with pyarrow's multithreaded CSV reader (whitespace-separated text with pandas'
C parser); only the columns that are used are converted. Timing: a time column (seconds, or
ISO-8601 timestamps) or a sample rate; gaps (> 1.5 nominal intervals) are reported and split
the log into segments, never bridged; backwards timestamps are an error; exact duplicate rows
are dropped with a note.
"""

from __future__ import annotations

import csv
import difflib
import io
import json
import math
import os
import re
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa

from . import __version__
from .data import Gap, GyroConstants, GyroLog, Timing
from .earth import Site, check_latitude, parse_ia
from .errors import InputError
from .profile import Profile, merge
from .units import INTERNAL, factor, to_internal

META_KEY = b"gyrotest"
GAP_FACTOR = 1.5  # an interval longer than this many nominal intervals is a gap
JITTER_WARN = 0.01  # relative std of the interval above which sampling is called irregular

# ----------------------------------------------------------------------------- auto-detection
_TIME_NAMES = {"time", "t", "t_s", "time_s", "times", "timestamp", "seconds", "sec", "elapsed",
               "elapsed_s", "datetime", "date_time"}
_RATE_NAMES = {"rate", "omega", "gyro", "w", "rate_dph", "omega_dph", "rate_dps", "omega_dps",
               "rate_rads", "gyro_rate"}
_COUNT_NAMES = {"counts", "count", "pulses", "pulse", "dn", "delta_n", "n_pulses"}
_COUNTER_NAMES = {"counter", "cnt", "cum_counts", "pulse_counter"}
_VOLT_NAMES = {"voltage", "v_out", "vout", "volt", "u_out", "analog"}
_SUPPLY_NAMES = {"supply", "vsupply", "v_supply", "supply_v", "vcc", "vin", "v_in", "vdd"}
_TABLE_NAMES = {"table_rate", "table", "cmd_rate", "table_dps", "commanded_rate", "table_cmd",
                "rate_cmd", "input_rate"}
_POSITION_NAMES = {"position", "pos", "ia_position"}
_FIELD_PATTERNS = [
    (re.compile(r"^(h|b|mag_?|field_?)x", re.I), "x"),
    (re.compile(r"^(h|b|mag_?|field_?)y", re.I), "y"),
    (re.compile(r"^(h|b|mag_?|field_?)z", re.I), "z"),
]
_TEMP_PATTERN = re.compile(r"^(temp|temperature|t_(?!s$)|tc\d|t\d|thermo)", re.I)

# unit hints from a column-name suffix
_SUFFIX_UNITS = [
    (re.compile(r"_(dph|deg_?h|deg_per_h)$", re.I), "deg/h"),
    (re.compile(r"_(dps|deg_?s|deg_per_s)$", re.I), "deg/s"),
    (re.compile(r"_(rads|rad_?s|rad_per_s)$", re.I), "rad/s"),
    (re.compile(r"_(mrads|mrad_?s)$", re.I), "mrad/s"),
    (re.compile(r"_(degc|c)$", re.I), "degC"),
    (re.compile(r"_k$", re.I), "K"),
    (re.compile(r"_(degf|f)$", re.I), "degF"),
    (re.compile(r"_(ut|µt|microtesla)$", re.I), "uT"),
    (re.compile(r"_nt$", re.I), "nT"),
    (re.compile(r"_mt$"), "mT"),
    (re.compile(r"_(g|gauss)$"), "G"),
    (re.compile(r"_mg$"), "mG"),
    (re.compile(r"_v$", re.I), "V"),
    (re.compile(r"_mv$", re.I), "mV"),
    (re.compile(r"_ms$", re.I), "ms"),
    (re.compile(r"_us$", re.I), "us"),
]


@dataclass
class RawTable:
    """A table as read from disk, before roles and units are applied."""

    table: pa.Table
    source: str
    fmt: str  # csv | tsv | whitespace | parquet | feather
    path: Path | None  # None for stdin
    header_line: int = 0  # 1-based line of the header in a text file
    meta: dict | None = None  # gyrotest metadata of a converted Parquet/Feather file
    # float64 columns read by the streaming reader, writeable and owned by this table: handed
    # to the first (only) role that uses them without a copy (see _column_to_float)
    owned: dict[str, np.ndarray] = field(default_factory=dict)
    exclusive: set[str] = field(default_factory=set)

    def line_of_row(self, row: int) -> int | None:
        """1-based text line of 0-based data row ``row`` (text files only)."""
        if self.fmt in ("parquet", "feather"):
            return None
        if self.path is None:
            return None
        count = -1
        with open(self.path, "rb") as fh:
            for lineno, line in enumerate(fh, 1):
                if lineno <= self.header_line:
                    continue
                s = line.strip()
                if not s or s.startswith(b"#"):
                    continue
                count += 1
                if count == row:
                    return lineno
        return None

    def where(self, row: int) -> str:
        line = self.line_of_row(row)
        return f"row {row + 1}" + (f" (line {line})" if line else "")


# ----------------------------------------------------------------------------- table reading
def _source_name(path: str | os.PathLike) -> str:
    return "<stdin>" if str(path) == "-" else str(path)


def _sniff_text(head: bytes, source: str) -> tuple[str, int, list[str]]:
    """Find the delimiter, the number of leading comment/blank lines and the header names."""
    if b"\x00" in head:
        raise InputError(
            f"{source}: binary data, not a text table; expected CSV/TSV text with a header, "
            "Parquet or Feather"
        )
    try:
        text = head.decode("utf-8")
    except UnicodeDecodeError as e:
        # a multi-byte character cut at the end of the sample is fine
        if e.start < len(head) - 4:
            try:
                text = head.decode("latin-1")
                if sum(ch.isprintable() or ch in "\r\n\t" for ch in text) < 0.95 * len(text):
                    raise ValueError
            except ValueError:
                raise InputError(
                    f"{source}: not a text table (undecodable bytes); expected CSV/TSV text with "
                    "a header, Parquet or Feather"
                ) from None
        else:
            text = head[: e.start].decode("utf-8")
    lines = text.splitlines()
    skip = 0
    while skip < len(lines) and (not lines[skip].strip() or lines[skip].lstrip().startswith("#")):
        skip += 1
    if skip >= len(lines):
        raise InputError(f"{source}: no header line found (the file holds only comments or blank "
                         "lines); the first non-comment line must name the columns")
    header = lines[skip]
    sample = [ln for ln in lines[skip: skip + 50] if ln.strip() and not ln.lstrip().startswith("#")]
    delim = None
    for cand in (",", "\t", ";", "|"):
        counts = [ln.count(cand) for ln in sample[:-1] or sample]
        if counts[0] > 0 and all(c == counts[0] for c in counts):
            delim = cand
            break
    if delim is None:
        if len(header.split()) > 1:
            delim = "whitespace"
        elif any(c in header for c in ",\t;|"):
            raise InputError(f"{source}: rows have different numbers of fields than the header; "
                             "check the delimiter and the header line")
        else:
            delim = ","  # a single column
    if delim == "whitespace":
        names = header.split()
    else:
        names = next(csv.reader([header], delimiter=delim))
        names = [n.strip() for n in names]
    if any(not n for n in names):
        raise InputError(f"{source}: the header (line {skip + 1}) has an empty column name; "
                         "every column needs a name")
    if not any(re.search(r"[A-Za-z_]", n) for n in names):
        raise InputError(f"{source}: line {skip + 1} does not look like a header (no column "
                         "names, only numbers); add a header line naming the columns")
    dup = {n for n in names if names.count(n) > 1}
    if dup:
        raise InputError(f"{source}: duplicate column name(s) in the header: {', '.join(sorted(dup))}")
    return delim, skip, names


def read_table(path: str | os.PathLike, columns: list[str] | None = None,
               *, _names_only: bool = False) -> RawTable:
    """Read a table file (or ``-`` for stdin) into a pyarrow Table, only ``columns`` when
    given. Errors name the file and the fix."""
    source = _source_name(path)
    data: bytes | None = None
    p: Path | None = None
    if str(path) == "-":
        data = sys.stdin.buffer.read()
        if not data:
            raise InputError(f"{source}: empty input; pipe a CSV table with a header into gyrotest")
        head = data[:65536]
    else:
        p = Path(path)
        if not p.exists():
            raise InputError(f"{source}: file not found")
        if p.is_dir():
            raise InputError(f"{source}: is a directory, expected a log file")
        if p.stat().st_size == 0:
            raise InputError(f"{source}: file is empty (0 bytes)")
        with open(p, "rb") as fh:
            head = fh.read(65536)
    suffix = p.suffix.lower() if p else ""
    if head[:4] == b"PAR1" or suffix in (".parquet", ".pq"):
        if p is None:
            _bad_binary(source)
        if _names_only:
            return RawTable(pa.table({}), source, "parquet", p)
        return _read_parquet(p, source, columns)
    if head[:6] == b"ARROW1" or head[:4] == b"FEA1" or suffix in (".feather", ".arrow", ".ipc"):
        if p is None:
            _bad_binary(source)
        if _names_only:
            return RawTable(pa.table({}), source, "feather", p)
        return _read_feather(p, source, columns)
    delim, skip, names = _sniff_text(head, source)
    if _names_only:
        # not pa.table/pa.array: they import pandas (≈ 0.4 s) on first use
        empty = pa.Table.from_batches([], schema=pa.schema([(n, pa.float64()) for n in names]))
        return RawTable(empty, source, "csv", p, skip + 1)
    if columns is not None:
        _check_columns(columns, names, source)
    fmt = {"\t": "tsv", "whitespace": "whitespace"}.get(delim, "csv")
    if delim == "whitespace":
        table = _read_whitespace(p if p else io.BytesIO(data), source, skip, columns)
    else:
        from .fastcsv import arrow_table, read_numeric  # plain numbers: fast path

        owned = read_numeric(p, delim, skip, names, columns) if p else None
        if owned is not None:
            table = arrow_table(owned, columns or names)
            if table.num_rows == 0:
                raise InputError(f"{source}: header only, no data rows")
            return RawTable(table, source, fmt, p, header_line=skip + 1, owned=owned)
        table = _read_csv_arrow(p if p else io.BytesIO(data), source, delim, skip, columns, names)
    if table.num_rows == 0:
        raise InputError(f"{source}: header only, no data rows")
    return RawTable(table, source, fmt, p, header_line=skip + 1)


def _bad_binary(source: str):
    raise InputError(f"{source}: Parquet/Feather cannot be read from stdin; pass the file path")


def _check_columns(wanted: list[str], names: list[str], source: str) -> None:
    for c in wanted:
        if c not in names:
            raise InputError(_missing_column_msg(c, names, source))


def _missing_column_msg(col: str, names: list[str], source: str, role: str | None = None) -> str:
    close = difflib.get_close_matches(col, names, n=1, cutoff=0.6)
    hint = f"did you mean {close[0]!r}? " if close else ""
    what = f" (named for {role})" if role else ""
    return (f"{source}: column {col!r}{what} not found; {hint}columns are: "
            f"{', '.join(names[:20])}{' ...' if len(names) > 20 else ''}")


NULL_VALUES = ["", "NA", "N/A", "null", "NULL", "-"]
#: text files at least this large are read by the streaming reader straight into float64 arrays
STREAM_MIN_BYTES = 128 << 20
#: bytes of text parsed at a time by the streaming reader
RANGE_BYTES = 64 << 20


def _skip_comment_rows(row):
    """pyarrow invalid-row handler: skip ``#`` comment lines in the middle of a file."""
    if row.text.lstrip().startswith("#") or not row.text.strip():
        return "skip"
    return "error"


def _csv_options(delim: str, skip: int, names: list[str], columns: list[str] | None,
                 column_types: dict | None = None):
    import pyarrow.csv as pcsv

    # the header line is skipped and our own (stripped) names are used, so that a padded
    # header such as "rate , temp" still matches --rate-col rate
    read_opts = pcsv.ReadOptions(skip_rows=skip + 1, column_names=names, use_threads=True,
                                 block_size=1 << 22)
    parse_opts = pcsv.ParseOptions(delimiter=delim, invalid_row_handler=_skip_comment_rows,
                                   ignore_empty_lines=True)
    conv_opts = pcsv.ConvertOptions(include_columns=columns, strings_can_be_null=True,
                                    null_values=NULL_VALUES, column_types=column_types)
    return read_opts, parse_opts, conv_opts


def _stream_numeric(path: Path, delim: str, skip: int, names: list[str],
                    columns: list[str] | None) -> dict[str, np.ndarray] | None:
    """Read a large, all-numeric text table straight into preallocated float64 arrays.

    The file is read in ranges of :data:`RANGE_BYTES` cut at line ends; each range
    is parsed by pyarrow's multithreaded reader with every used column forced to float64 and
    copied into the output arrays, so peak memory is about the arrays plus one range instead of
    Arrow buffers plus numpy copies of the whole file. Returns None — and the caller uses the
    whole-file reader, which also produces the precise error messages — for small files or
    anything that is not plain numbers (text, timestamps, quotes across a cut …)."""
    import pyarrow.csv as pcsv

    size = path.stat().st_size
    if size < STREAM_MIN_BYTES:
        return None
    cols = list(columns or names)
    try:
        fh = open(path, "rb")
    except OSError:
        return None
    try:
        head = fh.read(1 << 22)
        pos = 0
        for _ in range(skip + 1):  # comment lines and the header
            pos = head.index(b"\n", pos) + 1
        body_sample = head[pos:]
        per_row = len(body_sample) / max(body_sample.count(b"\n"), 1)
        cap = int((size - pos) / max(per_row, 1.0) * 1.02) + 1024
        out = {c: np.empty(cap) for c in cols}
        read_opts = pcsv.ReadOptions(column_names=names, use_threads=True, block_size=1 << 22)
        parse_opts = pcsv.ParseOptions(delimiter=delim, invalid_row_handler=_skip_comment_rows,
                                       ignore_empty_lines=True)
        conv_opts = pcsv.ConvertOptions(include_columns=cols, strings_can_be_null=True,
                                        null_values=NULL_VALUES,
                                        column_types={c: pa.float64() for c in cols})
        n = 0
        fh.seek(pos)
        # one reusable buffer (fresh memory is expensive to touch): [carry | new bytes]
        buf = bytearray(RANGE_BYTES + (1 << 20))
        view = memoryview(buf)
        held = 0  # bytes of an incomplete last line carried to the next range
        while True:
            if held >= len(buf) - (1 << 16):  # a single line longer than the buffer
                return None
            got = fh.readinto(view[held:held + RANGE_BYTES])
            end = held + got
            if end == 0:
                break
            if got:
                cut = buf.rfind(b"\n", 0, end) + 1
                if cut == 0:
                    held = end
                    continue
            else:
                cut = end  # last line without a newline
            tbl = pcsv.read_csv(pa.BufferReader(pa.py_buffer(view[:cut])), read_options=read_opts,
                                parse_options=parse_opts, convert_options=conv_opts)
            view[: end - cut] = view[cut:end]
            held = end - cut
            k = tbl.num_rows
            if n + k > cap:
                cap = max(int(cap * 1.25), n + k)
                for c in cols:
                    grown = np.empty(cap)
                    grown[:n] = out[c][:n]
                    out[c] = grown
            for c in cols:
                dst = out[c][n:n + k]
                off = 0
                for chunk in tbl.column(c).chunks:
                    m = len(chunk)
                    dst[off:off + m] = chunk.to_numpy(zero_copy_only=False)
                    off += m
            n += k
            del tbl
            if not got:
                break
    except (pa.ArrowInvalid, ValueError, OSError, KeyError):
        return None
    finally:
        fh.close()
    return {c: a[:n] for c, a in out.items()}


def _read_csv_arrow(src, source: str, delim: str, skip: int, columns: list[str] | None,
                    names: list[str]) -> pa.Table:
    import pyarrow.csv as pcsv

    read_opts, parse_opts, conv_opts = _csv_options(delim, skip, names, columns)
    try:
        return pcsv.read_csv(src, read_options=read_opts, parse_options=parse_opts,
                             convert_options=conv_opts)
    except pa.ArrowInvalid as e:
        msg = str(e)
        m = re.search(r"Expected (\d+) columns, got (\d+): (.*)", msg)
        if m:
            raise InputError(f"{source}: a row has {m.group(2)} fields where the header has "
                             f"{m.group(1)}: {m.group(3)[:60]!r}; fix or delete that line") from None
        if "Empty CSV file" in msg:
            raise InputError(f"{source}: no data") from None
        raise InputError(f"{source}: cannot parse as a {('TSV' if delim == chr(9) else 'CSV')} "
                         f"table: {msg.splitlines()[0][:200]}") from None


def _read_whitespace(src, source: str, skip: int, columns: list[str] | None) -> pa.Table:
    import pandas as pd

    try:
        df = pd.read_csv(src, sep=r"\s+", skiprows=skip, comment="#", usecols=columns,
                         engine="c")
    except (ValueError, pd.errors.ParserError) as e:
        raise InputError(f"{source}: cannot parse as a whitespace-separated table: "
                         f"{str(e).splitlines()[0][:200]}") from None
    return pa.Table.from_pandas(df, preserve_index=False)


def _read_parquet(p: Path, source: str, columns: list[str] | None) -> RawTable:
    import pyarrow.parquet as pq

    try:
        pf = pq.ParquetFile(p, memory_map=True)
        names = pf.schema_arrow.names
        if columns is not None:
            _check_columns(columns, names, source)
        table = pf.read(columns=columns, use_threads=True)  # pq.read_table imports pandas
        meta = pf.schema_arrow.metadata or {}
    except InputError:
        raise
    except Exception as e:  # pyarrow raises several types for corrupt files
        raise InputError(f"{source}: not a readable Parquet file ({type(e).__name__}: "
                         f"{str(e).splitlines()[0][:120]})") from None
    return _finish_binary(table, source, "parquet", p, meta)


def _read_feather(p: Path, source: str, columns: list[str] | None) -> RawTable:
    import pyarrow.feather as feather

    try:
        table = feather.read_table(p, columns=columns, memory_map=True)
        meta = table.schema.metadata or {}
    except Exception as e:
        raise InputError(f"{source}: not a readable Feather/Arrow file ({type(e).__name__}: "
                         f"{str(e).splitlines()[0][:120]})") from None
    return _finish_binary(table, source, "feather", p, meta)


def _finish_binary(table: pa.Table, source: str, fmt: str, p: Path, meta: dict) -> RawTable:
    if table.num_rows == 0:
        raise InputError(f"{source}: the {fmt} file has no rows")
    gmeta = None
    if META_KEY in meta:
        try:
            gmeta = json.loads(meta[META_KEY])
        except ValueError:
            gmeta = None
    return RawTable(table, source, fmt, p, meta=gmeta)


def column_names(path: str | os.PathLike) -> list[str]:
    """The column names of a log file without reading its data."""
    raw = read_table(path, _names_only=True) if str(path) != "-" else None
    return raw.table.column_names if raw else []


# ----------------------------------------------------------------------------- roles
def _ci(names: list[str]) -> dict[str, str]:
    return {n.lower(): n for n in names}


def _unit_from_name(col: str) -> str | None:
    for pat, unit in _SUFFIX_UNITS:
        if pat.search(col):
            return unit
    return None


def resolve_columns(names: list[str], prof: Profile, source: str) -> tuple[dict[str, Any], list[str]]:
    """Map roles to columns: the profile (and overrides) first, then obvious names.

    Returns (roles, notes). ``roles`` keys: time, kind, output (list), temperature (list),
    field (list), supply, table_rate, position, extra (list).
    """
    cols = prof.columns
    lower = _ci(names)
    notes: list[str] = []
    used: set[str] = set()

    def need(col: str, role: str) -> str:
        if col in names:
            used.add(col)
            return col
        if col.lower() in lower:
            real = lower[col.lower()]
            used.add(real)
            return real
        raise InputError(_missing_column_msg(col, names, source, role))

    roles: dict[str, Any] = {}
    # time
    if cols.get("time"):
        roles["time"] = need(cols["time"], "time")
    else:
        hits = [n for n in names if n.lower() in _TIME_NAMES]
        roles["time"] = hits[0] if hits else None
        if roles["time"]:
            used.add(roles["time"])
            notes.append(f"time: column {roles['time']!r} (auto-detected)")
    # gyro output
    kind = prof.output_kind()
    if kind == "updown":
        roles["output"] = [need(cols["up"], "up pulses"), need(cols["down"], "down pulses")]
    elif kind is not None:
        roles["output"] = [need(c, kind) for c in cols[kind]]
    else:
        found: dict[str, list[str]] = {}
        for n in names:
            if n in used:
                continue
            ln = n.lower()
            if ln in _RATE_NAMES or re.match(r"^(rate|omega|gyro)_?[xyz123]?(_d?p[hs]|_rads)?$", ln):
                found.setdefault("rate", []).append(n)
            elif ln in _COUNT_NAMES:
                found.setdefault("counts", []).append(n)
            elif ln in _COUNTER_NAMES:
                found.setdefault("counter", []).append(n)
            elif ln in _VOLT_NAMES:
                found.setdefault("voltage", []).append(n)
        if "up" in lower and "down" in lower:
            found["updown"] = [lower["up"], lower["down"]]
        if len(found) > 1:
            raise InputError(
                f"{source}: several gyro outputs look possible ({'; '.join(f'{k}: {v}' for k, v in found.items())}); "
                "name one with --rate-col, --counts-col, --up-col/--down-col, --counter-col or "
                "--voltage-col (or in the profile's [columns])"
            )
        if not found:
            raise InputError(
                f"{source}: no gyro output column found among {', '.join(names[:12])}; name it "
                "with --rate-col, --counts-col, --up-col/--down-col, --counter-col or --voltage-col "
                "(or in a --profile)"
            )
        kind, cs = next(iter(found.items()))
        roles["output"] = cs
        used.update(cs)
        notes.append(f"gyro output: {kind} from column(s) {', '.join(map(repr, cs))} (auto-detected)")
    roles["kind"] = kind
    # auxiliary channels
    if cols.get("temperature"):
        roles["temperature"] = [need(c, "temperature") for c in cols["temperature"]]
    else:
        roles["temperature"] = [n for n in names if n not in used and _TEMP_PATTERN.match(n)]
        if roles["temperature"]:
            notes.append("temperature: " + ", ".join(map(repr, roles["temperature"])) + " (auto-detected)")
        used.update(roles["temperature"])
    if cols.get("field"):
        roles["field"] = [need(c, "magnetic field") for c in cols["field"]]
    else:
        fx = []
        for pat, _axis in _FIELD_PATTERNS:
            hit = [n for n in names if n not in used and pat.match(n)]
            if len(hit) == 1:
                fx.append(hit[0])
        roles["field"] = fx if len(fx) == 3 else []
        if roles["field"]:
            notes.append("magnetic field X, Y, Z: " + ", ".join(map(repr, fx)) + " (auto-detected)")
        used.update(roles["field"])
    for role, pool, label in (("supply", _SUPPLY_NAMES, "supply voltage"),
                              ("table_rate", _TABLE_NAMES, "rate-table rate"),
                              ("position", _POSITION_NAMES, "position")):
        if cols.get(role):
            roles[role] = need(cols[role], label)
        else:
            hit = [n for n in names if n not in used and n.lower() in pool]
            roles[role] = hit[0] if hit else None
            if roles[role]:
                used.add(roles[role])
                notes.append(f"{label}: column {roles[role]!r} (auto-detected)")
    if cols.get("extra"):
        roles["extra"] = [need(c, "extra channel") for c in cols["extra"]]
    else:
        roles["extra"] = [n for n in names if n not in used and not n.startswith("Unnamed")]
    return roles, notes


# ----------------------------------------------------------------------------- conversion
def _column_to_float(raw: RawTable, col: str, role: str) -> np.ndarray:
    """A column as float64 with NaN for missing cells; a non-numeric cell is an error naming
    the row."""
    if col in raw.owned and col in raw.exclusive:
        return raw.owned.pop(col)  # writeable float64 from the streaming reader: no copy
    arr = raw.table.column(col)
    t = arr.type
    if pa.types.is_floating(t) or pa.types.is_integer(t) or pa.types.is_boolean(t):
        if pa.types.is_floating(t) and t != pa.float64():
            arr = arr.cast(pa.float64())
        out = arr.to_numpy() if arr.null_count == 0 else arr.to_numpy(zero_copy_only=False)
        out = np.asarray(out, dtype=np.float64)
        if not out.flags.writeable:
            out = out.copy()
        return out
    if pa.types.is_null(t):
        return np.full(len(arr), np.nan)
    if pa.types.is_string(t) or pa.types.is_large_string(t):
        import pandas as pd

        s = arr.to_pandas()
        num = pd.to_numeric(s, errors="coerce")
        bad = num.isna() & s.notna() & ~s.astype(str).str.strip().str.lower().isin(
            ["nan", "", "na", "n/a", "null", "-"])
        if bad.any():
            i = int(np.flatnonzero(bad.to_numpy())[0])
            raise InputError(f"{raw.source}: non-numeric value {str(s.iloc[i])[:30]!r} in column "
                             f"{col!r} ({role}), {raw.where(i)}; fix or delete that row")
        return num.to_numpy(dtype=np.float64, na_value=np.nan)
    raise InputError(f"{raw.source}: column {col!r} ({role}) has type {t}, expected numbers")


def _time_seconds(raw: RawTable, col: str, unit: str) -> tuple[np.ndarray, str | None]:
    """The time column in seconds from its first value, plus the ISO start when timestamps."""
    arr = raw.table.column(col)
    t = arr.type
    if arr.null_count:
        i = int(np.flatnonzero(arr.is_null().to_numpy(zero_copy_only=False))[0])
        raise InputError(f"{raw.source}: empty time value in column {col!r}, {raw.where(i)}; "
                         "every row needs a time")
    if pa.types.is_timestamp(t) or pa.types.is_date(t):
        ns = arr.cast(pa.timestamp("ns")).to_numpy().astype("datetime64[ns]").astype(np.int64)
        start = str(np.datetime64(int(ns[0]), "ns"))
        return (ns - ns[0]).astype(np.float64) * 1e-9, start
    if pa.types.is_string(t) or pa.types.is_large_string(t):
        import pandas as pd

        s = arr.to_pandas()
        num = pd.to_numeric(s, errors="coerce")
        if num.notna().all():
            return num.to_numpy(dtype=np.float64) * factor(unit, "time", what=f"column {col!r}"), None
        try:
            ts = pd.to_datetime(s, format="ISO8601", utc=False)
        except (ValueError, TypeError):
            ts = pd.to_datetime(s, errors="coerce", format="ISO8601")
            i = int(np.flatnonzero(ts.isna().to_numpy())[0]) if ts.isna().any() else 0
            raise InputError(f"{raw.source}: cannot read time {str(s.iloc[i])[:40]!r} in column "
                             f"{col!r}, {raw.where(i)}; use seconds or ISO-8601 timestamps") from None
        if getattr(ts.dt, "tz", None) is not None:
            ts = ts.dt.tz_convert("UTC").dt.tz_localize(None)
        ns = ts.to_numpy().astype("datetime64[ns]").astype(np.int64)
        return (ns - ns[0]).astype(np.float64) * 1e-9, str(ts.iloc[0].isoformat())
    v = _column_to_float(raw, col, "time")
    bad = ~np.isfinite(v)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputError(f"{raw.source}: invalid time value in column {col!r}, {raw.where(i)}")
    f = factor(unit, "time", what=f"column {col!r}")
    v -= v[0]  # in place: no new 10^7-element arrays
    if f != 1.0:
        v *= f
    return v, None


def analyse_timing(t: np.ndarray, source: str, where: Callable[[int], str],
                   tau0: float | None = None) -> tuple[Timing, np.ndarray]:
    """Nominal interval, gaps, jitter; raises on backwards time. Returns (Timing, keep mask for
    exact duplicate timestamps — the caller decides whether the duplicated rows are identical).
    """
    n = len(t)
    if n < 2:
        raise InputError(f"{source}: only {n} sample(s); a log needs at least 2")
    dt = np.diff(t)
    dmin, dmax = float(dt.min()), float(dt.max())
    if dmin > 0 and dmax <= dmin * (1 + 1e-6) and (tau0 is None or abs(dmin - tau0) <= 1e-6 * tau0):
        # uniform sampling (the common case): no median/partition over 10^7 intervals
        tau0 = (float(t[-1]) - float(t[0])) / (n - 1) if tau0 is None else tau0
        timing = Timing(n=n, tau0=tau0, duration_s=float(t[-1] - t[0] + tau0), source="",
                        jitter_rel=(dmax - dmin) / tau0 / math.sqrt(12.0))
        return timing, np.ones(n, dtype=bool)
    back = np.flatnonzero(dt < 0)
    if back.size:
        i = int(back[0]) + 1
        raise InputError(f"{source}: time goes backwards at {where(i)} ({t[i]:.6g} s after "
                         f"{t[i - 1]:.6g} s); sort the log by time or fix the logger")
    dup = dt == 0
    pos = dt[~dup]
    if pos.size == 0:
        raise InputError(f"{source}: all timestamps are equal")
    if tau0 is None:
        tau0 = float(np.median(pos))
    gap_idx = np.flatnonzero(dt > GAP_FACTOR * tau0)
    gaps = [Gap(index=int(i) + 1, time_s=float(t[i + 1]), duration_s=float(dt[i]),
                missing=int(round(dt[i] / tau0)) - 1) for i in gap_idx]
    inside = pos[pos <= GAP_FACTOR * tau0]
    jitter = float(np.std(inside) / tau0) if inside.size > 1 else 0.0
    keep = np.ones(n, dtype=bool)
    keep[1:][dup] = False
    timing = Timing(n=n, tau0=tau0, duration_s=float(t[-1] - t[0] + tau0), source="",
                    gaps=gaps, jitter_rel=jitter, irregular=jitter > JITTER_WARN)
    return timing, keep


def _nan_runs(mask: np.ndarray) -> tuple[int, int, int]:
    """(first index, length of the first run, total count) of True values."""
    idx = np.flatnonzero(mask)
    first = int(idx[0])
    run_end = first
    while run_end + 1 < len(mask) and mask[run_end + 1]:
        run_end += 1
    return first, run_end - first + 1, int(idx.size)


def read_log(path: str | os.PathLike, *, profile: Profile | None = None,
             overrides: dict[str, dict[str, Any]] | None = None,
             nan_policy: str = "error") -> GyroLog:
    """Read a bench log into a :class:`GyroLog` (see the module docstring).

    ``overrides`` has the profile's shape (``{"columns": {...}, "gyro": {...}, "site": {...},
    "units": {...}}``) and wins key by key. ``nan_policy``: ``error`` (default) stops at the
    first missing value naming the row and column; ``gap`` drops rows with a missing value
    and treats them as gaps; ``interpolate`` fills auxiliary channels linearly (missing gyro
    values still become gaps).
    """
    if nan_policy not in ("error", "gap", "interpolate"):
        raise InputError(f"unknown NaN policy {nan_policy!r}; use error, gap or interpolate")
    prof = merge(profile, overrides or {})
    source = _source_name(path)
    # names first (cheap) so that only the used columns are parsed
    if str(path) != "-":
        head = read_table(path, _names_only=True)
        if head.fmt in ("parquet", "feather"):
            return _from_binary(head, prof, nan_policy)
        roles, notes = resolve_columns(head.table.column_names, prof, source)
        wanted = _wanted(roles)
        raw = read_table(path, columns=wanted)
    else:
        raw = read_table(path)
        roles, notes = resolve_columns(raw.table.column_names, prof, source)
    return build_log(raw, roles, prof, notes, nan_policy)


def _wanted(roles: dict[str, Any]) -> list[str]:
    out: list[str] = []
    for key in ("time", "supply", "table_rate", "position"):
        if roles.get(key):
            out.append(roles[key])
    for key in ("output", "temperature", "field", "extra"):
        out.extend(roles.get(key) or [])
    return list(dict.fromkeys(out))


def _unit_for(col: str, prof: Profile, default: str) -> str:
    if col in prof.units:
        return prof.units[col]
    return _unit_from_name(col) or default


def build_log(raw: RawTable, roles: dict[str, Any], prof: Profile, notes: list[str],
              nan_policy: str = "error") -> GyroLog:
    """Apply roles, units, the gyro output conversion and the timing analysis."""
    source = raw.source
    g = prof.gyro
    n_rows = raw.table.num_rows
    used = [roles.get(k) for k in ("time", "supply", "table_rate")]
    for k in ("output", "temperature", "field", "extra"):
        used.extend(roles.get(k) or [])
    raw.exclusive = {c for c in used if c and used.count(c) == 1}
    kind = roles["kind"]
    units: dict[str, str] = {}
    # ---- time
    start_iso = None
    if roles.get("time"):
        tunit = _unit_for(roles["time"], prof, "s")
        if tunit not in ("ms", "us", "µs", "ns", "s", "min", "h"):
            tunit = prof.units.get(roles["time"], "s")
        t, start_iso = _time_seconds(raw, roles["time"], tunit)
        units[roles["time"]] = tunit if start_iso is None else "ISO-8601"
        time_source = f"time column {roles['time']!r}"
        tau0_given = None
        if g.get("sample_rate_hz"):
            notes.append("sample_rate_hz ignored: the log has a time column")
    else:
        fs = g.get("sample_rate_hz")
        if not fs:
            raise InputError(f"{source}: no time column and no sample rate; name the time column "
                             "with --time-col or give --sample-rate HZ (or [gyro] sample_rate_hz)")
        if fs <= 0:
            raise InputError(f"{source}: sample rate must be positive, got {fs}")
        t = None
        tau0_given = 1.0 / float(fs)
        time_source = f"sample rate {fs:g} Hz (no time column)"
    # ---- gyro output to rate (deg/h), before timing so that NaNs can become gaps
    outs = roles["output"]
    arrays = {c: _column_to_float(raw, c, "gyro output") for c in outs}
    gyro = GyroConstants(output_kind=kind, model=g.get("model"), serial=g.get("serial"),
                         type=g.get("type"))
    # ---- auxiliary
    temps = {c: _column_to_float(raw, c, "temperature") for c in roles.get("temperature") or []}
    fields = {c: _column_to_float(raw, c, "magnetic field") for c in roles.get("field") or []}
    supply = _column_to_float(raw, roles["supply"], "supply voltage") if roles.get("supply") else None
    table = _column_to_float(raw, roles["table_rate"], "rate-table rate") if roles.get("table_rate") else None
    extra = {}
    for c in roles.get("extra") or []:
        typ = raw.table.column(c).type
        if pa.types.is_string(typ) or pa.types.is_large_string(typ):
            try:
                extra[c] = _column_to_float(raw, c, "extra channel")
            except InputError:
                notes.append(f"column {c!r} is not numeric; ignored")
        else:
            extra[c] = _column_to_float(raw, c, "extra channel")
    position = None
    if roles.get("position"):
        position = np.asarray(raw.table.column(roles["position"]).to_pylist(), dtype=object)
        position = np.array([("" if v is None else str(v).strip().lower()) for v in position],
                            dtype=object)
    # ---- missing values
    aux = {**{f"temperature {c!r}": v for c, v in temps.items()},
           **{f"field {c!r}": v for c, v in fields.items()}}
    if supply is not None:
        aux[f"supply {roles['supply']!r}"] = supply
    if table is not None:
        aux[f"table rate {roles['table_rate']!r}"] = table
    gyro_cols = {f"gyro output {c!r}": v for c, v in arrays.items()}
    drop = np.zeros(n_rows, dtype=bool)
    for label, v in {**gyro_cols, **aux}.items():
        miss = np.isnan(v)
        if not miss.any():
            continue
        first, run, total = _nan_runs(miss)
        if total == n_rows:
            raise InputError(f"{source}: {label} has no values (all empty/NaN); check the column "
                             "or leave it out")
        if nan_policy == "error":
            rng = raw.where(first) if run == 1 else f"{raw.where(first)} to {raw.where(first + run - 1)}"
            raise InputError(
                f"{source}: {label} has {total} missing/NaN value(s), first at {rng}; fix the data, "
                "or pass --nan gap (drop those rows as gaps) or --nan interpolate"
            )
        if nan_policy == "interpolate" and label in aux:
            idx = np.arange(n_rows)
            v[miss] = np.interp(idx[miss], idx[~miss], v[~miss])
            notes.append(f"{label}: {total} missing value(s) interpolated linearly")
        else:
            drop |= miss
            notes.append(f"{label}: {total} row(s) with missing values dropped and treated as gaps")
    for c, v in extra.items():
        if np.isnan(v).any():
            idx = np.arange(n_rows)
            miss = np.isnan(v)
            if (~miss).any():
                v[miss] = np.interp(idx[miss], idx[~miss], v[~miss])
            notes.append(f"extra column {c!r}: missing values interpolated")
    if t is None:
        t = np.arange(n_rows, dtype=np.float64) * tau0_given
        synthetic_time = True
    else:
        synthetic_time = False
    if drop.any():
        keep = ~drop
        t = t[keep]
        arrays = {k: v[keep] for k, v in arrays.items()}
        temps = {k: v[keep] for k, v in temps.items()}
        fields = {k: v[keep] for k, v in fields.items()}
        extra = {k: v[keep] for k, v in extra.items()}
        supply = None if supply is None else supply[keep]
        table = None if table is None else table[keep]
        position = None if position is None else position[keep]
        rows = np.flatnonzero(keep)
    else:
        rows = None

    def where(i: int) -> str:
        return raw.where(int(rows[i]) if rows is not None else i)

    timing, keep = analyse_timing(t, source, where, tau0_given)
    if not keep.all():
        # equal timestamps: identical rows are logger repeats (dropped); others are an error
        dups = np.flatnonzero(~keep)
        for i in dups[:1000]:
            same = all(np.array_equal(v[i], v[i - 1], equal_nan=True)
                       for v in (*arrays.values(), *temps.values(), *fields.values()))
            if not same:
                raise InputError(f"{source}: duplicated timestamp {t[i]:.6g} s with different "
                                 f"values at {where(int(i))}; fix the logger output")
        t = t[keep]
        arrays = {k: v[keep] for k, v in arrays.items()}
        temps = {k: v[keep] for k, v in temps.items()}
        fields = {k: v[keep] for k, v in fields.items()}
        extra = {k: v[keep] for k, v in extra.items()}
        supply = None if supply is None else supply[keep]
        table = None if table is None else table[keep]
        position = None if position is None else position[keep]
        timing, _ = analyse_timing(t, source, where, tau0_given)
        timing.duplicates_dropped = int((~keep).sum())
        notes.append(f"{timing.duplicates_dropped} duplicated row(s) (same time, same values) dropped")
    timing.source = time_source
    timing.start = start_iso
    tau0 = timing.tau0
    if timing.gaps:
        tot = sum(gp.duration_s for gp in timing.gaps)
        notes.append(f"{len(timing.gaps)} gap(s) in the time axis ({tot:.4g} s in all); analyses "
                     "work per contiguous segment and never bridge a gap")
    if timing.irregular:
        notes.append(f"irregular sampling: interval jitter {100 * timing.jitter_rel:.2g}% of the "
                     f"nominal {tau0:.6g} s; uniform-sampling analyses assume the nominal interval")
    # ---- gyro conversion
    rates = _convert_output(kind, outs, arrays, gyro, prof, source, tau0, units, notes)
    if kind == "counter":
        # the first sample only sets the counter origin
        t = t[1:] - t[1]
        timing, _ = analyse_timing(t, source, lambda i: where(i + 1), tau0_given)
        timing.source, timing.start = time_source, start_iso
        temps = {k: v[1:] for k, v in temps.items()}
        fields = {k: v[1:] for k, v in fields.items()}
        extra = {k: v[1:] for k, v in extra.items()}
        supply = None if supply is None else supply[1:]
        table = None if table is None else table[1:]
        position = None if position is None else position[1:]
    # ---- auxiliary units
    for c in list(temps):
        u = _unit_for(c, prof, "degC")
        temps[c] = to_internal(temps[c], u, "temperature", what=f"column {c!r}")
        units[c] = u
    for c in list(fields):
        u = _unit_for(c, prof, "uT")
        temps_u = to_internal(fields[c], u, "field", what=f"column {c!r}")
        fields[c] = temps_u
        units[c] = u
    if supply is not None:
        u = _unit_for(roles["supply"], prof, "V")
        supply = to_internal(supply, u, "voltage", what=f"column {roles['supply']!r}")
        units[roles["supply"]] = u
    if table is not None:
        u = _unit_for(roles["table_rate"], prof, "deg/s")
        table = to_internal(table, u, "rate", what=f"column {roles['table_rate']!r}")
        units[roles["table_rate"]] = u
    for c in extra:
        units[c] = prof.units.get(c, _unit_from_name(c) or "")
    site = site_from_profile(prof, source)
    column_map = {"time": roles.get("time"), "gyro_output": outs, "output_kind": kind,
                  "temperature": list(temps), "field": list(fields),
                  "supply": roles.get("supply"), "table_rate": roles.get("table_rate"),
                  "position": roles.get("position"), "extra": list(extra)}
    log = GyroLog(
        source=source, rates=rates, tau0=tau0, timing=timing, gyro=gyro,
        time=None if synthetic_time and rows is None and timing.duplicates_dropped == 0 else t,
        temperature=temps, field_uT=fields, supply=supply, table_rate=table, position=position,
        extra=extra, site=site, column_map=column_map, units=units, notes=notes,
        meta={"profile": prof.source, "format": raw.fmt},
    )
    return log


def _convert_output(kind, outs, arrays, gyro, prof, source, tau0, units, notes):
    g = prof.gyro
    rates: dict[str, np.ndarray] = {}
    if kind == "rate":
        for c in outs:
            u = prof.units.get(c) or _unit_from_name(c) or g.get("rate_unit")
            if not u:
                raise InputError(
                    f"{source}: the unit of rate column {c!r} is not known; give --rate-unit "
                    "(deg/h, deg/s, rad/s, mrad/s, ...) or [gyro] rate_unit in the profile"
                )
            f = factor(u, "rate", what=f"rate column {c!r}")
            v = arrays[c]
            if f != 1.0:
                v *= f
            rates[c] = v
            units[c] = u
        gyro.rate_unit = units[outs[0]]
        return rates
    s0 = g.get("scale_factor")
    if s0 is None:
        what = "(deg/h)/V" if kind == "voltage" else "arcsec/pulse"
        raise InputError(f"{source}: {kind} output needs the scale factor S0 in {what}; give "
                         "--scale-factor or [gyro] scale_factor in the profile")
    s0 = float(s0)
    if not np.isfinite(s0) or s0 == 0:
        raise InputError(f"{source}: scale factor must be a non-zero number, got {s0}")
    gyro.scale_factor = s0
    if kind == "voltage":
        gyro.scale_factor_unit = "(deg/h)/V"
        off = g.get("offset_v")
        if off is None:
            off = 0.0
            notes.append("voltage offset not given: 0 V assumed (the bias absorbs it)")
        gyro.offset_v = float(off)
        for c in outs:
            v = arrays[c]
            v -= gyro.offset_v
            v *= s0
            rates[c] = v
            units[c] = "V"
        return rates
    gyro.scale_factor_unit = "arcsec/pulse"
    k = s0 / tau0  # arcsec per pulse / s = deg/h per (pulse/sample)
    if kind == "updown":
        up, down = arrays[outs[0]], arrays[outs[1]]
        net = up - down
        units[outs[0]] = units[outs[1]] = "pulses"
        rates["net"] = net * k
        return rates
    if kind == "counts":
        for c in outs:
            v = arrays[c]
            v *= k
            rates[c] = v
            units[c] = "pulses"
        return rates
    # cumulative counter
    bits = int(g.get("counter_bits") or 32)
    if "counter_bits" not in g:
        notes.append("counter width not given: 32 bits assumed ([gyro] counter_bits)")
    gyro.counter_bits = bits
    mod = float(2 ** bits)
    for c in outs:
        v = arrays[c]
        if np.any(v < 0) or np.any(v >= mod) or np.any(v != np.floor(v)):
            raise InputError(f"{source}: counter column {c!r} has values outside 0…2^{bits}−1 or "
                             "non-integers; check counter_bits or use --counts-col for per-sample counts")
        d = np.diff(v)
        d = np.mod(d + mod / 2, mod) - mod / 2  # signed, unwrapped modulo 2^bits
        rates[c] = d * k
        units[c] = f"counter ({bits}-bit)"
    notes.append(f"counter unwrapped modulo 2^{bits}; first sample sets the origin")
    return rates


def site_from_profile(prof: Profile, source: str = "profile") -> Site | None:
    s = prof.site
    if not s:
        return None
    lat = s.get("latitude_deg")
    if lat is None:
        if any(k in s for k in ("ia", "ia_azimuth_deg", "ia_elevation_deg")):
            raise InputError(f"{source}: the IA direction is given but no latitude; add "
                             "--latitude or [site] latitude_deg")
        return None
    lat = check_latitude(lat)
    if "ia_azimuth_deg" in s or "ia_elevation_deg" in s:
        az = float(s.get("ia_azimuth_deg", 0.0))
        el = float(s.get("ia_elevation_deg", 0.0))
        if not -90 <= el <= 90:
            raise InputError(f"{source}: ia_elevation_deg {el} is outside −90…90")
        label = s.get("ia") or f"az {az:g}°, el {el:g}°"
        if s.get("ia"):
            az, el, label = parse_ia(s["ia"])
        return Site(lat, az % 360.0, el, label)
    az, el, label = parse_ia(s.get("ia", "up"))
    return Site(lat, az, el, label)


# ----------------------------------------------------------------------------- gyrotest files
def _from_binary(head: RawTable, prof: Profile, nan_policy: str) -> GyroLog:
    """Read a Parquet/Feather file: a gyrotest-converted one through its metadata, any other
    through the column roles like a text table."""
    path = head.path
    if head.fmt == "parquet":
        import pyarrow.parquet as pq

        try:
            schema = pq.read_schema(path)
        except Exception as e:
            raise InputError(f"{head.source}: not a readable Parquet file ({type(e).__name__}: "
                             f"{str(e).splitlines()[0][:120]})") from None
    else:
        import pyarrow.feather as feather

        try:
            schema = feather.read_table(path, memory_map=True).schema
        except Exception as e:
            raise InputError(f"{head.source}: not a readable Feather/Arrow file "
                             f"({type(e).__name__}: {str(e).splitlines()[0][:120]})") from None
    meta = schema.metadata or {}
    if META_KEY in meta:
        try:
            gmeta = json.loads(meta[META_KEY])
        except ValueError:
            gmeta = None
        if gmeta:
            return _from_gyrotest(path, head.source, head.fmt, gmeta, prof)
    roles, notes = resolve_columns(schema.names, prof, head.source)
    raw = read_table(path, columns=_wanted(roles))
    return build_log(raw, roles, prof, notes, nan_policy)


def _from_gyrotest(path: Path, source: str, fmt: str, meta: dict, prof: Profile) -> GyroLog:
    raw = _read_parquet(path, source, None) if fmt == "parquet" else _read_feather(path, source, None)
    tab = raw.table
    cols = meta["columns"]

    def col(name):
        from .fastcsv import float64_values  # Arrow's to_numpy would import pandas

        return float64_values(tab.column(name))

    rates = {axis: col(c) for axis, c in cols["rates"].items()}
    time = col(cols["time"]) if cols.get("time") else None
    gaps = [Gap(int(g["index"]), float(g["time_s"]), float(g["duration_s"]),
                int(g["missing_samples"])) for g in meta["timing"]["gaps"]]
    tm = meta["timing"]
    timing = Timing(n=tm["samples"], tau0=tm["tau0_s"], duration_s=tm["duration_s"],
                    source=tm["time_source"], gaps=gaps, jitter_rel=tm["jitter_rel"],
                    irregular=tm["irregular"], duplicates_dropped=tm["duplicates_dropped"],
                    start=tm.get("start"))
    gm = meta["gyro"]
    gyro = GyroConstants(**{k: gm.get(k) for k in (
        "output_kind", "scale_factor", "scale_factor_unit", "offset_v", "rate_unit",
        "counter_bits", "model", "serial", "type")})
    for k in ("model", "serial", "type"):
        if prof.gyro.get(k):
            setattr(gyro, k, prof.gyro[k])
    site = None
    if meta.get("site"):
        s = meta["site"]
        site = Site(s["latitude_deg"], s["ia_azimuth_deg"], s["ia_elevation_deg"], s["ia"])
    if prof.site:
        override = site_from_profile(
            merge(Profile(site={"latitude_deg": site.latitude_deg, "ia_azimuth_deg": site.ia_azimuth_deg,
                                "ia_elevation_deg": site.ia_elevation_deg} if site else {}),
                  {"site": dict(prof.site)}), source)
        site = override
    position = None
    if cols.get("position"):
        position = np.asarray(tab.column(cols["position"]).to_pylist(), dtype=object)
    log = GyroLog(
        source=source, rates=rates, tau0=float(meta["tau0_s"]), timing=timing, gyro=gyro,
        time=time,
        temperature={c: col(c) for c in cols.get("temperature", [])},
        field_uT={c: col(c) for c in cols.get("field", [])},
        supply=col(cols["supply"]) if cols.get("supply") else None,
        table_rate=col(cols["table_rate"]) if cols.get("table_rate") else None,
        position=position,
        extra={c: col(c) for c in cols.get("extra", [])},
        site=site, column_map=meta.get("column_map", {}), units=meta.get("units", {}),
        notes=list(meta.get("notes", [])) + [f"read from gyrotest {fmt} (converted by "
                                             f"gyrotest {meta.get('gyrotest_version')})"],
        meta={"format": fmt, "converted_from": meta.get("source")},
    )
    return log


def log_to_table(log: GyroLog) -> pa.Table:
    """A GyroLog as an Arrow table in internal units, with the gyrotest metadata attached
    (units, sample interval, site, gyro constants, timing, column roles)."""
    arrays: dict[str, Any] = {}
    cols: dict[str, Any] = {"rates": {}}
    if log.time is not None:
        arrays["time_s"] = log.time
        cols["time"] = "time_s"
    for axis, v in log.rates.items():
        name = "rate_dph" if len(log.rates) == 1 else f"rate_{axis}_dph"
        arrays[name] = v
        cols["rates"][axis] = name
    for group, key in ((log.temperature, "temperature"), (log.field_uT, "field"),
                       (log.extra, "extra")):
        cols[key] = []
        for c, v in group.items():
            arrays[c] = v
            cols[key].append(c)
    if log.supply is not None:
        arrays["supply_V"] = log.supply
        cols["supply"] = "supply_V"
    if log.table_rate is not None:
        arrays["table_rate_dph"] = log.table_rate
        cols["table_rate"] = "table_rate_dph"
    if log.position is not None:
        arrays["position"] = pa.array(list(log.position), pa.string())
        cols["position"] = "position"
    units = {"time_s": "s", "supply_V": "V", "table_rate_dph": "deg/h"}
    units.update({c: "deg/h" for c in cols["rates"].values()})
    units.update({c: INTERNAL["temperature"] for c in cols["temperature"]})
    units.update({c: INTERNAL["field"] for c in cols["field"]})
    units.update({c: log.units.get(c, "") for c in cols["extra"]})
    meta = {
        "format_version": 1,
        "gyrotest_version": __version__,
        "source": log.source,
        "tau0_s": log.tau0,
        "columns": cols,
        "units": units,
        "gyro": log.gyro.to_dict(),
        "site": log.site.to_dict() if log.site else None,
        "timing": log.timing.to_dict(),
        "column_map": log.column_map,
        "notes": log.notes,
    }
    table = pa.table(arrays)
    return table.replace_schema_metadata({META_KEY: json.dumps(meta).encode()})


def write_log(log: GyroLog, path: str | os.PathLike, fmt: str | None = None) -> Path:
    """Write a GyroLog to Parquet (default) or Feather atomically, with metadata."""
    from .output import atomic_path

    p = Path(path)
    fmt = fmt or ("feather" if p.suffix.lower() in (".feather", ".arrow") else "parquet")
    table = log_to_table(log)
    with atomic_path(p) as tmp:
        if fmt == "parquet":
            import pyarrow.parquet as pq

            # plain, uncompressed float pages (gyro noise does not compress), large pages:
            # re-reading is close to a memory copy
            pq.write_table(table, tmp, compression="none", use_dictionary=False,
                           write_statistics=False, data_page_size=8 << 20)
        elif fmt == "feather":
            import pyarrow.feather as feather

            feather.write_feather(table, tmp, compression="uncompressed")
        else:
            raise InputError(f"unknown output format {fmt!r}; use parquet or feather")
    return p
