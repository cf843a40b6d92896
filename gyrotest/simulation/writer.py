"""Writing simulated logs: the log file, ``<stem>.truth.json`` and ``<stem>.profile.toml``.

Every file is written atomically (temporary file in the destination directory, then
``os.replace``), so an interrupted run never leaves a half-written file.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa

from ..core.errors import InputError
from ..core.output import atomic_path, write_json, write_text
from .simrun import SimResult, SimRun

FORMATS = {"csv": ".csv", "parquet": ".parquet", "feather": ".feather"}
_SUFFIX_FORMAT = {".csv": "csv", ".txt": "csv", ".parquet": "parquet", ".pq": "parquet",
                  ".feather": "feather", ".arrow": "feather", ".ipc": "feather"}


@dataclass
class WriteResult:
    """Paths written by :func:`write_log` (one log, truth and profile per run; a summary truth
    ``<stem>.truth.json`` for multi-run scenarios)."""

    logs: list[Path] = field(default_factory=list)
    truths: list[Path] = field(default_factory=list)
    profiles: list[Path] = field(default_factory=list)
    summary: Path | None = None
    format: str = "csv"
    rows: list[int] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        return {"format": self.format, "logs": [str(p) for p in self.logs],
                "truths": [str(p) for p in self.truths],
                "profiles": [str(p) for p in self.profiles],
                "summary": str(self.summary) if self.summary else None, "rows": self.rows}


def _format_for(path: Path, fmt: str | None) -> str:
    if fmt is not None:
        if fmt not in FORMATS:
            raise InputError(f"unknown output format {fmt!r}; use csv, parquet or feather")
        return fmt
    return _SUFFIX_FORMAT.get(path.suffix.lower(), "csv")


def sidecar_paths(log_path: str | Path) -> tuple[Path, Path]:
    """(truth, profile) paths beside a log: ``<stem>.truth.json``, ``<stem>.profile.toml``."""
    p = Path(log_path)
    return p.with_name(p.stem + ".truth.json"), p.with_name(p.stem + ".profile.toml")


#: what the files gyrotest simulate writes beside a log start with
_MARKERS = {".truth.json": b'"format": "gyrotest-sim-',
            ".profile.toml": b"written by 'gyrotest simulate'"}


def planned_paths(path: str | Path, fmt: str | None, runs: int) -> list[tuple[Path, str]]:
    """Every file :func:`write_log` writes for ``runs`` runs, with what each is."""
    p = Path(path)
    fmt = _format_for(p, fmt)
    if not p.suffix:
        p = p.with_suffix(FORMATS[fmt])
    out: list[tuple[Path, str]] = []
    for i in range(1, runs + 1):
        lp = p if runs == 1 else p.with_name(f"{p.stem}_run{i}{p.suffix}")
        tp, pp = sidecar_paths(lp)
        out += [(lp, "the simulated log"), (tp, "the truth file written beside the log"),
                (pp, "the profile written beside the log")]
    if runs > 1:
        out.append((p.with_name(p.stem + ".truth.json"), "the summary truth file"))
    return out


def check_planned(path: str | Path, fmt: str | None, runs: int) -> None:
    """Refuse, before anything is simulated, to write over an input (:mod:`gyrotest.core.guard`) or
    over a ``.truth.json``/``.profile.toml`` beside the output that simulate did not write (a
    user's own profile of the same name) unless ``--force``."""
    from ..core.guard import declare_output, forced

    for p, what in planned_paths(path, fmt, runs):
        declare_output(p, what)
        marker = next((m for suf, m in _MARKERS.items() if p.name.endswith(suf)), None)
        if marker is None or what == "the simulated log" or not p.exists() or forced():
            continue
        from ..core.guard import is_ours

        if not is_ours(p, marker):
            raise InputError(f"{p} exists and was not written by 'gyrotest simulate' (a file of "
                             f"your own?); it would be replaced by {what}: name another "
                             "output, or pass --force to replace it")


def write_log(result: SimResult | SimRun, path: str | Path, fmt: str | None = None
              ) -> WriteResult:
    """Write the simulated log(s) and the truth and profile files beside each.

    ``fmt``: csv, parquet or feather (default from the suffix of ``path``, else csv). A
    multi-run result writes ``<stem>_run1<ext>``, ``<stem>_run2<ext>``, ... each with its own
    ``.truth.json`` and ``.profile.toml``, plus the summary ``<stem>.truth.json``.
    """
    p = Path(path)
    fmt = _format_for(p, fmt)
    if not p.suffix:
        p = p.with_suffix(FORMATS[fmt])
    runs = [result] if isinstance(result, SimRun) else list(result.runs)
    wr = WriteResult(format=fmt)
    for run in runs:
        lp = p if len(runs) == 1 else p.with_name(f"{p.stem}_run{run.index}{p.suffix}")
        _write_table(run.columns, lp, fmt)
        tp, pp = sidecar_paths(lp)
        truth = dict(run.truth)
        truth["files"] = {"log": lp.name, "profile": pp.name, "format": fmt}
        write_json(tp, truth)
        write_text(pp, profile_toml(run.profile, header=_header(run)))
        wr.logs.append(lp)
        wr.truths.append(tp)
        wr.profiles.append(pp)
        wr.rows.append(int(len(next(iter(run.columns.values())))))
    if isinstance(result, SimResult) and len(runs) > 1:
        sp = p.with_name(p.stem + ".truth.json")
        summary = dict(result.summary)
        summary["files"] = [{"log": lp.name, "truth": tp.name, "profile": pp.name}
                            for lp, tp, pp in zip(wr.logs, wr.truths, wr.profiles)]
        write_json(sp, summary)
        wr.summary = sp
    return wr


def _header(run: SimRun) -> str:
    t = run.truth
    return (f"# bench profile written by 'gyrotest simulate' (scenario {t.get('scenario')!r}, "
            f"run {t.get('run')}/{t.get('runs')}, seed {t.get('seed')})")


def _arrow_table(columns: dict[str, np.ndarray]) -> pa.Table:
    arrays = []
    for v in columns.values():
        a = np.asarray(v)
        if a.dtype.kind in "OUS":
            arrays.append(pa.array(a.astype(str).tolist(), type=pa.string()))
        else:
            arrays.append(pa.array(a))
    return pa.Table.from_arrays(arrays, names=list(columns))


def _write_table(columns: dict[str, np.ndarray], path: Path, fmt: str) -> None:
    table = _arrow_table(columns)
    with atomic_path(path) as tmp:
        if fmt == "csv":
            _write_csv(table, tmp)
        elif fmt == "parquet":
            import pyarrow.parquet as pq

            pq.write_table(table, tmp)
        else:
            import pyarrow.feather as pf

            pf.write_feather(table, tmp)


def _write_csv(table: pa.Table, path: Path) -> None:
    """Plain CSV like a bench logger writes: unquoted header and values (quoted only where a
    value contains a comma, quote or newline)."""
    from pyarrow import csv as pacsv

    def q(name: str) -> str:
        return '"' + name.replace('"', '""') + '"' if any(c in name for c in ',"\n') else name

    with open(path, "wb") as fh:
        fh.write((",".join(q(c) for c in table.column_names) + "\n").encode("utf-8"))
        try:
            pacsv.write_csv(table, fh, pacsv.WriteOptions(include_header=False,
                                                          quoting_style="none"))
        except pa.ArrowInvalid:
            fh.seek(0)
            fh.truncate(0)
            fh.write((",".join(q(c) for c in table.column_names) + "\n").encode("utf-8"))
            pacsv.write_csv(table, fh, pacsv.WriteOptions(include_header=False,
                                                          quoting_style="needed"))


# ------------------------------------------------------------------------------ TOML

_BARE = re.compile(r"^[A-Za-z0-9_-]+$")


def _toml_key(k: str) -> str:
    return k if _BARE.match(k) else json.dumps(k, ensure_ascii=False)


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        x = float(v)
        if not math.isfinite(x):
            raise ValueError(f"cannot write non-finite number {x} to TOML")
        r = repr(x)
        return r if any(c in r for c in ".en") else r + ".0"
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise TypeError(f"cannot write {type(v).__name__} to TOML")


def profile_toml(profile: dict[str, dict[str, Any]], header: str = "") -> str:
    """Serialise a bench profile (sections of scalars and lists) as TOML."""
    lines = [header] if header else []
    for section, body in profile.items():
        if not body:
            continue
        if lines:
            lines.append("")
        lines.append(f"[{section}]")
        for k, v in body.items():
            lines.append(f"{_toml_key(k)} = {_toml_value(v)}")
    return "\n".join(lines) + "\n"
