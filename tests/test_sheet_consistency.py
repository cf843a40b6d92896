"""The sample spec sheet reads the same everywhere (issue 61): the README's headline image
shows the sheet the code makes, each f(I) term has one name and one formula in every output,
a number has the same uncertainty in a figure's legend as in the table beside it, JSON says
null where the sheet says "not evaluated", and no table cell breaks inside a word."""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

import pytest

from cliutil import run_cli

ROOT = Path(__file__).resolve().parents[1]
SAMPLE = ROOT / "sample_data"
sys.path.insert(0, str(ROOT / "docs"))
import make_figures  # noqa: E402  (docs/make_figures.py: the README's image)

RUNS = [SAMPLE / "ratetable_22a.parquet", SAMPLE / "ratetable_22b.parquet",
        SAMPLE / "ratetable_45.parquet", "--profile", SAMPLE / "ratetable_22a.profile.toml"]
OLD_NAMES = ("quadratic", "cubic", "quartic", "quintic")


@pytest.fixture(scope="module")
def sheet():
    """The customer sheet of the sample campaign with its figures (as make_figures builds
    it), and the legend texts of every figure drawn on the way."""
    import gyrotest.specsheet.figures as figures

    legends: dict[str, list[str]] = {}
    orig = figures._png_from_fig

    def capture(fig, size=None):
        texts = []
        for ax in fig.axes:
            lg = ax.get_legend()
            if lg is not None:
                texts += [lg.get_title().get_text()] + [t.get_text() for t in lg.get_texts()]
        legends[str(len(legends))] = texts
        return orig(fig, size)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(figures, "_png_from_fig", capture)
        sh = make_figures.build_sheet()
    from gyrotest.specsheet.pdf import render_pdf

    _, pages = render_pdf(sh)
    return sh, pages, [t for v in legends.values() for t in v]


# ----------------------------------------------------------------------------- item 1
def test_headline_image_shows_the_sheet_the_code_makes(sheet):
    sh, pages, _ = sheet
    stored = make_figures.read_stamp()
    assert stored, "docs/spec-page1.png has no stamp: run python docs/make_figures.py"
    diff = make_figures.differences(stored, make_figures.stamp(sh, pages))
    assert not diff, "docs/spec-page1.png is stale (python docs/make_figures.py): " + "\n".join(diff)
    # what the README promises about it
    assert "Compliance" in stored["gyrotest:page1"] and sh.overall() in stored["gyrotest:page1"]
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert "](docs/spec-page1.png)" in readme


def test_headline_image_stamp_detects_a_change(sheet):
    sh, pages, _ = sheet
    now = make_figures.stamp(sh, pages)
    changed = dict(now, **{"gyrotest:pages": str(pages + 1)})
    assert make_figures.differences(now, now) == []
    assert make_figures.differences(changed, now) == [
        f"gyrotest:pages: image '{pages + 1}', sheet '{pages}'"]


# ----------------------------------------------------------------------------- item 3
@pytest.fixture(scope="module")
def sf_outputs(tmp_path_factory):
    d = tmp_path_factory.mktemp("sf")
    term = run_cli(["scale-factor", *RUNS])
    assert term.code == 0, term.err
    js = run_cli(["scale-factor", *RUNS, "--json"])
    assert js.code == 0, js.err
    (d / "sf.json").write_text(js.out)
    assert run_cli(["export", "scale-factor", d / "sf.json", "-o", d / "sf.h"]).code == 0
    assert run_cli(["export", "scale-factor", d / "sf.json", "-o", d / "sf.csv"]).code == 0
    return term.out, json.loads(js.out), (d / "sf.h").read_text(), (d / "sf.csv").read_text()


def test_each_f_of_i_term_has_one_name_and_one_formula_everywhere(sf_outputs, sheet):
    from gyrotest.export.envlut import ascii_text
    from gyrotest.scalefactor.tablefit import OUTPUT_POWER_NOTE, TERM_LABELS, TERMS

    terminal, doc, header, csv_text = sf_outputs
    coefs = doc["nonlinearity_model"]["coefficients"]
    names = [c["term"] for c in coefs]
    assert {"u1", "u2"} <= set(names) and not set(names) & set(OLD_NAMES)
    # listed in powers of u, whatever order the selection found them in
    assert names == sorted(names, key=list(TERMS).index)
    for c in coefs:
        name, formula = c["term"], c["f_of_I"]
        assert formula == TERMS[name].formula
        # terminal: the name and the formula on one row
        assert re.search(rf"{re.escape(name)}\W+{re.escape(formula)}", terminal), name
    supported = [c for c in coefs if c["supported_by_data"]]
    for c in supported:
        name = c["term"]
        if name not in ("u1", "u2", "u3", "u4"):
            continue
        macro = f"GYRO_SF_{name.upper()}_PPM"
        power = int(name[1])
        assert f"{macro}" + " * u" * power in header  # the C function: c_k·u^k
        assert ascii_text(TERMS[name].formula) in header  # its comment: the same formula
        head = next(ln for ln in csv_text.splitlines() if not ln.startswith("#"))
        assert f"{name}_ppm" in head.split(","), head  # the look-up table's column
    # the sheet (PDF/HTML/Markdown) and its figure: u¹ … with the same formulas
    sh, _, legends = sheet
    model = next(t for s in sh.walk() for t in s.blocks
                 if getattr(t, "key", None) == "sf_model")
    rows = {r[0]: r[1] for r in model.rows}
    for name in ("u1", "u2", "u3", "u4"):
        if name in rows or TERM_LABELS[name] in rows:
            assert TERM_LABELS[name] in rows and rows[TERM_LABELS[name]] == TERMS[name].formula
    sf_legend = [t for t in legends if "term:" in t or t.startswith("model f(I)")]
    assert any("u¹ term: c1·u" in t for t in sf_legend), sf_legend
    # the earlier names (by the output power) are said once, in the note about the output
    everything = "\n".join([terminal.replace(OUTPUT_POWER_NOTE, ""), json.dumps(doc), header,
                            "\n".join(sf_legend)])
    for old in OLD_NAMES:
        assert old not in everything, old


# ----------------------------------------------------------------------------- item 4
def _pm(text: str) -> str:
    return text.split(" ± ", 1)[1].split()[0]


def test_legends_give_the_uncertainty_the_tables_give(sheet):
    from gyrotest.core.units import format_number

    sh, _, legends = sheet
    checks = {c.key: c for c in sh.checks}
    for key, sym in (("allan.N", "N = "), ("allan.B", "B = "), ("allan.Q", "Q = ")):
        text = next(t for t in legends if f"): {sym}" in t)
        assert _pm(text) == format_number(checks[key].expanded_uncertainty, 2), (key, text)
    for axis in ("x", "y", "z"):
        text = next(t for t in legends if t.startswith(f"w{axis} = "))
        want = checks[f"magnetic.w{axis}"].expanded_uncertainty
        assert float(_pm(text)) == pytest.approx(want, rel=0.05), (axis, text)
    assert legends.count(f"± = U (k = {checks['allan.N'].k:g})") >= 2
    assert not any(t == "± = 1σ" for t in legends)


def test_cli_plots_say_their_legend_is_one_sigma(tmp_path):
    from gyrotest.noise.plots import legend_pm_title

    assert legend_pm_title() == "± = 1σ" and legend_pm_title(2.0) == "± = U (k = 2)"


def test_json_uncertainty_is_null_where_the_sheet_says_not_evaluated(sheet):
    sh, _, _ = sheet
    d = sh.to_dict()
    limited = [c for c in d["checks"] if c["limit"] is not None and c["measured"]]
    none = [c for c in limited if c["measured"].get("sigma") is None]
    assert none, "the sample sheet has limited items without an uncertainty"
    for c in none:
        assert c["expanded_uncertainty"] is None, c["key"]
    for c in limited:
        if c["measured"].get("sigma") is not None and not c["measured"].get("upper_bound"):
            assert c["expanded_uncertainty"] == pytest.approx(2 * c["measured"]["sigma"])


def test_no_table_cell_breaks_inside_a_word(sheet):
    from gyrotest.specsheet.pdf import (
        CELL_PAD,
        VERDICT_COLOURS,
        _register_fonts,
        _styles,
        column_widths,
    )
    from gyrotest.specsheet.sheet import Num, Table

    _register_fonts()
    st = _styles()
    width = 510.0  # A4 less the margins, pt
    sh, _, _ = sheet
    fleet_like = Table(["serial", "scale factor SF ± U, arcsec/pulse", "ε0, ppm", "N, °/√h",
                        "B, °/h", "K, (°/h)/√h", "verdict"],
                       [["0427", "0.2000158 ± 0.0000021", "78.9", "0.007995 ± 0.000058",
                         "0.0398 ± 0.0090", "≤ 0.05265", "CONDITIONAL PASS"],
                        ["0428", Num(4.75e-6, "", 1.2e-7, k=2.0), "0.012", "strapdown",
                         "arcsec/pulse", "4.750·10⁻⁶", "PASS"]])
    from gyrotest.specsheet.build import make_report
    from gyrotest.specsheet.campaign import load_campaign

    eng = make_report(load_campaign(str(make_figures.CAMPAIGN)), figures=False,
                      variant="engineering")  # its commands, diagnostics and history tables
    tables = [b for one in (sh, eng) for s in one.walk() for b in s.blocks
              if isinstance(b, Table)] + [fleet_like]
    from reportlab.pdfbase.pdfmetrics import stringWidth

    for t in tables:
        colw = column_widths(t, st, width)
        assert sum(colw) == pytest.approx(width)
        mono = t.key in ("files", "commands")
        for r in [t.columns, *t.rows]:
            for j, c in enumerate(r):
                if mono and j == len(t.columns) - 1:
                    continue
                txt = c if isinstance(c, str) else t.cell_text(c)
                bold = r is t.columns or txt in VERDICT_COLOURS
                font = st["cellb"] if bold else st["cell"]
                for word in txt.split():
                    w = stringWidth(word, font.fontName, font.fontSize)
                    assert w + CELL_PAD <= colw[j] + 1e-6, (t.title, word, colw[j])
