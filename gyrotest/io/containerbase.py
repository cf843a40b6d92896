"""What the container readers (:mod:`.matlab`, :mod:`.hdf5`, :mod:`.rosbag`) share: an optional
package named by its pip extra (:func:`need`), the named arrays a reader returns
(:class:`Found`), and the checks that turn arrays into channels (equal lengths, matrix
columns, unique names). The dispatcher that picks the reader is :mod:`.containers`."""

from __future__ import annotations

from collections import Counter

import numpy as np

from ..core.errors import InputError

MAT73_TEXT = b"MATLAB 7.3 MAT-file"


#: a vector this much shorter than the table's columns is a constant (a calibration vector),
#: left out with a note; a longer one of another length is an error (a truncated column)
SHORT_FRACTION = 0.1


def need(module: str, extra: str, source: str, what: str):
    """Import an optional package, or a one-line error naming the pip extra."""
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError:
        raise InputError(f"{source}: reading {what} needs the Python package {module!r}; "
                         f"install it with: pip install 'gyrotest[{extra}]'") from None


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
