"""The noise floor a drift model is judged against, estimated without the model.

A model is complete when its held-out residual is as small as the gyro's own noise allows at
the working resolution. If that floor were estimated from the residual of the model being
judged, every effect the model misses would raise the floor with the residual and hide
itself ("held-out/floor 1.6×" where the true misfit was 50×). gyrotest therefore estimates the
floor once per log, from data the model cannot influence, and holds it fixed through a
diagnosis and a model history:

* **short-τ noise of the raw rate** (default): a *robust* overlapping Hadamard deviation of the
  raw rate (fine grid; the trimmed scale of the cluster differences, not their mean square, so
  sparse events -- field and supply steps, ramp corners, a warm-up -- do not count, and
  second differences, so rate ramps do not either, :func:`robust_avar`) gives the white noise N from the τ range that white noise alone
  explains, and the flicker plateau B as the lowest excess over white noise seen up to T/8
  (environmental stimuli only add variance), :func:`white_flicker`. Random walk cannot be
  told from slow environment in one record; this floor holds white and flicker noise only
  and says so.
* **a static reference run** (``--reference``): N, B and K fitted to the reference log's
  Allan variance up to an eighth of its length (σ² = N²/τ + B² + K²τ/3; flicker and random
  walk kept only where they exceed two standard errors), random walk included.

Either is turned into the RMS of the block-mean residual at the working resolution by
:func:`floor_rms`.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import optimize

from . import stats as st

#: Hadamard / Allan plateau of flicker rate noise, (8 ln 2 − 3 ln 3)/(4 ln 2)
HADAMARD_FLICKER = (8 * math.log(2) - 3 * math.log(3)) / (4 * math.log(2))
#: ln 2 factor of the flicker plateau: σ² = B²·(2 ln 2)/… — see :func:`floor_rms`
_LN2 = math.log(2.0)


def floor_rms(N: float, B: float, K: float, t_eff_s: float, duration_s: float) -> float:
    """RMS (deg/h) of mean-removed working-resolution residuals of white, flicker and
    random-walk rate noise.

    Formula: rms² = N²/T_eff + B²·ln(T/(2·T_eff))/(2 ln 2) + K²·T/6, with N in
    (deg/h)·√s (σ² = N²/τ), B the flicker Allan plateau in deg/h, K in (deg/h)/√s
    (σ² = K²τ/3), T_eff the averaging time of the working filter (smoother and block mean,
    :func:`gyrotest.envmodel.fit.effective_averaging_time`) and T the record length: white
    noise averaged over T_eff; flicker with one-sided PSD B²/(2 ln 2·f) integrated from 1/T to
    1/(2·T_eff); a random walk of diffusion K² has a mean-removed variance K²·T/6 over T.
    Source: IEEE Std 952-1997 Annex C (σ² of white, flicker and random-walk rate noise);
    gyrotest (integration over the record).
    """
    ratio = duration_s / (2.0 * t_eff_s)
    flick = B * B * math.log(ratio) / (2 * _LN2) if ratio > 1 else 0.0
    rw = K * K * duration_s / 6.0 if K > 0 else 0.0
    return math.sqrt(N * N / t_eff_s + flick + rw)


def _fit_allan(tau: np.ndarray, sig: np.ndarray, duration_s: float, cols: list[str]
               ) -> dict[str, float]:
    """Non-negative LS of σ²(τ) on the named columns (``quant`` 1/τ², ``white`` 1/τ,
    ``flicker`` 1, ``rw`` τ/3, ``drift`` τ²), each point weighted by its relative precision
    (σ²(τ)·√(2/ν), ν ≈ T/τ degrees of freedom)."""
    w = 1.0 / _se(tau, sig, duration_s)
    A = _columns(tau, cols) * w[:, None]
    scale = np.sqrt(np.sum(A * A, axis=0))
    scale[scale == 0] = 1.0
    coef, _ = optimize.nnls(A / scale, sig ** 2 * w)
    coef = coef / scale
    return dict(zip(cols, (float(c) for c in coef)))


def _se(tau: np.ndarray, sig: np.ndarray, duration_s: float) -> np.ndarray:
    """Standard error of an Allan variance estimate, σ²·√(2/ν) with ν ≈ max(1, T/τ − 1)
    (a rough, slightly conservative count of the independent second differences)."""
    nu = np.maximum(1.0, duration_s / tau - 1.0)
    return sig ** 2 * np.sqrt(2.0 / nu)


def _columns(tau: np.ndarray, cols) -> np.ndarray:
    """The σ²(τ) shapes of the noise and nuisance terms, one column each."""
    shape = {"quant": lambda t: 1.0 / t ** 2, "white": lambda t: 1.0 / t,
             "flicker": np.ones_like, "rw": lambda t: t / 3.0, "step": lambda t: t,
             "drift": lambda t: t ** 2}
    return np.column_stack([shape[c](tau) for c in cols])


def _cov(tau: np.ndarray, sig: np.ndarray, duration_s: float, cols, se_factor: float = 1.0
         ) -> np.ndarray:
    """Covariance of the weighted least-squares coefficients of :func:`_fit_allan`."""
    A = _columns(tau, cols) / (se_factor * _se(tau, sig, duration_s))[:, None]
    return np.linalg.pinv(A.T @ A)


def _model(c: dict[str, float], tau: np.ndarray) -> np.ndarray:
    return _columns(tau, list(c)) @ np.array(list(c.values()))


def fit_noise_range(tau: np.ndarray, sig: np.ndarray, duration_s: float,
                    cols: tuple[str, ...] = ("quant", "white", "flicker"), z_max: float = 3.0,
                    se_factor: float = 1.0) -> tuple[dict[str, float], int]:
    """Fit the noise columns ``cols`` to the shortest-τ part of an Allan curve that they
    explain: starting from the three shortest τ, the range is extended one τ at a time while
    every point stays within ``z_max`` standard errors of the fit (environmental stimuli only
    add variance at longer τ, so the first point that the noise model cannot follow ends the
    range). Returns (coefficients, number of τ used)."""
    n = len(tau)
    k = min(3, n)
    best = _fit_allan(tau[:k], sig[:k], duration_s, list(cols))
    while k < n:
        trial = _fit_allan(tau[:k + 1], sig[:k + 1], duration_s, list(cols))
        z = (sig[:k + 1] ** 2 - _model(trial, tau[:k + 1])) / (
            se_factor * _se(tau[:k + 1], sig[:k + 1], duration_s))
        if np.max(np.abs(z)) > z_max:
            break
        best, k = trial, k + 1
    return best, k


def white_flicker(tau: np.ndarray, sig: np.ndarray, duration_s: float,
                  se_factor: float = 1.0) -> tuple[float, float, tuple[float, float]]:
    """White N and flicker B of a rate from its Allan curve without being misled by slow
    environmental stimuli.

    Method: white noise alone, σ² = N²/τ, is fitted to the shortest τ it explains
    (:func:`fit_noise_range`, up to T/8). Flicker counts only when σ² = N²/τ + B² + C·τ
    explains at least four τ with B² above two standard errors: the C·τ term takes up random
    walk and the dense steps of a stimulus (whose share of the cluster differences grows
    with τ), so only a flat excess counts as flicker. B² is then capped by the lowest excess
    over white noise seen at any τ, min_τ [σ²(τ) − N²/τ + SE(τ)/2]₊ (anything environmental
    only adds to it). Flicker whose plateau is reached only where the environment already
    dominates cannot be told from it in one record: give a static reference run
    (:func:`reference_floor`). ``se_factor`` scales the standard errors (1.2 for the
    trimmed deviation of :func:`robust_avar`). Returns (N (deg/h)·√s, B deg/h, (last τ of
    the fit, last τ searched))."""
    keep = tau <= duration_s / 8.0
    if keep.sum() < 3:
        keep = np.arange(len(tau)) < 3
    tau, sig = tau[keep], sig[keep]
    cw, kw = fit_noise_range(tau, sig, duration_s, cols=("white",), z_max=3.0,
                             se_factor=se_factor)
    N = math.sqrt(cw["white"])
    B2 = 0.0
    t_lo = t_hi = float(tau[kw - 1])
    cols = ("white", "flicker", "step")
    c, k = fit_noise_range(tau, sig, duration_s, cols=cols, z_max=3.0, se_factor=se_factor)
    if c["flicker"] > 0 and k >= 4:
        cov = _cov(tau[:k], sig[:k], duration_s, cols, se_factor)
        if c["flicker"] > 2.0 * math.sqrt(max(cov[1, 1], 0.0)):
            N, B2 = math.sqrt(c["white"]), c["flicker"]
            t_lo = t_hi = float(tau[k - 1])
    sel = tau >= 2.0 * tau[0]
    if sel.any() and B2 > 0:
        ex = (sig[sel] ** 2 - N * N / tau[sel]
              + 0.5 * se_factor * _se(tau[sel], sig[sel], duration_s))
        B2 = min(B2, max(0.0, float(np.min(ex))))
        t_hi = float(tau[sel][-1])
    return N, math.sqrt(max(B2, 0.0)), (t_lo, t_hi)


#: variance of a standard normal truncated at ±4σ: 1 − 8φ(4)/(2Φ(4) − 1)
_TRUNC4 = 1.0 - 8.0 * math.exp(-8.0) / math.sqrt(2 * math.pi) / math.erf(4.0 / math.sqrt(2))


def _robust_scale(d: np.ndarray) -> float:
    """Standard deviation of the Gaussian bulk of ``d``: the MAD scale (1.4826·MAD) finds the
    bulk, values beyond 4 of those from the median are dropped, and the standard deviation of
    the rest is corrected for the truncation. Sparse large outliers (steps) are removed
    entirely, where a MAD alone would still be inflated by the fraction they occupy."""
    med = float(np.median(d))
    s0 = 1.4826 * float(np.median(np.abs(d - med)))
    if not s0 > 0:
        return float(np.std(d))
    keep = np.abs(d - med) < 4.0 * s0
    return float(np.std(d[keep]) / math.sqrt(_TRUNC4))


#: a logged channel "steps" where one sample-to-sample change exceeds this many robust σ of
#: its changes and :data:`STEP_RANGE_FRAC` of its range
STEP_SIGMA = 8.0
STEP_RANGE_FRAC = 0.02
#: samples kept out after a step (coil-current settling, the gyro's response)
STEP_SETTLE = 3
#: a channel whose changes are "steps" more often than this is not stepped but noisy: ignored
STEP_MAX_FRAC = 0.10
#: fewest clean differences for a τ to count
MIN_CLEAN_DIFFS = 30


def stimulus_steps(channels: dict[str, np.ndarray], segments: list[tuple[int, int]],
                   n: int) -> tuple[np.ndarray, list[str]]:
    """Samples at and just after a step of any logged channel (Helmholtz-coil or supply steps,
    tilt-table moves, chamber set-point jumps): a sample-to-sample change larger than
    ``STEP_SIGMA`` robust σ of the channel's changes (1.4826·MAD) and ``STEP_RANGE_FRAC`` of
    its 0.5–99.5 % range, marked with the ``STEP_SETTLE`` samples after it. Channels whose
    changes are steps more often than ``STEP_MAX_FRAC`` (noise, not a stepped stimulus) are
    ignored. Returns (boolean mask over the n samples, names of the stepped channels)."""
    mask = np.zeros(n, dtype=bool)
    names = []
    for name, x in channels.items():
        x = np.asarray(x, float)
        if x.shape != (n,) or not np.all(np.isfinite(x)):
            continue
        lo, hi = np.percentile(x, [0.5, 99.5])
        rng = float(hi - lo)
        if not rng > 0:
            continue
        hit = np.zeros(n, dtype=bool)
        for a, b in segments:
            if b - a < 3:
                continue
            d = np.abs(np.diff(x[a:b]))
            sig = 1.4826 * float(np.median(np.abs(d - np.median(d))))
            big = d > max(STEP_SIGMA * sig, STEP_RANGE_FRAC * rng)
            hit[a + 1:b] |= big
        frac = hit.mean()
        if frac == 0 or frac > STEP_MAX_FRAC:
            continue
        idx = np.flatnonzero(hit)
        for k in range(STEP_SETTLE + 1):
            mask[np.minimum(idx + k, n - 1)] = True
        mask[np.maximum(idx - 1, 0)] = True
        names.append(name)
    return mask, names


def frame_channels(fr) -> dict[str, np.ndarray]:
    """Every logged stimulus channel of an :class:`~gyrotest.envmodel.frame.EnvFrame`
    (temperatures, field, supply, table rate, extra channels, earth-rate projection)."""
    out: dict[str, np.ndarray] = {}
    for group in (fr.temperature, fr.field_uT, fr.extra):
        out.update(group)
    for name in ("supply", "table_rate", "earth_dph"):
        v = getattr(fr, name, None)
        if v is not None:
            out[name] = v
    return out


def robust_avar(rate: np.ndarray, dt: float, segments: list[tuple[int, int]],
                max_frac: float = 0.25, hadamard: bool = False,
                exclude: np.ndarray | None = None
                ) -> tuple[np.ndarray, np.ndarray]:
    """Overlapping Allan (or Hadamard) deviation with a robust scale: σ(τ) = s(d)/√2 over the
    differences d = ȳ_{k+m} − ȳ_k of adjacent overlapping τ-averages (Hadamard:
    d = ȳ_{k+2m} − 2ȳ_{k+m} + ȳ_k and /√6), octave τ = m·dt, pooled over the gap-free
    segments; s(d) the standard deviation of the Gaussian bulk of d (:func:`_robust_scale`:
    MAD to find it, a 4σ cut, truncation-corrected standard deviation).

    For Gaussian noise this equals the Allan (Hadamard) deviation; sparse environmental
    events -- field or supply steps, the corners of temperature ramps, a warm-up transient --
    only move the differences that straddle them and are ignored by the median, where they
    would add to a mean square; the Hadamard form also ignores linear trends of the rate
    (temperature ramps acting through D_T, a lag's exponential approach at short τ). For
    white rate noise both give N²/τ; for flicker the Hadamard plateau is
    (8 ln 2 − 3 ln 3)/(4 ln 2) = 0.811 of the Allan plateau. Source: IEEE Std 952-1997
    Annex C (Allan variance); Riley, Handbook of Frequency Stability Analysis (NIST SP 1065,
    2008) §5.2.8 (Hadamard variance); robust scale: Rousseeuw & Croux (1993) (MAD consistency
    factor 1.4826).

    ``exclude`` (boolean per sample, :func:`stimulus_steps`): differences whose window holds
    an excluded sample are left out, so that stimulus steps too dense to be "sparse" for the
    robust scale (a Helmholtz sequence stepping every minute) do not count as noise; a τ with
    fewer than ``MIN_CLEAN_DIFFS`` clean differences is skipped.
    """
    rate = np.asarray(rate, float)
    longest = max((b - a for a, b in segments), default=0)
    taus, sigs = [], []
    m = 1
    while m <= max_frac * longest:
        parts = []
        span = (3 if hadamard else 2) * m
        for a, b in segments:
            x = rate[a:b]
            if len(x) < 2 * m + 1:
                continue
            c = np.concatenate([[0.0], np.cumsum(x - x[0])])
            avg = (c[m:] - c[:-m]) / m
            if hadamard:
                if len(avg) <= 2 * m:
                    continue
                d = avg[2 * m:] - 2.0 * avg[m:-m] + avg[:-2 * m]
            else:
                d = avg[m:] - avg[:-m]
            if exclude is not None:
                ce = np.concatenate([[0], np.cumsum(exclude[a:b], dtype=np.int64)])
                d = d[(ce[span:] - ce[:-span])[:len(d)] == 0]
            parts.append(d)
        if parts and sum(len(p) for p in parts) >= (MIN_CLEAN_DIFFS if exclude is not None
                                                    else 1):
            d = np.concatenate(parts)
            taus.append(m * dt)
            sigs.append(_robust_scale(d) / math.sqrt(6.0 if hadamard else 2.0))
        m *= 2
    return np.asarray(taus), np.asarray(sigs)


def model_free_floor(wd) -> st.NoiseFloor:
    """The noise floor of a prepared log (:class:`~gyrotest.envmodel.fit.WorkData`) from the
    short-τ noise of its raw rate; see the module docstring. The result does not depend on
    any model."""
    fr = wd.frame
    steps, stepped = stimulus_steps(frame_channels(fr), fr.bounds, fr.n)
    tau, sig = robust_avar(fr.rate, fr.dt, fr.bounds, hadamard=True,
                           exclude=steps if stepped else None)
    ok = np.isfinite(sig) & (sig > 0) & (tau <= wd.duration_s / 4.0)
    tau, sig = tau[ok], sig[ok]
    t_eff = getattr(wd, "t_eff", wd.resolution_s)
    if len(tau) < 3:
        return st.NoiseFloor(float("nan"), float("nan"), float("nan"), (0.0, 0.0),
                             "record too short for an Allan estimate of the noise")
    N, B_h, (t_lo, t_hi) = white_flicker(tau, sig, wd.duration_s, se_factor=1.2)
    B = B_h / math.sqrt(HADAMARD_FLICKER)
    rms = floor_rms(N, B, 0.0, t_eff, wd.duration_s)
    basis = (f"white and flicker noise of the raw rate (robust Hadamard deviation over τ = "
             f"{tau[0]:.3g}–{t_lo:.3g} s, before environmental stimuli add to it; flicker "
             f"{'capped by the lowest excess up to ' + format(t_hi, '.3g') + ' s' if B > 0 else 'not detected'}"
             + (f"; windows across steps of {', '.join(stepped)} left out" if stepped else "")
             + f"), independent of the model; random walk not included; at T_eff = "
             f"{t_eff:.3g} s over {wd.duration_s:.0f} s")
    return st.NoiseFloor(rms, N, B, (float(tau[0]), float(t_hi)), basis)


def reference_floor(ref_log, wd, axis: str | None = None) -> st.NoiseFloor:
    """The noise floor from a static reference log (same gyro, no environmental stimulus):
    white, flicker and random-walk noise from its Allan variance (a τ² term removes a slow
    ramp), carried to this log's working resolution and length (:func:`floor_rms`)."""
    from .terms import frame_from_log

    fr = frame_from_log(ref_log, axis=axis or ref_log.axes[0],
                        dt=wd.frame.dt if wd.frame.dt > ref_log.tau0 * 1.5 else None)
    tau, sig = st.oadev(fr.rate, fr.dt, segments=fr.bounds)
    dur = fr.duration_s
    ok = np.isfinite(sig) & (sig > 0) & (tau <= dur / 8.0)
    tau, sig = tau[ok], sig[ok]
    t_eff = getattr(wd, "t_eff", wd.resolution_s)
    if len(tau) < 3:
        return st.NoiseFloor(float("nan"), float("nan"), float("nan"), (0.0, 0.0),
                             f"reference {ref_log.source} too short for an Allan estimate")
    cols = ["white", "flicker", "rw"]
    while True:  # keep only the noise terms the reference detects (> 2 standard errors)
        c = _fit_allan(tau, sig, dur, cols)
        cov = _cov(tau, sig, dur, cols)
        weak = [k for i, k in enumerate(cols) if k != "white"
                and not c[k] > 2.0 * math.sqrt(max(cov[i, i], 0.0))]
        if not weak:
            break
        cols.remove(weak[0])
    N = math.sqrt(c["white"])
    B = math.sqrt(c.get("flicker", 0.0))
    K = math.sqrt(c.get("rw", 0.0))
    rms = floor_rms(N, B, K, t_eff, wd.duration_s)
    basis = (f"white, flicker and random-walk noise of the static reference run "
             f"{ref_log.source} (Allan variance over {tau[0]:.3g}–{tau[-1]:.3g} s), "
             f"at T_eff = {t_eff:.3g} s over {wd.duration_s:.0f} s")
    fl = st.NoiseFloor(rms, N, B, (float(tau[0]), float(tau[-1])), basis)
    fl.random_walk_K = K  # type: ignore[attr-defined]
    return fl


def work_floor(wd) -> st.NoiseFloor:
    """The fixed noise floor of a prepared log: the reference run's when one was given
    (``wd.floor`` set by :func:`gyrotest.envmodel.prepare.prepare_log`), else the model-free
    estimate from the raw rate (computed once and kept on ``wd``)."""
    fl = getattr(wd, "floor", None)
    if fl is None:
        fl = model_free_floor(wd)
        wd.floor = fl
    return fl


def check_reference(ref_log, log, wd, floor: st.NoiseFloor) -> None:
    """A reference run must be the same kind of record: InputError (one line, naming the
    file and the fix) when its sample interval is not a divisor of the working grid or its
    white noise differs from the log's by more than 10× (another unit or another gyro)."""
    from ..errors import InputError

    own = model_free_floor(wd)
    if ref_log.tau0 > wd.frame.dt * (1 + 1e-6):
        raise InputError(f"--reference {ref_log.source}: sampled every {ref_log.tau0:g} s, "
                         f"coarser than the log's working grid ({wd.frame.dt:g} s); record "
                         "the reference at the log's sample rate or faster")
    if (math.isfinite(own.white_N) and math.isfinite(floor.white_N) and own.white_N > 0
            and floor.white_N > 0):
        r = floor.white_N / own.white_N
        if r > 10 or r < 0.1:
            raise InputError(f"--reference {ref_log.source}: its white noise "
                             f"({floor.white_N:.3g} (deg/h)·√s) is {r:.3g}× that of "
                             f"{log.source}; a different rate unit or another gyro? read it "
                             "with the same --rate-unit/--profile as the log")
