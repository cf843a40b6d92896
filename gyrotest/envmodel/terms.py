"""Library of physical effects for the gyro drift model (IEEE 952 §8.3 E-terms, Antonova & Matveev).

The modelled gyro error is a sum of terms, each a known regressor times a coefficient in
physical units::

    ω_meas − Ω_in = D_F + D_T·ΔT + D_T2·ΔT² + D_Ṫ·dT/dt + D_∇Ṫ·d(T_a−T_b)/dt
                    + w_x·Hx/H0 + w_y·Hy/H0 + w_z·Hz/H0 + D_V·(V − V_ref) + ... + noise

(rates in deg/h). Every effect is one documented function below (pure numpy: arrays in, array
out) plus an :class:`Effect` entry in :data:`EFFECTS` that says which channels it needs, the
unit of its coefficient, its nonlinear parameters (time constants, frequency) and where it
comes from. Terms are written as text, e.g. ``T``, ``T2(T_coil)``, ``dTdt``, ``dGdt(T_a,T_b)``,
``Tlag``, ``Hx``, ``V``, ``warmup``, ``sin``, or a custom ``name:expression``
(see :mod:`gyrotest.envmodel.expr`).

Conventions: time s, temperature degC, temperature rate degC/h, field uT normalised by
H0 = 100 uT, supply V, rates deg/h. Channels are held in an :class:`EnvFrame`, a uniformly
sampled set of channels (full rate, or block means) split into contiguous segments at gaps;
derivatives and lags never bridge a gap blindly.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import signal

from ..errors import InputError
from .expr import SafeExpression, parse_expression

#: magnetic-field normaliser H0, uT (Antonova & Matveev: close to the Earth's field; w in deg/h per 100 uT)
H0_UT = 100.0
SEC_PER_HOUR = 3600.0


# ============================================================================ channels frame
@dataclass
class EnvFrame:
    """Channels on a uniform time grid (full rate or block means), split into segments.

    ``t`` s from the log start; ``dt`` grid spacing s; ``bounds`` contiguous (start, stop)
    index ranges (gaps between them); ``rate`` gyro rate deg/h (input rate removed when the
    log has a rate-table channel); temperatures degC; field uT (X, Y, Z order); supply V;
    table rate deg/h; extra channels in their own units.
    """

    t: np.ndarray
    dt: float
    bounds: list[tuple[int, int]]
    rate: np.ndarray | None = None
    temperature: dict[str, np.ndarray] = field(default_factory=dict)
    field_uT: dict[str, np.ndarray] = field(default_factory=dict)
    supply: np.ndarray | None = None
    table_rate: np.ndarray | None = None
    extra: dict[str, np.ndarray] = field(default_factory=dict)
    source: str = "log"
    #: earth-rate component along the IA per sample, deg/h, when the log has a position or
    #: IA-attitude channel and a site latitude (:func:`earth_projection`); else None
    earth_dph: np.ndarray | None = None

    @property
    def n(self) -> int:
        return len(self.t)

    @property
    def duration_s(self) -> float:
        return float(self.t[-1] - self.t[0] + self.dt) if self.n else 0.0

    def group(self, group: str) -> dict[str, np.ndarray]:
        return {"temperature": self.temperature, "field": self.field_uT,
                "extra": self.extra}[group]

    def channel_values(self, group: str, name: str) -> np.ndarray:
        """The values of one channel; InputError naming it when the log lacks it."""
        if group == "t":
            return self.t
        if group == "t_h":
            return self.t / SEC_PER_HOUR
        if group in ("supply", "table_rate"):
            v = getattr(self, group)
            if v is None:
                raise InputError(f"{self.source} has no {group.replace('_', ' ')} channel")
            return v
        chans = self.group(group)
        if name not in chans:
            have = ", ".join(chans) or "none"
            raise InputError(f"{self.source} has no {group} channel {name!r} "
                             f"({group} channels: {have})")
        return chans[name]


def frame_from_log(log, *, axis: str | None = None, dt: float | None = None,
                   subtract_table: bool = True) -> EnvFrame:
    """Build an :class:`EnvFrame` from a :class:`~gyrotest.data.GyroLog`.

    With ``dt`` (s) the channels are averaged over consecutive bins of m = round(dt/τ0)
    samples within each segment (a trailing part shorter than m/2 is dropped); otherwise the
    frame is at full rate. The gyro rate of ``axis`` (default: first) minus the rate-table
    rate (when present and ``subtract_table``) becomes ``rate``.
    """
    if axis is None:
        axis = log.axes[0]
    if axis not in log.rates:
        raise InputError(f"{log.source}: no gyro axis {axis!r} (axes: {', '.join(log.axes)})")
    rate = np.asarray(log.rates[axis], dtype=np.float64)
    if log.table_rate is not None and subtract_table:
        rate = rate - log.table_rate
    t = log.t
    m = 1 if dt is None else max(1, int(round(dt / log.tau0)))
    chans: dict[str, Any] = {
        "earth_dph": earth_projection(log),
        "rate": rate,
        "temperature": dict(log.temperature),
        "field_uT": dict(log.field_uT),
        "supply": log.supply,
        "table_rate": log.table_rate,
        "extra": {k: v for k, v in log.extra.items() if _numeric(v)},
    }
    if m == 1:
        return EnvFrame(t=np.asarray(t, float), dt=log.tau0, bounds=list(log.segments),
                        source=log.source, **chans)
    idx_parts, bounds, pos = [], [], 0
    seg_of = []
    for a, b in log.segments:
        nb = (b - a) // m
        rem = (b - a) - nb * m
        starts = a + m * np.arange(nb)
        if rem >= (m + 1) // 2:
            starts = np.append(starts, a + nb * m)
        if len(starts) == 0:
            continue
        idx_parts.append(starts)
        seg_of.append((a, b))
        bounds.append((pos, pos + len(starts)))
        pos += len(starts)
    if not idx_parts:
        raise InputError(f"{log.source}: too short for {dt:g} s bins")
    starts = np.concatenate(idx_parts)
    # bin ends: next start within the same segment, or the segment end
    ends = np.empty_like(starts)
    k = 0
    for (_a, b), part in zip(seg_of, idx_parts):
        e = np.append(part[1:], min(b, part[-1] + m))
        ends[k:k + len(part)] = e
        k += len(part)

    def binmean(x):
        if x is None:
            return None
        x = np.asarray(x, dtype=np.float64)
        c = np.concatenate([[0.0], np.cumsum(x - x[0])])
        return (c[ends] - c[starts]) / (ends - starts) + x[0]

    return EnvFrame(
        t=binmean(t), dt=m * log.tau0, bounds=bounds, source=log.source,
        rate=binmean(chans["rate"]),
        temperature={k: binmean(v) for k, v in chans["temperature"].items()},
        field_uT={k: binmean(v) for k, v in chans["field_uT"].items()},
        supply=binmean(chans["supply"]), table_rate=binmean(chans["table_rate"]),
        extra={k: binmean(v) for k, v in chans["extra"].items()},
        earth_dph=binmean(chans["earth_dph"]),
    )


_ELEV_NAMES = ("ia_elevation_deg", "ia_el_deg", "ia_elev_deg", "elevation_deg", "elev_deg")
_AZIM_NAMES = ("ia_azimuth_deg", "ia_az_deg", "ia_azim_deg", "azimuth_deg", "azim_deg")


def earth_projection(log) -> np.ndarray | None:
    """Earth-rate component along the input axis for every sample of ``log``, deg/h, when the
    IA direction changes during the log (a tumble or multi-position test): from the position
    labels (``up``, ``north``, ``AZ/EL``, ...) or from numeric IA elevation/azimuth channels
    (``ia_elevation_deg``, ``ia_azimuth_deg``), at the site latitude. None without a
    latitude or such a channel. Formula: Ω_IA = Ω_E (cos φ cos e cos A + sin φ sin e)
    (:func:`gyrotest.earth.earth_rate_component`)."""
    from ..earth import earth_rate_component, parse_ia

    site = getattr(log, "site", None)
    if site is None:
        return None
    lat = site.latitude_deg
    pos = getattr(log, "position", None)
    if pos is not None:
        labels = np.asarray(pos).astype(str)
        uniq, inv = np.unique(labels, return_inverse=True)
        vals = []
        for u in uniq:
            try:
                az, el, _ = parse_ia(u)
            except InputError:
                return None
            vals.append(earth_rate_component(lat, az, el))
        return np.asarray(vals, float)[inv]
    low = {k.lower(): k for k in log.extra}
    el_k = next((low[n] for n in _ELEV_NAMES if n in low), None)
    if el_k is None:
        return None
    el = np.asarray(log.extra[el_k], float)
    az_k = next((low[n] for n in _AZIM_NAMES if n in low), None)
    az = np.asarray(log.extra[az_k], float) if az_k else site.ia_azimuth_deg
    return np.asarray(earth_rate_component(lat, az, el), float)


def _numeric(v) -> bool:
    try:
        return np.asarray(v).dtype.kind in "fiub"
    except Exception:  # pragma: no cover
        return False


# ============================================================================ effect functions
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
    for a, b in bounds or [(0, len(x))]:
        seg = x[a:b]
        n = len(seg)
        if n == 0:
            continue
        h = np.minimum(np.minimum(np.arange(n), n - 1 - np.arange(n)), half)
        off = seg[0]
        c = np.concatenate([[0.0], np.cumsum(seg - off)])
        k = np.arange(n)
        out[a:b] = (c[k + h + 1] - c[k - h]) / (2 * h + 1) + off
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
        seg = T[a:b].tolist()
        y = seg[0]
        ys = [0.0] * len(seg)
        lo_off, hi_off = -width_c, width_c
        for i, v in enumerate(seg):
            lo = v + lo_off
            if y < lo:
                y = lo
            else:
                hi = v + hi_off
                if y > hi:
                    y = hi
            ys[i] = y
        out[a:b] = (T[a:b] - np.asarray(ys)) / width_c
    return out


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


# ============================================================================ registry
@dataclass(frozen=True)
class NLParam:
    """A nonlinear parameter of an effect (fitted by variable projection)."""

    name: str
    unit: str
    kind: str  # "tau" (log-spaced search) or "freq" (periodogram start)


@dataclass(frozen=True)
class Effect:
    """One physical effect: what it needs, its coefficient units, its source."""

    key: str
    title: str  # the physical effect in words
    formula: str
    coef_names: tuple[str, ...]
    coef_unit: str
    source: str
    needs: str  # temperature | temperature2 | field | supply | table_rate | table+temp | extra | none
    function: Callable
    nonlinear: tuple[NLParam, ...] = ()
    smooth: bool = False  # the regressor is smooth: full-rate values may be interpolated
    prefiltered: bool = False  # already S_W-smoothed (derivatives): not smoothed again
    default_channel: int = 0  # field: X=0, Y=1, Z=2
    #: builder (frame, spec, theta, refs) -> (n, n_coef) array for effects defined outside
    #: this module (:mod:`gyrotest.envmodel.channel_terms`)
    build: Callable | None = None


EFFECTS: dict[str, Effect] = {}


def _reg(e: Effect) -> None:
    EFFECTS[e.key] = e


_reg(Effect("bias", "constant bias", "1", ("D_F",), "deg/h", "IEEE 952 §8.3 D_F", "none", bias))
_reg(Effect("T", "temperature sensitivity", "T − T_ref", ("D_T",), "deg/h/degC",
            "IEEE 952 §8.3 D_T·ΔT; Antonova & Matveev w1", "temperature", temperature_offset))
_reg(Effect("T2", "quadratic temperature sensitivity", "(T − T_ref)²", ("D_T2",), "deg/h/degC^2",
            "Antonova & Matveev eq.(3) w2·t²", "temperature", temperature_offset))
_reg(Effect("T3", "cubic temperature sensitivity", "(T − T_ref)³", ("D_T3",), "deg/h/degC^3",
            "Antonova & Matveev eq.(3) w3·t³; PX4 3rd-order polynomial", "temperature", temperature_offset))
_reg(Effect("dTdt", "temperature-rate sensitivity (thermal transient)", "dT/dt [degC/h]",
            ("D_Tdot",), "(deg/h)/(degC/h)", "IEEE 952 §8.3 D_Ṫ; Antonova & Matveev w_ΔV", "temperature",
            temperature_rate, smooth=True, prefiltered=True))
_reg(Effect("dGdt", "temperature-gradient rate (Shupe effect)", "d(T_a − T_b)/dt [degC/h]",
            ("D_gradTdot",), "(deg/h)/(degC/h)", "IEEE 952 §8.3 D_∇Ṫ", "temperature2",
            gradient_rate, smooth=True, prefiltered=True))
_reg(Effect("Tlag", "temperature of a lagging core (first-order lag τ)",
            "T_core − T_ref, τ·dT_core/dt = T − T_core", ("D_Tcore",), "deg/h/degC",
            "IEEE 952 §8.3 D_T·ΔT on the core temperature", "temperature", lagged_temperature,
            nonlinear=(NLParam("tau_s", "s", "tau"),), smooth=True))
for _i, _ax in enumerate("xyz"):
    _reg(Effect(f"H{_ax}", f"magnetic field along {_ax.upper()}", f"H{_ax}/H0 (H0 = 100 uT)",
                (f"w_{_ax}",), "deg/h per 100 uT", "Antonova & Matveev eq.(2); IEEE 952 §8.3", "field",
                magnetic_field, default_channel=_i))
_reg(Effect("V", "supply-voltage sensitivity", "V − V_ref", ("D_V",), "(deg/h)/V",
            "IEEE 952 §8.3 E-terms (supply voltage)", "supply", supply_voltage))
_reg(Effect("g", "acceleration (g) sensitivity", "g", ("w_g1",), "deg/h/g",
            "Antonova & Matveev eq.(1) w1·g", "extra", acceleration_power))
_reg(Effect("g2", "g² sensitivity", "g²", ("w_g2",), "deg/h/g^2", "Antonova & Matveev eq.(1) w2·g²",
            "extra", acceleration_power))
_reg(Effect("ramp", "time ramp (ageing, rate ramp R)", "t [h]", ("R",), "deg/h/h",
            "IEEE 952 §8.3 D_R; Annex C rate ramp", "none", time_ramp, smooth=True))
_reg(Effect("warmup", "warm-up transient after power-on", "exp(−(t − t_on)/τ_w)", ("A_w",),
            "deg/h", "IEEE 952 §12.11.4.1.1 warm-up", "none", warmup_transient,
            nonlinear=(NLParam("tau_w_s", "s", "tau"),), smooth=True))
_reg(Effect("sin", "periodic disturbance (sinusoid)", "a·cos 2πft + b·sin 2πft",
            ("a", "b"), "deg/h", "IEEE 952 Annex C sinusoid", "none", sinusoid,
            nonlinear=(NLParam("f_Hz", "Hz", "freq"),), smooth=True))
_reg(Effect("hyst", "thermal hysteresis (heating vs cooling branch)",
            "play-operator branch state s ∈ [−1, 1], half-width w", ("D_hyst",), "deg/h",
            "play operator; heating/cooling check", "temperature", thermal_branch,
            nonlinear=(NLParam("width_c", "degC", "tau"),), smooth=True))
_reg(Effect("earth", "earth-rate projection on a moving input axis",
            "Ω_E (cos φ cos e cos A + sin φ sin e)", ("k_E",), "1 (deg/h per deg/h)",
            "IEEE 952 §12.11.4.1.1 earth rate along the IA", "earth", earth_rate_projection))
_reg(Effect("rate", "scale-factor error on the input rate", "Ω_in·1e-6", ("eps_K",), "ppm",
            "IEEE 952 §8.3 ε_K", "table_rate", input_rate))
_reg(Effect("rateT", "scale-factor temperature sensitivity", "Ω_in·(T − T_ref)·1e-6",
            ("eps_T",), "ppm/degC", "IEEE 952 §8.3 ε_T·ΔT", "table+temp",
            input_rate_temperature))
_reg(Effect("custom", "user term", "user expression", ("c",), "deg/h per unit", "user",
            "custom", lambda *a: None))

ALIASES = {"dT/dt": "dTdt", "Tdot": "dTdt", "dT": "dTdt", "gradTdot": "dGdt",
           "dgrad": "dGdt", "time": "ramp", "t": "ramp", "R": "ramp", "V_supply": "V",
           "supply": "V", "lag": "Tlag", "hysteresis": "hyst", "warm-up": "warmup",
           "sinusoid": "sin", "DT": "T", "dTdt2": "dTdt"}
#: groups that expand to several terms
GROUPS = {"H": ["Hx", "Hy", "Hz"], "mag": ["Hx", "Hy", "Hz"], "poly2": ["T", "T2"],
          "poly3": ["T", "T2", "T3"]}


# ============================================================================ term specs
@dataclass(frozen=True)
class TermSpec:
    """One term of a model: registry key, resolved channels, custom name/expression."""

    key: str
    channels: tuple[str, ...] = ()
    name: str | None = None  # custom terms
    expr: str | None = None

    @property
    def effect(self) -> Effect:
        return EFFECTS[self.key]

    @property
    def label(self) -> str:
        if self.key == "custom":
            return str(self.name)
        if self.channels:
            return f"{self.key}({','.join(self.channels)})"
        return self.key

    def short(self, frame_or_defaults: Any = None) -> str:
        return self.label

    @property
    def n_coef(self) -> int:
        return len(self.effect.coef_names)

    def coef_labels(self) -> list[str]:
        e = self.effect
        if self.key == "custom":
            return [f"c[{self.name}]"]
        base = self.label
        if len(e.coef_names) == 1:
            return [base]
        return [f"{base}.{c}" for c in e.coef_names]

    def to_dict(self) -> dict:
        d: dict[str, Any] = {"key": self.key, "label": self.label}
        if self.channels:
            d["channels"] = list(self.channels)
        if self.key == "custom":
            d["name"] = self.name
            d["expr"] = self.expr
        return d

    @staticmethod
    def from_dict(d: dict) -> TermSpec:
        return TermSpec(d["key"], tuple(d.get("channels") or ()), d.get("name"), d.get("expr"))


_NAME_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_.\-]*$")


def split_terms(text: str) -> list[str]:
    """Split a comma-separated term list, respecting parentheses and brackets."""
    out, depth, cur = [], 0, []
    for ch in text:
        if ch in "([":
            depth += 1
        elif ch in ")]":
            depth -= 1
        if ch == "," and depth == 0:
            out.append("".join(cur).strip())
            cur = []
        else:
            cur.append(ch)
    out.append("".join(cur).strip())
    return [p for p in out if p]


def parse_term(text: str) -> list[TermSpec]:
    """Parse one term text into specs (a group like ``H`` gives three). Channels stay
    unresolved (empty) when not given; :func:`resolve_terms` fills them in."""
    s = text.strip()
    if not s:
        raise InputError("empty term")
    # custom: name:expr (but not e.g. "T(a:b)")
    m = re.match(r"^([A-Za-z_][A-Za-z0-9_]*)\s*:(.+)$", s)
    if m and "(" not in m.group(1):
        name, expr = m.group(1), m.group(2).strip()
        if name in EFFECTS or name in ALIASES or name in GROUPS:
            raise InputError(f"custom term {name!r}: the name is a built-in term; choose another")
        parse_expression(expr)
        return [TermSpec("custom", (), name, expr)]
    m = re.match(r"^([A-Za-z][A-Za-z0-9_/\-]*)\s*(?:\((.*)\))?$", s)
    if not m:
        raise InputError(f"term {s!r}: not understood; use e.g. T, T2(T_coil), dTdt, "
                         f"dGdt(T_a,T_b), Hx, V, warmup, or name:expression")
    key, args = m.group(1), m.group(2)
    key = ALIASES.get(key, key)
    chans = tuple(a.strip() for a in args.split(",") if a.strip()) if args else ()
    if key in GROUPS:
        if chans:
            raise InputError(f"term {s!r}: {key} is a group; give channels per term")
        return [TermSpec(k) for k in GROUPS[key]]
    if key not in EFFECTS or key == "custom":
        known = ", ".join(k for k in EFFECTS if k != "custom")
        raise InputError(f"term {s!r}: unknown term {key!r} (known: {known}, or "
                         "name:expression)")
    need = {"temperature2": 2, "table+temp": 1, "field2": 2, "any2": 2,
            "fieldall": 0, "earth": 0}.get(EFFECTS[key].needs, 1)
    if EFFECTS[key].needs in ("none", "fieldall", "earth") and chans:
        raise InputError(f"term {s!r}: {key} takes no channel")
    if len(chans) > need:
        raise InputError(f"term {s!r}: {key} takes at most {need} channel(s)")
    return [TermSpec(key, chans)]


def parse_terms(texts: list[str] | str | None) -> list[TermSpec]:
    """Parse term texts (a comma-separated string or a list of strings) into specs."""
    if texts is None:
        return []
    if isinstance(texts, str):
        texts = [texts]
    out: list[TermSpec] = []
    for t in texts:
        if isinstance(t, TermSpec):
            out.append(t)
            continue
        parts = [t] if re.match(r"^[A-Za-z_][A-Za-z0-9_]*\s*:", t.strip()) else split_terms(t)
        for p in parts:
            out.extend(parse_term(p))
    return out


_G_PATTERN = re.compile(r"^(acc|accel|a|g)(_?[xyz])?(_.*)?$|_g$", re.I)  # not gyro_y_dps


def resolve_terms(specs: list[TermSpec], frame: EnvFrame) -> list[TermSpec]:
    """Fill in default channels and check that every channel exists and is usable.

    Defaults: temperature terms use the first temperature channel, dGdt the first two, Hx/Hy/Hz
    the X/Y/Z field channels, g/g2 an extra channel named like acc*/g*/*_g. Raises
    InputError naming the term and the channel (missing, constant, not finite).
    """
    out: list[TermSpec] = []
    src = frame.source
    for sp in specs:
        e = sp.effect
        label = sp.label
        if sp.key == "custom":
            expr = parse_expression(sp.expr or "")
            for ref in expr.channels:
                try:
                    v = frame.channel_values(ref.group, ref.name)
                except InputError as err:
                    raise InputError(f"term {sp.name!r}: {err}") from None
                _check_channel(v, f"term {sp.name!r}", str(ref), src,
                               constant_ok=ref.group in ("t", "t_h"))
            out.append(sp)
            continue
        chans = list(sp.channels)
        if e.needs in ("temperature", "temperature2", "table+temp"):
            have = list(frame.temperature)
            need = 2 if e.needs == "temperature2" else 1
            if not have:
                raise InputError(f"term {label!r}: {src} has no temperature channel; name one "
                                 "with --temp-col")
            if not chans:
                if len(have) < need:
                    raise InputError(f"term {label!r}: needs two temperature channels; {src} "
                                     f"has only {', '.join(have)}")
                chans = have[:need]
            for c in chans:
                if c not in frame.temperature:
                    raise InputError(f"term {label!r}: {src} has no temperature channel {c!r} "
                                     f"(temperature channels: {', '.join(have)})")
            if e.needs == "temperature2" and chans[0] == chans[1]:
                raise InputError(f"term {label!r}: needs two different temperature channels")
            for c in chans:
                _check_channel(frame.temperature[c], f"term {label!r}", c, src,
                               constant_ok=sp.key in ("dTdt", "dGdt", "hyst", "Tlag"))
            if e.needs == "table+temp":
                if frame.table_rate is None:
                    raise InputError(f"term {label!r}: {src} has no rate-table channel; name it "
                                     "with --table-col")
                _check_channel(frame.table_rate, f"term {label!r}", "table rate", src)
            if e.needs == "temperature2":
                _check_channel(frame.temperature[chans[0]] - frame.temperature[chans[1]],
                               f"term {label!r}", f"{chans[0]}−{chans[1]}", src)
            elif sp.key in ("dTdt", "hyst", "Tlag"):
                _check_channel(frame.temperature[chans[0]], f"term {label!r}", chans[0], src)
        elif e.needs == "field":
            have = list(frame.field_uT)
            if not chans:
                if len(have) < e.default_channel + 1:
                    raise InputError(f"term {label!r}: {src} has no magnetic-field channels; "
                                     "name them with --field-cols X,Y,Z")
                chans = [have[e.default_channel]]
            if chans[0] not in frame.field_uT:
                raise InputError(f"term {label!r}: {src} has no field channel {chans[0]!r} "
                                 f"(field channels: {', '.join(have) or 'none'})")
            _check_channel(frame.field_uT[chans[0]], f"term {label!r}", chans[0], src)
        elif e.needs in ("field2", "fieldall"):
            have = list(frame.field_uT)
            if e.needs == "fieldall":
                if not have:
                    raise InputError(f"term {label!r}: {src} has no magnetic-field channels; "
                                     "name them with --field-cols X,Y,Z")
                chans = []
            elif len(chans) != 2 or chans[0] == chans[1]:
                raise InputError(f"term {label!r}: name two different field channels, e.g. "
                                 f"{sp.key}({','.join(have[:2]) or 'Hx_uT,Hy_uT'})")
            for c in chans:
                if c not in frame.field_uT:
                    raise InputError(f"term {label!r}: {src} has no field channel {c!r} "
                                     f"(field channels: {', '.join(have) or 'none'})")
            if chans:
                _check_channel(frame.field_uT[chans[0]] * frame.field_uT[chans[1]],
                               f"term {label!r}", f"{chans[0]}·{chans[1]}", src)
        elif e.needs in ("any", "any2"):
            from .channel_terms import find_channel

            n_need = 2 if e.needs == "any2" else 1
            if len(chans) != n_need:
                raise InputError(f"term {label!r}: name {'two channels' if n_need == 2 else 'the channel'}"
                                 f", e.g. {sp.key}({'a,b' if n_need == 2 else 'RH_pct'})")
            try:
                vals = [find_channel(frame, c)[1] for c in chans]
            except InputError as err:
                raise InputError(f"term {label!r}: {err}") from None
            for c, v in zip(chans, vals):
                _check_channel(v, f"term {label!r}", c, src,
                               constant_ok=sp.key in ("dchan", "dchanlag"))
            if n_need == 2:
                _check_channel(vals[0] * vals[1], f"term {label!r}", "·".join(chans), src)
        elif e.needs == "earth":
            if frame.earth_dph is None:
                raise InputError(f"term {label!r}: {src} has no position or IA-attitude channel "
                                 "with a site latitude; name them with --position-col (or "
                                 "ia_elevation_deg/ia_azimuth_deg columns) and --latitude")
            _check_channel(frame.earth_dph, f"term {label!r}", "earth-rate projection", src)
        elif e.needs == "supply":
            if frame.supply is None:
                raise InputError(f"term {label!r}: {src} has no supply-voltage channel; name it "
                                 "with --supply-col")
            _check_channel(frame.supply, f"term {label!r}", "supply", src)
        elif e.needs == "table_rate":
            if frame.table_rate is None:
                raise InputError(f"term {label!r}: {src} has no rate-table channel; name it "
                                 "with --table-col")
            _check_channel(frame.table_rate, f"term {label!r}", "table rate", src)
        elif e.needs == "extra":
            if not chans:
                hits = [k for k in frame.extra if _G_PATTERN.search(k)]
                if not hits:
                    raise InputError(f"term {label!r}: no acceleration channel found in {src}; "
                                     f"name it, e.g. {sp.key}(acc_g)")
                chans = hits[:1]
            if chans[0] not in frame.extra:
                raise InputError(f"term {label!r}: {src} has no channel {chans[0]!r} "
                                 f"(extra channels: {', '.join(frame.extra) or 'none'})")
            _check_channel(frame.extra[chans[0]], f"term {label!r}", chans[0], src)
        out.append(TermSpec(sp.key, tuple(chans), sp.name, sp.expr))
    labels = [s.label for s in out]
    dup = {x for x in labels if labels.count(x) > 1}
    if dup:
        raise InputError(f"term {sorted(dup)[0]!r} given twice")
    return out


def _check_channel(v: np.ndarray, who: str, chan: str, src: str, *,
                   constant_ok: bool = False) -> None:
    v = np.asarray(v, dtype=np.float64)
    good = np.isfinite(v)
    if not good.any():
        raise InputError(f"{who}: channel {chan!r} in {src} has no finite values (all NaN)")
    if not good.all():
        raise InputError(f"{who}: channel {chan!r} in {src} has {int((~good).sum())} NaN/inf "
                         "values; read the log with --nan interpolate or --nan gap")
    if constant_ok:
        return
    span = float(np.max(v) - np.min(v))
    if span <= 1e-12 * max(1.0, float(np.max(np.abs(v)))):
        raise InputError(f"{who}: channel {chan!r} in {src} is constant ({float(v[0]):g}); its "
                         "coefficient cannot be estimated from this log")


# ============================================================================ building
@dataclass
class Refs:
    """Reference values a model is expressed about (stored with the model)."""

    t_ref_c: dict[str, float] = field(default_factory=dict)
    v_ref: float | None = None
    h0_ut: float = H0_UT
    t_on_s: float = 0.0
    smoothing_s: float = 120.0
    hyst_threshold_c_per_h: dict[str, float] = field(default_factory=dict)
    hyst_min_width_c: dict[str, float] = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {"T_ref_degC": dict(self.t_ref_c), "V_ref_V": self.v_ref, "H0_uT": self.h0_ut,
                "t_power_on_s": self.t_on_s, "smoothing_window_s": self.smoothing_s,
                "hysteresis_threshold_degC_per_h": dict(self.hyst_threshold_c_per_h),
                "hysteresis_min_width_degC": dict(self.hyst_min_width_c)}

    @staticmethod
    def from_dict(d: dict) -> Refs:
        return Refs(t_ref_c={k: float(v) for k, v in (d.get("T_ref_degC") or {}).items()},
                    v_ref=d.get("V_ref_V"), h0_ut=float(d.get("H0_uT", H0_UT)),
                    t_on_s=float(d.get("t_power_on_s", 0.0)),
                    smoothing_s=float(d.get("smoothing_window_s", 120.0)),
                    hyst_threshold_c_per_h={k: float(v) for k, v in
                                            (d.get("hysteresis_threshold_degC_per_h") or {}).items()},
                    hyst_min_width_c={k: float(v) for k, v in
                                      (d.get("hysteresis_min_width_degC") or {}).items()})


def default_refs(frame: EnvFrame, *, t_ref: float | None = None, v_ref: float | None = None,
                 smoothing_s: float | None = None, t_on_s: float = 0.0,
                 resolution_s: float | None = None) -> Refs:
    """Reference values from the fitting data: T_ref = ``t_ref`` or the mean temperature
    rounded to 0.1 degC (per sensor), V_ref = ``v_ref`` or the mean supply rounded to 0.01 V,
    smoothing window W = ``smoothing_s`` or max(60 s, 2·resolution), hysteresis threshold =
    max(0.1 degC/h, 0.2 × the 95th percentile of |dT/dt|); the narrowest resolvable hysteresis
    half-width = max(5·σ_T (sensor noise from second differences), half the temperature change
    within W at the 95th-percentile rate)."""
    if smoothing_s is None:
        smoothing_s = max(60.0, 2.0 * (resolution_s or 0.0), 4.0 * frame.dt)
    r = Refs(smoothing_s=float(smoothing_s), t_on_s=float(t_on_s))
    for k, v in frame.temperature.items():
        v = np.asarray(v, float)
        fin = v[np.isfinite(v)]
        r.t_ref_c[k] = float(t_ref) if t_ref is not None else (
            round(float(np.mean(fin)), 1) if len(fin) else 0.0)
        if len(fin) == len(v) and len(v) > 2:
            rate = temperature_rate(v, frame.dt, smoothing_s, frame.bounds)
            r.hyst_threshold_c_per_h[k] = max(0.1, 0.2 * float(np.percentile(np.abs(rate), 95)))
            d2 = np.diff(v, 2)
            sig = 1.4826 * float(np.median(np.abs(d2 - np.median(d2)))) / math.sqrt(6.0)
            r.hyst_min_width_c[k] = max(5.0 * sig, 0.5 * float(np.percentile(np.abs(rate), 95))
                                        * smoothing_s / SEC_PER_HOUR)
        else:
            r.hyst_threshold_c_per_h[k] = 0.1
    if frame.supply is not None:
        r.v_ref = float(v_ref) if v_ref is not None else round(float(np.nanmean(frame.supply)), 2)
    return r


def build_term(frame: EnvFrame, spec: TermSpec, theta: dict[str, float], refs: Refs, *,
               to_be_smoothed: bool = False) -> np.ndarray:
    """The regressor column(s) of one term on ``frame``: shape (n, n_coef).
    ``to_be_smoothed``: the caller applies the working smoother afterwards (the fit's design
    matrix), so a custom expression's ``ddt`` is not smoothed a second time."""
    k = spec.key
    ch = spec.channels
    W = refs.smoothing_s
    if spec.effect.build is not None:
        return spec.effect.build(frame, spec, theta, refs)
    if k == "bias":
        x = bias(frame.n)
    elif k in ("T", "T2", "T3"):
        p = {"T": 1, "T2": 2, "T3": 3}[k]
        x = temperature_offset(frame.temperature[ch[0]], refs.t_ref_c.get(ch[0], 0.0), p)
    elif k == "dTdt":
        x = temperature_rate(frame.temperature[ch[0]], frame.dt, W, frame.bounds)
    elif k == "dGdt":
        x = gradient_rate(frame.temperature[ch[0]], frame.temperature[ch[1]], frame.dt, W,
                          frame.bounds)
    elif k == "Tlag":
        x = lagged_temperature(frame.temperature[ch[0]], frame.t, theta["tau_s"],
                               refs.t_ref_c.get(ch[0], 0.0), frame.bounds)
    elif k in ("Hx", "Hy", "Hz"):
        x = magnetic_field(frame.field_uT[ch[0]], refs.h0_ut)
    elif k == "V":
        x = supply_voltage(frame.supply, refs.v_ref if refs.v_ref is not None else 0.0)
    elif k in ("g", "g2"):
        x = acceleration_power(frame.extra[ch[0]], 1 if k == "g" else 2)
    elif k == "ramp":
        x = time_ramp(frame.t)
    elif k == "warmup":
        x = warmup_transient(frame.t, theta["tau_w_s"], refs.t_on_s)
    elif k == "sin":
        return sinusoid(frame.t, theta["f_Hz"])
    elif k == "hyst":
        x = thermal_branch(frame.temperature[ch[0]], theta["width_c"], frame.bounds)
    elif k == "earth":
        x = earth_rate_projection(frame.earth_dph)
    elif k == "rate":
        x = input_rate(frame.table_rate)
    elif k == "rateT":
        x = input_rate_temperature(frame.table_rate, frame.temperature[ch[0]],
                                   refs.t_ref_c.get(ch[0], 0.0))
    elif k == "custom":
        x = compiled(spec.expr or "").evaluate(frame, smoothing_s=W, raw_ddt=to_be_smoothed)
        if not np.all(np.isfinite(x)):
            raise InputError(f"term {spec.name!r}: expression {spec.expr!r} gives NaN/inf "
                             "values on this log (e.g. log or sqrt of a negative number)")
    else:  # pragma: no cover
        raise InputError(f"unknown term {k!r}")
    return np.asarray(x, dtype=np.float64).reshape(-1, 1)


_COMPILED: dict[str, SafeExpression] = {}


def compiled(expr: str) -> SafeExpression:
    if expr not in _COMPILED:
        _COMPILED[expr] = parse_expression(expr)
    return _COMPILED[expr]


def nonlinear_bounds(spec: TermSpec, duration_s: float, resolution_s: float,
                     refs: Refs | None = None) -> dict[str, tuple[float, float]]:
    """Search ranges of a term's nonlinear parameters for a record of ``duration_s`` fitted at
    ``resolution_s``: time constants from max(2·resolution, 10 s) to half the record (lags: up
    to the record); frequency from 2/duration to 1/(4·resolution); hysteresis half-width from
    the larger of 0.02 degC and the sensor's resolvable width (``refs.hyst_min_width_c``: a
    branch narrower than the sensor noise or than the temperature change within the smoother
    window only imitates sign(dT/dt)) to 5 degC."""
    lo_tau = max(2.0 * resolution_s, 10.0)
    if spec.key == "hyst":
        lo_w = 0.02
        if refs is not None and spec.channels:
            lo_w = max(lo_w, refs.hyst_min_width_c.get(spec.channels[0], 0.0))
        return {"width_c": (lo_w, max(5.0, 2.0 * lo_w))}
    if spec.key in ("Tlag", "dTlagdt", "chanlag", "dchanlag"):
        return {"tau_s": (lo_tau, max(lo_tau * 2, duration_s))}
    if spec.key == "warmup":
        return {"tau_w_s": (lo_tau, max(lo_tau * 2, duration_s / 2))}
    if spec.key == "sin":
        return {"f_Hz": (2.0 / duration_s, 1.0 / (4.0 * resolution_s))}
    return {}


def describe(spec: TermSpec) -> str:
    """One-line description of a term in physical words, e.g. 'temperature-rate sensitivity
    (thermal transient) of T_case'."""
    e = spec.effect
    if spec.key == "custom":
        return f"user term {spec.expr}"
    if spec.channels:
        return f"{e.title} [{', '.join(spec.channels)}]"
    return e.title


def effect_table() -> list[dict]:
    """The registry as rows (key, effect, formula, coefficient unit, source) for docs/--help."""
    return [{"term": e.key, "effect": e.title, "formula": e.formula, "unit": e.coef_unit,
             "nonlinear": [p.name for p in e.nonlinear], "source": e.source}
            for e in EFFECTS.values() if e.key != "custom"]


# the effects defined in their own module register themselves in EFFECTS
from . import channel_terms as _channel_terms  # noqa: E402,F401
