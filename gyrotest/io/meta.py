"""gyrotest's own Parquet/Feather files: the metadata written by ``gyrotest ingest``,
read back (validated like any other input) and written."""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa

from .. import __version__
from ..core.data import Gap, GyroConstants, GyroLog, Timing
from ..core.earth import Site
from ..core.errors import InputError
from ..core.profile import Profile, merge
from ..core.units import INTERNAL
from .site import site_from_profile
from .tables import META_KEY, _read_feather, _read_parquet


class MetaError(ValueError):
    """A damaged key in gyrotest's own metadata: ``key`` is its dotted path."""

    def __init__(self, key: str, problem: str):
        self.key, self.problem = key, problem
        super().__init__(f"key {key!r} {problem}")


_NUM = (int, float)
_KINDS = ("rate", "counts", "updown", "counter", "voltage", "delta-angle", "angle")


def _get(d: Any, key: str, path: str, typ, *, optional: bool = False):
    if not isinstance(d, dict):
        raise MetaError(path.rsplit(".", 1)[0] if "." in path else path, "is not a table")
    if key not in d or d[key] is None:
        if optional:
            return None
        raise MetaError(path, "is missing")
    v = d[key]
    if isinstance(v, bool) and typ is not bool:
        raise MetaError(path, f"is {v!r}, expected {_typename(typ)}")
    if not isinstance(v, typ):
        raise MetaError(path, f"is {str(v)[:40]!r}, expected {_typename(typ)}")
    if isinstance(v, float) and not math.isfinite(v):
        raise MetaError(path, f"is {v!r}, expected a finite number")
    return v


def _typename(typ) -> str:
    if typ == _NUM:
        return "a number"
    return {str: "text", int: "an integer", bool: "true/false", list: "a list",
            dict: "a table"}.get(typ, str(typ))


def validate_meta(meta: Any, names: list[str], n_rows: int) -> dict:
    """Check the metadata of a file written by ``gyrotest ingest`` against what
    :func:`_from_gyrotest` reads; raises :class:`MetaError` naming the first damaged key."""
    if not isinstance(meta, dict):
        raise MetaError("gyrotest", "is not a JSON object")
    cols = _get(meta, "columns", "columns", dict)

    def column(v: Any, path: str) -> str:
        if not isinstance(v, str):
            raise MetaError(path, f"is {str(v)[:40]!r}, expected a column name")
        if v not in names:
            raise MetaError(path, f"names column {v!r}, which the file does not have")
        return v

    rates = _get(cols, "rates", "columns.rates", dict)
    if not rates:
        raise MetaError("columns.rates", "is empty")
    for axis, c in rates.items():
        column(c, f"columns.rates.{axis}")
    for key in ("time", "supply", "table_rate", "position"):
        if cols.get(key) is not None:
            column(cols[key], f"columns.{key}")
    for key in ("temperature", "field", "extra"):
        for i, c in enumerate(_get(cols, key, f"columns.{key}", list, optional=True) or []):
            column(c, f"columns.{key}[{i}]")
    tau0 = _get(meta, "tau0_s", "tau0_s", _NUM)
    if not tau0 > 0:
        raise MetaError("tau0_s", f"is {tau0!r}, expected a positive interval in seconds")
    tm = _get(meta, "timing", "timing", dict)
    n = _get(tm, "samples", "timing.samples", int)
    if n != n_rows:
        raise MetaError("timing.samples", f"is {n}, but the file has {n_rows} rows")
    for key in ("tau0_s", "duration_s", "jitter_rel"):
        v = _get(tm, key, f"timing.{key}", _NUM)
        if v < 0 or (key == "tau0_s" and v == 0):
            raise MetaError(f"timing.{key}", f"is {v!r}, expected a positive number")
    _get(tm, "time_source", "timing.time_source", str)
    _get(tm, "irregular", "timing.irregular", bool)
    if _get(tm, "duplicates_dropped", "timing.duplicates_dropped", int) < 0:
        raise MetaError("timing.duplicates_dropped", "is negative")
    _get(tm, "start", "timing.start", str, optional=True)
    for i, g in enumerate(_get(tm, "gaps", "timing.gaps", list)):
        path = f"timing.gaps[{i}]"
        for key, typ in (("index", int), ("time_s", _NUM), ("duration_s", _NUM),
                         ("missing_samples", int)):
            if _get(g, key, f"{path}.{key}", typ) < 0:
                raise MetaError(f"{path}.{key}", "is negative")
    gm = _get(meta, "gyro", "gyro", dict)
    if _get(gm, "output_kind", "gyro.output_kind", str) not in _KINDS:
        raise MetaError("gyro.output_kind", f"is {gm['output_kind'][:20]!r}, expected one of "
                        + ", ".join(_KINDS))
    for key in ("scale_factor", "offset_v"):
        _get(gm, key, f"gyro.{key}", _NUM, optional=True)
    _get(gm, "counter_bits", "gyro.counter_bits", int, optional=True)
    for key in ("scale_factor_unit", "rate_unit", "model", "serial", "type"):
        _get(gm, key, f"gyro.{key}", str, optional=True)
    site = meta.get("site")
    if site is not None:
        lat = _get(meta, "site", "site", dict) and _get(site, "latitude_deg", "site.latitude_deg", _NUM)
        if not -90 <= lat <= 90:
            raise MetaError("site.latitude_deg", f"is {lat!r}, outside -90…90")
        _get(site, "ia_azimuth_deg", "site.ia_azimuth_deg", _NUM)
        el = _get(site, "ia_elevation_deg", "site.ia_elevation_deg", _NUM)
        if not -90 <= el <= 90:
            raise MetaError("site.ia_elevation_deg", f"is {el!r}, outside -90…90")
        _get(site, "ia", "site.ia", str)
    for key, typ in (("column_map", dict), ("units", dict), ("notes", list),
                     ("source", str), ("gyrotest_version", str)):
        _get(meta, key, key, typ, optional=True)
    if any(not isinstance(x, str) for x in meta.get("notes") or []):
        raise MetaError("notes", "holds something other than text")
    if any(not isinstance(x, str) for x in (meta.get("units") or {}).values()):
        raise MetaError("units", "holds something other than unit names")
    return meta


def read_gyrotest_table(path: Path, source: str, fmt: str):
    """The whole table of a gyrotest-converted file (a RawTable)."""
    return _read_parquet(path, source, None) if fmt == "parquet" else _read_feather(path, source, None)


def timing_from_meta(meta: dict) -> Timing:
    """The :class:`Timing` (gaps included) stored in a converted file's metadata."""
    tm = meta["timing"]
    gaps = [Gap(int(g["index"]), float(g["time_s"]), float(g["duration_s"]),
                int(g["missing_samples"])) for g in tm["gaps"]]
    return Timing(n=tm["samples"], tau0=tm["tau0_s"], duration_s=tm["duration_s"],
                  source=tm["time_source"], gaps=gaps, jitter_rel=tm["jitter_rel"],
                  irregular=tm["irregular"], duplicates_dropped=tm["duplicates_dropped"],
                  start=tm.get("start"))


def gyro_from_meta(meta: dict, prof: Profile) -> GyroConstants:
    """The :class:`GyroConstants` stored in a converted file's metadata; the profile's model,
    serial and type win."""
    gm = meta["gyro"]
    gyro = GyroConstants(**{k: gm.get(k) for k in (
        "output_kind", "scale_factor", "scale_factor_unit", "offset_v", "rate_unit",
        "counter_bits", "model", "serial", "type")})
    for k in ("model", "serial", "type"):
        if prof.gyro.get(k):
            setattr(gyro, k, prof.gyro[k])
    return gyro


def _from_gyrotest(raw, source: str, fmt: str, meta: dict, prof: Profile) -> GyroLog:
    """A GyroLog from a converted file whose metadata passed :func:`validate_meta`; a non-finite
    value in a data column raises :class:`MetaError` too (the caller reads the columns by name
    instead, where the --nan policy applies)."""
    tab = raw.table
    cols = meta["columns"]

    def col(name):
        from .fastcsv import float64_values  # Arrow's to_numpy would import pandas

        return float64_values(tab.column(name))

    rates = {axis: col(c) for axis, c in cols["rates"].items()}
    time = col(cols["time"]) if cols.get("time") else None
    for c, v in [*zip(cols["rates"].values(), rates.values()), (cols.get("time"), time)]:
        if v is not None and not np.isfinite(v).all():
            raise MetaError(f"columns ({c})", "holds NaN/±inf values a converted file never has")
    timing = timing_from_meta(meta)
    gyro = gyro_from_meta(meta, prof)
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
    from ..core.output import atomic_path

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
