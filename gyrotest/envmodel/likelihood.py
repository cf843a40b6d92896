"""The gyro's own noise model and the Gaussian likelihood of a drift model under it.

Statistical model
-----------------
The workbench fits smoothed block means (:mod:`.workdata`): the gyro rate and every regressor
pass through the same smoother S_W and are averaged over blocks. For the likelihood, blocks are
averaged further into samples of Δ = g·T_b ≥ W (:func:`lik_grid`), so that the samples carry
the whole band the smoother passes and no more (at Δ = W the smoother still passes 16 % of the
power at the Nyquist frequency 1/(2Δ), so the covariance stays well conditioned). Within each
gap-free run of samples::

    d = D·y = D·X(θ)·β + D·η,        D·η ~ N(0, Σ(q))

D takes first differences (the bias drops out, and random-walk rate noise becomes stationary);
η is the IEEE 952 noise of the gyro seen through the same filters: white (angle random walk N),
flicker (bias instability B) and rate random walk K, with two-sided rate PSDs
N², B²/(2π|f|) and (K/2π)²/f² (IEEE Std 952-1997 Annex C). The autocovariance of D·η at lag
k·Δ is the integral

    γ(k) = ∫ S_Ω(f) · |H_W(f)|² · |H_Δ(f)|² · 4 sin²(πfΔ) · cos(2πfkΔ) df

with H_W the smoother (moving mean of L fine samples, twice: a Dirichlet kernel to the fourth
power) and H_Δ the box average over Δ; aliasing is included because the integral runs over the
whole band of the fine grid. Runs separated by gaps are independent (first differences within
each run). The exact Gaussian log-likelihood is computed with a Cholesky factor of the
Toeplitz Σ of each run; β enters by generalised least squares (GLS, closed form) and the
noise level σ² is profiled analytically, so a noise model has two free shape parameters (the
shares of white, flicker and random walk in the variance; :func:`fit_noise`).

Sources: IEEE Std 952-1997 Annex C; D. B. Percival, A. T. Walden, *Spectral Analysis for
Physical Applications*, CUP 1993 (filtered and sampled spectra); J. Durbin, S. J. Koopman,
*Time Series Analysis by State Space Methods*, OUP 2012 (differencing a random walk).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import linalg, optimize

from ..core.errors import AnalysisError
from .workbench_rules import NL_MAX  # noqa: E402  (computing budget of the likelihood)

#: fewest first differences a likelihood needs
MIN_DIFFS = 8
#: the noise components (key, unit of the parameter)
COMPONENTS = (("white", "N"), ("flicker", "B"), ("rw", "K"))
#: the keys of the variance shares, in order: the components and the Gauss–Markov term
SHARE_KEYS = tuple(k for k, _ in COMPONENTS) + ("gm",)


# ============================================================================ sample grid
@dataclass
class LikGrid:
    """Likelihood samples: means of ``g`` consecutive complete blocks within runs of
    consecutive blocks. ``idx`` lists the blocks used (run after run, g per sample);
    ``runs`` the (start, stop) sample ranges of the gap-free runs; ``t`` the sample times."""

    g: int
    delta_s: float
    idx: np.ndarray
    runs: list[tuple[int, int]]
    t: np.ndarray
    nb: int

    @property
    def n(self) -> int:
        return len(self.t)

    @property
    def m(self) -> int:
        """Number of first differences (the likelihood's observations)."""
        return sum(b - a - 1 for a, b in self.runs if b - a > 1)

    def means(self, a: np.ndarray) -> np.ndarray:
        """Sample means of a block-level array (nb,) or (nb, k)."""
        a = np.asarray(a, float)
        if a.ndim == 1:
            return a[self.idx].reshape(-1, self.g).mean(axis=1)
        return a[self.idx].reshape(-1, self.g, a.shape[1]).mean(axis=1)

    def diffs(self, a: np.ndarray) -> list[np.ndarray]:
        """First differences of a sample-level array, one array per run."""
        return [np.diff(a[s:e], axis=0) for s, e in self.runs if e - s > 1]


def lik_grid(wd, mask: np.ndarray | None = None, n_max: int = NL_MAX,
             g: int | None = None) -> LikGrid:
    """The likelihood samples of a prepared log (:class:`~gyrotest.envmodel.workdata.WorkData`):
    Δ = g·T_b with g = round(max(W, duration/``n_max``)/T_b) (at least 1); only complete
    blocks (as many fine samples as the block length) of the blocks in ``mask`` (default all)
    count, and a run ends at a gap, an incomplete block or a block outside the mask; ``g``
    forces the group size (a training subset on the grid of the whole log)."""
    tb = wd.resolution_s
    W = wd.refs.smoothing_s
    nb = wd.nb
    target = max(W, wd.duration_s / max(n_max, 1), tb)
    if g is None:
        g = max(1, int(round(target / tb)))
    full = wd.counts >= np.max(wd.counts) - 0.5 if nb else np.zeros(0, bool)
    ok = full.copy()
    if mask is not None:
        ok &= np.asarray(mask, bool)
    # a new run where consecutive blocks are not adjacent in time
    step_ok = np.zeros(nb, bool)
    if nb > 1:
        step_ok[1:] = np.abs(np.diff(wd.t) - tb) < 0.25 * tb
    idx: list[np.ndarray] = []
    runs: list[tuple[int, int]] = []
    t_out: list[np.ndarray] = []
    k = 0
    i = 0
    while i < nb:
        if not ok[i]:
            i += 1
            continue
        j = i + 1
        while j < nb and ok[j] and step_ok[j]:
            j += 1
        ns = (j - i) // g
        if ns >= 2:
            blk = np.arange(i, i + ns * g)
            idx.append(blk)
            t_out.append(wd.t[blk].reshape(ns, g).mean(axis=1))
            runs.append((k, k + ns))
            k += ns
        i = j
    if not runs:
        return LikGrid(g, g * tb, np.zeros(0, int), [], np.zeros(0), nb)
    return LikGrid(g, g * tb, np.concatenate(idx), runs, np.concatenate(t_out), nb)


# ============================================================================ spectra
def _dirichlet2(f: np.ndarray, L: int, dt: float) -> np.ndarray:
    """|mean of L samples|² transfer at frequency f (Hz) on a grid of step dt."""
    x = np.pi * f * dt
    num = np.sin(L * x)
    den = L * np.sin(x)
    out = np.ones_like(f)
    nz = np.abs(den) > 1e-300
    out[nz] = (num[nz] / den[nz]) ** 2
    return out


def component_psd(f: np.ndarray, key: str) -> np.ndarray:
    """Two-sided rate PSD of one IEEE 952 noise term with unit parameter, (deg/h)²/Hz.

    white: S = N² (N in (deg/h)·√s; σ²(τ) = N²/τ); flicker: S = B²/(2π|f|) (Allan plateau
    (2 ln 2/π)·B²); rate random walk: S = (K/2π)²/f² (K in (deg/h)/√s; σ²(τ) = K²τ/3).
    Source: IEEE Std 952-1997 Annex C, Table C.1."""
    f = np.abs(np.asarray(f, float))
    with np.errstate(divide="ignore"):
        if key == "white":
            return np.ones_like(f)
        if key == "flicker":
            return 1.0 / (2.0 * np.pi * f)
        if key == "rw":
            return (1.0 / (2.0 * np.pi)) ** 2 / (f * f)
    raise ValueError(key)


def gm_psd(f: np.ndarray, tau_c: float) -> np.ndarray:
    """Two-sided rate PSD of a first-order Gauss–Markov process of unit variance, (deg/h)²/Hz.

    S(f) = 2·T_c / (1 + (2π·f·T_c)²), with correlation time T_c (s): the autocovariance is
    σ²·exp(−|t|/T_c) and ∫S df = 1. In IEEE 952 terms q_c = σ·√(2/T_c) (S(0) = (q_c·T_c)²).
    Source: IEEE Std 952-1997 Annex C (correlated noise); A. Papoulis, *Probability, Random
    Variables and Stochastic Processes*, McGraw-Hill 1991 (the Lorentzian)."""
    f = np.abs(np.asarray(f, float))
    return 2.0 * tau_c / (1.0 + (2.0 * np.pi * f * tau_c) ** 2)


def _acov_kernel(dt: float, half: int, M: int, nlag: int) -> tuple[np.ndarray, np.ndarray, int, float]:
    """The frequency grid and integration weights of :func:`component_acov`: (f, weights
    |H_W|²·|H_Δ|²·4 sin²(πfΔ)·df, P, Δ)."""
    delta = M * dt
    L = 2 * half + 1
    P = 1 << int(math.ceil(math.log2(max(8 * nlag, 64))))
    df = 1.0 / (P * delta)
    fmax = min(0.5 / dt, 24.0 / (L * dt))
    nf = max(P, int(math.ceil(fmax / df)) + 1)
    f = np.arange(nf) * df
    H = _dirichlet2(f, L, dt) ** 2 * _dirichlet2(f, M, dt)
    w = np.full(nf, 2.0 * df)
    w[0] = df
    return f, H * 4.0 * np.sin(np.pi * f * delta) ** 2 * w, P, delta


def _fold(g: np.ndarray, P: int, nlag: int) -> np.ndarray:
    folded = np.bincount(np.arange(len(g)) % P, weights=g, minlength=P)
    return np.real(np.fft.fft(folded))[:nlag]


def component_acov(dt: float, half: int, M: int, nlag: int) -> dict[str, np.ndarray]:
    """Autocovariance (lags 0 … ``nlag`` − 1, at Δ = M·dt) of the first differences of the
    likelihood samples for each noise component with unit parameter (see the module
    docstring): fine grid step ``dt`` (s), smoother half-width ``half`` (moving mean of
    2·half + 1 samples, applied twice), box average of ``M`` fine samples.

    Numerical integration on f ∈ [0, f_max] with step 1/(P·Δ), P ≥ 8·nlag a power of two
    (the integrand is folded modulo P and one FFT gives every lag); f_max = min(1/(2·dt),
    24/W) (beyond, the smoother's sidelobes leave < 1e-6 of the variance)."""
    f, wk, P, delta = _acov_kernel(dt, half, M, nlag)
    out = {}
    for key, _ in COMPONENTS:
        g = np.empty(len(f))
        g[1:] = component_psd(f[1:], key) * wk[1:]
        # f → 0 limits: white and flicker vanish after differencing, random walk tends to Δ²
        # (the random walk's integrand tends to Δ², times the weight df = 1/(P·Δ))
        g[0] = delta / P if key == "rw" else 0.0
        out[key] = _fold(g, P, nlag)
    return out


def gm_acov(dt: float, half: int, M: int, nlag: int, tau_c: float) -> np.ndarray:
    """As :func:`component_acov` for a first-order Gauss–Markov rate of unit variance and
    correlation time ``tau_c`` (s) (:func:`gm_psd`)."""
    f, wk, P, _ = _acov_kernel(dt, half, M, nlag)
    return _fold(gm_psd(f, tau_c) * wk, P, nlag)


# ============================================================================ noise model
@dataclass
class NoiseParams:
    """The gyro's noise in IEEE 952 terms: N (deg/√h), B (deg/h), K (deg/h/√h), and a
    first-order Gauss–Markov rate of standard deviation ``gm_sigma`` (deg/h) and correlation
    time ``gm_tau_s`` (s) when the log needs one (0 and None otherwise)."""

    N: float
    B: float
    K: float
    loglik: float = math.nan
    fixed: bool = False  # from a reference run, not estimated on this log
    basis: str = ""
    gm_sigma: float = 0.0
    gm_tau_s: float | None = None

    @property
    def var(self) -> dict[str, float]:
        """Component parameters squared in the internal units of :func:`component_acov`:
        N² in (deg/h)²·s, B² in (deg/h)², K² in (deg/h)²/s."""
        return {"white": (self.N * 60.0) ** 2, "flicker": self.B ** 2,
                "rw": (self.K / 60.0) ** 2, "gm": self.gm_sigma ** 2}

    @property
    def markov(self) -> bool:
        return bool(self.gm_tau_s) and self.gm_sigma > 0

    def to_dict(self) -> dict:
        d = {"N_deg_per_sqrt_h": float(self.N), "B_deg_per_h": float(self.B),
             "K_deg_per_h_per_sqrt_h": float(self.K), "loglik": float(self.loglik),
             "from_reference": bool(self.fixed), "basis": self.basis}
        if self.markov:
            d["markov_sigma_deg_per_h"] = float(self.gm_sigma)
            d["markov_tau_s"] = float(self.gm_tau_s)
        return d

    def text(self) -> str:
        t = (f"N = {self.N:.3g} deg/√h, B = {self.B:.3g} deg/h, "
             f"K = {self.K:.3g} deg/h/√h")
        if self.markov:
            t += f", Gauss–Markov σ = {self.gm_sigma:.3g} deg/h with T_c = {self.gm_tau_s:.3g} s"
        return t


def params_from_shares(shares: np.ndarray, sigma2: float, gam0: dict[str, float],
                       tau_c: float | None = None) -> NoiseParams:
    """Noise parameters from the shares of the variance of the differenced samples and its
    level σ²: component c has parameter² = σ²·share_c / γ_c(0) (the fourth share, when
    given, is the Gauss–Markov term's at correlation time ``tau_c``)."""
    v = {k: sigma2 * s / gam0[k] if gam0.get(k, 0.0) > 0 else 0.0
         for k, s in zip(SHARE_KEYS, shares)}
    return NoiseParams(N=math.sqrt(max(v["white"], 0.0)) / 60.0,
                       B=math.sqrt(max(v["flicker"], 0.0)),
                       K=math.sqrt(max(v["rw"], 0.0)) * 60.0,
                       gm_sigma=math.sqrt(max(v.get("gm", 0.0), 0.0)),
                       gm_tau_s=tau_c if len(shares) > 3 else None)


def _shares(u: np.ndarray) -> np.ndarray:
    """Softmax of (0, u1, u2[, u3]): the shares of white, flicker, random walk[, Gauss–Markov];
    a fourth logit (ln T_c of the Gauss–Markov term) is not a share."""
    u = np.asarray(u, float)
    z = np.concatenate([[0.0], u[:3] if len(u) >= 4 else u])
    z = z - z.max()
    e = np.exp(z)
    return e / e.sum()


@dataclass
class Likelihood:
    """The Gaussian likelihood of block-level series on one :class:`LikGrid` under one noise
    shape; see the module docstring. ``shape`` gives the autocovariance of the differences
    up to the level σ² (``gamma = Σ_c share_c·γ_c/γ_c(0)``)."""

    grid: LikGrid
    gamma: np.ndarray
    factors: dict[int, np.ndarray] = field(default_factory=dict)
    logdet: float = 0.0

    @classmethod
    def build(cls, grid: LikGrid, gamma: np.ndarray) -> Likelihood:
        lk = cls(grid, np.asarray(gamma, float))
        ld = 0.0
        for a, b in grid.runs:
            n = b - a - 1
            if n < 1:
                continue
            L = lk._factor(n)
            ld += 2.0 * float(np.sum(np.log(np.diag(L))))
        lk.logdet = ld
        return lk

    def _factor(self, n: int) -> np.ndarray:
        L = self.factors.get(n)
        if L is None:
            g = self.gamma[:n].copy()
            g[0] *= 1.0 + 1e-10
            C = linalg.toeplitz(g)
            try:
                L = linalg.cholesky(C, lower=True, check_finite=False)
            except linalg.LinAlgError:
                C[np.diag_indices(n)] += 1e-8 * g[0]
                L = linalg.cholesky(C, lower=True, check_finite=False)
            self.factors[n] = L
        return L

    def whiten(self, a: np.ndarray) -> np.ndarray:
        """Σ^(−1/2)·D·(sample means of) a block-level array (nb,) or (nb, k): GLS becomes
        ordinary least squares on whitened rows."""
        return self.whiten_samples(self.grid.means(a))

    def whiten_samples(self, s: np.ndarray) -> np.ndarray:
        """Σ^(−1/2)·D of a sample-level array (n,) or (n, k)."""
        return self.whiten_diffs(self.grid.diffs(s), np.shape(s)[1:])

    def whiten_diffs(self, diffs: list[np.ndarray], tail: tuple = ()) -> np.ndarray:
        """Σ^(−1/2) of first differences already taken per run (:meth:`LikGrid.diffs`)."""
        parts = []
        for d in diffs:
            L = self._factor(len(d))
            parts.append(linalg.solve_triangular(L, d, lower=True, check_finite=False))
        if not parts:
            return np.zeros((0,) + tuple(tail))
        return np.concatenate(parts, axis=0)

    @property
    def m(self) -> int:
        return self.grid.m

    def loglik(self, rss: float, sigma2: float) -> float:
        """Gaussian log-likelihood of a whitened residual sum of squares at noise level σ²."""
        s2 = max(float(sigma2), 1e-300)
        return -0.5 * (self.m * math.log(2 * math.pi * s2) + self.logdet + rss / s2)

    def profile(self, rss: float) -> tuple[float, float]:
        """(log-likelihood with σ² profiled, σ̂²) for a whitened residual sum of squares."""
        m = self.m
        s2 = max(rss, 1e-300) / m
        return -0.5 * (m * math.log(2 * math.pi * s2) + self.logdet + m), s2


def gls(Xw: np.ndarray, yw: np.ndarray) -> tuple[np.ndarray, float, np.ndarray]:
    """Least squares on whitened rows: (β, RSS, (XᵀX)⁻¹). Columns that whitening made zero
    (a constant: the bias) get β = 0 and no variance; near-zero columns are dropped the same
    way."""
    p = Xw.shape[1] if Xw.ndim == 2 else 0
    if p == 0:
        return np.zeros(0), float(yw @ yw), np.zeros((0, 0))
    scale = np.sqrt(np.sum(Xw * Xw, axis=0))
    live = scale > 1e-12 * max(float(scale.max()), 1e-300)
    beta = np.zeros(p)
    cov = np.zeros((p, p))
    if live.any():
        A = Xw[:, live] / scale[live]
        Q, R = np.linalg.qr(A)
        qy = Q.T @ yw
        try:
            b = linalg.solve_triangular(R, qy, check_finite=False)
            Rinv = linalg.solve_triangular(R, np.eye(R.shape[0]), check_finite=False)
        except (linalg.LinAlgError, ValueError):
            b, *_ = np.linalg.lstsq(A, yw, rcond=None)
            Rinv = np.linalg.pinv(R)
        beta[live] = b / scale[live]
        ci = (Rinv @ Rinv.T) / np.outer(scale[live], scale[live])
        cov[np.ix_(live, live)] = ci
        r = yw - A @ b
    else:
        r = yw
    return beta, float(r @ r), cov


@dataclass
class NoiseFit:
    """A noise model fitted (or fixed) on one log: the parameters, the shares of the
    differenced variance, the likelihood object and the component autocovariances."""

    params: NoiseParams
    shares: np.ndarray
    lik: Likelihood
    acov: dict[str, np.ndarray]
    sigma2: float
    n_free: int = 2
    #: the optimiser's logits of the shares (a warm start for a related model)
    logits: np.ndarray | None = None
    #: autocovariance of the sensors' noise through the model's terms (absolute), or None;
    #: and each channel's part of it
    extra: np.ndarray | None = None
    extra_parts: dict = field(default_factory=dict)
    #: each channel's simulated realisations of that noise (block level, at the same
    #: coefficients; :func:`gyrotest.envmodel.sensors.eiv_series`)
    extra_series: dict = field(default_factory=dict)
    #: the noise level the likelihood's covariance is scaled by: σ² (the covariance is
    #: σ²·shape), or 1 when it holds the absolute covariance (with ``extra``)
    level: float | None = None

    @property
    def scale(self) -> float:
        return self.sigma2 if self.level is None else self.level

    @property
    def grid(self) -> LikGrid:
        return self.lik.grid


def acov_for(wd, grid: LikGrid) -> dict[str, np.ndarray]:
    """Unit-parameter component autocovariances of the differenced samples of ``grid``
    (cached on ``wd`` per sample length)."""
    cache = wd.acov_cache
    fr = wd.frame
    from .effects import smoothing_half

    half = smoothing_half(wd.refs.smoothing_s, fr.dt)
    m = int(round(wd.resolution_s / fr.dt))
    M = grid.g * m
    nlag = max(2, max((b - a for a, b in grid.runs), default=2))
    key = (M, half, nlag)
    if key not in cache:
        cache[key] = component_acov(fr.dt, half, M, nlag)
        cache[key]["_spec"] = np.array([fr.dt, half, M, nlag], float)
    return cache[key]


def with_markov(acov: dict[str, np.ndarray], tau_c: float) -> dict[str, np.ndarray]:
    """The component autocovariances of :func:`acov_for` plus a Gauss–Markov term of
    correlation time ``tau_c`` (s) under the key ``"gm"`` (cached per T_c to 0.1 %)."""
    dt, half, M, nlag = acov["_spec"]
    lt = round(math.log(tau_c), 3)
    memo = acov.setdefault("_gm", {})
    if lt not in memo:
        memo[lt] = gm_acov(float(dt), int(half), int(M), int(nlag), math.exp(lt))
    out = {k: v for k, v in acov.items() if not k.startswith("_")}
    out["gm"] = memo[lt]
    out["_spec"] = acov["_spec"]
    return out


def shape_gamma(acov: dict[str, np.ndarray], shares: np.ndarray) -> np.ndarray:
    """Autocovariance of the differences for shares of the variance (σ² = 1); a fourth share
    is the Gauss–Markov term's (``acov["gm"]``, :func:`with_markov`)."""
    g = np.zeros_like(acov["white"])
    for k, s in zip(SHARE_KEYS, shares):
        if s > 0 and acov[k][0] > 0:
            g = g + s * acov[k] / acov[k][0]
    return g


def fit_noise(wd, grid: LikGrid, resid_fn, *, start: np.ndarray | None = None,
              maxiter: int = 40, white: float | None = None,
              extra: np.ndarray | None = None, markov: bool = True) -> NoiseFit:
    """Maximum-likelihood noise model for the model whose whitened residual sum of squares at
    a given :class:`Likelihood` is ``resid_fn(lik) -> RSS`` (GLS inside): Nelder–Mead over
    the two logits of the white/flicker/random-walk shares of the differenced variance, from
    ``start`` (logits) or two standard starts.

    ``markov``: also try a first-order Gauss–Markov term (its share and ln T_c, with
    Δ ≤ T_c ≤ half the log; :func:`gm_psd`) and keep it when it lowers Akaike's criterion
    (twice the log-likelihood gain above 4, the term's two parameters): the noise model is a
    nuisance of every test, and a nuisance left too simple makes the tests too liberal,
    while one a little too rich only costs a little power. Real MEMS records carry
    correlated wander that white, flicker and random walk do not describe (the ADIS16405
    record's x axis gains 2Δℓ ≈ 8.7 with T_c ≈ 280 s), and a drift model judged under too
    simple a noise model names that wander as an effect. With a ``start`` (a
    related model's logits) the related model's choice stands: four logits keep the term
    (at its correlation time; the shares are refitted), two leave it out.

    ``white``: the white-noise parameter N² ((deg/h)²·s) measured on the full band of the
    log (:func:`white_level`); the level of the other two then follows from their shares.
    Without it, the level σ² is profiled and all three come from the likelihood's band
    alone, where a large effect the model lacks can take the place of the white noise.
    ``extra``: an autocovariance added to the gyro's (the noise the model's terms carry from
    their sensors, :func:`gyrotest.envmodel.sensors.eiv_acov`); used with ``white``."""
    if extra is not None and not (white and np.any(extra)):
        extra = None
    acov = acov_for(wd, grid)
    if grid.m < MIN_DIFFS:
        raise AnalysisError(f"{wd.info.get('source', 'log')}: only {grid.m} samples of "
                            f"{grid.delta_s:g} s for the noise model; the log is too short for "
                            "the working smoother (use a shorter --smooth)")
    memo: dict[tuple, tuple[float, Likelihood, float]] = {}
    lt_lo = math.log(grid.delta_s)
    span = (float(grid.t[-1] - grid.t[0]) if grid.n > 1 else grid.delta_s)
    lt_hi = max(lt_lo, math.log(max(span / 2.0, grid.delta_s)))

    def nll(u) -> float:
        u = np.asarray(u, float)
        key = tuple(np.round(u, 6))
        if key in memo:
            return -memo[key][0]
        sh = _shares(u)
        ac = with_markov(acov, math.exp(float(np.clip(u[3], lt_lo, lt_hi)))) if len(u) == 4 \
            else acov
        if extra is not None:
            s2 = white * float(acov["white"][0]) / max(sh[0], 1e-300)
            g = s2 * shape_gamma(ac, sh)
            n = min(len(g), len(extra))
            g[:n] += extra[:n]
            lk = Likelihood.build(grid, g)
            ll = lk.loglik(resid_fn(lk), 1.0)
            memo[key] = (ll, lk, s2)
            return -ll
        lk = Likelihood.build(grid, shape_gamma(ac, sh))
        rss = resid_fn(lk)
        if white:
            s2 = white * float(acov["white"][0]) / max(sh[0], 1e-300)
            ll = lk.loglik(rss, s2)
        else:
            ll, s2 = lk.profile(rss)
        memo[key] = (ll, lk, s2)
        return -ll

    def search(x0s: list[np.ndarray], it: int):
        best = None
        for x0 in x0s:
            d = len(x0)
            bounds = [(-18.0, 18.0)] * min(d, 3) + ([(lt_lo, lt_hi)] if d == 4 else [])
            x0 = np.clip(x0, [lo for lo, _ in bounds], [hi for _, hi in bounds])
            simplex = [x0] + [x0 + np.eye(d)[i] for i in range(d)]
            r = optimize.minimize(nll, x0, method="Nelder-Mead", bounds=bounds,
                                  options={"xatol": 0.1, "fatol": 0.05, "maxiter": it,
                                           "initial_simplex": simplex})
            if best is None or r.fun < best.fun:
                best = r
        return best

    start = None if start is None else np.asarray(start, float)
    if start is not None and len(start) == 4:
        # a related model keeps the Gauss–Markov correlation time; the shares are refitted
        lt_fix = float(start[3])
        start = np.append(np.clip(start[:3], -18.0, 18.0), lt_fix)
        r3 = optimize.minimize(lambda v: nll(np.append(v, lt_fix)), start[:3],
                               method="Nelder-Mead", bounds=[(-18.0, 18.0)] * 3,
                               options={"xatol": 0.1, "fatol": 0.05, "maxiter": maxiter,
                                        "initial_simplex": [start[:3]] + [
                                            start[:3] + np.eye(3)[i] for i in range(3)]})
        best = optimize.OptimizeResult(x=np.append(r3.x, lt_fix), fun=r3.fun)
    else:
        # from a related model's shape alone, else from two standard starts (mostly white;
        # even)
        best = search([start] if start is not None
                      else [np.array([-3.0, -3.0]), np.array([0.0, 0.0])], maxiter)
        if markov and start is None and lt_hi - lt_lo > math.log(4.0):
            # a coarse look first, at T_c = 2Δ … T/2 a factor 4 apart: the term beside the
            # fitted shape (a tenth of the variance) or in place of its flicker and random
            # walk; the search only from a look that raises the likelihood
            crit = 4.0  # Akaike: the term's two parameters must buy 2 units of ℓ each
            u0 = np.asarray(best.x, float)
            lts = np.arange(lt_lo + math.log(2.0), lt_hi + 1e-9, math.log(4.0))
            looks = ([np.concatenate([u0, [-2.0, lt]]) for lt in lts]
                     + [np.concatenate([u0 - 3.0, [max(u0.max(), 0.0), lt]]) for lt in lts])
            vals = [nll(x) for x in looks]
            if vals and min(vals) < best.fun:
                gm = search([looks[int(np.argmin(vals))]], maxiter)
                if 2.0 * (best.fun - gm.fun) > crit:
                    best = gm
    x = np.asarray(best.x, float)
    key = tuple(np.round(x, 6))
    if key not in memo:
        nll(x)
    ll, lk, s2 = memo[key]
    sh = _shares(x)
    tau_c = None
    if len(x) == 4:
        tau_c = math.exp(float(np.clip(x[3], lt_lo, lt_hi)))
        acov = with_markov(acov, tau_c)
    gam0 = {k: float(acov[k][0]) for k in SHARE_KEYS if k in acov}
    p = params_from_shares(sh, s2, gam0, tau_c)
    p.loglik = float(ll)
    nf = NoiseFit(p, sh, lk, acov, s2, n_free=len(x), logits=x, extra=extra)
    if extra is not None:
        nf.level = 1.0  # the likelihood holds the absolute covariance
    return nf


def white_level(wd) -> float:
    """The white-noise parameter N² ((deg/h)²·s) of a prepared log from its full band: the
    robust scale of the fine-grid rate's first differences, σ_d²/2·dt (white noise dominates
    the sample-to-sample changes; slow effects and steps do not move a median). Where the
    whole band is quantised to one level (no difference at all) it is 0: not measured."""
    from .frame import _white_sigma

    s = _white_sigma(wd.frame)
    return float(s * s * wd.frame.dt) if math.isfinite(s) else 0.0


def fixed_noise(wd, grid: LikGrid, params: NoiseParams) -> NoiseFit:
    """The likelihood under noise parameters given from outside (a static reference run):
    shares and level from the parameters, nothing estimated."""
    acov = acov_for(wd, grid)
    keys = [k for k, _ in COMPONENTS]
    if params.markov:
        acov = with_markov(acov, float(params.gm_tau_s))
        keys.append("gm")
    v = params.var
    tot = {k: v[k] * float(acov[k][0]) for k in keys}
    s2 = sum(tot.values())
    if not s2 > 0:
        raise AnalysisError("the reference noise model has no variance")
    sh = np.array([tot[k] / s2 for k in keys])
    lk = Likelihood.build(grid, shape_gamma(acov, sh))
    return NoiseFit(params, sh, lk, acov, s2, n_free=0)


def reference_noise(ref_log, wd, axis: str | None = None) -> NoiseParams:
    """The noise model of a static reference run of the same gyro (no stimulus), fitted by
    maximum likelihood through the same smoother, block length and sample length as the log
    ``wd`` it will judge (a bias only): the parameters are then fixed for every model of
    that log."""
    from .workdata import prepare

    ref = prepare(ref_log, axis=axis or ref_log.axes[0], resolution=wd.resolution_s,
                  smoothing_s=wd.refs.smoothing_s,
                  fine_dt=wd.frame.dt if wd.frame.dt >= ref_log.tau0 else None)
    grid = lik_grid(ref, g=max(1, int(round(lik_grid(wd).delta_s / ref.resolution_s))))

    def rss(lk) -> float:
        yw = lk.whiten(ref.y)
        return float(yw @ yw)

    nf = fit_noise(ref, grid, rss, white=white_level(ref) or None)
    p = nf.params
    return NoiseParams(p.N, p.B, p.K, loglik=math.nan, fixed=True,
                       gm_sigma=p.gm_sigma, gm_tau_s=p.gm_tau_s,
                       basis=f"the noise model of the static reference run {ref_log.source} "
                             f"({p.text()}, maximum likelihood), fixed")


__all__ = ["COMPONENTS", "LikGrid", "Likelihood", "NL_MAX", "NoiseFit", "NoiseParams",
           "acov_for", "component_acov", "component_psd", "fit_noise", "fixed_noise", "gls",
           "gm_acov", "gm_psd", "lik_grid", "reference_noise", "shape_gamma", "white_level",
           "with_markov"]
