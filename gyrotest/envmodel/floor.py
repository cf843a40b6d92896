"""The noise floor a drift model is judged against, estimated without the model.

A model is complete when its held-out residual is as small as the gyro's own noise allows at
the working resolution. If that floor were estimated from the residual of the model being
judged, every effect the model misses would raise the floor with the residual and hide
itself ("held-out/floor 1.6×" where the true misfit was 50×). gyrotest therefore estimates the
floor once per log, from data the model cannot influence, and holds it fixed through a
diagnosis and a model history:

* **short-τ noise of the raw rate** (default): the overlapping Allan variance of the raw rate
  (fine grid) is fitted over τ from the fine-grid step up to a quarter of the record with

      σ²(τ) = N²/τ + B² + C·τ + D·τ²          (non-negative least squares, relative errors)

  N (white) and B (flicker plateau, σ² = B² convention) are the noise.
  rate steps and random walk and D·τ² smooth environmental drift, which both grow with τ while
  the noise terms fall or stay flat, so slow environmental stimuli do not enter N and B.
  Random walk and steps are inseparable in σ²(τ); the floor therefore holds white and flicker
  noise only and says so.
* **a static reference run** (``--reference``): N, B and K fitted to the reference log's
  Allan variance over its whole τ range (σ² = N²/τ + B² + K²τ/3 + D·τ², the D term removing
  a slow ramp), random walk included.

Either is turned into the RMS of the block-mean residual at the working resolution by
:func:`floor_rms`.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import optimize

from . import stats as st

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
    funcs = {"quant": 1.0 / tau ** 2, "white": 1.0 / tau, "flicker": np.ones_like(tau),
             "rw": tau / 3.0, "drift": tau ** 2}
    w = 1.0 / _se(tau, sig, duration_s)
    A = np.column_stack([funcs[c] for c in cols]) * w[:, None]
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


def _model(c: dict[str, float], tau: np.ndarray) -> np.ndarray:
    funcs = {"quant": 1.0 / tau ** 2, "white": 1.0 / tau, "flicker": np.ones_like(tau),
             "rw": tau / 3.0, "drift": tau ** 2}
    return sum(v * funcs[k] for k, v in c.items())


def fit_noise_range(tau: np.ndarray, sig: np.ndarray, duration_s: float,
                    cols: tuple[str, ...] = ("quant", "white", "flicker"), z_max: float = 3.0
                    ) -> tuple[dict[str, float], int]:
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
        z = (sig[:k + 1] ** 2 - _model(trial, tau[:k + 1])) / _se(tau[:k + 1], sig[:k + 1],
                                                                  duration_s)
        if np.max(np.abs(z)) > z_max:
            break
        best, k = trial, k + 1
    return best, k


def white_flicker(tau: np.ndarray, sig: np.ndarray, duration_s: float, t_eff_s: float
                  ) -> tuple[float, float, tuple[float, float]]:
    """White N and flicker B of a rate from its Allan curve without being misled by slow
    environmental stimuli.

    Method: N from a fit of σ² = N²/τ to the τ up to max(T_eff/2, 3 points),
    where white noise dominates; then the flicker plateau as the lowest excess over white
    noise seen at τ from 2·τ0 up to T/8, B² = min_τ [σ²(τ) − N²/τ + SE(τ)/2]₊ (SE the standard
    error of σ²(τ)): flicker is flat in σ², while anything environmental only adds to it, so
    the lowest excess bounds the flicker from above and equals it where the environment is
    quiet. Returns (N (deg/h)·√s, B deg/h, (last τ of the white fit, last τ searched))."""
    keep = tau <= duration_s / 8.0
    if keep.sum() < 3:
        keep = np.arange(len(tau)) < 3
    tau, sig = tau[keep], sig[keep]
    c, k = fit_noise_range(tau, sig, duration_s, cols=("white", "flicker"), z_max=3.0)
    N = math.sqrt(c["white"])
    B2 = c["flicker"]
    t_lo = t_hi = float(tau[k - 1])
    sel = tau >= 2.0 * tau[0]
    if sel.any() and B2 > 0:
        ex = sig[sel] ** 2 - N * N / tau[sel] + _se(tau[sel], sig[sel], duration_s)
        B2 = min(B2, max(0.0, float(np.min(ex))))
        t_hi = float(tau[sel][-1])
    return N, math.sqrt(max(B2, 0.0)), (t_lo, t_hi)


def model_free_floor(wd) -> st.NoiseFloor:
    """The noise floor of a prepared log (:class:`~gyrotest.envmodel.fit.WorkData`) from the
    short-τ noise of its raw rate; see the module docstring. The result does not depend on
    any model."""
    fr = wd.frame
    tau, sig = st.oadev(fr.rate, fr.dt, segments=fr.bounds)
    ok = np.isfinite(sig) & (sig > 0) & (tau <= wd.duration_s / 4.0)
    tau, sig = tau[ok], sig[ok]
    t_eff = getattr(wd, "t_eff", wd.resolution_s)
    if len(tau) < 3:
        return st.NoiseFloor(float("nan"), float("nan"), float("nan"), (0.0, 0.0),
                             "record too short for an Allan estimate of the noise")
    N, B, (t_lo, t_hi) = white_flicker(tau, sig, wd.duration_s, t_eff)
    rms = floor_rms(N, B, 0.0, t_eff, wd.duration_s)
    basis = (f"white noise of the raw rate (Allan variance at τ ≤ {t_lo:.3g} s) and flicker "
             f"from the lowest Allan level it leaves over {t_eff:.3g}–{t_hi:.3g} s "
             "(environmental stimuli only add variance); independent of the model; random "
             f"walk not included; at T_eff = {t_eff:.3g} s over {wd.duration_s:.0f} s")
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
    ok = np.isfinite(sig) & (sig > 0) & (tau <= dur / 4.0)
    tau, sig = tau[ok], sig[ok]
    t_eff = getattr(wd, "t_eff", wd.resolution_s)
    if len(tau) < 3:
        return st.NoiseFloor(float("nan"), float("nan"), float("nan"), (0.0, 0.0),
                             f"reference {ref_log.source} too short for an Allan estimate")
    c = _fit_allan(tau, sig, dur, ["quant", "white", "flicker", "rw", "drift"])
    N, B, K = (math.sqrt(c[k]) for k in ("white", "flicker", "rw"))
    rms = floor_rms(N, B, K, t_eff, wd.duration_s)
    basis = (f"white, flicker and random-walk noise of the static reference run "
             f"{ref_log.source} (Allan variance over {tau[0]:.3g}–{tau[-1]:.3g} s), "
             f"at T_eff = {t_eff:.3g} s over {wd.duration_s:.0f} s")
    fl = st.NoiseFloor(rms, N, B, (float(tau[0]), float(tau[-1])), basis)
    fl.random_walk_K = K  # type: ignore[attr-defined]
    return fl
