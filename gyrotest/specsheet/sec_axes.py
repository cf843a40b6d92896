"""Per-axis tables of the spec sheet for multi-axis logs (several gyro rate columns).

The checks of section 3 use the first analysed axis (or the test's ``axis``), and say so; these
tables list every axis the analysis covered, with numbers sourced from the same command
output (``per_axis`` of ``gyrotest bias --json``, ``logs[0].axes`` of ``gyrotest allan
--json``), so every number stays checkable against the command.
"""

from __future__ import annotations

from pathlib import Path

from .layout import U_DPH, Src, T, _unit, dig


def axis_note(axes: list[str]) -> str:
    """``" (axis gx of gx, gy, gz)"`` when several axes were analysed, else ``""``."""
    if len(axes) > 1:
        return f" (axis {axes[0]} of {', '.join(axes)})"
    return ""


def allan_axis_names(result: dict) -> list[str]:
    """The axis names of a ``gyrotest allan --json`` document's first log."""
    return [a["axis"] for a in (dig(result, ["logs", 0, "axes"]) or [])]


def bias_axes_table(s: Src, result: dict):
    """Bias of every gyro axis (mean output and D_F ± 1σ per run), or None for one axis."""
    per = result.get("per_axis") or []
    if len(per) < 2:
        return None
    rows = []
    for i, d in enumerate(per):
        for j, run in enumerate(d.get("runs", [])):
            p = ["per_axis", i, "runs", j]
            rows.append([d["axis"], Path(run["source"]).name,
                         s.num(p + ["mean_output_dph"], U_DPH, digits=6),
                         s.num(p + ["bias_D_F_dph"], U_DPH, p + ["bias_sigma_dph"])])
    return T(["axis", "run", "mean output, °/h", "D_F ± 1σ, °/h"], rows,
             title="Every gyro axis of the log(s) (one IA direction: the earth rate is not "
                   "removed when several axes are analysed)", unit_in_header=True,
             widths=[1.6, 2.4, 1.8, 2.2], key="bias_axes")


_TERMS = (("N", "N, ARW"), ("B", "B, bias instability"), ("K", "K, RRW"), ("R", "R, rate ramp"),
          ("Q", "Q, quantization"))


def allan_axes_table(s: Src, result: dict):
    """N, B, K, R, Q of every analysed axis (≤ for bounds), or None for one axis."""
    axes = dig(result, ["logs", 0, "axes"]) or []
    if len(axes) < 2:
        return None
    rows = []
    for j, ax in enumerate(axes):
        terms = ax["fit"]["terms"]
        row = [ax["axis"]]
        for key, _ in _TERMS:
            i = next((k for k, t in enumerate(terms) if t["key"] == key), None)
            if i is None:
                row.append("not fitted")
                continue
            tp = ["logs", 0, "axes", j, "fit", "terms", i]
            unit = _unit(terms[i]["units"].get(key, ""))
            if terms[i]["status"] == "identified":
                row.append(s.num(tp + ["params", key], unit, tp + ["sigma", key]))
            else:
                row.append(s.num(tp + ["upper_95"], unit, bound=True))
        rows.append(row)
    return T(["axis", *[lab for _, lab in _TERMS]], rows,
             title="Allan-variance coefficients of every gyro axis (≤: upper bound only)",
             widths=[1.6, 1.8, 1.8, 1.8, 1.8, 1.8], key="allan_axes")
