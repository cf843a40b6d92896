"""Markdown rendering of the spec sheet (GitHub-flavoured: pipe tables, fenced equation).

Good in a terminal and in git: no timestamps, stable order, one table row per line. Figures
are listed by caption; with ``figure_links`` (file names by figure key) they are linked.
"""

from __future__ import annotations

from .sheet import Equation, Figure, Para, Section, Sheet, Table


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def _table(t: Table) -> list[str]:
    out = []
    if t.title:
        out += [f"*{t.title}*", ""]
    out.append("| " + " | ".join(_cell(c) for c in t.columns) + " |")
    out.append("|" + "|".join("---" for _ in t.columns) + "|")
    for r in t.rows:
        out.append("| " + " | ".join(_cell(t.cell_text(c)) for c in r) + " |")
    if t.note:
        out += ["", t.note]
    return out + [""]


def _section(s: Section, depth: int, links: dict[str, str] | None) -> list[str]:
    out = ["#" * min(depth, 6) + " " + s.heading, ""]
    if s.status != "tested" and s.status != "not tested":
        out += [f"*({s.status})*", ""]
    for b in s.blocks:
        if isinstance(b, Para):
            prefix = {"note": "> ", "warning": "> **warning:** "}.get(b.style, "")
            out += [prefix + b.text, ""]
        elif isinstance(b, Table):
            out += _table(b)
        elif isinstance(b, Equation):
            out += ["```text", *b.lines, "```", ""]
        elif isinstance(b, Figure):
            if links and b.key in links:
                out += [f"![Figure {b.number}]({links[b.key]})", ""]
            out += [f"*Figure {b.number}: {b.caption}*"
                    + ("" if links and b.key in links else " (embedded in the HTML and PDF "
                       "sheets)"), ""]
    for sub in s.subsections:
        out += _section(sub, depth + 1, links)
    return out


def render_markdown(sheet: Sheet, figure_links: dict[str, str] | None = None) -> str:
    """The sheet as Markdown text."""
    out = [f"# {sheet.title}", ""]
    out.append("| | |")
    out.append("|---|---|")
    for k, v in sheet.identity:
        out.append(f"| **{_cell(k)}** | {_cell(v)} |")
    out.append("")
    if sheet.notes:
        out += [f"> {sheet.notes}", ""]
    for s in sheet.sections:
        out += _section(s, 2, figure_links)
    return "\n".join(out).rstrip() + "\n"
