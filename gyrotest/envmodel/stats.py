"""Small statistics of the model workbench: least squares, collinearity, the residual's
integrated autocorrelation time, its Allan deviation (the shared Allan core) and the noise
level at the working resolution. The likelihood and the tests are in
:mod:`gyrotest.envmodel.likelihood` and :mod:`gyrotest.envmodel.selection`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


def lstsq_coef(X: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Least-squares coefficients β = argmin ‖y − Xβ‖² (columns scaled for conditioning) of
    one series ``y`` or of each column of an n × K array (then p × K). Units: those of y per
    unit of each column."""
    scale = np.sqrt(np.sum(X * X, axis=0))
    scale[scale == 0] = 1.0
    beta_s, *_ = np.linalg.lstsq(X / scale, y, rcond=None)
    return beta_s / (scale if beta_s.ndim == 1 else scale[:, None])


def lstsq(X: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, float]:
    """Least-squares coefficients β of :func:`lstsq_coef` and the residual sum of squares
    RSS of the series ``y``."""
    beta = lstsq_coef(X, y)
    r = y - X @ beta
    return beta, float(r @ r)


def ols_covariance(X: np.ndarray, e: np.ndarray) -> np.ndarray:
    """Textbook OLS covariance σ²(XᵀX)⁻¹ with σ² = RSS/(n − k): correct only for
    independent residuals (shown for comparison)."""
    n, k = X.shape
    s2 = float(e @ e) / max(n - k, 1)
    scale = np.sqrt(np.sum(X * X, axis=0))
    scale[scale == 0] = 1.0
    Xs = X / scale
    return s2 * np.linalg.pinv(Xs.T @ Xs) / np.outer(scale, scale)


def integrated_time(e: np.ndarray, max_lag: int | None = None) -> float:
    """Integrated autocorrelation time of a residual series, in samples.

    Formula: τ_int = 1 + 2·Σ_{k≥1} ρ_k, summed until the first k with ρ_k ≤ 0 (or k ≥
    ``max_lag``, default n/10): the number of consecutive samples worth one independent one.
    Source: Sokal (1997) "Monte Carlo methods in statistical mechanics", §3.
    """
    x = np.asarray(e, float) - float(np.mean(e))
    n = len(x)
    v = float(x @ x)
    if n < 4 or v <= 0:
        return 1.0
    max_lag = max_lag or max(1, n // 10)
    nfft = 1 << int(math.ceil(math.log2(2 * n)))
    f = np.fft.rfft(x, nfft)
    acf = np.fft.irfft(f * np.conj(f), nfft)[:max_lag + 1] / v
    tau = 1.0
    for k in range(1, max_lag + 1):
        if acf[k] <= 0:
            break
        tau += 2.0 * acf[k]
    return float(tau)


def collinearity(X: np.ndarray, names: list[str]) -> tuple[float, dict[str, float], np.ndarray]:
    """Condition number of the column-normalised design (Belsley), variance inflation
    factors VIF_j = 1/(1 − R²_j) of each non-constant column regressed on the others (each
    column's residual computed by least squares, so an exact dependence reads as a VIF of
    order 1/rounding rather than whatever the inverse of a singular matrix happens to give),
    and the correlation matrix of the centred columns."""
    n, k = X.shape
    if k == 0:
        return 1.0, {}, np.zeros((0, 0))
    scale = np.sqrt(np.sum(X * X, axis=0))
    scale[scale == 0] = 1.0
    sv = np.linalg.svd(X / scale, compute_uv=False)
    cond = float(sv[0] / sv[-1]) if sv[-1] > 0 else float("inf")
    Xc = X - X.mean(axis=0)
    sd = Xc.std(axis=0)
    const = sd <= 1e-12 * (np.abs(X).max(axis=0) + 1e-300)
    vif: dict[str, float] = {}
    corr = np.full((k, k), np.nan)
    nz = np.where(~const)[0]
    if len(nz):
        Z = Xc[:, nz] / sd[nz]
        c = (Z.T @ Z) / n
        corr[np.ix_(nz, nz)] = c
        for i, j in enumerate(nz):
            others = np.delete(Z, i, axis=1)
            z = Z[:, i]
            if others.shape[1]:
                b, *_ = np.linalg.lstsq(others, z, rcond=None)
                r = z - others @ b
            else:
                r = z
            own = float(r @ r)
            tot = float(z @ z)
            vif[names[j]] = tot / own if own > 1e-300 * tot else float("inf")
    return cond, vif, corr


def oadev(rate: np.ndarray, tau0: float, taus: np.ndarray | None = None,
          segments: list[tuple[int, int]] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Overlapping Allan deviation of a rate series (deg/h), pooled over segments.

    Formula: σ²(τ) = Σ (θ_{k+2m} − 2θ_{k+m} + θ_k)² / (2τ²·Σ(N_s − 2m)), θ = cumulative
    angle τ0·Σω, τ = m·τ0 (IEEE 952 Annex C): the shared Allan core,
    :func:`gyrotest.noise.deviations.compute_deviation`. Returns (tau s, sigma deg/h); τ with no complete cluster is dropped.
    """
    from ..noise.deviations import compute_deviation

    rate = np.asarray(rate, dtype=np.float64)
    if segments is None:
        segments = [(0, len(rate))]
    res = compute_deviation(rate, tau0, input_kind="rate", kind="oadev",
                            taus="octave" if taus is None else list(taus),
                            segments=segments, noise_id=False)
    tau = np.asarray(res.tau, float)
    sig = np.asarray(res.sigma, float)
    ok = np.isfinite(sig)
    return tau[ok], sig[ok]


@dataclass
class NoiseFloor:
    """The residual RMS the gyro's noise alone leaves at the working resolution."""

    rms_dph: float  # predicted RMS of block-mean residuals (white, flicker, random walk)
    white_N: float  # (deg/h)·sqrt(s): σ²(τ) = N²/τ
    flicker_B: float  # deg/h: Allan plateau of the flicker part
    t_eff_s: float  # averaging time of the working filter
    duration_s: float  # record length
    basis: str
    random_walk_K: float = 0.0  # (deg/h)/sqrt(s): σ²(τ) = K²τ/3

    @property
    def arw_deg_rt_h(self) -> float:
        return self.white_N / 60.0

    @property
    def white_flicker_rms(self) -> float:
        """The RMS of the white and flicker part alone (:func:`.floor.floor_rms`)."""
        from .floor import floor_rms

        return floor_rms(self.white_N, self.flicker_B, 0.0, self.t_eff_s, self.duration_s)

    def to_dict(self) -> dict:
        return {"rms_dph": self.rms_dph, "white_N_dph_rts": self.white_N,
                "arw_deg_per_rt_h": self.arw_deg_rt_h, "flicker_plateau_dph": self.flicker_B,
                "random_walk_K_dph_per_rts": self.random_walk_K,
                "t_eff_s": self.t_eff_s, "duration_s": self.duration_s, "basis": self.basis}
