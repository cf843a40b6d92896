"""``gyrotest scale-factor`` through the command line: output, files, and bad input.

Bad input gives exit code 2, one ``gyrotest: error:`` line on stderr, no traceback and no
output file (plot, points table) left behind.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from gyrotest.simulation import simulate, write_log

from cliutil import run_cli

BASE = {
    "record": {"sample_rate_hz": 20.0},
    "gyro": {"output": "counts", "scale_factor": 0.5, "bias_dph": 1.0, "serial": "CLI-1",
             "noise": {"N": 0.02}},
    "site": {"latitude_deg": 48.137, "ia": "up"},
    "effects": {"scale_factor": {"offset_ppm": 80.0, "asymmetry_ppm": 30.0,
                                 "nonlinearity_ppm": [0.0, -20.0]}},
    "rate_table": {"rates_dps": [0, 1, -1, 10, -10, 100, -100, 300, -300],
                   "dwell_s": 20, "settle_tau_s": 0.2, "exclude_s": 5},
}


def make(tmp: Path, stem: str, *, runs: int = 1, seed: int = 1, **rt) -> tuple[list[str], str]:
    sc = json.loads(json.dumps(BASE))
    sc["rate_table"].update(rt)
    if runs > 1:
        sc["runs"] = {"count": runs, "sf_offsets_ppm": [0.0, 12.0, -6.0][:runs]}
    w = write_log(simulate(sc, seed=seed), tmp / f"{stem}.csv")
    return [str(p) for p in w.logs], str(w.profiles[0])


@pytest.fixture(scope="module")
def three(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("sfcli")
    logs, prof = make(tmp, "rt", runs=3)
    return tmp, logs, prof


def no_files(tmp: Path, *names: str) -> None:
    for n in names:
        assert not (tmp / n).exists(), f"{n} was left behind"
        assert not list(tmp.glob(f".{n}.*")), f"a temporary file for {n} was left behind"


def test_json_output(three):
    tmp, logs, prof = three
    r = run_cli(["scale-factor", *logs, "--profile", prof, "--settle", "5s", "--json"])
    assert r.code == 0, r.err
    d = json.loads(r.out)  # exactly one JSON document on stdout
    assert d["command"] == "scale-factor" and d["output_kind"] == "counts"
    assert d["scale_factor_unit"] == "arcsec/pulse"
    for key in ("scale_factor_arcsec_per_pulse", "scale_factor_sigma_arcsec_per_pulse",
                "scale_factor_error_ppm", "bias_dph", "full_scale_dps"):
        assert isinstance(d[key], float), key
    assert d["scale_factor_arcsec_per_pulse"] == pytest.approx(0.5 * (1 + 80e-6), rel=2e-5)
    assert len(d["runs"]) == 3 and d["repeatability"]["repeatability_1sigma_ppm"] > 3
    assert d["linearity"]["linearity_max_ppm_fs"] > 0
    assert d["asymmetry"]["asymmetry_ppm"] == pytest.approx(30, abs=10)
    assert d["nonlinearity_model"]["history"][0]["added"] == "straight line"
    assert len(d["points"]) == 27 and "linearity_ppm_fs" in d["points"][0]
    assert d["epsilon_k"]["epsilon_0_ppm"] == d["scale_factor_error_ppm"]


def test_human_output_points_and_plot(three):
    tmp, logs, prof = three
    pts, png = tmp / "pts.csv", tmp / "sf.png"
    r = run_cli(["scale-factor", *logs, "--profile", prof, "--settle", "5s",
                 "--points", pts, "--plot", png])
    assert r.code == 0, r.err
    for text in ("Scale factor (IEEE 952 §12.9.4)", "linearity error per rate",
                 "add a term, watch the residual fall", "repeatability", "asymmetry"):
        assert text in r.out
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # the plateau table reads back with --table and gives the same scale factor
    r1 = run_cli(["scale-factor", *logs, "--profile", prof, "--settle", "5s", "--json"])
    r2 = run_cli(["scale-factor", "--table", pts, "--json"])
    assert r2.code == 0, r2.err
    a, b = json.loads(r1.out), json.loads(r2.out)
    assert b["scale_factor_arcsec_per_pulse"] == pytest.approx(a["scale_factor_arcsec_per_pulse"],
                                                               rel=1e-10)
    assert b["repeatability"]["repeatability_1sigma_ppm"] == pytest.approx(
        a["repeatability"]["repeatability_1sigma_ppm"], rel=1e-6)


@pytest.mark.parametrize("suffix", [".svg", ".pdf"])
def test_plot_formats(three, suffix):
    tmp, logs, prof = three
    out = tmp / f"sf{suffix}"
    r = run_cli(["scale-factor", logs[0], "--profile", prof, "--settle", "5s", "--plot", out,
                 "--json"])
    assert r.code == 0, r.err
    assert out.stat().st_size > 1000


def test_no_negative_rates(tmp_path):
    """Issue #4: no negative rates is bad input for an asymmetry test (exit 2, say so); with
    --no-asymmetry the rest of the reduction goes ahead and the asymmetry says why it is absent."""
    logs, prof = make(tmp_path, "pos", rates_dps=[0, 1, 10, 100, 300])
    r = run_cli(["scale-factor", *logs, "--profile", prof, "--settle", "5s",
                 "--plot", tmp_path / "np.png"])
    r.assert_clean_error("no negative input rates", "--no-asymmetry")
    no_files(tmp_path, "np.png")
    r = run_cli(["scale-factor", *logs, "--profile", prof, "--settle", "5s", "--json",
                 "--no-asymmetry"])
    assert r.code == 0, r.err
    d = json.loads(r.out)
    assert d["asymmetry"]["status"].startswith("skipped: no negative input rates")
    assert d["asymmetry"]["asymmetry_ppm"] is None
    assert "asymmetry" in r.err and "Traceback" not in r.err


def test_bad_single_rate(tmp_path):
    logs, prof = make(tmp_path, "one", rates_dps=[10])
    r = run_cli(["scale-factor", *logs, "--profile", prof, "--settle", "5s",
                 "--plot", tmp_path / "p.png", "--points", tmp_path / "p.csv"])
    r.assert_clean_error("only one input rate", "+10 deg/s")
    no_files(tmp_path, "p.png", "p.csv")


def test_bad_mismatched_rate_sets(tmp_path):
    a, prof = make(tmp_path, "a", seed=1)
    b, _ = make(tmp_path, "b", seed=2, rates_dps=[0, 1, -1, 10, -10, 50, -50])
    args = ["scale-factor", a[0], b[0], "--profile", prof, "--settle", "5s"]
    r = run_cli(args + ["--plot", tmp_path / "m.png"])
    r.assert_clean_error("mismatched runs", "--common-rates")
    no_files(tmp_path, "m.png")
    r = run_cli(args + ["--common-rates", "--json"])
    assert r.code == 0, r.err
    assert all(run["n_points_used"] == 5 for run in json.loads(r.out)["runs"])


def test_bad_mismatched_output_kinds(tmp_path):
    a, _ = make(tmp_path, "cnt")
    p = Path(a[0])
    rate = tmp_path / "rate.csv"
    lines = p.read_text().splitlines()
    head = lines[0].split(",")
    i = head.index("pulses")
    head[i] = "omega_dph"
    body = []
    for ln in lines[1:]:
        f = ln.split(",")
        f[i] = repr(float(f[i]) * 0.5 * 20.0)
        body.append(",".join(f))
    rate.write_text(",".join(head) + "\n" + "\n".join(body) + "\n")
    r = run_cli(["scale-factor", a[0], str(rate), "--scale-factor", "0.5", "--table-col",
                 "table_dps", "--latitude", "48.137", "--settle", "5s"])
    r.assert_clean_error("mismatched runs", "counts", "rate")


def test_bad_plateau_shorter_than_settling(tmp_path):
    logs, prof = make(tmp_path, "short")
    r = run_cli(["scale-factor", *logs, "--profile", prof, "--settle", "30s",
                 "--points", tmp_path / "s.csv"])
    r.assert_clean_error("settling time", "--settle")
    no_files(tmp_path, "s.csv")


def test_bad_rates_without_commanded_column(tmp_path):
    logs, prof = make(tmp_path, "amb", rates_dps=[0, 123.4, -123.4, 10, -10], column="")
    r = run_cli(["scale-factor", *logs, "--profile", prof, "--settle", "5s"])
    r.assert_clean_error("cannot infer the input rate", "--rates")
    r = run_cli(["scale-factor", *logs, "--profile", prof, "--settle", "5s",
                 "--rates", "123.4,10", "--json"])
    assert r.code == 0, r.err
    rates = sorted({p["table_rate_dps"] for p in json.loads(r.out)["points"]})
    assert rates == pytest.approx([-123.4, -10, 0, 10, 123.4])
    r = run_cli(["scale-factor", *logs, "--profile", prof, "--detect", "table"])
    r.assert_clean_error("no table-rate column")


@pytest.mark.parametrize("args,fragment", [
    (["--plot", "x.gif"], "unknown format"),
    (["--settle", "ten seconds"], "settle"),
    (["--terms", "cubic,sextic"], "unknown nonlinearity term"),
    (["--alpha", "2"], "--alpha"),
    (["--rates", "1,x"], "--rates"),
])
def test_bad_options(three, args, fragment):
    tmp, logs, prof = three
    r = run_cli(["scale-factor", logs[0], "--profile", prof, *args])
    r.assert_clean_error(fragment)


def test_bad_no_input_and_both_inputs(three):
    tmp, logs, prof = three
    run_cli(["scale-factor"]).assert_clean_error("no input")
    r = run_cli(["scale-factor", logs[0], "--table", str(tmp / "pts.csv")])
    r.assert_clean_error("not both")
    run_cli(["scale-factor", "--table", str(tmp / "missing.csv")]).assert_clean_error("not found")


def test_forced_terms(three):
    tmp, logs, prof = three
    r = run_cli(["scale-factor", *logs, "--profile", prof, "--settle", "5s", "--terms",
                 "asymmetry,u2", "--json"])
    assert r.code == 0, r.err
    d = json.loads(r.out)
    assert d["nonlinearity_model"]["terms"] == ["asymmetry", "u2"]
    c = {x["term"]: x for x in d["nonlinearity_model"]["coefficients"]}
    assert c["u2"]["coefficient_ppm"] == pytest.approx(-20, abs=3)
    # the earlier name (by the output power) is read as the one name
    old = run_cli(["scale-factor", *logs, "--profile", prof, "--settle", "5s", "--terms",
                   "asymmetry,cubic", "--json"])
    assert old.code == 0 and json.loads(old.out)["nonlinearity_model"] == d["nonlinearity_model"]
