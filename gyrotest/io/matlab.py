"""MATLAB ``.mat`` logs: v4 to v7.2 through ``scipy.io.loadmat``, v7.3 (HDF5) through h5py.

Columns are the numeric variables of the file, or the fields of the struct named with
``--topic`` (a file whose only variable is a struct is read from that struct):

* a vector (N×1 or 1×N) is one column named after the variable (``t``/``time`` is the time
  column, ``gx``/``gyro_x``/``rate`` a rate column, as in a CSV header);
* an N×k matrix is k columns: the names in a companion cell array or char matrix
  ``<name>_names`` (or ``names``/``colnames``/``labels`` when the file holds one matrix),
  else ``name_x/_y/_z`` for three channels and ``name_1 … name_k`` otherwise;
* scalars, strings and cell arrays are not columns; vectors much shorter than the others
  (calibration constants) are left out with a note.

MATLAB files carry no units: give them with ``--rate-unit`` (and a profile's ``[units]``) or
in the variable names (``gx_dps``).
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from ..core.errors import InputError
from .containerbase import MAT73_TEXT, Found, as_channels, equal_lengths, matrix_columns
from .hdf5 import as_column

_HINT_SUFFIXES = ("_names", "_columns", "_colnames", "_labels", "_header")
_HINT_GENERIC = ("names", "colnames", "columns", "labels", "header", "headers", "varnames")

#: the last file loaded by scipy (path, size, mtime) → variables: the names pass and the
#: data pass of one read_log share a single loadmat
_cache: dict[tuple, dict] = {}


def _is_v73(p: Path) -> bool:
    with open(p, "rb") as fh:
        return fh.read(128).startswith(MAT73_TEXT)


def _strings(v) -> list[str] | None:
    """A cell array of strings or a char matrix as a list of names, else None."""
    if isinstance(v, str):
        return None
    if isinstance(v, (list, tuple)) and all(isinstance(x, str) for x in v):
        return list(v)
    if isinstance(v, np.ndarray):
        if v.dtype.kind == "U":
            return [str(x).strip() for x in v.reshape(-1)]
        if v.dtype == object and all(isinstance(x, str) for x in v.reshape(-1)):
            return [x for x in v.reshape(-1)]
    return None


def _load(p: Path, source: str) -> dict:
    st = p.stat()
    key = (str(p.resolve()), st.st_size, st.st_mtime_ns)
    if key in _cache:
        return _cache[key]
    import scipy.io

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # scipy's "duplicate variable name" and the like
            data = scipy.io.loadmat(p, simplify_cells=True)
    except MemoryError:
        raise InputError(f"{source}: the MATLAB file does not fit in memory; save the log as "
                         "-v7.3 (read piece by piece) or as CSV") from None
    except Exception as e:  # scipy raises ValueError, TypeError, MatReadError, OSError ...
        raise InputError(f"{source}: not a readable MATLAB file ({type(e).__name__}: "
                         f"{str(e).splitlines()[0][:120] if str(e) else 'damaged or truncated'}"
                         "); re-save it with save(..., '-v7') or export a CSV") from None
    _cache.clear()
    _cache[key] = data
    return data


def _columns_of(variables: dict, found: Found) -> tuple[dict[str, np.ndarray], list[str]]:
    """(column → 1-D array, struct variables not entered)."""
    cols: dict[str, np.ndarray] = {}
    structs: list[str] = []
    matrices = [k for k, v in variables.items()
                if isinstance(v, np.ndarray) and (c := as_channels(v)) is not None
                and c.shape[0] > 1]
    for name, v in variables.items():
        if name.startswith("__"):
            continue
        if isinstance(v, dict):
            structs.append(name)
            continue
        if not isinstance(v, np.ndarray):
            continue
        ch = as_channels(v)
        if ch is None:
            continue
        if ch.shape[0] == 1:
            cols[name] = ch[0]
            continue
        hint = None
        for h in [name + s for s in _HINT_SUFFIXES] + (
                list(_HINT_GENERIC) if len(matrices) == 1 else []):
            if h in variables and (hint := _strings(variables[h])) is not None:
                if len(hint) == ch.shape[0]:
                    break
                hint = None
        for i, col in enumerate(matrix_columns(name, ch.shape[0], hint)):
            cols[col] = ch[i]
        if hint:
            found.notes.append(f"matrix {name!r}: column names from {h!r}")
    return cols, structs


def read_mat(p: Path, source: str, columns: list[str] | None, select: str | None, *,
             names_only: bool = False) -> Found:
    """Read a MATLAB file (see the module docstring)."""
    if _is_v73(p):
        from .hdf5 import read_hdf5

        return read_hdf5(p, source, columns, select, names_only=names_only, matlab=True)
    variables = _load(p, source)
    found = Found("MATLAB file")
    if select:
        v = variables.get(select)
        if not isinstance(v, dict):
            structs = [k for k, x in variables.items() if isinstance(x, dict)]
            raise InputError(f"{source}: no struct {select!r} in the MATLAB file; structs: "
                             f"{', '.join(structs) or 'none'}")
        cols, _ = _columns_of(v, found)
        found.what = f"struct {select!r}"
    else:
        cols, structs = _columns_of(variables, found)
        if not cols and len(structs) == 1:
            cols, _ = _columns_of(variables[structs[0]], found)
            found.notes.append(f"columns from struct {structs[0]!r}")
            found.what = f"struct {structs[0]!r}"
        elif structs:
            found.notes.append(f"struct(s) {', '.join(map(repr, structs[:6]))} not read; name "
                               "one with --topic to read its fields")
    keep, notes = equal_lengths({k: v.size for k, v in cols.items()}, source, found.what)
    found.notes += notes
    found.names = keep
    if not names_only:
        for k in (columns if columns is not None else keep):
            if k in cols:
                found.arrays[k] = np.array(as_column(cols[k]))  # own, writeable copy
        _cache.clear()
    return found
