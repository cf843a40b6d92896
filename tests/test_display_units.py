"""Display units (``--unit deg/h|deg/s|rad/s|mdps``, ``[display] unit``): the conversion layer
against closed forms and against the noise fit's own exported conversions, end to end on
simulated noise of known density, and the CLI wiring (tables and plots change, JSON does not).
"""

from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest

from gyrotest.core.display import UNITS, parse_display_unit, term_text
from gyrotest.core.errors import InputError

from cliutil import run_cli

D2R = math.pi / 180.0


# ----------------------------------------------------------------------------- closed forms
# Hand derivations (1 h = 3600 s, √h = 60 √s, 1 deg = 3600 arcsec = π/180 rad):
#   1 deg/√h   = 1 deg/(60 √s)        = 1/60 deg/s/√Hz     = 60 deg/h/√Hz
#   1 deg/h/√h = (1/3600 deg/s)/(60 √s) = 1/216000 deg/s/√s
#   1 deg/h/h  = (1/3600 deg/s)/(3600 s) = 1/12 960 000 deg/s²
#   1 arcsec   = 1/3600 deg = π/648000 rad = 1/3.6 mdeg
@pytest.mark.parametrize("name,rate,n,k,r,q", [
    ("deg/h", 1.0, 1.0, 1.0, 1.0, 1.0),
    ("deg/s", 1 / 3600, 1 / 60, 1 / 216000, 1 / 12_960_000, 1 / 3600),
    ("rad/s", D2R / 3600, D2R / 60, D2R / 216000, D2R / 12_960_000, math.pi / 648000),
    ("mdps", 1 / 3.6, 1000 / 60, 1000 / 216000, 1000 / 12_960_000, 1 / 3.6),
])
def test_one_internal_unit_in_each_family(name, rate, n, k, r, q):
    u = UNITS[name]
    assert u.rate_value(1.0) == pytest.approx(rate, rel=1e-12)
    assert u.n_value(1.0) == pytest.approx(n, rel=1e-12)
    assert u.k_value(1.0) == pytest.approx(k, rel=1e-12)
    assert u.r_value(1.0) == pytest.approx(r, rel=1e-12)
    assert u.angle_value(1.0) == pytest.approx(q, rel=1e-12)
    assert u.psd_value(1.0) == pytest.approx(rate**2, rel=1e-12)


def test_datasheet_examples():
    # ADIS16405 datasheet: rate noise density 0.05 °/s/√Hz is an ARW of 3 °/√h
    assert UNITS["deg/s"].n_value(3.0) == pytest.approx(0.05, rel=1e-12)
    # 1 °/√h in rad/s/√Hz (Kalibr's gyroscope_noise_density unit): 2.908882e-4
    assert UNITS["rad/s"].n_value(1.0) == pytest.approx(2.908882e-4, rel=1e-6)
    # in-run bias stability 0.007 °/s = 25.2 °/h
    assert UNITS["deg/s"].rate_value(25.2) == pytest.approx(0.007, rel=1e-12)


def test_labels_and_convert_by_unit_string():
    u = UNITS["deg/s"]
    assert u.convert(60.0, "deg/sqrt(h)") == (pytest.approx(1.0), "deg/s/√Hz")
    assert u.convert(216000.0, "deg/h/sqrt(h)") == (pytest.approx(1.0), "deg/s/√s")
    assert u.convert(3600.0, "deg/h") == (pytest.approx(1.0), "deg/s")
    assert u.convert(3600.0, "arcsec") == (pytest.approx(1.0), "deg")
    assert u.convert(2.0, "s") == (2.0, "s")  # not a rate: unchanged
    assert u.convert(None, "deg/h") == (None, "deg/s")
    ieee = UNITS["deg/h"]
    assert [ieee.label(q) for q in ("N", "K", "R", "Q")] == ["deg/√h", "deg/h/√h", "deg/h/h",
                                                              "arcsec"]


def test_parse_aliases_and_errors():
    assert parse_display_unit(None).name == "deg/h"
    for text, name in (("dps", "deg/s"), ("°/s", "deg/s"), ("DPH", "deg/h"),
                       ("mdeg/s", "mdps"), (" rad/s ", "rad/s")):
        assert parse_display_unit(text).name == name
    with pytest.raises(InputError, match="unknown display unit 'furlong/fortnight'.*deg/h, "
                                         "deg/s, rad/s, mdps"):
        parse_display_unit("furlong/fortnight")


# ----------------------------------------------------------------------------- vs the fit's own
@pytest.fixture(scope="module")
def wn_log(tmp_path_factory):
    """10 Hz, 100 000 samples: white rate noise of density 0.01 °/s/√Hz (σ per sample
    n·√fs) plus a rate random walk K = 1e-4 °/s/√s (step σ K·√τ0), in deg/s."""
    rng = np.random.default_rng(52)
    fs, n = 10.0, 100_000
    white = 0.01 * math.sqrt(fs) * rng.standard_normal(n)
    walk = np.cumsum(1e-4 * math.sqrt(1 / fs) * rng.standard_normal(n))
    path = tmp_path_factory.mktemp("units") / "wn.csv"
    t = np.arange(n) / fs
    np.savetxt(path, np.column_stack([t, white + walk + 0.2]), delimiter=",",
               header="t,gx", comments="", fmt="%.9g")
    return str(path)


ARGS = ["--rate-col", "gx", "--rate-unit", "deg/s", "--terms", "N,K", "--no-diagnose"]


def test_json_unchanged_and_matches_fit_conversions(wn_log):
    a = run_cli(["allan", wn_log, *ARGS, "--json"])
    b = run_cli(["allan", wn_log, *ARGS, "--json", "--unit", "rad/s"])
    assert a.code == 0 and b.code == 0, a.err + b.err
    da, db = json.loads(a.out), json.loads(b.out)
    ax = da["logs"][0]["axes"][0]
    assert ax == db["logs"][0]["axes"][0]  # JSON keeps its explicit units
    terms = {t["key"]: t for t in ax["fit"]["terms"]}
    N, K = terms["N"]["params"]["N"], terms["K"]["params"]["K"]
    conv = ax["conversions"]
    # the display layer agrees with the fit's exported conversions (written independently)
    assert UNITS["deg/s"].n_value(N) == pytest.approx(conv["N"]["deg_s_per_rt_hz"], rel=1e-12)
    assert UNITS["rad/s"].n_value(N) == pytest.approx(conv["kalibr"]["gyroscope_noise_density"],
                                                      rel=1e-12)
    assert UNITS["rad/s"].k_value(K) == pytest.approx(conv["kalibr"]["gyroscope_random_walk"],
                                                      rel=1e-12)
    # and recovers the simulated densities in deg/s units
    assert UNITS["deg/s"].n_value(N) == pytest.approx(0.01, rel=0.03)
    assert UNITS["deg/s"].k_value(K) == pytest.approx(1e-4, rel=0.4)


def _row(out: str, label: str) -> list[str]:
    line = next(ln for ln in out.splitlines() if label in ln)
    return [c.strip() for c in re.split(r"[│|]", line) if c.strip()]


def test_allan_table_in_deg_s(wn_log):
    r = run_cli(["allan", wn_log, *ARGS, "--unit", "deg/s"])
    assert r.code == 0, r.err
    assert "σ in deg/s" in r.out
    n_row = _row(r.out, "N ARW")
    assert n_row[2] == "deg/s/√Hz"
    assert float(n_row[1].split("±")[0]) == pytest.approx(0.01, rel=0.03)
    k_row = _row(r.out, "K RRW")
    assert k_row[2] == "deg/s/√s"
    ieee = run_cli(["allan", wn_log, *ARGS])
    assert _row(ieee.out, "N ARW")[2] == "deg/sqrt(h)"
    assert float(_row(ieee.out, "N ARW")[1].split("±")[0]) == pytest.approx(0.6, rel=0.03)


def test_allan_plot_labels(wn_log, tmp_path):
    from gyrotest.io.ingest import read_log
    from gyrotest.noise.analysis import analyse_allan
    from gyrotest.noise.plots import figure_allan, figure_psd

    g = read_log(wn_log, overrides={"columns": {"rate": ["gx"]}, "gyro": {"rate_unit": "deg/s"}})
    res = analyse_allan(g, terms="N,K", run_diagnosis=False)
    items = [(res.source, a) for a in res.axes]
    fig = figure_allan(items, unit=UNITS["mdps"])
    ax = fig.axes[0]
    assert ax.get_ylabel().endswith("mdps")
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert any("mdps/√Hz" in t for t in labels)
    # the plotted σ are the table's σ × the factor (deg/h → mdps: 1/3.6)
    ys = np.concatenate([ln.get_ydata() for ln in ax.lines if len(ln.get_ydata()) > 10])
    assert ys.max() < res.axes[0].fit.sigma.max() / 3.6 * 1.5
    fig2 = figure_psd(items, unit=UNITS["rad/s"])
    assert "(rad/s)²/Hz" in fig2.axes[0].get_ylabel()
    import matplotlib.pyplot as plt

    plt.close(fig)
    plt.close(fig2)
    n_term = res.axes[0].fit.term("N")
    assert "deg/s/√Hz" in term_text(n_term, UNITS["deg/s"])
    assert term_text(n_term, UNITS["deg/h"]) == n_term.text()


# ----------------------------------------------------------------------------- CLI wiring
def test_bias_and_info_tables_follow_unit_and_profile(wn_log, tmp_path):
    j = json.loads(run_cli(["bias", wn_log, "--rate-col", "gx", "--rate-unit", "deg/s",
                            "--json"]).out)
    d_dph = j["runs"][0]["bias_D_F_dph"]
    assert d_dph == pytest.approx(0.2 * 3600, rel=0.05)
    r = run_cli(["bias", wn_log, "--rate-col", "gx", "--rate-unit", "deg/s", "--unit", "mdps"])
    assert r.code == 0, r.err
    assert "rates in mdps" in r.out
    assert float(_row(r.out, "wn.csv")[4]) == pytest.approx(d_dph / 3.6, rel=1e-5)
    prof = tmp_path / "p.toml"
    prof.write_text('[columns]\nrate = "gx"\n[gyro]\nrate_unit = "deg/s"\n'
                    '[display]\nunit = "rad/s"\n')
    r = run_cli(["info", wn_log, "--profile", prof])
    assert r.code == 0, r.err
    row = _row(r.out, "rate:gx")
    assert row[1] == "rad/s"
    assert float(row[3]) == pytest.approx(0.2 * D2R, rel=0.05)
    r = run_cli(["info", wn_log, "--profile", prof, "--unit", "deg/h"])  # option wins
    assert _row(r.out, "rate:gx")[1] == "deg/h"


def test_bad_units_are_clean_errors(wn_log, tmp_path):
    run_cli(["allan", wn_log, *ARGS, "--unit", "rpm"]).assert_clean_error(
        "unknown display unit 'rpm'", "--unit", "deg/s")
    prof = tmp_path / "bad.toml"
    prof.write_text('[display]\nunit = "deg/fortnight"\n')
    run_cli(["bias", wn_log, "--profile", prof]).assert_clean_error(
        "bad.toml", "[display] unit", "deg/fortnight")
