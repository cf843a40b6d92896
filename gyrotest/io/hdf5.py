"""HDF5 logs (and MATLAB v7.3 ``.mat`` files, which are HDF5) through h5py.

Columns are the numeric datasets of the file (or of the group named with ``--topic``):

* a 1-D dataset (or N×1) is one column named after the dataset;
* an N×k matrix is k columns: ``name_x/_y/_z`` for three channels, else ``name_1 … name_k``
  (MATLAB stores matrices transposed; the longer dimension is always taken as time);
* a compound dataset (a table with named fields) gives one column per numeric field.

A ``units``/``unit`` attribute on a dataset is used as the unit of its column(s). Only the
datasets of the columns used are read, each straight from the file (h5py reads chunk by chunk),
so a large file is never loaded whole. Requires ``h5py`` (``pip install 'gyrotest[hdf5]'``).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..core.errors import InputError
from .containerbase import (
    MAX_MATRIX_CHANNELS,
    Found,
    equal_lengths,
    matrix_columns,
    need,
    unique_names,
)

_MATLAB_SKIP = {"char", "cell", "function_handle", "canonical empty"}


@dataclass
class _Col:
    path: str  # dataset path in the file
    index: int | str | None  # channel of a matrix, field of a compound dataset, None: 1-D
    length: int
    transposed: bool = False  # channels along the first axis of the stored array


def _attr_text(v: Any) -> str | None:
    if isinstance(v, bytes):
        return v.decode("utf-8", errors="replace")
    if isinstance(v, str):
        return v
    if isinstance(v, np.ndarray) and v.size == 1:
        return _attr_text(v.reshape(-1)[0])
    return None


def _matlab_class(obj) -> str | None:
    return _attr_text(obj.attrs.get("MATLAB_class"))


def _entries(h5py, base, prefix: str, matlab: bool, recurse: bool
             ) -> tuple[list[tuple[str, _Col]], dict[str, str], list[str]]:
    """(column name, where) for every numeric dataset under ``base``; units; struct groups
    seen but not entered (MATLAB)."""
    out: list[tuple[str, _Col]] = []
    units: dict[str, str] = {}
    skipped: list[str] = []
    for key in base:
        if key.startswith("#"):  # MATLAB's #refs# / #subsystem#
            continue
        try:
            obj = base[key]
        except (KeyError, OSError):  # a dangling link
            continue
        path = f"{prefix}/{key}"
        if isinstance(obj, h5py.Group):
            if recurse:
                o, u, s = _entries(h5py, obj, path, matlab, recurse)
                out += o
                units.update(u)
                skipped += s
            else:
                skipped.append(key)
            continue
        if not isinstance(obj, h5py.Dataset):
            continue
        if matlab and (_matlab_class(obj) or "") in _MATLAB_SKIP:
            continue
        unit = _attr_text(obj.attrs.get("units", obj.attrs.get("unit")))
        dt = obj.dtype
        if dt.names:  # compound table
            if len(obj.shape) != 1:
                continue
            for f in dt.names:
                if dt.fields[f][0].kind in "biuf" and dt.fields[f][0].shape == ():
                    out.append((f, _Col(path, f, obj.shape[0])))
            continue
        if dt.kind not in "biuf" or obj.size < 2:
            continue
        shape = [s for s in obj.shape if s != 1]
        if len(shape) == 1:
            out.append((key, _Col(path, None, shape[0])))
            if unit:
                units[key] = unit
        elif len(shape) == 2 and len(obj.shape) == 2:
            n, k = max(obj.shape), min(obj.shape)
            if k > MAX_MATRIX_CHANNELS:
                continue
            transposed = obj.shape[0] < obj.shape[1]
            for i, name in enumerate(matrix_columns(key, k)):
                out.append((name, _Col(path, i, n, transposed)))
                if unit:
                    units[name] = unit
    return out, units, skipped


def scan(f, h5py, source: str, select: str | None, *, matlab: bool) -> tuple[Found, dict]:
    """The columns of an open HDF5 file: (Found without arrays, name → _Col)."""
    what = "MATLAB v7.3 file" if matlab else "HDF5 file"
    base = f
    if select and select.strip("/"):
        key = select.strip("/")
        if key not in f or not isinstance(f[key], h5py.Group):
            groups = []
            f.visit(lambda n: groups.append(n) if isinstance(f[n], h5py.Group)
                    and not n.startswith("#") else None)
            raise InputError(f"{source}: no group {select!r} in the {what}; groups: "
                             f"{', '.join(groups[:12]) or 'none'}")
        base = f[key]
        what = f"group {select!r}"
    entries, units, skipped = _entries(h5py, base, "/" + (select or "").strip("/"), matlab,
                                       recurse=not matlab or bool(select))
    found = Found(what)
    if matlab and not entries and not select and len(skipped) == 1:
        # only a struct: its fields are the columns
        entries, units, _ = _entries(h5py, base[skipped[0]], "/" + skipped[0], True, True)
        found.notes.append(f"columns from struct {skipped[0]!r}")
        found.what = f"struct {skipped[0]!r}"
    elif matlab and skipped:
        found.notes.append(f"struct(s) {', '.join(map(repr, skipped[:6]))} not read; name "
                           "one with --topic to read its fields")
    # lengths are compared by path (``imu/time`` and ``gps/time`` differ); the columns kept
    # are named by their dataset (a clash gets a numeric suffix)
    where = {f"{c.path.rsplit('/', 1)[0]}/{n}".lstrip("/"): (n, c) for n, c in entries}
    keep, notes = equal_lengths({k: c.length for k, (_, c) in where.items()}, source,
                                found.what)
    found.notes += notes
    names = unique_names([where[k][0] for k in keep])
    cols = {n: where[k][1] for n, k in zip(names, keep)}
    found.names = names
    found.units = {n: units[where[k][0]] for n, k in zip(names, keep) if where[k][0] in units}
    return found, cols


def read_columns(f, found: Found, cols: dict, wanted: list[str]) -> None:
    """Read the ``wanted`` columns into ``found.arrays`` (a matrix dataset once for all its
    channels)."""
    cache: dict[str, np.ndarray] = {}
    for name in wanted:
        c = cols.get(name)
        if c is None:
            continue
        ds = f[c.path]
        if isinstance(c.index, str):  # compound field: reads only that field
            a = np.asarray(ds.fields(c.index)[()])
        elif c.index is None:
            a = np.asarray(ds[()]).reshape(-1)
        else:
            m = cache.get(c.path)
            if m is None:
                m = cache[c.path] = np.asarray(ds[()])
            a = m[c.index, :] if c.transposed else m[:, c.index]
        found.arrays[name] = as_column(np.ascontiguousarray(a))


def as_column(a: np.ndarray) -> np.ndarray:
    """float64, or int64 for 64-bit integers (nanosecond timestamps keep every digit)."""
    if a.dtype.itemsize == 8 and a.dtype.kind in "iu":
        return a.astype(np.int64, copy=False)
    return a.astype(np.float64, copy=False)


def read_hdf5(p: Path, source: str, columns: list[str] | None, select: str | None, *,
              names_only: bool = False, matlab: bool = False) -> Found:
    """Read an HDF5 file (see the module docstring)."""
    what = "a MATLAB v7.3 file" if matlab else "an HDF5 file"
    h5py = need("h5py", "hdf5", source, what)
    try:
        f = h5py.File(p, "r")
    except OSError as e:
        raise InputError(f"{source}: not a readable HDF5 file ({str(e).splitlines()[0][:120]}); "
                         "the file may be truncated or damaged") from None
    try:
        with f:
            found, cols = scan(f, h5py, source, select, matlab=matlab)
            if not names_only:
                read_columns(f, found, cols, columns if columns is not None else found.names)
    except InputError:
        raise
    except (OSError, KeyError, ValueError, TypeError, RuntimeError) as e:
        raise InputError(f"{source}: cannot read {what} ({type(e).__name__}: "
                         f"{str(e).splitlines()[0][:120]}); the file may be truncated or "
                         "damaged") from None
    return found
