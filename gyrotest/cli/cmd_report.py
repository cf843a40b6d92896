"""``gyrotest report``: the IEEE-952-style spec sheet of a test campaign."""

from __future__ import annotations

import time
from pathlib import Path

import click

from ..core.errors import InputError
from .common import console, emit_json, err_console, note, settings


def _init(folder: str, as_json: bool) -> None:
    """``--init DIR``: DIR/campaign.toml from the logs in DIR (:mod:`gyrotest.specsheet.init`)."""
    from ..core.output import atomic_open
    from ..specsheet.init import campaign_text

    d = Path(folder)
    if not d.is_dir():
        raise InputError(f"--init {folder}: no such directory; give the folder holding the logs")
    out = d / "campaign.toml"
    if out.exists():
        raise InputError(f"--init: {out} exists; edit it, or move it away to start again")
    text, found = campaign_text(d)
    if not any(f.test for f in found):
        raise InputError(f"--init {folder}: no log recognised among {len(found)} file(s)"
                         + (f" ({found[0].path.name}: {found[0].why})" if found else "")
                         + "; put a bench profile NAME.profile.toml beside each log")
    with atomic_open(out, "w", encoding="utf-8") as fh:
        fh.write(text + "\n")
    if as_json:
        emit_json({"campaign": str(out), "logs": [
            {"file": f.path.name, "profile": f.profile.name if f.profile else None,
             "test": f.test, "why": f.why} for f in found]})
        return
    from rich.markup import escape

    c = console()
    c.print(f"wrote {escape(str(out))}: "
            f"{sum(1 for f in found if f.test)} of {len(found)} log(s) recognised")
    for f in found:
        c.print(f"  {escape(f.path.name):<28} {escape(f.test or 'not used'):<14} "
                f"{escape(f.why)}")
    c.print(f"next: fill in the lines marked FILL IN, then 'gyrotest report {escape(str(out))} "
            "--pdf spec.pdf'")


def _check_out(path: str | None, suffixes: tuple[str, ...], what: str) -> Path | None:
    if path is None:
        return None
    p = Path(path)
    if p.suffix.lower() not in suffixes:
        raise InputError(f"{what} {p}: expected a {' or '.join(suffixes)} file name")
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.is_dir():
        raise InputError(f"{what} {p}: directory {parent} does not exist")
    return p


@click.command("report")
@click.argument("campaign", type=str, required=False)
@click.option("--variant", type=click.Choice(["customer", "engineering"]), default="customer",
              show_default=True,
              help="customer: results with expanded uncertainties (k = 2), limits, decision "
                   "rule, conditions, equipment, references and sign-off; engineering: adds "
                   "the diagnostics, algorithm notes, model history, commands and warnings.")
@click.option("--template", is_flag=True,
              help="Print a commented campaign file with every key (docs/campaign.md) and exit.")
@click.option("--init", "init_dir", default=None, metavar="DIR",
              type=click.Path(file_okay=False),
              help="Start a campaign from the logs in DIR: write DIR/campaign.toml with each "
                   "log it recognises in its test (rate table → scale_factor, coils → "
                   "magnetic, positions → multiposition, temperature span → thermal, static "
                   "→ bias and allan), commented, and exit. An existing file is kept.")
@click.option("--pdf", "pdf_path", default=None, metavar="FILE",
              help="Write the sheet as PDF to this file.")
@click.option("--html", "html_path", default=None, metavar="FILE",
              help="Write the sheet as one self-contained HTML file (figures embedded).")
@click.option("--md", "md_path", default=None, metavar="FILE",
              help="Write the Markdown to this file instead of stdout.")
@click.option("--no-figures", is_flag=True,
              help="Leave the figures out of the HTML/PDF (faster).")
@click.option("--json", "as_json", is_flag=True,
              help="Print the whole sheet as one JSON document (items with units, sources, "
                   "limits and verdicts; provenance) instead of Markdown.")
def command(campaign, variant, template, init_dir, pdf_path, html_path, md_path, no_figures,
            as_json):
    """Spec sheet (IEEE 952 style) of the test campaign CAMPAIGN (a TOML file).

    Runs every test of the campaign through the same analyses as the individual commands
    (bias, allan, scale-factor, thermal-fit, mag-fit, model fit, info) and lays out, in IEEE
    952 order: title block, the model equation with the fitted coefficients, scale factor,
    bias and random drift (N, B, K, R, Q; ≤ for bounds) with the noise structure and the
    platform vs strapdown note, environmental sensitivities, IA alignment, test conditions
    with every file's SHA-256, warnings, and PASS/FAIL against the campaign's limits. A test
    the campaign does not list reads "not tested".

    The customer sheet (default) states expanded uncertainties (k = 2), the decision rule
    (guarded acceptance per ILAC-G8: PASS / CONDITIONAL PASS / CONDITIONAL FAIL / FAIL),
    environmental conditions per test, test equipment with calibration dates, references,
    revision history and an approval block; --variant engineering adds the algorithm notes,
    diagnostics, model history, equivalent commands and warnings.

    The campaign file is checked completely (keys, paths, profiles, options) before any
    analysis. Markdown (with the figures as PNG files beside it when --md is given) goes to
    stdout unless --md, --html, --pdf or --json is given. The campaign format: docs/campaign.md,
    or 'gyrotest report --template'.

    \b
    Examples:
      gyrotest report --template > my-campaign.toml
      mkdir -p my_lab && cp sample_data/*.parquet sample_data/*.profile.toml my_lab/
      gyrotest report --init my_lab        # my_lab/campaign.toml from the logs in my_lab/
      gyrotest report sample_data/campaign.toml --pdf spec.pdf
      gyrotest report sample_data/campaign.toml --variant engineering --pdf eng.pdf
      gyrotest report sample_data/campaign.toml --html spec.html --json > spec.json
    """
    from ..core.output import write_rendered
    from ..specsheet.campaign import load_campaign

    if template:
        from ..specsheet.template import TEMPLATE

        click.echo(TEMPLATE, nl=False)
        return
    if init_dir is not None:
        _init(init_dir, as_json)
        return
    if campaign is None:
        raise InputError("report: give a CAMPAIGN file (or --template to print one)")

    t0 = time.perf_counter()
    pdf = _check_out(pdf_path, (".pdf",), "PDF file")
    htm = _check_out(html_path, (".html", ".htm"), "HTML file")
    md = _check_out(md_path, (".md", ".markdown", ".txt"), "Markdown file")
    camp = load_campaign(campaign)  # validates everything before any analysis
    from ..api.campaign import report

    figures = bool(pdf or htm or md) and not no_figures
    quiet = settings().quiet

    import contextlib
    import sys

    live = not quiet and sys.stderr.isatty()
    status_cm = err_console().status("report: reading the campaign …") if live else (
        contextlib.nullcontext())
    with status_cm as status:
        def progress(name: str) -> None:
            """A spinner line on a terminal; one note per analysis when piped (not -q/--json)."""
            if status is not None:
                status.update(f"report: {name} …")
            elif not quiet and not as_json:
                note(f"report: {name} …")

        sheet = report(camp, figures=figures, progress=progress, variant=variant).core
    t1 = time.perf_counter()
    outputs = []
    pdf_bytes = None
    if pdf:
        from ..specsheet.pdf import render_pdf

        pdf_bytes, pages = render_pdf(sheet)
        outputs.append(f"{pdf} ({pages} pages)")
    html_text = None
    if htm:
        from ..specsheet.html import render_html

        html_text = render_html(sheet)
        outputs.append(str(htm))
    md_text = None
    if md or not (pdf or htm or as_json):
        from ..specsheet.markdown import render_markdown

        links = None
        fig_files = {}
        if md is not None:
            figdir = f"{md.stem}_figures"
            for f in sheet.figures:
                if f.png is not None:
                    name = f"{figdir}/fig{f.number}_{f.key}.png"
                    fig_files[md.parent / name] = f.png
            links = {f.key: f"{figdir}/fig{f.number}_{f.key}.png" for f in sheet.figures
                     if f.png is not None}
        md_text = render_markdown(sheet, links)
    # every output is rendered before the first file is written
    write_rendered(pdf=pdf, pdf_bytes=pdf_bytes, html=htm, html_text=html_text, md=md,
                   md_text=md_text, figures=fig_files if md is not None else None)
    if md is not None:
        outputs.append(str(md) + (f" (+ {len(fig_files)} figures in {md.stem}_figures/)"
                                  if fig_files else ""))
    sheet.provenance["timing_s"]["render"] = time.perf_counter() - t1
    if as_json:
        emit_json(sheet.to_dict())
    elif md is None and md_text is not None:
        click.echo(md_text, nl=False)
    if outputs:
        note(f"report: {sheet.overall()}; wrote " + ", ".join(outputs)
             + f" in {time.perf_counter() - t0:.1f} s")
