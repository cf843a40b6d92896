"""Scale factor (IEEE 952 §12.9.4): unit tests of the core on small synthetic data.

Plateau statistics and detection, rate snapping, the IEEE line and its propagated
uncertainty, the nonlinearity model selection, asymmetry estimators, lock-in, the periodic
scan, the points table. The acceptance tests against the simulator are in
``test_scalefactor_sim.py``; the command line in ``test_scalefactor_cli.py``.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from gyrotest.core.data import GyroConstants, GyroLog, Timing
from gyrotest.core.earth import Site
from gyrotest.core.errors import AnalysisError, InputError
from gyrotest.core.output import dumps
from gyrotest.scalefactor import (
    Plateau,
    RunPlateaus,
    analyse,
    extract_plateaus,
    read_points_table,
    reduce_logs,
    snap_rates,
    write_points_csv,
)
from gyrotest.scalefactor.characteristics import (
    asymmetry_common_intercept,
    asymmetry_separate_lines,
)
from gyrotest.scalefactor.plateaus import (
    allan_stderr,
    assign_sweeps,
    constant_runs,
    detect_steps,
    mean_stderr,
)
from gyrotest.scalefactor.tablefit import (
    Points,
    adler,
    ieee_line,
    select_model,
)

DPS = 3600.0


# ----------------------------------------------------------------------------- generators
def make_log(rates_dps, dwell_s=30.0, *, fs=50.0, s0=0.5, kind="counts", eps0=100.0,
             asym=0.0, c=(), noise_dph=0.05 * 60, bias=2.0, lat=45.0, seed=1, tau_table=0.15,
             table=True, temp=25.0, lock_dph=0.0, fs_dps=None):
    """A rate-table log with the simulator's model: S0·out = LockIn(I + D)/(1 + 1e-6 ε),
    ε = eps0 + (asym/2) sgn(I) + Σ c_k (I/FS)^k; I = table (first-order lag) + earth rate
    (asym in the SF column's convention: (SF+ − SF−)/SF̄ with SF input per output).
    ``noise_dph``: white rate noise N (deg/h·√s, i.e. N[deg/√h]·60)."""
    rng = np.random.default_rng(seed)
    dw = np.broadcast_to(np.asarray(dwell_s, float), (len(rates_dps),))
    n_each = np.round(dw * fs).astype(int)
    cmd = np.concatenate([np.full(n, r * DPS) for r, n in zip(rates_dps, n_each)])
    n = len(cmd)
    a = math.exp(-1.0 / (fs * tau_table))
    act = np.empty(n)
    v = cmd[0]
    for i in range(n):  # first-order table
        v = a * v + (1 - a) * cmd[i]
        act[i] = v
    site = Site(lat, 0.0, 90.0, "up")
    I = act + site.earth_rate_dph()
    FS = (fs_dps or max(abs(r) for r in rates_dps)) * DPS
    u = I / FS
    eps = eps0 + 0.5 * asym * np.sign(I) + sum(ck * u ** (k + 1) for k, ck in enumerate(c))
    x = I + bias + rng.normal(0, noise_dph * math.sqrt(fs), n)
    if lock_dph:
        x = adler(x, lock_dph)
    rate = x / (1 + 1e-6 * eps)
    if kind == "counts":  # pulses with remainder carry
        cum = np.floor(np.cumsum(rate / s0 / fs) + rng.uniform())
        rate = np.diff(np.r_[np.floor(rng.uniform()), cum]) * s0 * fs
    tm = Timing(n=n, tau0=1 / fs, duration_s=n / fs, source="sample rate")
    g = GyroConstants(output_kind=kind, scale_factor=s0 if kind != "rate" else None)
    return GyroLog(source=f"gen{seed}.csv", rates={"g": rate}, tau0=1 / fs, timing=tm, gyro=g,
                   temperature={"T": np.full(n, temp)}, table_rate=cmd if table else None,
                   site=site)


SYM = [1, 2, 5, 10, 20, 50, 100, 200, 500]
RATES = [0] + [s * r for r in SYM for s in (1, -1)]


def truth_line(rates_dps, s0=0.5, eps0=100.0, asym=0.0, c=(), fs_dps=500.0):
    """Noise-free IEEE line (unweighted) of the generator's output vs table rate."""
    x = np.array(rates_dps, float) * DPS
    u = x / (fs_dps * DPS)
    eps = eps0 + 0.5 * asym * np.sign(x) + sum(ck * u ** (k + 1) for k, ck in enumerate(c))
    y = x / (1 + 1e-6 * eps)
    k, b = np.polyfit(x, y, 1)
    return s0 / k, x, y


# ----------------------------------------------------------------------------- statistics
def test_mean_stderr_white_and_correlated():
    rng = np.random.default_rng(3)
    y = rng.normal(5.0, 2.0, 64000)
    m, se, se_w = mean_stderr(y)
    assert abs(m - 5.0) < 5 * se
    assert se == pytest.approx(2.0 / math.sqrt(len(y)), rel=0.35)
    assert se_w == pytest.approx(2.0 / math.sqrt(len(y)), rel=0.02)
    # AR(1) with phi = 0.95: the variance of the mean is (1+phi)/(1-phi) = 39x the white one
    e = rng.normal(0, 1, 64000)
    ar = np.empty_like(e)
    ar[0] = e[0]
    for i in range(1, len(e)):
        ar[i] = 0.95 * ar[i - 1] + e[i]
    _, se, se_w = mean_stderr(ar)
    assert se / se_w > 3.5


def test_allan_stderr_white_noise_is_sigma_over_sqrt_n():
    rng = np.random.default_rng(4)
    wins = [rng.normal(0, 3.0, n) for n in (2000, 3000, 1500, 2500, 2000)]
    se, info = allan_stderr(wins, 0.02)
    expect = np.array([3.0 / math.sqrt(len(w)) for w in wins])
    np.testing.assert_allclose(se, expect, rtol=0.2)
    assert info["method"] == "allan"


def test_allan_stderr_is_honest_for_quantized_pulses():
    """Pulse quantization (remainder carry): σ/√n is far too large, σ_A(T) is right."""
    rng = np.random.default_rng(5)
    s0, fs, n = 1.0, 100.0, 3000
    errs, ses, naive = [], [], []
    for _rep in range(8):
        wins, truths = [], []
        for _j in range(6):
            r = rng.uniform(500, 5000)  # deg/h
            x = r + rng.normal(0, 2.0, n)  # small white noise
            cum = np.floor(np.cumsum(x / s0 / fs) + rng.uniform())
            q = np.diff(np.r_[0.0, cum]) * s0 * fs
            wins.append(q[1:])
            truths.append(r)  # noise-free rate
        se, _ = allan_stderr(wins, 1 / fs)
        for w, t, s in zip(wins, truths, se):
            errs.append(np.mean(w) - t)
            ses.append(s)
            naive.append(np.std(w) / math.sqrt(len(w)))
    z = np.array(errs) / np.array(ses)
    assert 0.5 < np.sqrt(np.mean(z ** 2)) < 1.5
    assert np.median(naive) > 5 * np.median(ses)


# ----------------------------------------------------------------------------- detection
def test_constant_runs():
    x = np.r_[np.zeros(5), np.full(3, 2.0), np.full(4, -1.0)]
    s, e = constant_runs(x)
    assert s.tolist() == [0, 5, 8] and e.tolist() == [5, 8, 12]


def _steps(levels, dwells, fs=50.0, noise=5.0, seed=0, tau=0.4):
    rng = np.random.default_rng(seed)
    cmd = np.concatenate([np.full(int(d * fs), lv) for lv, d in zip(levels, dwells)])
    a = math.exp(-1 / (fs * tau))
    out = np.empty_like(cmd)
    v = cmd[0]
    for i, c in enumerate(cmd):
        v = a * v + (1 - a) * c
        out[i] = v
    return out + rng.normal(0, noise, len(cmd)), np.cumsum([0] + [int(d * fs) for d in dwells])


@pytest.mark.parametrize("order", ["up", "reversed", "shuffled"])
def test_detect_steps_unequal_dwells_any_order(order):
    levels = [r * DPS for r in RATES]
    dwells = [20, 35, 25, 50, 22, 40, 30, 45, 28, 33, 21, 60, 24, 38, 26, 42, 31, 27, 36]
    if order == "reversed":
        levels = levels[::-1]
    elif order == "shuffled":
        perm = np.random.default_rng(7).permutation(len(levels))
        levels = [levels[i] for i in perm]
    y, bounds = _steps(levels, dwells, noise=20.0)
    segs, info = detect_steps(y, 1 / 50.0, min_dwell_s=2.0)
    assert len(segs) == len(levels)
    for sg, lv, b0, b1 in zip(segs, levels, bounds[:-1], bounds[1:]):
        assert b0 - 5 <= sg.start <= b0 + 5 * 50  # within 5 s of the true change
        assert b1 - 50 <= sg.stop <= b1 + 5
        assert abs(sg.level - lv) < 4.0 + 1e-6 * abs(lv)


def test_detect_steps_small_steps_and_heteroscedastic_noise():
    levels = [0.0, 360.0, 0.0, -360.0, 1.8e6, 0.0]  # 0.1 deg/s steps and a large one
    y, bounds = _steps(levels, [30] * 6, noise=5.0)
    y[bounds[4]:bounds[5]] += np.random.default_rng(1).normal(0, 40.0, bounds[5] - bounds[4])
    segs, _ = detect_steps(y, 1 / 50.0, min_dwell_s=2.0)
    assert len(segs) == 6


def test_snap_rates():
    se = np.full(5, 0.5)
    L = np.array([499.7, -500.4, 0.3502, -0.35, 0.0]) * DPS + 10.0
    tab, how = snap_rates(L, se, earth_rate_dph=10.0)
    assert np.allclose(tab / DPS, [500, -500, 0.35, -0.35, 0.0])
    assert "zero-rate plateau" in how
    with pytest.raises(InputError, match="cannot infer"):
        snap_rates(np.array([123.45, -123.45, 10.0]) * DPS, np.full(3, 0.5))
    tab, _ = snap_rates(np.array([123.45, -123.45]) * DPS, np.full(2, 0.5), rates_dps=[123.4])
    assert np.allclose(tab / DPS, [123.4, -123.4])
    with pytest.raises(InputError, match="matches none"):
        snap_rates(np.array([50.0, -50.0]) * DPS, np.full(2, 0.5), rates_dps=[100])


def test_assign_sweeps_ignores_zero_plateaus():
    r = np.array([0, 1, -1, 0, 10, -10, 0, 1, -1, 10, -10, 0]) * DPS
    assert assign_sweeps(r).tolist() == [0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 1]


def test_extract_plateaus_without_table_column_matches_with():
    lg = make_log(RATES, 20.0, asym=30, c=(0, -20), seed=2)
    a = extract_plateaus(lg, settle_s=4)
    lg.table_rate = None
    b = extract_plateaus(lg, settle_s=4)
    assert b.method == "detected" and len(a.plateaus) == len(b.plateaus) == len(RATES)
    for p, q in zip(a.plateaus, b.plateaus):
        assert p.table_rate_dph == q.table_rate_dph
        assert abs(p.output_dph - q.output_dph) < 5 * p.stderr_dph


def test_plateau_shorter_than_settling_time():
    lg = make_log([1, -1, 5, -5], 8.0)
    with pytest.raises(InputError, match="settling time"):
        extract_plateaus(lg, settle_s=10)


# ----------------------------------------------------------------------------- fits
def test_ieee_line_propagated_covariance_matches_monte_carlo():
    rng = np.random.default_rng(9)
    x = np.array([-500, -100, -10, 0, 10, 100, 500], float) * DPS
    se = np.array([1.0, 0.5, 0.3, 0.3, 0.3, 0.5, 1.0])
    y0 = 1.0001 * x + 0.3 + 2e-12 * x ** 2  # a bit of curvature: not noise
    ks = []
    for _ in range(3000):
        f = ieee_line(x, y0 + rng.normal(0, se), se)
        ks.append(f.coef[1])
    f = ieee_line(x, y0, se)
    assert np.std(ks) == pytest.approx(math.sqrt(f.cov[1, 1]), rel=0.08)
    assert f.coef[1] == pytest.approx(np.polyfit(x, y0, 1)[0], rel=1e-13)


def _points(I, y, se, runs=None):
    runs = np.zeros(len(I), int) if runs is None else runs
    return Points(I=I, y=y, se=se, run=runs, runs=[f"r{i}" for i in range(runs.max() + 1)],
                  table=I.copy())


def test_select_model_recovers_terms_and_rejects_spurious():
    rng = np.random.default_rng(11)
    x = np.array([s * r for r in SYM for s in (1, -1)] * 2, float) * DPS
    fs = 500 * DPS
    u = x / fs
    found = []
    for seed in range(6):
        r = np.random.default_rng(seed)
        eps = 50 + 0.5 * 40 * np.sign(x) + (-25) * u ** 2
        se = np.full(len(x), 0.3)
        y = x / (1 + 1e-6 * eps) + 1.0 + r.normal(0, se)
        m, hist, _ = select_model(_points(x, y, se), fs, 1.0,
                                  candidates=["asymmetry", "u1", "u2", "u3",
                                              "u4", "lockin"])
        found.append(set(m.terms))
        c, cv = m.term_coef("asymmetry")
        assert abs(c[0] - 40) < 4 * math.sqrt(cv[0, 0]) + 0.5
        assert hist[0].added == "straight line" and hist[-1].accepted is False
    assert sum(f == {"asymmetry", "u2"} for f in found) >= 5
    # pure straight line: nothing should be added (mostly)
    spurious = 0
    for _ in range(10):
        se = np.full(len(x), 0.3)
        y = 0.9999 * x + rng.normal(0, se)
        m, _, _ = select_model(_points(x, y, se), fs, 1.0,
                               candidates=["asymmetry", "u1", "u2", "u3",
                                           "u4", "periodic"])
        spurious += bool(m.terms)
    assert spurious <= 2


def test_periodic_term_detected_on_dense_rates():
    x = np.concatenate([np.arange(3, 300, 4.7), -np.arange(3, 300, 4.7)]) * DPS
    fs = 300 * DPS
    eps = 20 + 3.0 * np.sin(2 * np.pi * (x / DPS) / 13.0 + 0.7)
    rng = np.random.default_rng(2)
    se = np.full(len(x), 0.1)
    y = x / (1 + 1e-6 * eps) + rng.normal(0, se)
    m, hist, _ = select_model(_points(x, y, se), fs, 1.0,
                              candidates=["asymmetry", "u1", "u2", "periodic"])
    assert "periodic" in m.terms
    assert m.period_dps == pytest.approx(13.0, rel=0.01)
    c, _ = m.term_coef("periodic")
    assert math.hypot(*c) == pytest.approx(3.0, rel=0.1)


def test_lock_in_exact_adler():
    lg = make_log([0, 0.2, -0.2, 0.5, -0.5, 1, -1, 2, -2, 5, -5, 10, -10, 50, -50, 100, -100],
                  30.0, kind="rate", eps0=10, lock_dph=0.3 * DPS, noise_dph=0.002 * 60,
                  bias=0.0, seed=4)
    lg.gyro = GyroConstants(output_kind="rate")
    res = reduce_logs([lg], settle_s=5)
    assert res.lock_in.detected and 0.2 in res.lock_in.locked_rates_dps
    assert "lockin" in res.model.terms
    assert res.lock_in.fitted_dps == pytest.approx(0.3, rel=0.002)


def test_asymmetry_estimators_sign_and_value():
    """SF+ larger (input per output, the SF column's unit) → positive asymmetry, equal to
    (SF+ − SF−)/SF̄ with SF± = S0/k±; pure kink: all three estimators agree."""
    x = np.array([0] + [s * r for r in SYM for s in (1, -1)], float) * DPS
    A = 60.0
    y = x / (1 + 1e-6 * (0.5 * A * np.sign(x))) + 3.0
    kp = np.polyfit(x[x >= 0], y[x >= 0], 1)[0]
    km = np.polyfit(x[x <= 0], y[x <= 0], 1)[0]
    sfp, sfm = 0.5 / kp, 0.5 / km  # arcsec/pulse with S0 = 0.5
    assert (sfp - sfm) / (0.5 * (sfp + sfm)) * 1e6 == pytest.approx(A, rel=1e-3)
    sep = asymmetry_separate_lines(x, y, None)
    f = ieee_line(x, y, None)
    ci = asymmetry_common_intercept(x, y, None, f.coef[0], np.zeros_like(x))
    assert sep[0] == pytest.approx(A, rel=1e-3)
    assert ci[0] > 0
    P = _points(x, y, np.full(len(x), 0.1))
    m, _, _ = select_model(P, 500 * DPS, 1.0, candidates=[], forced=["asymmetry"])
    assert m.term_coef("asymmetry")[0][0] == pytest.approx(A, rel=1e-3)


# ----------------------------------------------------------------------------- analysis
def test_analyse_recovers_generator_truth():
    c = (0.0, -20.0)
    seq = RATES + RATES[::-1][1:]  # up, then back down (no command repeated back to back)
    logs = [make_log(seq, 20.0, eps0=e, asym=40, c=c, seed=s, temp=t)
            for s, (e, t) in enumerate([(100, 20), (112, 30), (95, 40)])]
    res = reduce_logs(logs, settle_s=4, periodic=False)
    for r, e in zip(res.runs, (100, 112, 95)):
        sf_true, _, _ = truth_line(seq, eps0=e, asym=40, c=c)
        assert abs(r.scale_factor - sf_true) < 3 * r.scale_factor_sigma
        assert (r.scale_factor_model / 0.5 - 1) * 1e6 == pytest.approx(e, abs=1.0)
        assert abs(r.bias_model_dph - 2.0) < 4 * r.bias_model_sigma_dph
    assert set(res.model.terms) == {"asymmetry", "u2"}
    assert res.asymmetry.model_ppm == pytest.approx(40, abs=2.0)
    rel = np.array([100, 112, 95]) - np.mean([100, 112, 95])
    # runs at 20/30/40 °C: their spread is ε_T·ΔT + run-to-run, kept apart from repeatability
    assert res.repeatability.all_runs_sigma_ppm == pytest.approx(np.std(rel, ddof=1), rel=0.1)
    assert math.isnan(res.repeatability.sigma_ppm)
    assert any("repeatability not measured" in n for n in res.notes)
    assert res.runs[0].stability is not None and res.runs[0].stability.n_sweeps == 2
    assert res.temperature.status == "ok"
    d = json.loads(dumps(res))  # strict JSON, no NaN
    assert d["scale_factor_unit"] == "arcsec/pulse" and "scale_factor_arcsec_per_pulse" in d
    assert d["linearity"]["linearity_max_ppm_fs"] > 0
    assert d["epsilon_k"]["f_terms"]


def test_no_negative_rates_skips_asymmetry():
    lg = make_log([0, 1, 5, 10, 50, 100, 500], 20.0)
    res = reduce_logs([lg], settle_s=4)
    assert res.asymmetry.status.startswith("skipped")
    assert math.isnan(res.asymmetry.asymmetry_ppm)
    assert any("no negative" in n for n in res.notes)


def test_single_rate_and_mismatched_runs():
    with pytest.raises(AnalysisError, match="only one input rate"):
        reduce_logs([make_log([10, 10], 20.0)], settle_s=4)
    a = make_log([1, -1, 10, -10], 20.0, seed=1)
    b = make_log([1, -1, 20, -20], 20.0, seed=2)
    with pytest.raises(InputError, match="mismatched runs.*common-rates"):
        reduce_logs([a, b], settle_s=4)
    res = reduce_logs([a, b], settle_s=4, common_rates=True)
    assert all(r.n_used == 2 for r in res.runs)
    c = make_log([1, -1, 10, -10], 20.0, kind="rate")
    c.gyro = GyroConstants(output_kind="rate")
    with pytest.raises(InputError, match="mismatched runs"):
        reduce_logs([a, c], settle_s=4)


def test_points_table_round_trip(tmp_path):
    lg = make_log(RATES, 20.0, asym=30, c=(0, -10), seed=6)
    res = reduce_logs([lg], settle_s=4)
    p = write_points_csv(res, tmp_path / "pts.csv")
    runs, kind, s0, notes = read_points_table(p)
    assert kind == "counts" and s0 == 0.5 and not notes
    res2 = analyse(runs, output_kind=kind, nominal_scale_factor=s0)
    assert res2.scale_factor == pytest.approx(res.scale_factor, rel=1e-12)
    assert res2.asymmetry.asymmetry_ppm == pytest.approx(res.asymmetry.asymmetry_ppm, abs=1e-6)


def test_lab_points_table_in_native_units(tmp_path):
    """A spreadsheet table: rate in deg/s, output in pulse/s, no SEs (unweighted)."""
    rates = np.array([-100, -10, -1, 1, 10, 100], float)
    pps = rates * DPS / 0.5 * (1 + 20e-6) + 3.0
    f = tmp_path / "lab.csv"
    f.write_text("rate_dps,output_pps\n" + "".join(f"{r},{float(o)!r}\n" for r, o in zip(rates, pps)))
    runs, kind, s0, notes = read_points_table(f, scale_factor=0.5)
    res = analyse(runs, output_kind=kind, nominal_scale_factor=s0)
    assert res.scale_factor == pytest.approx(0.5 / (1 + 20e-6), rel=1e-9)
    assert not res.weighted


def test_run_plateaus_dicts_are_json():
    rp = RunPlateaus("r", "x.csv", [Plateau("r", 0, 3600.0, 10.0, 3610.0, 0.1)], "points table")
    assert json.loads(dumps(rp))["n_plateaus"] == 1
