"""Start-up imports and the fast paths of issue #13, each against the slow reference.

* which modules a command imports (a module-set check in a fresh interpreter, not a timing);
* the numpy Welch PSD against ``scipy.signal.welch``;
* the χ² quantiles from ``scipy.special`` against ``scipy.stats``;
* the plain-number CSV reader (``gyrotest.io.fastcsv``) against pyarrow's reader and the general
  ingest path, including ranges, comments, missing cells and the fall-back cases.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
HEAVY = ("scipy.stats", "scipy.signal", "matplotlib", "pandas", "reportlab")


def _modules_after(code: str, *args: str) -> set[str]:
    """Names in sys.modules after running ``code`` in a fresh interpreter (argv = args)."""
    full = (
        "import sys, json, atexit\n"
        "atexit.register(lambda: sys.__stderr__.write('MODULES=' + json.dumps(sorted("
        "sys.modules)) + '\\n'))\n"
        "sys.argv = ['gyrotest', *json.loads(sys.argv[1])]\n"
        f"{code}\n"
    )
    # the normal exit (atexit runs): the console script otherwise skips the teardown
    env = dict(os.environ, GYROTEST_FAST_EXIT="0",
               PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    p = subprocess.run([sys.executable, "-c", full, json.dumps(list(args))], capture_output=True,
                       text=True, env=env, cwd=ROOT, timeout=300)
    line = [ln for ln in p.stderr.splitlines() if ln.startswith("MODULES=")]
    assert line, p.stderr
    return set(json.loads(line[-1][len("MODULES="):]))


def test_import_cli_is_light():
    mods = _modules_after("import gyrotest.cli")
    for m in (*HEAVY, "numpy", "scipy", "pyarrow", "rich"):
        assert m not in mods, f"`import gyrotest.cli` imports {m}"


def test_help_imports_no_command_module():
    mods = _modules_after("from gyrotest.cli import main\nmain()", "--help")
    assert not [m for m in mods if m.startswith("gyrotest.cli.cmd_")]
    for m in (*HEAVY, "numpy", "scipy", "pyarrow"):
        assert m not in mods, f"`gyrotest --help` imports {m}"


def test_allan_help_and_info_import_no_heavy_module(tmp_path):
    mods = _modules_after("from gyrotest.cli import main\nmain()", "allan", "--help")
    for m in (*HEAVY, "scipy", "gyrotest.noise.analysis"):  # options from noise.kinds
        assert m not in mods, f"`gyrotest allan --help` imports {m}"
    f = tmp_path / "small.csv"
    t = np.arange(1, 501) * 0.1
    np.savetxt(f, np.c_[t, np.sin(t)], delimiter=",", header="t_s,omega_dph", comments="")
    mods = _modules_after("from gyrotest.cli import main\nmain()", "info", str(f), "--json")
    for m in (*HEAVY, "scipy"):
        assert m not in mods, f"`gyrotest info` imports {m}"


def test_allan_on_plain_csv_imports_no_stats_signal_pandas(tmp_path):
    f = tmp_path / "log.csv"
    rng = np.random.default_rng(3)
    t = np.arange(1, 4001) * 0.01
    np.savetxt(f, np.c_[t, rng.standard_normal(t.size)], delimiter=",",
               header="t_s,omega_dph", comments="")
    mods = _modules_after("from gyrotest.cli import main\nmain()", "allan", str(f), "--rate-unit",
                          "deg/h", "--json")
    for m in HEAVY:
        assert m not in mods, f"`gyrotest allan` imports {m}"
    # the fit's NNLS, profile bounds and shape optimisation are numpy (noise.numerics): no
    # scipy.optimize, even when the diagnosis tries markov/sine/blue candidates
    assert "scipy.optimize" not in mods
    mods = _modules_after("from gyrotest.cli import main\nmain()", "allan", str(f), "--rate-unit",
                          "deg/h", "--json", "--terms", "N,markov,sine")
    assert "scipy.optimize" not in mods
    # the impact of a bias-instability (flicker) term is in closed form (Ci): no
    # scipy.integrate (≈ 0.15–0.25 s to import with the scipy.optimize it pulls in)
    mods = _modules_after("from gyrotest.noise.impact import Component, axial_variance\n"
                          "axial_variance(Component('B', 1.0), 3600.0, tau0=0.01, "
                          "record_s=1e5)")
    assert "scipy.integrate" not in mods and "scipy.optimize" not in mods


def test_numerics_match_scipy_optimize():
    """The fit's NNLS and bracketed root (gyrotest.noise.numerics) against scipy.optimize."""
    from scipy.optimize import brentq
    from scipy.optimize import nnls as sp_nnls

    from gyrotest.noise.numerics import nnls, root_bracketed

    rng = np.random.default_rng(11)
    for i in range(400):
        m = int(rng.integers(3, 80))
        n = int(rng.integers(1, min(m, 9) + 1))
        A = rng.standard_normal((m, n))
        if i % 2:  # positive, badly scaled columns as in the noise fit
            A = np.abs(A) * rng.lognormal(0.0, 2.0, n)
        b = rng.standard_normal(m) * 3
        x_ref, r_ref = sp_nnls(A, b)
        x, r = nnls(A, b, maxiter=50 * n)
        assert np.max(np.abs(x - x_ref)) <= 1e-9 * max(1.0, np.max(np.abs(x_ref)))
        assert r == pytest.approx(r_ref, rel=1e-9, abs=1e-12)
    for f, a, b in [(lambda x: x**3 - 2, 0, 3), (lambda x: np.exp(x) - 10, -5, 10),
                    (lambda x: np.tanh(50 * (x - 0.3)), -1, 2), (lambda x: np.log(x) + x, 0.01, 5),
                    (lambda x: (x - 1) ** 5 * 1e3 + (x - 1), -3, 4)]:
        assert root_bracketed(f, a, b, xtol=1e-6) == pytest.approx(brentq(f, a, b, xtol=1e-14),
                                                                   abs=1e-6)
    with pytest.raises(ValueError):
        root_bracketed(lambda x: x * x + 1, -1, 1)


def test_shape_minimisers_match_scipy_optimize():
    """Brent's bounded minimiser and Nelder–Mead (gyrotest.noise.numerics) follow the same
    iterates as scipy.optimize's: the same minimum and value to the last bit, on smooth,
    multimodal, flat and kinked functions in 1–3 variables."""
    from scipy.optimize import minimize, minimize_scalar

    from gyrotest.noise.numerics import minimize_bounded, nelder_mead

    rng = np.random.default_rng(5)
    for i in range(150):
        c = rng.normal(0, 2, 4)
        w = rng.uniform(0.5, 8)
        funcs = [lambda x, c=c, w=w: (x - c[0]) ** 2 + c[1] * np.sin(w * x),
                 lambda x, c=c: abs(x - c[0]) + 0.1 * c[2] * x,
                 lambda x, c=c: np.floor(3 * x) * 0.1 + (x - c[1]) ** 4,
                 lambda x: 1.0]
        f = funcs[i % 4]
        a, b = sorted(rng.uniform(-5, 5, 2))
        tol = float(10.0 ** rng.uniform(-6, -2))
        ref = minimize_scalar(f, bounds=(a, b), method="bounded", options={"xatol": tol})
        x, fx = minimize_bounded(f, a, b, xatol=tol)
        assert (x, fx) == (float(ref.x), float(ref.fun)), i
    for i in range(60):
        n = 1 + i % 3
        A = rng.normal(size=(n, n))
        ctr = rng.normal(0, 2, n)
        w = rng.uniform(0.5, 4)

        def g(v, A=A, ctr=ctr, w=w, kink=(i % 5 == 0)):
            d = A @ (v - ctr)
            return float(d @ d + 0.3 * np.sum(np.cos(w * v)) + (abs(v[0]) if kink else 0.0))

        x0 = rng.normal(0, 2, n)
        if i % 7 == 0:
            x0[0] = 0.0  # the zero-coordinate vertex of the initial simplex
        xatol, fatol, maxiter = (1e-4, 1e-6, 400) if i % 2 else (1e-3, 1e-4, 200)
        ref = minimize(g, x0, method="Nelder-Mead",
                       options={"xatol": xatol, "fatol": fatol, "maxiter": maxiter})
        x, fx = nelder_mead(g, x0, xatol=xatol, fatol=fatol, maxiter=maxiter)
        assert np.array_equal(x, ref.x) and fx == ref.fun, i


@pytest.mark.parametrize("n,nperseg", [(1000, 64), (12345, 1024), (777, 17), (70_000, 4096)])
def test_welch_matches_scipy(n, nperseg):
    from scipy import signal

    from gyrotest.noise.spectral import _welch_density

    rng = np.random.default_rng(n)
    x = np.cumsum(rng.standard_normal(n)) * 0.01 + rng.standard_normal(n) + 3.0
    f, p = signal.welch(x, fs=50.0, window="hann", nperseg=nperseg, noverlap=nperseg // 2,
                        detrend="constant", scaling="density")
    f2, p2 = _welch_density(x, 50.0, nperseg)
    np.testing.assert_allclose(f2, f, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(p2, p, rtol=1e-10)


def test_find_lines_chi2_only_above_the_snr_floor():
    """find_lines evaluates the χ² tail only where the PSD exceeds min_snr × background; the
    candidates and every reported line equal those of the tail evaluated on all bins."""
    from scipy import special

    from gyrotest.noise import spectral

    rng = np.random.default_rng(21)
    t = np.arange(1 << 18) * 0.01
    for amp in (0.0, 0.05, 0.2, 1.0):
        x = rng.standard_normal(t.size) + amp * np.sin(2 * np.pi * 7.3 * t) \
            + 0.5 * amp * np.sin(2 * np.pi * 21.0 * t)
        psd = spectral.welch_psd(x, 0.01)
        got = spectral.find_lines(psd)
        bg = spectral._background(psd.f, psd.psd)
        ratio = psd.psd / bg
        nu = max(psd.dof, 2.0)
        pv = special.chdtrc(nu, nu * ratio)
        cand = (ratio > 4.0) & (pv < 1e-6 / psd.f.size)
        cand[0] = False
        for ln in got:  # the peak bin's tail probability, as evaluated on all bins
            k = int(np.flatnonzero(ratio == ln.snr)[0])
            assert ln.p_value == pv[k]
        runs = int(np.count_nonzero(np.diff(cand.astype(int)) == 1) + cand[0])
        assert len(got) == min(runs, 3), amp
        if amp >= 0.2:
            assert got and abs(got[0].f_hz - 7.3) < 0.05


def test_find_lines_merges_runs_at_the_ends_of_the_spectrum():
    """Candidate runs are grouped without a loop over bins: a run that starts at bin 1 (bin 0
    is never a line) and one that ends at the last bin are each one line, with the centroid
    and amplitude of the brute-force grouping."""
    from gyrotest.noise import spectral

    f = np.arange(1, 4097) * 0.01
    p = np.ones(f.size)
    p[[0, 1, 2]] = 1e4  # bins 0–2: bin 0 excluded, 1–2 one run
    p[[2000, 2001, 2002]] = [5e3, 9e3, 5e3]
    p[[-2, -1]] = 2e4  # the last two bins
    psd = spectral.PsdEstimate(f=f, psd=p, dof=200.0, nperseg=8192, tau0=0.01, n_used=10**6)
    got = spectral.find_lines(psd, max_lines=5)
    bg = spectral._background(f, p)
    want = []
    for i, j in ((1, 2), (2000, 2002), (f.size - 2, f.size - 1)):
        a, b = max(i - 1, 0), min(j + 2, f.size)
        ex = np.maximum(p[a:b] - bg[a:b], 0.0)
        want.append((float(np.sum(f[a:b] * ex) / ex.sum()),
                     math.sqrt(4.0 * ex.sum() * (f[1] - f[0]))))
    assert sorted((ln.f_hz, ln.amplitude_dph) for ln in got) == sorted(want)


@pytest.mark.parametrize("segments", [None, [(0, 150_000), (150_100, 400_000)]])
def test_akdev_from_the_oadev_sums_equals_the_direct_estimator(segments):
    """The trend check's AKDEV from the OADEV table (``reuse``: the mean second difference
    telescoped, no pass over θ) equals the centred direct estimator, with a strong ramp (the
    subtraction σ²_OA − d̄²/2 cancels most of σ²_OA there) and over gaps."""
    from gyrotest.noise.deviations import compute_deviation

    rng = np.random.default_rng(13)
    n = 400_000
    x = rng.standard_normal(n) + np.cumsum(rng.standard_normal(n)) * 2e-3
    x += np.arange(n) * 4e-5  # a rate ramp: AKDEV well below OADEV at long τ
    kw = dict(input_kind="rate", segments=segments, noise_id=False)
    oa = compute_deviation(x, 0.01, kind="oadev", taus="decade10", segments=segments,
                           input_kind="rate")
    taus = oa.tau[-5:-1].tolist()
    direct = compute_deviation(x, 0.01, kind="akdev", taus=taus, **kw)
    reused = compute_deviation(x, 0.01, kind="akdev", taus=taus, reuse=oa, **kw)
    assert np.all(direct.sigma < 0.5 * oa.sigma[np.isin(oa.tau, taus)])
    np.testing.assert_allclose(reused.sigma, direct.sigma, rtol=1e-9)
    for k in ("tau", "n", "edf", "alpha"):
        np.testing.assert_array_equal(getattr(reused, k), getattr(direct, k))
    # a τ not in the OADEV table is computed directly
    other = compute_deviation(x, 0.01, kind="akdev", taus=[333.0, taus[0]], reuse=oa, **kw)
    ref = compute_deviation(x, 0.01, kind="akdev", taus=[333.0, taus[0]], **kw)
    np.testing.assert_allclose(other.sigma, ref.sigma, rtol=1e-9)


def test_trend_check_computes_the_hadamard_deviation_only_as_trend_evidence():
    """``allan``'s trend check: OHDEV at the long τ is computed when the Allan–Krobka
    dispersion falls below the Allan deviation's interval (the KROBKA-M7 evidence, shown in
    the warning's rows), and not on a record without a trend."""
    from gyrotest.core.data import GyroConstants, GyroLog, Timing
    from gyrotest.noise.analysis import analyse_allan

    rng = np.random.default_rng(3)
    n = 200_000
    t = np.arange(n) * 0.1
    for ramp, want in ((0.0, False), (0.2 / 3600.0, True)):  # deg/h per s
        x = rng.standard_normal(n) * 0.3 + ramp * t
        log = GyroLog(source="mem", rates={"x": x}, tau0=0.1,
                      timing=Timing(n=n, tau0=0.1, duration_s=n * 0.1, source="test"),
                      gyro=GyroConstants(output_kind="rate"))
        ax = analyse_allan(log).axes[0]
        assert (ax.ohdev is not None) is want, ramp
        m7 = [w for w in ax.warnings if w.code == "KROBKA-M7"]
        assert bool(m7) is want
        if want:
            assert all("hadamard" in r for r in m7[0].evidence["rows"])
            assert ax.akdev is not None and ax.to_dict()["trend_check"]["ohdev"]["sigma"]


def test_chi2_from_special_matches_stats():
    from scipy import stats

    from gyrotest.noise.edf import chi2_interval

    edf = np.array([0.7, 1.0, 2.5, 10.0, 333.0, 1e5])
    sigma = np.full(edf.size, 2.0)
    for conf in (0.683, 0.95):
        p = 0.5 * (1 - conf)
        lo, hi = chi2_interval(sigma, edf, conf)
        np.testing.assert_allclose(lo, sigma * np.sqrt(edf / stats.chi2.ppf(1 - p, edf)),
                                   rtol=1e-12)
        np.testing.assert_allclose(hi, sigma * np.sqrt(edf / stats.chi2.ppf(p, edf)), rtol=1e-12)
    lo, hi = chi2_interval(np.array([1.0]), np.array([np.nan]), 0.683)
    assert np.isnan(lo[0]) and np.isnan(hi[0])


def _write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def test_fastcsv_matches_pyarrow_across_ranges(tmp_path, monkeypatch):
    import pyarrow.csv as pcsv

    from gyrotest.io import fastcsv

    rng = np.random.default_rng(7)
    n = 50_000
    a, b, c = np.arange(n) * 0.01, rng.standard_normal(n) * 1e3, rng.standard_normal(n) * 1e-7
    lines = ["# comment before the header", "t,x,y"]
    lines += [f"{float(u)!r},{float(v)!r},{float(w)!r}" for u, v, w in zip(a, b, c)]
    lines.insert(5000, "# a comment in the middle")
    lines.insert(20_000, "")
    f = _write(tmp_path / "log.csv", "\n".join(lines))  # no final newline
    monkeypatch.setattr(fastcsv, "RANGE_BYTES", 100_003)  # many ranges, cuts mid-line
    got = fastcsv.read_numeric(f, ",", 1, ["t", "x", "y"], ["y", "t"])
    assert got is not None and set(got) == {"y", "t"}
    ref = pcsv.read_csv(f, read_options=pcsv.ReadOptions(skip_rows=1),
                        parse_options=pcsv.ParseOptions(
                            invalid_row_handler=lambda r: "skip"))
    np.testing.assert_array_equal(got["t"], ref.column("t").to_numpy())
    np.testing.assert_array_equal(got["y"], ref.column("y").to_numpy())
    np.testing.assert_array_equal(got["t"], a)  # repr round-trips exactly
    assert got["t"].flags.writeable
    monkeypatch.setattr(fastcsv, "RANGE_BYTES", 16 << 20)
    one = fastcsv.read_numeric(f, ",", 1, ["t", "x", "y"], None)
    np.testing.assert_array_equal(one["x"], b)


def test_fastcsv_missing_cells_are_nan_and_text_falls_back(tmp_path):
    from gyrotest.io import fastcsv

    f = _write(tmp_path / "na.csv", "t;x\n0;1.5\n1;NA\n2;\n3;nan\n4;-2e3\n")
    got = fastcsv.read_numeric(f, ";", 0, ["t", "x"], None)
    assert got is not None
    np.testing.assert_array_equal(got["x"][[0, 4]], [1.5, -2e3])
    assert np.isnan(got["x"][1:4]).all()
    f2 = _write(tmp_path / "ts.csv", "time,x\n2024-01-01T00:00:00,1\n2024-01-01T00:00:01,2\n")
    assert fastcsv.read_numeric(f2, ",", 0, ["time", "x"], None) is None
    f3 = _write(tmp_path / "bad.csv", "t,x\n0,1\n1,oops\n")
    assert fastcsv.read_numeric(f3, ",", 0, ["t", "x"], None) is None


def test_ingest_results_unchanged_by_fast_path(tmp_path, monkeypatch):
    """read_log through the fast path equals read_log through the general reader."""
    from gyrotest.io import fastcsv
    from gyrotest.io.ingest import read_log

    rng = np.random.default_rng(11)
    n = 3000
    t = np.arange(n) * 0.1
    x = rng.standard_normal(n)
    x_txt = [repr(float(v)) for v in x]
    x_txt[100] = "NA"
    f = _write(tmp_path / "g.csv", "t_s,omega_dph,temp_c\n" + "\n".join(
        f"{float(a)!r},{b},{float(c)!r}" for a, b, c in zip(t, x_txt, 20 + x / 10)) + "\n")
    fast = read_log(f, overrides={"gyro": {"rate_unit": "deg/h"}}, nan_policy="gap")
    monkeypatch.setattr(fastcsv, "read_numeric", lambda *a, **k: None)
    slow = read_log(f, overrides={"gyro": {"rate_unit": "deg/h"}}, nan_policy="gap")
    assert fast.axes == slow.axes and fast.n == slow.n and fast.tau0 == slow.tau0
    for k in fast.rates:
        np.testing.assert_array_equal(fast.rates[k], slow.rates[k])
    np.testing.assert_array_equal(fast.t, slow.t)
    assert [g.index for g in fast.timing.gaps] == [g.index for g in slow.timing.gaps]


def test_bad_value_in_big_csv_still_names_the_row(tmp_path):
    from cliutil import run_cli

    n = 20_000
    rows = [f"{i * 0.01!r},{math.sin(i):.6f}" for i in range(n)]
    rows[12_345] = "123.45,abc"
    f = _write(tmp_path / "bad.csv", "t_s,omega_dph\n" + "\n".join(rows) + "\n")
    run_cli(["info", str(f)]).assert_clean_error("bad.csv", "abc", "12346")


def test_allan_jobs_identical_to_serial(tmp_path):
    """`allan A B C --jobs 3` (process pool) prints exactly what --jobs 1 prints."""
    from cliutil import run_cli

    paths = []
    for seed in (1, 2, 3):
        rng = np.random.default_rng(seed)
        t = np.arange(1, 20_001) * 0.01
        x = rng.standard_normal(t.size) * 6.0 + np.cumsum(rng.standard_normal(t.size)) * 0.01
        f = tmp_path / f"log{seed}.csv"
        np.savetxt(f, np.c_[t, x], delimiter=",", header="t_s,omega_dph", comments="",
                   fmt="%.10g")
        paths.append(str(f))
    args = ["allan", *paths, "--rate-unit", "deg/h", "--taus", "octave"]
    serial = run_cli([*args, "--json", "--jobs", "1"])
    pooled = run_cli([*args, "--json", "--jobs", "3"])
    assert serial.code == 0 and pooled.code == 0, serial.err + pooled.err
    assert json.loads(serial.out)["logs"] and serial.out == pooled.out
    text1, text3 = run_cli([*args, "--jobs", "1"]), run_cli([*args, "--jobs", "3"])
    assert text1.out == text3.out and text1.err == text3.err
    bad = tmp_path / "bad.csv"
    bad.write_text("t_s,omega_dph\n0.01,1\n0.02,x\n")
    run_cli([*args[:2], str(bad), *args[2:], "--jobs", "2"]).assert_clean_error("bad.csv")


def test_deviation_progress_hook_sees_every_tau_in_order(monkeypatch):
    from gyrotest import _runtime
    from gyrotest.noise import deviations

    calls = []
    monkeypatch.setattr(_runtime, "PROGRESS", lambda d, t, k: calls.append((d, t, k)))
    x = np.random.default_rng(5).standard_normal(300_000)  # above PARALLEL_MIN_SAMPLES
    r = deviations.compute_deviation(x, 0.01, input_kind="rate", taus="octave", noise_id=False)
    n = len(r.tau)
    assert [c[0] for c in calls[:n]] == list(range(1, n + 1))
    assert all(c[1] == n and c[2] == "oadev" for c in calls[:n])


def test_mtotdev_progress_within_each_tau(monkeypatch):
    """MTOTDEV reports progress inside a τ too (fractional ``done``), still in order."""
    from gyrotest import _runtime
    from gyrotest.noise import deviations, mtot

    calls = []
    monkeypatch.setattr(_runtime, "PROGRESS", lambda d, t, k: calls.append((d, t, k)))
    monkeypatch.setattr(mtot, "STEP_INTERVAL_S", 0.0)
    monkeypatch.setattr(mtot, "BATCH_ELEMS", 512)  # many chunks and batches
    x = np.random.default_rng(6).standard_normal(20_000)
    r = deviations.compute_deviation(x, 0.01, input_kind="rate", kind="mtotdev", taus="octave",
                                     noise_id=False)
    n = calls[-1][1]  # τ values in the loop (one more than the table's last τ here)
    assert n >= len(r.tau)
    done = [c[0] for c in calls]
    assert all(b > a for a, b in zip(done, done[1:]))  # strictly increasing
    assert [d for d in done if d == int(d)] == list(range(1, n + 1))
    assert sum(d != int(d) for d in done) > n  # fractions in between
    assert all(c[1] == n and c[2] == "mtotdev" for c in calls) and done[-1] == n
    assert mtot.STEP is None  # reset after the loop


def test_no_progress_text_when_piped(tmp_path):
    from cliutil import run_cli

    f = tmp_path / "log.csv"
    t = np.arange(1, 3001) * 0.01
    np.savetxt(f, np.c_[t, np.sin(t * 7)], delimiter=",", header="t_s,omega_dph", comments="")
    r = run_cli(["allan", str(f), "--rate-unit", "deg/h", "--dev", "mtotdev", "--taus", "octave"])
    assert r.code == 0, r.err
    assert "τ ━" not in r.err and "\r" not in r.err


def test_allan_prefetched_read_identical_to_serial(tmp_path, monkeypatch):
    """`allan` reads a single text log on a thread while it imports the analysis: stdout,
    stderr (ingest notes first) and exit codes are identical to the serial read, including
    the order of errors (a bad option before a bad file) — and the prefetch really ran."""
    from gyrotest.cli import cmd_allan, pool

    from cliutil import run_cli

    rng = np.random.default_rng(5)
    t = np.arange(6000) * 0.01
    good = tmp_path / "notes.csv"
    np.savetxt(good, np.c_[t, rng.standard_normal(t.size), rng.standard_normal(t.size)],
               delimiter=",", header="time,gx,gy", comments="")
    bad = tmp_path / "bad.csv"
    bad.write_text("t_s,omega_dph\n0.01,1\n0.02,abc\n0.03,2\n")
    cases = [[str(good), "--rate-unit", "deg/s", "-v"], [str(good), "--rate-unit", "deg/s", "--json"],
             [str(bad), "--rate-unit", "deg/h"], [str(bad), "--rate-unit", "deg/h", "--taus", "zz"],
             [str(tmp_path / "missing.csv")]]
    started = []

    def counting(paths, opts):
        fut = pool.prefetch_log(paths, opts)
        started.append(fut is not None)
        return fut

    monkeypatch.setattr(cmd_allan, "prefetch_log", counting)
    early = [run_cli(["allan", *c]) for c in cases]
    assert started == [True, True, True, True, False]
    monkeypatch.setattr(cmd_allan, "prefetch_log", lambda paths, opts: None)
    serial = [run_cli(["allan", *c]) for c in cases]
    for c, a, b in zip(cases, early, serial):
        assert (a.code, a.out, a.err) == (b.code, b.out, b.err), c
    assert "auto-detected" in early[0].err.splitlines()[0]
    early[3].assert_clean_error("--taus")
    early[2].assert_clean_error("row 2")


def test_cli_turns_off_numpy_huge_page_advice_unless_the_user_sets_it():
    """`gyrotest` asks numpy not to madvise huge pages (first touch of a fresh large array
    cost 7x under THP compaction); a user's NUMPY_MADVISE_HUGEPAGE wins."""
    import os
    import subprocess
    import sys

    code = ("import gyrotest.cli, numpy; from numpy._core import multiarray as m; "
            "print(m._get_madvise_hugepage())")
    env = {k: v for k, v in os.environ.items() if k != "NUMPY_MADVISE_HUGEPAGE"}
    off = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert off.stdout.strip() == "False", off.stderr
    if not sys.platform.startswith("linux"):
        return
    env["NUMPY_MADVISE_HUGEPAGE"] = "1"
    on = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert on.stdout.strip() == "True", on.stderr


def test_console_script_fast_exit_keeps_output_and_exit_codes(tmp_path):
    """``python -m gyrotest`` ends without the interpreter's teardown
    (``gyrotest.cli._fast_exit``): the JSON on a pipe and a plot file are complete, a bad
    input still exits 2 with its one-line error, and the output equals the normal exit's."""
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""),
               MPLBACKEND="Agg")
    S = ROOT / "sample_data"
    png = tmp_path / "a.png"
    args = [sys.executable, "-m", "gyrotest", "allan", str(S / "static.parquet"), "--profile",
            str(S / "static.profile.toml"), "--taus", "octave", "--json"]
    fast = subprocess.run(args + ["--plot", str(png)], capture_output=True, text=True,
                          env=env, cwd=ROOT, timeout=300)
    assert fast.returncode == 0, fast.stderr
    doc = json.loads(fast.stdout)
    assert doc["logs"] and png.stat().st_size > 10_000
    assert png.read_bytes().endswith(b"IEND\xaeB`\x82")  # the PNG is whole
    slow = subprocess.run(args, capture_output=True, text=True, cwd=ROOT, timeout=300,
                          env=dict(env, GYROTEST_FAST_EXIT="0"))
    assert slow.returncode == 0, slow.stderr
    a, b = (json.loads(slow.stdout)["logs"][0]["axes"][0]["table"],
            doc["logs"][0]["axes"][0]["table"])
    assert a and json.dumps(a, sort_keys=True) == json.dumps(b, sort_keys=True)
    bad = subprocess.run([sys.executable, "-m", "gyrotest", "allan",
                          str(tmp_path / "missing.csv")], capture_output=True, text=True,
                         env=env, cwd=ROOT, timeout=300)
    assert bad.returncode == 2
    assert bad.stderr.count("\n") == 1 and "missing.csv" in bad.stderr
