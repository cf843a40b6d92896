"""``gyrotest fleet``: the acceptance campaigns of a lot of serials in one summary."""

from __future__ import annotations

import time

import click

from ..core.errors import InputError
from .cmd_report import _check_out
from .common import emit_json, note, settings


@click.command("fleet")
@click.argument("campaigns", nargs=-1, required=True, type=str)
@click.option("--jobs", "-j", type=int, default=None, metavar="N",
              help="Worker processes for the per-campaign analyses [default: the number of "
                   "CPU cores; 1 = one after the other in this process].")
@click.option("--scheduler", default=None, metavar="ADDRESS|local",
              help="Run the analyses on Dask instead of the process pool: 'local' starts a "
                   "local cluster (--jobs workers), tcp://HOST:PORT uses a running scheduler "
                   "(its workers must see the campaign files at the same paths). Needs the "
                   "extra gyrotest[dask].")
@click.option("--pdf", "pdf_path", default=None, metavar="FILE",
              help="Write the summary as PDF to this file.")
@click.option("--html", "html_path", default=None, metavar="FILE",
              help="Write the summary as one self-contained HTML file.")
@click.option("--md", "md_path", default=None, metavar="FILE",
              help="Write the Markdown to this file (the control charts as a PNG beside it) "
                   "instead of stdout.")
@click.option("--no-figures", is_flag=True, help="Leave out the control charts (faster).")
@click.option("--json", "as_json", is_flag=True,
              help="Print the summary as JSON: every campaign's spec items (value, 1σ, "
                   "expanded uncertainty, limit, verdict), the lot statistics, modified "
                   "z-scores and outliers.")
def command(campaigns, jobs, scheduler, pdf_path, html_path, md_path, no_figures, as_json):
    """Summary of the acceptance tests of a lot of gyros, one CAMPAIGN file per test.

    Every campaign is analysed exactly as 'gyrotest report CAMPAIGN' does (same analyses,
    limits and decision rule), on a process pool by default or on Dask (--scheduler).
    Campaigns are grouped by gyro model and serial: the latest test of each serial (by
    [campaign] date) is its entry in the lot, earlier ones are charted as its earlier
    acceptance tests.

    The summary has one table with every spec item of every serial (value ± U, verdict), the
    lot statistics per item (n, mean, σ, min, max, PASS count), control charts of the items
    with limits (limit, lot median, outlier fence, earlier tests), and the outliers: serials
    whose value has a modified z-score |M| over the lot (Iglewicz & Hoaglin 1993) above a
    threshold c(n) set for a 1 % false alarm per item and lot of n normal values (c = 9.9 for
    6 serials, 5.2 for 20; never below 3.5), flagged when the lot has 5 or more serials. All
    campaign files are checked before any analysis.

    \b
    Examples:
      python sample_data/make_lot.py lot/          # a simulated lot of 6 serials
      gyrotest fleet lot/campaign_*.toml --pdf lot.pdf
      gyrotest fleet lot/campaign_*.toml --md lot.md --jobs 4
      gyrotest fleet lot/campaign_*.toml --scheduler local --json > lot.json
      gyrotest fleet lot/campaign_*.toml --scheduler tcp://10.0.0.5:8786 --html lot.html
    """
    from ..core.output import write_rendered
    from ..fleet import fleet_sheet, run_fleet
    from ..specsheet.campaign import load_campaign

    t0 = time.perf_counter()
    pdf = _check_out(pdf_path, (".pdf",), "PDF file")
    htm = _check_out(html_path, (".html", ".htm"), "HTML file")
    md = _check_out(md_path, (".md", ".markdown", ".txt"), "Markdown file")
    if jobs is not None and jobs < 1:
        raise InputError(f"--jobs {jobs}: give 1 or more worker processes")
    for c in campaigns:  # every file checked before any analysis
        load_campaign(c)
    if scheduler is not None:
        import importlib.util

        if importlib.util.find_spec("distributed") is None:
            raise InputError("--scheduler needs Dask, which is not installed: "
                             "pip install 'gyrotest[dask]'")
    quiet = settings().quiet or as_json

    def progress(path: str) -> None:
        if not quiet:
            note(f"fleet: {path} done")

    fleet = run_fleet(list(campaigns), jobs=jobs, scheduler=scheduler, progress=progress)
    outputs = []
    want_doc = bool(pdf or htm or md) or not as_json
    sheet = fleet_sheet(fleet, figures=bool(pdf or htm or md) and not no_figures) \
        if want_doc else None
    pdf_bytes = html_text = md_text = None
    fig_files = {}
    if pdf:
        from ..specsheet.pdf import render_pdf

        pdf_bytes, pages = render_pdf(sheet)
        outputs.append(f"{pdf} ({pages} pages)")
    if htm:
        from ..specsheet.html import render_html

        html_text = render_html(sheet)
        outputs.append(str(htm))
    if md or not (pdf or htm or as_json):
        from ..specsheet.markdown import render_markdown

        links = None
        if md is not None:
            links = {}
            for f in sheet.figures:
                if f.png is not None:
                    name = f"{md.stem}_figures/fig{f.number}_{f.key}.png"
                    fig_files[md.parent / name] = f.png
                    links[f.key] = name
        md_text = render_markdown(sheet, links)
    # every output is rendered before the first file is written
    write_rendered(pdf=pdf, pdf_bytes=pdf_bytes, html=htm, html_text=html_text, md=md,
                   md_text=md_text, figures=fig_files if md is not None else None)
    if md is not None:
        outputs.append(str(md) + (f" (+ {len(fig_files)} figure in {md.stem}_figures/)"
                                  if fig_files else ""))
    if as_json:
        emit_json(fleet.to_dict())
    elif md is None and md_text is not None:
        click.echo(md_text, nl=False)
    if outputs and not settings().quiet:
        note(f"fleet: {len(fleet.lot)} serials, {fleet.overall()}, "
             f"{len(fleet.outliers())} outliers; {fleet.run['executor']}; wrote "
             + ", ".join(outputs) + f" in {time.perf_counter() - t0:.1f} s")
