"""Readers for the public reference records used by the conformance checks.

Stable32 result tables (``AF Tau # Alpha MinSigma Sigma MaxSigma``, 68.3 % intervals) and
gzip'd ``time,rate`` CSV records (the AllanTools test data: GPS 1PPS, Cs 5071A, Keysight
53230A TIC, pink noise; W. J. Riley, *Handbook of Frequency Stability Analysis*, NIST SP 1065,
2008, for the table format). Used by the tests and benchmarks only; the data themselves are not
part of the package.
"""

from __future__ import annotations

import gzip
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["Stable32Row", "load_rate_csv", "read_stable32", "stable32_table_kind"]


@dataclass(frozen=True)
class Stable32Row:
    m: int
    tau: float
    n: int
    alpha: int
    lo: float
    sigma: float
    hi: float


def read_stable32(path: str | Path) -> list[Stable32Row]:
    """Rows of a Stable32 table (comment lines ``#`` skipped)."""
    rows = []
    for line in Path(path).read_text().splitlines():
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        p = line.split()
        rows.append(Stable32Row(int(p[0]), float(p[1]), int(p[2]), int(p[3]), float(p[4]),
                                float(p[5]), float(p[6])))
    return rows


def stable32_table_kind(path: str | Path) -> str:
    """The deviation kind of a table file named ``<set>_<kind>[_<grid>].txt``."""
    name = Path(path).stem.lower()
    for k in ("ohdev", "oadev", "totdev", "mdev", "tdev", "hdev", "adev"):
        if re.search(rf"(^|_){k}(_|$)", name):
            return k
    raise ValueError(f"no deviation kind in {Path(path).name}")


def load_rate_csv(path: str | Path, column: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """(time, value) columns of a (gzip'd) CSV with one header line."""
    path = Path(path)
    opener = gzip.open if path.suffix == ".gz" else open
    with opener(path, "rt") as fh:
        data = np.loadtxt(fh, delimiter=",", skiprows=1, usecols=(0, column))
    return data[:, 0], data[:, 1]
