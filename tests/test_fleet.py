"""gyrotest fleet: a simulated lot (5 serials, one with an earlier test, one outlier) through
the serial, process-pool and Dask paths; the summary against the truth and the report."""

from __future__ import annotations

import json

import numpy as np
import pytest

from cliutil import run_cli


@pytest.fixture(scope="module")
def lot(tmp_path_factory):
    from gyrotest.simulation.lot import SMALL, write_lot

    return write_lot(tmp_path_factory.mktemp("lot"), 5, size=SMALL, outlier=3, earlier=1)


@pytest.fixture(scope="module")
def serial_fleet(lot):
    from gyrotest.fleet import run_fleet

    return run_fleet(lot.campaigns, jobs=1)


def test_lot_summary_against_truth(lot, serial_fleet):
    f = serial_fleet
    assert [r["serial"] for r in f.lot] == ["1101", "1102", "1103", "1104", "1105"]
    assert list(f.earlier) == ["1101"] and f.earlier["1101"][0]["date"] < f.lot[0]["date"]
    truth = {m.serial: m.truth for m in lot.members if not m.earlier}
    stats = {s.key: s for s in f.stats}
    bias = stats["bias.bias_dph"]
    vals = [f.item(r, "bias.bias_dph") for r in f.lot]
    for r, it in zip(f.lot, vals):  # each serial's D_F against its simulated bias
        assert abs(it["value"] - truth[r["serial"]]["bias_dph"]) < 5 * it["sigma"] + 0.02
    x = np.array([v["value"] for v in vals])
    assert bias.n == 5 and bias.mean == pytest.approx(x.mean())
    assert bias.std == pytest.approx(x.std(ddof=1)) and bias.max == pytest.approx(x.max())
    assert bias.limit == 3.0 and bias.verdicts == {"PASS": 5}
    # the simulated outlier (bias 2.4 °/h against ≈0.4 ± 0.15) is the one flagged
    assert bias.outliers == ["1104"] and bias.z["1104"] > bias.threshold
    assert [(o["key"], o["serial"]) for o in f.outliers()] == [("bias.bias_dph", "1104")]
    assert "scale_factor.nominal" not in stats  # settings are not lot statistics


def test_numbers_equal_the_report(lot, serial_fleet):
    camp = next(m.campaign for m in lot.members if m.serial == "1102")
    r = run_cli(["-q", "report", camp, "--json"])
    assert r.code == 0, r.err
    rep = {c["key"]: c for c in json.loads(r.out)["checks"]}
    rec = next(x for x in serial_fleet.lot if x["serial"] == "1102")
    for it in rec["items"]:
        m = rep[it["key"]]["measured"]
        assert it["value"] == (m["value"] if m else None), it["key"]
        assert it["verdict"] == rep[it["key"]]["verdict"]


def test_process_pool_equals_serial(lot, serial_fleet):
    from gyrotest.fleet import run_fleet

    pool = run_fleet(lot.campaigns, jobs=2)
    assert pool.run["executor"].startswith("process pool")
    assert pool.to_dict(timing=False) == serial_fleet.to_dict(timing=False)


def test_dask_local_cluster_equals_serial(lot, serial_fleet):
    distributed = pytest.importorskip("distributed")
    from gyrotest.fleet import run_fleet

    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        fl = run_fleet(lot.campaigns, client=client)
    assert fl.run["executor"].startswith("dask")
    assert fl.to_dict(timing=False) == serial_fleet.to_dict(timing=False)


def test_cli_outputs_and_errors(lot, tmp_path):
    md, pdf = tmp_path / "lot.md", tmp_path / "lot.pdf"
    r = run_cli(["-q", "fleet", *lot.campaigns, "--md", md, "--pdf", pdf, "--jobs", "1"])
    assert r.code == 0, r.err
    text = md.read_text(encoding="utf-8")
    assert "| s/n 1101 | s/n 1102 | s/n 1103 | s/n 1104 | s/n 1105 |" in text
    assert "2.400 ± 0.0" in text and "(outlier)" in text
    assert (tmp_path / "lot_figures" / "fig1_control_charts.png").stat().st_size > 20_000
    assert "2024-03-05" in text.split("## 5 Earlier", 1)[1]  # the earlier test of 1101
    assert pdf.read_bytes().startswith(b"%PDF")
    j = run_cli(["-q", "fleet", *lot.campaigns[:3], "--json", "-j", "1"])
    d = json.loads(j.out)
    assert d["format"] == "gyrotest-fleet" and d["outliers"] == []  # < 5 serials: none
    # bad input: one line, exit 2, nothing written
    bad = tmp_path / "bad.toml"
    bad.write_text("[campaign\n")
    out = tmp_path / "x.pdf"
    run_cli(["fleet", lot.campaigns[0], bad, "--pdf", out]).assert_clean_error("bad.toml")
    assert not out.exists()
    run_cli(["fleet", lot.campaigns[0], "--jobs", "0"]).assert_clean_error("--jobs")
    run_cli(["fleet", lot.campaigns[0], lot.campaigns[0]]).assert_clean_error("given twice")
    html = tmp_path / "lot.html"
    r = run_cli(["-q", "fleet", *lot.campaigns, "--html", html, "-j", "1"])
    assert r.code == 0 and html.read_text(encoding="utf-8").count("data:image/png;base64,") == 1
    run_cli(["fleet", lot.campaigns[0], "--md", tmp_path / "x.png"]).assert_clean_error(".md")


def test_outlier_rule_false_alarms_and_recall():
    """The n-dependent threshold (tuned with seed 1) on other random lots: about 1 % of null
    lots have a flag; a value 20σ (n = 6) or 8σ (n = 20) off is found; the others are not
    flagged with it."""
    from gyrotest.fleet.core import flag_outliers, outlier_threshold

    assert outlier_threshold(4) == np.inf and outlier_threshold(200) >= 3.5
    assert outlier_threshold(11) == pytest.approx((6.83 + 6.3) / 2)
    rng = np.random.default_rng(2024)
    for n, shift, want in ((6, 20.0, 0.85), (20, 8.0, 0.85)):
        fa = np.mean([flag_outliers(rng.standard_normal(n))[1].any() for _ in range(1500)])
        assert fa < 0.03, (n, fa)
        hits = wrong = 0
        for _ in range(300):
            x = rng.standard_normal(n)
            x[0] += shift
            f = flag_outliers(x)[1]
            hits += f[0]
            wrong += f[1:].any()
        assert hits / 300 > want and wrong / 300 < 0.03, (n, hits, wrong)
    # equal values (a setting) are never outliers
    assert not flag_outliers(np.array([0.2, 0.2, 0.2, 0.2, 0.2 + 1e-17, 0.2]))[1].any()
