"""``gyrotest report``: the IEEE-952-style specification sheet of a test campaign.

Pipeline::

    from gyrotest.specsheet import load_campaign, make_report, render_markdown

    camp = load_campaign("sample_data/campaign.toml")   # validated before any work
    sheet = make_report(camp)                           # every analysis, then the layout
    print(render_markdown(sheet))                       # or render_html / render_pdf / to_dict

Modules: :mod:`.campaign` (the campaign file), :mod:`.adapters` (one small adapter per
analysis, calling the same core as the command), :mod:`.build` (sections in IEEE 952 order,
numbers with provenance, limits and verdicts), :mod:`.sheet` (the document model),
:mod:`.figures` (the analysis modules' plots), :mod:`.markdown`, :mod:`.html`,
:mod:`.pdf`.
"""

from __future__ import annotations

from .build import build_sheet, make_report, run_campaign
from .campaign import Campaign, load_campaign
from .markdown import render_markdown
from .sheet import Sheet

__all__ = ["Campaign", "Sheet", "build_sheet", "load_campaign", "make_report",
           "render_markdown", "run_campaign"]


def render_html(sheet: Sheet) -> str:
    """The sheet as one self-contained HTML document (see :mod:`.html`)."""
    from .html import render_html as _r

    return _r(sheet)


def render_pdf(sheet: Sheet) -> tuple[bytes, int]:
    """The sheet as PDF bytes and its page count (see :mod:`.pdf`)."""
    from .pdf import render_pdf as _r

    return _r(sheet)
