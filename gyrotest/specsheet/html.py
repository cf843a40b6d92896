"""Self-contained HTML rendering of the spec sheet: one file, figures embedded as base64 PNG,
print-friendly CSS (A4, tables and figures kept whole, running header with model and serial).
"""

from __future__ import annotations

import base64
import html

from .sheet import FAIL, INCONCLUSIVE, PASS, Equation, Figure, Para, Section, Sheet, Table

CSS = """
:root { --ink: #1a1a1a; --muted: #5a5a5a; --rule: #c8c8c8; --head: #eef1f5; }
* { box-sizing: border-box; }
body { font-family: "DejaVu Sans", "Segoe UI", Helvetica, Arial, sans-serif; color: var(--ink);
       max-width: 190mm; margin: 1.5em auto; padding: 0 1em; font-size: 10pt; line-height: 1.4; }
h1 { font-size: 17pt; margin: 0 0 .3em; }
h2 { font-size: 13pt; margin: 1.6em 0 .5em; border-bottom: 1.5px solid var(--ink);
     padding-bottom: .15em; }
h3 { font-size: 11pt; margin: 1.2em 0 .4em; }
h4 { font-size: 10pt; margin: 1em 0 .3em; }
p { margin: .4em 0; }
p.note { color: var(--muted); font-style: italic; }
table { border-collapse: collapse; width: 100%; margin: .5em 0 .9em; font-size: 8.5pt;
        page-break-inside: auto; }
caption { caption-side: top; text-align: left; font-weight: bold; font-size: 9pt;
          padding: .2em 0; }
th, td { border: 1px solid var(--rule); padding: 2px 5px; vertical-align: top; text-align: left; }
th { background: var(--head); font-weight: bold; }
tr { page-break-inside: avoid; }
td.num { white-space: nowrap; }
table.ident { width: auto; min-width: 60%; font-size: 9.5pt; }
table.ident th { width: 13em; }
.PASS { color: #0a6b2d; font-weight: bold; }
.FAIL { color: #b00020; font-weight: bold; }
.INCONCLUSIVE { color: #a35a00; font-weight: bold; }
.status { color: var(--muted); font-style: italic; }
pre.equation { background: #f6f7f9; border: 1px solid var(--rule); padding: .6em .8em;
               font-family: "DejaVu Sans Mono", Menlo, Consolas, monospace; font-size: 8.5pt;
               overflow-x: auto; page-break-inside: avoid; }
figure { margin: .8em 0 1.2em; page-break-inside: avoid; }
figure img { width: 100%; height: auto; border: 1px solid #e4e4e4; }
figcaption { font-size: 8.5pt; color: var(--muted); margin-top: .2em; }
.runhead { display: none; }
code { font-family: "DejaVu Sans Mono", Menlo, Consolas, monospace; font-size: 8pt; }
@page { size: A4; margin: 16mm 14mm 16mm 14mm; }
@media print {
  body { max-width: none; margin: 0; padding: 0; font-size: 9pt; }
  .runhead { display: block; position: fixed; top: -10mm; left: 0; right: 0; font-size: 7.5pt;
             color: var(--muted); border-bottom: .5px solid var(--rule); }
  h2, h3 { page-break-after: avoid; }
  a { color: inherit; text-decoration: none; }
}
"""


def _e(t: str) -> str:
    return html.escape(str(t), quote=False)


def _table(t: Table) -> str:
    out = ["<table>"]
    if t.title:
        out.append(f"<caption>{_e(t.title)}</caption>")
    out.append("<thead><tr>" + "".join(f"<th>{_e(c)}</th>" for c in t.columns)
               + "</tr></thead><tbody>")
    for r in t.rows:
        cells = []
        for c in r:
            txt = t.cell_text(c)
            cls = []
            if txt in (PASS, FAIL, INCONCLUSIVE):
                cls.append(txt)
            if not isinstance(c, str):
                cls.append("num")
            if t.key in ("commands", "files") and c is r[-1]:
                txt_html = f"<code>{_e(txt)}</code>"
            else:
                txt_html = _e(txt)
            cl = f' class="{" ".join(cls)}"' if cls else ""
            cells.append(f"<td{cl}>{txt_html}</td>")
        out.append("<tr>" + "".join(cells) + "</tr>")
    out.append("</tbody></table>")
    if t.note:
        out.append(f'<p class="note">{_e(t.note)}</p>')
    return "\n".join(out)


def _section(s: Section, depth: int) -> str:
    h = min(depth, 6)
    out = [f'<section id="s{s.number}"><h{h}>{_e(s.heading)}</h{h}>']
    if s.status not in ("tested", "not tested"):
        out.append(f'<p class="status">({_e(s.status)})</p>')
    for b in s.blocks:
        if isinstance(b, Para):
            cls = f' class="{b.style}"' if b.style != "normal" else ""
            out.append(f"<p{cls}>{_e(b.text)}</p>")
        elif isinstance(b, Table):
            out.append(_table(b))
        elif isinstance(b, Equation):
            out.append('<pre class="equation">' + _e("\n".join(b.lines)) + "</pre>")
        elif isinstance(b, Figure):
            if b.png is not None:
                src = "data:image/png;base64," + base64.b64encode(b.png).decode("ascii")
                out.append(f'<figure><img src="{src}" alt="Figure {b.number}">'
                           f"<figcaption>Figure {b.number}. {_e(b.caption)}</figcaption></figure>")
            else:
                out.append(f'<p class="note">Figure {b.number}: {_e(b.caption)} (not drawn)</p>')
    for sub in s.subsections:
        out.append(_section(sub, depth + 1))
    out.append("</section>")
    return "\n".join(out)


def _logo(data: bytes) -> str:
    """The lab logo as an embedded image (PNG or JPEG)."""
    import base64

    mime = "image/png" if data[:4] == b"\x89PNG" else "image/jpeg"
    return (f'<img alt="logo" style="max-height:60px;float:right" '
            f'src="data:{mime};base64,{base64.b64encode(data).decode()}">')


def render_html(sheet: Sheet) -> str:
    """The sheet as one self-contained HTML document."""
    rows = []
    for k, v in sheet.identity:
        cls = ""
        if k == "Compliance":
            cls = f' class="{v.split(":")[0]}"' if v.split(":")[0] in (PASS, FAIL,
                                                                        INCONCLUSIVE) else ""
        rows.append(f"<tr><th>{_e(k)}</th><td{cls}>{_e(v)}</td></tr>")
    body = [f'<div class="runhead">{_e(sheet.header)} — {_e(sheet.kind.split(" (")[0])}</div>',
            "<header>" + (_logo(sheet.logo) if sheet.logo else "")
            + f"<h1>{_e(sheet.title)}</h1>",
            '<table class="ident"><tbody>' + "".join(rows) + "</tbody></table>"]
    if sheet.notes:
        body.append(f'<p class="note">{_e(sheet.notes)}</p>')
    body.append("</header>")
    body += [_section(s, 2) for s in sheet.sections]
    return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<meta name=\"generator\" content=\"gyrotest\"><title>{_e(sheet.title)}</title>"
            f"<style>{CSS}</style></head><body>\n" + "\n".join(body) + "\n</body></html>\n")
