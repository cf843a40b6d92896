"""gyrotest's own Parquet/Feather files: the metadata written by ``gyrotest ingest``,
read back (validated like any other input) and written."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa

from .. import __version__
from ..data import Gap, GyroConstants, GyroLog, Timing
from ..earth import Site
from ..errors import InputError
from ..profile import Profile, merge
from ..units import INTERNAL
from .site import site_from_profile
from .tables import META_KEY, _read_feather, _read_parquet


def _from_gyrotest(path: Path, source: str, fmt: str, meta: dict, prof: Profile) -> GyroLog:
    raw = _read_parquet(path, source, None) if fmt == "parquet" else _read_feather(path, source, None)
    tab = raw.table
    cols = meta["columns"]

    def col(name):
        a = tab.column(name)
        out = a.to_numpy() if a.null_count == 0 else a.to_numpy(zero_copy_only=False)
        return np.asarray(out, dtype=np.float64)

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
    from ..output import atomic_path

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
