"""Reading bench logs: one place for every command.

:func:`read_log` turns a file (CSV/TSV/semicolon/whitespace text with a header, Parquet,
Feather/Arrow IPC, or ``-`` for CSV on stdin) plus an optional bench profile and command-line
overrides into a :class:`~gyrotest.core.data.GyroLog` in internal units (rate deg/h, time s,
temperature degC, field uT, supply V).

Gyro output kinds (IEEE 952 §8.3 model equation, S0 = scale factor):

* ``rate``: an angular-rate column in any unit (deg/h, deg/s, rad/s, mrad/s ...);
* ``counts``: pulses per sample; rate = counts · S0[arcsec/pulse] / τ0[s] (1 arcsec/s = 1 deg/h);
* ``updown``: up/down pulse pairs, net = up − down, then as counts;
* ``counter``: a cumulative pulse counter that rolls over at 2^bits; unwrapped modulo 2^bits
  (the first sample only sets the origin and is dropped);
* ``voltage``: analog output; rate = S0[(deg/h)/V] · (V − offset).
* ``delta-angle``: angle increments per sample (an IMU's Δθ output) in rad/deg/arcsec/mrad/µrad;
  rate = Δθ / τ0 (the increment of sample k covers one nominal interval);
* ``angle``: a cumulative (integrated) angle; rate_k = (θ_k − θ_{k−1}) / (t_k − t_{k−1}) (the
  first sample only sets the origin and is dropped).

Text is parsed with pyarrow's multithreaded CSV reader (whitespace-separated text with pandas'
C parser); only the columns that are used are converted. Timing: a time column (seconds, or
ISO-8601 timestamps) or a sample rate; gaps (> 1.5 nominal intervals) are reported and split
the log into segments, never bridged; backwards timestamps are an error; exact duplicate rows
are dropped with a note.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Callable
from typing import Any

import numpy as np
import pyarrow as pa

from ..core.data import GyroConstants, GyroLog
from ..core.errors import InputError
from ..core.profile import Profile, merge
from ..core.units import factor, to_internal
from .columns import (
    _SUFFIX_UNITS,
    RoleError,
    _ci,
    _unit_from_name,
    angle_unit_from_name,
    column_guesses,
    resolve_columns,
)
from .health import MAX_ABS, PHYSICAL_RANGE, outside_physical, overflow_mask
from .meta import (
    META_KEY,
    _from_gyrotest,
    log_to_table,
    read_gyrotest_table,
    validate_meta,
    write_log,
)
from .rawtable import RawTable
from .site import site_from_profile
from .tables import (
    NULL_VALUES,
    RANGE_BYTES,
    STREAM_MIN_BYTES,
    _column_to_float,
    _source_name,
    column_names,
    read_table,
)
from .timeaxis import (
    GAP_FACTOR,
    JITTER_WARN,
    TIME_UNIT_FIX,
    _time_seconds,
    analyse_timing,
    check_rate,
)

__all__ = [
    "GAP_FACTOR", "JITTER_WARN", "META_KEY", "NULL_VALUES", "RANGE_BYTES", "STREAM_MIN_BYTES",
    "RawTable", "RoleError", "_SUFFIX_UNITS", "_ci", "analyse_timing", "build_log",
    "column_guesses", "column_names", "describe_columns",
    "log_to_table", "read_log", "read_table", "resolve_columns", "site_from_profile", "write_log",
]


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
             nan_policy: str = "error", dead: str = "note") -> GyroLog:
    """Read a bench log into a :class:`GyroLog` (see the module docstring).

    ``overrides`` has the profile's shape (``{"columns": {...}, "gyro": {...}, "site": {...},
    "units": {...}}``) and wins key by key. ``nan_policy``: ``error`` (default) stops at the
    first missing value naming the row and column; ``gap`` drops rows with a missing value
    and treats them as gaps; ``interpolate`` fills auxiliary channels linearly (missing gyro
    values still become gaps). Values beyond ±1e40 (a logger's overflow code) count as missing.
    A dead or stuck gyro output (constant over the whole run) is a note, or with
    ``dead="error"`` (every analysis command) an InputError (:mod:`gyrotest.io.health`).
    """
    from .health import check_log

    log = _read_log(path, profile, overrides, nan_policy)
    check_log(log, dead=dead)
    return log


def _read_log(path, profile, overrides, nan_policy) -> GyroLog:
    if nan_policy not in ("error", "gap", "interpolate"):
        raise InputError(f"unknown NaN policy {nan_policy!r}; use error, gap or interpolate")
    from ..core.guard import declare_input

    declare_input(path, "a log")  # no output of this run may replace it
    prof = merge(profile, overrides or {})
    source = _source_name(path)
    from ..core.documents import path_kind, read_fifo

    if str(path) != "-" and path_kind(path) == "fifo":
        # a named pipe (an acquisition program, `<(zcat log.csv.gz)`): read to its end, once,
        # never blocking on a pipe with no writer; then parsed like stdin
        data = read_fifo(path, "a log", hint=", or pipe it into gyrotest and pass '-'")
        raw = read_table(path, _data=data)
        roles, notes = resolve_columns(raw.table.column_names, prof, source)
        notes.append(f"read {len(data):,} bytes from the named pipe to its end")
    # names first (cheap) so that only the used columns are parsed
    elif str(path) != "-":
        select = prof.columns.get("topic")
        head = read_table(path, select=select, _names_only=True)
        if head.fmt in ("parquet", "feather"):
            return _from_binary(head, prof, nan_policy)
        if select and head.fmt not in CONTAINER_FORMATS:
            raise InputError(f"{source}: --topic (or [columns] topic) selects a ROS topic, HDF5 "
                             f"group or MATLAB struct; a {head.fmt.upper()} table has none")
        roles, notes = resolve_columns(head.table.column_names, prof, source)
        notes[:0] = head.notes
        wanted = _wanted(roles)
        raw = read_table(path, columns=wanted, select=select)
        notes += [n for n in raw.notes if n not in notes]  # found while reading the data
    else:
        raw = read_table(path)
        roles, notes = resolve_columns(raw.table.column_names, prof, source)
    return _naming_file(source, lambda: build_log(raw, roles, prof, notes, nan_policy))


def describe_columns(path: str | os.PathLike, *, profile: Profile | None = None,
                     overrides: dict[str, dict[str, Any]] | None = None) -> dict[str, Any]:
    """Every column a log file holds, without reading its data: the role its name suggests,
    the unit the header or the file states, and the role :func:`read_log` would give it with
    this profile and these options (``assigned``; None for every column when the roles cannot
    be resolved — ``problem`` then says why). JSON-ready."""
    prof = merge(profile, overrides or {})
    source = _source_name(path)
    select = prof.columns.get("topic")
    from ..core.documents import path_kind, read_fifo

    if str(path) != "-" and path_kind(path) == "fifo":  # a named pipe: its text, to the end
        head = read_table(path, _data=read_fifo(path, "a log"), _names_only=True)
    else:
        head = read_table(path, select=select, _names_only=True)
    names = (column_names(path) if head.fmt in ("parquet", "feather")
             else head.table.column_names)
    guesses = column_guesses(names)
    assigned: dict[str, str] = {}
    problem = None
    notes = list(head.notes)
    try:
        roles, more = resolve_columns(names, prof, source)
        notes += more
        if roles.get("time"):
            assigned[roles["time"]] = "time"
        for c in roles.get("output") or []:
            assigned[c] = f"gyro output ({roles['kind']})"
        for key, label in (("temperature", "temperature"), ("field", "magnetic field"),
                           ("extra", "extra channel")):
            for c in roles.get(key) or []:
                assigned.setdefault(c, label)
        for key, label in (("supply", "supply voltage"), ("table_rate", "rate-table rate"),
                           ("position", "position")):
            if roles.get(key):
                assigned[roles[key]] = label
    except InputError as e:
        problem = str(e)
    for g in guesses:
        g["unit"] = prof.units.get(g["column"]) or head.units.get(g["column"]) or g["unit"]
        g["assigned"] = assigned.get(g["column"])
    return {"source": source, "format": head.fmt, "columns": guesses, "notes": notes,
            "problem": problem}


def _naming_file(source: str, build: Callable[[], GyroLog]) -> GyroLog:
    """Run ``build``; an error that does not name the file yet (a unit, a profile value) gets
    the file name in front, keeping its type."""
    try:
        return build()
    except InputError as e:
        if str(e).startswith(source):
            raise
        raise type(e)(f"{source}: {e}") from None


def _wanted(roles: dict[str, Any]) -> list[str]:
    out: list[str] = []
    for key in ("time", "supply", "table_rate", "position"):
        if roles.get(key):
            out.append(roles[key])
    for key in ("output", "temperature", "field", "extra"):
        out.extend(roles.get(key) or [])
    return list(dict.fromkeys(out))


#: formats read by gyrotest.io.containers (their columns may come with units)
CONTAINER_FORMATS = ("mat", "hdf5", "rosbag")


def _time_unit_from_name(col: str) -> str | None:
    u = _unit_from_name(col)
    return u if u in ("ms", "us", "ns") else None


def _field_unit(c: str, prof: Profile, file_units: dict | None) -> str:
    """Unit of a magnetic-field column: as :func:`_unit_for`, a name's ``_g``/``_mg`` suffix
    read as gauss/milligauss (``hx_g``; on an accelerometer it is standard gravity)."""
    u = _unit_for(c, prof, "uT", file_units)
    if c not in prof.units and not (file_units or {}).get(c):
        u = {"g": "G", "mg": "mG"}.get(u, u)
    return u


def _unit_for(col: str, prof: Profile, default: str, stated: dict[str, str] | None = None
              ) -> str:
    """A column's unit: the profile's [units], else the file's own (ROS, HDF5 attribute),
    else the header, else the role default."""
    if col in prof.units:
        return prof.units[col]
    return (stated or {}).get(col) or _unit_from_name(col) or default


def _take(keep, arrays: dict, temps: dict, fields: dict, extra: dict, supply, table,
          position) -> tuple:
    """The rows ``keep`` (a mask or a slice) of every channel of a log being built."""
    def sub(v):
        return None if v is None else v[keep]

    return ({k: v[keep] for k, v in arrays.items()}, {k: v[keep] for k, v in temps.items()},
            {k: v[keep] for k, v in fields.items()}, {k: v[keep] for k, v in extra.items()},
            sub(supply), sub(table), sub(position))


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
    fs = g.get("sample_rate_hz")
    if fs is not None and not (isinstance(fs, (int, float)) and math.isfinite(fs) and fs > 0):
        raise InputError(f"{source}: sample rate must be a positive number of Hz, got {fs}")
    if roles.get("time"):
        tcol = roles["time"]
        tunit = (prof.units.get(tcol) or raw.units.get(tcol) or g.get("time_unit")
                 or _time_unit_from_name(tcol))
        if tunit is not None:
            factor(tunit, "time", what=f"time column {tcol!r}")  # an unknown unit: clean error
        ax = _time_seconds(raw, tcol, tunit, sample_rate_hz=fs)
        t, start_iso = ax.t, ax.start
        notes.extend(ax.notes)
        units[tcol] = ax.unit
        time_source = f"time column {tcol!r}" + (f" ({ax.unit})" if ax.unit != "s" else "")
        tau0_given = None
    else:
        if not fs:
            raise InputError(f"{source}: no time column and no sample rate; name the time column "
                             "with --time-col or give --sample-rate HZ (or [gyro] sample_rate_hz)")
        check_rate(1.0 / fs, source, f"--sample-rate {fs:g}")
        t = None
        tau0_given = 1.0 / float(fs)
        time_source = f"sample rate {fs:g} Hz (no time column)"
    # ---- gyro output to rate (deg/h), before timing so that NaNs can become gaps
    outs = roles["output"]
    arrays = {c: _column_to_float(raw, c, "gyro output") for c in outs}
    gyro = GyroConstants(output_kind=kind, model=g.get("model"), serial=g.get("serial"),
                         type=g.get("type"), power_on_at_start=g.get("power_on_at_start"))
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
    physical = {**{f"temperature {c!r}": (c, "temperature", "degC") for c in temps},
                **{f"field {c!r}": (c, "field", "uT") for c in fields}}
    for label, v in {**gyro_cols, **aux}.items():
        # ±inf is a missing value too (an overflowed logger cell), and so is a value beyond
        # ±MAX_ABS (a logger's overflow code) or a temperature/field no sensor can read
        # (gyrotest.io.health)
        big = overflow_mask(v)
        why = f"beyond ±{MAX_ABS:g}, where the arithmetic would overflow"
        if label in physical and not big.all():
            c, quantity, default = physical[label]
            unit = (_field_unit(c, prof, raw.units) if quantity == "field"
                    else _unit_for(c, prof, default, raw.units))
            outside = outside_physical(np.where(big, 0.0, v), unit, quantity)
            if outside.any():
                why = f"outside {PHYSICAL_RANGE[quantity][2]}"
                big |= outside
        miss = ~np.isfinite(v) | big
        if not miss.any():
            continue
        n_big = int(big.sum())
        first_big = float(v[np.flatnonzero(big)[0]]) if n_big else None
        v[miss] = np.nan
        first, run, total = _nan_runs(miss)
        over = (f" ({n_big} of them {why}, e.g. {first_big:.6g}: a logger's overflow or error "
                "code)" if n_big else "")
        if total == n_rows:
            raise InputError(f"{source}: {label} has no values (all empty/NaN/±inf){over}; check "
                             "the column or leave it out")
        if nan_policy == "error":
            rng = raw.where(first) if run == 1 else f"{raw.where(first)} to {raw.where(first + run - 1)}"
            raise InputError(
                f"{source}: {label} has {total} missing/NaN/±inf value(s){over}, first at {rng}; "
                "fix the data, or pass --nan gap (drop those rows as gaps) or --nan interpolate"
            )
        if nan_policy == "interpolate" and label in aux:
            idx = np.arange(n_rows)
            v[miss] = np.interp(idx[miss], idx[~miss], v[~miss])
            notes.append(f"{label}: {total} missing value(s) interpolated linearly")
        else:
            drop |= miss
            notes.append(f"{label}: {total} row(s) with missing values dropped and treated as gaps")
    for c, v in extra.items():
        miss = ~np.isfinite(v) | overflow_mask(v)
        if miss.any():
            idx = np.arange(n_rows)
            v[miss] = np.nan
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
        arrays, temps, fields, extra, supply, table, position = _take(
            keep, arrays, temps, fields, extra, supply, table, position)
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
        arrays, temps, fields, extra, supply, table, position = _take(
            keep, arrays, temps, fields, extra, supply, table, position)
        timing, _ = analyse_timing(t, source, where, tau0_given)
        timing.duplicates_dropped = int((~keep).sum())
        notes.append(f"{timing.duplicates_dropped} duplicated row(s) (same time, same values) dropped")
    timing.source = time_source
    timing.start = start_iso
    tau0 = timing.tau0
    if roles.get("time"):
        check_rate(tau0, source, f"time column {roles['time']!r} read in {units[roles['time']]}")
        if fs:
            if abs(1.0 / tau0 - fs) > 0.01 * fs:
                raise InputError(
                    f"{source}: the sample rate {fs:g} Hz (--sample-rate or [gyro] sample_rate_hz) "
                    f"conflicts with time column {roles['time']!r} ({1.0 / tau0:.6g} Hz read in "
                    f"{units[roles['time']]}); drop the sample rate, or {TIME_UNIT_FIX}")
            notes.append(f"sample rate {fs:g} Hz agrees with the time column")
    if timing.gaps:
        tot = sum(gp.duration_s for gp in timing.gaps)
        notes.append(f"{len(timing.gaps)} gap(s) in the time axis ({tot:.4g} s in all); analyses "
                     "work per contiguous segment (allan bridges gaps of ≤ --fill missed "
                     "samples, default 1, and says so)")
    if timing.irregular:
        notes.append(f"irregular sampling: interval jitter {100 * timing.jitter_rel:.2g}% of the "
                     f"nominal {tau0:.6g} s; uniform-sampling analyses assume the nominal interval")
    # ---- gyro conversion
    rates = _convert_output(kind, outs, arrays, gyro, prof, source, tau0, units, notes, raw.units,
                            t)
    if kind in ("counter", "angle"):
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
        u = _unit_for(c, prof, "degC", raw.units)
        temps[c] = to_internal(temps[c], u, "temperature", what=f"column {c!r}")
        units[c] = u
    for c in list(fields):
        u = _field_unit(c, prof, raw.units)
        temps_u = to_internal(fields[c], u, "field", what=f"column {c!r}")
        fields[c] = temps_u
        units[c] = u
    if supply is not None:
        u = _unit_for(roles["supply"], prof, "V", raw.units)
        supply = to_internal(supply, u, "voltage", what=f"column {roles['supply']!r}")
        units[roles["supply"]] = u
    if table is not None:
        u = _unit_for(roles["table_rate"], prof, "deg/s", raw.units)
        table = to_internal(table, u, "rate", what=f"column {roles['table_rate']!r}")
        units[roles["table_rate"]] = u
    for c in extra:
        units[c] = prof.units.get(c) or raw.units.get(c) or _unit_from_name(c) or ""
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
        meta={"profile": prof.source, "format": raw.fmt, **raw.origin},
    )
    return log


def _convert_output(kind, outs, arrays, gyro, prof, source, tau0, units, notes, stated=None,
                    t=None):
    g = prof.gyro
    stated = stated or {}
    rates: dict[str, np.ndarray] = {}
    if kind in ("delta-angle", "angle"):
        return _angle_to_rate(kind, outs, arrays, gyro, prof, source, tau0, units, notes,
                              stated, t)
    if kind == "rate":
        for c in outs:
            u = prof.units.get(c) or stated.get(c) or _unit_from_name(c) or g.get("rate_unit")
            if not u:
                raise RoleError(
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


def _angle_to_rate(kind, outs, arrays, gyro, prof, source, tau0, units, notes, stated, t):
    """Angle outputs to rate in deg/h (1 arcsec/s = 1 deg/h).

    delta-angle: Ω_k = Δθ_k / τ0, the increment over one nominal sample interval (an IMU's
    coning/sculling-free Δθ output; the same convention as pulse counts, IEEE 952 §8.3).
    angle: Ω_k = (θ_k − θ_{k−1}) / (t_k − t_{k−1}), the mean rate over each actual interval;
    the first sample sets the origin.
    """
    g = prof.gyro
    rates: dict[str, np.ndarray] = {}
    for c in outs:
        u = prof.units.get(c) or stated.get(c) or angle_unit_from_name(c) or g.get("angle_unit")
        if not u:
            raise RoleError(f"{source}: the unit of {kind} column {c!r} is not known; give "
                            "--angle-unit (rad, deg, arcsec, mrad, urad) or [gyro] angle_unit")
        f = factor(u, "angle", what=f"{kind} column {c!r}")  # → arcsec
        v = arrays[c]
        if kind == "delta-angle":
            rates[c] = v * (f / tau0)
        else:
            dt = np.diff(t) if t is not None else np.full(len(v) - 1, tau0)
            rates[c] = np.diff(v) * f / dt
        units[c] = u
    gyro.rate_unit = units[outs[0]]
    notes.append(f"{kind} output ({gyro.rate_unit}) converted to rate: "
                 + ("Δθ/τ0" if kind == "delta-angle" else "Δθ/Δt between samples, first sample "
                    "sets the origin"))
    return rates


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
    damaged = None
    if META_KEY in meta:
        try:
            gmeta = json.loads(meta[META_KEY])
            raw = read_gyrotest_table(path, head.source, head.fmt)
            validate_meta(gmeta, raw.table.column_names, raw.table.num_rows)
            return _from_gyrotest(raw, head.source, head.fmt, gmeta, prof)
        except (ValueError, RecursionError) as e:  # MetaError, JSON errors
            damaged = (f"its gyrotest metadata is damaged ({str(e)[:120]}); ignored, the "
                       "columns are read by name")
    try:
        roles, notes = resolve_columns(schema.names, prof, head.source)
        if damaged:
            notes.insert(0, damaged)
        raw = read_table(path, columns=_wanted(roles))
        return build_log(raw, roles, prof, notes, nan_policy)
    except InputError as e:
        if not damaged:
            raise
        raise InputError(f"{e} ({head.source}: {damaged}; re-create it with 'gyrotest ingest')"
                         ) from None


