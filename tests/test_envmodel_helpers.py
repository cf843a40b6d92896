"""Shared helpers for the envmodel tests: small synthetic logs and cached simulator runs.

(No tests here; imported by the ``test_envmodel*.py`` modules.)
"""

from __future__ import annotations

import copy
import functools
import tomllib
from pathlib import Path

import numpy as np

from gyrotest.core.data import GyroConstants, GyroLog, Timing

SCENARIOS = Path(__file__).resolve().parents[1] / "sample_data" / "scenarios"


def make_log(rate, tau0, *, temps=None, field=None, supply=None, extra=None, table=None,
             source="synthetic.csv") -> GyroLog:
    """A GyroLog built directly from arrays (deg/h, degC, uT, V)."""
    rate = np.asarray(rate, float)
    n = len(rate)
    timing = Timing(n=n, tau0=tau0, duration_s=n * tau0, source="synthetic")
    return GyroLog(source=source, rates={"rate": rate}, tau0=tau0, timing=timing,
                   gyro=GyroConstants("rate", rate_unit="deg/h"), temperature=dict(temps or {}),
                   field_uT=dict(field or {}), supply=supply, table_rate=table,
                   extra=dict(extra or {}))


def chamber_profile(t: np.ndarray) -> np.ndarray:
    """Piecewise-linear chamber temperature: ramps up and down between 20 and 45 degC."""
    kt = np.array([0, 0.5, 1.5, 2.0, 3.0, 3.5, 4.2, 5.0]) * 3600
    kT = np.array([20, 20, 45, 45, 25, 25, 38, 38])
    return np.interp(t, kt, kT)


def lag(x, t, tau):
    from gyrotest.envmodel.terms import first_order_lag

    return first_order_lag(np.asarray(x, float), t, tau)


def load_scenario_dict(name: str) -> dict:
    with open(SCENARIOS / name, "rb") as fh:
        return tomllib.load(fh)


@functools.lru_cache(maxsize=64)
def _sim(name: str, seed: int, rate_hz: float | None, tmpdir: str):
    from gyrotest.core.profile import profile_from_dict
    from gyrotest.io.ingest import read_log
    from gyrotest.simulation import simulate, write_log

    sc = load_scenario_dict(name)
    if rate_hz is not None:
        sc["record"]["sample_rate_hz"] = rate_hz
    res = simulate(sc, seed=seed)
    stem = f"{Path(name).stem}_{seed}_{rate_hz or 'd'}"
    w = write_log(res, Path(tmpdir) / f"{stem}.parquet")
    log = read_log(w.logs[0], profile=profile_from_dict(res.profile))
    return res, log, w.logs[0]


def simulated(name: str, seed: int, tmpdir, rate_hz: float | None = None):
    """(SimResult, GyroLog, path) of a scenario file in sample_data/scenarios, cached."""
    return _sim(name, seed, rate_hz, str(tmpdir))


def noise_floor_of(res, log, wd) -> float:
    """The simulated noise floor at the working resolution of ``wd``: the RMS of the pure
    noise (ideal − noise-free output) through the same smoother and blocks."""
    from gyrotest.envmodel.modelfit import prepare

    run = res.run
    noise_log = copy.copy(log)
    noise_log.rates = {log.axes[0]: run.ideal_rate_dph - run.noise_free_rate_dph}
    wd2 = prepare(noise_log, resolution=wd.resolution_s, smoothing_s=wd.refs.smoothing_s,
                  t_ref=21.0)
    return float(np.std(wd2.y))


def colored_noise(n: int, dt: float, *, N: float = 0.0, B: float = 0.0, K: float = 0.0,
                  rng=None) -> np.ndarray:
    """Gyro rate noise (deg/h) on a grid of ``dt`` s with the IEEE 952 parameters N
    (deg/√h, white: σ²(τ) = N²/τ), B (deg/h, flicker with two-sided PSD B²/(2πf)) and K
    (deg/h/√h, rate random walk: σ²(τ) = K²τ/3). Flicker by shaping white noise in the
    frequency domain (a record twice as long, the first half kept)."""
    rng = rng or np.random.default_rng()
    x = (N * 60.0) / np.sqrt(dt) * rng.standard_normal(n)
    if B > 0:
        nf = 2 * n
        W = np.fft.rfft(rng.standard_normal(nf))
        f = np.fft.rfftfreq(nf, dt)
        S = np.zeros_like(f)
        S[1:] = B * B / (2 * np.pi * f[1:])
        x += np.fft.irfft(W * np.sqrt(S / dt), nf)[:n]
    if K > 0:
        x += np.cumsum((K / 60.0) * np.sqrt(dt) * rng.standard_normal(n))
    return x
