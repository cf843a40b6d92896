"""The lot summary as a document (:class:`~gyrotest.specsheet.sheet.Sheet`), so that the report's
Markdown, HTML and PDF renderers lay it out."""

from __future__ import annotations

import hashlib
from typing import Any

from .. import __version__
from ..specsheet.sheet import Figure, Num, Para, Section, Sheet, Table, fmt_number
from .core import OUTLIER_ALPHA, OUTLIER_MIN_N, Fleet, outlier_threshold

#: serial columns per summary table (wider lots continue in a second table)
PER_TABLE = 8

SHORT = {"PASS": "PASS", "FAIL": "FAIL", "CONDITIONAL PASS": "COND. PASS",
         "CONDITIONAL FAIL": "COND. FAIL", "INCONCLUSIVE": "INCONCL.",
         "no limit given": "", "not tested": "not tested"}


def _value_text(it: dict[str, Any] | None, k: float) -> str:
    if it is None or it["value"] is None:
        return "not tested"
    n = Num(it["value"], "", it["sigma"], it["bound"], k=k)
    v = SHORT.get(it["verdict"], it["verdict"])
    return n.text(unit=False) + (f" {v}" if v else "")


def _num(v: float | None, digits: int = 4) -> str:
    return fmt_number(v, digits)


def _digits(s) -> int:
    """Significant digits that resolve the lot spread of an item (4 … 10)."""
    import math

    spread = s.std or s.robust_sigma
    if not s.median or not spread or not math.isfinite(spread):
        return 4
    return max(4, min(10, math.ceil(math.log10(abs(s.median) / spread)) + 2))


def fleet_sheet(fleet: Fleet, figures: bool = True) -> Sheet:
    """Lay out the lot summary: title block, summary table (spec item × serial), lot
    statistics, control charts, outliers, earlier tests, campaigns."""
    lot = fleet.lot
    serials = [r["serial"] for r in lot]
    k = lot[0]["coverage_factor"] if lot else 2.0
    stats = fleet.stats
    n_out = len(fleet.outliers())
    counts: dict[str, int] = {}
    for r in lot:
        counts[r["overall"]] = counts.get(r["overall"], 0) + 1
    verdicts = ", ".join(f"{n} {v}" for v, n in sorted(counts.items()))
    dates = sorted(r["date"] for r in fleet.records)
    ident = [("Gyro model", fleet.model), ("Serials", f"{len(lot)}: {', '.join(serials)}"),
             ("Campaigns", f"{len(fleet.records)} ({len(fleet.records) - len(lot)} earlier "
                           "acceptance tests of the same serials)"),
             ("Test dates", f"{dates[0]} … {dates[-1]}" if dates else "—"),
             ("Uncertainty", f"expanded uncertainty U = k·u, k = {k:g} (± values)"),
             ("Outlier rule", f"modified z-score |M| over the lot (Iglewicz & Hoaglin 1993) "
                              f"above c(n) = {outlier_threshold(len(lot)):.2f} for n = "
                              f"{len(lot)} serials (false alarm {OUTLIER_ALPHA:.0%} per item "
                              f"and lot); with {OUTLIER_MIN_N} or more serials"
                              if len(lot) >= OUTLIER_MIN_N else
                              f"none flagged: fewer than {OUTLIER_MIN_N} serials"),
             ("Software", f"gyrotest {__version__}"),
             ("Compliance", f"{fleet.overall()}: {verdicts} serials; {n_out} outlier"
                            f"{'' if n_out == 1 else 's'} flagged")]

    # 1 summary: spec item × serial
    s1 = Section("1", "Lot summary: every spec item of every serial")
    for lo in range(0, len(lot), PER_TABLE):  # at most PER_TABLE serials side by side
        part = lot[lo:lo + PER_TABLE]
        rows = [["overall verdict", "", "", *[r["overall"] for r in part]]]
        for s in stats:
            cells: list[Any] = [s.item, s.unit, _num(s.limit) if s.limit is not None else "—"]
            for r in part:
                t = _value_text(fleet.item(r, s.key), k)
                if r["serial"] in s.outliers:
                    t += " (outlier)"
                cells.append(t)
            rows.append(cells)
        span = "" if len(lot) <= PER_TABLE else f" (serials {lo + 1}…{lo + len(part)})"
        s1.add(Table(["spec item", "unit", "limit", *[f"s/n {r['serial']}" for r in part]],
                     rows, title=f"Latest acceptance test of each serial{span}: value ± U "
                                 f"(k = {k:g}) and verdict; ≤: upper bound (95 %)",
                     key="summary", widths=[3.2, 1.4, 0.9, *[2.0] * len(part)]))
    s1.add(Para("Verdicts follow each campaign's decision rule (guarded acceptance per "
                "ILAC-G8 unless the campaign states simple acceptance); COND.: conditional; "
                "INCONCL.: an upper bound above the limit. The overall verdict of a serial is "
                "its worst item."))

    # 2 lot statistics
    s2 = Section("2", "Lot statistics")
    rows = []
    for s in stats:
        pas = s.verdicts.get("PASS", 0)
        judged = sum(v for kk, v in s.verdicts.items() if kk not in ("no limit given",
                                                                    "not tested"))
        d = _digits(s)
        rows.append([s.item, s.unit, _num(s.limit) if s.limit is not None else "—", str(s.n)
                     + (f" ({s.n_bounds} ≤)" if s.n_bounds else ""), _num(s.mean, d),
                     _num(s.std), _num(s.min, d), _num(s.max, d), f"{pas}/{judged}" if judged else "—",
                     ", ".join(s.outliers) or "—"])
    s2.add(Table(["spec item", "unit", "limit", "n", "mean", "σ", "min", "max", "PASS",
                  "outliers"], rows, title="Over the latest test of each serial (σ: sample "
                                           "standard deviation, n − 1)", key="lot_statistics",
                 widths=[3.0, 1.3, 0.9, 0.8, 1.1, 1.1, 1.1, 1.1, 0.8, 1.2]))
    if any(s.n_bounds for s in stats):
        s2.add(Para("Items given as upper bounds (≤) enter the statistics with the bound."))

    # 3 control charts
    s3 = Section("3", "Control charts")
    if figures:
        from ..specsheet.figures import _png_from_fig
        from .charts import control_charts

        fig = control_charts(fleet)
        if fig is not None:
            png, w, h = _png_from_fig(fig)
            s3.add(Figure("control_charts", "Control charts of the spec items with limits: "
                          f"value ± U (k = {k:g}) per serial, coloured by verdict; red: limit; "
                          "dashed: lot median; dotted: median ± c(n)·robust σ "
                          "(outlier fence; robust σ = MAD/0.6745); hollow grey: earlier acceptance tests of the same "
                          "serial; ringed: flagged outlier.", png, None, w, h, 1))
    else:
        s3.add(Para("Figures left out (--no-figures)."))

    # 4 outliers
    s4 = Section("4", "Outliers in the lot")
    outs = fleet.outliers()
    if outs:
        s4.add(Table(["spec item", "serial", "value", "lot median", "robust σ", "M", "c(n)"],
                     [[o["item"] + (f" ({o['unit']})" if o["unit"] else ""), o["serial"],
                       _num(o["value"]), _num(o["median"]), _num(o["robust_sigma"]),
                       f"{o['modified_z']:.1f}", f"{o['threshold']:.2f}"] for o in outs],
                     key="outliers"))
        s4.add(Para("An outlier may still PASS its limit: it marks a serial that differs from "
                    "its lot and deserves a look (mounting, a different build, a bench fault)."))
    else:
        s4.add(Para("No spec item has a serial with |M| above c(n)"
                    + (f" (outliers are flagged with {OUTLIER_MIN_N} or more serials)"
                       if len(lot) < OUTLIER_MIN_N else "") + "."))

    # 5 earlier tests
    s5 = Section("5", "Earlier acceptance tests of the same serials")
    rows = []
    for r in lot:
        for e in fleet.earlier.get(r["serial"], []):
            for s in stats:
                if s.limit is None:
                    continue
                a, b = fleet.item(e, s.key), fleet.item(r, s.key)
                if a is None or b is None or a["value"] is None or b["value"] is None:
                    continue
                rows.append([r["serial"], s.item + (f" ({s.unit})" if s.unit else ""),
                             f"{e['date']}: {_value_text(a, k)}",
                             f"{r['date']}: {_value_text(b, k)}",
                             _num(b["value"] - a["value"])])
    if rows:
        s5.add(Table(["serial", "spec item", "earlier test", "latest test", "change"], rows,
                     key="earlier", widths=[0.9, 3.0, 2.6, 2.6, 1.0]))
    else:
        s5.add(Para("No serial was given with an earlier acceptance test."))

    # 6 campaigns
    s6 = Section("6", "Campaigns")
    in_lot = {id(r) for r in lot}
    s6.add(Table(["campaign", "serial", "date", "report", "overall", "role", "SHA-256"],
                 [[r["file"], r["serial"], r["date"], r["report_id"] or "—", r["overall"],
                   "lot" if id(r) in in_lot else "earlier test", r["sha256"][:16] + "…"]
                  for r in fleet.records], key="campaigns",
                 widths=[2.4, 0.8, 1.2, 1.5, 1.6, 1.1, 1.9]))
    s6.add(Para("Each campaign was analysed exactly as 'gyrotest report CAMPAIGN' does; the "
                "numbers equal that command's --json output."))

    digest = hashlib.sha256("".join(r["sha256"] for r in fleet.records).encode()).hexdigest()
    title = f"{fleet.model} lot of {len(lot)} serials: acceptance-test summary"
    return Sheet(title=title, identity=ident, sections=[s1, s2, s3, s4, s5, s6], checks=[],
                 figures=[b for b in s3.blocks if isinstance(b, Figure)], warnings=[],
                 provenance={"gyrotest_version": __version__,
                             "campaign": {"name": f"{len(fleet.records)} campaigns",
                                          "sha256": digest}},
                 header=f"{fleet.model} lot of {len(lot)}", kind="lot acceptance-test summary")
