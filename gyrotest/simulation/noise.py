"""Random-drift generators: exact discretisations of the IEEE 952 noise terms.

Every generator returns the **average rate over each sample interval** in deg/h (what an
ideal pulse integrator delivers as S0*dN/dt), for ``n`` intervals of ``tau0`` s. Averaging
matters: the closed forms of :mod:`gyrotest.noise.terms` are for continuous averaging, and
with interval averages the discrete overlapping Allan variance at tau = m*tau0 equals them
exactly in expectation (for the FFT-shaped terms up to the finite frequency grid).

Parameters are in the internal second-based units of :mod:`gyrotest.noise.terms`
(N in (deg/h)*sqrt(s), K and q_c in (deg/h)/sqrt(s), R in (deg/h)/s); convert with
``TERMS[key].to_internal``.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from scipy import fft as sfft
from scipy import signal


def white_rate(rng: np.random.Generator, n: int, tau0: float, N: float) -> np.ndarray:
    """ARW: white rate, PSD S = N^2 -> interval averages are iid N(0, N^2/tau0).

    sigma^2(tau) = N^2/tau exactly (IEEE 952 Annex C, Krobka (Allan-graph topology) eq. 5.2).
    """
    return rng.standard_normal(n) * (N / math.sqrt(tau0))


def white_angle(rng: np.random.Generator, n: int, tau0: float, Q: float) -> np.ndarray:
    """White angle noise theta_k ~ N(0, Q^2) arcsec, rate = (theta_k - theta_(k-1))/tau0.

    sigma^2(tau) = 3 Q^2/tau^2 exactly at tau = m*tau0 (IEEE 952 Annex C quantization term).
    """
    th = rng.standard_normal(n + 1) * Q
    return np.diff(th) / tau0


def random_walk_rate(rng: np.random.Generator, n: int, tau0: float, K: float) -> np.ndarray:
    """RRW: rate W(t) = Brownian motion with diffusion K^2 ((deg/h)^2/s), W(0) = 0.

    Exact interval averages: mean of W over [t_(k-1), t_k] = W_(k-1) + dW_k/2 + xi_k with
    dW_k ~ N(0, K^2 tau0) and the Brownian-bridge average xi_k ~ N(0, K^2 tau0/12), independent.
    Gives sigma^2(tau) = K^2 tau/3 exactly (IEEE 952 Annex C, eq. 5.4).
    """
    dW = rng.standard_normal(n)
    dW *= K * math.sqrt(tau0)
    out = np.cumsum(dW)
    dW *= 0.5
    out -= dW  # W_(k-1) + dW_k/2
    del dW
    xi = rng.standard_normal(n)
    xi *= K * math.sqrt(tau0 / 12.0)
    out += xi
    return out


def _series_f(r: float) -> float:
    """f(r) = r - 2(1 - e^-r) + (1 - e^-2r)/2, without cancellation for small r."""
    if r > 1e-2:
        return r + 2.0 * math.expm1(-r) - 0.5 * math.expm1(-2.0 * r)
    acc = 0.0
    for k in range(3, 12):
        acc += (-1) ** (k + 1) * (2 ** (k - 1) - 2) * r**k / math.factorial(k)
    return acc


def markov_rate(rng: np.random.Generator, n: int, tau0: float, q_c: float, T_c: float,
                ) -> np.ndarray:
    """First-order Gauss-Markov rate x: dx = -x/T_c dt + q_c dW, stationary start.

    Exact: the state follows the AR(1) recursion x_k = phi x_(k-1) + e1_k, phi = e^(-tau0/T_c),
    Var e1 = (q_c^2 T_c/2)(1 - phi^2); the interval integral is
    I_k = T_c (1 - phi) x_(k-1) + e2_k with Var e2 = q_c^2 T_c^2 [tau0 - 2T_c(1-phi) +
    T_c(1-phi^2)/2] and Cov(e1, e2) = q_c^2 T_c^2 (1-phi)^2/2. The output is I_k/tau0.
    Process variance q_c^2 T_c/2, S(0) = (q_c T_c)^2; sigma^2(tau) is eq. (5.7) exactly.
    """
    r = tau0 / T_c
    phi = math.exp(-r)
    one_m_phi = -math.expm1(-r)
    v1 = q_c**2 * T_c / 2.0 * (-math.expm1(-2.0 * r))
    v2 = q_c**2 * T_c**3 * _series_f(r)
    c12 = q_c**2 * T_c**2 * one_m_phi**2 / 2.0
    l11 = math.sqrt(v1)
    l21 = c12 / l11 if l11 > 0 else 0.0
    l22 = math.sqrt(max(v2 - l21**2, 0.0))
    z1 = rng.standard_normal(n)
    z2 = rng.standard_normal(n)
    e1 = l11 * z1
    e2 = l21 * z1 + l22 * z2
    x0 = rng.standard_normal() * q_c * math.sqrt(T_c / 2.0)
    x, _ = signal.lfilter([1.0], [1.0, -phi], e1, zi=[phi * x0])
    x_prev = np.concatenate(([x0], x[:-1]))
    return (T_c * one_m_phi * x_prev + e2) / tau0


def markov_derivative_rate(rng: np.random.Generator, n: int, tau0: float, alpha: float,
                           beta: float) -> np.ndarray:
    """Blue noise S = alpha f^2/(beta^2 + f^2) (Krobka (Allan-graph topology) Table 7.3), exactly.

    It is white noise w (PSD alpha) minus its first-order low-pass y (T_c = 1/(2 pi beta)),
    i.e. Omega = T_c dy/dt; interval average = T_c (y_k - y_(k-1))/tau0 with y the exact
    AR(1) samples of the OU process of variance alpha/(2 T_c).
    """
    T_c = 1.0 / (2.0 * math.pi * beta)
    phi = math.exp(-tau0 / T_c)
    var = alpha / (2.0 * T_c)
    e = rng.standard_normal(n) * math.sqrt(var * (-math.expm1(-2.0 * tau0 / T_c)))
    y0 = rng.standard_normal() * math.sqrt(var)
    y, _ = signal.lfilter([1.0], [1.0, -phi], e, zi=[phi * y0])
    return T_c * np.diff(np.concatenate(([y0], y))) / tau0


def sinusoid_rate(n: int, tau0: float, amplitude: float, f0: float, phase_rad: float,
                  t_start: float = 0.0) -> np.ndarray:
    """Omega0 sin(2 pi f0 t + phase), averaged exactly over each interval (via the angle).

    theta(t) = -Omega0/(2 pi f0) cos(2 pi f0 t + phase); sample k covers
    [t_start + k tau0, t_start + (k+1) tau0]. sigma^2(tau) is eq. (5.8).
    """
    w = 2.0 * math.pi * f0
    t = t_start + tau0 * np.arange(n + 1)
    th = -(amplitude / w) * np.cos(w * t + phase_rad)
    return np.diff(th) / tau0


def fft_shaped_rate(rng: np.random.Generator, n: int, tau0: float,
                    S: Callable[[np.ndarray], np.ndarray], padding: int = 4,
                    f_max: float | None = None) -> np.ndarray:
    """Gaussian rate noise with two-sided PSD S(f) (deg/h)^2/Hz, as interval averages.

    Timmer & Koenig (1995) synthesis on a padded length M = next_fast_len(padding*n): each
    positive-frequency bin gets complex Gaussian amplitude with E|X_k|^2 = M fs S(f_k) |H(f_k)|^2,
    H(f) = sin(pi f tau0)/(pi f tau0) the interval-averaging response (so that the discrete
    Allan variance matches the continuous closed form), DC set to 0, inverse real FFT, first n
    samples kept. Padding breaks the periodicity of the FFT record and extends the lowest
    frequency to 1/(M tau0); power below it (and above fs/2) is not represented. ``f_max``: S is
    zero above it (only those bins are drawn). Used for the bias-instability flicker
    (band-limited to f0 <= fs/2: no aliasing) and for the blue families alpha f^n e^(-beta f),
    alpha f^n e^(-beta f^2) (accurate when S is negligible above fs/2).
    """
    M = sfft.next_fast_len(max(int(padding) * n, n + 1), real=True)
    if M % 2:
        M += 1
    fs = 1.0 / tau0
    half = M // 2
    kmax = half if f_max is None else min(half, int(math.floor(f_max * M * tau0)))
    # single precision for long records: twice as fast, 1e-6 relative rounding on a noise
    big = M > 2**22
    X = np.zeros(half + 1, dtype=np.complex64 if big else np.complex128)
    if kmax >= 1:
        f = np.arange(1, kmax + 1, dtype=np.float64) * (fs / M)
        with np.errstate(divide="ignore", invalid="ignore"):
            S_f = np.asarray(S(f), dtype=float)
        S_f = np.where(np.isfinite(S_f), S_f, 0.0)
        power = (M * fs) * S_f * np.sinc(f * tau0) ** 2  # E|X_k|^2; np.sinc(x) = sin(pi x)/(pi x)
        del f, S_f
        amp = np.sqrt(0.5 * power)
        X[1:kmax + 1].real = rng.standard_normal(kmax) * amp
        X[1:kmax + 1].imag = rng.standard_normal(kmax) * amp
        if kmax == half:  # the Nyquist bin is real
            X[half] = math.sqrt(power[-1]) * rng.standard_normal()
        del power, amp
    x = sfft.irfft(X, n=M, overwrite_x=True, workers=-1 if big else 1)
    return x[:n].astype(np.float64)


def flicker_rate(rng: np.random.Generator, n: int, tau0: float, B: float, f0: float,
                 padding: int = 4) -> np.ndarray:
    """Bias instability: PSD B^2/(2 pi f) for 0 < f <= f0 (IEEE 952 Annex C, eq. 5.3).

    FFT-shaped (:func:`fft_shaped_rate`); f0 must not exceed fs/2.
    """
    return fft_shaped_rate(rng, n, tau0, lambda f: B**2 / (2.0 * np.pi * f), padding, f_max=f0)
