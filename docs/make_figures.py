"""The README's headline image, made from the bundled sample campaign.

    python docs/make_figures.py            # rewrite docs/spec-page1.png
    python docs/make_figures.py --check    # exit 1 when the image no longer shows the sheet

``docs/spec-page1.png`` is page 1 of the customer sheet of ``sample_data/campaign.toml`` --
what ``gyrotest report sample_data/campaign.toml --pdf spec.pdf`` writes -- rendered at
90 dpi by ``pdftoppm`` (Debian/Ubuntu: ``apt-get install poppler-utils``). Pixels differ
between renderer versions, so the image carries, as PNG text chunks, what the page says: the
text of the title block and section 1 (as the Markdown sheet has it), the overall verdict, the
page count and the campaign file's SHA-256. ``tests/test_sheet_consistency.py`` builds the
sheet again and compares those; when the sheet changes (a number, the verdict, the page
count, the campaign), the test fails until this script is run.
"""

from __future__ import annotations

import dataclasses
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CAMPAIGN = ROOT / "sample_data" / "campaign.toml"
IMAGE = ROOT / "docs" / "spec-page1.png"
DPI = 90
#: PNG text-chunk keys (tEXt/iTXt) of what the image shows
KEYS = ("gyrotest:page1", "gyrotest:overall", "gyrotest:pages", "gyrotest:campaign_sha256",
        "gyrotest:version")


def build_sheet():
    """The customer sheet of the sample campaign, with its figures (they decide the page
    count), as ``gyrotest report`` builds it."""
    from gyrotest.specsheet.build import make_report
    from gyrotest.specsheet.campaign import load_campaign

    return make_report(load_campaign(str(CAMPAIGN)), figures=True, variant="customer")


def page_one_text(sheet) -> str:
    """What page 1 says, as text: the title, the title block (with the overall verdict) and
    section 1 (the model equation with the fitted coefficients), in the Markdown renderer's
    words -- the same numbers the PDF prints, independent of fonts and renderers."""
    from gyrotest.specsheet.markdown import render_markdown

    first = dataclasses.replace(sheet, sections=sheet.sections[:1])
    return render_markdown(first).strip()


def stamp(sheet, pages: int) -> dict[str, str]:
    """The text chunks of the image for ``sheet`` rendered on ``pages`` pages."""
    from gyrotest import __version__

    return {"gyrotest:page1": page_one_text(sheet), "gyrotest:overall": sheet.overall(),
            "gyrotest:pages": str(pages),
            "gyrotest:campaign_sha256": sheet.provenance["campaign"]["sha256"],
            "gyrotest:version": __version__}


def read_stamp(path: Path = IMAGE) -> dict[str, str]:
    """The text chunks stored in the image (empty for an image this script did not make)."""
    from PIL import Image

    with Image.open(path) as im:
        im.load()
        return {k: v for k, v in getattr(im, "text", {}).items() if k in KEYS}


def render_page_one(pdf: bytes, out: Path) -> None:
    """Page 1 of ``pdf`` as a PNG at :data:`DPI`, by pdftoppm."""
    exe = shutil.which("pdftoppm")
    if exe is None:
        raise SystemExit("make_figures: pdftoppm not found; install poppler-utils "
                         "(apt-get install poppler-utils) and run again")
    with tempfile.TemporaryDirectory() as d:
        src = Path(d) / "spec.pdf"
        src.write_bytes(pdf)
        subprocess.run([exe, "-f", "1", "-l", "1", "-r", str(DPI), "-png", "-singlefile",
                        str(src), str(Path(d) / "page")], check=True)
        shutil.copyfile(Path(d) / "page.png", out)


def write_image(out: Path = IMAGE) -> dict[str, str]:
    """Build the sheet, render its page 1 to ``out`` with the text chunks; returns them."""
    from PIL import Image
    from PIL.PngImagePlugin import PngInfo

    from gyrotest.specsheet.pdf import render_pdf

    sheet = build_sheet()
    pdf, pages = render_pdf(sheet)
    meta = stamp(sheet, pages)
    with tempfile.TemporaryDirectory() as d:
        raw = Path(d) / "page1.png"
        render_page_one(pdf, raw)
        info = PngInfo()
        for k, v in meta.items():
            info.add_itxt(k, v)
        with Image.open(raw) as im:
            tmp = out.with_suffix(".tmp.png")
            im.save(tmp, pnginfo=info, optimize=True)
        tmp.replace(out)
    return meta


def differences(stored: dict[str, str], now: dict[str, str]) -> list[str]:
    """What the image says that the sheet no longer does (one line per key)."""
    out = []
    for k in KEYS:
        if stored.get(k) != now.get(k):
            a, b = stored.get(k, "(missing)"), now.get(k, "(missing)")
            if k == "gyrotest:page1":
                import difflib

                diff = [ln for ln in difflib.unified_diff(a.splitlines(), b.splitlines(),
                                                          "image", "sheet", lineterm="", n=0)
                        if ln.startswith(("+", "-")) and not ln.startswith(("+++", "---"))]
                out.append(f"{k}: " + "; ".join(diff[:6]))
            else:
                out.append(f"{k}: image {a!r}, sheet {b!r}")
    return out


def main() -> int:
    if "--check" in sys.argv[1:]:
        from gyrotest.specsheet.pdf import render_pdf

        sheet = build_sheet()
        _, pages = render_pdf(sheet)
        diff = differences(read_stamp(), stamp(sheet, pages))
        for d in diff:
            print(d, file=sys.stderr)
        if diff:
            print("docs/spec-page1.png is stale: run python docs/make_figures.py",
                  file=sys.stderr)
        return 1 if diff else 0
    meta = write_image()
    print(f"wrote {IMAGE.relative_to(ROOT)}: {meta['gyrotest:overall']}, "
          f"{meta['gyrotest:pages']} pages")
    return 0


if __name__ == "__main__":
    sys.exit(main())
