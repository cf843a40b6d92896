"""Fast, exact reader for plain numeric CSV/TSV text: the common bench-log case.

:func:`read_numeric_table` is the hook :func:`gyrotest.ingest.read_table` calls for a text
file before the general pyarrow reader. It returns the table the pyarrow path would produce
for the used columns, or ``None`` — and then the pyarrow path reads the file and gives its
usual (error) messages. It never raises on bad input.

Handled: the header found by ``_sniff_text`` with ``#``/blank lines before it; a one-byte
delimiter (``,`` ``\\t`` ``;`` ``|``); LF or CRLF line ends, blank lines, a last line without
newline; numeric cells (optional sign, decimal/exponent floats, integers, ``.5``, ``5.``,
``nan``/``inf``/``infinity`` in any case, spaces around a number) and the null cells of the
pyarrow path (empty, ``NA``, ``N/A``, ``null``, ``NULL``, ``-``). Unused columns are skipped,
not parsed. Anything else — a quote, text or a timestamp in a used column, a comment inside
the data, a ragged row, a lone CR, a byte order mark — hands the file over to pyarrow.

Exactness: every value is the correctly rounded double, bit for bit ``float(text)``.
Clinger's fast path when the decimal mantissa is <= 2^53 and the power of ten within ±22 (one
exact multiply/divide); otherwise Eisel–Lemire on the first 19 significant digits (128-bit
products with a table of truncated powers of five; always decisive for 19 digits, Mushtak &
Lemire 2023). With more digits the result stands when the truncated mantissa w and w + 1
round alike; the rare undecided field is converted afterwards with ``float()``.

Typing follows pyarrow's inference: integer-only columns become int64 (so ``-0`` there is 0,
as before), others float64; null cells are Arrow nulls, an all-null column has the null type.

Speed: numba kernels (``nogil``, cached on disk; numba is imported and the kernels compiled
or loaded on first use only, so importing this module is cheap). The file is memory-mapped
and read in windows of ``threads × PART_BYTES`` split at newlines: per part the lines are
counted (row offsets), then the part is parsed by one thread straight into preallocated
column arrays — no Arrow builders, no concatenation; the pages behind are released, so
resident memory stays about one window above the arrays.

Only files of at least ``MIN_BYTES`` take the fast path (``WARM_MIN_BYTES`` once the kernels
are loaded in the process): below that numba's one-off start-up cost is not repaid. Without a
writable numba cache (in-tree ``__pycache__``, the user cache, or ``NUMBA_CACHE_DIR``) the
kernels compile in every process, and only files from ``UNCACHED_MIN_BYTES`` take the path.

Environment: ``GYROTEST_FASTCSV=0`` disables the fast path, ``=strict`` re-raises internal
errors instead of falling back (for tests); ``GYROTEST_FASTCSV_MIN_BYTES`` sets the size
threshold; ``GYROTEST_FASTCSV_THREADS`` the number of threads.
"""

from __future__ import annotations

import csv
import logging
import mmap
import os
import threading
from concurrent.futures import ThreadPoolExecutor

import numpy as np

log = logging.getLogger(__name__)

# Below MIN_BYTES pyarrow wins: numba's one-off cost in a process (import, target set-up,
# loading the cached kernels: ~0.5-1 s of CPU) outweighs the faster parse. Measured break-even
# on the 2-core test machine: ~200 MB of text (10^7 rows of 4 columns = 660 MB). Once the
# kernels are loaded, files from WARM_MIN_BYTES up take the fast path.
MIN_BYTES = 256 << 20
WARM_MIN_BYTES = 16 << 20
UNCACHED_MIN_BYTES = 2 << 30  # no writable numba cache: every process compiles (~5 s)
PART_BYTES = 4 << 20  # bytes of text per thread and window
HARD_CAP = 1 << 14  # undecided fields per part left to float(); more: hand over to pyarrow
DELIMS = (",", "\t", ";", "|")
NULL_BITS = 0x7FF800006E756C6C  # quiet-NaN payload marking a null cell while parsing
OK, FALLBACK = 0, 1  # kernel status

# ----------------------------------------------------------------------------- tables


def _pow5_tables() -> tuple[np.ndarray, np.ndarray]:
    """128-bit truncated 5^q for q in [-342, 308] with bit 127 set, as (high, low) words —
    the table of fast_float / Lemire, computed exactly with Python integers."""
    hi, lo = [], []
    for q in range(-342, 309):
        if q < 0:
            p5 = 5 ** -q
            z = p5.bit_length()  # 2^(z-1) < 5^-q < 2^z
            if q >= -27:
                c = (1 << (z + 127)) // p5 + 1
            else:
                c = (1 << (2 * z + 128)) // p5 + 1
                c >>= max(0, c.bit_length() - 128)
        else:
            c = 5 ** q
            c = c << (128 - c.bit_length()) if c.bit_length() <= 128 else c >> (c.bit_length() - 128)
        hi.append(c >> 64)
        lo.append(c & ((1 << 64) - 1))
    return np.array(hi, dtype=np.uint64), np.array(lo, dtype=np.uint64)


_P5HI, _P5LO = _pow5_tables()
_P10 = np.array([float(f"1e{k}") for k in range(23)])  # exactly representable
_P10U = np.array([10 ** k for k in range(9)], dtype=np.uint64)
_POW2 = np.ldexp(1.0, np.arange(2048) - 1075)  # value = 53-bit mantissa * _POW2[biased exp]
_SUB = 2.0 ** -1074
_W_NAN = np.frombuffer(b"nan", dtype=np.uint8).copy()
_W_INF = np.frombuffer(b"inf", dtype=np.uint8).copy()
_W_INFINITY = np.frombuffer(b"infinity", dtype=np.uint8).copy()

_U = np.uint64
_U1, _U3, _U8, _U10 = _U(1), _U(3), _U(8), _U(10)
_S3, _S8, _S16, _S32, _S63 = _U(3), _U(8), _U(16), _U(32), _U(63)
_M32 = _U(0xFFFFFFFF)
_TWO52, _TWO53 = _U(1 << 52), _U(1 << 53)
_MASK9 = _U(0x1FF)  # Eisel–Lemire: the low bits of the product that may be inexact
_NULL = _U(NULL_BITS)
_INT64_MAX = _U((1 << 63) - 1)
_E8 = _U(100_000_000)
_ZEROS = _U(0x3030303030303030)  # eight ASCII '0'
_K76 = _U(0x7676767676767676)
_HIBITS = _U(0x8080808080808080)
_MASK8 = _U(0x000000FF000000FF)
_MUL1 = _U(0x000F424000000064)  # 100 + (1000000 << 32)
_MUL2 = _U(0x0000271000000001)  # 1 + (10000 << 32)

# ----------------------------------------------------------------------------- kernels
# Plain functions here; _kernels() imports numba and replaces each by its compiled version
# (module-level functions, so numba's on-disk cache finds them again in the next process).
_KERNELS: list[str] = []
types = ir = leading_zeros = trailing_zeros = None  # bound by _kernels()


def _kernel(fn):
    _KERNELS.append(fn.__name__)
    return fn


def _ld(typingctx, arr, idx):
    """Intrinsic ``arr[idx]`` of a uint8 array without numba's negative-index wrap-around
    (which costs a compare and a select on every byte and blocks vectorisation)."""
    if not isinstance(arr, types.Array) or arr.dtype != types.uint8:
        return None
    sig = types.uint8(arr, types.intp)

    def codegen(context, builder, signature, args):
        ary = context.make_array(signature.args[0])(context, builder, args[0])
        return builder.load(builder.gep(ary.data, [args[1]]))

    return sig, codegen


def _load_u64(typingctx, arr, idx):
    """Intrinsic: the 8 bytes ``arr[idx:idx + 8]`` as one unaligned little-endian uint64."""
    if not isinstance(arr, types.Array) or arr.dtype != types.uint8:
        return None
    sig = types.uint64(arr, types.intp)

    def codegen(context, builder, signature, args):
        ary = context.make_array(signature.args[0])(context, builder, args[0])
        ptr = builder.bitcast(builder.gep(ary.data, [args[1]]), ir.IntType(64).as_pointer())
        return builder.load(ptr, align=1)

    return sig, codegen


_INTRINSICS = ("_ld", "_load_u64")


@_kernel
def _mul128(a, b):
    """The 128-bit product of two uint64 as (high, low) words."""
    a_lo = a & _M32
    a_hi = a >> _S32
    b_lo = b & _M32
    b_hi = b >> _S32
    p0 = a_lo * b_lo
    p1 = a_lo * b_hi
    p2 = a_hi * b_lo
    p3 = a_hi * b_hi
    mid = (p0 >> _S32) + (p1 & _M32) + (p2 & _M32)
    lo = (p0 & _M32) | (mid << _S32)
    hi = p3 + (p1 >> _S32) + (p2 >> _S32) + (mid >> _S32)
    return hi, lo


@_kernel
def _eisel_lemire(w, q):
    """The double nearest to w · 10^q for a uint64 w (Eisel–Lemire, as in fast_float)."""
    if w == 0 or q < -342:
        return 0.0
    if q > 308:
        return np.inf
    lz = leading_zeros(w)
    w = w << lz
    idx = q + 342
    hi, lo = _mul128(w, _P5HI[idx])
    if (hi & _MASK9) == _MASK9:  # the low bits may be off: add the next 64 bits of 5^q
        hi2, _ = _mul128(w, _P5LO[idx])
        lo = lo + hi2
        if hi2 > lo:
            hi = hi + _U1
    upper = hi >> _S63
    shift = upper + _U(9)
    mant = hi >> shift
    power2 = ((np.int64(217706) * q) >> 16) + 63 + np.int64(upper) - np.int64(lz) + 1023
    if power2 <= 0:  # subnormal
        if 1 - power2 >= 64:
            return 0.0
        mant = mant >> _U(1 - power2)
        mant = mant + (mant & _U1)
        mant = mant >> _U1
        return np.float64(mant) * _SUB  # exact: mant < 2^53
    if lo <= _U1 and q >= -4 and q <= 23 and (mant & _U3) == _U1:
        if (mant << shift) == hi:  # exactly half-way: round to even
            mant = mant & ~_U1
    mant = mant + (mant & _U1)
    mant = mant >> _U1
    if mant >= _TWO53:
        mant = _TWO52
        power2 += 1
    if power2 >= 2047:
        return np.inf
    return np.float64(mant) * _POW2[power2]  # exact: a 53-bit integer times a power of two


@_kernel
def _to_double(w, q):
    """w · 10^q correctly rounded, w exact (at most 19 digits)."""
    if w <= _TWO53 and q >= -22 and q <= 22:  # Clinger: one correctly rounded operation
        x = np.float64(w)
        if q < 0:
            return x / _P10[-q]
        return x * _P10[q]
    return _eisel_lemire(w, q)


@_kernel
def _digits(buf, i, e, w):
    """Append the decimal digits at ``i`` to ``w`` (wrapping past 19 digits: the caller
    counts them); return (w, position after them). Eight bytes at a time while
    ``i + 8 <= e`` (SWAR as in fast_float: digits found with one add/or/mask, converted with
    three multiplies), the rest byte by byte."""
    while i + 8 <= e:
        x = _load_u64(buf, i) ^ _ZEROS  # digit bytes -> 0..9
        m = ((x + _K76) | x) & _HIBITS  # the high bit of every byte that is not a digit
        if m == 0:
            x = x * _U10 + (x >> _S8)
            x = (((x & _MASK8) * _MUL1) + (((x >> _S16) & _MASK8) * _MUL2)) >> _S32
            w = w * _E8 + (x & _M32)
            i += 8
            continue
        # digits before the first non-digit (carries only run upwards, so the lowest
        # flagged byte is right)
        n = trailing_zeros(m) >> _S3
        if n == 0:
            return w, i
        x = x << ((_U8 - n) << _S3)  # the n digits to the top, zeros below
        x = x * _U10 + (x >> _S8)
        x = (((x & _MASK8) * _MUL1) + (((x >> _S16) & _MASK8) * _MUL2)) >> _S32
        return w * _P10U[n] + (x & _M32), i + np.int64(n)
    while True:
        d = np.int64(_ld(buf, i)) - 48
        if d < 0 or d > 9:
            break
        w = w * _U10 + _U(d)
        i += 1
    return w, i


@_kernel
def _rescan(buf, i, e10):
    """A mantissa of more than 19 digits at ``i`` (after the sign): its first 19
    significant digits, the power of ten, and whether nonzero digits were cut off."""
    w = _U(0)
    nsig = 0
    q = 0
    cut = False
    dot = False
    started = False
    while True:
        c = _ld(buf, i)
        if c == 46:
            dot = True
            i += 1
            continue
        d = np.int64(c) - 48
        if d < 0 or d > 9:
            break
        if d == 0 and not started:
            if dot:
                q -= 1
        else:
            started = True
            if nsig < 19:
                w = w * _U10 + _U(d)
                nsig += 1
                if dot:
                    q -= 1
            else:
                if d != 0:
                    cut = True
                if not dot:
                    q += 1
        i += 1
    return w, q + e10, cut


@_kernel
def _match(buf, i, word):
    """Case-insensitive match of the lower-case ASCII ``word`` at ``i``."""
    for k in range(word.shape[0]):
        c = _ld(buf, i + k)
        if 65 <= c <= 90:
            c = c | 32
        if c != word[k]:
            return False
    return True


@_kernel
def _special(buf, fs, fe):
    """A cell without digits: (kind, value) with kind 0 = value (nan/inf), 1 = null,
    2 = something else."""
    n = fe - fs
    # the null tokens of the pyarrow path (untrimmed, case-sensitive)
    if n == 0:
        return 1, 0.0
    c0 = _ld(buf, fs)
    if n == 1 and c0 == 45:  # "-"
        return 1, 0.0
    if n == 2 and c0 == 78 and _ld(buf, fs + 1) == 65:  # "NA"
        return 1, 0.0
    if n == 3 and c0 == 78 and _ld(buf, fs + 1) == 47 and _ld(buf, fs + 2) == 65:  # "N/A"
        return 1, 0.0
    if n == 4:
        c1, c2, c3 = _ld(buf, fs + 1), _ld(buf, fs + 2), _ld(buf, fs + 3)
        if (c0 == 110 and c1 == 117 and c2 == 108 and c3 == 108) or (
                c0 == 78 and c1 == 85 and c2 == 76 and c3 == 76):  # "null", "NULL"
            return 1, 0.0
    # nan / inf / infinity, any case, optional sign, spaces around (trimmed like pyarrow)
    while fs < fe and _ld(buf, fs) == 32:
        fs += 1
    while fe > fs and _ld(buf, fe - 1) == 32:
        fe -= 1
    neg = False
    if fs < fe and (_ld(buf, fs) == 45 or _ld(buf, fs) == 43):
        neg = _ld(buf, fs) == 45
        fs += 1
    n = fe - fs
    if n == 3 and _match(buf, fs, _W_NAN):
        v = np.nan
    elif (n == 3 and _match(buf, fs, _W_INF)) or (n == 8 and _match(buf, fs, _W_INFINITY)):
        v = np.inf
    else:
        return 2, 0.0
    return 0, -v if neg else v


@_kernel
def _count_lines(buf, s, e):
    sub = buf[s:e]
    n = 0
    for i in range(sub.shape[0]):  # an index numba knows is >= 0: vectorised
        if sub[i] == 10:
            n += 1
    return n


@_kernel
def _parse_part(buf, s, e, delim, colmap, out, bits, row0, hard, stats):
    """Parse the rows of ``buf[s:e]`` (which ends with a newline) into ``out[k, row0:]``.

    ``colmap[j]``: the output row of column j, or -1 to skip it. ``bits`` is ``out`` viewed
    as uint64 (a null cell gets the NULL_BITS payload). ``hard`` collects (row, k, start,
    end) of fields left to ``float()``; ``stats[k, 0]`` counts the nulls of column k,
    ``stats[k, 1]`` is set by a cell pyarrow would not type int64. Returns (rows, fields in
    ``hard``, status, position of the problem).
    """
    ncols = colmap.shape[0]
    hcap = hard.shape[0]
    nhard = 0
    row = row0
    i = s
    while i < e:
        c = _ld(buf, i)
        if c == 10:  # blank line
            i += 1
            continue
        if c == 13 and _ld(buf, i + 1) == 10:
            i += 2
            continue
        if c == 35:  # '#': a comment inside the data
            return row - row0, nhard, FALLBACK, i
        for j in range(ncols):
            k = colmap[j]
            if k < 0:  # an unused column: skip to the next delimiter or line end
                while True:
                    c = _ld(buf, i)
                    if c == delim or c == 10 or c == 13:
                        break
                    if c == 34:  # a quote: pyarrow handles quoting
                        return row - row0, nhard, FALLBACK, i
                    i += 1
            else:
                fs = i
                while _ld(buf, i) == 32:
                    i += 1
                neg = False
                c = _ld(buf, i)
                if c == 45:
                    neg = True
                    i += 1
                elif c == 43:
                    i += 1
                    stats[k, 1] = 1  # pyarrow types "+5" as double, not int64
                ms = i
                w, i = _digits(buf, i, e, _U(0))
                nint = i - ms
                nfrac = 0
                isint = True
                if _ld(buf, i) == 46:
                    isint = False
                    f0 = i + 1
                    w, i = _digits(buf, f0, e, w)
                    nfrac = i - f0
                nd = nint + nfrac
                if nd == 0:  # no digits: null, nan/inf, or not a number
                    fe = fs
                    while True:
                        c = _ld(buf, fe)
                        if c == delim or c == 10 or c == 13:
                            break
                        fe += 1
                    kind, v = _special(buf, fs, fe)
                    if kind == 2:
                        return row - row0, nhard, FALLBACK, fs
                    if kind == 1:
                        bits[k, row] = _NULL
                        stats[k, 0] += 1
                    else:
                        out[k, row] = v
                        stats[k, 1] = 1
                    i = fe
                else:
                    e10 = 0
                    c = _ld(buf, i)
                    if c == 101 or c == 69:  # exponent
                        isint = False
                        i += 1
                        eneg = False
                        c = _ld(buf, i)
                        if c == 45:
                            eneg = True
                            i += 1
                        elif c == 43:
                            i += 1
                        es = i
                        while True:
                            d = np.int64(_ld(buf, i)) - 48
                            if d < 0 or d > 9:
                                break
                            if e10 < 100000:
                                e10 = e10 * 10 + d
                            i += 1
                        if i == es:  # "1e", "1e+": not a number
                            return row - row0, nhard, FALLBACK, fs
                        if eneg:
                            e10 = -e10
                    while _ld(buf, i) == 32:
                        i += 1
                    c = _ld(buf, i)
                    if not (c == delim or c == 10 or c == 13):  # "1.5x", "1 2", ...
                        return row - row0, nhard, FALLBACK, fs
                    if not isint:
                        stats[k, 1] = 1
                    if nd <= 19:
                        if isint and nd == 19 and w > _INT64_MAX:
                            stats[k, 1] = 1  # beyond int64: pyarrow types it double
                        v = _to_double(w, e10 - nfrac)
                    else:
                        if isint:  # a long integer: leave pyarrow's int64/double choice to it
                            return row - row0, nhard, FALLBACK, fs
                        w, q, cut = _rescan(buf, ms, e10)
                        if not cut:
                            v = _to_double(w, q)
                        else:
                            v = _eisel_lemire(w, q)
                            if v != _eisel_lemire(w + _U1, q):  # undecided: float() later
                                if nhard >= hcap:
                                    return row - row0, nhard, FALLBACK, fs
                                hard[nhard, 0] = row
                                hard[nhard, 1] = k
                                hard[nhard, 2] = fs
                                hard[nhard, 3] = i
                                nhard += 1
                    out[k, row] = -v if neg else v
            # after a field: a delimiter, or the line end after the last column
            c = _ld(buf, i)
            if j < ncols - 1:
                if c != delim:  # too few fields
                    return row - row0, nhard, FALLBACK, i
                i += 1
            else:
                if c == 13:
                    i += 1
                    c = _ld(buf, i)
                if c != 10:  # too many fields, or a lone CR
                    return row - row0, nhard, FALLBACK, i
                i += 1
        row += 1
    return row - row0, nhard, OK, i


_READY: bool | None = None
_CACHED = True  # the kernels are cached on disk (else compiled in every process)
_WARM = False  # the kernels have run in this process (no start-up cost left)
_LOCK = threading.Lock()


def _kernels() -> bool:
    """Import numba and compile (or load from its cache) the kernels, once. False when
    numba is not installed."""
    global _READY, _CACHED, types, ir, leading_zeros, trailing_zeros
    with _LOCK:
        if _READY is not None:
            return _READY
        try:
            import numba
            from llvmlite import ir as _ir
            from numba.core import types as _types
            from numba.cpython.unsafe.numbers import leading_zeros as _lz
            from numba.cpython.unsafe.numbers import trailing_zeros as _tz
            from numba.extending import intrinsic
        except ImportError:
            _READY = False
            return False
        types, ir, leading_zeros, trailing_zeros = _types, _ir, _lz, _tz
        g = globals()
        for name in _INTRINSICS:
            g[name] = intrinsic(g[name])
        for name in _KERNELS:
            try:
                g[name] = numba.njit(nogil=True, cache=True)(g[name])
            except RuntimeError:  # no writable cache location: compile in every process
                g[name] = numba.njit(nogil=True)(g[name])
                _CACHED = False
        _READY = True
        return True


# ----------------------------------------------------------------------------- driver
def _setting(name: str, default: int) -> int:
    env = os.environ.get(name, "").strip()
    return int(env) if env.isdigit() else default


def _threads() -> int:
    try:
        n = len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        n = os.cpu_count() or 1
    return max(1, _setting("GYROTEST_FASTCSV_THREADS", min(n, 16)))


# line breaks of str.splitlines() that _sniff_text would count and pyarrow would not
_BREAKS = ("\r", "\x0b", "\x0c", "\x1c", "\x1d", "\x1e", "\x85", "\u2028", "\u2029", "\ufeff")


def _data_start(mm, delim: str, skip: int, names: list[str]) -> int | None:
    """Byte offset of the first data line after ``skip`` comment/blank lines and the header,
    or None if those lines hold anything the pyarrow path might read differently."""
    pos = 0
    for lineno in range(skip + 1):
        nl = mm.find(b"\n", pos, pos + (1 << 20))
        if nl < 0:
            return None
        raw = mm[pos:nl]
        pos = nl + 1
        if raw.endswith(b"\r"):
            raw = raw[:-1]
        try:
            text = raw.decode("utf-8")
        except UnicodeDecodeError:
            return None
        if any(ch in text for ch in _BREAKS):
            return None
        if lineno < skip:
            s = text.strip()
            if '"' in text or (s and not s.startswith("#")):
                return None
            continue
        # the header: exactly the sniffed names (pyarrow keeps padding that the sniffer strips)
        try:
            fields = next(csv.reader([text], delimiter=delim))
        except (csv.Error, StopIteration):
            return None
        if fields != names or text.count('"') % 2:
            return None
    return pos


def read_numeric(path: str | os.PathLike, delim: str, skip: int, names: list[str],
                 columns: list[str] | None = None, *, part_bytes: int = PART_BYTES,
                 threads: int | None = None):
    """Parse the columns ``columns`` (default: all) of a delimited numeric text file.

    ``skip`` lines (comments/blank) precede the header, whose fields are ``names``. Returns
    ``(wanted, values, nulls, intlike)``: the column names; a float64 array of shape
    (len(wanted), rows) whose rows are the columns (each contiguous); a dict name -> boolean
    mask of the null cells (NaN in ``values``) for columns that have any; the set of names
    whose cells are all integers (pyarrow's int64). None when the file needs pyarrow.
    """
    if delim not in DELIMS or not _kernels():
        return None
    wanted = list(names) if columns is None else list(columns)
    if not wanted or len(set(wanted)) != len(wanted) or not set(wanted) <= set(names):
        return None
    colmap = np.array([wanted.index(n) if n in wanted else -1 for n in names], dtype=np.int64)
    threads = threads or _threads()
    part_bytes = max(int(part_bytes), 1)
    with open(path, "rb") as fh:
        size = os.fstat(fh.fileno()).st_size
        if size == 0:
            return None
        mm = mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ)
    try:
        start = _data_start(mm, delim, skip, names)
        if start is None or start >= size:
            return None
        return _parse_mapped(mm, start, size, ord(delim), wanted, colmap, threads, part_bytes)
    finally:
        try:
            mm.close()
        except BufferError:  # a traceback still holds a view: the GC unmaps it
            pass


def _parse_mapped(mm, start, size, delim, wanted, colmap, threads, part_bytes):
    nk = len(wanted)
    last_nl = mm.rfind(b"\n", start)
    body_end = last_nl + 1 if last_nl >= 0 else start  # [start, body_end): whole lines
    tail = mm[body_end:size]  # a last line without newline
    buf = np.frombuffer(mm, dtype=np.uint8)
    # capacity from the bytes per row of the first part (untouched pages cost no memory)
    probe = min(body_end, start + part_bytes)
    n_probe = int(_count_lines(buf, start, probe)) if probe > start else 0
    per_row = (probe - start) / n_probe if n_probe else 64.0
    cap = int((size - start) / per_row * 1.1) + 1024
    out = np.empty((nk, cap))
    stats = np.zeros((nk, 2), dtype=np.int64)
    hard = [np.empty((HARD_CAP, 4), dtype=np.int64) for _ in range(threads)]
    pool = ThreadPoolExecutor(threads) if threads > 1 else None
    run = pool.map if pool else map
    released, n, pos = 0, 0, start
    try:
        while pos < body_end or tail:
            if pos < body_end:  # a window: one part per thread, split at newlines
                parts = []
                while pos < body_end and len(parts) < threads:
                    e = min(pos + part_bytes, body_end)
                    if e < body_end:
                        e = mm.find(b"\n", e - 1, body_end) + 1
                    parts.append((buf, pos, e))
                    pos = e
            else:  # the last line, given a newline
                tb = np.frombuffer(tail + b"\n", dtype=np.uint8)
                parts, tail = [(tb, 0, len(tb))], b""
            counts = [int(c) for c in run(lambda a: _count_lines(*a), parts)]
            if n + sum(counts) > cap:
                cap = max(n + sum(counts), int((n + sum(counts)) * (size - start)
                                               / max(pos - start, 1) * 1.1))
                grown = np.empty((nk, cap))
                grown[:, :n] = out[:, :n]
                out = grown
            bits = out.view(np.uint64)
            offs = np.cumsum([n] + counts[:-1]).tolist()
            jobs = [(b, s, e, delim, colmap, out, bits, o, h, stats)
                    for (b, s, e), o, h in zip(parts, offs, hard)]
            res = list(run(lambda a: _parse_part(*a), jobs))
            for r in res:
                if r[2] != OK:
                    log.debug("fastcsv: handing over to pyarrow at byte %d", r[3])
                    return None
            # fields left to float(): more than 19 digits and undecided rounding
            for (b, _s, _e), r, h in zip(parts, res, hard):
                for row, k, fs, fe in h[: r[1]].tolist():
                    out[k, row] = float(bytes(b[fs:fe]))
            # blank lines leave holes in the rows: close them
            dst = n
            for r, o in zip(res, offs):
                if dst != o and r[0]:
                    out[:, dst:dst + r[0]] = out[:, o:o + r[0]]
                dst += r[0]
            n = dst
            # release the pages behind (page cache, not ours: keeps the resident size small)
            done = pos // mmap.PAGESIZE * mmap.PAGESIZE
            if done > released and hasattr(mmap, "MADV_DONTNEED"):
                mm.madvise(mmap.MADV_DONTNEED, released, done - released)
                released = done
    finally:
        if pool is not None:
            pool.shutdown()
    values = out[:, :n]
    nulls = {}
    for k, name in enumerate(wanted):
        if stats[k, 0]:
            mask = values[k].view(np.uint64) == _NULL
            values[k][mask] = np.nan
            nulls[name] = mask
    intlike = {name for k, name in enumerate(wanted) if not stats[k, 1] and stats[k, 0] < n}
    global _WARM
    _WARM = True
    return wanted, values, nulls, intlike


def read_numeric_table(path: str | os.PathLike, delim: str, skip: int, names: list[str],
                       columns: list[str] | None = None):
    """The fast path of :func:`gyrotest.ingest.read_table`: a pyarrow Table of the used
    columns typed as the pyarrow path types them, or None (use pyarrow)."""
    mode = os.environ.get("GYROTEST_FASTCSV", "1").strip().lower()
    if mode in ("0", "off", "no", "false"):
        return None
    try:
        size, forced = os.path.getsize(path), _setting("GYROTEST_FASTCSV_MIN_BYTES", -1)
        if size < (forced if forced >= 0 else WARM_MIN_BYTES if _WARM else MIN_BYTES):
            return None
        if not _kernels() or (forced < 0 and not _CACHED and size < UNCACHED_MIN_BYTES):
            return None
        res = read_numeric(path, delim, skip, names, columns)
        if res is None:
            return None
        wanted, values, nulls, intlike = res
        if values.shape[1] == 0:
            return None  # header only: the pyarrow path says so
        import pyarrow as pa

        cols = {}
        for k, name in enumerate(wanted):
            v, mask = values[k], nulls.get(name)
            if mask is not None and mask.all():
                cols[name] = pa.nulls(len(v))  # pyarrow's type for an all-empty column
            elif name in intlike:
                with np.errstate(invalid="ignore"):  # NaN under the null mask
                    cols[name] = pa.array(v.astype(np.int64), mask=mask)
            else:
                cols[name] = pa.array(v, mask=mask)  # no copy
        return pa.table(cols)
    except Exception:
        if mode == "strict":
            raise
        log.debug("fastcsv failed; using pyarrow", exc_info=True)
        return None
