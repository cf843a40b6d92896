"""Scale-factor reduction of rate-table runs: the numbers of IEEE 952 §12.9.4 and ε_K (§8.3).

:func:`analyse` takes the plateau points of one or more runs (:class:`RunPlateaus`, from
:func:`~gyrotest.scalefactor.plateaus.extract_plateaus` or a points table) and returns a
:class:`ScaleFactorResult`: per-run scale factor and bias, linearity error, the nonlinearity
model f(I) chosen by the data with its history, asymmetry, the rate-periodic check,
repeatability, in-run stability, temperature sensitivity and the lock-in dead band. Pure:
arrays in, dataclasses out; nothing is printed or written.
"""

from __future__ import annotations

import copy
import math

import numpy as np

from ..core.errors import AnalysisError, InputError
from .characteristics import (
    AsymmetryResult,
    asymmetry_common_intercept,
    asymmetry_separate_lines,
    detect_lock_in,
    linearity_stats,
    per_rate_asymmetry,
)
from .lowrate import detect_saturation, resolution, threshold
from .plateaus import STDERR_METHODS, Plateau, RunPlateaus
from .repeatability import Repeatability, repeatability_by_condition
from .sfresult import (
    LockIn,
    NonlinearityModel,
    PeriodicCheck,
    RunResult,
    ScaleFactorResult,
    StabilityResult,
    TemperatureSensitivity,
    TermCoefficient,
)
from .tablefit import (
    DPS,
    TERMS,
    ModelFit,
    ModelStep,
    Points,
    applicable_terms,
    canonical_terms,
    fit_model,
    ieee_line,
    select_model,
    term_order,
)

PULSE_KINDS = ("counts", "updown", "counter")


def sf_unit(output_kind: str) -> tuple[str, str]:
    """(unit, key suffix) of the scale factor for an output kind: arcsec/pulse for pulse
    outputs, (deg/h)/V for analog, dimensionless (deg/h per deg/h) for rate output."""
    if output_kind in PULSE_KINDS:
        return "arcsec/pulse", "arcsec_per_pulse"
    if output_kind == "voltage":
        return "(deg/h)/V", "dph_per_v"
    return "1", "dimensionless"


def scale_factor_from_slope(k: float, sk: float, s0: float) -> tuple[float, float]:
    """SF = S0/k and σ_SF = S0·σ_k/k², with k the fitted output-per-input slope of the log's
    rate (which was computed with the nominal S0): the scale factor in the log's own units,
    input per unit output (IEEE 952 §8.3 model equation, §12.9.4.1)."""
    return s0 / k, abs(s0 * sk / (k * k))


# ----------------------------------------------------------------------------- helpers
def points_from_runs(runs: list[RunPlateaus]) -> tuple[Points, list[Plateau]]:
    """Flatten the runs' plateaus into :class:`Points` arrays (input I = table + Ω_IA and
    output in deg/h, SE in deg/h, run index, sweep, window mid-time s, temperature degC) and
    the matching list of plateaus."""
    pl = [p for rp in runs for p in rp.plateaus]
    names = [rp.run for rp in runs]
    ridx = {n: i for i, n in enumerate(names)}
    P = Points(
        I=np.array([p.input_rate_dph for p in pl], float),
        y=np.array([p.output_dph for p in pl], float),
        se=np.array([p.stderr_dph for p in pl], float),
        run=np.array([ridx[p.run] for p in pl], int),
        runs=names,
        table=np.array([p.table_rate_dph for p in pl], float),
        sweep=np.array([p.sweep for p in pl], int),
        t=np.array([0.5 * (p.t_start_s + p.t_end_s) for p in pl], float),
        temp=np.array([p.temperature_degC for p in pl], float),
    )
    return P, pl


def _rate_set(P: Points, r: int) -> set[float]:
    return set(np.round(P.table[P.run == r] / DPS, 6).tolist())


#: how :func:`analyse` notes a reduction without negative input rates
ASYMMETRY_SKIPPED = "asymmetry not computed"

def _fmt_rates(rs) -> str:
    rs = sorted(rs)
    s = ", ".join(f"{r:+g}" for r in rs[:8])
    return s + (" ..." if len(rs) > 8 else "")


def _check_runs(P: Points, runs: list[RunPlateaus], common_rates: bool) -> tuple[np.ndarray, list[str]]:
    """Validate the rate sets; returns the mask of points to use and notes."""
    notes = []
    keep = np.ones(P.n, dtype=bool)
    sets = [_rate_set(P, r) for r in range(len(runs))]
    if len(runs) > 1 and any(s != sets[0] for s in sets[1:]):
        common = set.intersection(*sets)
        if not common_rates:
            j = next(i for i, s in enumerate(sets) if s != sets[0])
            only0 = sets[0] - sets[j]
            onlyj = sets[j] - sets[0]
            diff = []
            if only0:
                diff.append(f"{runs[j].run} lacks {_fmt_rates(only0)} deg/s")
            if onlyj:
                diff.append(f"{runs[j].run} has extra {_fmt_rates(onlyj)} deg/s")
            raise InputError(
                f"mismatched runs: {runs[0].run} and {runs[j].run} were tested at different rates "
                f"({'; '.join(diff)}); pass --common-rates to use only the rates all runs share, "
                "or reduce them separately")
        keep = np.isin(np.round(P.table / DPS, 6), sorted(common))
        notes.append(f"--common-rates: {len(common)} rate(s) shared by all runs kept, "
                     f"{int((~keep).sum())} point(s) dropped")
    for r, rp in enumerate(runs):
        s = np.unique(np.round(P.table[(P.run == r) & keep] / DPS, 6))
        if len(s) < 2:
            only = f" ({s[0]:+g} deg/s)" if len(s) == 1 else ""
            raise AnalysisError(
                f"{rp.source}: only one input rate{only} in run {rp.run}; a scale factor needs "
                "plateaus at two or more rates")
    return keep, notes


def _stability(P: Points, r: int, name: str, model: ModelFit, k_run: float,
               weighted: bool) -> StabilityResult | None:
    sel = P.run == r
    sweeps = np.unique(P.sweep[sel])
    if len(sweeps) < 2 or P.t is None:
        return None
    lin = P.y - model.nonlinear_output(P.I)
    vals, sig, tm = [], [], []
    for s in sweeps:
        m = sel & (P.sweep == s) & (P.table != 0)
        if len(np.unique(np.round(P.I[m], 6))) < 2:
            continue
        m = sel & (P.sweep == s)
        f = ieee_line(P.I[m], lin[m], P.se[m] if P.weighted else None, weighted=weighted)
        k, sk = f.coef[1], math.sqrt(f.cov[1, 1])
        # ppm change of SF = S0/k relative to the run's SF
        vals.append((k_run / k - 1.0) * 1e6)
        sig.append(sk / k * 1e6)
        tm.append(float(np.mean(P.t[m])) / 3600.0)
    if len(vals) < 2:
        return None
    v, s, t = np.array(vals), np.array(sig), np.array(tm)
    if len(v) >= 3:
        w = 1 / np.where(np.isfinite(s) & (s > 0), s, np.nanmedian(s) or 1.0) ** 2
        X = np.column_stack([np.ones_like(t), t - t.mean()])
        cov = np.linalg.inv(X.T @ (X * w[:, None]))
        beta = cov @ (X.T @ (w * v))
        res = v - X @ beta
        chi = float(np.sum(w * res ** 2)) / (len(v) - 2)
        drift, dsig = float(beta[1]), float(math.sqrt(cov[1, 1] * max(1.0, chi)))
    else:
        drift = float((v[1] - v[0]) / (t[1] - t[0])) if t[1] != t[0] else math.nan
        dsig = float(math.hypot(s[0], s[1]) / abs(t[1] - t[0])) if t[1] != t[0] else math.nan
    return StabilityResult(name, len(v), v.tolist(), s.tolist(), t.tolist(),
                           float(np.std(v, ddof=1)), float(np.ptp(v)), float(v[-1] - v[0]),
                           drift, dsig)


# ----------------------------------------------------------------------------- main
def _line_hat(I: np.ndarray, se: np.ndarray, weighted: bool) -> np.ndarray:
    """A (2×n) with (b, k) = A·y for the §12.9.4.1 line (for error propagation)."""
    X = np.column_stack([np.ones_like(I), I - I.mean()])
    w = 1 / se ** 2 if weighted else np.ones_like(I)
    A = np.linalg.inv(X.T @ (X * w[:, None])) @ (X.T * w)
    A[0] -= I.mean() * A[1]
    return A


def analyse(runs: list[RunPlateaus], *, output_kind: str = "rate",
            nominal_scale_factor: float | None = None, full_scale_dps: float | None = None,
            terms: str | list[str] = "auto", alpha: float = 0.05, weighted: bool = True,
            weighted_line: bool = False, lock_in: bool = True, periodic: bool = True,
            common_rates: bool = False, temp_min_range_degC: float = 1.0,
            repeat_temp_tol_degC: float = 2.0) -> ScaleFactorResult:
    """Reduce rate-table plateau points to the IEEE 952 scale-factor figures.

    Inputs: per point the input I = table rate + Ω_IA (deg/h), the mean output y = S0 ×
    native output (deg/h) and its standard error.

    * Scale factor (§12.9.4.1): per run the least-squares line y = b + k·I (unweighted unless
      ``weighted_line``; σ from the plateau SEs propagated through the fit, see
      :func:`~gyrotest.scalefactor.tablefit.ieee_line`); SF = S0/k in the log's units
      (arcsec/pulse, (deg/h)/V, 1 for rate output), σ_SF = S0·σ_k/k²; bias D_F = b/k (deg/h,
      input-referred, earth rate removed). Combined: mean over runs,
      σ = max(√Σσ_r²/R, std_r/√R). ``scale_factor_error_ppm`` = (SF/S0 − 1)·1e6 = ε_0.
    * Linearity error (§12.9.4.2.1): residual of each point from its run's line, ppm of
      full-scale output r/(k·FS) and of output r/(k·I); max |·| and 1σ (RMS). FS = largest
      |table rate| unless ``full_scale_dps``. After-model values: residuals of the model.
    * Nonlinearity f(I) of ε_K (§8.3): weighted fit (``weighted``) of per-run b_r, k_r plus
      shared terms chosen by the data (``terms="auto"``; "linear"; or a list), see
      :func:`~gyrotest.scalefactor.tablefit.select_model`. ``scale_factor_model`` = S0/k_r.
    * Asymmetry (§12.9.4.2.2), periodic check (§5.3.2.1 a), repeatability (§12.9.4.2.3: 1σ
      with ddof=1 and max spread of the run SFs, ppm, within groups of runs whose mean
      temperatures agree within ``repeat_temp_tol_degC``; :mod:`.repeatability`), stability
      (§12.9.4.2.4: per sweep), temperature sensitivity (§12.9.4.3.1: ppm/°C of the model SF
      across runs), lock-in dead band (points whose output collapsed are excluded).

    ``nominal_scale_factor`` is S0 (arcsec/pulse or (deg/h)/V; ignored for rate output).
    Raises :class:`~gyrotest.core.errors.InputError` for a single rate or mismatched runs.
    """
    if not runs:
        raise InputError("no runs to reduce")
    runs = copy.deepcopy(list(runs))  # pure: duplicate names and lock-in flags change a copy
    unit, key = sf_unit(output_kind)
    s0 = 1.0 if output_kind == "rate" or nominal_scale_factor is None else float(nominal_scale_factor)
    names = [rp.run for rp in runs]
    if len(set(names)) != len(names):
        seen: set[str] = set()
        for rp in runs:
            base, i = rp.run, 2
            while rp.run in seen:
                rp.run = f"{base}#{i}"
                i += 1
            seen.add(rp.run)
            for p in rp.plateaus:
                p.run = rp.run
    notes: list[str] = []
    for rp in runs:
        notes += [f"{rp.run}: {n}" for n in rp.notes]
    P_all, plist = points_from_runs(runs)
    # a zero standard error (noise-free or saturated data) would get infinite weight
    se = P_all.se
    okse = np.isfinite(se) & (se > 0)
    if okse.any() and not okse.all() and np.all(np.isfinite(se)):
        floor = float(np.min(se[okse]))
        P_all.se = np.where(okse, se, floor)
    elif np.all(np.isfinite(se)) and not okse.any():
        P_all.se = np.full_like(se, math.nan)
    keep, n2 = _check_runs(P_all, runs, common_rates)
    notes += n2
    # ---- saturation (input range, IEEE 952 §5.3.1): excluded from the fits like lock-in
    sat_sub, in_range = detect_saturation(P_all.subset(keep))
    saturated = np.zeros(P_all.n, bool)
    saturated[np.flatnonzero(keep)[sat_sub]] = True
    if saturated.any():
        notes.append(f"saturation: the output stops following the table at "
                     f"{', '.join(f'{r:+g}' for r in in_range.saturated_rates_dps)} deg/s "
                     f"({int(saturated.sum())} point(s)); excluded from the fits")
        keep &= ~saturated
        _check_runs(P_all.subset(keep), runs, True)
    # ---- lock-in (dead band)
    li = LockIn(checked=lock_in)
    if lock_in:
        locked, _ = detect_lock_in(P_all.subset(keep))
        locked_all = np.zeros(P_all.n, bool)
        locked_all[np.flatnonzero(keep)[locked]] = True
        if locked_all.any():
            li.detected = True
            rates = sorted(set(np.round(np.abs(P_all.table[locked_all]) / DPS, 6).tolist()))
            li.locked_rates_dps = rates
            li.dead_band_below_dps = max(rates)
            free = np.abs(P_all.table[keep & ~locked_all & (P_all.table != 0)]) / DPS
            above = free[free > max(rates)]
            li.dead_band_above_dps = float(np.min(above)) if len(above) else math.nan
            for i in np.flatnonzero(locked_all):
                plist[i].locked = True
            notes.append(f"lock-in: output collapsed at |rate| ≤ {max(rates):g} deg/s "
                         f"({int(locked_all.sum())} point(s)); excluded from the fits")
            keep &= ~locked_all
            _check_runs(P_all.subset(keep), runs, True)
    locked_all = np.array([p.locked for p in plist], dtype=bool)
    P = P_all.subset(keep)
    weighted = weighted and P.weighted
    weighted_line = weighted_line and P.weighted
    if not P.weighted:
        notes.append("no standard errors for the points: unweighted fits, uncertainties from the "
                     "residual scatter")
    fs = (full_scale_dps * DPS) if full_scale_dps else float(np.max(np.abs(P.table)))
    if not fs > 0:
        raise AnalysisError("all input rates are zero")
    R = len(runs)
    se_or_none = P.se if P.weighted else None
    # ---- per-run IEEE straight lines
    lines = []
    lin_fs = np.full(P.n, math.nan)
    lin_out = np.full(P.n, math.nan)
    for r in range(R):
        m = P.run == r
        f = ieee_line(P.I[m], P.y[m], None if se_or_none is None else se_or_none[m],
                      weighted=weighted_line)
        lines.append(f)
        b, k = f.coef
        lin_fs[m] = f.resid / (k * fs) * 1e6
        with np.errstate(divide="ignore", invalid="ignore"):
            lo = f.resid / (k * P.I[m]) * 1e6
        lo[P.table[m] == 0] = math.nan
        lin_out[m] = lo
    kref = float(np.median([f.coef[1] for f in lines]))
    # ---- nonlinearity model
    cand_all = [t for t in TERMS if periodic or t != "periodic"]
    if terms == "auto":
        cands, tn = applicable_terms(P, cand_all)
        notes += tn
        model, hist, mn = select_model(P, fs, kref, candidates=cands, alpha=alpha,
                                       weighted=weighted)
    else:
        forced = [] if terms in ("linear", "none", []) else canonical_terms(terms)
        bad = [t for t in forced if t not in TERMS]
        if bad:
            raise InputError(f"unknown nonlinearity term {bad[0]!r}; use {', '.join(TERMS)}")
        if "asymmetry" in forced and not (np.any(P.I < 0) and np.any(P.I > 0)):
            raise AnalysisError("the asymmetry term needs negative and positive input rates")
        model, hist, mn = select_model(P, fs, kref, candidates=[], forced=forced,
                                       alpha=alpha, weighted=weighted)
    notes += mn
    mres = model.wls.resid
    k_run_model = np.array([model.slope(r)[0] for r in range(R)])
    after_fs = mres / (k_run_model[P.run] * fs) * 1e6
    with np.errstate(divide="ignore", invalid="ignore"):
        after_out = mres / (k_run_model[P.run] * P.I) * 1e6
    after_out[P.table == 0] = math.nan
    birge_m = math.sqrt(max(1.0, model.wls.chi2_per_dof)) if weighted and model.wls.dof > 0 else 1.0
    if weighted and model.wls.dof > 0 and model.wls.chi2_per_dof > 3:
        notes.append(f"the selected model leaves χ²/dof = {model.wls.chi2_per_dof:.3g}: the "
                     "plateau standard errors understate the scatter (correlated noise or an "
                     "unmodelled effect); model uncertainties scaled by √(χ²/dof)")
    # ---- per-run results
    run_results = []
    for r, rp in enumerate(runs):
        m = P.run == r
        f = lines[r]
        b, k = f.coef
        sk, sb = math.sqrt(f.cov[1, 1]), math.sqrt(f.cov[0, 0])
        sf, ssf = scale_factor_from_slope(k, sk, s0)
        km, skm = model.slope(r)
        bm, sbm = model.bias(r)
        sfm, ssfm = scale_factor_from_slope(km, skm * birge_m, s0)
        temps = P.temp[m]
        tmean = float(np.nanmean(temps)) if np.any(np.isfinite(temps)) else math.nan
        stab = _stability(P, r, rp.run, model, k, weighted_line)
        # IEEE 952 §12.11.4.1.1 at zero table rate: D = y/k − Ω_IA (model-free)
        z0 = m & (P.table == 0)
        bz, sbz = math.nan, math.nan
        if z0.any():
            d = P.y[z0] / km - P.I[z0]
            if P.weighted:
                w = (km / P.se[z0]) ** 2
                bz, sbz = float(np.sum(w * d) / np.sum(w)), float(1 / math.sqrt(np.sum(w)))
            else:
                bz = float(np.mean(d))
                sbz = float(np.std(d, ddof=1) / math.sqrt(len(d))) if len(d) > 1 else math.nan
        run_results.append(RunResult(
            run=rp.run, source=rp.source, method=rp.method, n_plateaus=len(rp.plateaus),
            n_used=int(m.sum()), n_sweeps=len(np.unique(P.sweep[m])),
            earth_rate_dph=rp.earth_rate_dph, temperature_mean_degC=tmean,
            slope=float(k), slope_sigma=sk, scale_factor=sf, scale_factor_sigma=ssf,
            scale_factor_error_ppm=(sf / s0 - 1.0) * 1e6, bias_dph=float(b / k),
            bias_sigma_dph=sb / abs(k), chi2_per_dof=f.chi2_per_dof,
            scale_factor_model=sfm, scale_factor_model_sigma=ssfm,
            bias_model_dph=bm / km, bias_model_sigma_dph=sbm * birge_m / abs(km),
            linearity=linearity_stats(P.I[m], lin_fs[m], lin_out[m]), stability=stab,
            sf_key=key, bias_zero_rate_dph=bz, bias_zero_rate_sigma_dph=sbz))
    sfs = np.array([rr.scale_factor for rr in run_results])
    ssf = np.array([rr.scale_factor_sigma for rr in run_results])
    sfm = np.array([rr.scale_factor_model for rr in run_results])
    ssfm = np.array([rr.scale_factor_model_sigma for rr in run_results])

    def combine(v, s):
        mean = float(np.mean(v))
        stat = float(math.sqrt(np.sum(s ** 2)) / len(v)) if np.all(np.isfinite(s)) else math.nan
        spread = float(np.std(v, ddof=1) / math.sqrt(len(v))) if len(v) > 1 else 0.0
        return mean, (max(stat, spread) if math.isfinite(stat) else spread)

    sf_mean, sf_sig = combine(sfs, ssf)
    sfm_mean, sfm_sig = combine(sfm, ssfm)
    bias_mean, bias_sig = combine(np.array([rr.bias_model_dph for rr in run_results]),
                                  np.array([rr.bias_model_sigma_dph for rr in run_results]))
    bz = np.array([rr.bias_zero_rate_dph for rr in run_results])
    if np.all(np.isfinite(bz)):
        bz_mean, bz_sig = combine(bz, np.array([rr.bias_zero_rate_sigma_dph
                                                for rr in run_results]))
    else:
        bz_mean, bz_sig = math.nan, math.nan
    rep = None
    if R >= 2:
        rel = (sfs / np.mean(sfs) - 1) * 1e6
        relm = (sfm / np.mean(sfm) - 1) * 1e6
        groups, within, within_unc, within_spread, rnotes = repeatability_by_condition(
            [rr.run for rr in run_results], sfs, ssf,
            [rr.temperature_mean_degC for rr in run_results],
            [rp.power_on for rp in runs], tol_degC=repeat_temp_tol_degC)
        rep = Repeatability(R, within, within_spread, rel.tolist(), float(np.std(relm, ddof=1)),
                            within_unc, float(np.std(rel, ddof=1)), float(np.ptp(rel)),
                            groups, rnotes)
        notes += [f"repeatability: {n}" for n in rnotes]
    # ---- temperature sensitivity (ε_T, model SF across runs)
    tr = np.array([rr.temperature_mean_degC for rr in run_results])
    ok = np.isfinite(tr)
    if R < 2:
        ts = TemperatureSensitivity("needs runs at two or more temperatures (one run)")
    elif ok.sum() < 2:
        ts = TemperatureSensitivity("no temperature channel in the runs")
    elif np.ptp(tr[ok]) < temp_min_range_degC:
        ts = TemperatureSensitivity(
            f"runs span {np.ptp(tr[ok]):.2g} °C (< {temp_min_range_degC:g} °C): not estimated")
    else:
        t_ok, v = tr[ok], (sfm[ok] / np.mean(sfm[ok]) - 1) * 1e6
        sv = ssfm[ok] / np.mean(sfm[ok]) * 1e6
        X = np.column_stack([np.ones_like(t_ok), t_ok - t_ok.mean()])
        w = 1 / np.maximum(sv, 1e-6) ** 2
        cov = np.linalg.inv(X.T @ (X * w[:, None]))
        beta = cov @ (X.T @ (w * v))
        dof = len(v) - 2
        chi = float(np.sum(w * (v - X @ beta) ** 2)) / dof if dof > 0 else 1.0
        ts = TemperatureSensitivity(
            "ok", float(t_ok.min()), float(t_ok.max()), float(beta[1]),
            float(math.sqrt(cov[1, 1] * max(1.0, chi))), float(np.ptp(v) / np.ptp(t_ok)))
        if R > len(np.unique(np.round(t_ok, 1))):
            notes.append("temperature sensitivity: several runs share a temperature; the "
                         "slope goes through the temperature groups and its σ includes the "
                         "run-to-run scatter (repeatability)")
    # ---- asymmetry
    have_neg = bool(np.any(P.table < 0) and np.any(P.table > 0))
    if not have_neg:
        asym = AsymmetryResult("skipped: no negative input rates (asymmetry needs SF+ and SF−)")
        notes.append(f"{ASYMMETRY_SKIPPED}: the runs have no negative input rates")
    else:
        per_run, per_sig, ci, ci_sig, methods = [], [], [], [], set()
        for r in range(R):
            m = P.run == r
            Ir, yr, tb = P.I[m], P.y[m], P.table[m]
            if not (np.any(tb > 0) and np.any(tb < 0)):
                continue
            ser = None if se_or_none is None else se_or_none[m]
            A = _line_hat(Ir, P.se[m] if weighted_line else np.ones(m.sum()), weighted_line)
            c_r = asymmetry_common_intercept(Ir, yr, ser, lines[r].coef[0], A[0])
            sl = asymmetry_separate_lines(Ir, yr, ser, tb)
            ci.append(c_r[0])
            ci_sig.append(c_r[1])
            if sl is None:
                sl = c_r
                methods.add("common intercept (a side has fewer than two distinct inputs)")
            else:
                methods.add("separate lines (each side with the zero-rate plateaus)")
            per_run.append(sl[0])
            per_sig.append(sl[1])

        def mean_sig(v, s):
            v, s = np.array(v), np.array(s)
            if np.all(np.isfinite(s)):
                return float(np.mean(v)), float(math.sqrt(np.sum(s ** 2)) / len(s))
            return float(np.mean(v)), (float(np.std(v, ddof=1) / math.sqrt(len(v)))
                                       if len(v) > 1 else math.nan)

        a_mean, a_sig = mean_sig(per_run, per_sig)
        c_mean, c_sig = mean_sig(ci, ci_sig)
        try:
            am = model if "asymmetry" in model.terms else fit_model(
                P, model.terms + ["asymmetry"], fs, kref, period_dps=model.period_dps,
                lockin_dph=model.lockin_dph, weighted=weighted)
            ca, cva = am.term_coef("asymmetry")
            ba = math.sqrt(max(1.0, am.wls.chi2_per_dof)) if weighted and am.wls.dof > 0 else 1.0
        except AnalysisError:  # too few points for one more term
            ca, cva, ba = np.array([math.nan]), np.array([[math.nan]]), 1.0
        biases = np.array([model.bias(r)[0] for r in range(R)])
        asym = AsymmetryResult(
            "ok", asymmetry_ppm=a_mean, asymmetry_sigma_ppm=a_sig, per_run_ppm=per_run,
            method="; ".join(sorted(methods)), common_intercept_ppm=c_mean,
            common_intercept_sigma_ppm=c_sig, model_ppm=float(ca[0]),
            model_sigma_ppm=float(math.sqrt(cva[0, 0]) * ba),
            supported="asymmetry" in model.terms, per_rate=per_rate_asymmetry(P, biases))
    # ---- periodic
    if not periodic:
        per = PeriodicCheck("not checked (--no-periodic)")
    elif "periodic" in model.terms:
        c, cv = model.term_coef("periodic")
        amp = float(math.hypot(*c))
        g = np.array([c[0], c[1]]) / amp if amp > 0 else np.array([1.0, 0.0])
        samp = float(math.sqrt(g @ cv @ g)) * birge_m
        step = next(h for h in hist if h.added == "periodic")
        per = PeriodicCheck("ok", True, model.period_dps, amp, samp,
                            float(math.degrees(math.atan2(c[1], c[0]))), step.p_value)
    else:
        tr_ = [h for h in hist if h.added == "periodic"]
        if tr_:
            h = tr_[-1]
            per = PeriodicCheck(f"tried, not supported by the data (best {h.note.split(';')[0]})",
                                False, p_value=h.p_value)
        else:
            per = PeriodicCheck("not tried (too few distinct rates)")
    # ---- model coefficients and statement
    coefs = []
    for t in model.terms:
        c, cv = model.term_coef(t)
        if t == "periodic":
            coefs.append(TermCoefficient(t, TERMS[t].formula, TERMS[t].output_form,
                                         per.amplitude_ppm, per.amplitude_sigma_ppm, True,
                                         {"period_dps": model.period_dps,
                                          "phase_deg": per.phase_deg}))
        else:
            extra = {}
            sc = birge_m
            if t == "lockin":
                extra = {"lock_in_rate_dps": model.lockin_dph / DPS,
                         "lock_in_rate_sigma_dps": model.lockin_sigma_dph / DPS}
                sc = 1.0  # already scaled in the scan
            coefs.append(TermCoefficient(t, TERMS[t].formula, TERMS[t].output_form, float(c[0]),
                                         float(math.sqrt(cv[0, 0]) * sc), True, extra))
    for h in hist:
        if not h.accepted and h.added in TERMS and h.added not in ("periodic", "lockin"):
            try:
                f2 = fit_model(P, model.terms + [h.added], fs, kref, period_dps=model.period_dps,
                               lockin_dph=model.lockin_dph, weighted=weighted)
                c, cv = f2.term_coef(h.added)
                coefs.append(TermCoefficient(h.added, TERMS[h.added].formula,
                                             TERMS[h.added].output_form, float(c[0]),
                                             float(math.sqrt(cv[0, 0])), False))
            except AnalysisError:
                pass
    # ---- threshold and resolution (IEEE Std 528 definitions; IEEE 952 §5.3.2)
    thr = threshold(P_all, saturated | ~keep & ~locked_all, fs, locked=locked_all)
    res_ = resolution(P_all, saturated | locked_all,
                      above_dps=thr.value_dps if math.isfinite(thr.value_dps) else 0.0)
    if model.lockin_dph:
        li.fitted_dps = model.lockin_dph / DPS
        li.fitted_sigma_dps = model.lockin_sigma_dph / DPS
    statement = _statement(model, hist, asym, per)
    coefs.sort(key=lambda c: term_order(c.name))  # f(I) read in powers of u: u1 before u2
    nl = NonlinearityModel(sorted(model.terms, key=term_order), coefs, hist, fs,
                           model.period_dps,
                           model.wls.chi2_per_dof, model.rms_ppm_fs, statement, alpha, model)

    # ---- point table (all points, NaN where excluded)
    def full(v):
        out = np.full(P_all.n, math.nan)
        out[keep] = v
        return out

    k_line = np.array([f.coef[1] for f in lines])
    lin_all = full(lin_fs)
    for i in np.flatnonzero(~keep):  # locked points: their deviation, outside the statistics
        if plist[i].locked:
            r = P_all.run[i]
            b, k = lines[r].coef
            lin_all[i] = (P_all.y[i] - b - k * P_all.I[i]) / (k * fs) * 1e6
    point_table = {
        "linearity_ppm_fs": lin_all,
        "linearity_ppm_output": full(lin_out),
        "stderr_ppm_fs": full(P.se / (k_line[P.run] * fs) * 1e6),
        "model_residual_ppm_fs": full(after_fs),
        "f_model_ppm": model.f_ppm(P_all.I),
    }
    settings = {"alpha": alpha, "terms": terms if isinstance(terms, str) else list(terms),
                "model_fit_weighted": weighted, "line_fit_weighted": weighted_line,
                "lock_in_check": lock_in, "periodic_check": periodic,
                "common_rates": common_rates,
                "stderr_method": "; ".join(sorted({STDERR_METHODS.get(rp.stderr_method,
                                                                      rp.stderr_method)
                                                   for rp in runs}))}
    return ScaleFactorResult(
        output_kind=output_kind, nominal_scale_factor=s0, sf_unit=unit, sf_key=key,
        full_scale_dph=fs, weighted=weighted, settings=settings, runs=run_results,
        scale_factor=sf_mean, scale_factor_sigma=sf_sig, scale_factor_model=sfm_mean,
        scale_factor_model_sigma=sfm_sig, scale_factor_error_ppm=(sf_mean / s0 - 1) * 1e6,
        bias_dph=bias_mean, bias_sigma_dph=bias_sig, bias_zero_rate_dph=bz_mean,
        bias_zero_rate_sigma_dph=bz_sig,
        linearity=linearity_stats(P.I, lin_fs, lin_out),
        linearity_after_model=linearity_stats(P.I, after_fs, after_out),
        model=nl, asymmetry=asym, periodic=per, repeatability=rep, temperature=ts,
        lock_in=li, points=plist, point_table=point_table, run_plateaus=runs, notes=notes,
        threshold=thr, resolution=res_, input_range=in_range)


def _statement(model: ModelFit, hist: list[ModelStep], asym: AsymmetryResult,
               per: PeriodicCheck) -> str:
    sup = sorted(model.terms, key=term_order)
    rej = sorted((h.added for h in hist if not h.accepted and h.added in TERMS), key=term_order)
    parts = []
    if sup:
        parts.append("the data support " + ", ".join(sup) + " term(s)")
    else:
        parts.append("the data support a straight line only (no nonlinearity term lowers the "
                     "misfit significantly)")
    if rej:
        parts.append("not supported: " + ", ".join(rej))
    if asym.status != "ok":
        parts.append("asymmetry not testable (no negative rates)")
    return "; ".join(parts) + "."
