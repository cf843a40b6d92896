"""Fast path for plain numeric text logs: CSV/TSV straight into float64 arrays.

Most bench logs are a header line and rows of plain numbers. This reader parses such a file
with pyarrow's CSV parser, every used column forced to float64, in ranges of
:data:`RANGE_BYTES` cut at line ends, and copies each range into preallocated float64 arrays
that the log then owns (no Arrow → numpy concatenation, no second copy of the record).

Why this shape (measured on the 2-core VM, 10^7 rows, 290 MB; ``benchmarks/bench_speed.py``
and ``benchmarks/README.md``):

* single-threaded pyarrow reads cost 0.85–0.9 s of CPU per 290 MB, its multithreaded mode
  1.4–1.5 s for no gain in wall time on a busy machine; so ranges are parsed single-threaded,
  two ranges at a time on a small thread pool (pyarrow releases the GIL), which keeps the
  single-thread CPU cost and still uses both cores when they are free;
* polars 2.1 was measured as an alternative: 1.0 s CPU for the same file (no faster) for a
  181 MB install, so it is not used;
* the columns are taken out of Arrow with ``numpy.frombuffer`` on the value buffers: Arrow's
  ``to_numpy``/``pa.array`` import pandas on first use (≈ 0.3–0.5 s), which a small log would
  otherwise pay on every call.

Anything that is not plain numbers (timestamps, text, quotes across a range cut, a ragged row)
makes :func:`read_numeric` return None and the caller falls back to the general reader, which
also produces the precise error messages. Missing cells (``NA``, empty …) become NaN, as in
the general reader.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

#: bytes of text parsed per range (and per task of the thread pool)
RANGE_BYTES = 16 << 20
#: cells read as missing (NaN), as in :data:`gyrotest.io.ingest.NULL_VALUES`
NULL_VALUES = ["", "NA", "N/A", "null", "NULL", "-"]


def _skip_comment_rows(row):
    """pyarrow invalid-row handler: skip ``#`` comment lines in the middle of a file."""
    try:
        text = row.text
    except UnicodeDecodeError:  # undecodable bytes in the row: pyarrow reports the row
        return "error"
    if text.lstrip().startswith("#") or not text.strip():
        return "skip"
    return "error"


def _ranges(fh, start: int, nbuf: int, step: int):
    """Byte ranges of whole lines, about ``step`` bytes each, as memoryviews into
    ``nbuf`` reused buffers taken in turn (the last partial line is carried to the next range).
    Fresh memory is expensive to touch on the VM (page faults: 0.5–2 s of system time per GB),
    so the 16 MB buffers are recycled; a view must be consumed before ``nbuf − 1`` more ranges
    are taken."""
    fh.seek(start)
    bufs = [bytearray(step + (1 << 16)) for _ in range(nbuf)]
    carry = b""
    i = 0
    while True:
        buf = bufs[i % nbuf]
        i += 1
        held = len(carry)
        if held + step > len(buf):  # a line longer than the slack: grow this buffer
            buf = bufs[(i - 1) % nbuf] = bytearray(held + step)
        view = memoryview(buf)
        view[:held] = carry
        got = fh.readinto(view[held:held + step])
        end = held + got
        if not got:
            if bytes(view[:end]).strip():
                yield view[:end]
            return
        cut = buf.rfind(b"\n", 0, end) + 1
        if cut == 0:
            carry = bytes(view[:end])
            continue
        carry = bytes(view[cut:end])
        yield view[:cut]


def data_start_and_capacity(head: bytes, skip: int, size: int) -> tuple[int, int]:
    """Byte offset of the first data row (after ``skip`` comment lines and the header) in the
    file's first bytes ``head``, and a row capacity for the ``size``-byte file from the mean
    row length of the sample (2 % and 1024 rows of slack). ValueError when ``head`` holds
    fewer lines."""
    pos = 0
    for _ in range(skip + 1):  # comment lines and the header
        pos = head.index(b"\n", pos) + 1
    body = head[pos:]
    per_row = len(body) / max(body.count(b"\n"), 1)
    return pos, int((size - pos) / max(per_row, 1.0) * 1.02) + 1024


def int64_values(chunked) -> np.ndarray:
    """int64 numpy values of a null-free integer pyarrow (Chunked)Array (ns epochs keep every
    digit), without Arrow's ``to_numpy`` (which imports pandas on first use)."""
    import pyarrow as pa

    chunks = chunked.chunks if hasattr(chunked, "chunks") else [chunked]
    parts = []
    for chunk in chunks:
        if chunk.type != pa.int64():
            chunk = chunk.cast(pa.int64())
        buf = chunk.buffers()[1]
        parts.append(np.zeros(len(chunk), np.int64) if buf is None else
                     np.frombuffer(buf, dtype=np.int64, count=len(chunk),
                                   offset=chunk.offset * 8))
    return np.concatenate(parts) if parts else np.empty(0, np.int64)


def float64_values(chunked) -> np.ndarray:
    """float64 numpy values of a numeric pyarrow (Chunked)Array, nulls as NaN, without Arrow's
    ``to_numpy`` (which imports pandas, ≈ 0.4 s, on first use). Zero-copy (read-only) for a
    single null-free float64 chunk, one concatenation otherwise."""
    import pyarrow as pa

    chunks = chunked.chunks if hasattr(chunked, "chunks") else [chunked]
    parts = []
    for chunk in chunks:
        if chunk.type != pa.float64():
            chunk = chunk.cast(pa.float64(), safe=False)  # ints beyond 2^53 round, as numpy
        if chunk.null_count:
            chunk = chunk.fill_null(float("nan"))
        buf = chunk.buffers()[1]
        if buf is None:  # an all-null / empty chunk
            parts.append(np.full(len(chunk), np.nan))
            continue
        parts.append(np.frombuffer(buf, dtype=np.float64, count=len(chunk),
                                   offset=chunk.offset * 8))
    if len(parts) == 1:
        return parts[0]
    return np.concatenate(parts) if parts else np.empty(0)


def read_numeric(path: Path, delim: str, skip: int, names: list[str],
                 columns: list[str] | None, *, threads: int | None = None
                 ) -> dict[str, np.ndarray] | None:
    """Read the ``columns`` (default all ``names``) of a delimited text file of plain numbers.

    ``skip`` = comment lines before the header; the header line itself is skipped and
    ``names`` used. Returns writeable float64 arrays (NaN for missing cells), or None when the
    file is not plain numbers (the caller then uses the general reader)."""
    import pyarrow as pa
    import pyarrow.csv as pcsv

    if delim not in (",", ";", "\t", "|"):
        return None
    cols = list(columns or names)
    try:
        size = path.stat().st_size
        fh = open(path, "rb")
    except OSError:
        return None
    read_opts = pcsv.ReadOptions(column_names=names, use_threads=False, block_size=1 << 24)
    parse_opts = pcsv.ParseOptions(delimiter=delim, invalid_row_handler=_skip_comment_rows,
                                   ignore_empty_lines=True)
    conv_opts = pcsv.ConvertOptions(include_columns=cols, strings_can_be_null=True,
                                    null_values=NULL_VALUES,
                                    column_types={c: pa.float64() for c in cols})

    # the parsed ranges live until take() copies them out: glibc's heap (tuned by
    # gyrotest._runtime for whole-log reads) reuses their pages; Arrow's default mimalloc pool
    # cost 0.1–0.5 s more system time per 290 MB on the reference VM (benchmarks/README.md)
    arrow_pool = pa.system_memory_pool()

    def parse(data: memoryview):
        tbl = pcsv.read_csv(pa.BufferReader(pa.py_buffer(data)), read_options=read_opts,
                            parse_options=parse_opts, convert_options=conv_opts,
                            memory_pool=arrow_pool)
        return tbl.num_rows, [float64_values(tbl.column(c)) for c in cols]

    try:
        with fh:
            pos, cap = data_start_and_capacity(fh.read(1 << 16), skip, size)
            out = [np.empty(cap) for _ in cols]
            n = 0

            def take(res) -> None:
                nonlocal n, cap, out
                k, vals = res
                if n + k > cap:
                    cap = max(int(cap * 1.25), n + k)
                    grown = [np.empty(cap) for _ in cols]
                    for g, o in zip(grown, out):
                        g[:n] = o[:n]
                    out = grown
                for o, v in zip(out, vals):
                    o[n:n + k] = v
                n += k

            if size - pos <= RANGE_BYTES:
                for data in _ranges(fh, pos, 1, size - pos + 1):
                    take(parse(data))
            else:
                workers = threads or min(2, os.cpu_count() or 1)
                with ThreadPoolExecutor(max_workers=workers) as pool:
                    pending = []
                    for data in _ranges(fh, pos, workers + 2, RANGE_BYTES):
                        pending.append(pool.submit(parse, data))
                        if len(pending) > workers:  # bounded: ≈ (workers + 1) ranges in flight
                            take(pending.pop(0).result())
                    for f in pending:
                        take(f.result())
    except (pa.ArrowInvalid, ValueError, OSError, KeyError):
        return None
    return {c: o[:n] for c, o in zip(cols, out)}


def arrow_table(arrays: dict[str, np.ndarray], names: list[str]):
    """A pyarrow Table viewing float64 ``arrays`` (zero-copy, without pyarrow's pandas shim)."""
    import pyarrow as pa

    cols = [pa.Array.from_buffers(pa.float64(), len(arrays[c]),
                                  [None, pa.py_buffer(np.ascontiguousarray(arrays[c]))])
            for c in names]
    return pa.Table.from_arrays(cols, names=list(names))
