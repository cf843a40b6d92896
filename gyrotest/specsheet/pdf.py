"""PDF rendering of the spec sheet with reportlab.

Layout: A4 portrait; running header (gyro model and serial, report id and date) and footer
(gyrotest version, campaign SHA-256, "page X of Y") on every page; the title block as a
boxed table with the overall verdict; numbered section headings kept with their first block;
tables with the units in the header or in each cell, header rows repeated across pages and
PASS/FAIL coloured; the model equation in a monospaced box; figures scaled to the text width
with a numbered caption, kept on one page with it.

Fonts: DejaVu Sans / Sans Mono from matplotlib's font directory (every symbol of the sheet:
≤ √ ∇ Ṫ Θ ε ω σ τ ± µ ⁻¹ ...), so the output does not depend on system fonts.
"""

from __future__ import annotations

import io
import os
from xml.sax.saxutils import escape

from .sheet import FAIL, INCONCLUSIVE, PASS, Equation, Figure, Para, Section, Sheet, Table

FONT, FONT_B, FONT_I, MONO = "GTSans", "GTSans-Bold", "GTSans-Oblique", "GTMono"
_registered = False


def _register_fonts() -> None:
    global _registered
    if _registered:
        return
    import matplotlib
    from reportlab.lib.fonts import addMapping
    from reportlab.pdfbase import pdfmetrics
    from reportlab.pdfbase.ttfonts import TTFont

    d = os.path.join(matplotlib.get_data_path(), "fonts", "ttf")
    for name, f in ((FONT, "DejaVuSans.ttf"), (FONT_B, "DejaVuSans-Bold.ttf"),
                    (FONT_I, "DejaVuSans-Oblique.ttf"), (MONO, "DejaVuSansMono.ttf")):
        pdfmetrics.registerFont(TTFont(name, os.path.join(d, f)))
    addMapping(FONT, 0, 0, FONT)
    addMapping(FONT, 1, 0, FONT_B)
    addMapping(FONT, 0, 1, FONT_I)
    addMapping(FONT, 1, 1, FONT_B)
    _registered = True


def _styles():
    from reportlab.lib import colors
    from reportlab.lib.styles import ParagraphStyle

    base = ParagraphStyle("base", fontName=FONT, fontSize=8.6, leading=11.2, spaceAfter=3.5)
    return {
        "base": base,
        "title": ParagraphStyle("title", base, fontName=FONT_B, fontSize=16, leading=20,
                                spaceAfter=8),
        "h1": ParagraphStyle("h1", base, fontName=FONT_B, fontSize=12.5, leading=15.5,
                             spaceBefore=10, spaceAfter=5, keepWithNext=1),
        "h2": ParagraphStyle("h2", base, fontName=FONT_B, fontSize=10.5, leading=13,
                             spaceBefore=8, spaceAfter=4, keepWithNext=1),
        "h3": ParagraphStyle("h3", base, fontName=FONT_B, fontSize=9.5, leading=12,
                             spaceBefore=6, spaceAfter=3, keepWithNext=1),
        "note": ParagraphStyle("note", base, fontName=FONT_I, textColor=colors.HexColor("#505050")),
        "cell": ParagraphStyle("cell", base, fontSize=7.3, leading=8.9, spaceAfter=0),
        "cellb": ParagraphStyle("cellb", base, fontName=FONT_B, fontSize=7.3, leading=8.9,
                                spaceAfter=0),
        "mono": ParagraphStyle("mono", base, fontName=MONO, fontSize=6.6, leading=8.2,
                               spaceAfter=0),
        "eq": ParagraphStyle("eq", base, fontName=MONO, fontSize=7.9, leading=10.2, spaceAfter=0),
        "caption": ParagraphStyle("caption", base, fontName=FONT_I, fontSize=7.8, leading=9.6,
                                  textColor=colors.HexColor("#404040"), spaceBefore=2,
                                  spaceAfter=8),
        "tcap": ParagraphStyle("tcap", base, fontName=FONT_B, fontSize=8, leading=10,
                               spaceBefore=3, spaceAfter=2, keepWithNext=1),
        "ident": ParagraphStyle("ident", base, fontSize=9, leading=11.5, spaceAfter=0),
        "identb": ParagraphStyle("identb", base, fontName=FONT_B, fontSize=9, leading=11.5,
                                 spaceAfter=0),
    }


VERDICT_COLOURS = {PASS: "#0a6b2d", FAIL: "#b00020", INCONCLUSIVE: "#a35a00"}


def _p(text: str, style):
    from reportlab.platypus import Paragraph

    return Paragraph(escape(str(text)), style)


#: left + right padding of a table cell, pt (the TableStyle below)
CELL_PAD = 6.0


def _token_width(text: str, font: str, size: float) -> float:
    """Width of the widest word of ``text`` (what a cell cannot wrap), pt."""
    from reportlab.pdfbase.pdfmetrics import stringWidth

    return max((stringWidth(w, font, size) for w in str(text).split()), default=0.0)


def column_widths(t: Table, st, width: float) -> list[float]:
    """Column widths of a table, pt: the table's proportions, widened where a word of a cell
    (a number, a unit, a verdict) would not fit, taken from the columns with room to spare, so
    that no cell breaks inside a word ("strapdow|n", "0.01|2"). The monospaced last column
    of the file and command tables (hashes, command lines) wraps as a terminal does. When the
    words cannot all fit, the proportions stand."""
    n = len(t.columns)
    w = t.widths if t.widths and len(t.widths) == n else [1.0] * n
    tot = sum(w)
    colw = [width * x / tot for x in w]
    mono = t.key in ("files", "commands")
    need = [0.0] * n
    for j, head in enumerate(t.columns):
        need[j] = _token_width(head, st["cellb"].fontName, st["cellb"].fontSize)
    for r in t.rows:
        for j, c in enumerate(r):
            if mono and j == n - 1:
                continue
            txt = t.cell_text(c)
            sty = st["cellb"] if txt in VERDICT_COLOURS else st["cell"]
            need[j] = max(need[j], _token_width(txt, sty.fontName, sty.fontSize))
    need = [x + CELL_PAD + 0.5 for x in need]
    if sum(need) > width:
        return colw
    for _ in range(n):  # widen the short columns, narrow the roomy ones in proportion
        short = [j for j in range(n) if colw[j] < need[j]]
        if not short:
            break
        deficit = sum(need[j] - colw[j] for j in short)
        for j in short:
            colw[j] = need[j]
        slack = {j: colw[j] - need[j] for j in range(n) if colw[j] > need[j]}
        room = sum(slack.values())
        for j, s in slack.items():
            colw[j] -= deficit * s / room
    return colw


def _table(t: Table, st, width: float) -> list[list]:
    """Units (lists of flowables to keep together) of a table: caption + table, then note."""
    from reportlab.lib import colors
    from reportlab.platypus import Paragraph, TableStyle
    from reportlab.platypus import Table as RLTable

    n = len(t.columns)
    colw = column_widths(t, st, width)
    mono = t.key in ("files", "commands")
    data = [[Paragraph(escape(c), st["cellb"]) for c in t.columns]]
    style = [("GRID", (0, 0), (-1, -1), 0.4, colors.HexColor("#b8b8b8")),
             ("BACKGROUND", (0, 0), (-1, 0), colors.HexColor("#e9edf2")),
             ("VALIGN", (0, 0), (-1, -1), "TOP"),
             ("LEFTPADDING", (0, 0), (-1, -1), 3), ("RIGHTPADDING", (0, 0), (-1, -1), 3),
             ("TOPPADDING", (0, 0), (-1, -1), 1.6), ("BOTTOMPADDING", (0, 0), (-1, -1), 1.8)]
    for i, r in enumerate(t.rows, 1):
        row = []
        for j, c in enumerate(r):
            txt = t.cell_text(c)
            if txt in VERDICT_COLOURS:
                row.append(Paragraph(f'<font color="{VERDICT_COLOURS[txt]}"><b>{txt}</b></font>',
                                     st["cell"]))
            elif mono and j == n - 1:
                row.append(Paragraph(escape(txt), st["mono"]))
            else:
                row.append(Paragraph(escape(txt), st["cell"]))
        data.append(row)
        if i % 2 == 0:
            style.append(("BACKGROUND", (0, i), (-1, i), colors.HexColor("#f7f8fa")))
    tab = RLTable(data, colWidths=colw, repeatRows=1, hAlign="LEFT")
    tab.setStyle(TableStyle(style))
    units = [([_p(t.title, st["tcap"])] if t.title else []) + [tab]]
    if t.note:
        units.append([_p(t.note, st["note"])])
    return units


def _figure(f: Figure, st, width: float, max_h: float) -> list[list]:
    from reportlab.platypus import Image

    if f.png is None:
        return [[_p(f"Figure {f.number}: {f.caption} (not drawn)", st["note"])]]
    ratio = (f.height_in / f.width_in) if f.width_in else 0.6
    w = min(width, width * f.width_in / 7.6) if f.width_in else width
    h = w * ratio
    if h > max_h:
        h = max_h
        w = h / ratio
    img = Image(io.BytesIO(f.png), width=w, height=h)
    img.hAlign = "CENTER"
    return [[img, _p(f"Figure {f.number}. {f.caption}", st["caption"])]]


def _equation(e: Equation, st, width: float) -> list[list]:
    from reportlab.lib import colors
    from reportlab.platypus import Paragraph, TableStyle
    from reportlab.platypus import Table as RLTable

    txt = "<br/>".join(escape(ln).replace(" ", "&nbsp;") if ln else "&nbsp;" for ln in e.lines)
    box = RLTable([[Paragraph(txt, st["eq"])]], colWidths=[width])
    box.setStyle(TableStyle([("BOX", (0, 0), (-1, -1), 0.5, colors.HexColor("#b8b8b8")),
                             ("BACKGROUND", (0, 0), (-1, -1), colors.HexColor("#f6f7f9")),
                             ("LEFTPADDING", (0, 0), (-1, -1), 7),
                             ("TOPPADDING", (0, 0), (-1, -1), 5),
                             ("BOTTOMPADDING", (0, 0), (-1, -1), 6)]))
    return [[box]]


def _section(s: Section, depth: int, st, width: float, max_h: float,
             pending: list | None = None) -> list:
    """Flowables of a section; each heading is kept on the page of the first block under it
    (``pending`` carries headings of parents that have no block of their own)."""
    from reportlab.platypus import KeepTogether

    heads = list(pending or []) + [_p(s.heading, st[f"h{min(depth, 3)}"])]
    if s.status not in ("tested", "not tested"):
        heads.append(_p(f"({s.status})", st["note"]))
    units: list[list] = []
    for b in s.blocks:
        if isinstance(b, Para):
            units.append([_p(b.text, st["note"] if b.style != "normal" else st["base"])])
        elif isinstance(b, Table):
            units += _table(b, st, width)
        elif isinstance(b, Equation):
            units += _equation(b, st, width)
        elif isinstance(b, Figure):
            units += _figure(b, st, width, max_h)
    out: list = []
    if units:
        units[0] = heads + units[0]
        heads = []
        for u in units:
            out.append(KeepTogether(u) if len(u) > 1 else u[0])
    for sub in s.subsections:
        out += _section(sub, depth + 1, st, width, max_h, heads)
        heads = []
    if heads:
        out += heads
    return out


def render_pdf(sheet: Sheet) -> tuple[bytes, int]:
    """The sheet as PDF bytes, and its page count."""
    from reportlab.lib import colors
    from reportlab.lib.pagesizes import A4
    from reportlab.lib.units import mm
    from reportlab.pdfgen import canvas as rl_canvas
    from reportlab.platypus import Paragraph, SimpleDocTemplate, Spacer, TableStyle
    from reportlab.platypus import Table as RLTable

    _register_fonts()
    st = _styles()
    pw, ph = A4
    lm = rm = 15 * mm
    tm, bm = 18 * mm, 17 * mm
    width = pw - lm - rm
    max_h = (ph - tm - bm) * 0.62
    prov = sheet.provenance
    left_head = f"{sheet.header} — {sheet.kind}"
    ident = dict(sheet.identity)
    right_head = " · ".join(x for x in (ident.get("Report"), ident.get("Date of test")) if x)
    foot = (f"gyrotest {prov.get('gyrotest_version', '')} · {prov['campaign']['name']} "
            f"SHA-256 {prov['campaign']['sha256'][:16]}…")

    class NumberedCanvas(rl_canvas.Canvas):
        """Canvas that writes "page X of Y" once the page count is known."""

        def __init__(self, *a, **k):
            super().__init__(*a, **k)
            self._pages: list[dict] = []

        def showPage(self):
            """Keep the page state; decorate once the page count is known."""
            self._pages.append(dict(self.__dict__))
            self._startPage()

        def save(self):
            """Draw header and footer ("page X of Y") on every page, then save."""
            n = len(self._pages)
            pages.append(n)
            for state in self._pages:
                self.__dict__.update(state)
                self._decorate(n)
                super().showPage()
            super().save()

        def _decorate(self, total: int) -> None:
            self.saveState()
            self.setStrokeColor(colors.HexColor("#9a9a9a"))
            self.setLineWidth(0.4)
            self.line(lm, ph - 12 * mm, pw - rm, ph - 12 * mm)
            self.line(lm, 11.5 * mm, pw - rm, 11.5 * mm)
            self.setFillColor(colors.HexColor("#404040"))
            self.setFont(FONT, 7.5)
            self.drawString(lm, ph - 10.6 * mm, left_head)
            self.drawRightString(pw - rm, ph - 10.6 * mm, right_head)
            self.drawString(lm, 8 * mm, foot)
            self.drawRightString(pw - rm, 8 * mm, f"page {self._pageNumber} of {total}")
            self.restoreState()

    pages: list[int] = []
    story: list = [Paragraph(escape(sheet.title), st["title"])]
    if sheet.logo:  # the lab's logo, top right of the first page
        from reportlab.platypus import Image

        logo = Image(io.BytesIO(sheet.logo), width=40 * mm, height=16 * mm, kind="proportional",
                     hAlign="RIGHT")
        story.insert(0, logo)
    rows = []
    for k, v in sheet.identity:
        if k == "Compliance":
            colr = VERDICT_COLOURS.get(v.split(":")[0])
            cell = Paragraph(f'<font color="{colr}"><b>{escape(v)}</b></font>' if colr
                             else escape(v), st["ident"])
        else:
            cell = Paragraph(escape(v), st["ident"])
        rows.append([Paragraph(escape(k), st["identb"]), cell])
    box = RLTable(rows, colWidths=[48 * mm, width - 48 * mm], hAlign="LEFT")
    box.setStyle(TableStyle([("BOX", (0, 0), (-1, -1), 0.9, colors.HexColor("#303030")),
                             ("LINEBELOW", (0, 0), (-1, -2), 0.3, colors.HexColor("#c0c0c0")),
                             ("BACKGROUND", (0, 0), (0, -1), colors.HexColor("#eef1f5")),
                             ("VALIGN", (0, 0), (-1, -1), "TOP"),
                             ("TOPPADDING", (0, 0), (-1, -1), 2.2),
                             ("BOTTOMPADDING", (0, 0), (-1, -1), 2.6)]))
    story.append(box)
    if sheet.notes:
        story += [Spacer(1, 3), _p(sheet.notes, st["note"])]
    for s in sheet.sections:
        story += _section(s, 1, st, width, max_h)
    buf = io.BytesIO()
    meta = {"title": sheet.title, "author": ident.get("Operator", ""),
            "subject": sheet.kind,
            "creator": f"gyrotest {prov.get('gyrotest_version', '')}"}
    # creation date: now, or SOURCE_DATE_EPOCH when set (reproducible builds; the document
    # is then byte-for-byte invariant)
    invariant = 1 if os.environ.get("SOURCE_DATE_EPOCH", "").strip() else 0
    doc = SimpleDocTemplate(buf, pagesize=A4, leftMargin=lm, rightMargin=rm, topMargin=tm,
                            bottomMargin=bm, invariant=invariant, **meta)
    from reportlab import rl_config

    a85 = rl_config.useA85
    rl_config.useA85 = 0  # binary streams: smaller, and much faster without the C accelerator
    try:
        doc.build(story, canvasmaker=NumberedCanvas)
    finally:
        rl_config.useA85 = a85
    return buf.getvalue(), pages[-1] if pages else 0
