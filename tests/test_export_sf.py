"""``gyrotest export scale-factor``: the scale-factor model as a look-up table and a C header,
checked against closed forms, the fit's own f(I) at every plateau, the simulation truth of
the sample rate-table runs and the compiled header."""

from __future__ import annotations

import csv
import json
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

from gyrotest.export.common import Document
from gyrotest.export.sflut import load

from cliutil import run_cli

ROOT = Path(__file__).resolve().parents[1]
SD = ROOT / "sample_data"


def _doc(terms, *, eps0=50.0, epsT=0.5, temps=(20.0, 30.0), bias_dph=36.0, fs=400.0):
    return {"command": "scale-factor", "bias_dph": bias_dph,
            "runs": [{"temperature_mean_degC": t} for t in temps],
            "nonlinearity_model": {"full_scale_dps": fs},
            "epsilon_k": {"epsilon_0_ppm": eps0, "epsilon_T_ppm_per_degC": epsT,
                          "full_scale_dps": fs, "f_terms": terms}}


TERMS = [{"term": "quadratic", "coefficient_ppm": 8.0, "sigma_ppm": 0.1},
         {"term": "cubic", "coefficient_ppm": -12.0, "sigma_ppm": 0.1},
         {"term": "asymmetry", "coefficient_ppm": 6.0, "sigma_ppm": 0.2},
         {"term": "periodic", "coefficient_ppm": 0.7, "sigma_ppm": 0.05, "period_dps": 7.5,
          "phase_deg": 30.0}]


def _f_closed(I):
    u = I / 400.0
    return 8 * u - 12 * u ** 2 + 3 * np.sign(u) + 0.7 * np.sin(2 * np.pi * I / 7.5 + np.pi / 6)


def _write(tmp_path, d, name="sf.json"):
    p = tmp_path / name
    p.write_text(json.dumps(d))
    return p


def _read_lut(p):
    rows = [r for r in csv.reader(ln for ln in p.read_text().splitlines()
                                  if not ln.startswith("#"))]
    head, data = rows[0], np.array(rows[1:], dtype=float)
    return {h: data[:, i] for i, h in enumerate(head)}


def test_lut_closed_form(tmp_path):
    src = _write(tmp_path, _doc(TERMS))
    out = tmp_path / "sf.csv"
    r = run_cli(["export", "scale-factor", src, "-o", out, "--rates", "-400:400:2.5", "--json"])
    assert r.code == 0, r.err
    lut = _read_lut(out)
    I = lut["input_rate_dps"]
    assert len(I) == 321
    np.testing.assert_allclose(lut["f_ppm"], _f_closed(I), atol=1e-8)
    np.testing.assert_allclose(lut["epsilon_k_ppm"], 50.0 + _f_closed(I), atol=1e-8)
    np.testing.assert_allclose(lut["output_rate_dps"],
                               I / (1 + 1e-6 * (50.0 + _f_closed(I))), rtol=1e-11, atol=1e-12)
    np.testing.assert_allclose(lut["u2_ppm"], -12 * (I / 400) ** 2, atol=1e-8)
    assert json.loads(r.out)["t_ref_degC"] == 25.0
    text = out.read_text()
    assert "eps_K [ppm] = 50 + 0.5*(T - 25 degC) + f(I)" in text


@pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler")
def test_c_header_compiles_and_inverts_the_model(tmp_path):
    src = _write(tmp_path, _doc(TERMS))
    h = tmp_path / "sf_comp.h"
    r = run_cli(["export", "scale-factor", src, "-o", h, "--prefix", "fog"])
    assert r.code == 0, r.err
    m = load(Document("scale-factor", json.loads(src.read_text()), str(src)))
    cases = [(I, T) for I in (-400.0, -123.4, -0.5, 0.01, 0.37, 7.5, 250.0, 399.0)
             for T in (-10.0, 25.0, 60.0)]
    prog = tmp_path / "t.c"
    prog.write_text('#include <stdio.h>\n#include "sf_comp.h"\nint main(void){double r,t;\n'
                    'while (scanf("%lf %lf", &r, &t) == 2) printf("%.17g %.17g\\n", '
                    'fog_input_dps(r, t), fog_f_ppm(r));\nreturn 0;}\n')
    exe = tmp_path / "t"
    subprocess.run(["cc", "-std=c99", "-Wall", "-Wextra", "-Werror", "-O1", str(prog), "-o",
                    str(exe), "-lm"], check=True, cwd=tmp_path)
    rates = [float(m.output_dps(I, T)) for I, T in cases]
    stdin = "".join(f"{y!r} {T!r}\n" for y, (_, T) in zip(rates, cases))
    res = subprocess.run([str(exe)], input=stdin, capture_output=True, text=True, check=True)
    got = np.array([[float(x) for x in ln.split()] for ln in res.stdout.splitlines()])
    for (I, T), y, (inv, f) in zip(cases, rates, got):
        # the exact root of output(I, T) = y (independent of the header's iteration)
        exact = brentq(lambda x, y=y, T=T: float(m.output_dps(x, T)) - y, I - 1, I + 1,
                       xtol=1e-14, rtol=1e-15)
        assert inv == pytest.approx(exact, abs=1e-9 * max(1.0, abs(I)))
        assert f == pytest.approx(float(m.f_ppm(y)), abs=1e-9)


@pytest.fixture(scope="module")
def sample_sf(tmp_path_factory):
    if not (SD / "ratetable_22a.parquet").exists():
        pytest.skip("sample_data rate-table runs absent")
    r = run_cli(["scale-factor", SD / "ratetable_22a.parquet", SD / "ratetable_22b.parquet",
                 SD / "ratetable_45.parquet", "--profile", SD / "ratetable_22a.profile.toml",
                 "--json", "-q"])
    assert r.code == 0, r.err
    p = tmp_path_factory.mktemp("sf") / "sf.json"
    p.write_text(r.out)
    return p


def test_lut_equals_the_fit_at_every_plateau_and_the_truth(sample_sf, tmp_path):
    d = json.loads(sample_sf.read_text())
    m = load(Document("scale-factor", d, str(sample_sf)))
    # the exporter's f(I) at each plateau input = the f the fit itself reported there
    np.testing.assert_allclose(m.f_ppm(m.points_I_dps), m.points_f_ppm, rtol=1e-9, atol=1e-9)
    # simulation truth of the sample runs (sample_data/*.truth.json): f(I) = 6u − 18u² − 12 sgn
    truth = json.loads((SD / "ratetable_22a.truth.json").read_text())["scale_factor"]["model"]
    fs = truth["full_scale_dph"] / 3600
    c1, c2 = truth["nonlinearity_ppm"]
    out = tmp_path / "lut.csv"
    assert run_cli(["export", "scale-factor", sample_sf, "-o", out]).code == 0
    lut = _read_lut(out)
    u = lut["input_rate_dps"] / fs
    f_true = c1 * u + c2 * u * u + truth["asymmetry_ppm"] / 2 * np.sign(u)
    assert np.max(np.abs(lut["f_ppm"] - f_true)) < 0.5  # ppm; fit σ ≈ 0.05–0.13 ppm


def test_lock_in_table_and_no_header(tmp_path):
    L = 0.8
    src = _write(tmp_path, _doc([{"term": "lockin", "coefficient_ppm": 0.5 * (L / 400) ** 2 * 1e6,
                                  "lock_in_rate_dps": L, "sigma_ppm": 0.01}]))
    out = tmp_path / "li.csv"
    assert run_cli(["export", "scale-factor", src, "-o", out, "--rates", "-3:3:0.125"]).code == 0
    lut = _read_lut(out)
    I = lut["input_rate_dps"]
    inside = np.abs(I) <= L
    assert np.isnan(lut["f_ppm"][inside]).all()
    np.testing.assert_allclose(lut["f_ppm"][~inside],
                               (np.abs(I[~inside]) / np.sqrt(I[~inside] ** 2 - L * L) - 1) * 1e6,
                               rtol=1e-9)
    h = tmp_path / "li.h"
    run_cli(["export", "scale-factor", src, "-o", h]).assert_clean_error("lock-in", ".csv")
    assert not h.exists()


@pytest.mark.parametrize("mutate,frag", [
    (lambda d: d.pop("epsilon_k"), "'epsilon_k' missing"),
    (lambda d: d["epsilon_k"]["f_terms"].append({"term": "sextic", "coefficient_ppm": 1}),
     "unknown term 'sextic'"),
    (lambda d: d["epsilon_k"]["f_terms"][3].pop("period_dps"), "period_dps"),
    (lambda d: d["epsilon_k"].update(full_scale_dps=-1), "full_scale_dps"),
    (lambda d: d["epsilon_k"]["f_terms"][0].update(coefficient_ppm="x"), "not a number"),
])
def test_malformed_inputs(tmp_path, mutate, frag):
    d = _doc([dict(t) for t in TERMS])
    mutate(d)
    src = _write(tmp_path, d)
    for suffix in (".csv", ".h"):
        out = tmp_path / f"o{suffix}"
        run_cli(["export", "scale-factor", src, "-o", out]).assert_clean_error(frag)
        assert not out.exists()


def test_bad_options(tmp_path):
    src = _write(tmp_path, _doc(TERMS))
    run_cli(["export", "scale-factor", src, "-o", tmp_path / "x.txt"]).assert_clean_error(
        ".csv or .h")
    run_cli(["export", "scale-factor", src, "-o", tmp_path / "x.csv",
             "--rates", "5:1:1"]).assert_clean_error("--rates")
    run_cli(["export", "scale-factor", src, "-o", tmp_path / "x.h",
             "--rates", "-1:1:1"]).assert_clean_error("--rates")
    run_cli(["export", "scale-factor", src, "-o", tmp_path / "x.h",
             "--prefix", "1bad"]).assert_clean_error("C identifier")
    other = _write(tmp_path, {"analysis": "allan"}, "allan.json")
    run_cli(["export", "scale-factor", other, "-o", tmp_path / "x.csv"]).assert_clean_error(
        "--json output of 'gyrotest scale-factor'")
