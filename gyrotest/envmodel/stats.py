"""Statistics for the model workbench: least squares, autocorrelation-robust (HAC)
covariance, collinearity, information criteria, Allan deviation of residuals, noise floor.

Why HAC: gyro residuals are autocorrelated (flicker, Markov, random walk, unmodelled slow
effects). The textbook OLS covariance σ²(XᵀX)⁻¹ assumes independent samples; on 10⁵
correlated samples it understates the coefficient error by orders of magnitude. gyrotest uses
the Newey–West (Bartlett kernel) long-run covariance of the scores x_t·e_t with Andrews–
Monahan VAR(1) prewhitening and Andrews' (1991) AR(1) plug-in bandwidth:

    Cov(β) = (XᵀX)⁻¹ · S · (XᵀX)⁻¹,
    S = D·[Γ0 + Σ_{j=1..L} (1 − j/(L+1))·(Γj + Γjᵀ)]·Dᵀ,  Γj = Σ_t v_t v_{t−j}ᵀ,
    v_t = u_t − A·u_{t−1} (VAR(1) prewhitening of u_t = x_t·e_t), D = (I − A)⁻¹,
    L = 1.1447·(α̂·n)^{1/3}, α̂ = Σ 4ρ²σ⁴/((1−ρ)⁶(1+ρ)²) / Σ σ⁴/(1−ρ)⁴ (AR(1) fits per column).

Sources: Newey & West (1987) Econometrica 55:703; Andrews (1991) Econometrica 59:817;
Andrews & Monahan (1992) Econometrica 60:953.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import stats

#: largest eigenvalue modulus allowed in the VAR(1) prewhitening filter (Andrews–Monahan)
PREWHITEN_MAX_EIG = 0.97


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


def andrews_bandwidth(v: np.ndarray) -> tuple[float, float]:
    """Andrews (1991) AR(1) plug-in bandwidth for the Bartlett kernel.

    Formula: L = 1.1447·(α̂(1)·n)^{1/3}, α̂(1) = Σ_a 4ρ_a²σ_a⁴/((1−ρ_a)⁶(1+ρ_a)²) /
    Σ_a σ_a⁴/(1−ρ_a)⁴ with ρ_a, σ_a² from AR(1) fits of each column a of ``v`` (n × k).
    Returns (L, mean ρ). Source: Andrews (1991) eq. (6.4)-(6.6).
    """
    n = v.shape[0]
    num = den = 0.0
    rhos = []
    for a in range(v.shape[1]):
        x = v[:, a] - v[:, a].mean()
        x0, x1 = x[:-1], x[1:]
        d = float(x0 @ x0)
        if d <= 0:
            continue
        rho = float(np.clip((x0 @ x1) / d, -0.97, 0.97))
        s2 = float(np.mean((x1 - rho * x0) ** 2))
        num += 4 * rho ** 2 * s2 ** 2 / ((1 - rho) ** 6 * (1 + rho) ** 2)
        den += s2 ** 2 / (1 - rho) ** 4
        rhos.append(rho)
    if den <= 0:
        return 1.0, 0.0
    alpha = num / den
    L = 1.1447 * (alpha * n) ** (1.0 / 3.0)
    return float(min(max(L, 1.0), n / 2)), float(np.mean(rhos)) if rhos else 0.0


@dataclass
class HACInfo:
    """How the long-run covariance was estimated."""

    method: str
    bandwidth: float  # Bartlett lags (in blocks)
    prewhiten_eig: float  # largest eigenvalue modulus of the VAR(1) filter
    residual_rho1: float  # lag-1 autocorrelation of the residual

    def to_dict(self) -> dict:
        return {"method": self.method, "bandwidth_blocks": self.bandwidth,
                "prewhiten_max_eigenvalue": self.prewhiten_eig,
                "residual_lag1_autocorrelation": self.residual_rho1}


def hac_covariance(X: np.ndarray, e: np.ndarray, *, prewhiten: bool = True,
                   bandwidth: float | None = None) -> tuple[np.ndarray, HACInfo]:
    """Heteroskedasticity-and-autocorrelation-consistent covariance of LS coefficients.

    Formula: see the module docstring (Newey–West Bartlett kernel, VAR(1) prewhitening,
    Andrews AR(1) plug-in bandwidth). ``X`` n × k design (or Jacobian), ``e`` residuals.
    Returns (k × k covariance in the units of β², info).
    """
    n, k = X.shape
    u = X * e[:, None]
    A = None
    eig = 0.0
    v = u
    if prewhiten and n > 4 * k + 10:
        U0, U1 = u[:-1], u[1:]
        At, *_ = np.linalg.lstsq(U0, U1, rcond=None)
        A = At.T
        ev = np.linalg.eigvals(A)
        eig = float(np.max(np.abs(ev))) if len(ev) else 0.0
        if eig > PREWHITEN_MAX_EIG:
            # shrink the filter so that its largest eigenvalue is PREWHITEN_MAX_EIG
            uu, s, vt = np.linalg.svd(A)
            s = np.minimum(s, PREWHITEN_MAX_EIG)
            A = (uu * s) @ vt
            ev2 = np.linalg.eigvals(A)
            m2 = float(np.max(np.abs(ev2)))
            if m2 > PREWHITEN_MAX_EIG:
                A = A * (PREWHITEN_MAX_EIG / m2)
        v = U1 - U0 @ A.T
    if bandwidth is None:
        L, _ = andrews_bandwidth(v)
    else:
        L = float(bandwidth)
    Lint = int(math.floor(L))
    S = v.T @ v
    for j in range(1, Lint + 1):
        w = 1.0 - j / (L + 1.0)
        G = v[j:].T @ v[:-j]
        S += w * (G + G.T)
    if A is not None:
        D = np.linalg.inv(np.eye(k) - A)
        S = D @ S @ D.T * (n / (n - 1.0))
    scale = np.sqrt(np.sum(X * X, axis=0))
    scale[scale == 0] = 1.0
    Xs = X / scale
    XtX_inv = np.linalg.pinv(Xs.T @ Xs) / np.outer(scale, scale)
    cov = XtX_inv @ S @ XtX_inv
    cov = 0.5 * (cov + cov.T)
    ee = e - e.mean()
    rho1 = float((ee[1:] @ ee[:-1]) / (ee @ ee)) if float(ee @ ee) > 0 else 0.0
    info = HACInfo("Newey-West (Bartlett) with VAR(1) prewhitening, Andrews AR(1) bandwidth"
                   if A is not None else "Newey-West (Bartlett), Andrews AR(1) bandwidth",
                   L, eig, rho1)
    return cov, info


def ols_covariance(X: np.ndarray, e: np.ndarray) -> np.ndarray:
    """Textbook OLS covariance σ²(XᵀX)⁻¹ with σ² = RSS/(n − k): correct only for
    independent residuals (shown for comparison)."""
    n, k = X.shape
    s2 = float(e @ e) / max(n - k, 1)
    scale = np.sqrt(np.sum(X * X, axis=0))
    scale[scale == 0] = 1.0
    Xs = X / scale
    return s2 * np.linalg.pinv(Xs.T @ Xs) / np.outer(scale, scale)


def wald(beta: np.ndarray, cov: np.ndarray) -> tuple[float, float, float]:
    """Wald test that the coefficients ``beta`` are all zero.

    Formula: W = βᵀ Cov⁻¹ β ~ χ²_q. Returns (W, p, z) with z the standard-normal quantile of
    the same p-value (|z| for q = 1). Source: standard large-sample test.
    """
    beta = np.atleast_1d(beta)
    cov = np.atleast_2d(cov)
    q = len(beta)
    try:
        W = float(beta @ np.linalg.solve(cov, beta))
    except np.linalg.LinAlgError:
        W = float(beta @ np.linalg.pinv(cov) @ beta)
    if not np.isfinite(W) or W < 0:
        return float("nan"), float("nan"), float("nan")
    p = float(stats.chi2.sf(W, q))
    z = math.sqrt(W) if q == 1 else float(stats.norm.isf(max(p, 1e-300) / 2))
    return W, p, z


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


def effective_df(X: np.ndarray, idx: list[int], tau_int: float) -> float:
    """Effective degrees of freedom behind the coefficients ``idx`` of a design ``X``.

    Formula: for each column j in ``idx``, x̃_j = the part of column j not explained by the
    other columns; n_eff,j = (Σ x̃²)² / Σ x̃⁴ (participation ratio: how many observations carry
    the regressor); df = min_j n_eff,j / τ_int with τ_int the residual's integrated
    autocorrelation time (:func:`integrated_time`). A regressor that lives in a few blocks (a
    short transient) then gets a Student-t/F reference with few degrees of freedom instead of
    the normal one, for which the HAC asymptotics would be far too optimistic. Source:
    gyrotest (small-sample guard in the spirit of fixed-b HAC inference, Kiefer & Vogelsang
    2005).
    """
    k = X.shape[1]
    others = [j for j in range(k) if j not in idx]
    best = math.inf
    for j in idx:
        x = X[:, j]
        if others:
            b, _ = lstsq(X[:, others], x)
            x = x - X[:, others] @ b
        s2 = float(np.sum(x * x))
        s4 = float(np.sum(x ** 4))
        if s4 > 0:
            best = min(best, s2 * s2 / s4)
    if not math.isfinite(best):
        return 1.0
    return max(1.0, best / max(1.0, tau_int))


def wald_t(beta: np.ndarray, cov: np.ndarray, df: float) -> tuple[float, float, float]:
    """Wald test with a small-sample reference: t (q = 1) or F(q, df) (q > 1).

    Formula: W = βᵀ Cov⁻¹ β; p = P(|t_df| > √W) for q = 1, P(F_{q,df} > W/q) otherwise.
    Returns (W, p, z) with z the normal quantile of the same two-sided p.
    """
    beta = np.atleast_1d(beta)
    cov = np.atleast_2d(cov)
    q = len(beta)
    W, _, _ = wald(beta, cov)
    if not math.isfinite(W):
        return W, float("nan"), float("nan")
    if q == 1:
        p = float(2 * stats.t.sf(math.sqrt(W), df))
    else:
        p = float(stats.f.sf(W / q, q, df))
    z = float(stats.norm.isf(max(p, 1e-300) / 2))
    return W, p, z


def collinearity(X: np.ndarray, names: list[str]) -> tuple[float, dict[str, float], np.ndarray]:
    """Condition number of the column-normalised design (Belsley), variance inflation
    factors VIF_j = 1/(1 − R²_j) of each non-constant column regressed on the others, and the
    correlation matrix of the centred columns."""
    n, k = X.shape
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
        try:
            inv = np.linalg.inv(c)
            for i, j in enumerate(nz):
                vif[names[j]] = float(inv[i, i])
        except np.linalg.LinAlgError:
            for j in nz:
                vif[names[j]] = float("inf")
    return cond, vif, corr


def aic_bic(rss: float, n: int, p: int) -> tuple[float, float]:
    """Gaussian information criteria on n residuals with p fitted parameters.

    Formula: AIC = n·ln(RSS/n) + 2p, BIC = n·ln(RSS/n) + p·ln n. With autocorrelated
    residuals only differences between models fitted to the same data are meaningful.
    Source: Akaike (1974); Schwarz (1978).
    """
    if rss <= 0 or n <= 0:
        return float("nan"), float("nan")
    base = n * math.log(rss / n)
    return base + 2 * p, base + p * math.log(n)


# ----------------------------------------------------------------------------- Allan deviation
def octave_taus(tau0: float, n: int, max_frac: float = 0.25) -> np.ndarray:
    """Octave-spaced averaging times τ = 2^k·τ0 up to ``max_frac`` of the record."""
    m = 1
    out = []
    while m <= max_frac * n:
        out.append(m)
        m *= 2
    return np.array(out, dtype=float) * tau0


def oadev(rate: np.ndarray, tau0: float, taus: np.ndarray | None = None,
          segments: list[tuple[int, int]] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Overlapping Allan deviation of a rate series (deg/h), pooled over segments.

    Formula: σ²(τ) = Σ (θ_{k+2m} − 2θ_{k+m} + θ_k)² / (2τ²·Σ(N_s − 2m)), θ = cumulative
    angle τ0·Σω, τ = m·τ0 (GYRO_REFERENCE §4, IEEE 952 Annex C). Uses
    :func:`gyrotest.noise.deviations.compute_deviation` when that module is installed.
    Returns (tau s, sigma deg/h); τ with no complete cluster is dropped.
    """
    rate = np.asarray(rate, dtype=np.float64)
    if segments is None:
        segments = [(0, len(rate))]
    try:  # the shared Allan core (gyrotest.noise.deviations)
        from ..noise.deviations import compute_deviation  # type: ignore

        res = compute_deviation(rate, tau0, input_kind="rate", kind="oadev",
                                taus="octave" if taus is None else list(taus),
                                segments=segments, noise_id=False)
        tau = np.asarray(res.tau, float)
        sig = np.asarray(res.sigma, float)
        ok = np.isfinite(sig)
        return tau[ok], sig[ok]
    except Exception:  # pragma: no cover - fallback when the Allan core cannot serve the grid
        pass
    if taus is None:
        longest = max(b - a for a, b in segments)
        taus = octave_taus(tau0, longest)
    ms = np.unique(np.maximum(1, np.round(np.asarray(taus) / tau0).astype(int)))
    tau_out, sig_out = [], []
    thetas = []
    for a, b in segments:
        x = rate[a:b] - rate[a:b].mean() if b > a else rate[a:b]
        thetas.append(np.concatenate([[0.0], np.cumsum(x) * tau0]))
    for m in ms:
        num = 0.0
        cnt = 0
        for th in thetas:
            nn = len(th) - 1
            if nn < 2 * m + 1:
                continue
            d = th[2 * m:] - 2 * th[m:-m] + th[:-2 * m]
            num += float(d @ d)
            cnt += len(d)
        if cnt == 0:
            continue
        tau = m * tau0
        tau_out.append(tau)
        sig_out.append(math.sqrt(num / (2 * tau * tau * cnt)))
    return np.array(tau_out), np.array(sig_out)


@dataclass
class NoiseFloor:
    """The residual RMS expected from noise alone at the working resolution."""

    rms_dph: float  # predicted RMS of block-mean residuals
    white_N: float  # (deg/h)·sqrt(s): σ²(τ) = N²/τ
    flicker_B: float  # deg/h: Allan plateau of the flicker part
    tau_range_s: tuple[float, float]
    basis: str

    @property
    def arw_deg_rt_h(self) -> float:
        return self.white_N / 60.0

    def to_dict(self) -> dict:
        return {"rms_dph": self.rms_dph, "white_N_dph_rts": self.white_N,
                "arw_deg_per_rt_h": self.arw_deg_rt_h, "flicker_plateau_dph": self.flicker_B,
                "tau_range_s": list(self.tau_range_s), "basis": self.basis}


#: smoothing of the residual's periodogram for :func:`whittle_z`: each bin k is the mean of the
#: bins within max(WHITTLE_MIN_HALF, WHITTLE_FRAC·k) of it (log-like resolution)
WHITTLE_MIN_HALF = 4
WHITTLE_FRAC = 0.15


def smoothed_periodogram(e: np.ndarray) -> np.ndarray:
    """Smoothed one-sided periodogram of ``e`` (mean removed), I_k = |E_k|²/n averaged over
    the bins k' ≠ 0 with |k' − k| ≤ max(:data:`WHITTLE_MIN_HALF`, :data:`WHITTLE_FRAC`·k);
    (unit of e)² per bin, length n//2 + 1."""
    n = e.size
    per = np.abs(np.fft.rfft(e - e.mean())) ** 2 / n
    c = np.concatenate([[0.0], np.cumsum(per)])
    k = np.arange(per.size)
    h = np.maximum(WHITTLE_MIN_HALF, (WHITTLE_FRAC * k).astype(int))
    a = np.maximum(1, k - h)
    b = np.minimum(per.size, k + h + 1)
    return (c[b] - c[a]) / np.maximum(b - a, 1)


#: the low-frequency floor of :func:`red_floor`: a power law fitted to the smoothed periodogram
#: on the bins RED_BAND[0] … RED_BAND[1] bounds the bins below RED_BAND[0] from below, when its
#: slope is below RED_SLOPE (a red residual: flicker, random walk, bias instability)
RED_BAND = (6, 40)
RED_SLOPE = -0.5


def red_floor(S: np.ndarray) -> np.ndarray:
    """The smoothed periodogram ``S`` (:func:`smoothed_periodogram`) with its lowest bins
    k = 1 … k₀−1 raised to the power law S ≈ a·k^b fitted (least squares in log-log) on the
    bins k₀ … k₁ (:data:`RED_BAND`), b clipped to [−2, 0], when b < :data:`RED_SLOPE`.

    A regressor that varies as slowly as the record (a temperature settling, one chamber
    cycle) is fitted to whatever the residual holds at k = 1 … 5; the fitted model's own
    residual then lacks that power, and weighed against it the coefficient of a channel
    fitted to a gyro's slow wander looks precise (spectral z 7-11 on real MEMS noise with no
    effect behind it, ADIS16405 record, seeds 30138 and 30697). A wander that is red above
    k₀ (slope −1 for flicker, −2 for a random walk) goes on rising below it; the floor puts
    that back. A white residual (slope ≈ 0) is left as it is. Source: the power-law noise
    model behind the Allan variance (S(f) ∝ f^α with α = 0 white, −1 flicker, −2 random
    walk), IEEE Std 952-1997, Annex C."""
    k0, k1 = RED_BAND
    k = np.arange(S.size)
    band = (k >= k0) & (k <= min(k1, S.size - 1)) & (S > 0)
    if band.sum() < 3 or S.size <= k0:
        return S
    lk, ls = np.log(k[band]), np.log(S[band])
    b = float(np.polyfit(lk, ls, 1)[0])
    if not b < RED_SLOPE:
        return S
    b = max(b, -2.0)
    a = float(np.mean(ls - b * lk))
    out = S.copy()
    out[1:k0] = np.maximum(S[1:k0], np.exp(a + b * np.log(k[1:k0])))
    return out


def cosine_taper(a: np.ndarray, frac: float = 0.1) -> np.ndarray:
    """``a`` (samples along axis 0) multiplied by a split cosine bell: 1 in the middle, a
    half-cosine from 0 to 1 over ``frac``/2 of the record at each end. A linear operation:
    applied to y, X and e = y − Xβ alike it keeps the regression. Source: D. B. Percival and
    A. T. Walden, *Spectral Analysis for Physical Applications*, Cambridge University Press
    1993, §6.4 (data tapers; the split cosine bell, their eq. 209)."""
    a = np.asarray(a, dtype=float)
    n = a.shape[0]
    m = int(frac * n / 2)
    if m < 1:
        return a
    w = np.ones(n)
    ramp = 0.5 * (1.0 - np.cos(np.pi * (np.arange(m) + 0.5) / m))
    w[:m] = ramp
    w[n - m:] = ramp[::-1]
    return a * (w if a.ndim == 1 else w[:, None])


def whittle_z(X: np.ndarray, y: np.ndarray, e: np.ndarray, idx: list[int],
              red: bool = True) -> float:
    """Significance of the coefficients ``idx`` of the regression y ≈ Xβ against noise with
    the spectrum of the residual ``e``: frequency-domain generalised least squares (Whittle
    likelihood), β̂ = (X̃ᴴWX̃)⁻¹X̃ᴴWỹ, Cov = (X̃ᴴWX̃)⁻¹ with W = 1/(n·Ŝ_k) on the real FFT
    bins (k = 1 … n/2 counted twice), Ŝ = :func:`smoothed_periodogram` of e with the
    low-frequency floor of a red residual (:func:`red_floor`) unless ``red`` is False.

    Returns z = √(β̂ᵀCov⁻¹β̂ / q), the root-mean-square z of the q coefficients.

    X, y and e are first tapered (:func:`cosine_taper`, 10 %): the discrete Fourier transform
    treats a record as one period of a periodic series, and the jump from its last value to
    its first would otherwise appear in every bin. A regressor that trends over the record
    (a temperature settling) and a residual that wanders (a random walk) then share that
    sawtooth, and its high-frequency part, weighed against the residual's low white level,
    gives a coefficient fitted to the end-to-end difference a precision it does not have
    (spectral z 50-80 on real-noise nulls, 4-6 tapered).

    Unlike the HAC covariance, whose kernel bandwidth grows only as n^(1/3), the weights
    follow the residual's own spectrum to the lowest frequencies: a coefficient fitted to a
    slow wander that the model leaves in the residual (random walk, bias instability) is
    weighed against that wander. Sources: P. Whittle, "Estimation and information in
    stationary time series", Arkiv för Matematik 2 (1953) 423–434; E. J. Hannan, "Regression
    for time series", in Time Series Analysis (Rosenblatt, ed.), Wiley 1963.
    """
    n = y.size
    X, y, e = cosine_taper(X), cosine_taper(y), cosine_taper(e)
    S = smoothed_periodogram(e)
    if red:
        S = red_floor(S)
    pos = S > 0
    if not idx or n < 8 or not pos.any():
        return float("nan")
    w = np.where(pos, 2.0 / (n * np.where(pos, S, 1.0)), 0.0)
    w[0] /= 2.0
    if n % 2 == 0:
        w[-1] /= 2.0
    Xf = np.fft.rfft(X, axis=0)
    yf = np.fft.rfft(y)
    XW = Xf.conj().T * w
    A = (XW @ Xf).real
    b = (XW @ yf).real
    scale = np.sqrt(np.abs(np.diag(A)))
    scale[scale == 0] = 1.0
    cov = np.linalg.pinv(A / np.outer(scale, scale)) / np.outer(scale, scale)
    beta = cov @ b
    bi, ci = beta[idx], cov[np.ix_(idx, idx)]
    chi2 = float(bi @ np.linalg.pinv(ci) @ bi)
    return math.sqrt(max(chi2, 0.0) / len(idx)) if math.isfinite(chi2) else float("nan")
