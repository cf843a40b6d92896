"""The working data of the drift-model fit: a log reduced to smoothed block means.

Raw 10 Hz samples are dominated by white noise and 10⁶ rows make every fit slow, while the
environmental effects live at minutes to hours. gyrotest therefore fits **smoothed block
means**:

1. channels are averaged onto a fine grid (dt_f ≈ 1 s, a multiple of τ0) on which every
   regressor is computed (powers, lags and derivatives of the channels);
2. the gyro rate and every regressor pass through the same smoother S_W (moving mean over W,
   applied twice: a triangular kernel 2·W wide). Because output and regressors are filtered
   alike, a model linear in its coefficients stays exact, and the dT/dt regressor
   d(S_W T)/dt = S_W(dT/dt) carries no smoothing bias however large W is; W only costs time
   resolution. W = max(60 s, the window at which the noisiest temperature sensor's derivative
   noise falls to 1–5 % of its dT/dt RMS: 1 % when the rate follows that dT/dt strongly, up
   to 5 % when its derivative noise would not show in the model) (:func:`choose_smoothing`);
3. everything is averaged over consecutive blocks of T_b inside each gap-free segment (the
   smoother's reach, 2·W, is left out at each segment end).

T_b is chosen from the noise level (:func:`choose_resolution`): the rate's Allan deviation
reaches its minimum at τ_min (below it white noise dominates, above it drift and environment);
T_b = τ_min/4 rounded down to 1-2-5 steps, clipped to [max(W/4, duration/20000),
max(that, min(60 s, duration/300))]: no finer than the smoothed series can carry, at most
20 000 blocks, at least 300 when the record allows. ``resolution=`` and ``smoothing_s=``
override. The choice and its reason are stated in every result.
"""

from __future__ import annotations

import hashlib
import math
import os
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..core.errors import AnalysisError, InputError
from . import stats as st
from .frame import _white_sigma
from .terms import (
    EnvFrame,
    Refs,
    default_refs,
    frame_from_log,
    smooth,
    smoothed_rate,
    smoothing_half,
)

NICE_STEPS = (0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 30.0, 60.0)
MAX_BLOCKS = 20000
MIN_BLOCKS_RES = 300
MAX_RES_S = 60.0
#: the smoother makes the derivative noise of a temperature sensor at most this fraction of its
#: dT/dt RMS (a regressor noise r attenuates a dT/dt coefficient by r²) ...
DERIV_NOISE_FRAC = (0.05, 0.03, 0.02, 0.01)
#: ... the largest fraction whose prediction noise, fraction × (an upper estimate of the rate
#: variation that follows that sensor's dT/dt), stays below this share of the white-noise
#: floor at W; 1 % when the rate follows dT/dt strongly
DERIV_NOISE_SHARE = 0.25


# ============================================================================ working data
@dataclass
class WorkData:
    """A log prepared for model fitting: fine-grid channels and block means."""

    frame: EnvFrame  # fine grid (rate + channels)
    block: np.ndarray  # block id of each fine sample (−1: not used)
    counts: np.ndarray  # fine samples per block
    t: np.ndarray  # block mean time, s
    y: np.ndarray  # block mean rate (minus input rate), deg/h
    resolution_s: float
    resolution_note: str
    refs: Refs
    axis: str
    info: dict[str, Any] = field(default_factory=dict)
    log: Any = None
    #: the fixed noise floor (st.NoiseFloor) the models of this log are judged against
    floor: Any = None
    #: noise parameters fixed from a static reference run
    #: (:class:`gyrotest.envmodel.likelihood.NoiseParams`), else None: estimated per model
    noise_ref: Any = None
    #: the log starts at the gyro's power-on (a warm-up transient is a candidate effect)
    power_on: bool = False
    #: each filtered channel's measurement noise ({name: SensorNoise},
    #: :mod:`gyrotest.envmodel.sensors`)
    sensor_noise: dict = field(default_factory=dict)
    #: the working resolution in a few words, for one-line summaries
    resolution_short: str = ""
    #: effective averaging time of the smoother and the blocks (s); None: the resolution
    t_eff: float | None = None
    #: the white-noise parameter N² ((deg/h)²·s) of the full band
    #: (:func:`gyrotest.envmodel.likelihood.white_level`), computed on first use
    white_n2: float | None = field(default=None, init=False, repr=False, compare=False)
    #: the component autocovariances per sample length
    #: (:func:`gyrotest.envmodel.likelihood.acov_for`)
    acov_cache: dict = field(default_factory=dict, init=False, repr=False, compare=False)
    #: each quantised channel's reconstructed node path
    #: (:func:`gyrotest.envmodel.sensors.reading_path`), computed on first use
    sensor_paths: dict = field(default_factory=dict, init=False, repr=False, compare=False)
    _sel_cache: np.ndarray | None = field(default=None, init=False, repr=False, compare=False)
    _starts_cache: np.ndarray | None = field(default=None, init=False, repr=False,
                                             compare=False)
    _ids_cache: tuple[np.ndarray, bool] | None = field(default=None, init=False, repr=False,
                                                       compare=False)

    @property
    def nb(self) -> int:
        return len(self.y)

    @property
    def duration_s(self) -> float:
        return float(self.info.get("duration_s", self.frame.duration_s))

    def bmean(self, x: np.ndarray) -> np.ndarray:
        """Block means of a fine-grid array (n_f,) or (n_f, k)."""
        sel = self._sel
        ids, every = self._ids
        if x.ndim == 1:
            return np.bincount(ids, weights=x if every else x[sel],
                               minlength=self.nb) / self.counts
        # the selected samples' block ids never decrease (blocks are consecutive runs of the
        # fine grid): one reduceat over the starts of the blocks sums every column at once
        xs = x if every else x[sel]
        return np.add.reduceat(xs, self._starts, axis=0) / self.counts[:, None]

    def smooth(self, x: np.ndarray) -> np.ndarray:
        """The working smoother S_W on the fine grid (columns of a 2-D array separately)."""
        W = self.refs.smoothing_s
        if x.ndim == 1:
            return smooth(x, self.frame.dt, W, self.frame.bounds)
        return np.column_stack([smooth(x[:, j], self.frame.dt, W, self.frame.bounds)
                                for j in range(x.shape[1])])

    @property
    def _sel(self) -> np.ndarray:
        if self._sel_cache is None:
            self._sel_cache = self.block >= 0
        return self._sel_cache

    @property
    def _starts(self) -> np.ndarray:
        """Index (among the selected samples) of the first sample of each block."""
        if self._starts_cache is None:
            ids, _ = self._ids
            self._starts_cache = np.flatnonzero(np.r_[True, ids[1:] != ids[:-1]])
        return self._starts_cache

    @property
    def _ids(self) -> tuple[np.ndarray, bool]:
        """The block id of each selected fine sample, and whether every sample is selected."""
        if self._ids_cache is None:
            sel = self._sel
            self._ids_cache = (self.block[sel], bool(sel.all()))
        return self._ids_cache


def _nice_floor(x: float) -> float:
    best = NICE_STEPS[0]
    for s in NICE_STEPS:
        if s <= x * (1 + 1e-9):
            best = s
    return best


def choose_resolution(frame: EnvFrame, smoothing_s: float, duration_s: float
                      ) -> tuple[float, str, dict]:
    """Working resolution T_b (s): the block length, chosen from the noise level.

    Rule: τ_min = argmin of the overlapping Allan deviation of the rate (octave τ, on the fine
    grid ``frame``): below τ_min white noise dominates, above it drift and environment. T_b =
    τ_min/4 rounded down to a 1-2-5 step and clipped to [max(W/4, duration/20000, dt_f),
    max(that, min(60 s, duration/300))]: no finer than a quarter of the smoother window W (the
    smoothed series carries nothing faster), at most 20 000 blocks, and at least 300 blocks when
    the record allows; a multiple of the fine-grid step dt_f. Returns (T_b, reason, details).
    """
    dt = frame.dt
    tau, sig = st.oadev(frame.rate, dt, segments=frame.bounds)
    lo = max(smoothing_s / 4.0, duration_s / MAX_BLOCKS, dt)
    hi = max(lo, min(MAX_RES_S, duration_s / MIN_BLOCKS_RES))
    if len(sig):
        i = int(np.argmin(sig))
        tmin, smin = float(tau[i]), float(sig[i])
        target = tmin / 4.0
    else:  # pragma: no cover - very short logs
        tmin, smin, target = dt, float("nan"), dt
    tb = _nice_floor(min(max(target, lo), hi))
    if tb < lo:
        tb = lo
    tb = max(dt, round(tb / dt) * dt)
    why = (f"block means of {tb:g} s: the rate's Allan deviation is lowest "
           f"({smin:.3g} deg/h) at tau = {tmin:.3g} s (white noise dominates below); "
           f"T_b = tau_min/4 rounded to 1-2-5 within [{lo:.3g}, {hi:.3g}] s "
           f"(>= W/4, <= {MAX_BLOCKS} and >= {MIN_BLOCKS_RES} blocks, <= {MAX_RES_S:g} s)")
    return tb, why, {"tau_min_s": tmin, "sigma_min_dph": smin}


def file_provenance(path: str | os.PathLike | None) -> dict:
    """File name, size and sha256 of the input file (for the model's provenance)."""
    if path is None or str(path) == "-":
        return {"file": "<stdin>" if path == "-" else None}
    p = os.fspath(path)
    h = hashlib.sha256()
    with open(p, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return {"file": os.path.basename(p), "path": os.path.abspath(p), "sha256": h.hexdigest(),
            "bytes": os.path.getsize(p)}


def channel_ranges(log) -> dict[str, list[float]]:
    """min/max of every auxiliary channel (the model's domain of validity)."""
    out: dict[str, list[float]] = {}
    for k, v in log.temperature.items():
        out[f"temperature:{k}"] = [float(np.nanmin(v)), float(np.nanmax(v))]
    for k, v in log.field_uT.items():
        out[f"field:{k}"] = [float(np.nanmin(v)), float(np.nanmax(v))]
    if log.supply is not None:
        out["supply:V"] = [float(np.nanmin(log.supply)), float(np.nanmax(log.supply))]
    for k, v in log.extra.items():
        try:
            out[f"extra:{k}"] = [float(np.nanmin(v)), float(np.nanmax(v))]
        except (TypeError, ValueError):
            pass
    return out


def choose_smoothing(frame: EnvFrame, duration_s: float) -> tuple[float, str]:
    """Window W of the working smoother S_W (moving mean over W, applied twice).

    Rule: W = max(min(60 s, duration/20), 4·dt_f, W_noise), W_noise = the window at which the derivative noise of
    the noisiest temperature sensor, σ_T·√(2·dt/W³)·3600 degC/h (σ_T from second differences
    on the fine grid), falls to a fraction f of the RMS of that sensor's dT/dt (sensors whose
    dT/dt is at the noise level are ignored); at most duration/20. f is the largest of 5, 3, 2
    and 1 % for which f × (an upper estimate of how much of the gyro rate follows that dT/dt,
    :func:`_rate_effect_bound`) stays below a quarter of the white-noise floor at W: the
    regressor noise then costs the model nothing measurable, and a log whose rate hardly
    follows dT/dt (a Helmholtz or tilt run) keeps a short window and its time resolution.
    Because S_W is applied to the gyro rate and to every regressor alike, W costs time
    resolution but never biases a coefficient.
    """
    w0 = max(min(60.0, duration_s / 20.0), 4.0 * frame.dt)
    need = w0
    why = "at least 60 s" if w0 >= 60.0 else "a log shorter than 20 min: 1/20 of its length"
    s1 = _white_sigma(frame)
    for name, x in frame.temperature.items():
        x = np.asarray(x, float)
        if len(x) < 8 or not np.all(np.isfinite(x)):
            continue
        d2 = x[2:] - 2 * x[1:-1] + x[:-2]
        sig = 1.4826 * float(np.median(np.abs(d2 - np.median(d2)))) / math.sqrt(6.0)
        if sig <= 0:
            sig = float(np.std(d2)) / math.sqrt(6.0)
        rate = smoothed_rate(x, frame.dt, w0, frame.bounds)
        edge = 2 * smoothing_half(w0, frame.dt)
        inner = np.zeros(len(rate), bool)
        for a, b in frame.bounds:
            inner[a + edge:b - edge] = True
        if not inner.any():
            continue
        rms = float(np.sqrt(np.mean(rate[inner] ** 2)))
        noise0 = sig * 3600.0 * math.sqrt(2 * frame.dt / w0 ** 3)
        if not (rms > 0 and sig > 0) or rms < 3.0 * noise0:
            continue  # no measurable temperature change: nothing to resolve
        effect = _rate_effect_bound(frame, rate, inner, w0)
        for frac in DERIV_NOISE_FRAC:
            w = (sig * 3600.0 * math.sqrt(2 * frame.dt) / (frac * rms)) ** (2.0 / 3.0)
            floor_w = s1 * math.sqrt(frame.dt / max(w, w0))
            if frac * effect <= DERIV_NOISE_SHARE * floor_w:
                break
        if w > need:
            need = w
            why = (f"derivative noise of {name} (σ ≈ {sig:.2g} °C per {frame.dt:g} s) below "
                   f"{100 * frac:g} % of its dT/dt RMS ({rms:.3g} °C/h); the rate follows "
                   f"its dT/dt by at most ≈ {effect:.2g} deg/h")
    cap = max(w0, duration_s / 20.0)
    W = min(need, cap)
    W = float(np.ceil(W / frame.dt - 1e-9) * frame.dt)
    return W, f"smoothing window W = {W:g} s ({why})"


def _rate_effect_bound(frame: EnvFrame, trate: np.ndarray, inner: np.ndarray,
                       w0: float) -> float:
    """Upper estimate (deg/h) of the RMS of the gyro-rate variation that follows one sensor's
    dT/dt: the rate, smoothed over ``w0``, regressed on a constant, that dT/dt (``trate``,
    degC/h) and the level of every logged channel, on samples one window apart;
    (|D| + 2·SE(D))·RMS(dT/dt). Only the size matters: it decides how finely the smoother
    must suppress that sensor's derivative noise."""
    step = max(1, int(round(w0 / frame.dt)))
    idx = np.flatnonzero(inner)[::step]
    if len(idx) < 12:
        return math.inf
    y = smooth(np.asarray(frame.rate, float), frame.dt, w0, frame.bounds)[idx]
    cols = [np.ones(len(idx)), trate[idx]]
    for group in (frame.temperature, frame.field_uT, frame.extra):
        for v in group.values():
            v = np.asarray(v, float)
            if v.shape == trate.shape and np.all(np.isfinite(v[idx])):
                cols.append(smooth(v, frame.dt, w0, frame.bounds)[idx])
    fields = [np.asarray(v, float) for v in frame.field_uT.values()
              if np.shape(v) == trate.shape and np.all(np.isfinite(v))]
    for i, a in enumerate(fields):  # second-order field terms (Antonova-Matveev m = 2)
        for b in fields[i:]:
            cols.append(smooth(a * b, frame.dt, w0, frame.bounds)[idx])
    if frame.supply is not None:
        cols.append(smooth(np.asarray(frame.supply, float), frame.dt, w0, frame.bounds)[idx])
    X = np.column_stack(cols)
    X[:, 2:] -= X[:, 2:].mean(axis=0)
    sd = X.std(axis=0)
    keep = np.ones(X.shape[1], bool)
    keep[2:] = sd[2:] > 0
    X = X[:, keep]
    if len(idx) < X.shape[1] + 8:
        X = X[:, :2]
    beta = st.lstsq(X, y)[0]
    e = y - X @ beta
    dof = max(1, len(idx) - X.shape[1])
    s2 = float(e @ e) / dof
    try:
        cov = s2 * np.linalg.pinv(X.T @ X)
    except np.linalg.LinAlgError:
        return math.inf
    se = math.sqrt(max(float(cov[1, 1]), 0.0))
    return (abs(float(beta[1])) + 2.0 * se) * float(np.sqrt(np.mean(trate[idx] ** 2)))


def prepare(log, *, axis: str | None = None, resolution: float | None = None,
            t_ref: float | None = None, v_ref: float | None = None,
            smoothing_s: float | None = None, t_on_s: float = 0.0,
            provenance: dict | None = None, fine_dt: float | None = None) -> WorkData:
    """Prepare a :class:`~gyrotest.core.data.GyroLog` for fitting at the working resolution.

    ``resolution`` T_b (s; default chosen by :func:`choose_resolution`), ``t_ref`` reference
    temperature degC (default: mean, per sensor), ``v_ref`` reference supply V (default mean),
    ``smoothing_s`` smoother window W (default :func:`choose_smoothing`), ``t_on_s`` power-on
    time relative to the log start (warm-up term; −skip when the start was trimmed).

    The gyro rate and every regressor are smoothed by S_W and then averaged over blocks of T_b
    within each segment; samples within the smoother's reach (2·⌈W/2⌉) of a segment end are
    left out.
    """
    axis = axis or log.axes[0]
    if axis not in log.rates:
        raise InputError(f"{log.source}: no gyro axis {axis!r} (axes: {', '.join(log.axes)})")
    if log.n < 8:
        raise AnalysisError(f"{log.source}: only {log.n} samples; too short to fit a model")
    details: dict = {}
    dur = log.duration_s
    if resolution is not None:
        resolution = float(resolution)
        if not resolution > 0:
            raise InputError(f"resolution must be > 0 s (got {resolution:g})")
        if resolution < log.tau0 * (1 - 1e-9):
            raise InputError(f"resolution {resolution:g} s is shorter than the sample interval "
                             f"{log.tau0:g} s")
    if fine_dt is None:
        fine_dt = max(min(1.0, resolution or 1.0), dur / 200000.0)
    mf = max(1, int(round(fine_dt / log.tau0)))
    fine_dt = mf * log.tau0
    frame = frame_from_log(log, axis=axis, dt=fine_dt if mf > 1 else None)
    # each temperature and extra channel's own measurement noise, carried into the noise
    # model through the terms that read it (:mod:`gyrotest.envmodel.sensors`)
    from .sensors import measure_frame

    sensor_noise = measure_frame(frame)
    if smoothing_s is None:
        W, wnote = choose_smoothing(frame, dur)
    else:
        W = float(smoothing_s)
        if not W > 0:
            raise InputError(f"smoothing window must be > 0 s (got {W:g})")
        wnote = f"smoothing window W = {W:g} s (given)"
    if resolution is None:
        tb, why, details = choose_resolution(frame, W, dur)
    else:
        tb = resolution
        why = f"block means of {tb:g} s (given)"
    m = max(1, int(round(tb / fine_dt)))
    tb = m * fine_dt
    h = smoothing_half(W, frame.dt)
    edge = 2 * h
    block = np.full(frame.n, -1, dtype=np.int64)
    nb = 0
    for a, b in frame.bounds:
        a2, b2 = a + edge, b - edge
        if b2 - a2 < max(1, (m + 1) // 2):
            continue
        k = (b2 - a2) // m
        rem = (b2 - a2) - k * m
        ids = nb + np.repeat(np.arange(k), m)
        block[a2:a2 + k * m] = ids
        nb += k
        if rem >= (m + 1) // 2 and rem > 0:
            block[a2 + k * m:b2] = nb
            nb += 1
    if nb < 3:
        raise AnalysisError(f"{log.source}: only {nb} usable blocks of {tb:g} s (smoothing "
                            f"window {W:g} s trims each segment end); the log is too short "
                            "for this resolution (use a finer --resolution or --smooth)")
    counts = np.bincount(block[block >= 0], minlength=nb).astype(float)
    refs = default_refs(frame, t_ref=t_ref, v_ref=v_ref, smoothing_s=W, t_on_s=t_on_s,
                        resolution_s=tb)
    info = {"source": log.source, "axis": axis, "samples": log.n, "tau0_s": log.tau0,
            "duration_s": log.duration_s, "start": log.timing.start,
            "segments": len(log.segments), "fine_dt_s": fine_dt, "blocks": nb,
            "smoothing_window_s": W, "channel_ranges": channel_ranges(log),
            "sensor_noise": {k: v.to_dict() for k, v in sensor_noise.items()}, **details}
    if provenance:
        info.update(provenance)
    wd = WorkData(frame=frame, block=block, counts=counts, t=np.zeros(nb), y=np.zeros(nb),
                  resolution_s=tb, resolution_note=why + "; " + wnote + "; the same smoother "
                  "is applied to the gyro rate and to every regressor", refs=refs, axis=axis,
                  info=info, log=log, sensor_noise=sensor_noise)
    wd.t = wd.bmean(frame.t)
    wd.y = wd.bmean(wd.smooth(frame.rate))
    tm = details.get("tau_min_s")
    wd.resolution_short = (f"{tb:g} s blocks after a W = {W:g} s matched smoother"
                           + (f" (Allan minimum {details['sigma_min_dph']:.3g} deg/h at "
                              f"{tm:.3g} s)" if tm else " (given)"))
    wd.t_eff = effective_averaging_time(frame.dt, h, m)
    return wd


def effective_averaging_time(dt: float, half: int, m: int) -> float:
    """Averaging time T_eff (s) of the combined filter (smoother S_W then block mean of m
    samples) for white noise: T_eff = dt / Σ h_k² with h the unit-sum impulse response."""
    box = np.ones(2 * half + 1) / (2 * half + 1)
    k = np.convolve(np.convolve(box, box), np.ones(m) / m)
    return float(dt / np.sum(k * k))
