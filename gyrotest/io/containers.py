"""Logs inside container files: MATLAB ``.mat``, HDF5 and ROS bags.

:func:`container_format` recognises the file (by its magic bytes, else its suffix, and a ROS 2
bag directory by its ``metadata.yaml``); :func:`read_container` hands it to the reader module
(:mod:`.matlab`, :mod:`.hdf5`, :mod:`.rosbag`), which returns named 1-D arrays. This module
turns those into the same :class:`~gyrotest.io.rawtable.RawTable` the text readers produce, so
column roles, units and timing are applied exactly as for a CSV.

The HDF5 and ROS readers need optional packages (``h5py``, ``rosbags``); when one is missing
the error names the pip extra that installs it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyarrow as pa

from ..core.errors import InputError
from .containerbase import MAT73_TEXT
from .rawtable import RawTable, _check_columns

HDF5_MAGIC = b"\x89HDF\r\n\x1a\n"
MCAP_MAGIC = b"\x89MCAP"
ROSBAG1_MAGIC = b"#ROSBAG V2.0"
SQLITE_MAGIC = b"SQLite format 3\x00"
MAT5_TEXT = b"MATLAB 5.0 MAT-file"

_SUFFIX = {".mat": "mat", ".h5": "hdf5", ".hdf5": "hdf5", ".hdf": "hdf5", ".he5": "hdf5",
           ".bag": "rosbag", ".mcap": "rosbag", ".db3": "rosbag"}


def container_format(p: Path, head: bytes | None) -> str | None:
    """``mat``, ``hdf5``, ``rosbag`` or None (a text/Parquet/Feather table). ``head`` None:
    decide from the path alone (only a ROS 2 bag directory can be recognised so)."""
    if head is None:
        try:
            if p.is_dir() and (p / "metadata.yaml").is_file():
                return "rosbag"
        except OSError:
            return None
        return None
    if head.startswith(MAT5_TEXT) or head.startswith(MAT73_TEXT):
        return "mat"
    if head.startswith(HDF5_MAGIC):
        return "hdf5"
    if head.startswith(ROSBAG1_MAGIC) or head.startswith(MCAP_MAGIC):
        return "rosbag"
    if head.startswith(SQLITE_MAGIC) and p.suffix.lower() == ".db3":
        return "rosbag"
    return _SUFFIX.get(p.suffix.lower())


def read_container(fmt: str, p: Path, source: str, columns: list[str] | None,
                   select: str | None, *, names_only: bool = False) -> RawTable:
    """Read a container file into a RawTable (only ``columns`` when given; with
    ``names_only`` a table without rows that carries the column names)."""
    if fmt == "mat":
        from .matlab import read_mat as reader
    elif fmt == "hdf5":
        from .hdf5 import read_hdf5 as reader
    else:
        from .rosbag import read_bag as reader
    found = reader(p, source, columns, select, names_only=names_only)
    if names_only:
        schema = pa.schema([(n, pa.float64()) for n in found.names])
        empty = pa.Table.from_batches([], schema=schema)
        return RawTable(empty, source, fmt, p, units=found.units, notes=found.notes,
                        origin=found.origin)
    if columns is not None:
        _check_columns(columns, found.names, source)
    arrays = {n: found.arrays[n] for n in (columns if columns is not None else found.names)}
    table = pa.Table.from_arrays([pa.array(v) for v in arrays.values()], names=list(arrays))
    if table.num_rows == 0:
        raise InputError(f"{source}: no samples in the {found.what}")
    owned = {n: v for n, v in arrays.items() if v.dtype == np.float64 and v.flags.writeable}
    return RawTable(table, source, fmt, p, units=found.units, notes=found.notes, owned=owned,
                    origin=found.origin)


