"""Logs inside container files: MATLAB ``.mat``, HDF5 and ROS bags.

:func:`container_format` recognises the file (by its magic bytes, else its suffix, and a ROS 2
bag directory by its ``metadata.yaml``); :func:`read_container` hands it to the reader module
(:mod:`.matlab`, :mod:`.hdf5`, :mod:`.rosbag`), which returns named 1-D arrays. This module
turns those into the same :class:`~gyrotest.io.tables.RawTable` the text readers produce, so
column roles, units and timing are applied exactly as for a CSV.

The HDF5 and ROS readers need optional packages (``h5py``, ``rosbags``); when one is missing
the error names the pip extra that installs it.
"""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import numpy as np
import pyarrow as pa

from ..core.errors import InputError
from .tables import RawTable, _check_columns

HDF5_MAGIC = b"\x89HDF\r\n\x1a\n"
MCAP_MAGIC = b"\x89MCAP"
ROSBAG1_MAGIC = b"#ROSBAG V2.0"
SQLITE_MAGIC = b"SQLite format 3\x00"
MAT5_TEXT = b"MATLAB 5.0 MAT-file"
MAT73_TEXT = b"MATLAB 7.3 MAT-file"

_SUFFIX = {".mat": "mat", ".h5": "hdf5", ".hdf5": "hdf5", ".hdf": "hdf5", ".he5": "hdf5",
           ".bag": "rosbag", ".mcap": "rosbag", ".db3": "rosbag"}

#: a vector this much shorter than the table's columns is a constant (a calibration vector),
#: left out with a note; a longer one of another length is an error (a truncated column)
SHORT_FRACTION = 0.1


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


def need(module: str, extra: str, source: str, what: str):
    """Import an optional package, or a one-line error naming the pip extra."""
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError:
        raise InputError(f"{source}: reading {what} needs the Python package {module!r}; "
                         f"install it with: pip install 'gyrotest[{extra}]'") from None


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


class Found:
    """What a container reader found: column names (in file order), their arrays (only
    those read), units the file states, notes, and what the columns came from."""

    def __init__(self, what: str):
        self.what = what
        self.names: list[str] = []
        self.arrays: dict[str, np.ndarray] = {}
        self.units: dict[str, str] = {}
        self.notes: list[str] = []
        self.origin: dict[str, str] = {}  # e.g. the ROS topic the columns came from


def equal_lengths(lengths: dict[str, int], source: str, what: str) -> tuple[list[str], list[str]]:
    """Pick the vectors that form the table: the length most vectors share (ties: the longer).

    Returns (kept names, notes). Much shorter vectors (constants) are left out with a note;
    a vector of comparable but different length is an error naming both lengths."""
    if not lengths:
        raise InputError(f"{source}: no numeric vector in the {what}; gyrotest reads "
                         "equal-length numeric vectors (time, gyro axes ...) as columns")
    counts = Counter(lengths.values())
    n = max(counts, key=lambda k: (counts[k], k))
    keep = [k for k, v in lengths.items() if v == n]
    short = [k for k, v in lengths.items() if v != n and v < SHORT_FRACTION * n]
    odd = [k for k, v in lengths.items() if v != n and v >= SHORT_FRACTION * n]
    if odd:
        k = odd[0]
        raise InputError(
            f"{source}: vectors of different lengths in the {what}: {k!r} has {lengths[k]:,} "
            f"values, {keep[0]!r} (and {len(keep) - 1} more) {n:,}; columns must have equal "
            "lengths: fix the file, or store the log in its own struct/group and name it "
            "with --topic")
    notes = []
    if short:
        notes.append(f"left out short vector(s) {', '.join(map(repr, short[:8]))} (not "
                     f"{n:,} samples long)")
    return keep, notes


def matrix_columns(name: str, k: int, hint: list[str] | None = None) -> list[str]:
    """Column names for the k channels of an N×k matrix: the hint's names when it has k,
    ``name_x/_y/_z`` for three channels, else ``name_1 … name_k``."""
    if hint is not None and len(hint) == k:
        return [str(h).strip() for h in hint]
    if k == 3:
        return [f"{name}_{a}" for a in "xyz"]
    return [f"{name}_{i + 1}" for i in range(k)]


#: most channels an N×k matrix may have to be read as k columns (more: not a log)
MAX_MATRIX_CHANNELS = 64


def as_channels(a: np.ndarray) -> np.ndarray | None:
    """A 1-D or N×k numeric array as (k, N) channels (the longer dimension is time), or
    None when it is not a vector/matrix of numbers."""
    if a.dtype.kind not in "biuf" or a.size < 2:
        return None
    a = np.squeeze(a)
    if a.ndim == 1:
        return a[None, :]
    if a.ndim != 2:
        return None
    if a.shape[0] >= a.shape[1]:
        a = a.T
    if a.shape[0] > MAX_MATRIX_CHANNELS:
        return None
    return a


def unique_names(names: list[str]) -> list[str]:
    """Names made unique by a numeric suffix (two groups holding ``gx``)."""
    seen: Counter[str] = Counter()
    out = []
    for n in names:
        seen[n] += 1
        out.append(n if seen[n] == 1 else f"{n}_{seen[n]}")
    return out
