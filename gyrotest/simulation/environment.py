"""Bench environment for the simulator: temperature, magnetic field, supply, IA positions,
rate-table plateaus. All functions are vectorised over the sample grid.

Time arguments are seconds from the start of the run; ``tm`` is the mid-point of each sample
interval (deterministic effects are evaluated there), ``tau0`` the sample interval.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import signal

from ..core.earth import earth_rate_component
from .specs import (
    FieldSpec,
    HelmholtzSpec,
    PositionSpec,
    RateTableSpec,
    SensorSpec,
    SupplySpec,
    TemperatureSpec,
)

# ------------------------------------------------------------------------------ temperature


@dataclass
class Piece:
    """One piece of the ambient profile on [start, end): value = v0 + slope (t - start)
    + amp sin(2 pi (t - start)/period)."""

    start: float
    end: float
    v0: float
    slope: float = 0.0  # degC/s
    amp: float = 0.0
    period: float = 1.0

    def value_at_end(self) -> float:
        d = self.end - self.start
        return self.v0 + self.slope * d + self.amp * math.sin(2 * math.pi * d / self.period)


def build_pieces(spec: TemperatureSpec) -> tuple[list[Piece], float, float]:
    """Turn the profile segments into contiguous pieces.

    Returns (pieces, end time of the profile, final value). Segment kinds: hold (value_c
    optional, duration_s), ramp (to_c, rate_c_per_h or duration_s), step (to_c, instantaneous),
    staircase (levels_c, dwell_s, ramp_c_per_h: 0 = steps), sine (amplitude_c, period_s, cycles
    or duration_s; around the current value).
    """
    pieces: list[Piece] = []
    t, v = 0.0, spec.initial_c

    def ramp_to(target: float, rate_c_per_h: float | None, duration: float | None) -> None:
        nonlocal t, v
        if duration is None:
            duration = abs(target - v) / rate_c_per_h * 3600.0 if rate_c_per_h else 0.0
        if duration > 0 and target != v:
            pieces.append(Piece(t, t + duration, v, (target - v) / duration))
            t += duration
        v = target

    for seg in spec.segments:
        p = seg.p
        if seg.kind == "hold":
            if p.get("value_c") is not None:
                v = p["value_c"]
            pieces.append(Piece(t, t + p["duration_s"], v))
            t += p["duration_s"]
        elif seg.kind == "ramp":
            ramp_to(p["to_c"], p.get("rate_c_per_h"), p.get("duration_s"))
        elif seg.kind == "step":
            v = p["to_c"]
        elif seg.kind == "staircase":
            for level in p["levels_c"]:
                ramp_to(level, p["ramp_c_per_h"] or None, None)
                pieces.append(Piece(t, t + p["dwell_s"], v))
                t += p["dwell_s"]
        elif seg.kind == "sine":
            dur = p["duration_s"] if p.get("duration_s") is not None else p["cycles"] * p["period_s"]
            pc = Piece(t, t + dur, v, 0.0, p["amplitude_c"], p["period_s"])
            pieces.append(pc)
            t += dur
            v = pc.value_at_end()
    return pieces, t, v


def ambient_temperature(spec: TemperatureSpec, tm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Ambient (chamber) temperature, degC, and its analytic time derivative, degC/h.

    Instantaneous steps have no derivative (a delta); drive rate terms from a lagged node when
    the profile has steps. After the profile ends the final value is held.
    """
    pieces, t_end, v_end = build_pieces(spec)
    T = np.full(tm.shape, v_end, dtype=float)
    dT = np.zeros(tm.shape, dtype=float)
    if not pieces:
        return T, dT
    starts = np.array([p.start for p in pieces])
    idx = np.searchsorted(starts, tm, side="right") - 1
    inside = (idx >= 0) & (tm < t_end)
    for i, p in enumerate(pieces):
        m = inside & (idx == i)
        if not m.any():
            continue
        x = tm[m] - p.start
        w = 2 * math.pi / p.period
        T[m] = p.v0 + p.slope * x + p.amp * np.sin(w * x)
        dT[m] = (p.slope + p.amp * w * np.cos(w * x)) * 3600.0
    return T, dT


def first_order_lag(u: np.ndarray, tau0: float, tau: float, initial: float,
                    rate: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
    """y' = (u - y)/tau, sampled: y_k = a y_(k-1) + (1 - a) u_k, a = e^(-tau0/tau).

    Returns (y, dy/dt in units/h) with the derivative taken from the ODE, (u - y)/tau
    (None when ``rate`` is False). tau = 0 returns u itself (derivative: numerical gradient).
    """
    if tau <= 0:
        return u.copy(), (np.gradient(u, tau0) * 3600.0 if rate else None)
    a = math.exp(-tau0 / tau)
    y, _ = signal.lfilter([1.0 - a], [1.0, -a], u, zi=[a * initial])
    return y, ((u - y) / tau * 3600.0 if rate else None)


def thermal_nodes(spec: TemperatureSpec, tm: np.ndarray, tau0: float
                  ) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """Temperatures (degC) and rates (degC/h) of 'ambient' and every lagged node."""
    T_amb, dT_amb = ambient_temperature(spec, tm)
    temps = {"ambient": T_amb}
    rates = {"ambient": dT_amb}
    for nd in spec.nodes:
        u = temps[nd.input]
        init = nd.initial_c if nd.initial_c is not None else float(u[0])
        y, dy = first_order_lag(u, tau0, nd.tau_s, init)
        temps[nd.name], rates[nd.name] = y, dy
    return temps, rates


def sensor_reading(sen: SensorSpec, node_T: np.ndarray, tau0: float,
                   rng: np.random.Generator) -> np.ndarray:
    """A temperature sensor: first-order lag (its own time constant) of its node, plus offset,
    white noise and resolution (rounding to a multiple of resolution_c)."""
    y, _ = first_order_lag(node_T, tau0, sen.tau_s, float(node_T[0]), rate=False)
    if sen.offset_c:
        y += sen.offset_c
    if sen.noise_c > 0:
        y += rng.standard_normal(y.size) * sen.noise_c
    if sen.resolution_c > 0:
        y = np.round(y / sen.resolution_c) * sen.resolution_c
    return y


def play_operator(T: np.ndarray, width: float, max_points: int = 200_000) -> np.ndarray:
    """Heating/cooling state s in [-1, 1] from a backlash (play) operator of half-width
    ``width`` degC: y_k = min(max(y_(k-1), T_k - width), T_k + width), s = (T - y)/width.

    s = +1 on a heating branch, -1 on a cooling branch; switching needs a temperature reversal
    of 2*width. Evaluated on at most ``max_points`` decimated samples and interpolated.
    """
    n = T.size
    step = max(1, math.ceil(n / max_points))
    idx = np.arange(0, n, step)
    if idx[-1] != n - 1:
        idx = np.append(idx, n - 1)
    Td = T[idx].tolist()
    y = Td[0]
    out = np.empty(len(Td))
    for i, t in enumerate(Td):
        if y < t - width:
            y = t - width
        elif y > t + width:
            y = t + width
        out[i] = y
    s = (np.asarray(Td) - out) / width
    return np.interp(np.arange(n), idx, s)


# ------------------------------------------------------------------------------ IA positions


@dataclass
class PositionSchedule:
    index: np.ndarray | None  # position number per sample (None: one fixed IA)
    names: list[str]
    earth_dph: np.ndarray  # earth-rate component along IA per sample
    windows: list[dict]

    @property
    def labels(self) -> np.ndarray:
        """Position label per sample (object array of str)."""
        names = np.array(self.names, dtype=object)
        if self.index is None:
            return np.full(self.earth_dph.size, names[0], dtype=object)
        return names[self.index]


def position_schedule(positions: list[PositionSpec], fixed: PositionSpec | None,
                      latitude_deg: float, tm: np.ndarray) -> PositionSchedule:
    """Earth-rate component along the IA for a fixed IA or a multi-position sequence.

    Omega_IA = Omega_E (cos(phi) cos(e) cos(A) + sin(phi) sin(e)), Omega_E = 15.041067 deg/h
    (IEEE 952 §12.11.4.1.1; GYRO_REFERENCE §2). After the last dwell the last position holds.
    """
    if not positions:
        assert fixed is not None
        er = earth_rate_component(latitude_deg, fixed.azimuth_deg, fixed.elevation_deg)
        win = [{"label": fixed.label, "ia_azimuth_deg": fixed.azimuth_deg,
                "ia_elevation_deg": fixed.elevation_deg, "start_s": 0.0,
                "end_s": None, "earth_rate_ia_dph": er}]
        return PositionSchedule(None, [fixed.label], np.full(tm.size, er), win)
    ends = np.cumsum([p.dwell_s for p in positions])
    idx = np.minimum(np.searchsorted(ends, tm, side="right"), len(positions) - 1)
    er = np.array([earth_rate_component(latitude_deg, p.azimuth_deg, p.elevation_deg)
                   for p in positions])
    wins = []
    start = 0.0
    for p, e, r in zip(positions, ends, er):
        wins.append({"label": p.label, "ia_azimuth_deg": p.azimuth_deg,
                     "ia_elevation_deg": p.elevation_deg, "start_s": start, "end_s": float(e),
                     "earth_rate_ia_dph": float(r)})
        start = float(e)
    return PositionSchedule(idx, [p.label for p in positions], er[idx], wins)


# ------------------------------------------------------------------------------ rate table


@dataclass
class TableSchedule:
    cmd_dps: np.ndarray
    actual_dps: np.ndarray
    plateaus: list[dict]


def table_schedule(spec: RateTableSpec, tm: np.ndarray) -> TableSchedule:
    """Commanded plateaus and the table's first-order settling (time constant settle_tau_s).

    Plateau i runs [s_i, s_i + dwell_i); the actual rate is c_i + (a_i - c_i) e^(-(t-s_i)/tau)
    with a_i the actual rate at s_i. After the last plateau the table stops (0 deg/s) with the
    same settling.
    """
    rates = list(spec.rates_dps)
    starts = np.concatenate(([0.0], np.cumsum(spec.dwell_s)))
    cmd_levels = np.array(rates + [0.0])
    idx = np.searchsorted(starts, tm, side="right") - 1
    idx = np.clip(idx, 0, len(rates))
    cmd = cmd_levels[idx]
    tau = spec.settle_tau_s
    # actual rate at each plateau start
    a = np.zeros(len(rates) + 1)
    prev = 0.0
    for i in range(len(rates) + 1):
        a[i] = prev
        if i < len(rates):
            d = spec.dwell_s[i]
            c = cmd_levels[i]
            prev = c + (prev - c) * (math.exp(-d / tau) if tau > 0 else 0.0)
    if tau > 0:
        x = tm - starts[idx]
        actual = cmd + (a[idx] - cmd) * np.exp(-x / tau)
    else:
        actual = cmd.copy()
    plateaus = [{"index": i, "rate_dps": r, "start_s": float(starts[i]),
                 "end_s": float(starts[i + 1])} for i, r in enumerate(rates)]
    return TableSchedule(cmd, actual, plateaus)


# ------------------------------------------------------------------------------ magnetic field


def helmholtz_levels(h: HelmholtzSpec) -> list[float]:
    """0 -> +max -> -max -> 0 in steps (Antonova & Matveev, Antonova & Matveev): 0, 50, ..., 300, 250,
    ..., -300, -250, ..., 0 uT for step 50, max 300 (25 levels)."""
    k = int(round(h.max_uT / h.step_uT))
    up = [i * h.step_uT for i in range(0, k + 1)]
    down = [i * h.step_uT for i in range(k - 1, -k - 1, -1)]
    back = [i * h.step_uT for i in range(-k + 1, 1)]
    return up + down + back


def helmholtz_schedule(h: HelmholtzSpec) -> list[dict]:
    """Time windows of every level on every axis (one axis at a time)."""
    levels = helmholtz_levels(h)
    out = []
    t = h.start_s
    for ax in h.axes:
        for lv in levels:
            out.append({"axis": ax, "level_uT": lv, "start_s": t, "end_s": t + h.dwell_s})
            t += h.dwell_s
        t += h.pause_s
    return out


def magnetic_field(spec: FieldSpec, tm: np.ndarray, tau0: float,
                   rng: np.random.Generator) -> tuple[np.ndarray, list[dict]]:
    """True field (3, n) in uT in the gyro frame: background + sinusoid + random walk +
    Helmholtz levels (applied along one axis at a time)."""
    n = tm.size
    H = np.empty((3, n))
    for i in range(3):
        H[i] = spec.background_uT[i]
        if spec.sine_amplitude_uT[i]:
            H[i] += spec.sine_amplitude_uT[i] * np.sin(2 * math.pi * tm / spec.sine_period_s)
    if spec.random_walk_uT_per_sqrt_h > 0:
        step = spec.random_walk_uT_per_sqrt_h * math.sqrt(tau0 / 3600.0)
        H += np.cumsum(rng.standard_normal((3, n)) * step, axis=1)
    sched: list[dict] = []
    if spec.helmholtz is not None:
        sched = helmholtz_schedule(spec.helmholtz)
        starts = np.array([w["start_s"] for w in sched])
        idx = np.searchsorted(starts, tm, side="right") - 1
        ax_index = {"x": 0, "y": 1, "z": 2}
        for j, w in enumerate(sched):
            m = (idx == j) & (tm < w["end_s"])
            if m.any() and w["level_uT"]:
                H[ax_index[w["axis"]], m] += w["level_uT"]
    return H, sched


# ------------------------------------------------------------------------------ supply


def supply_voltage(spec: SupplySpec, tm: np.ndarray, tau0: float) -> np.ndarray:
    """True supply voltage: nominal, set-point steps [[t_s, V], ...], linear drift, and a
    ripple averaged exactly over each sample interval (no aliasing of mains ripple)."""
    V = np.full(tm.size, spec.nominal_v)
    for t_s, v in sorted(spec.steps):
        V[tm >= t_s] = v
    if spec.drift_v_per_h:
        V = V + spec.drift_v_per_h * tm / 3600.0
    if spec.ripple_v:
        w = 2 * math.pi * spec.ripple_hz
        a, b = tm - tau0 / 2, tm + tau0 / 2
        V = V + spec.ripple_v * (np.cos(w * a) - np.cos(w * b)) / (w * tau0)
    return V


def profile_end(spec: TemperatureSpec) -> float:
    """End time (s) of the temperature profile."""
    return build_pieces(spec)[1]
