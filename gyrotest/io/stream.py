"""Long Parquet logs streamed straight into the integrated angle θ (no rate array held).

A 24 h log at 10 kHz has 8.6·10⁸ samples: 6.9 GB as float64. :func:`read_log` would hold the
time column, the rate column(s) and the Arrow table at once (≈ 3–6× the record), and the
analysis would then build θ next to the rate. :func:`stream_log` reads the Parquet file batch
by batch (:data:`BATCH_ROWS` rows) and integrates each rate axis into its angle series θ
(:class:`gyrotest.core.angle.AngleSeries`) on the fly, with the cumulative sum carried
across batches; the time column is only used as an on-the-fly timing check (sample interval,
gaps, jitter) and is never stored. The peak memory is θ (the size of one float64 rate column)
plus a few batches.

θ per gap-free segment is [0, cumsum(x − c)] with c the mean of the segment's first batch; when
the segment ends, θ_k −= k·(x̄ − c) makes it [0, cumsum(x − x̄)] (the form of
:func:`~gyrotest.core.angle.angle_series`; the two differ by rounding only). Every
deviation, the noise identification and the trend check read θ; the spike check, the Welch PSD,
the autocorrelation and the axis cross-correlation read rate samples rebuilt from θ
(Ω_k = θ_{k+1} − θ_k + x̄; :mod:`gyrotest.noise.streamed`).

Used by ``gyrotest allan`` for Parquet logs of at least :data:`STREAM_MIN_ROWS` rows when
nothing else needs the samples themselves (no ``--model``, ``--detrend``, ``--skip``,
``--outliers remove/robust``); files written by ``gyrotest ingest`` (their metadata gives the
timing) and plain Parquet tables with the usual column roles (rate, voltage, counts or updown
output; ``--nan error``). Anything else returns None and the log is read whole.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .. import _runtime
from ..core.angle import CHUNK, AngleSeries
from ..core.data import Gap, GyroConstants, Timing
from ..core.errors import AnalysisError, InputError
from .health import MAX_ABS, overflow_mask
from .rawtable import RawTable

__all__ = ["BATCH_ROWS", "STREAM_MIN_ROWS", "StreamedLog", "stream_log"]

#: Parquet logs with at least this many rows (2²⁴ ≈ 1.7·10⁷) are streamed; smaller ones are
#: read whole: the in-memory path gives bit-identical results to the CSV path and is faster
#: while the record fits easily (10⁷ rows: 1.9 s against 2.7 s streamed, peak 0.46 GB against
#: 0.26 GB; benchmarks/README.md); at 2²⁴ rows that is about 0.8 GB
STREAM_MIN_ROWS = int(os.environ.get("GYROTEST_STREAM_MIN_ROWS", 1 << 24))
#: rows per batch read from the Parquet file
BATCH_ROWS = 1 << 18
_SLACK = 4096
_HIST_MAX = 1 << 16  # distinct sample intervals kept for the exact median (else: 1st batch's)  # θ slots for the leading zeros of segments (grown if a log has more gaps)
_STREAM_KINDS = ("rate", "voltage", "counts", "updown")


@dataclass
class StreamedLog:
    """A long log as its angle series: what :func:`gyrotest.noise.analysis.analyse_allan`
    needs from a :class:`~gyrotest.core.data.GyroLog`, without the samples.

    ``series[axis]`` is θ of that axis (rate input: cumsum of deg/h × samples; pulse outputs:
    angle increments in arcsec), ``means[axis]`` the mean rate (deg/h) of each segment."""

    source: str
    tau0: float
    timing: Timing
    gyro: GyroConstants
    series: dict[str, AngleSeries]
    means: dict[str, list[float]]
    notes: list[str] = field(default_factory=list)
    meta: dict[str, Any] = field(default_factory=dict)

    @property
    def n(self) -> int:
        return self.timing.n

    @property
    def axes(self) -> list[str]:
        return list(self.series)

    @property
    def duration_s(self) -> float:
        return self.timing.duration_s

    @property
    def segments(self) -> list[tuple[int, int]]:
        cuts = [0] + [g.index for g in self.timing.gaps] + [self.n]
        return [(a, b) for a, b in zip(cuts[:-1], cuts[1:]) if b > a]


class _Integrator:
    """θ of one axis, built batch by batch (module docstring)."""

    def __init__(self, capacity: int, increment: bool):
        self.theta = np.empty(capacity, dtype=np.float64)
        self.increment = increment
        self.pos = 0
        self.bounds: list[tuple[int, int]] = []
        self.means: list[float] = []
        self.seg_start = -1  # θ index of the current segment's leading zero, -1 = none open
        self.count = 0
        self.offset = 0.0
        self.carry = 0.0
        self.lo, self.hi = math.inf, -math.inf
        self.variation = False

    def _grow(self, need: int) -> None:
        new = np.empty(max(need, int(self.theta.size * 1.05) + _SLACK), dtype=np.float64)
        new[: self.pos] = self.theta[: self.pos]
        self.theta = new

    def append(self, x: np.ndarray, scale: float = 1.0) -> None:
        """Append samples ``x`` (× ``scale``: τ0 turns rates into increments) to the open
        segment, opening one if needed."""
        if x.size == 0:
            return
        if self.seg_start < 0:
            if self.pos + 1 + x.size > self.theta.size:
                self._grow(self.pos + 1 + x.size)
            self.seg_start = self.pos
            self.theta[self.pos] = 0.0
            self.pos += 1
            self.count = 0
            self.carry = 0.0
            self.offset = float(np.mean(x)) * scale
            self.lo, self.hi = math.inf, -math.inf
        elif self.pos + x.size > self.theta.size:
            self._grow(self.pos + x.size)
        if not np.isfinite(self.offset):
            raise InputError("non-finite rate value")
        for s in range(0, x.size, CHUNK):
            xs = x[s:s + CHUNK]
            buf = self.theta[self.pos:self.pos + xs.size]
            if scale != 1.0:
                np.multiply(xs, scale, out=buf)
                buf -= self.offset
            else:
                np.subtract(xs, self.offset, out=buf)
            self.lo = min(self.lo, float(buf.min()))
            self.hi = max(self.hi, float(buf.max()))
            buf[0] += self.carry
            np.cumsum(buf, out=buf)
            self.carry = float(buf[-1])
            self.pos += xs.size
            self.count += xs.size

    def close(self) -> None:
        """End the open segment: remove its exact mean (θ_k −= k·(x̄ − c))."""
        if self.seg_start < 0:
            return
        a, L = self.seg_start, self.count
        d = self.carry / L
        th = self.theta[a:a + L + 1]
        for s in range(0, L + 1, CHUNK):
            e = min(L + 1, s + CHUNK)
            k = np.arange(s, e, dtype=np.float64)
            k *= d
            th[s:e] -= k
        mean = self.offset + d
        lo, hi = self.lo + self.offset, self.hi + self.offset
        mag = max(abs(lo), abs(hi))
        self.variation |= (hi - lo) > 4 * np.finfo(float).eps * max(mag, 1e-300)
        self.means.append(mean)
        self.bounds.append((a, a + L + 1))
        self.seg_start = -1


def _eligible_rows(path: str, min_rows: int) -> tuple[Any, int] | None:
    """(ParquetFile, rows) when ``path`` is a Parquet file long enough to stream."""
    p = Path(path)
    if str(path) == "-" or not p.is_file():
        return None
    try:
        with open(p, "rb") as fh:
            if fh.read(4) != b"PAR1":
                return None
        import pyarrow.parquet as pq

        # no memory map: mapped pages of the file would count in the resident set
        pf = pq.ParquetFile(p, memory_map=False, pre_buffer=False, buffer_size=1 << 22)
        rows = int(pf.metadata.num_rows)
    except Exception:  # not readable: the whole-file reader gives the clean error
        return None
    if rows < min_rows:
        return None
    return pf, rows


def stream_log(path: str, *, profile=None, overrides: dict | None = None,
               nan_policy: str = "error", min_rows: int | None = None) -> StreamedLog | None:
    """Stream a long Parquet log into θ (module docstring); None when the file is not one this
    path handles (not Parquet, shorter than ``min_rows`` (default :data:`STREAM_MIN_ROWS`),
    a counter output, a --nan policy other than ``error`` on a plain table, damaged metadata):
    the caller then reads it whole with :func:`gyrotest.io.ingest.read_log`."""
    found = _eligible_rows(path, STREAM_MIN_ROWS if min_rows is None else min_rows)
    if found is None:
        return None
    _fixed_mmap_threshold()
    pf, rows = found
    from ..core.profile import merge
    from .meta import META_KEY, validate_meta

    prof = merge(profile, overrides or {})
    source = str(path)
    meta = pf.schema_arrow.metadata or {}
    if META_KEY in meta:
        try:
            gmeta = json.loads(meta[META_KEY])
            validate_meta(gmeta, pf.schema_arrow.names, rows)
        except (ValueError, RecursionError):
            return None  # damaged metadata: the whole-file reader explains it
        if gmeta["gyro"].get("output_kind") not in _STREAM_KINDS + ("counter",):
            return None
        log = _stream_converted(pf, rows, source, gmeta, prof)
    elif nan_policy != "error":
        return None
    else:
        log = _stream_plain(pf, rows, source, prof)
    del pf, found
    _release_memory()
    return log


def _progress(done: int, total: int) -> None:
    """The CLI's progress hook (:data:`gyrotest._runtime.PROGRESS`), per batch."""
    if _runtime.PROGRESS is not None:
        _runtime.PROGRESS(min(done, total), total, "reading rows")


def _fixed_mmap_threshold() -> None:
    """glibc serves blocks ≥ 1 MiB from mmap from now on (its threshold otherwise grows to
    32 MiB after the first frees, and the freed batch buffers of every later step would stay
    in the heap, counted in the peak resident memory; Arrow's own pool is emptied by
    :func:`_release_memory`). The heap's trim threshold goes to 32 MiB with it: pinning the
    mmap threshold also pins the trim threshold at 128 KiB, and the heap top was then handed
    back and faulted in again for every chunk buffer of the later steps (MTOTDEV on 10⁷
    samples spent a third of its time in the kernel; benchmarks/README.md)."""
    try:
        import ctypes

        libc = ctypes.CDLL("libc.so.6")
        libc.mallopt(-4, 65536)  # M_MMAP_MAX: glibc's default (gyrotest._runtime may have set 0)
        libc.mallopt(-3, 1 << 20)  # M_MMAP_THRESHOLD
        libc.mallopt(-1, 32 << 20)  # M_TRIM_THRESHOLD
    except (OSError, AttributeError):  # pragma: no cover - not glibc
        pass


def _release_memory() -> None:
    """Hand the batches' freed memory back to the system (Arrow's pool and glibc's heap keep
    it otherwise, and it would count in the peak of every later step)."""
    try:
        import pyarrow as pa

        pa.default_memory_pool().release_unused()
    except Exception:  # pragma: no cover - old pyarrow
        pass
    try:
        import ctypes

        ctypes.CDLL("libc.so.6").malloc_trim(0)
    except (OSError, AttributeError):  # pragma: no cover - not glibc
        pass


def _finish(source, integ: dict[str, _Integrator], timing: Timing, gyro: GyroConstants,
            tau0: float, notes: list[str], fmt_meta: dict) -> StreamedLog:
    series: dict[str, AngleSeries] = {}
    means: dict[str, list[float]] = {}
    segs = [(a, b) for a, b in zip([0] + [g.index for g in timing.gaps],
                                   [g.index for g in timing.gaps] + [timing.n]) if b > a]
    lengths = [b - a for a, b in segs]
    for axis, it in integ.items():
        it.close()
        if not it.variation:
            raise AnalysisError(
                f"{source} [{axis}]: the rate is constant in every sample: every deviation is "
                "exactly zero and no noise can be identified; check the channel, scale factor "
                "and quantization (a gyro output this quiet is below its resolution)")
        if sum(b - a - 1 for a, b in it.bounds) != timing.n:  # pragma: no cover - internal
            raise AnalysisError(f"{source}: streamed sample count differs from the timing")
        notes_s = []
        if len(segs) > 1:
            notes_s.append(f"gap-aware estimate: {len(segs)} segments analysed separately, sums "
                           "of squares and term counts pooled; no difference spans a gap")
        theta = it.theta[: it.pos]
        series[axis] = AngleSeries(
            theta=theta, bounds=list(it.bounds),
            scale=1.0 if it.increment else float(tau0), tau0=float(tau0),
            input_kind="increment" if it.increment else "rate", segments=segs,
            n_data=int(sum(lengths)), n_longest=int(max(lengths)), notes=notes_s)
        # segment means of the rate (deg/h): increments are rate·τ0
        means[axis] = [m / tau0 if it.increment else m for m in it.means]
    return StreamedLog(source=source, tau0=float(tau0), timing=timing, gyro=gyro, series=series,
                       means=means, notes=notes, meta=fmt_meta)


def _stream_converted(pf, rows: int, source: str, gmeta: dict, prof) -> StreamedLog:
    """A file written by ``gyrotest ingest``: timing and gaps from its metadata, rate columns
    in deg/h; the time column (if any) is checked batch by batch against the metadata."""
    from .meta import gyro_from_meta, timing_from_meta

    cols = gmeta["columns"]
    timing = timing_from_meta(gmeta)
    gyro = gyro_from_meta(gmeta, prof)
    tau0 = float(gmeta["tau0_s"])
    increment = gyro.output_kind in ("counts", "updown", "counter")
    rate_cols = dict(cols["rates"])
    integ = {axis: _Integrator(rows + _SLACK, increment) for axis in rate_cols}
    cuts = [g.index for g in timing.gaps]
    tcol = cols.get("time")
    from .fastcsv import float64_values

    pos = 0
    t_prev = None
    for batch in pf.iter_batches(batch_size=BATCH_ROWS, columns=list(rate_cols.values())
                                 + ([tcol] if tcol else []), use_threads=False):
        k = batch.num_rows
        if tcol:  # on-the-fly check: the time column must agree with the metadata's timing
            t = float64_values(batch.column(tcol))
            bad = _time_problem(t, t_prev, pos, tau0, cuts)
            if bad:
                raise InputError(f"{source}: {bad}; re-create the file with 'gyrotest ingest'")
            t_prev = float(t[-1])
        _progress(pos + k, rows)
        inside = [c - pos for c in cuts if pos < c < pos + k]
        for axis, c in rate_cols.items():
            x = float64_values(batch.column(c))
            bad = ~np.isfinite(x) | overflow_mask(x)
            if bad.any():
                i = int(np.flatnonzero(bad)[0])
                raise InputError(f"{source}: rate column {c!r} holds {x[i]:.6g} at row "
                                 f"{pos + i + 1} (a converted file never has NaN/inf or values "
                                 f"beyond ±{MAX_ABS:g}); re-create the file with "
                                 "'gyrotest ingest'")
            _append_split(integ[axis], x, inside, pos, cuts, tau0 if increment else 1.0)
        pos += k
    if pos != timing.n:
        raise InputError(f"{source}: {pos} rows but the metadata says {timing.n} samples; "
                         "re-create the file with 'gyrotest ingest'")
    notes = list(gmeta.get("notes", [])) + [
        f"read from gyrotest parquet (converted by gyrotest {gmeta.get('gyrotest_version')}); "
        f"streamed in batches of {BATCH_ROWS} rows into the integrated angle"]
    return _finish(source, integ, timing, gyro, tau0, notes,
                   {"format": "parquet", "converted_from": gmeta.get("source"), "streamed": True})


def _append_split(it: _Integrator, x: np.ndarray, inside: list[int], pos: int, cuts: list[int],
                  scale: float) -> None:
    """Append one batch, closing the segment at every gap (batch-relative ``inside``) and at a
    gap that falls exactly on the batch start."""
    if pos in cuts:
        it.close()
    s = 0
    for c in inside:
        it.append(x[s:c], scale)
        it.close()
        s = c
    it.append(x[s:], scale)


def _time_problem(t: np.ndarray, t_prev: float | None, pos: int, tau0: float,
                  cuts: list[int]) -> str | None:
    """A reason when the time column of a converted file contradicts its metadata timing
    (a gap or a backwards step the metadata does not list)."""
    if not np.isfinite(t).all():
        return f"non-finite time value near row {pos + 1}"
    dt = np.diff(t)
    if t_prev is not None:
        dt = np.concatenate([[t[0] - t_prev], dt])
        first = pos
    else:
        first = pos + 1
    big = np.flatnonzero((dt > 1.5 * tau0) | (dt <= 0))
    for i in big:
        if first + int(i) not in cuts:
            return (f"time step of {dt[i]:.6g} s at row {first + int(i) + 1} is not a gap of "
                    "the file's metadata")
    return None


def _stream_plain(pf, rows: int, source: str, prof) -> StreamedLog | None:
    """A plain Parquet table: the column roles, units and output conversion of
    :func:`gyrotest.io.ingest.build_log`, applied batch by batch with one row of overlap (so the
    timing check sees the step across every batch boundary)."""
    import pyarrow as pa

    from .columns import resolve_columns
    from .ingest import _wanted, build_log
    from .timeaxis import GAP_FACTOR, JITTER_WARN

    roles, notes0 = resolve_columns(pf.schema_arrow.names, prof, source)
    if roles["kind"] not in _STREAM_KINDS:
        return None
    wanted = _wanted(roles)
    integ: dict[str, _Integrator] = {}
    gaps: list[Gap] = []
    notes: list[str] = []
    n = 0  # samples emitted
    t_off = 0.0  # global time of the batch's first row
    prev = None  # the previous batch's last row (a one-row table)
    tau0_nom = None
    dmin, dmax = math.inf, -math.inf
    s1 = s2 = 0.0
    cnt = 0
    dups = 0
    start_iso = None
    time_source = ""
    gyro = None
    chunk_tau0 = None
    hist: tuple | None = (np.zeros(0), np.zeros(0))
    for bi, batch in enumerate(pf.iter_batches(batch_size=BATCH_ROWS, columns=wanted,
                                               use_threads=False)):
        tab = pa.Table.from_batches([batch])
        if prev is not None:
            tab = pa.concat_tables([prev, tab])
        first_row = n + dups - (1 if prev is not None else 0)
        raw = _BatchTable(tab, source, "parquet", None, offset=first_row)
        nb: list[str] = []
        log = build_log(raw, roles, prof, nb, "error")
        if bi == 0:
            first_row_tab = tab.slice(0, 1)
            time_unit = log.units.get(roles["time"]) if roles.get("time") else None
            notes = [m for m in nb if "gap(s) in the time axis" not in m
                     and not m.startswith("irregular sampling")]
            gyro = log.gyro
            start_iso = log.timing.start
            time_source = log.timing.source
            tau0_nom = log.timing.tau0
        dups += log.timing.duplicates_dropped
        t = log.t
        chunk_tau0 = log.timing.tau0
        dt = np.diff(t)
        if hist is not None:  # the distinct positive intervals and their counts (for the median)
            u, c = np.unique(dt[dt > 0], return_counts=True)
            hv, inv = np.unique(np.concatenate([hist[0], u]), return_inverse=True)
            hist = (hv, np.bincount(inv, np.concatenate([hist[1], c])))
            if hv.size > _HIST_MAX:
                hist = None
        lim = GAP_FACTOR * tau0_nom
        gi = np.flatnonzero(dt > lim)
        inside_dt = dt[dt <= lim]
        if inside_dt.size:
            dmin = min(dmin, float(inside_dt.min()))
            dmax = max(dmax, float(inside_dt.max()))
            s1 += float(inside_dt.sum())
            s2 += float(np.dot(inside_dt, inside_dt))
            cnt += inside_dt.size
        skip = 1 if prev is not None else 0  # the overlap row was emitted with the last batch
        base = n - skip  # global index of this batch's row 0
        for i in gi:
            gaps.append(Gap(index=base + int(i) + 1, time_s=t_off + float(t[i + 1]),
                            duration_s=float(dt[i]), missing=int(round(dt[i] / tau0_nom)) - 1))
        inside = [base + int(i) + 1 - n for i in gi]  # relative to the emitted samples
        for axis, r in log.rates.items():
            if axis not in integ:
                integ[axis] = _Integrator(rows + _SLACK, roles["kind"] in ("counts", "updown"))
            x = r[skip:]
            it = integ[axis]
            sc = chunk_tau0 if it.increment else 1.0
            s = 0
            for c in inside:
                it.append(x[s:c], sc)
                it.close()
                s = c
            it.append(x[s:], sc)
        n += t.size - skip
        _progress(n + dups, rows)
        t_off += float(t[-1])
        prev = tab.slice(tab.num_rows - 1, 1)
    if n < 2 or gyro is None:
        return None
    span = t_off  # the sum of the batches' spans; exactly as read whole:
    if roles.get("time"):
        from .timeaxis import _time_seconds

        ends = _BatchTable(pa.concat_tables([first_row_tab, prev]), source, "parquet", None)
        span = float(_time_seconds(ends, roles["time"], time_unit).t[1])
    else:
        span = (n - 1) * tau0_nom
    if not roles.get("time"):
        tau0 = float(tau0_nom)
        jitter = 0.0
    elif not gaps and dmax <= dmin * (1 + 1e-6):
        tau0 = span / (n - 1)
        jitter = (dmax - dmin) / tau0 / math.sqrt(12.0)
    else:
        tau0 = float(tau0_nom) if hist is None else _hist_median(*hist)
        var = max(s2 / cnt - (s1 / cnt) ** 2, 0.0) if cnt > 1 else 0.0
        jitter = math.sqrt(var) / tau0
    timing = Timing(n=n, tau0=tau0, duration_s=span + tau0, source=time_source, gaps=gaps,
                    jitter_rel=jitter, irregular=jitter > JITTER_WARN, duplicates_dropped=dups,
                    start=start_iso)
    if gaps:
        tot = sum(g.duration_s for g in gaps)
        notes.append(f"{len(gaps)} gap(s) in the time axis ({tot:.4g} s in all); analyses work "
                     "per contiguous segment and never bridge a gap")
    if timing.irregular:
        notes.append(f"irregular sampling: interval jitter {100 * jitter:.2g}% of the nominal "
                     f"{tau0:.6g} s; uniform-sampling analyses assume the nominal interval")
    notes = notes0 + notes + [f"streamed in batches of {BATCH_ROWS} rows into the integrated "
                              "angle (the time column checked on the fly, not stored)"]
    return _finish(source, integ, timing, gyro, tau0, notes,
                   {"profile": prof.source, "format": "parquet", "streamed": True})


def _hist_median(values: np.ndarray, counts: np.ndarray) -> float:
    """np.median of the samples that ``values`` × ``counts`` stand for."""
    cum = np.cumsum(counts)
    tot = int(cum[-1])
    lo = float(values[np.searchsorted(cum, (tot - 1) // 2 + 1)])
    hi = float(values[np.searchsorted(cum, tot // 2 + 1)])
    return lo if tot % 2 else 0.5 * (lo + hi)


@dataclass
class _BatchTable(RawTable):
    """A RawTable of one batch whose row numbers in messages count from the file's start."""

    offset: int = 0

    def where(self, row: int) -> str:
        return f"row {self.offset + row + 1}"
