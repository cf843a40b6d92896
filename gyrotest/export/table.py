"""The Allan deviation table as CSV, units in the column names (``tau_s``,
``sigma_deg_h``...): one row per (log, axis, τ) with the confidence interval, the EDF, the
noise type α, the fitted model and the residual in CI units."""

from __future__ import annotations

import csv
import io
import math

from .common import AllanAxis, need


def _unit_tag(unit: str) -> str:
    """'deg/h' → 'deg_h', 'arcsec/s' → 'arcsec_s'."""
    return "".join(c if c.isalnum() else "_" for c in unit).strip("_") or "unit"


def allan_csv(axes: list[AllanAxis]) -> str:
    units = {str((need(a.doc, "deviation", a.file).get("unit")) or "deg/h") for a in axes}
    if len(units) > 1:  # one header for all rows
        from ..core.errors import InputError

        raise InputError(f"the axes have different units ({', '.join(sorted(units))}); export "
                         "them one at a time with --axis")
    u = _unit_tag(units.pop())
    cols = ["source", "axis", "deviation", "tau_s", "m", "n", "alpha", "edf",
            f"sigma_lo_{u}", f"sigma_{u}", f"sigma_hi_{u}", f"model_{u}", "residual_ci",
            "fitted"]
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(cols)
    for a in axes:
        kind = need(a.doc, "deviation", a.file).get("kind", "")
        for i, r in enumerate(need(a.doc, "table", a.file, f"axis {a.axis}")):
            for key in ("tau", "sigma"):
                need(r, key, a.file, f"axis {a.axis} table row {i + 1}")
            vals = [r.get(k) for k in ("tau", "m", "n", "alpha", "edf", "sigma_lo", "sigma",
                                       "sigma_hi", "model", "residual_ci")]
            out = [a.source, a.axis, kind]
            for v in vals:
                if v is None or (isinstance(v, float) and not math.isfinite(v)):
                    out.append("")
                elif isinstance(v, int):
                    out.append(str(v))
                else:
                    out.append(f"{float(v):.10g}")
            f = r.get("fitted")
            out.append("" if f is None else str(bool(f)).lower())
            w.writerow(out)
    return buf.getvalue()
