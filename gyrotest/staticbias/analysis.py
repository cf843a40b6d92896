"""Bias D_F, run-to-run repeatability and multi-position tests (IEEE 952 §12.11.4.1.1).

For each sample ``Ω_m = S0·ΔN_m/Δt_m − Ω_IA`` (GYRO_REFERENCE §2); the bias D_F is the mean of
Ω_m after the warm-up. Its uncertainty is **not** σ/√n: gyro noise is correlated (flicker,
rate random walk, Markov), so the standard uncertainty of a mean over a record of length T is
taken from the Allan variance at τ = T, σ_A²(T), which equals the variance of the mean for white
rate noise (N²/T), for rate random walk started at the record start (K²T/3) and for Markov
noise with T ≫ T_c ((q_c·T_c)²/T). σ_A(T) cannot be measured directly from one record of
length T, so it is evaluated from a noise model fitted to the overlapping Allan deviation of
the record (see :func:`mean_uncertainty`).

Repeatability of D_F: sample standard deviation (1σ) and max − min spread of D_F over runs
separated by power-off, thermal cycles or remounting.

Multi-position tests: with the IA pointing in several directions u_p (unit vectors in the
local north/east/up frame), the mean outputs obey ``m_p = D_F + Ω⃗_E · u_p`` and a weighted
least-squares fit separates the bias from the earth rate; the fitted earth-rate vector gives
the latitude check and the IA misalignment (azimuth offset of the fixture, equivalent tilt of
the IA) where the positions allow.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..core.data import GyroLog
from ..core.earth import OMEGA_E_DPH, Site, earth_rate_vector, ia_unit_vector, parse_ia
from ..core.errors import AnalysisError, InputError

MIN_RECORD_SAMPLES = 16


# ----------------------------------------------------------------------------- uncertainty
@dataclass
class MeanUncertainty:
    """Standard uncertainty of the mean of a correlated-noise record."""

    sigma_dph: float  # 1σ of the mean, deg/h
    record_s: float
    method: str
    naive_sigma_dph: float  # σ/√n, for comparison (wrong for correlated noise)
    bound_sigma_dph: float = 0.0  # with the bound-only noise terms at their 95 % upper limits
    bounded_terms: list[str] = field(default_factory=list)
    N_dph_rt_s: float = 0.0  # fitted white-rate coefficient, (deg/h)·√s
    flicker_level_dph: float = 0.0  # fitted flat Allan level, deg/h
    K_dph_per_rt_s: float = 0.0  # fitted rate-random-walk coefficient, (deg/h)/√s
    model_terms: list[str] = field(default_factory=list)  # terms of the model used for ±1σ
    model_chi2_dof: float = math.nan
    default_rejected: str | None = None  # why the default Q,N,B,K model was not used

    def to_dict(self) -> dict:
        return {
            "model_terms": list(self.model_terms),
            "model_chi2_per_dof": None if not math.isfinite(self.model_chi2_dof)
            else self.model_chi2_dof,
            "default_model_rejected": self.default_rejected,
            "sigma_mean_dph": self.sigma_dph,
            "record_s": self.record_s,
            "method": self.method,
            "naive_sigma_over_sqrt_n_dph": self.naive_sigma_dph,
            "sigma_mean_upper_bound_dph": self.bound_sigma_dph,
            "bound_only_noise_terms": self.bounded_terms,
            "model": {
                "N_deg_per_rt_h": self.N_dph_rt_s / 60.0,
                "allan_floor_dph": self.flicker_level_dph,
                "K_deg_per_h_per_rt_h": self.K_dph_per_rt_s * 60.0,
            },
        }


def mean_uncertainty(rate: np.ndarray, tau0: float,
                     segments: list[tuple[int, int]] | None = None) -> MeanUncertainty:
    """Standard uncertainty (1σ, deg/h) of the mean of ``rate`` (deg/h, interval ``tau0`` s).

    Method: overlapping Allan deviation on an octave τ grid up to a quarter of the record
    (gap-aware pooling over ``segments``), the joint χ²-likelihood noise-model fit of
    :func:`gyrotest.noise.noisefit.fit_deviation` with white rate, bias-instability and rate-random-walk
    terms (N, B, K), evaluated at τ = T, the record length: ``u = sqrt(σ²_model(T))``. σ_A²(T)
    is the variance of a mean over T for white rate noise (N²/T), rate random walk started at
    the record start (K²T/3) and Markov noise with T ≫ T_c (IEEE 952 Annex C relations), so this
    is honest for correlated noise, unlike σ/√n. Never smaller than the white-noise value
    σ(τ0)·sqrt(τ0/T); the extrapolation from the longest measured τ to T stays between the
    white-noise (∝ 1/τ) and random-walk (∝ τ) continuations of the measured level.
    """
    from ..noise.deviations import compute_deviation
    from ..noise.noisefit import fit_deviation

    rate = np.asarray(rate, dtype=np.float64)
    n = rate.size
    if n < MIN_RECORD_SAMPLES:
        raise AnalysisError(f"only {n} samples: too few to estimate a bias uncertainty "
                            f"(need at least {MIN_RECORD_SAMPLES})")
    T = n * tau0
    naive = float(np.std(rate, ddof=1) / math.sqrt(n))
    segs = segments or [(0, n)]
    dev = compute_deviation(rate, tau0, input_kind="rate", kind="oadev", taus="decade10",
                            stop_ratio=4, segments=segs)
    ok = np.isfinite(dev.sigma) & (np.asarray(dev.sigma) > 0)
    if not ok.any():
        raise AnalysisError("the rate is constant: the bias uncertainty cannot be estimated "
                            "(quantised to a single level? check the scale factor)")
    fit = fit_deviation(dev, terms="Q,N,B,K")
    rejected = None
    if not fit.consistent:
        # the default model misfits: take the model the diagnosis accepts (as gyrotest allan
        # does), not coefficients that absorbed the missing noise
        from ..noise.diagnose import diagnose

        try:
            final = diagnose(fit).final
        except AnalysisError:
            final = fit
        if final is not fit and final.chi2_dof < fit.chi2_dof:
            rejected = (f"the default noise model Q,N,B,K does not fit this record (χ²/dof "
                        f"{fit.chi2_dof:.3g}); ±1σ from the diagnosed model "
                        f"{','.join(final.requested)} (χ²/dof {final.chi2_dof:.3g})")
            fit = final
        else:
            rejected = (f"the noise model Q,N,B,K does not fit this record (χ²/dof "
                        f"{fit.chi2_dof:.3g}) and the diagnosis found no better one: treat ±1σ "
                        "as approximate")
    var_T = float(fit.predict_avar([T])[0][0])
    var_bound = float(fit.predict_avar([T], conservative=True)[0][0])
    white_floor = float(dev.sigma[ok][0] ** 2 * dev.tau[ok][0] / T)
    # Beyond the longest measured τ the Allan variance can grow no faster than rate random walk
    # (∝ τ) and fall no faster than white rate noise (∝ 1/τ): keep the extrapolation inside that
    # envelope around the measured level (geometric mean of the last three points), so that a
    # noisy long-τ end cannot swing a fitted K term to an absurd σ_A(T).
    tail_s2, tail_tau = np.asarray(dev.sigma)[ok][-3:] ** 2, np.asarray(dev.tau)[ok][-3:]
    level = float(np.exp(np.mean(np.log(tail_s2))))
    t_a = float(np.exp(np.mean(np.log(tail_tau))))
    lo, hi = level * t_a / T, level * T / t_a
    var_T = min(max(var_T, white_floor, lo), hi)
    var_bound = max(min(var_bound, hi), var_T)
    par = {t.key: t.params.get(t.key, 0.0) for t in fit.terms}
    return MeanUncertainty(
        sigma_dph=math.sqrt(var_T), record_s=T,
        method="Allan variance at the record length, σ_A(T), from the joint noise-model fit "
               f"({','.join(fit.requested)}; Q,N,B,K unless it misfits, then the diagnosed "
               "model) of the overlapping Allan deviation (10 τ per decade up to T/4)",
        naive_sigma_dph=naive,
        bound_sigma_dph=math.sqrt(var_bound),
        bounded_terms=[t.key for t in fit.terms if t.status != "identified"],
        N_dph_rt_s=par.get("N", 0.0) * 60.0,
        flicker_level_dph=par.get("B", 0.0) * math.sqrt(2 * math.log(2) / math.pi),
        K_dph_per_rt_s=par.get("K", 0.0) / 60.0,
        model_terms=list(fit.requested), model_chi2_dof=float(fit.chi2_dof),
        default_rejected=rejected,
    )


# ----------------------------------------------------------------------------- single run
@dataclass
class BiasResult:
    """D_F of one run (or one position of a multi-position run)."""

    source: str
    axis: str
    label: str  # run or position label
    samples: int
    skip_s: float
    duration_s: float
    mean_output_dph: float  # mean indicated rate before earth-rate removal
    earth_rate_ia_dph: float | None
    bias_dph: float  # D_F
    uncertainty: MeanUncertainty
    site: Site | None
    mean_temperature_c: float | None = None
    notes: list[str] = field(default_factory=list)
    outliers: dict | None = None
    warmup: dict | None = None
    #: warm-up time from power-on (:func:`gyrotest.staticbias.warmup.warmup_time`) when a band was given
    warmup_time: dict | None = None

    @property
    def sigma_dph(self) -> float:
        return self.uncertainty.sigma_dph

    def to_dict(self) -> dict:
        return {
            "source": self.source,
            "axis": self.axis,
            "label": self.label,
            "samples": self.samples,
            "skip_s": self.skip_s,
            "duration_s": self.duration_s,
            "mean_output_dph": self.mean_output_dph,
            "earth_rate_ia_dph": self.earth_rate_ia_dph,
            "bias_D_F_dph": self.bias_dph,
            "bias_sigma_dph": self.sigma_dph,
            "bias_2sigma_dph": 2 * self.sigma_dph,
            "uncertainty": self.uncertainty.to_dict(),
            "site": self.site.to_dict() if self.site else None,
            "mean_temperature_c": self.mean_temperature_c,
            "outliers": self.outliers,
            "warmup": self.warmup,
            "warmup_time_s": (self.warmup_time or {}).get("warmup_time_s"),
            "warmup_time": self.warmup_time,
            "notes": self.notes,
        }


def _mean_over_segments(x: np.ndarray, segs: list[tuple[int, int]]) -> float:
    tot = sum(float(np.sum(x[a:b])) for a, b in segs)
    cnt = sum(b - a for a, b in segs)
    return tot / cnt


def estimate_bias(log: GyroLog, *, skip_s: float = 0.0, axis: str | None = None,
                  earth_rate: bool = True, label: str | None = None,
                  outliers: str = "flag", warmup_band_dph: float | None = None,
                  warmup_block_s: float = 60.0) -> BiasResult:
    """D_F of a static run: mean rate after ``skip_s`` minus the earth-rate component along
    the IA (from ``log.site``; without a site the earth rate is not removed and a note says
    so). Uncertainty from :func:`mean_uncertainty`. Spikes are detected
    (:mod:`gyrotest.noise.outliers`) and, by ``outliers``, flagged in a note ("flag"), replaced
    by their running median ("remove") or clipped ("robust").

    With ``warmup_band_dph``, the warm-up time of the run (the log starts at power-on; the
    whole log, before ``skip_s``) with :func:`gyrotest.staticbias.warmup.warmup_time` in blocks of
    ``warmup_block_s``.
    """
    axis = axis or log.axes[0]
    if axis not in log.rates:
        raise InputError(f"{log.source}: no axis {axis!r}; axes are {', '.join(log.axes)}")
    if skip_s >= log.duration_s:
        raise InputError(f"{log.source}: --skip {skip_s:g} s removes the whole record "
                         f"({log.duration_s:.6g} s long); use a shorter warm-up trim")
    part = log.skip(skip_s)
    if part.n < MIN_RECORD_SAMPLES:
        raise AnalysisError(f"{log.source}: only {part.n} samples after the warm-up trim; "
                            f"need at least {MIN_RECORD_SAMPLES}")
    rate = part.rates[axis]
    segs = part.segments
    notes: list[str] = []
    rate, out_info = _treat_outliers(rate, part, segs, axis, outliers, notes)
    mean = _mean_over_segments(rate, segs)
    if len(segs) > 1:
        notes.append(f"{len(segs)} contiguous segments (gaps not bridged); mean and Allan "
                     "deviation pooled over segments")
    er = None
    if earth_rate and log.site is not None:
        er = log.site.earth_rate_dph()
    elif earth_rate:
        notes.append("no site given (--latitude/--ia): earth rate NOT removed; D_F includes it")
    try:
        unc = mean_uncertainty(rate, part.tau0, segs)
    except AnalysisError as e:  # a constant rate: say which log
        raise AnalysisError(f"{log.source}: {e}") from None
    if unc.default_rejected:
        notes.append(unc.default_rejected)
    warm = None
    if skip_s <= 0 and len(segs) == 1:
        from .warmup import detect_warmup

        warm = detect_warmup(rate, part.tau0)
        if warm is not None and warm.detected:
            notes.append(warm.message())
    if unc.bound_sigma_dph > 3 * unc.sigma_dph and unc.bounded_terms:
        notes.append(
            f"noise term(s) {', '.join(unc.bounded_terms)} only bounded by this record: if they "
            f"were at their 95 % upper limits the 1σ would be {unc.bound_sigma_dph:.3g} deg/h; "
            "a longer record would resolve them")
    wt = None
    if warmup_band_dph is not None:
        wt = run_warmup_time(log, axis, warmup_band_dph, warmup_block_s)
    temps = [np.mean(v) for v in part.temperature.values()]
    return BiasResult(
        source=log.source, axis=axis, label=label or log.source, samples=part.n,
        skip_s=skip_s, duration_s=part.duration_s, mean_output_dph=mean,
        earth_rate_ia_dph=er, bias_dph=mean - (er or 0.0), uncertainty=unc, site=log.site,
        mean_temperature_c=float(np.mean(temps)) if temps else None, notes=notes,
        outliers=out_info, warmup=None if warm is None else warm.to_dict(), warmup_time=wt,
    )


def run_warmup_time(log: GyroLog, axis: str, band_dph: float, block_s: float) -> dict:
    """Warm-up time of ``log`` (starting at power-on) for one axis: the JSON form of
    :func:`gyrotest.staticbias.warmup.warmup_time` on the whole record (no trim); its 1σ
    ``warmup_time_sigma_s`` combines the block resolution and the band-crossing jitter."""
    from .warmup import warmup_time

    if len(log.segments) > 1:
        raise InputError(f"{log.source}: the warm-up time needs one contiguous record from "
                         f"power-on; the log has {len(log.segments)} segments (gaps)")
    try:
        w = warmup_time(log.rates[axis], log.tau0, band_dph=band_dph, block_s=block_s)
    except AnalysisError as e:
        raise AnalysisError(f"{log.source}: {e}") from None
    d = w.to_dict()
    if not math.isfinite(w.warmup_s):
        d["warmup_time_sigma_s"] = None
    return d


def _treat_outliers(rate, part: GyroLog, segs, axis: str, mode: str, notes: list[str]):
    """Spike detection for the bias (never silent): (rate after ``mode``, report dict)."""
    from ..noise.outliers import apply_outliers, detect_outliers

    rep = detect_outliers(rate, part.tau0, t0=float(part.t[0]) if part.n else 0.0,
                          channel=axis, segments=segs)
    info = rep.to_dict()
    info["mode"] = mode
    if rep.found:
        raw_mean = _mean_over_segments(rate, segs)
        rate = apply_outliers(rate, rep, mode, segments=segs)
        shift = _mean_over_segments(rate, segs) - raw_mean if mode != "flag" else None
        what = {"flag": "the mean includes them (--outliers remove or robust to treat them)",
                "remove": f"each replaced by its running median (--outliers remove): the mean "
                          f"moved by {shift:+.4g} deg/h" if shift is not None else "",
                "robust": f"each clipped to the threshold (--outliers robust): the mean moved "
                          f"by {shift:+.4g} deg/h" if shift is not None else ""}[mode]
        notes.append(f"spikes: {rep.summary()}; {what}")
        info["mean_shift_dph"] = shift
    return rate, info


# ----------------------------------------------------------------------------- repeatability
@dataclass
class Repeatability:
    """Run-to-run repeatability of D_F (IEEE 952 §12.11.4.1.1)."""

    runs: list[BiasResult]
    mean_dph: float
    sigma_1_dph: float  # sample standard deviation over runs (ddof = 1)
    spread_dph: float  # max − min
    within_run_sigma_dph: float  # RMS of the runs' own uncertainties
    notes: list[str] = field(default_factory=list)

    def to_dict(self) -> dict:
        return {
            "runs": len(self.runs),
            "mean_bias_dph": self.mean_dph,
            "repeatability_1sigma_dph": self.sigma_1_dph,
            "repeatability_max_spread_dph": self.spread_dph,
            "within_run_sigma_rms_dph": self.within_run_sigma_dph,
            "notes": self.notes,
        }


def repeatability(runs: list[BiasResult]) -> Repeatability:
    """1σ (ddof = 1) and max − min spread of D_F over runs; notes when the spread is not
    larger than the runs' own uncertainties (then it is not resolved)."""
    if len(runs) < 2:
        raise InputError("repeatability needs at least two runs")
    b = np.array([r.bias_dph for r in runs])
    u = np.array([r.sigma_dph for r in runs])
    s1 = float(np.std(b, ddof=1))
    within = float(np.sqrt(np.mean(u**2)))
    notes = []
    if s1 < 1.5 * within:
        notes.append("the run-to-run spread is comparable with the runs' own uncertainty: "
                     "repeatability is at most this (longer runs would resolve it)")
    return Repeatability(runs, float(np.mean(b)), s1, float(b.max() - b.min()), within, notes)


# ----------------------------------------------------------------------------- multi-position
@dataclass
class MultiPositionResult:
    """Bias separated from earth rate by a multi-position test."""

    positions: list[BiasResult]
    bias_dph: float
    bias_sigma_dph: float
    earth_rate_fit_dph: dict[str, float | None]  # north/east/up components fitted (None: fixed)
    earth_rate_fit_sigma_dph: dict[str, float | None]
    latitude_deg: float | None  # given
    latitude_est_deg: float | None
    latitude_est_sigma_deg: float | None
    azimuth_misalignment_deg: float | None
    azimuth_misalignment_sigma_deg: float | None
    ia_tilt_deg: float | None  # apparent IA tilt north from the up/down earth-rate component
    residuals_dph: list[float]
    chi2_dof: float | None
    notes: list[str] = field(default_factory=list)

    def to_dict(self) -> dict:
        return {
            "positions": [
                {"label": p.label, "source": p.source, "mean_output_dph": p.mean_output_dph,
                 "sigma_dph": p.sigma_dph, "duration_s": p.duration_s,
                 "ia_azimuth_deg": p.site.ia_azimuth_deg if p.site else None,
                 "ia_elevation_deg": p.site.ia_elevation_deg if p.site else None,
                 "residual_dph": r}
                for p, r in zip(self.positions, self.residuals_dph)
            ],
            "bias_D_F_dph": self.bias_dph,
            "bias_sigma_dph": self.bias_sigma_dph,
            "earth_rate_fit_dph": self.earth_rate_fit_dph,
            "earth_rate_fit_sigma_dph": self.earth_rate_fit_sigma_dph,
            "earth_rate_expected_dph": (
                dict(zip(("north", "east", "up"),
                         map(float, earth_rate_vector(self.latitude_deg))))
                if self.latitude_deg is not None else None),
            "latitude_given_deg": self.latitude_deg,
            "latitude_est_deg": self.latitude_est_deg,
            "latitude_est_sigma_deg": self.latitude_est_sigma_deg,
            "azimuth_misalignment_deg": self.azimuth_misalignment_deg,
            "azimuth_misalignment_sigma_deg": self.azimuth_misalignment_sigma_deg,
            "ia_tilt_north_deg": self.ia_tilt_deg,
            "chi2_per_dof": self.chi2_dof,
            "notes": self.notes,
        }


def multi_position(positions: list[BiasResult], latitude_deg: float | None) -> MultiPositionResult:
    """Separate D_F from earth rate: weighted least squares of
    ``m_p = D_F + Ω_N·u_N,p + Ω_E·u_E,p + Ω_U·u_U,p`` over positions p (IA unit vector u_p in the
    north/east/up frame; weights 1/σ_p²). Earth-rate components the positions cannot resolve
    are fixed at their values for the given latitude. Derived: latitude estimate (from the
    fitted components), the azimuth misalignment δA = −atan2(Ω_E, Ω_N) (the horizontal IA
    positions point δA clockwise of nominal; the true east component is zero), and the
    apparent IA tilt from up/down positions.
    """
    if len(positions) < 2:
        raise InputError("a multi-position test needs at least two IA positions")
    if any(p.site is None for p in positions):
        raise InputError("every position needs its IA direction (a position column, --positions, "
                         "or [site] ia per file)")
    U = np.array([ia_unit_vector(p.site.ia_azimuth_deg, p.site.ia_elevation_deg) for p in positions])
    m = np.array([p.mean_output_dph for p in positions])
    s = np.array([p.sigma_dph for p in positions])
    w = 1.0 / s
    names = ("north", "east", "up")
    # which earth-rate components the positions resolve (together with the bias column)
    resolvable = []
    base = np.ones((len(positions), 1))
    for j in range(3):
        trial = np.column_stack([base] + [U[:, k] for k in resolvable + [j]])
        if np.linalg.matrix_rank(trial, tol=1e-6) == trial.shape[1]:
            resolvable.append(j)
    fixed = [j for j in range(3) if j not in resolvable]
    notes: list[str] = []
    if fixed and latitude_deg is None:
        raise InputError("these positions do not resolve every earth-rate component; give the "
                         "latitude (--latitude) so the others can be fixed")
    er_known = earth_rate_vector(latitude_deg) if latitude_deg is not None else np.zeros(3)
    y = m - (U[:, fixed] @ er_known[fixed] if fixed else 0.0)
    X = np.column_stack([np.ones(len(positions))] + [U[:, j] for j in resolvable])
    if X.shape[0] < X.shape[1]:
        raise InputError("too few positions for the unknowns")
    Xw, yw = X * w[:, None], y * w
    beta, *_ = np.linalg.lstsq(Xw, yw, rcond=None)
    cov = np.linalg.inv(Xw.T @ Xw)
    resid = y - X @ beta
    dof = X.shape[0] - X.shape[1]
    chi2 = float(np.sum((resid * w) ** 2) / dof) if dof > 0 else None
    if chi2 is not None and chi2 > 1:
        cov = cov * chi2  # scale by the observed scatter (Birge ratio)
        notes.append(f"position scatter exceeds the noise (χ²/dof = {chi2:.2f}); uncertainties "
                     "scaled up accordingly")
    sig = np.sqrt(np.diag(cov))
    fit = {n: None for n in names}
    fit_s = {n: None for n in names}
    for k, j in enumerate(resolvable, start=1):
        fit[names[j]] = float(beta[k])
        fit_s[names[j]] = float(sig[k])
    # latitude check
    lat_est = lat_sig = None
    comps = {names[j]: beta[k] for k, j in enumerate(resolvable, start=1)}
    if "up" in comps and ("north" in comps):
        h = math.hypot(comps["north"], comps.get("east", 0.0))
        lat_est = math.degrees(math.atan2(comps["up"], h))
        # first-order error propagation
        ju = h / (h * h + comps["up"] ** 2)
        jh = -comps["up"] / (h * h + comps["up"] ** 2)
        iu = resolvable.index(2) + 1
        iN = resolvable.index(0) + 1
        var = ju**2 * cov[iu, iu] + jh**2 * cov[iN, iN] + 2 * ju * jh * cov[iu, iN]
        lat_sig = math.degrees(math.sqrt(max(var, 0.0)))
    elif "up" in comps:
        r = comps["up"] / OMEGA_E_DPH
        if abs(r) <= 1:
            lat_est = math.degrees(math.asin(r))
            iu = resolvable.index(2) + 1
            lat_sig = math.degrees(sig[iu] / (OMEGA_E_DPH * max(math.sqrt(1 - r * r), 1e-9)))
        else:
            notes.append("fitted vertical earth-rate component exceeds Ω_E: check the bias "
                         "stability between positions")
    elif "north" in comps:
        r = math.hypot(comps["north"], comps.get("east", 0.0)) / OMEGA_E_DPH
        if r <= 1 and latitude_deg is not None:
            lat_est = math.copysign(math.degrees(math.acos(r)), latitude_deg)
            iN = resolvable.index(0) + 1
            lat_sig = math.degrees(sig[iN] / (OMEGA_E_DPH * max(math.sqrt(1 - r * r), 1e-9)))
    az = az_sig = None
    if "north" in comps and "east" in comps:
        # an IA turned δA clockwise (towards east) from its nominal azimuth makes the fit see
        # an east earth-rate component −Ω_h·sin δA: δA = −atan2(Ω_E,fit, Ω_N,fit)
        az = -math.degrees(math.atan2(comps["east"], comps["north"]))
        iE = resolvable.index(1) + 1
        az_sig = math.degrees(sig[iE] / max(abs(comps["north"]), 1e-12))
    elif "east" in comps and latitude_deg is not None:
        h = OMEGA_E_DPH * math.cos(math.radians(latitude_deg))
        if h > 1e-9:
            az = -math.degrees(math.asin(max(-1.0, min(1.0, comps["east"] / h))))
            iE = resolvable.index(1) + 1
            az_sig = math.degrees(sig[iE] / h)
    tilt = None
    if "up" in comps and latitude_deg is not None and "north" not in comps:
        r = max(-1.0, min(1.0, comps["up"] / OMEGA_E_DPH))
        tilt = math.degrees(math.asin(r)) - latitude_deg
        notes.append("up/down positions cannot tell a latitude error from an IA tilt towards "
                     "north: the tilt shown is the equivalent of the whole difference")
    if fixed:
        notes.append("earth-rate component(s) " + ", ".join(names[j] for j in fixed)
                     + " not resolved by these positions: fixed at the value for the given latitude")
    return MultiPositionResult(
        positions=positions, bias_dph=float(beta[0]), bias_sigma_dph=float(sig[0]),
        earth_rate_fit_dph=fit, earth_rate_fit_sigma_dph=fit_s, latitude_deg=latitude_deg,
        latitude_est_deg=lat_est, latitude_est_sigma_deg=lat_sig,
        azimuth_misalignment_deg=az, azimuth_misalignment_sigma_deg=az_sig, ia_tilt_deg=tilt,
        residuals_dph=[float(r) for r in resid], chi2_dof=chi2, notes=notes,
    )


def split_positions(log: GyroLog, settle_s: float = 0.0) -> list[tuple[str, GyroLog]]:
    """Split a log with a position column into one log per contiguous position, dropping
    ``settle_s`` after every change (the fixture moved). Labels must be IA directions."""
    if log.position is None:
        raise InputError(f"{log.source}: no position column; name it with --position-col")
    lab = log.position.astype(str)
    change = np.flatnonzero(lab[1:] != lab[:-1]) + 1
    cuts = [0, *change.tolist(), log.n]
    out = []
    for a, b in zip(cuts[:-1], cuts[1:]):
        label = lab[a]
        if not label:
            continue
        part = log.slice(a, b).skip(settle_s)
        if part.n < MIN_RECORD_SAMPLES:
            raise AnalysisError(f"{log.source}: position {label!r} at t = {log.t[a]:.6g} s is "
                                f"too short after the {settle_s:g} s settling time")
        az, el, name = parse_ia(label)
        lat = log.site.latitude_deg if log.site else None
        part.site = Site(lat if lat is not None else float("nan"), az, el, name)
        out.append((name, part))
    return out


# ----------------------------------------------------------------------------- the command
@dataclass
class BiasAnalysis:
    """Everything ``gyrotest bias`` computes (and the spec-sheet report quotes): the D_F of
    each run or position, and the repeatability over runs or the multi-position fit."""

    runs: list[BiasResult]
    repeatability: Repeatability | None
    multi: MultiPositionResult | None
    #: the logs the runs were estimated on (one per run, or one per position), for the plot
    parts: list[GyroLog]
    #: warm-up trim still inside ``parts`` (0 when they are position pieces, already trimmed)
    parts_skip_s: float = 0.0

    @property
    def analysis(self) -> str:
        """``multi-position``, ``repeatability`` or ``bias``."""
        if self.multi:
            return "multi-position"
        return "repeatability" if self.repeatability else "bias"

    @property
    def warmup_worst(self) -> tuple[float | None, int | None]:
        """The longest warm-up time over the runs (s) and its run index; (None, None) when no
        band was given; NaN when a run's warm-up was not resolvable or not reached."""
        wts = [r.warmup_time for r in self.runs]
        if not wts or any(w is None for w in wts):
            return None, None
        vals = [w["warmup_time_s"] for w in wts]
        if any(not math.isfinite(v) for v in vals):
            i = next(i for i, v in enumerate(vals) if not math.isfinite(v))
            return math.nan, i
        i = int(np.argmax(vals))
        return float(vals[i]), i

    def to_dict(self) -> dict:
        """The JSON document of ``gyrotest bias --json``."""
        worst, iw = self.warmup_worst
        return {
            "analysis": self.analysis,
            "warmup_time_worst_s": worst,
            "warmup_time_worst_sigma_s": (self.runs[iw].warmup_time["warmup_time_sigma_s"]
                                          if iw is not None else None),
            "warmup_time_worst_run": self.runs[iw].source if iw is not None else None,
            "runs": [r.to_dict() for r in self.runs],
            "repeatability": self.repeatability.to_dict() if self.repeatability else None,
            "multi_position": self.multi.to_dict() if self.multi else None,
            "units": {"bias": "deg/h", "time": "s"},
        }


def parse_positions(positions: str | list[str] | None, n_logs: int) -> list[str] | None:
    """The IA direction of each of ``n_logs`` logs from ``"up,down,..."`` (or a list); None
    when not given. InputError when the count does not match."""
    if not positions:
        return None
    pos_list = ([p.strip() for p in positions.split(",")] if isinstance(positions, str)
                else [str(p).strip() for p in positions])
    if len(pos_list) != n_logs:
        raise InputError(f"--positions lists {len(pos_list)} direction(s) for {n_logs} file(s); "
                         "give one IA direction per file")
    return pos_list


def analyse_bias(logs: list[GyroLog], *, skip_s: float = 0.0, settle_s: float = 0.0,
                 axis: str | None = None, positions: str | list[str] | None = None,
                 earth_rate: bool = True, outliers: str = "flag",
                 warmup_band_dph: float | None = None,
                 warmup_block_s: float = 60.0) -> BiasAnalysis:
    """The whole bias analysis of ``gyrotest bias`` (no printing, no files).

    * ``positions`` (one IA direction per log, :func:`parse_positions`) sets each log's IA;
    * logs with a position column are trimmed by ``skip_s``, split into positions
      (:func:`split_positions`, ``settle_s`` dropped after every change) and each position's
      mean is taken without earth-rate removal (the multi-position fit separates it);
    * otherwise D_F of each log after ``skip_s`` (:func:`estimate_bias`, earth rate removed
      unless ``earth_rate`` is False);
    * several IA directions (or a position column): :func:`multi_position`; several runs with
      one IA: :func:`repeatability`;
    * ``warmup_band_dph``: the warm-up time of each log from its start (power-on), blocks of
      ``warmup_block_s`` (:func:`run_warmup_time`; not for logs with a position column).

    The input logs are not modified.
    """
    import copy

    pos_list = parse_positions(positions, len(logs))
    if pos_list:
        placed = []
        for g, lab in zip(logs, pos_list):
            az, el, name = parse_ia(lab)
            if g.site is None:
                raise InputError("--positions needs the site latitude: give --latitude")
            g = copy.copy(g)
            g.site = Site(g.site.latitude_deg, az, el, name)
            placed.append(g)
        logs = placed
    runs: list[BiasResult] = []
    parts: list[GyroLog] = []
    has_pos_col = any(g.position is not None for g in logs)
    if has_pos_col and warmup_band_dph is not None:
        raise InputError("the warm-up time (--warmup-band) needs static runs from power-on, "
                         "not a multi-position log with a position column")
    if has_pos_col:
        for g in logs:
            if g.position is None:
                raise InputError(f"{g.source}: no position column while other logs have one")
            for label, part in split_positions(g.skip(skip_s), settle_s):
                parts.append(part)
                runs.append(estimate_bias(part, axis=axis, earth_rate=False,
                                          label=f"{label} ({g.source})", outliers=outliers))
    else:
        for g in logs:
            parts.append(g)
            runs.append(estimate_bias(g, skip_s=skip_s, axis=axis, earth_rate=earth_rate,
                                      outliers=outliers, warmup_band_dph=warmup_band_dph,
                                      warmup_block_s=warmup_block_s))
    sites = {(round(r.site.ia_azimuth_deg, 6), round(r.site.ia_elevation_deg, 6))
             for r in runs if r.site is not None}
    multi = rep = None
    if has_pos_col or len(sites) > 1:
        lat = next((r.site.latitude_deg for r in runs if r.site is not None
                    and r.site.latitude_deg == r.site.latitude_deg), None)
        multi = multi_position(runs, lat)
    elif len(runs) > 1:
        rep = repeatability(runs)
    return BiasAnalysis(runs, rep, multi, parts, 0.0 if has_pos_col else skip_s)
