"""A table as read from disk (:class:`RawTable`), before roles and units are applied, and the
column checks every reader shares: the plain-text readers (:mod:`.tables`) and the container
readers (:mod:`.containers`: MATLAB, HDF5, ROS bags) all return one."""

from __future__ import annotations

import difflib
import gzip
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pyarrow as pa

from ..core.errors import InputError


@dataclass
class RawTable:
    """A table as read from disk, before roles and units are applied."""

    table: pa.Table
    source: str
    fmt: str  # csv | tsv | whitespace | parquet | feather | mat | hdf5 | rosbag
    path: Path | None  # None for stdin
    header_line: int = 0  # 1-based line of the header in a text file
    meta: dict | None = None  # gyrotest metadata of a converted Parquet/Feather file
    # float64 columns read by the streaming reader, writeable and owned by this table: handed
    # to the first (only) role that uses them without a copy (see _column_to_float)
    owned: dict[str, np.ndarray] = field(default_factory=dict)
    exclusive: set[str] = field(default_factory=set)
    #: units the file itself states for columns (a ROS message definition, an HDF5 ``units``
    #: attribute); a profile's [units] still wins
    units: dict[str, str] = field(default_factory=dict)
    #: what the reader left out or assumed (shown as notes)
    notes: list[str] = field(default_factory=list)
    compressed: bool = False  # gzip'd text
    origin: dict = field(default_factory=dict)  # where in a container file (ROS topic ...)

    def line_of_row(self, row: int) -> int | None:
        """1-based text line of 0-based data row ``row`` (text files only)."""
        if self.fmt not in ("csv", "tsv", "whitespace"):
            return None
        if self.path is None:
            return None
        count = -1
        with (gzip.open(self.path, "rb") if self.compressed else open(self.path, "rb")) as fh:
            for lineno, line in enumerate(fh, 1):
                if lineno <= self.header_line:
                    continue
                s = line.strip()
                if not s or s.startswith(b"#"):
                    continue
                count += 1
                if count == row:
                    return lineno
        return None

    def where(self, row: int) -> str:
        line = self.line_of_row(row)
        return f"row {row + 1}" + (f" (line {line})" if line else "")


def _check_columns(wanted: list[str], names: list[str], source: str) -> None:
    for c in wanted:
        if c not in names:
            raise InputError(_missing_column_msg(c, names, source))


def _missing_column_msg(col: str, names: list[str], source: str, role: str | None = None) -> str:
    close = difflib.get_close_matches(col, names, n=1, cutoff=0.6)
    hint = f"did you mean {close[0]!r}? " if close else ""
    what = f" (named for {role})" if role else ""
    return (f"{source}: column {col!r}{what} not found; {hint}columns are: "
            f"{', '.join(names[:20])}{' ...' if len(names) > 20 else ''}")
