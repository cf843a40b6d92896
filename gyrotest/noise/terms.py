"""Registry of gyro noise terms: closed-form Allan variances, rate PSDs and units.

Every entry of :data:`TERMS` describes one noise term of the IEEE Std 952-1997 catalogue
(Annex C) or one of Krobka's "zero PSD at zero frequency" (blue) families (Krobka (Allan-graph topology), §7,
Tables 7.1-7.3, with the errata of ``notes-allan-topology.md`` §2.7/§8 applied).

Conventions (the same everywhere in gyrotest)
---------------------------------------------
* Rate unit: deg/h. Time and tau: seconds. Frequency: Hz. 1 deg/h = 1 arcsec/s.
* ``avar(tau, **params)`` returns the Allan variance sigma^2(tau) in (deg/h)^2 for tau in s.
* ``psd(f, **params)`` returns the *two-sided* rate PSD S(f) in (deg/h)^2/Hz, evaluated on
  f > 0, normalised as in IEEE 952 Annex C / GYRO_REFERENCE §4:

      sigma^2(tau) = 4 * integral_0^inf S(f) sin^4(pi f tau) / (pi f tau)^2 df,

  so that white noise S = N^2 gives sigma^2 = N^2/tau and the variance of a sampled
  process is integral_{-fs/2}^{fs/2} S df.
* Parameters passed to ``avar``/``psd`` are in the **IEEE reporting units** listed by
  ``entry.params`` (N in deg/sqrt(h), K in deg/h/sqrt(h), R in deg/h/h, ...). The conversion
  to the internal second-based units is explicit: ``entry.to_internal(**p)`` /
  ``entry.from_internal(**p)``; each :class:`Param` carries its factor
  (internal = ``scale`` * reported).

  Example: N = 0.01 deg/sqrt(h) is 0.6 (deg/h)*sqrt(s) internally, because
  sigma(tau) = N_int/sqrt(tau[s]) and sigma(1 h) = N_int/sqrt(3600) = N_int/60 = N.
  Likewise K_int = K/60 (deg/h)/sqrt(s) and R_int = R/3600 (deg/h)/s.

Use :func:`avar_from_psd` to evaluate sigma^2(tau) numerically for any PSD (band-limited or
not); every closed form here is tested against it where the integral converges.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import special

from ..core.earth import OMEGA_E_DPH

__all__ = [
    "BIAS_INSTABILITY_PLATEAU",
    "EARTH_RATE_DPH",
    "PLATFORM_BENIGN_LABEL",
    "SEC_PER_HOUR",
    "TERMS",
    "NoiseTerm",
    "Param",
    "arw_from_sigma",
    "avar_from_psd",
    "get_term",
    "mixture_avar",
    "quantization_from_scale_factor",
    "sigma_from_arw",
]

SEC_PER_HOUR = 3600.0
SQRT_SEC_PER_HOUR = 60.0
#: sqrt(2 ln2 / pi): the bias-instability plateau sigma/B (IEEE 952 Annex C: "0.664").
BIAS_INSTABILITY_PLATEAU = math.sqrt(2.0 * math.log(2.0) / math.pi)
#: Sidereal earth rate, deg/h (7.2921150e-5 rad/s): the one in :mod:`gyrotest.core.earth`.
EARTH_RATE_DPH = OMEGA_E_DPH
PLATFORM_BENIGN_LABEL = "platform-benign / strapdown-critical"

ArrayLike = Any


# ---------------------------------------------------------------------------------------------
# Unit helpers
# ---------------------------------------------------------------------------------------------


def arw_from_sigma(sigma_dph: ArrayLike, tau_s: ArrayLike) -> ArrayLike:
    """Angle random walk N [deg/sqrt(h)] of the -1/2 line through sigma(tau).

    ``N = sigma(tau) * sqrt(tau) / 60`` with sigma in deg/h and tau in s (N equals sigma(1 s)
    in deg/h divided by 60, i.e. sigma at tau = 1 h). Applied to the leftmost point of an Allan
    graph this is Krobka's upper bound N_upper (Krobka (Allan-graph topology), §6; GYRO_REFERENCE §4 warning 1).
    Example (Optolink): sigma(1/2000 s) = 1 deg/h gives N_upper = 3.727e-4 deg/sqrt(h).
    """
    return np.asarray(sigma_dph) * np.sqrt(np.asarray(tau_s, dtype=float)) / SQRT_SEC_PER_HOUR


def sigma_from_arw(n_dpsh: ArrayLike, tau_s: ArrayLike) -> ArrayLike:
    """sigma(tau) [deg/h] of pure ARW N [deg/sqrt(h)]: ``60 N / sqrt(tau[s])``."""
    return SQRT_SEC_PER_HOUR * np.asarray(n_dpsh) / np.sqrt(np.asarray(tau_s, dtype=float))


def quantization_from_scale_factor(s0_arcsec: float) -> float:
    """Quantization coefficient Q [arcsec] of a pulse output with S0 arcsec/pulse: ``S0/sqrt(12)``.

    The angle error of pulse integration with remainder carry is uniform on [0, S0), variance
    S0^2/12; white angle noise of variance Q^2 has sigma^2 = 3 Q^2/tau^2 (IEEE 952 Annex C).
    """
    return float(s0_arcsec) / math.sqrt(12.0)


# ---------------------------------------------------------------------------------------------
# Closed forms, internal (second-based) units. Each documents formula, units and source.
# ---------------------------------------------------------------------------------------------


def _tau(tau: ArrayLike) -> np.ndarray:
    t = np.asarray(tau, dtype=float)
    if np.any(t <= 0):
        raise ValueError("tau must be > 0 s")
    return t


def quantization_avar(tau: ArrayLike, Q: float) -> np.ndarray:
    """Quantization / white angle noise: ``sigma^2 = 3 Q^2 / tau^2``.

    Q in arcsec, tau in s, sigma in deg/h (= arcsec/s). IEEE 952 Annex C (quantization
    noise), Krobka (Allan-graph topology) eq. (5.6). Exact at tau = m*tau0 for white angle noise of variance Q^2.
    """
    t = _tau(tau)
    return 3.0 * Q**2 / t**2


def quantization_psd(f: ArrayLike, Q: float, tau0: float) -> np.ndarray:
    """Quantization rate PSD ``(2 pi f)^2 tau0 Q^2`` for f < 1/(2 tau0), 0 above.

    (deg/h)^2/Hz with Q in arcsec, tau0 (sample interval) in s. IEEE 952 Annex C, Krobka (Allan-graph topology)
    eq. (5.6) (the approximation of (4Q^2/tau0) sin^2(pi f tau0)); with this band-limited form
    eq. (5.1) gives exactly 3Q^2/tau^2 at tau = 2k*tau0.
    """
    f = np.asarray(f, dtype=float)
    return np.where(f < 0.5 / tau0, (2 * np.pi * f) ** 2 * tau0 * Q**2, 0.0)


def arw_avar(tau: ArrayLike, N: float) -> np.ndarray:
    """Angle random walk: ``sigma^2 = N^2 / tau``.

    Internal units: N in (deg/h)*sqrt(s) (= 60 x N in deg/sqrt(h)), tau in s.
    IEEE 952 Annex C, Krobka (Allan-graph topology) eq. (5.2).
    """
    return N**2 / _tau(tau)


def arw_psd(f: ArrayLike, N: float) -> np.ndarray:
    """ARW rate PSD ``S = N^2`` (white), N in (deg/h)*sqrt(s); IEEE 952 Annex C, eq. (5.2)."""
    return np.full_like(np.asarray(f, dtype=float), N**2)


# (sin u / u)^4 Taylor coefficients in u^2 for the small-x series of the bias-instability form.
def _sinc4_series(nterms: int = 14) -> np.ndarray:
    sinc = np.array([(-1) ** k / math.factorial(2 * k + 1) for k in range(nterms)])
    s2 = np.convolve(sinc, sinc)[:nterms]
    return np.convolve(s2, s2)[:nterms]


_SINC4 = _sinc4_series()
# F(x) = int_0^x sin^4 u / u^3 du = sum_j c_j x^(2j+2)/(2j+2)
_BI_SERIES = _SINC4 / (2.0 * np.arange(len(_SINC4)) + 2.0)


def _bias_instability_F(x: np.ndarray) -> np.ndarray:
    """F(x) = int_0^x sin^4(u)/u^3 du = ln2 - sin^3x(sin x + 4x cos x)/(2x^2) + Ci(2x) - Ci(4x)."""
    x = np.asarray(x, dtype=float)
    out = np.empty_like(x)
    small = x < 0.5
    xs = x[small]
    x2 = xs**2
    acc = np.zeros_like(xs)
    for c in _BI_SERIES[::-1]:
        acc = acc * x2 + c
    out[small] = acc * x2
    xl = x[~small]
    if xl.size:
        s, c = np.sin(xl), np.cos(xl)
        _, ci2 = special.sici(2 * xl)
        _, ci4 = special.sici(4 * xl)
        out[~small] = math.log(2.0) - s**3 * (s + 4 * xl * c) / (2 * xl**2) + ci2 - ci4
    return out


def bias_instability_avar(tau: ArrayLike, B: float, f0: float) -> np.ndarray:
    """Bias instability (flicker rate noise with cut-off f0), the full IEEE form.

    ``sigma^2 = (2 B^2/pi) [ln2 - sin^3 x (sin x + 4x cos x)/(2x^2) + Ci(2x) - Ci(4x)]``,
    ``x = pi f0 tau`` (Krobka (Allan-graph topology) eq. (5.3), printed "x = pi f tau": erratum, it is f0). B in deg/h,
    f0 in Hz, tau in s. Equivalently (2B^2/pi) int_0^x sin^4 u/u^3 du. Limits: x -> 0:
    sigma ~ (x/sqrt(pi)) B (slope +1); x -> inf: sigma -> sqrt(2 ln2/pi) B = 0.6643 B, reached to
    99 % at x ~ 4.2 (tau ~ 1.34/f0). IEEE 952 Annex C.
    """
    t = _tau(tau)
    x = np.pi * f0 * t
    return (2.0 * B**2 / np.pi) * _bias_instability_F(np.atleast_1d(x)).reshape(x.shape)


def bias_instability_psd(f: ArrayLike, B: float, f0: float) -> np.ndarray:
    """Bias-instability rate PSD ``B^2/(2 pi f)`` for 0 < f <= f0, 0 above (deg/h)^2/Hz.

    IEEE 952 Annex C; Krobka (Allan-graph topology) eq. (5.3).
    """
    f = np.asarray(f, dtype=float)
    with np.errstate(divide="ignore"):
        return np.where((f > 0) & (f <= f0), B**2 / (2 * np.pi * f), 0.0)


def rrw_avar(tau: ArrayLike, K: float) -> np.ndarray:
    """Rate random walk: ``sigma^2 = K^2 tau / 3``.

    Internal units: K in (deg/h)/sqrt(s) (= K[deg/h/sqrt(h)]/60). IEEE 952 Annex C, eq. (5.4).
    """
    return K**2 * _tau(tau) / 3.0


def rrw_psd(f: ArrayLike, K: float) -> np.ndarray:
    """RRW rate PSD ``(K/2 pi)^2 / f^2``, K in (deg/h)/sqrt(s). IEEE 952 Annex C, eq. (5.4)."""
    f = np.asarray(f, dtype=float)
    return (K / (2 * np.pi)) ** 2 / f**2


def rate_ramp_avar(tau: ArrayLike, R: float) -> np.ndarray:
    """Rate ramp (deterministic Omega = R t): ``sigma^2 = R^2 tau^2 / 2``.

    Internal units: R in (deg/h)/s (= R[deg/h/h]/3600). IEEE 952 Annex C, Krobka (Allan-graph topology) eq. (5.5).
    Not obtainable from eq. (5.1): the formal PSD R^2/(2 pi f)^3 makes the integral diverge.
    """
    return R**2 * _tau(tau) ** 2 / 2.0


def rate_ramp_psd(f: ArrayLike, R: float) -> np.ndarray:
    """Formal rate-ramp PSD ``R^2/(2 pi f)^3`` (IEEE 952 Annex C); eq. (5.1) diverges with it."""
    f = np.asarray(f, dtype=float)
    return R**2 / (2 * np.pi * f) ** 3


def _markov_h(u: np.ndarray) -> np.ndarray:
    """h(u) = 1 - (3 - 4 e^-u + e^-2u)/(2u), with a series for small u (no cancellation)."""
    u = np.asarray(u, dtype=float)
    out = np.empty_like(u)
    small = u < 0.02
    us = u[small]
    # 3 - 4e^-u + e^-2u = sum_k c_k u^k, c_k = (-1)^k (2^k - 4)/k!; h = -sum_{k>=3} c_k u^(k-1)/2
    acc = np.zeros_like(us)
    for k in range(10, 2, -1):
        ck = (-1) ** k * (2**k - 4) / math.factorial(k)
        acc = acc * us + (-ck / 2.0)
    out[small] = acc * us**2
    ul = u[~small]
    out[~small] = 1.0 - (-4.0 * np.expm1(-ul) + np.expm1(-2.0 * ul)) / (2.0 * ul)
    return out


def markov_avar(tau: ArrayLike, q_c: float, T_c: float) -> np.ndarray:
    """First-order Gauss-Markov rate noise (correlation time T_c, driving intensity q_c).

    ``sigma^2 = ((q_c T_c)^2/tau) [1 - (T_c/(2 tau)) (3 - 4 e^(-tau/T_c) + e^(-2 tau/T_c))]``.
    Internal units: q_c in (deg/h)/sqrt(s) (= q_c[deg/h/sqrt(h)]/60), T_c and tau in s.
    Process variance q_c^2 T_c/2 (deg/h)^2; S(0) = (q_c T_c)^2. tau << T_c: q_c^2 tau/3
    (slope +1/2); tau >> T_c: (q_c T_c)^2/tau (ARW with N_eq = q_c T_c). Peak
    sigma = 0.436542 q_c sqrt(T_c) at tau = 1.89262 T_c. IEEE 952 Annex C; Krobka (Allan-graph topology) eq. (5.7).
    """
    t = _tau(tau)
    u = np.atleast_1d(t / T_c)
    return ((q_c * T_c) ** 2 / t) * _markov_h(u).reshape(t.shape)


def markov_psd(f: ArrayLike, q_c: float, T_c: float) -> np.ndarray:
    """Markov rate PSD ``(q_c T_c)^2 / (1 + (2 pi f T_c)^2)``; Krobka (Allan-graph topology) eq. (5.7)."""
    f = np.asarray(f, dtype=float)
    return (q_c * T_c) ** 2 / (1.0 + (2 * np.pi * f * T_c) ** 2)


def sinusoid_avar(tau: ArrayLike, Omega0: float, f0: float) -> np.ndarray:
    """Sinusoidal rate Omega0 sin(2 pi f0 t + phi): ``sigma^2 = Omega0^2 (sin^2(pi f0 tau)/(pi f0 tau))^2``.

    Omega0 (amplitude) in deg/h, f0 in Hz. Zeros at tau = k/f0; first lobe 0.724611 Omega0 at
    tau = 0.37101/f0. IEEE 952 Annex C; Krobka (Allan-graph topology) eq. (5.8).
    """
    x = np.pi * f0 * _tau(tau)
    return Omega0**2 * (np.sin(x) ** 2 / x) ** 2


def sinusoid_psd(f: ArrayLike, Omega0: float, f0: float) -> np.ndarray:
    """Continuous part of the sinusoid PSD: zero. The power sits in two lines, see ``lines``."""
    return np.zeros_like(np.asarray(f, dtype=float))


def sinusoid_lines(Omega0: float, f0: float) -> list[tuple[float, float]]:
    """Spectral lines of a sinusoid: weight Omega0^2/4 at each of +-f0.

    With the normalisation of eq. (5.1) (white S = N^2 -> N^2/tau; total variance =
    integral of the two-sided S over all f = Omega0^2/2), the line weight that reproduces
    eq. (5.8) is Omega0^2/4 at each of +f0 and -f0. The table form "1/2 Omega0^2 [delta(f-f0) +
    delta(f+f0)]" (IEEE 952 Annex C as quoted in Krobka (Allan-graph topology)) is a factor 2 larger in this
    normalisation; the Allan variance (5.8) itself is the checked quantity.
    """
    return [(float(f0), 0.25 * Omega0**2)]


def blue_markov_derivative_avar(tau: ArrayLike, alpha: float, beta: float) -> np.ndarray:
    """Blue family ``S = alpha f^2/(beta^2 + f^2)`` (Krobka (Allan-graph topology) Table 7.3).

    ``sigma^2 = (alpha/(4 beta pi tau^2)) (3 - 4 e^(-2 beta pi tau) + e^(-4 beta pi tau))``.
    alpha in (deg/h)^2/Hz, beta in Hz. It is the derivative of a Markov process, T_c = 1/(2 pi beta):
    white alpha at short tau (slope -1/2), white angle noise of variance alpha/(4 pi beta)
    arcsec^2 at long tau (slope -1); asymptotes cross at tau beta = 3/(4 pi).
    """
    t = _tau(tau)
    v = 2 * np.pi * beta * t
    return alpha / (4 * beta * np.pi * t**2) * (-4.0 * np.expm1(-v) + np.expm1(-2.0 * v))


def blue_markov_derivative_psd(f: ArrayLike, alpha: float, beta: float) -> np.ndarray:
    """``S = alpha f^2/(beta^2 + f^2)`` (deg/h)^2/Hz; Krobka (Allan-graph topology) Table 7.3."""
    f = np.asarray(f, dtype=float)
    return alpha * f**2 / (beta**2 + f**2)


def blue_exp_avar(tau: ArrayLike, alpha: float, beta: float, n: float) -> np.ndarray:
    """Blue family ``S = alpha f^n e^(-beta f)`` (Krobka (Allan-graph topology) Table 7.1(a), Table 7.2).

    n > 1: ``sigma^2 = alpha Gamma(n-1)/(4 pi^2 tau^2) [6 beta^(1-n) - 8 Re(beta + 2i pi tau)^(1-n)
    + 2 Re(beta + 4i pi tau)^(1-n)]``; n = 1: ``-(alpha/(4 pi^2 tau^2)) [ln(beta^2 + 16 pi^2 tau^2)
    - 4 ln(beta^2 + 4 pi^2 tau^2) + 6 ln beta]``. Checked against eq. (5.1) (n = 1 ... 4.5).
    alpha in (deg/h)^2/Hz^(n+1), beta in s (1/Hz). Slopes +1 (short) and -1 (long; n = 1 with a
    sqrt(ln tau) factor). The Table 7.2 row n = 3 is printed with 60 pi^4 tau^4: erratum, 64.
    """
    t = _tau(tau)
    if n == 1:
        return -(alpha / (4 * np.pi**2 * t**2)) * (
            np.log(beta**2 + 16 * np.pi**2 * t**2)
            - 4 * np.log(beta**2 + 4 * np.pi**2 * t**2)
            + 6 * np.log(beta)
        )
    if n <= 1:
        raise ValueError("blue_exp: n must be >= 1")
    p = 1.0 - n
    z2 = (beta + 2j * np.pi * t) ** p
    z4 = (beta + 4j * np.pi * t) ** p
    bracket = 6 * beta**p - 8 * z2.real + 2 * z4.real
    return alpha * special.gamma(n - 1) / (4 * np.pi**2 * t**2) * bracket


def blue_exp_psd(f: ArrayLike, alpha: float, beta: float, n: float) -> np.ndarray:
    """``S = alpha f^n e^(-beta f)`` (deg/h)^2/Hz; Krobka (Allan-graph topology) Table 7.1(a)."""
    f = np.asarray(f, dtype=float)
    return alpha * f**n * np.exp(-beta * f)


def blue_gauss_avar(tau: ArrayLike, alpha: float, beta: float, n: float) -> np.ndarray:
    """Blue family ``S = alpha f^n e^(-beta f^2)`` (Krobka (Allan-graph topology) Table 7.1(b), Table 7.2).

    ``sigma^2 = alpha/(4 pi^2 tau^2) beta^((1-n)/2) Gamma((n-1)/2) [3 + 1F1((n-1)/2; 1/2;
    -4 pi^2 tau^2/beta) - 4 1F1((n-1)/2; 1/2; -pi^2 tau^2/beta)]``, n > 1 (1F1: Kummer).
    alpha in (deg/h)^2/Hz^(n+1), beta in s^2. n = 2 reduces to alpha(3 + e^(-4pi^2tau^2/beta)
    - 4 e^(-pi^2 tau^2/beta))/(4 beta^(1/2) pi^(3/2) tau^2); n = 3 to the Dawson-function form.
    """
    t = _tau(tau)
    if n <= 1:
        raise ValueError("blue_gauss: n must be > 1")
    a = 0.5 * (n - 1)
    z = np.atleast_1d(np.pi**2 * t**2 / beta)
    bracket = np.empty_like(z)
    small = z < 0.05
    # small z: 3 + 1F1(-4z) - 4 1F1(-z) = sum_{k>=2} c_k (-z)^k (4^k - 4), c_k = (a)_k/((1/2)_k k!)
    zs = z[small]
    acc = np.zeros_like(zs)
    ck = 1.0
    for k in range(1, 30):
        ck *= (a + k - 1) / ((0.5 + k - 1) * k)
        if k >= 2:
            acc += ck * (-zs) ** k * (4.0**k - 4.0)
    bracket[small] = acc
    zl = z[~small]
    bracket[~small] = 3.0 + special.hyp1f1(a, 0.5, -4.0 * zl) - 4.0 * special.hyp1f1(a, 0.5, -zl)
    bracket = bracket.reshape(np.shape(t))
    return alpha / (4 * np.pi**2 * t**2) * beta ** (-a) * special.gamma(a) * bracket


def blue_gauss_psd(f: ArrayLike, alpha: float, beta: float, n: float) -> np.ndarray:
    """``S = alpha f^n e^(-beta f^2)`` (deg/h)^2/Hz; Krobka (Allan-graph topology) Table 7.1(b)."""
    f = np.asarray(f, dtype=float)
    return alpha * f**n * np.exp(-beta * f**2)


# ---------------------------------------------------------------------------------------------
# Numerical PSD -> Allan variance
# ---------------------------------------------------------------------------------------------

_GL_X, _GL_W = np.polynomial.legendre.leggauss(24)


def avar_from_psd(
    S: Callable[[np.ndarray], ArrayLike],
    tau: ArrayLike,
    f_max: float | None = None,
    *,
    lines: Iterable[tuple[float, float]] = (),
    breakpoints: Sequence[float] = (),
    n_half_periods: int = 4000,
) -> np.ndarray:
    """sigma^2(tau) = 4 int_0^f_max S(f) sin^4(pi f tau)/(pi f tau)^2 df, numerically.

    Krobka, Allan-graph topology, eq. (5.1); IEEE 952 Annex C. ``S`` is the two-sided rate PSD in (deg/h)^2/Hz
    (vectorised over f > 0), tau in s, result in (deg/h)^2. ``f_max`` is the band edge of a
    band-limited PSD (the integral stops there); without it the integral runs to infinity.

    Method: 24-point Gauss-Legendre on each half-period [k/(2 tau), (k+1)/(2 tau)] of the
    kernel (where sin^4 vanishes), on a geometric grid below 1/(2 tau) (down to 1e-9/tau,
    for PSDs with low-frequency structure) and across any ``breakpoints`` (cut-offs, corners);
    beyond ``n_half_periods`` half-periods the kernel is replaced by its mean 3/(8 (pi f tau)^2)
    and the tail integrated with ``scipy.integrate.quad``. ``lines`` = [(f_k, P_k), ...] adds
    spectral lines P_k [delta(f - f_k) + delta(f + f_k)] (two-sided), each contributing
    4 P_k sin^4(pi f_k tau)/(pi f_k tau)^2.
    """
    taus = np.atleast_1d(np.asarray(tau, dtype=float))
    out = np.empty_like(taus)
    for i, t in enumerate(taus):
        out[i] = _avar_from_psd_one(S, float(t), f_max, list(lines), breakpoints, n_half_periods)
    return out.reshape(np.shape(tau)) if np.ndim(tau) else out[0]


def _avar_from_psd_one(S, tau, f_max, lines, breakpoints, n_half) -> float:
    if tau <= 0:
        raise ValueError("tau must be > 0 s")
    h = 0.5 / tau
    geo = h * np.logspace(-9, 0, 91)
    top = n_half * h if f_max is None else min(f_max, n_half * h)
    grid = np.arange(1, int(np.floor(top / h)) + 1) * h
    edges = np.concatenate(([0.0], geo, grid, [top], np.asarray(breakpoints, dtype=float)))
    edges = np.unique(edges[(edges >= 0) & (edges <= top)])
    a, b = edges[:-1], edges[1:]
    mid, half = 0.5 * (a + b), 0.5 * (b - a)
    f = mid[:, None] + half[:, None] * _GL_X[None, :]
    x = np.pi * f * tau
    with np.errstate(divide="ignore", invalid="ignore"):
        kern = np.sin(x) ** 4 / x**2
        val = np.asarray(S(f), dtype=float) * kern
    val = np.where(np.isfinite(val), val, 0.0)
    total = 4.0 * float(np.sum(val * _GL_W[None, :] * half[:, None]))
    if f_max is None or f_max > top:
        # tail: sin^4 -> 3/8; with u = 1/f, int_top^fmax S(f)/f^2 df = int_(1/fmax)^(1/top) S(1/u) du
        u_lo = 0.0 if f_max is None else 1.0 / f_max

        def tail(u: float) -> float:
            if u <= 0.0:
                return 0.0
            return float(np.asarray(S(np.array([1.0 / u])), dtype=float)[0])

        from scipy import integrate  # imported on use: start-up time

        tval, _ = integrate.quad(tail, u_lo, 1.0 / top, limit=200)
        total += 4.0 * 0.375 / (np.pi * tau) ** 2 * tval
    for fk, pk in lines:
        xk = np.pi * fk * tau
        total += 4.0 * pk * np.sin(xk) ** 4 / xk**2
    return total


# ---------------------------------------------------------------------------------------------
# Registry
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Param:
    """One parameter of a noise term: reported (IEEE) unit and the factor to internal units.

    ``internal value = scale * reported value``.
    """

    name: str
    unit: str
    internal_unit: str
    scale: float
    description: str

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "unit": self.unit,
            "internal_unit": self.internal_unit,
            "scale_to_internal": self.scale,
            "description": self.description,
        }


@dataclass(frozen=True)
class NoiseTerm:
    """A registry entry: one noise term with its closed forms and units.

    ``avar``/``psd``/``lines``/``f_max`` take parameters in the reported (IEEE) units of
    ``params``; ``avar_internal``/``psd_internal`` take the internal (second-based) values.
    """

    key: str
    symbol: str
    title: str
    params: tuple[Param, ...]
    avar_internal: Callable[..., np.ndarray]
    psd_internal: Callable[..., np.ndarray]
    zero_dc_psd: bool
    slope_short: float
    slope_long: float
    source: str
    psd_formula: str
    avar_formula: str
    deterministic: bool = False
    lines_internal: Callable[..., list[tuple[float, float]]] | None = None
    band_edge: Callable[..., float | None] | None = None
    notes: str = ""
    _names: tuple[str, ...] = field(init=False, repr=False, default=())

    def __post_init__(self) -> None:
        object.__setattr__(self, "_names", tuple(p.name for p in self.params))

    # --- units ---------------------------------------------------------------------------
    def _check(self, params: Mapping[str, float], extra: Sequence[str] = ()) -> None:
        allowed = set(self._names) | set(extra)
        unknown = set(params) - allowed
        missing = set(self._names) - set(params)
        if unknown or missing:
            raise TypeError(
                f"{self.key}: parameters are {list(self._names)}"
                + (f"; unknown {sorted(unknown)}" if unknown else "")
                + (f"; missing {sorted(missing)}" if missing else "")
            )

    def to_internal(self, **params: float) -> dict[str, float]:
        """Reported (IEEE) units -> internal second-based units (extra keys pass through)."""
        scale = {p.name: p.scale for p in self.params}
        return {k: float(v) * scale.get(k, 1.0) for k, v in params.items()}

    def from_internal(self, **params: float) -> dict[str, float]:
        """Internal second-based units -> reported (IEEE) units (extra keys pass through)."""
        scale = {p.name: p.scale for p in self.params}
        return {k: float(v) / scale.get(k, 1.0) for k, v in params.items()}

    # --- closed forms in reported units ----------------------------------------------------
    def avar(self, tau: ArrayLike, **params: float) -> np.ndarray:
        """Allan variance sigma^2(tau) in (deg/h)^2, tau in s, params in reported units."""
        self._check(params)
        return self.avar_internal(tau, **self.to_internal(**params))

    def adev(self, tau: ArrayLike, **params: float) -> np.ndarray:
        """Allan deviation sigma(tau) in deg/h (square root of :meth:`avar`)."""
        return np.sqrt(self.avar(tau, **params))

    def psd(self, f: ArrayLike, tau0: float | None = None, **params: float) -> np.ndarray:
        """Two-sided rate PSD in (deg/h)^2/Hz at f > 0 (``tau0`` only for quantization)."""
        self._check(params)
        internal = self.to_internal(**params)
        if self.key == "quantization":
            if tau0 is None:
                raise TypeError("quantization psd needs tau0 (sample interval, s)")
            internal["tau0"] = tau0
        return self.psd_internal(f, **internal)

    def lines(self, **params: float) -> list[tuple[float, float]]:
        """Spectral lines [(f, P)] (two-sided weight P at +-f), for :func:`avar_from_psd`."""
        self._check(params)
        if self.lines_internal is None:
            return []
        return self.lines_internal(**self.to_internal(**params))

    def f_max(self, tau0: float | None = None, **params: float) -> float | None:
        """Band edge of the PSD (Hz) or None when it extends to infinity."""
        if self.band_edge is None:
            return None
        return self.band_edge(tau0=tau0, **self.to_internal(**params))

    @property
    def platform_benign(self) -> bool:
        """True when S(0) = 0: bounded angle error on a platform, growing in strapdown."""
        return self.zero_dc_psd

    @property
    def label(self) -> str:
        return PLATFORM_BENIGN_LABEL if self.zero_dc_psd else ""

    def to_dict(self) -> dict[str, Any]:
        return {
            "key": self.key,
            "symbol": self.symbol,
            "title": self.title,
            "params": [p.to_dict() for p in self.params],
            "psd": self.psd_formula,
            "avar": self.avar_formula,
            "zero_dc_psd": self.zero_dc_psd,
            "label": self.label,
            "slope_short": self.slope_short,
            "slope_long": self.slope_long,
            "deterministic": self.deterministic,
            "source": self.source,
            "notes": self.notes,
        }


_TERMS_LIST = [
    NoiseTerm(
        key="quantization",
        symbol="Q",
        title="Quantization noise (white angle noise)",
        params=(Param("Q", "arcsec", "arcsec", 1.0, "quantization coefficient; S0/sqrt(12)"),),
        avar_internal=quantization_avar,
        psd_internal=quantization_psd,
        zero_dc_psd=True,
        slope_short=-1.0,
        slope_long=-1.0,
        source="IEEE 952-1997 Annex C; Krobka (Allan-graph topology) eq. (5.6)",
        psd_formula="(2 pi f)^2 tau0 Q^2, f < 1/(2 tau0)",
        avar_formula="3 Q^2 / tau^2",
        band_edge=lambda tau0=None, **_: None if tau0 is None else 0.5 / tau0,
        notes="sigma(sqrt(3) s) = Q; pulse output: Q = S0/sqrt(12)",
    ),
    NoiseTerm(
        key="arw",
        symbol="N",
        title="Angle random walk (white rate noise)",
        params=(
            Param(
                "N",
                "deg/sqrt(h)",
                "(deg/h)*sqrt(s)",
                SQRT_SEC_PER_HOUR,
                "sigma at tau = 1 h; = sigma(1 s)[deg/h]/60",
            ),
        ),
        avar_internal=arw_avar,
        psd_internal=arw_psd,
        zero_dc_psd=False,
        slope_short=-0.5,
        slope_long=-0.5,
        source="IEEE 952-1997 Annex C; Krobka (Allan-graph topology) eq. (5.2)",
        psd_formula="N^2",
        avar_formula="N^2 / tau",
        notes="N[deg/sqrt(h)] = sigma(1 s)[deg/h] / 60",
    ),
    NoiseTerm(
        key="bias_instability",
        symbol="B",
        title="Bias instability (flicker rate noise with cut-off f0)",
        params=(
            Param("B", "deg/h", "deg/h", 1.0, "bias instability coefficient"),
            Param("f0", "Hz", "Hz", 1.0, "upper cut-off frequency of the 1/f PSD"),
        ),
        avar_internal=bias_instability_avar,
        psd_internal=bias_instability_psd,
        zero_dc_psd=False,
        slope_short=1.0,
        slope_long=0.0,
        source="IEEE 952-1997 Annex C; Krobka (Allan-graph topology) eq. (5.3) (x = pi f0 tau)",
        psd_formula="B^2/(2 pi f), 0 < f <= f0",
        avar_formula=(
            "(2B^2/pi)[ln2 - sin^3x(sin x + 4x cos x)/(2x^2) + Ci(2x) - Ci(4x)], x = pi f0 tau"
        ),
        band_edge=lambda f0, **_: f0,
        notes="plateau sigma = 0.6643 B for tau >~ 1.3/f0",
    ),
    NoiseTerm(
        key="rrw",
        symbol="K",
        title="Rate random walk",
        params=(
            Param(
                "K", "deg/h/sqrt(h)", "(deg/h)/sqrt(s)", 1.0 / SQRT_SEC_PER_HOUR, "sigma at tau = 3 h"
            ),
        ),
        avar_internal=rrw_avar,
        psd_internal=rrw_psd,
        zero_dc_psd=False,
        slope_short=0.5,
        slope_long=0.5,
        source="IEEE 952-1997 Annex C; Krobka (Allan-graph topology) eq. (5.4)",
        psd_formula="(K/2pi)^2 / f^2",
        avar_formula="K^2 tau / 3",
    ),
    NoiseTerm(
        key="rate_ramp",
        symbol="R",
        title="Rate ramp (deterministic)",
        params=(Param("R", "deg/h/h", "(deg/h)/s", 1.0 / SEC_PER_HOUR, "rate slope"),),
        avar_internal=rate_ramp_avar,
        psd_internal=rate_ramp_psd,
        zero_dc_psd=False,
        slope_short=1.0,
        slope_long=1.0,
        deterministic=True,
        source="IEEE 952-1997 Annex C; Krobka (Allan-graph topology) eq. (5.5)",
        psd_formula="R^2/(2 pi f)^3 (formal; eq. 5.1 diverges)",
        avar_formula="R^2 tau^2 / 2",
        notes="sigma(sqrt(2) h) = R; deterministic, not from eq. (5.1)",
    ),
    NoiseTerm(
        key="markov",
        symbol="q_c,T_c",
        title="First-order Gauss-Markov rate noise",
        params=(
            Param(
                "q_c",
                "deg/h/sqrt(h)",
                "(deg/h)/sqrt(s)",
                1.0 / SQRT_SEC_PER_HOUR,
                "driving-noise intensity; process std = q_c sqrt(T_c/2)",
            ),
            Param("T_c", "s", "s", 1.0, "correlation time"),
        ),
        avar_internal=markov_avar,
        psd_internal=markov_psd,
        zero_dc_psd=False,
        slope_short=0.5,
        slope_long=-0.5,
        source="IEEE 952-1997 Annex C; Krobka (Allan-graph topology) eq. (5.7)",
        psd_formula="(q_c T_c)^2 / (1 + (2 pi f T_c)^2)",
        avar_formula="((q_c T_c)^2/tau)[1 - (T_c/2tau)(3 - 4e^(-tau/T_c) + e^(-2tau/T_c))]",
        notes="peak 0.436542 q_c sqrt(T_c) at tau = 1.89262 T_c; long-tau ARW N_eq = q_c T_c",
    ),
    NoiseTerm(
        key="sinusoid",
        symbol="Omega0,f0",
        title="Sinusoidal rate",
        params=(
            Param("Omega0", "deg/h", "deg/h", 1.0, "amplitude"),
            Param("f0", "Hz", "Hz", 1.0, "frequency"),
        ),
        avar_internal=sinusoid_avar,
        psd_internal=sinusoid_psd,
        lines_internal=sinusoid_lines,
        zero_dc_psd=True,
        slope_short=1.0,
        slope_long=-1.0,
        source="IEEE 952-1997 Annex C; Krobka (Allan-graph topology) eq. (5.8)",
        psd_formula="lines Omega0^2/4 at +-f0 (total variance Omega0^2/2)",
        avar_formula="Omega0^2 (sin^2(pi f0 tau)/(pi f0 tau))^2",
        notes="first lobe 0.724611 Omega0 at tau = 0.37101/f0; nulls at k/f0",
    ),
    NoiseTerm(
        key="blue_markov_derivative",
        symbol="alpha,beta",
        title="Blue noise alpha f^2/(beta^2 + f^2) (derivative of a Markov process)",
        params=(
            Param("alpha", "(deg/h)^2/Hz", "(deg/h)^2/Hz", 1.0, "high-frequency level"),
            Param("beta", "Hz", "Hz", 1.0, "corner frequency; T_c = 1/(2 pi beta)"),
        ),
        avar_internal=blue_markov_derivative_avar,
        psd_internal=blue_markov_derivative_psd,
        zero_dc_psd=True,
        slope_short=-0.5,
        slope_long=-1.0,
        source="Krobka (Allan-graph topology) Table 7.3",
        psd_formula="alpha f^2 / (beta^2 + f^2)",
        avar_formula="(alpha/(4 beta pi tau^2))(3 - 4 e^(-2 beta pi tau) + e^(-4 beta pi tau))",
    ),
    NoiseTerm(
        key="blue_exp",
        symbol="alpha,beta,n",
        title="Blue noise alpha f^n exp(-beta f)",
        params=(
            Param("alpha", "(deg/h)^2/Hz^(n+1)", "(deg/h)^2/Hz^(n+1)", 1.0, "level"),
            Param("beta", "s", "s", 1.0, "exponential roll-off, 1/Hz"),
            Param("n", "1", "1", 1.0, "power of f, n >= 1"),
        ),
        avar_internal=blue_exp_avar,
        psd_internal=blue_exp_psd,
        zero_dc_psd=True,
        slope_short=1.0,
        slope_long=-1.0,
        source="Krobka (Allan-graph topology) Table 7.1(a), Table 7.2 (row n=3: 64 pi^4 tau^4, row n=2: 96 alpha)",
        psd_formula="alpha f^n exp(-beta f)",
        avar_formula=(
            "alpha Gamma(n-1)/(4 pi^2 tau^2)[6 beta^(1-n) - 8 Re(beta+2i pi tau)^(1-n)"
            " + 2 Re(beta+4i pi tau)^(1-n)]"
        ),
    ),
    NoiseTerm(
        key="blue_gauss",
        symbol="alpha,beta,n",
        title="Blue noise alpha f^n exp(-beta f^2)",
        params=(
            Param("alpha", "(deg/h)^2/Hz^(n+1)", "(deg/h)^2/Hz^(n+1)", 1.0, "level"),
            Param("beta", "s^2", "s^2", 1.0, "Gaussian roll-off, 1/Hz^2"),
            Param("n", "1", "1", 1.0, "power of f, n > 1"),
        ),
        avar_internal=blue_gauss_avar,
        psd_internal=blue_gauss_psd,
        zero_dc_psd=True,
        slope_short=1.0,
        slope_long=-1.0,
        source="Krobka (Allan-graph topology) Table 7.1(b), Table 7.2",
        psd_formula="alpha f^n exp(-beta f^2)",
        avar_formula=(
            "alpha/(4 pi^2 tau^2) beta^((1-n)/2) Gamma((n-1)/2)[3 + 1F1((n-1)/2;1/2;-4pi^2tau^2/beta)"
            " - 4 1F1((n-1)/2;1/2;-pi^2tau^2/beta)]"
        ),
    ),
]

#: The registry: key -> :class:`NoiseTerm`.
TERMS: dict[str, NoiseTerm] = {t.key: t for t in _TERMS_LIST}


def get_term(key: str) -> NoiseTerm:
    """Registry lookup with a helpful error listing the known keys."""
    try:
        return TERMS[key]
    except KeyError:
        raise KeyError(f"unknown noise term {key!r}; known: {', '.join(TERMS)}") from None


def mixture_avar(tau: ArrayLike, components: Iterable[tuple[str, Mapping[str, float]]]) -> np.ndarray:
    """Allan variance of independent noises: ``sigma^2 = sum sigma_i^2`` (Krobka (Allan-graph topology) eq. (5.9)).

    ``components`` = [(key, params in reported units), ...].
    """
    t = np.asarray(tau, dtype=float)
    total = np.zeros_like(t)
    for key, params in components:
        total = total + get_term(key).avar(t, **dict(params))
    return total
