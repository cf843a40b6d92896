"""What a notebook hands the API, turned into what the analyses take.

:func:`gyrotest.read` is the public entry point; the command line reads its logs through
:func:`read_with_options`. A log can be
given as a file path, a :class:`pandas.DataFrame`, a numpy array with its sample interval and
unit, a simulation (:func:`gyrotest.simulate`) or an already read
:class:`~gyrotest.core.data.GyroLog`; the ingest options have the command line's names
(``rate_col="gx"``, ``temp_col=["T_case_C"]``, ``latitude=48.1``, ``nan="gap"`` ...).

No numpy/pandas at import: ``import gyrotest`` and ``gyrotest --help`` stay cheap.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable, Sequence
from typing import Any

from ..core.console import warn
from ..core.errors import OptionError

#: ingest option -> the key the command line collects it under (``--nan`` is ``nan_policy``)
READ_OPTIONS: dict[str, str] = {
    "time_col": "time_col", "rate_col": "rate_col", "rate_unit": "rate_unit",
    "counts_col": "counts_col", "up_col": "up_col", "down_col": "down_col",
    "counter_col": "counter_col", "counter_bits": "counter_bits",
    "voltage_col": "voltage_col", "delta_angle_col": "delta_angle_col",
    "angle_col": "angle_col", "angle_unit": "angle_unit", "output_kind": "output_kind",
    "scale_factor": "scale_factor", "offset": "offset", "sample_rate": "sample_rate",
    "time_unit": "time_unit", "temp_col": "temp_col", "field_cols": "field_cols",
    "supply_col": "supply_col", "table_col": "table_col", "position_col": "position_col",
    "latitude": "latitude", "ia": "ia", "topic": "topic", "nan": "nan_policy",
}


def _split_cols(value) -> list[str] | None:
    if value is None:
        return None
    if isinstance(value, str):
        parts = [p.strip() for p in value.split(",") if p.strip()]
    else:
        parts = [str(p).strip() for p in value if str(p).strip()]
    return parts or None


def _split_many(*values) -> list[str] | None:
    """Column names from repeated and/or comma-separated option values (``--temp-col A,B``,
    ``--temp-col A --temp-col B``); a campaign's string or list works too."""
    parts: list[str] = []
    for v in values:
        if v is None:
            continue
        for item in [v] if isinstance(v, str) else v:
            parts += _split_cols(item) or []
    return parts or None


def ingest_overrides(opts: dict) -> dict[str, dict[str, Any]]:
    """The ingest options (the command line's keys, :data:`READ_OPTIONS` values) as profile
    overrides: ``{"columns": {...}, "gyro": {...}, "site": {...}}`` (None: not given)."""
    cols = {
        "time": opts.get("time_col"),
        "rate": _split_cols(opts.get("rate_col")),
        "counts": _split_cols(opts.get("counts_col")),
        "up": opts.get("up_col"),
        "down": opts.get("down_col"),
        "counter": _split_cols(opts.get("counter_col")),
        "voltage": _split_cols(opts.get("voltage_col")),
        "delta_angle": _split_cols(opts.get("delta_angle_col")),
        "angle": _split_cols(opts.get("angle_col")),
        "temperature": _split_many(opts.get("temp_col")),
        "field": _split_many(opts.get("field_cols"), opts.get("field_cols_alias")),
        "supply": opts.get("supply_col"),
        "table_rate": opts.get("table_col"),
        "position": opts.get("position_col"),
        "topic": opts.get("topic"),
    }
    gyro = {
        "rate_unit": opts.get("rate_unit"),
        "angle_unit": opts.get("angle_unit"),
        "output_kind": opts.get("output_kind"),
        "scale_factor": opts.get("scale_factor"),
        "offset_v": opts.get("offset"),
        "counter_bits": opts.get("counter_bits"),
        "sample_rate_hz": opts.get("sample_rate"),
        "time_unit": opts.get("time_unit"),
    }
    site: dict[str, Any] = {"latitude_deg": opts.get("latitude")}
    if opts.get("ia"):
        site["ia"] = opts["ia"]
    return {"columns": cols, "gyro": gyro, "site": site}


def split_read_options(kwargs: dict, where: str) -> dict:
    """Pop the ingest options (API names) out of ``kwargs`` and return them under the command
    line's keys; anything else left in ``kwargs`` is an unknown keyword (OptionError)."""
    opts = {READ_OPTIONS[k]: kwargs.pop(k) for k in list(kwargs) if k in READ_OPTIONS}
    if kwargs:
        bad = ", ".join(sorted(kwargs))
        raise OptionError(f"{where}: unknown keyword argument(s) {bad}",
                          fix=f"see help(gyrotest.{where}); ingest options: "
                              + ", ".join(READ_OPTIONS))
    return opts


def as_profile(profile):
    """``profile``: None, a TOML path, a dict of the TOML's shape or a
    :class:`~gyrotest.core.profile.Profile`."""
    if profile is None:
        return None
    from ..core.profile import Profile, load_profile, profile_from_dict

    if isinstance(profile, Profile):
        return profile
    if isinstance(profile, dict):
        return profile_from_dict(profile, source="profile")
    if isinstance(profile, (str, os.PathLike)):
        return load_profile(profile)
    raise OptionError(f"profile: expected a TOML path, a dict or a Profile, got "
                      f"{type(profile).__name__}")


def is_log(obj) -> bool:
    """An already read log (GyroLog, or the streamed angle series of a long Parquet log)."""
    from ..core.data import GyroLog

    if isinstance(obj, GyroLog):
        return True
    stream = sys.modules.get("gyrotest.io.stream")
    return stream is not None and isinstance(obj, stream.StreamedLog)


def _is_frame(obj) -> bool:
    pd = sys.modules.get("pandas")
    return pd is not None and isinstance(obj, pd.DataFrame)


def _sim_run(obj):
    """The first run of a simulation (Simulation, SimResult or SimRun), else None."""
    core = getattr(obj, "core", obj)
    sim = sys.modules.get("gyrotest.simulation.simrun")
    if sim is None:
        return None
    if isinstance(core, sim.SimResult):
        if len(core.runs) > 1:
            raise OptionError(f"simulation {core.name!r} has {len(core.runs)} runs",
                              fix="pass one run, e.g. sim.runs[0]")
        return core.runs[0]
    return core if isinstance(core, sim.SimRun) else None


def read_log_from(data, *, profile=None, opts: dict | None = None, sample_interval=None,
                  unit: str | None = None, name: str | None = None, stream: bool = False,
                  dead: str = "note"):
    """The engine of :func:`gyrotest.read` (arguments as there; ``opts`` under the command
    line's keys; ``dead``: a dead or stuck gyro output in a file is a note, or with
    ``"error"`` an InputError, :mod:`gyrotest.io.health`)."""
    opts = dict(opts or {})
    nan_policy = opts.pop("nan_policy", None) or "error"
    if is_log(data):
        if profile is not None or any(v not in (None, (), []) for v in opts.values()):
            raise OptionError("ingest options and a profile apply when a log is read; this "
                              "one is already read", fix="pass the file, frame or array instead")
        return data
    prof = as_profile(profile)
    run = _sim_run(data)
    if run is not None:
        import pandas as pd

        from ..core.profile import profile_from_dict

        if prof is None:
            prof = profile_from_dict(run.profile, source="simulation profile")
        frame = pd.DataFrame({k: v for k, v in run.columns.items()})
        return _from_frame(frame, prof, opts, nan_policy, name or f"simulation run {run.index}")
    if isinstance(data, (str, os.PathLike)):
        if sample_interval is not None or unit is not None:
            raise OptionError("sample_interval/unit are for arrays",
                              fix="for a file use sample_rate=HZ and rate_unit=UNIT")
        return _from_path(os.fspath(data), prof, opts, nan_policy, stream, dead)
    if _is_frame(data):
        if unit is not None:
            opts.setdefault("rate_unit", unit)
        if sample_interval is not None:
            opts["sample_rate"] = 1.0 / _positive_seconds(sample_interval, "sample_interval")
        return _from_frame(data, prof, opts, nan_policy, name or "<DataFrame>")
    import numpy as np

    if isinstance(data, np.ndarray):
        return _from_array(data, prof, opts, nan_policy, sample_interval, unit,
                           name or "<array>")
    raise OptionError(f"cannot read a {type(data).__name__} as a log",
                      fix="give a file path, a pandas DataFrame, a numpy array (with "
                          "sample_interval= and unit=), a simulation or a GyroLog")


def _positive_seconds(value, what: str) -> float:
    from ..core.units import parse_duration

    s = parse_duration(value, what=what)
    if not s > 0:
        raise OptionError(f"{what} must be > 0 s, got {value!r}")
    return s


def _from_path(path: str, prof, opts: dict, nan_policy: str, stream: bool,
               dead: str = "note"):
    over = ingest_overrides(opts)
    if stream:
        from .stream import stream_log

        log = stream_log(path, profile=prof, overrides=over, nan_policy=nan_policy)
        if log is not None:
            return log
    from .ingest import read_log

    return read_log(path, profile=prof, overrides=over, nan_policy=nan_policy, dead=dead)


def _from_frame(frame, prof, opts: dict, nan_policy: str, source: str):
    import pandas as pd
    import pyarrow as pa

    from ..core.profile import merge
    from .ingest import _naming_file, build_log, resolve_columns
    from .rawtable import RawTable

    if frame.index.name is not None or isinstance(frame.index, pd.DatetimeIndex):
        frame = frame.reset_index()  # a named (time) index is a column like any other
    frame = frame.rename(columns=str)
    if frame.columns.duplicated().any():
        dup = frame.columns[frame.columns.duplicated()][0]
        raise OptionError(f"{source}: column {dup!r} appears twice", fix="rename one of them")
    try:
        table = pa.Table.from_pandas(frame, preserve_index=False)
    except (pa.ArrowException, TypeError, ValueError) as e:
        raise OptionError(f"{source}: the frame cannot be read as a table ({e})",
                          fix="give numeric columns (and a time column in seconds or "
                              "timestamps)") from None
    p = merge(prof, ingest_overrides(opts))
    raw = RawTable(table=table, source=source, fmt="dataframe", path=None)
    roles, notes = resolve_columns(table.column_names, p, source)
    return _naming_file(source, lambda: build_log(raw, roles, p, notes, nan_policy))


def _from_array(arr, prof, opts: dict, nan_policy: str, sample_interval, unit, source: str):
    import numpy as np
    import pandas as pd

    if sample_interval is None and opts.get("sample_rate") is None:
        raise OptionError(f"{source}: an array has no time axis",
                          fix="give sample_interval= in s (or '10ms') or sample_rate= in Hz")
    if unit is None and opts.get("rate_unit") is None and opts.get("angle_unit") is None:
        raise OptionError(f"{source}: an array has no unit",
                          fix="give unit='deg/h' (or deg/s, rad/s, ...; angle_unit= with "
                              "output_kind='delta-angle')")
    a = np.asarray(arr)
    if a.ndim not in (1, 2) or a.size == 0 or not np.issubdtype(a.dtype, np.number):
        raise OptionError(f"{source}: expected a non-empty numeric 1-D array (one axis) or "
                          f"2-D array (samples x axes), got shape {a.shape}, dtype {a.dtype}")
    if a.ndim == 1:
        a = a[:, None]
    if a.shape[1] > a.shape[0]:
        raise OptionError(f"{source}: {a.shape[1]} axes of {a.shape[0]} samples",
                          fix="pass samples along the first dimension (arr.T)")
    k = a.shape[1]
    names = ["rate"] if k == 1 else (["gx", "gy", "gz"][:k] if k <= 3
                                      else [f"rate{i + 1}" for i in range(k)])
    opts = dict(opts)
    if sample_interval is not None:
        opts["sample_rate"] = 1.0 / _positive_seconds(sample_interval, "sample_interval")
    if unit is not None:
        opts.setdefault("rate_unit", unit)
    kind_col = {"delta-angle": "delta_angle_col", "angle": "angle_col"}.get(
        opts.get("output_kind") or "", "rate_col")
    opts.setdefault(kind_col, names)
    frame = pd.DataFrame({n: a[:, i].astype(float) for i, n in enumerate(names)})
    return _from_frame(frame, prof, opts, nan_policy, source)


def as_logs(data, where: str, *, profile=None, opts=None, **kw) -> list:
    """One log or a list of them (paths, frames, arrays, logs) as a list of logs."""
    items = list(data) if isinstance(data, (list, tuple)) else [data]
    if not items:
        raise OptionError(f"{where}: no log given")
    if sum(1 for p in items if isinstance(p, str) and p == "-") > 1:
        raise OptionError(f"{where}: stdin ('-') can be read only once")
    return [read_log_from(x, profile=profile, opts=opts, **kw) for x in items]


def seconds(value, what: str) -> float:
    """A duration as seconds: a number of seconds or a text such as ``"30min"``, ``"2h"``."""
    from ..core.units import parse_duration

    return parse_duration(value, what=what)


def text_list(value: str | Sequence[str] | None) -> str | None:
    """A list option given as a list or as the command line's comma-separated text → text."""
    if value is None or isinstance(value, str):
        return value
    return ",".join(str(v) for v in value)


def read_with_options(path: str, opts: dict, *, note: Callable[[str], None] | None = None,
                      stream: bool = False, dead: str = "error"):
    """Read one log as a command does, with the ingest options the command line collected
    (``opts``, under its keys): the findings about the data (a dead or saturated output, a unit
    option not used) are warnings on stderr (:func:`gyrotest.core.console.warn`), the other
    notes (the column choices) go to ``note`` when given. ``stream``: a long Parquet log may
    come back as a :class:`gyrotest.io.stream.StreamedLog` (its angle series only; see that
    module). ``dead="note"``: a dead or stuck gyro output is a note, not an error."""
    if not stream or not _parquet(path):  # a streamed log sets its own heap settings
        from .._runtime import reuse_freed_memory

        reuse_freed_memory()  # the whole record in memory: reuse freed arrays' pages
    o = api_read_options(opts)
    prof = o.pop("profile", None)
    log = read_log_from(path, profile=prof, opts=split_read_options(o, "read"), stream=stream,
                        dead=dead)
    for msg in log.notes:  # a finding about the data (a dead or saturated output) is a warning
        if msg.startswith("warning: "):
            warn(f"{log.source}: {msg[len('warning: '):]}")
        elif note is not None:
            note(f"{log.source}: {msg}")
    unused_unit_warning(log, opts)
    return log


def _parquet(path: str) -> bool:
    """A regular file starting with Parquet's magic (a pipe or device is never opened here:
    opening a FIFO with no writer would block)."""
    import stat

    try:
        if not stat.S_ISREG(os.stat(path).st_mode):
            return False
        with open(path, "rb") as fh:
            return fh.read(4) == b"PAR1"
    except OSError:
        return False


def api_read_options(opts: dict) -> dict:
    """The collected ingest options as keyword arguments of :func:`gyrotest.read`."""
    out = {api: opts[cli] for api, cli in READ_OPTIONS.items() if opts.get(cli) is not None}
    if opts.get("field_cols_alias"):  # the old spelling --field-cols, still accepted
        out["field_cols"] = list(out.get("field_cols") or ()) + [opts["field_cols_alias"]]
    out["profile"] = opts.get("profile")
    return out


def unused_unit_warning(log, opts: dict) -> None:
    """--rate-unit (or --angle-unit) on a log whose gyro output has no such column is not used:
    say so rather than leave the user believing it applied."""
    kind = getattr(getattr(log, "gyro", None), "output_kind", None)
    if kind is None:
        return
    if opts.get("rate_unit") and kind not in ("rate",):
        warn(f"{log.source}: --rate-unit {opts['rate_unit']} not used: the gyro output is "
             f"{kind}, not a rate column")
    if opts.get("angle_unit") and kind not in ("delta-angle", "angle"):
        warn(f"{log.source}: --angle-unit {opts['angle_unit']} not used: the gyro output is "
             f"{kind}, not an angle column")
