"""Physical effects of the gyro drift model, one documented function each (pvlib style).

Each function maps channel arrays (numpy, physical units) to the regressor of one effect; its
docstring gives the formula, the units of the regressor and of its coefficient, and the source
(IEEE Std 952-1997 §8.3; V. Antonova and V. Matveev, thermal and magnetic drift of FOGs).
The registry that ties them to term names is :data:`gyrotest.envmodel.terms.EFFECTS`.

Conventions: time s, temperature degC, temperature rate degC/h, field uT normalised by
H0 = 100 uT, supply V, rates deg/h.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import signal

#: magnetic-field normaliser H0, uT (Antonova & Matveev: close to the Earth's field; w in deg/h per 100 uT)
H0_UT = 100.0
SEC_PER_HOUR = 3600.0


def bias(n: int) -> np.ndarray:
    """Constant bias regressor.

    Formula: x = 1. Units: dimensionless; coefficient D_F in deg/h (includes the earth-rate
    component along the IA unless removed). Source: IEEE Std 952-1997 §8.3, drift term D = D_F + ...
    """
    return np.ones(n)


def temperature_offset(temp_c: np.ndarray, t_ref_c: float, power: int = 1) -> np.ndarray:
    """Temperature offset from the reference, to a power.

    Formula: x = (T − T_ref)^p, p = 1, 2, 3. Units: degC^p; coefficient deg/h/degC^p
    (D_T, D_T2, D_T3; Antonova's w1, w2). Source: IEEE Std 952-1997 §8.3 E = D_T·ΔT + ...;
    Antonova & Matveev eq. (3) Δω = Σ w_i·(t_f − t0)^i.
    """
    return (np.asarray(temp_c, float) - t_ref_c) ** power


def moving_mean(x: np.ndarray, half: int, bounds: list[tuple[int, int]] | None = None
                ) -> np.ndarray:
    """Centred moving mean over 2·half + 1 samples within each segment (the window shrinks
    symmetrically near the segment ends). Units: those of x."""
    x = np.asarray(x, dtype=np.float64)
    out = np.empty_like(x)
    w = 2 * half + 1
    for a, b in bounds or [(0, len(x))]:
        seg = x[a:b]
        n = len(seg)
        if n == 0:
            continue
        off = seg[0]
        c = np.empty(n + 1)
        c[0] = 0.0
        np.cumsum(seg - off, out=c[1:])
        if n >= w:
            # the full window on slices; only the ends take the shrinking one
            out[a + half:b - half] = (c[w:] - c[:n + 1 - w]) / w + off
            k = np.concatenate([np.arange(half), np.arange(n - half, n)])
        else:
            k = np.arange(n)
        h = np.minimum(np.minimum(k, n - 1 - k), half)
        out[a + k] = (c[k + h + 1] - c[k - h]) / (2 * h + 1) + off
    return out


def smoothing_half(window_s: float, dt: float) -> int:
    """Half-width in samples of the moving mean of the working smoother for window W."""
    return max(1, int(round(window_s / dt / 2.0)))


def smooth(x: np.ndarray, dt: float, window_s: float,
           bounds: list[tuple[int, int]] | None = None) -> np.ndarray:
    """The working smoother S_W: a centred moving mean over W applied twice.

    Formula: S_W x = MA_W(MA_W(x)), a triangular kernel of total width 2W and unit area
    (half-power period ≈ 2.3·W). gyrotest applies S_W to the gyro rate *and* to every regressor
    before block averaging, so a model linear in its coefficients stays exact and the
    derivative regressor d(S_W T)/dt = S_W(dT/dt) carries no smoothing bias. Units: those of x.
    Source: gyrotest (matched filtering of output and regressors).
    """
    h = smoothing_half(window_s, dt)
    return moving_mean(moving_mean(x, h, bounds), h, bounds)


def smoothed_rate(x: np.ndarray, dt: float, window_s: float,
                  bounds: list[tuple[int, int]] | None = None) -> np.ndarray:
    """Time derivative of a noisy channel, per hour: the derivative of the smoothed series.

    Formula: dx/dt ≈ d(S_W x)/dt · 3600 (central differences), S_W = moving mean over W applied
    twice (:func:`smooth`), i.e. S_W(dx/dt): the true rate seen through a triangular kernel of
    total width 2W. White sensor noise σ (per sample at interval dt) leaves a derivative noise
    of about σ·√(2·dt/W³)·3600 per hour. Near segment ends the windows shrink (the fit leaves
    those samples out). Units: (unit of x)/h. Source: IEEE 952 §8.3 D_Ṫ·dT/dt; Antonova & Matveev
    ΔV_t = Δt/τ (degC/h); smoothing: gyrotest (stated window W).
    """
    x = np.asarray(x, dtype=np.float64)
    out = np.empty_like(x)
    xs = smooth(x, dt, window_s, bounds)
    for a, b in bounds or [(0, len(x))]:
        if b - a < 2:
            out[a:b] = 0.0
            continue
        out[a:b] = np.gradient(xs[a:b], dt) * SEC_PER_HOUR
    return out


def temperature_rate(temp_c: np.ndarray, dt: float, window_s: float,
                     bounds: list[tuple[int, int]] | None = None) -> np.ndarray:
    """Temperature rate dT/dt in degC/h from a noisy sensor (see :func:`smoothed_rate`).

    Formula: dT/dt ≈ d(S_W T)/dt · 3600, S_W = moving mean over W applied twice. Units: degC/h; coefficient
    (deg/h)/(degC/h) = deg/degC (IEEE D_Ṫ; Antonova–Matveev w_ΔV, 1.997 deg/degC in their
    FOG). Source: IEEE Std 952-1997 §8.3 E-term D_Ṫ·dT/dt; Antonova & Matveev eq. (3).
    """
    return smoothed_rate(temp_c, dt, window_s, bounds)


def gradient_rate(temp_a_c: np.ndarray, temp_b_c: np.ndarray, dt: float, window_s: float,
                  bounds: list[tuple[int, int]] | None = None) -> np.ndarray:
    """Rate of change of a temperature difference (time-varying gradient).

    Formula: d(T_a − T_b)/dt, smoothed as in :func:`smoothed_rate`. Units: degC/h;
    coefficient (deg/h)/(degC/h) (IEEE D_∇Ṫ; the Shupe effect of a FOG coil).
    Source: IEEE Std 952-1997 §8.3 E-term D_∇Ṫ·d(∇T)/dt.
    """
    return smoothed_rate(np.asarray(temp_a_c, float) - np.asarray(temp_b_c, float), dt,
                         window_s, bounds)


def first_order_lag(x: np.ndarray, t: np.ndarray, tau_s: float,
                    bounds: list[tuple[int, int]] | None = None) -> np.ndarray:
    """First-order lag of a channel (what a body with thermal time constant τ follows).

    Formula: τ·dy/dt = x − y, y(0) = x(0); discretised exactly for a piecewise-constant input:
    y_k = a·y_{k−1} + (1 − a)·x_k, a = exp(−Δt/τ). Across a gap of length g the state relaxes
    towards the first value after the gap with factor exp(−g/τ). Units: those of x; τ in s.
    Source: standard lumped thermal model (gyro core lags the case sensor).
    """
    x = np.asarray(x, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64)
    if bounds is None:
        bounds = [(0, len(x))]
    out = np.empty_like(x)
    y_prev, t_prev = None, None
    for a, b in bounds:
        if b <= a:
            continue
        seg = x[a:b]
        dt = float(t[a + 1] - t[a]) if b - a > 1 else 1.0
        alpha = math.exp(-dt / tau_s)
        if y_prev is None:
            y0 = seg[0]
        else:
            g = math.exp(-max(float(t[a] - t_prev), 0.0) / tau_s)
            y0 = g * y_prev + (1 - g) * seg[0]
        # y_0 = y0, then y_k = alpha*y_{k-1} + (1-alpha)*x_k
        y = np.empty(b - a)
        y[0] = y0
        if b - a > 1:
            y[1:], _ = signal.lfilter([1 - alpha], [1.0, -alpha], seg[1:], zi=[alpha * y0])
        out[a:b] = y
        y_prev, t_prev = y[-1], t[b - 1]
    return out


def lagged_temperature(temp_c: np.ndarray, t: np.ndarray, tau_s: float, t_ref_c: float,
                       bounds: list[tuple[int, int]] | None = None) -> np.ndarray:
    """Lagged (core) temperature offset.

    Formula: ΔT_core = T_core − T_ref with τ·dT_core/dt = T_sensor − T_core (see
    :func:`first_order_lag`), τ fitted. Units: degC; coefficient deg/h/degC (D_T of the core);
    τ in s. Source: IEEE 952 §8.3 D_T·ΔT applied to the core temperature; the sensor/core lag
    is the usual reason a plain D_T·ΔT fit of a chamber ramp shows loops.
    """
    return first_order_lag(temp_c, t, tau_s, bounds) - t_ref_c


def lagged_temperature_square(temp_c: np.ndarray, t: np.ndarray, tau_s: float, t_ref_c: float,
                              bounds: list[tuple[int, int]] | None = None) -> np.ndarray:
    """Square of a lagged (core) temperature offset.

    Formula: x = (T_core − T_ref)², τ·dT_core/dt = T_sensor − T_core (see
    :func:`first_order_lag`), τ fitted. Units: degC²; coefficient deg/h/degC² (the quadratic
    sensitivity w2 of a node that lags the logged sensor). Source: Antonova & Matveev eq. (3)
    w2·t² applied to the core temperature; IEEE 952 §8.3 D_T2.
    """
    return lagged_temperature(temp_c, t, tau_s, t_ref_c, bounds) ** 2


def magnetic_field(field_ut: np.ndarray, h0_ut: float = H0_UT) -> np.ndarray:
    """Magnetic field component in units of H0.

    Formula: x = H_i / H0, H0 = 100 uT. Units: dimensionless; coefficient w_i in deg/h per
    100 uT. Source: Antonova & Matveev eq. (2): Δω(H) = w0 + Σ w_i·H_i/H0;
    IEEE 952 §8.3 lists magnetic field among the E-terms.
    """
    return np.asarray(field_ut, float) / h0_ut


def supply_voltage(volts: np.ndarray, v_ref: float) -> np.ndarray:
    """Supply-voltage deviation.

    Formula: x = V − V_ref. Units: V; coefficient (deg/h)/V. Source: IEEE 952 §8.3 E-terms
    ("supply voltage ... pertinent to the application").
    """
    return np.asarray(volts, float) - v_ref


def acceleration_power(g: np.ndarray, power: int = 1) -> np.ndarray:
    """Acceleration (load) sensitivity term.

    Formula: x = g^i (g in units of standard gravity), i = 1, 2. Units: g^i; coefficient
    deg/h/g^i. Source: Antonova & Matveev eq. (1) ω = Σ w_i·g^i (mechanical gyros, usually m ≤ 2).
    """
    return np.asarray(g, float) ** power


def time_ramp(t_s: np.ndarray) -> np.ndarray:
    """Time since the log start, hours (ageing / rate ramp).

    Formula: x = t/3600. Units: h; coefficient R in deg/h/h. Source: IEEE 952 §8.3 drift D_R
    and Annex C rate ramp R (σ = R·τ/√2).
    """
    return np.asarray(t_s, float) / SEC_PER_HOUR


def warmup_transient(t_s: np.ndarray, tau_w_s: float, t_on_s: float = 0.0) -> np.ndarray:
    """Warm-up transient after power-on.

    Formula: x = exp(−(t − t_on)/τ_w), τ_w fitted. Units: dimensionless; coefficient A in
    deg/h (the transient amplitude at power-on). Source: IEEE 952 §12.11.4.1.1 (bias measured
    after warm-up); exponential settling is the usual first-order warm-up model.
    """
    return np.exp(-(np.asarray(t_s, float) - t_on_s) / tau_w_s)


def sinusoid(t_s: np.ndarray, freq_hz: float) -> np.ndarray:
    """Sinusoid at frequency f (cos and sin columns).

    Formula: x = [cos 2πft, sin 2πft]. Units: dimensionless, f in Hz; coefficients a, b in
    deg/h; amplitude √(a²+b²). f is
    detected from the residual periodogram and refined by least squares. Source: IEEE 952
    Annex C sinusoidal noise Ω0·sin(2πf0t) (σ peak 0.7246·Ω0 at τ = 0.371/f0).
    """
    w = 2 * math.pi * freq_hz * np.asarray(t_s, float)
    return np.column_stack([np.cos(w), np.sin(w)])


def thermal_branch(temp_c: np.ndarray, width_c: float,
                   bounds: list[tuple[int, int]] | None = None) -> np.ndarray:
    """Heating/cooling branch state of a backlash (play) operator (thermal hysteresis).

    Formula: y_k = min(max(y_{k−1}, T_k − w), T_k + w), y_0 = T_0 (half-width w, fitted);
    s = (T − y)/w ∈ [−1, +1]: +1 on a heating branch, −1 on a cooling branch, moving linearly
    between them while the temperature reverses by 2w. Units: dimensionless, w in degC;
    coefficient = half the heating − cooling offset, deg/h. Source: the play operator of
    hysteresis modelling (Krasnosel'skii & Pokrovskii 1989; the simulator's thermal
    hysteresis); the heating-vs-cooling check PX4's thermal calibration lacks (peer-tools §7).
    """
    T = np.asarray(temp_c, dtype=np.float64)
    out = np.empty_like(T)
    for a, b in bounds or [(0, len(T))]:
        if b <= a:
            continue
        out[a:b] = (T[a:b] - _play(T[a:b], width_c)) / width_c
    return out


def _play(v: np.ndarray, w: float) -> np.ndarray:
    """The play operator y_k = min(max(y_{k−1}, v_k − w), v_k + w), y_0 = v_0, vectorised by
    phases: while rising, y is the running maximum of v − w (from the phase's start value);
    the phase ends where v + w falls below it, and a falling phase (running minimum of
    v + w) begins; and so on. Each phase is scanned in windows that double in length."""
    n = len(v)
    ys = np.empty(n)
    y = float(v[0])
    i = 0
    rising = True
    while i < n:
        L = 256
        while True:
            j = min(n, i + L)
            if rising:
                run = np.maximum(np.maximum.accumulate(v[i:j] - w), y)
                end = np.flatnonzero(v[i:j] + w < run)
            else:
                run = np.minimum(np.minimum.accumulate(v[i:j] + w), y)
                end = np.flatnonzero(v[i:j] - w > run)
            if len(end) or j == n:
                break
            L *= 4
        k = int(end[0]) if len(end) else j - i
        ys[i:i + k] = run[:k]
        if k:
            y = float(run[k - 1])
        i += k
        rising = not rising
    return ys


def earth_rate_projection(earth_dph: np.ndarray) -> np.ndarray:
    """Earth rate along an input axis whose direction changes (tumble, multi-position).

    Formula: x = Ω_E (cos φ cos e cos A + sin φ sin e) per sample (deg/h), from the position or
    IA-attitude channel (:func:`earth_projection`). Units: deg/h; coefficient k_E,
    dimensionless (1 when the positions and the latitude are right; the fitted value checks
    them). Source: IEEE Std 952-1997 §12.11.4.1.1 (earth-rate component along the IA);
    without it a tumble test reads earth rate as g-sensitivity.
    """
    return np.asarray(earth_dph, float)


def input_rate(omega_dph: np.ndarray) -> np.ndarray:
    """Input (rate-table) rate for a scale-factor error, in units of 1e6 deg/h.

    Formula: x = Ω_in·1e-6. Units: deg/h × 1e-6; coefficient ε_K in ppm. Source: IEEE 952
    §8.3 [1 + 1e-6·ε_K]^-1 factor, linearised.
    """
    return np.asarray(omega_dph, float) * 1e-6


def input_rate_temperature(omega_dph: np.ndarray, temp_c: np.ndarray,
                           t_ref_c: float) -> np.ndarray:
    """Input rate × temperature offset (scale-factor temperature sensitivity).

    Formula: x = Ω_in·(T − T_ref)·1e-6. Units: deg/h·degC·1e-6; coefficient ε_T in ppm/degC.
    Source: IEEE 952 §8.3 ε_K = ε_T·ΔT + f(I); §12.9.4 SF temperature sensitivity.
    """
    return np.asarray(omega_dph, float) * (np.asarray(temp_c, float) - t_ref_c) * 1e-6
