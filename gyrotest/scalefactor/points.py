"""Plateau tables on disk: ``--points FILE.csv`` (write) and ``--table FILE.csv`` (read).

The written table has one row per plateau (``run, index, sweep, table_rate_dps, ...,
output_dph, stderr_dph, temperature_degC, linearity_ppm_fs, ...``) and two comment lines
with the output kind and the nominal scale factor, so it reads straight back with
``--table``. A lab's own spreadsheet table needs, case-insensitively:

* input: ``table_rate_dps`` / ``table_rate_dph`` / ``rate_dps`` / ``rate_dph`` /
  ``input_dps`` / ``input_dph`` — the table rate; the earth-rate component is added from an
  ``earth_rate_dph`` column or from ``--latitude/--ia``;
* output: ``output_dph`` (S0 × output, deg/h; kind ``rate`` unless the comment says
  otherwise), ``output_pps`` (pulse/s: SF in arcsec/pulse) or ``output_v`` (V: SF in
  (deg/h)/V); S0 from ``--scale-factor`` or 1;
* optional: ``stderr_*`` (same unit as the output; without it the fit is unweighted),
  ``temperature_degC``, ``run``, ``sweep``, ``t_start_s``/``t_end_s``.
"""

from __future__ import annotations

import io
import math
import re
from pathlib import Path

import numpy as np
import pandas as pd

from ..core.errors import InputError
from ..core.output import atomic_open
from .plateaus import DPS, Plateau, RunPlateaus, assign_sweeps

_INPUT = {"table_rate_dps": DPS, "table_rate_dph": 1.0, "rate_dps": DPS, "rate_dph": 1.0,
          "input_dps": DPS, "input_dph": 1.0, "input_rate_dps": DPS, "input_rate_dph": 1.0,
          "table_dps": DPS, "table_dph": 1.0}
_OUTPUT = {"output_dph": ("rate", "dph"), "output_dps": ("rate", "dps"),
           "output_pps": ("counts", "pps"), "output_pulse_per_s": ("counts", "pps"),
           "output_v": ("voltage", "v"), "output_volt": ("voltage", "v")}
_TEMP = ("temperature_degc", "temperature_c", "temp_c", "temperature", "temp")


def write_points_csv(result, path: str | Path) -> Path:
    """Write the plateau table of a :class:`ScaleFactorResult` (atomic)."""
    rows = result.to_dict()["points"]
    df = pd.DataFrame(rows)
    p = Path(path)
    with atomic_open(p, "w", encoding="utf-8", newline="") as fh:
        fh.write(f"# gyrotest scale-factor points; output_kind={result.output_kind}\n")
        fh.write(f"# nominal_scale_factor={result.nominal_scale_factor!r} {result.sf_unit}\n")
        df.to_csv(fh, index=False, lineterminator="\n", float_format="%.12g")
    return p


def _meta(text: str) -> dict:
    meta = {}
    for line in text.splitlines()[:20]:
        if not line.startswith("#"):
            break
        for k, v in re.findall(r"(output_kind|nominal_scale_factor)=([^\s;]+)", line):
            meta[k] = v
    return meta


def read_points_table(path: str | Path, *, earth_rate_dph: float | None = None,
                      scale_factor: float | None = None
                      ) -> tuple[list[RunPlateaus], str, float | None, list[str]]:
    """Read a ready plateau table (see module doc). Returns (runs, output_kind, S0, notes)."""
    from ..core.documents import read_table_text

    p = Path(path)
    src = str(p)
    text = read_table_text(p, "the plateau table")  # FIFO, device, gzip, encoding: one line
    try:
        df = pd.read_csv(io.StringIO(text), comment="#", skipinitialspace=True)
    except (ValueError, pd.errors.ParserError) as e:
        raise InputError(f"{src}: cannot read the points table: {str(e).splitlines()[0][:150]}") from None
    if df.empty:
        raise InputError(f"{src}: the points table has no rows")
    cols = {c.strip().lower(): c for c in df.columns}
    notes: list[str] = []
    inp = next((c for c in _INPUT if c in cols), None)
    out = next((c for c in _OUTPUT if c in cols), None)
    if inp is None or out is None:
        need = "an input-rate column (table_rate_dps, rate_dps, input_dps, ... or *_dph)" if inp is None \
            else "an output column (output_dph, output_pps or output_v)"
        raise InputError(f"{src}: the points table needs {need}; columns are: "
                         f"{', '.join(map(str, df.columns[:15]))}")
    meta = _meta(text)
    kind, ounit = _OUTPUT[out]
    if ounit == "dph" and meta.get("output_kind"):
        kind = meta["output_kind"]
    s0 = scale_factor
    if s0 is None and ounit == "dph" and meta.get("nominal_scale_factor"):
        try:
            s0 = float(meta["nominal_scale_factor"])
        except ValueError:
            s0 = None

    def num(col: str) -> np.ndarray:
        v = pd.to_numeric(df[cols[col]], errors="coerce").to_numpy(dtype=float)
        bad = np.flatnonzero(~np.isfinite(v) | (np.abs(np.nan_to_num(v)) > 1e40))  # MAX_ABS
        if len(bad):
            raise InputError(f"{src}: column {cols[col]!r} has a missing or non-numeric value in "
                             f"data row {bad[0] + 1}; fix the table")
        return v

    table = num(inp) * _INPUT[inp]
    y = num(out)
    if ounit == "dps":
        y = y * DPS
    elif ounit in ("pps", "v"):
        y = y * (s0 if s0 is not None else 1.0)
        if s0 is None:
            notes.append(f"{src}: output in {'pulse/s' if ounit == 'pps' else 'V'} and no "
                         "--scale-factor: S0 = 1 used (the scale factor is then absolute)")
    se_col = next((c for c in cols if c.startswith("stderr") and "ppm" not in c
                   and "white" not in c), None)
    if se_col is not None:
        se = pd.to_numeric(df[cols[se_col]], errors="coerce").to_numpy(dtype=float)
        if ounit == "dps" and se_col.endswith("dps"):
            se = se * DPS
        elif ounit in ("pps", "v"):
            se = se * (s0 if s0 is not None else 1.0)
        if not (np.all(np.isfinite(se)) and np.all(se > 0)):
            notes.append(f"{src}: some standard errors are missing or zero: unweighted fit")
            se = np.full(len(y), math.nan)
    else:
        se = np.full(len(y), math.nan)
    if "earth_rate_dph" in cols:
        er = num("earth_rate_dph")
    else:
        er = np.full(len(y), earth_rate_dph if earth_rate_dph is not None else 0.0)
        if earth_rate_dph is None:
            notes.append(f"{src}: no earth_rate_dph column and no site (--latitude/--ia): the "
                         "earth rate is not removed")
    tcol = next((c for c in _TEMP if c in cols), None)
    temp = pd.to_numeric(df[cols[tcol]], errors="coerce").to_numpy(float) if tcol else \
        np.full(len(y), math.nan)
    runs_col = df[cols["run"]].astype(str).to_numpy() if "run" in cols else np.full(len(y), p.stem)
    t0 = pd.to_numeric(df[cols["t_start_s"]], errors="coerce").to_numpy(float) \
        if "t_start_s" in cols else np.arange(len(y), dtype=float)
    t1 = pd.to_numeric(df[cols["t_end_s"]], errors="coerce").to_numpy(float) \
        if "t_end_s" in cols else t0 + 1.0
    sweep_given = "sweep" in cols
    runs: list[RunPlateaus] = []
    for name in dict.fromkeys(runs_col.tolist()):
        idx = np.flatnonzero(runs_col == name)
        sw = (pd.to_numeric(df[cols["sweep"]], errors="coerce").fillna(0).astype(int).to_numpy()[idx]
              if sweep_given else assign_sweeps(table[idx]))
        pl = [Plateau(run=name, index=j, table_rate_dph=float(table[i]),
                      earth_rate_dph=float(er[i]), output_dph=float(y[i]),
                      stderr_dph=float(se[i]), t_start_s=float(t0[i]), t_end_s=float(t1[i]),
                      dwell_start_s=float(t0[i]), dwell_end_s=float(t1[i]),
                      temperature_degC=float(temp[i]), rate_source="points table",
                      sweep=int(sw[j]))
              for j, i in enumerate(idx)]
        runs.append(RunPlateaus(run=name, source=src, plateaus=pl, method="points table",
                                earth_rate_dph=float(np.mean(er[idx])), stderr_method="points"))
    return runs, kind, s0, notes
