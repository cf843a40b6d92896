"""Reading a table file into Arrow: format sniffing, the text readers (CSV/TSV/semicolon/
whitespace, stdin) and the Parquet/Feather readers.

:func:`read_table` is the one entry point; the CSV path is :func:`_read_csv_arrow` (whole
file) with :func:`_stream_numeric` for large all-numeric files.
"""

from __future__ import annotations

import contextlib
import csv
import gzip
import io
import json
import os
import re
import stat
import sys
import zlib
from pathlib import Path

import numpy as np
import pyarrow as pa

from ..core.errors import InputError
from .fastcsv import _skip_comment_rows  # the one invalid-row handler of both CSV readers
from .rawtable import RawTable, _check_columns

META_KEY = b"gyrotest"  # schema-metadata key of gyrotest's own converted files


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
    if len(head) >= 65536 and len(lines) <= 1 + sum(
            1 for ln in lines if not ln.strip() or ln.lstrip().startswith("#")):
        raise InputError(f"{source}: no complete line in the first 64 KiB (a header of "
                         f"{text.count(',') + text.count(chr(9)) + 1:,}+ fields, or no line "
                         "ends); a gyro log has a header line naming a few columns — check the "
                         "file and its line endings")
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
    seen: set[str] = set()
    dup = {n for n in names if n in seen or seen.add(n)}
    if dup:
        raise InputError(f"{source}: duplicate column name(s) in the header: {', '.join(sorted(dup))}")
    return delim, skip, names


def read_table(path: str | os.PathLike, columns: list[str] | None = None,
               *, select: str | None = None, _names_only: bool = False,
               _data: bytes | None = None) -> RawTable:
    """Read a table file (or ``-`` for stdin) into a pyarrow Table, only ``columns`` when
    given. Errors name the file and the fix.

    Besides text and Parquet/Feather: gzip'd text, MATLAB ``.mat``, HDF5 and ROS bags
    (:mod:`gyrotest.io.containers`); ``select`` names the ROS topic, HDF5 group or MATLAB
    struct that holds the columns. ``_data``: the bytes of a stream already read (a named
    pipe, :func:`gyrotest.io.ingest.read_log`), parsed like stdin."""
    source = _source_name(path)
    data: bytes | None = None
    p: Path | None = None
    compressed = False
    if _data is not None:
        data = _check_stream(_data, source)
        head = data[:65536]
    elif str(path) == "-":
        data = _read_stdin(source)
        head = data[:65536]
    else:
        from .containers import container_format, read_container

        p = Path(path)
        fmt = container_format(p, None)
        if fmt is None:
            head = _read_head(p, source)
            fmt = container_format(p, head)
        if fmt is not None:
            return read_container(fmt, p, source, columns, select, names_only=_names_only)
        if head[:2] == GZIP_MAGIC:
            compressed = True
            head = _gzip_head(p, source)
    suffix = p.suffix.lower() if p else ""
    if head[:4] == b"PAR1" or suffix in (".parquet", ".pq"):
        if p is None:
            _bad_binary(source)
        if _names_only:
            return RawTable(pa.Table.from_batches([], schema=pa.schema([])), source, "parquet", p)
        return _read_parquet(p, source, columns)
    if head[:6] == b"ARROW1" or head[:4] == b"FEA1" or suffix in (".feather", ".arrow", ".ipc"):
        if p is None:
            _bad_binary(source)
        if _names_only:
            return RawTable(pa.Table.from_batches([], schema=pa.schema([])), source, "feather", p)
        return _read_feather(p, source, columns)
    if head.startswith(BOM):  # Excel "CSV UTF-8": the mark would hide the first column name
        head = head[len(BOM):]
    delim, skip, names = _sniff_text(head, source)
    decimal = _sniff_decimal(head, delim, skip)
    if _names_only:
        # not pa.table/pa.array: they import pandas (≈ 0.4 s) on first use
        empty = pa.Table.from_batches([], schema=pa.schema([(n, pa.float64()) for n in names]))
        return RawTable(empty, source, "csv", p, skip + 1, compressed=compressed)
    if columns is not None:
        _check_columns(columns, names, source)
    fmt = {"\t": "tsv", "whitespace": "whitespace"}.get(delim, "csv")
    if compressed:
        table = _read_gzip_text(p, source, delim, skip, columns, names, decimal=decimal)
        if table.num_rows == 0:
            raise InputError(f"{source}: header only, no data rows")
        return RawTable(table, source, fmt, p, header_line=skip + 1, compressed=True)
    if delim == "whitespace":
        table = _read_whitespace(p if p else io.BytesIO(data), source, skip, columns,
                                 decimal=decimal)
    else:
        owned = None
        if p and decimal == ".":
            from .fastcsv import arrow_table, read_numeric  # plain numbers: fast path

            with _quiet_invalid_row_handler():
                owned = read_numeric(p, delim, skip, names, columns)
            if owned is not None and any(
                    v.size and max(np.fmax.reduce(v), -np.fmin.reduce(v)) >= 2.0 ** 53
                    for v in owned.values()):  # fmax/fmin skip NaN; no |v| copy
                owned = None  # integers beyond float64's 53 bits (ns epochs): exact reader
        elif p:
            owned = _stream_numeric(p, delim, skip, names, columns, decimal=decimal)
        if owned is not None:
            from .fastcsv import arrow_table

            table = arrow_table(owned, columns or names)
            if table.num_rows == 0:
                raise InputError(f"{source}: header only, no data rows")
            return RawTable(table, source, fmt, p, header_line=skip + 1, owned=owned)
        table = _read_csv_arrow(p if p else io.BytesIO(data), source, delim, skip, columns, names,
                                decimal=decimal)
    if table.num_rows == 0:
        raise InputError(f"{source}: header only, no data rows")
    return RawTable(table, source, fmt, p, header_line=skip + 1)


def _read_head(p: Path, source: str) -> bytes:
    """The first 64 KiB of a regular file; anything else (missing, directory, FIFO, device,
    unreadable) is a one-line error. A FIFO or device is refused rather than opened: opening
    a FIFO blocks until a writer appears and /dev/zero never ends."""
    try:
        st = p.stat()
    except FileNotFoundError:
        raise InputError(f"{source}: file not found") from None
    except OSError as e:
        raise InputError(f"{source}: cannot access the file ({e.strerror}); check the path and "
                         "its permissions") from None
    if stat.S_ISDIR(st.st_mode):
        raise InputError(f"{source}: is a directory, expected a log file")
    if not stat.S_ISREG(st.st_mode):
        what = "a FIFO (named pipe)" if stat.S_ISFIFO(st.st_mode) else "a device or socket"
        raise InputError(f"{source}: is {what}, not a regular file; save the log to a file, or "
                         "pipe CSV text into gyrotest and pass '-'")
    if st.st_size == 0:
        raise InputError(f"{source}: file is empty (0 bytes)")
    try:
        with open(p, "rb") as fh:
            return fh.read(65536)
    except PermissionError:
        raise InputError(f"{source}: permission denied; make the file readable "
                         "(chmod u+r) or run as its owner") from None
    except OSError as e:
        raise InputError(f"{source}: cannot read the file ({e.strerror})") from None


GZIP_MAGIC = b"\x1f\x8b"


def _gzip_head(p: Path, source: str) -> bytes:
    """The first 64 KiB of a gzip'd text file, decompressed."""
    try:
        with gzip.open(p, "rb") as fh:
            head = fh.read(65536)
    except (OSError, EOFError, zlib.error) as e:  # BadGzipFile is an OSError
        raise InputError(f"{source}: not a readable gzip file ({type(e).__name__}: "
                         f"{str(e)[:100]}); check the file or decompress it with gunzip") from None
    if not head:
        raise InputError(f"{source}: the gzip file holds no data")
    return head


def _read_gzip_text(p: Path, source: str, delim: str, skip: int, columns: list[str] | None,
                    names: list[str], *, decimal: str = ".") -> pa.Table:
    """A gzip'd text table, decompressed while it is parsed (never a decompressed copy of the
    whole file in memory or on disk)."""
    try:
        if delim == "whitespace":
            with gzip.open(p, "rb") as fh:
                return _read_whitespace(fh, source, skip, columns, decimal=decimal)
        stream = pa.CompressedInputStream(pa.OSFile(str(p)), "gzip")
        with stream:
            return _read_csv_arrow(stream, source, delim, skip, columns, names, decimal=decimal)
    except InputError:
        raise
    except (OSError, EOFError, zlib.error, pa.ArrowException) as e:  # truncated or corrupt
        raise InputError(f"{source}: the gzip stream is damaged or truncated "
                         f"({str(e).splitlines()[0][:100]}); check the file (gzip -t)") from None


def _check_stream(data: bytes, source: str) -> bytes:
    """The bytes of a named pipe: text, like stdin."""
    if not data:
        raise InputError(f"{source}: the named pipe sent no data; a log is CSV text with a "
                         "header")
    if b"\x00" in data[:65536]:
        raise InputError(f"{source}: binary data from a named pipe; stream CSV/TSV text "
                         "(Parquet/Feather: save the file and pass its path)")
    return data


def _read_stdin(source: str) -> bytes:
    """All of stdin; binary data (e.g. ``< /dev/zero``) is refused after the first 64 KiB
    instead of being read to exhaustion."""
    buf = sys.stdin.buffer
    first = buf.read(65536)
    if not first:
        raise InputError(f"{source}: empty input; pipe a CSV table with a header into gyrotest")
    if b"\x00" in first:
        raise InputError(f"{source}: binary data, not a text table; pipe CSV/TSV text into "
                         "gyrotest (Parquet/Feather: pass the file path)")
    return first + buf.read()


BOM = b"\xef\xbb\xbf"
_COMMA_DECIMAL = re.compile(r"^[-+]?\d+,\d+(?:[eE][-+]?\d+)?$")
_DOT_DECIMAL = re.compile(r"^[-+]?\d*\.\d+(?:[eE][-+]?\d+)?$")


def _sniff_decimal(head: bytes, delim: str, skip: int) -> str:
    """``,`` when the data rows (of a file not separated by commas) hold numbers written with
    decimal commas (``0,1;5,82`` as European Excel writes them) and none with a decimal point."""
    if delim == ",":
        return "."
    text = head.decode("utf-8", errors="ignore")
    lines = [ln for ln in text.splitlines()[skip + 1: skip + 200]
             if ln.strip() and not ln.lstrip().startswith("#")]
    if len(head) >= 65536:
        lines = lines[:-1]  # may be cut
    sep = None if delim == "whitespace" else delim
    comma = dot = 0
    for ln in lines:
        for tok in ln.split(sep):
            tok = tok.strip().strip('"')
            if _COMMA_DECIMAL.match(tok):
                comma += 1
            elif _DOT_DECIMAL.match(tok):
                dot += 1
    return "," if comma and not dot else "."


def _bad_binary(source: str):
    raise InputError(f"{source}: Parquet/Feather cannot be read from stdin; pass the file path")


NULL_VALUES = ["", "NA", "N/A", "null", "NULL", "-"]
#: text files at least this large are read by the streaming reader straight into float64 arrays
STREAM_MIN_BYTES = 128 << 20
#: bytes of text parsed at a time by the streaming reader
RANGE_BYTES = 64 << 20


@contextlib.contextmanager
def _quiet_invalid_row_handler():
    """pyarrow decodes an invalid row as UTF-8 *before* calling :func:`_skip_comment_rows`;
    undecodable bytes raise there, inside a callback, and Python prints the traceback as
    "Exception ignored in ..." — the row is still reported as an error, so silence that print
    while a CSV is parsed."""
    old = sys.unraisablehook

    def hook(unraisable):
        if unraisable.object is not _skip_comment_rows:
            old(unraisable)

    sys.unraisablehook = hook
    try:
        yield
    finally:
        sys.unraisablehook = old


def _csv_options(delim: str, skip: int, names: list[str], columns: list[str] | None,
                 column_types: dict | None = None, *, decimal: str = "."):
    import pyarrow.csv as pcsv

    # the header line is skipped and our own (stripped) names are used, so that a padded
    # header such as "rate , temp" still matches --rate-col rate
    read_opts = pcsv.ReadOptions(skip_rows=skip + 1, column_names=names, use_threads=True,
                                 block_size=1 << 22)
    parse_opts = pcsv.ParseOptions(delimiter=delim, invalid_row_handler=_skip_comment_rows,
                                   ignore_empty_lines=True)
    conv_opts = pcsv.ConvertOptions(include_columns=columns, strings_can_be_null=True,
                                    null_values=NULL_VALUES, column_types=column_types,
                                    decimal_point=decimal)
    return read_opts, parse_opts, conv_opts


def _stream_numeric(path: Path, delim: str, skip: int, names: list[str],
                    columns: list[str] | None, *, decimal: str = "."
                    ) -> dict[str, np.ndarray] | None:
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
        from .fastcsv import data_start_and_capacity

        pos, cap = data_start_and_capacity(fh.read(1 << 22), skip, size)
        out = {c: np.empty(cap) for c in cols}
        read_opts = pcsv.ReadOptions(column_names=names, use_threads=True, block_size=1 << 22)
        parse_opts = pcsv.ParseOptions(delimiter=delim, invalid_row_handler=_skip_comment_rows,
                                       ignore_empty_lines=True)
        conv_opts = pcsv.ConvertOptions(include_columns=cols, strings_can_be_null=True,
                                        null_values=NULL_VALUES, decimal_point=decimal,
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
            with _quiet_invalid_row_handler():
                tbl = pcsv.read_csv(pa.BufferReader(pa.py_buffer(view[:cut])),
                                    read_options=read_opts, parse_options=parse_opts,
                                    convert_options=conv_opts)
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
                    names: list[str], *, decimal: str = ".") -> pa.Table:
    import pyarrow.csv as pcsv

    read_opts, parse_opts, conv_opts = _csv_options(delim, skip, names, columns, decimal=decimal)
    try:
        with _quiet_invalid_row_handler():
            return pcsv.read_csv(src, read_options=read_opts, parse_options=parse_opts,
                                 convert_options=conv_opts)
    except pa.ArrowInvalid as e:
        msg = str(e)
        m = re.search(r"Expected (\d+) columns, got (\d+): (.*)", msg)
        if m:
            raise InputError(f"{source}: a row has {m.group(2)} fields where the header has "
                             f"{m.group(1)}: {m.group(3)[:60]!r}; fix or delete that line") from None
        if "straddl" in msg:
            raise InputError(f"{source}: a line longer than {4 << 20 >> 20} MiB; a bench log has "
                             "short lines: check the line endings (or the file)") from None
        if "Empty CSV file" in msg:
            raise InputError(f"{source}: no data") from None
        raise InputError(f"{source}: cannot parse as a {('TSV' if delim == chr(9) else 'CSV')} "
                         f"table: {msg.splitlines()[0][:200]}") from None


def _read_whitespace(src, source: str, skip: int, columns: list[str] | None, *,
                     decimal: str = ".") -> pa.Table:
    import pandas as pd

    try:
        df = pd.read_csv(src, sep=r"\s+", skiprows=skip, comment="#", usecols=columns,
                         engine="c", decimal=decimal)
    except (ValueError, pd.errors.ParserError) as e:
        raise InputError(f"{source}: cannot parse as a whitespace-separated table: "
                         f"{str(e).splitlines()[0][:200]}") from None
    try:
        return pa.Table.from_pandas(df, preserve_index=False)
    except (OverflowError, pa.ArrowException):
        # an object column Arrow cannot type (integers beyond 64 bits, mixed values): as text,
        # so the column conversion reports the row
        obj = [c for c in df.columns if df[c].dtype == object]
        return pa.Table.from_pandas(df.astype({c: str for c in obj}).where(df.notna(), None),
                                    preserve_index=False)


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
    if str(path) == "-":
        return []
    raw = read_table(path, _names_only=True)
    if raw.fmt == "parquet":
        import pyarrow.parquet as pq

        try:
            return list(pq.read_schema(raw.path).names)
        except Exception:  # a corrupt file: the full read reports it
            return []
    if raw.fmt == "feather":
        import pyarrow.feather as feather

        try:
            return list(feather.read_table(raw.path, memory_map=True).schema.names)
        except Exception:
            return []
    return raw.table.column_names


# ----------------------------------------------------------------------------- conversion
def _column_to_float(raw: RawTable, col: str, role: str) -> np.ndarray:
    """A column as float64 with NaN for missing cells; a non-numeric cell is an error naming
    the row."""
    if col in raw.owned and col in raw.exclusive:
        return raw.owned.pop(col)  # writeable float64 from the streaming reader: no copy
    arr = raw.table.column(col)
    t = arr.type
    if pa.types.is_floating(t) or pa.types.is_integer(t) or pa.types.is_boolean(t):
        from .fastcsv import float64_values  # Arrow's to_numpy would import pandas

        out = float64_values(arr)
        # a zero-copy view of an Arrow buffer can be writeable (buffers decoded from
        # Parquet are mutable): callers shift and scale in place, so always own the data
        if out.base is not None or not out.flags.writeable:
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
        out = num.to_numpy(dtype=np.float64, na_value=np.nan)
        return out if out.flags.writeable else out.copy()  # callers convert units in place
    raise InputError(f"{raw.source}: column {col!r} ({role}) has type {t}, expected numbers")

