"""``gyrotest report``: every number of the sample sheet equals what the individual command
prints, "not tested" sections, campaign validation before any work, and the outputs."""

from __future__ import annotations

import json
import math
import os
import shutil
from pathlib import Path

import pytest

from cliutil import run_cli

ROOT = Path(__file__).resolve().parents[1]
SAMPLE = ROOT / "sample_data"
CAMPAIGN = SAMPLE / "campaign.toml"


def numbers(doc) -> list[dict]:
    """Every number of a sheet's JSON that carries a source."""
    out = []

    def walk(x):
        if isinstance(x, dict):
            if "source" in x and "value" in x:
                out.append(x)
            for v in x.values():
                walk(v)
        elif isinstance(x, list):
            for v in x:
                walk(v)

    walk(doc)
    return out


def dig(d, path):
    for k in path:
        d = d[k]
    return d


@pytest.fixture(scope="module")
def sample_sheet():
    r = run_cli(["-q", "report", CAMPAIGN, "--json", "--variant", "engineering"])
    assert r.code == 0, r.err
    return json.loads(r.out)


def check_against_commands(sheet: dict, cwd: Path) -> set[str]:
    """Run each command of the sheet's provenance with --json in ``cwd`` (the campaign
    directory, as the sheet says) and compare every sourced number and 1σ with it; return the
    analyses that were checked."""
    cmds = {c["key"]: c["argv"] for c in sheet["provenance"]["commands"]}
    outputs = {}
    old = os.getcwd()
    os.chdir(cwd)
    try:
        for key, argv in cmds.items():
            assert argv[0] == "gyrotest"
            r = run_cli([*argv[1:], "--json"])
            assert r.code == 0, f"{key}: {r.err}"
            outputs[key] = json.loads(r.out)
    finally:
        os.chdir(old)
    checked = set()
    for n in numbers(sheet):
        for src, val in ((n["source"], n["value"]), (n.get("sigma_source"), n.get("sigma"))):
            if src is None:
                continue
            want = dig(outputs[src["analysis"]], src["path"])
            assert isinstance(want, (int, float)) and val is not None, (src, want, val)
            assert val == want or math.isclose(val, want, rel_tol=1e-12, abs_tol=0.0), \
                (src, val, want)
            checked.add(src["analysis"])
    assert checked == set(cmds), set(cmds) - checked  # every analysis contributed numbers
    return checked


def test_every_number_equals_the_individual_command(sample_sheet):
    """The acceptance check: each number of the sample sheet is the one the command prints."""
    checked = check_against_commands(sample_sheet, SAMPLE)
    assert {"bias", "allan", "scale_factor", "thermal", "magnetic", "multiposition",
            "thermal.step1", "thermal.step4", "info:static.parquet"} <= checked
    assert len(numbers(sample_sheet)) > 250


def test_sample_sheet_content(sample_sheet):
    d = sample_sheet
    assert d["format"] == "gyrotest-spec-sheet"
    titles = [s["title"] for s in d["sections"]]
    assert titles[0] == "Model equation" and titles[1] == "Scale factor"
    assert "IA alignment" in titles and "Compliance with the spec limits" in titles
    assert titles[-3:] == ["References", "Revision history", "Approval"]
    assert d["variant"] == "engineering"
    checks = {c["key"]: c for c in d["checks"]}
    # bounds are printed with ≤ and carry the upper_bound flag
    for k in ("allan.K", "allan.R"):
        assert checks[k]["measured"]["upper_bound"] is True
        assert checks[k]["measured"]["text"].startswith("≤")
    # the supply test is absent: not tested, and it says so
    assert checks["supply.supply_dph_per_v"]["verdict"] == "not tested"
    env = next(s for s in d["sections"] if s["title"].startswith("Environmental"))
    supply = next(s for s in env["subsections"] if s["title"] == "Supply voltage")
    assert supply["status"] == "not tested"
    assert d["overall_verdict"] in ("PASS", "CONDITIONAL PASS", "CONDITIONAL FAIL", "FAIL",
                                    "INCONCLUSIVE")
    # reproducibility: version, campaign and every input with its SHA-256
    prov = d["provenance"]
    assert prov["gyrotest_version"]
    assert len(prov["campaign"]["sha256"]) == 64
    files = {f["file"]: f["sha256"] for f in prov["inputs"]}
    assert "static.parquet" in files and "multipos.csv" in files
    import hashlib

    assert files["multipos.csv"] == hashlib.sha256((SAMPLE / "multipos.csv").read_bytes()
                                                   ).hexdigest()
    # units everywhere: every sourced number has a unit, or sits under a header with one
    for n in numbers(d):
        assert n["text"] != "—"


def _mini_campaign(tmp_path: Path, body: str) -> Path:
    """A campaign in tmp_path using one bias run of the sample data."""
    for f in ("bias_run1.parquet", "bias_run1.profile.toml"):
        shutil.copy(SAMPLE / f, tmp_path / f)
    p = tmp_path / "camp.toml"
    p.write_text('[campaign]\noperator = "T"\ndate = "2024-01-01"\n'
                 '[gyro]\nmodel = "GT-FOG-100"\nserial = "0427"\n'
                 'nominal_scale_factor = 0.2\nscale_factor_unit = "arcsec/pulse"\n'
                 '[site]\nlatitude_deg = 48.137\n' + body, encoding="utf-8")
    return p


BIAS = ('[tests.bias]\nlogs = ["bias_run1.parquet"]\nprofile = "bias_run1.profile.toml"\n'
        'skip = "30min"\nlimits = { bias_dph = 0.5 }\n')


def test_missing_tests_read_not_tested_and_outputs(tmp_path):
    camp = _mini_campaign(tmp_path, BIAS)
    pdf, html, md = tmp_path / "s.pdf", tmp_path / "s.html", tmp_path / "s.md"
    r = run_cli(["-q", "report", camp, "--pdf", pdf, "--html", html, "--md", md])
    assert r.code == 0, r.err
    text = md.read_text(encoding="utf-8")
    for heading in ("2 Scale factor", "3.2 Random drift", "4.1 Thermal", "4.2 Magnetic",
                    "5 IA alignment"):
        part = text.split(heading, 1)[1].split("\n#", 1)[0]
        assert "Not tested" in part, heading
    # the one test that ran: D_F with its 1σ and a FAIL against the (too tight) limit
    assert "| bias D_F ± U (k = 2) |" in text and "FAIL" in text
    assert pdf.read_bytes().startswith(b"%PDF") and pdf.stat().st_size > 5000
    h = html.read_text(encoding="utf-8")
    assert h.startswith("<!DOCTYPE html>") and "not tested" in h.lower()
    assert "<img" not in h  # no analysis with a figure ran
    # no stray temporary files
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        ["bias_run1.parquet", "bias_run1.profile.toml", "camp.toml", "s.pdf", "s.html", "s.md"])
    assert "not listed in the campaign" in text  # no [[equipment]]: the sheet says so


def test_markdown_to_stdout_by_default(tmp_path):
    camp = _mini_campaign(tmp_path, BIAS)
    r = run_cli(["-q", "report", camp])
    assert r.code == 0, r.err
    assert r.out.startswith("# GT-FOG-100 s/n 0427: gyro specification sheet")
    assert "## 7 Compliance with the spec limits" in r.out
    assert "## 10 Approval" in r.out and "Warnings raised" not in r.out


@pytest.mark.parametrize(("body", "fragments"), [
    (BIAS.replace("skip =", "skipp ="), ["camp.toml", "[tests.bias] skipp", "unknown key"]),
    (BIAS.replace("bias_run1.parquet\"]", "nope.parquet\"]"),
     ["camp.toml", "[tests.bias] logs[0]", "nope.parquet", "not found"]),
    (BIAS + '[tests.allan]\nlog = "bias_run1.parquet"\nprofile = "missing.toml"\n',
     ["camp.toml", "[tests.allan] profile", "missing.toml"]),
    (BIAS + '[tests.alan]\nlog = "bias_run1.parquet"\n', ["camp.toml", "[tests.alan]",
                                                         "unknown test"]),
    (BIAS.replace("bias_dph", "bias_dhp"), ["camp.toml", "limits.bias_dhp", "unknown limit"]),
    (BIAS.replace('"30min"', '"thirty minutes"'), ["camp.toml", "[tests.bias] skip"]),
    (BIAS + '[tests.allan]\nlog = "bias_run1.parquet"\nvehicle_rates = ["fast"]\n',
     ["camp.toml", "vehicle_rates", "fast"]),
    (BIAS + '[tests.allan]\nlog = "bias_run1.parquet"\nterms = "Q,N,X"\n',
     ["camp.toml", "[tests.allan] terms"]),
    (BIAS + '[tests.thermal]\nlog = "bias_run1.parquet"\nmodel_steps = ["T,bogus"]\n',
     ["camp.toml", "model_steps", "bogus"]),
    (BIAS + '[tests.magnetic]\nprofile = "bias_run1.profile.toml"\n',
     ["camp.toml", "[tests.magnetic] log", "missing"]),
    ('[tests]\nbias = 3\n', ["camp.toml", "[tests.bias]", "table"]),
    ('[extra]\nx = 1\n', ["camp.toml", "[extra]", "unknown section"]),
])
def test_bad_campaign_fails_before_any_work(tmp_path, monkeypatch, body, fragments):
    import gyrotest.specsheet.build as build

    def boom(*a, **k):
        raise AssertionError("an analysis ran before the campaign was validated")

    monkeypatch.setattr(build, "run_campaign", boom)
    camp = _mini_campaign(tmp_path, body)
    pdf = tmp_path / "spec.pdf"
    r = run_cli(["report", camp, "--pdf", pdf])
    r.assert_clean_error(*fragments)
    assert not pdf.exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


def test_bad_toml_missing_file_and_output_path(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[campaign\n")
    run_cli(["report", bad]).assert_clean_error("bad.toml", "invalid TOML")
    run_cli(["report", tmp_path / "none.toml"]).assert_clean_error("none.toml", "not found")
    camp = _mini_campaign(tmp_path, BIAS)
    run_cli(["report", camp, "--pdf", tmp_path / "no" / "x.pdf"]).assert_clean_error(
        "does not exist")
    run_cli(["report", camp, "--pdf", tmp_path / "x.png"]).assert_clean_error(".pdf")
    c2 = _mini_campaign(tmp_path, BIAS.replace('operator = "T"', ""))
    c2.write_text(c2.read_text().replace('operator = "T"\n', ""))
    run_cli(["report", c2]).assert_clean_error("[campaign] operator", "missing")


def test_analysis_error_names_the_test(tmp_path):
    camp = _mini_campaign(tmp_path, BIAS.replace('"30min"', '"3h"'))
    r = run_cli(["report", camp])
    r.assert_clean_error("camp.toml", "[tests.bias]", "removes the whole record")


def test_number_formatting_and_verdicts():
    from gyrotest.specsheet.sheet import (
        FAIL,
        INCONCLUSIVE,
        NO_LIMIT,
        PASS,
        Check,
        Num,
        fmt_number,
        fmt_pm,
    )

    assert fmt_pm(1.80912, 0.03249) == "1.809 ± 0.032"
    assert fmt_pm(0.00799512, 2.9e-5) == "0.007995 ± 0.000029"
    assert fmt_pm(-0.0421, 0.0203) == "−0.042 ± 0.020"
    assert fmt_pm(2.3e-5, 1.1e-6).endswith("·10⁻⁵")
    assert fmt_number(216000.0) == "216000"
    assert fmt_number(0.2) == "0.2"
    assert fmt_number(1.99975, 3, strip=False) == "2.00"
    assert fmt_number(float("nan")) == "—"
    assert Num(0.0527, "(°/h)/√h", bound=True).text() == "≤ 0.0527 (°/h)/√h"

    def v(value, limit, bound=False):
        return Check("k", "x", "", Num(value, "u", bound=bound), limit, "u").verdict

    assert v(0.8, 1.0) == PASS and v(-0.8, 1.0) == PASS and v(1.2, 1.0) == FAIL
    assert v(1.2, 1.0, bound=True) == INCONCLUSIVE and v(0.5, 1.0, bound=True) == PASS
    # ILAC-G8 guarded acceptance with U = 2σ, and simple acceptance
    from gyrotest.specsheet.sheet import COND_FAIL, COND_PASS

    def g(value, sigma, limit, rule="guard-band"):
        return Check("k", "x", "", Num(value, "u", sigma), limit, "u", rule=rule).verdict

    assert g(0.7, 0.1, 1.0) == PASS            # 0.7 + 0.2 <= 1
    assert g(0.9, 0.1, 1.0) == COND_PASS       # 0.9 <= 1 < 1.1
    assert g(-1.1, 0.1, 1.0) == COND_FAIL      # 0.9 <= 1 < 1.1
    assert g(1.3, 0.1, 1.0) == FAIL            # 1.1 > 1
    assert g(0.9, 0.1, 1.0, "simple") == PASS and g(1.05, 0.1, 1.0, "simple") == FAIL
    assert Num(1.0, "u", 0.1, k=2).text() == "1.00 ± 0.20 u"
    assert v(0.5, None) == NO_LIMIT
    assert Check("k", "x", "", None, 1.0, "u").verdict == "not tested"


def test_sample_pdf_and_html_with_figures(tmp_path):
    """The README's first command on the bundled campaign: PDF and HTML with every figure."""
    pdf, html = tmp_path / "spec.pdf", tmp_path / "spec.html"
    r = run_cli(["-q", "report", CAMPAIGN, "--pdf", pdf, "--html", html, "--json",
                 "--variant", "engineering"])
    assert r.code == 0, r.err
    d = json.loads(r.out)
    figs = d["figures"]
    assert [f["key"] for f in figs] == ["scale_factor", "allan", "thermal_thermal",
                                        "thermal_time", "magnetic", "history"]
    assert all(f["embedded"] for f in figs)
    assert not [w for w in d["warnings"] if "could not be drawn" in w["text"]]
    data = pdf.read_bytes()
    assert data.startswith(b"%PDF") and data.rstrip().endswith(b"%%EOF")
    assert 200_000 < len(data) < 3_000_000
    h = html.read_text(encoding="utf-8")
    assert h.count("data:image/png;base64,") == 6
    assert "Figure 6." in h and "not tested" in h.lower()


def test_supply_test_and_equality(tmp_path):
    """A campaign with a supply-voltage run: the sensitivity is reported, checked against its
    limit, and equals what 'gyrotest model fit --terms V' prints."""
    from gyrotest.simulation import simulate, write_log

    scen = {"scenario": {"seed": 3}, "record": {"sample_rate_hz": 1.0, "duration_s": 7200},
            "gyro": {"output": "rate", "rate_unit": "deg/h", "bias_dph": 0.5,
                     "model": "GT-FOG-100", "serial": "0427", "noise": {"N": 0.01}},
            "site": {"latitude_deg": 48.137, "ia": "east"},
            "environment": {"supply": {"nominal_v": 15.0,
                                       "steps": [[1800.0, 14.0], [3600.0, 16.0],
                                                 [5400.0, 15.0]], "noise_v": 0.001}},
            "effects": {"supply": {"dph_per_v": 0.08}}}
    write_log(simulate(scen), tmp_path / "supply.csv")
    camp = _mini_campaign(tmp_path, BIAS + '[tests.supply]\nlog = "supply.csv"\n'
                          'profile = "supply.profile.toml"\n'
                          'limits = { supply_dph_per_v = 0.05 }\n')
    r = run_cli(["-q", "report", camp, "--json"])
    assert r.code == 0, r.err
    d = json.loads(r.out)
    ch = {c["key"]: c for c in d["checks"]}["supply.supply_dph_per_v"]
    assert ch["verdict"] == "FAIL"
    assert abs(ch["measured"]["value"] - 0.08) < 5 * ch["measured"]["sigma"]
    checked = check_against_commands(d, tmp_path)
    assert {"bias", "supply", "info:supply.csv"} <= checked


def test_customer_sheet_is_sendable(tmp_path):
    """The default (customer) sheet of the sample campaign: expanded uncertainties with k
    stated, the ILAC-G8 rule, environment per test, equipment with calibration dates,
    references by author and title, revision history and approval; no internal notes."""
    md = tmp_path / "spec.md"
    r = run_cli(["-q", "report", CAMPAIGN, "--md", md, "--json"])
    assert r.code == 0, r.err
    d = json.loads(r.out)
    text = md.read_text(encoding="utf-8")
    assert d["variant"] == "customer"
    titles = [s["title"] for s in d["sections"]]
    assert titles[-4:] == ["Compliance with the spec limits", "References", "Revision history",
                           "Approval"]
    assert "Warnings raised by the analyses" not in titles
    for frag in ("U (k = 2)", "ILAC-G8", "Environmental conditions per test", "Test equipment",
                 "calibration due", "2024-11-02", "Antonova, V. A. Matveev",
                 "Herald of the Bauman", "Krobka", "C. Head", "first issue"):
        assert frag in text, frag
    # no internal language, algorithm notes or diagnostics in the customer sheet
    low = text.lower()
    for frag in ("seed", "tau_min/4", "1/0.664", "gyrotest model diagnose", "error falling as terms are added",
                 "equivalent command", "χ²/dof = "):
        assert frag.lower() not in low, frag
    # the contradictions of issue 14 are explained, not left side by side
    assert "D_T and w1 are not two measurements" in text
    assert "Two asymmetry numbers, one explanation" in text
    assert "u²" in text and "cubic in the output" not in text
    # expanded uncertainty: U = 2σ in the check JSON, and in the number text
    ch = {c["key"]: c for c in d["checks"]}["thermal.D_T"]
    m = ch["measured"]
    assert ch["coverage_factor"] == 2.0
    assert math.isclose(ch["expanded_uncertainty"], 2 * m["sigma"])
    assert math.isclose(m["expanded_uncertainty"], 2 * m["sigma"])
    # the Markdown has its figures, written beside it
    figs = sorted((tmp_path / "spec_figures").glob("*.png"))
    assert len(figs) == 5 and all(f.read_bytes().startswith(b"\x89PNG") for f in figs)
    assert text.count("](spec_figures/") == 5


def test_engineering_sheet_adds_diagnostics(sample_sheet):
    titles = [s["title"] for s in sample_sheet["sections"]]
    assert "Warnings raised by the analyses" in titles
    blob = json.dumps(sample_sheet, ensure_ascii=False)
    assert "Model history" in blob and "Graph read-offs" in blob and "seed" not in blob.lower()
    w = [x["text"] for x in sample_sheet["warnings"] if "not significant" in x["text"]]
    assert w and all("Antonova–Matveev model" in x and "IEEE D_T" in x for x in w)


def test_template_is_a_valid_campaign(tmp_path):
    r = run_cli(["report", "--template"])
    assert r.code == 0 and "[[equipment]]" in r.out and "[decision]" in r.out
    p = SAMPLE / "_template_check.toml"
    try:
        p.write_text(r.out, encoding="utf-8")
        from gyrotest.specsheet.campaign import load_campaign

        c = load_campaign(p)
        assert c.decision == {"rule": "guard-band", "coverage_factor": 2.0}
        assert len(c.equipment) == 2 and c.revisions[0]["revision"] == "1"
    finally:
        p.unlink(missing_ok=True)
    run_cli(["report"]).assert_clean_error("CAMPAIGN", "--template")


@pytest.mark.parametrize(("body", "fragments"), [
    ('[decision]\nrule = "strict"\n', ["[decision] rule", "guard-band"]),
    ('[decision]\ncoverage_factor = 7.0\n', ["[decision] coverage_factor"]),
    ('[[equipment]]\nname = "table"\n', ["[[equipment]] #1 calibration_due", "missing"]),
    ('[[equipment]]\nname = "t"\ncalibration_due = "soon"\n', ["calibration_due", "date"]),
    ('[[equipment]]\nname = "t"\ncalibration_due = 2025-01-01\ntests = ["biass"]\n',
     ["[[equipment]] #1 tests", "biass"]),
    ('[lab]\nlogo = "nope.png"\n', ["[lab] logo", "not found"]),
    ('[equipment]\nname = "t"\n', ["[[equipment]]", "array of tables"]),
])
def test_bad_lab_keys(tmp_path, body, fragments):
    camp = _mini_campaign(tmp_path, BIAS)
    camp.write_text(camp.read_text().replace("[site]", body + "[site]"), encoding="utf-8")
    run_cli(["report", camp]).assert_clean_error("camp.toml", *fragments)


def test_expired_calibration_is_flagged(tmp_path):
    camp = _mini_campaign(tmp_path, BIAS.replace("[tests.bias]\n", "[tests.bias]\nenvironment"
                                                 " = { temperature = \"22 ± 1 °C\" }\n"))
    camp.write_text(camp.read_text().replace(
        "[site]", '[[equipment]]\nname = "Logger"\ncalibration_due = 2023-12-31\n[site]'),
        encoding="utf-8")
    r = run_cli(["-q", "report", camp, "--variant", "engineering"])
    assert r.code == 0, r.err
    assert "| Logger |" in r.out and "EXPIRED" in r.out and "temperature 22 ± 1 °C" in r.out
    assert "Logger: calibration EXPIRED" in r.out


def test_pdf_creation_date(tmp_path, monkeypatch):
    from gyrotest.specsheet import build_sheet, load_campaign
    from gyrotest.specsheet.pdf import render_pdf

    camp = _mini_campaign(tmp_path, BIAS)
    sheet = build_sheet(load_campaign(camp), {}, figures=False)
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1700000000")
    data, _ = render_pdf(sheet)
    assert b"D:20231114221320" in data
    monkeypatch.delenv("SOURCE_DATE_EPOCH")
    import time

    data, _ = render_pdf(sheet)
    assert f"D:{time.strftime('%Y%m%d')}".encode() in data
