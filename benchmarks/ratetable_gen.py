"""Independent rate-table log generator for the scale-factor settling/repeatability checks.

Deliberately *not* built on ``gyrotest.simulation``: plain numpy, its own physics, its own truth.
A pulse-output gyro (counts per sample) on a rate table that follows the commanded rate with a
first-order lag (time constant ``lag_s``; 0 = ideal steps). Per run r the scale factor (input
per output pulse, arcsec/pulse, the unit of the SF column) is

    S_r = S0 · (1 + 1e-6·(e0 + δ_r)),    S± = S_r · (1 ± ½·1e-6·A)

for inputs of either sign, so that the asymmetry A = (S+ − S−)/(½(S+ + S−))·1e6 is defined with
the SF column's own (input per output) scale factor. Pulses = floor(θ/S) of the exactly
integrated angle (closed-form lag response on 10 sub-steps per sample) plus white angle noise
(ARW ``arw_dpsh``, deg/√h) and a constant bias ``bias_dph`` (deg/h, earth rate included: no
site is written, so the tool keeps it in the bias). Truth: every run's S_r (arcsec/pulse),
A (ppm), and the repeatability = std(S_r, ddof=1)/mean·1e6 (ppm).

Usage (as a library)::

    from ratetable_gen import write_campaign
    truth = write_campaign(tmpdir, seed=1, lag_s=2.0)
    # truth["logs"], truth["profile"], truth["asymmetry_ppm"], truth["repeatability_ppm"]
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

RATES_DPS = (1, 2, 5, 10, 20, 50, 100, 200, 400)


def command_sequence(rates=RATES_DPS, reverse: bool = False) -> list[float]:
    """+r1, −r1, +r2, −r2, … (alternating signs, rising magnitudes); ``reverse``: the same
    plateaus in the opposite time order."""
    seq = [s * r for r in rates for s in (1.0, -1.0)]
    return seq[::-1] if reverse else seq


def table_angle(cmd_dps: list[float], dwell_s: float, fs_hz: float, lag_s: float,
                sub: int = 10) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Table angle increments (arcsec) on sub-steps of 1/(fs·sub) s, the sign of the table rate
    on each sub-step, and the commanded rate (deg/s) per output sample. First-order lag:
    ω(t) = c + (ω0 − c)·e^(−t/τ) from each command change; θ(t) = c·t + (ω0 − c)·τ·(1 − e^(−t/τ))."""
    n_per = int(round(dwell_s * fs_hz))
    dt = 1.0 / (fs_hz * sub)
    t = np.arange(1, n_per * sub + 1) * dt  # sub-step ends from the command change
    w0 = 0.0
    dth, sgn, cmd = [], [], []
    for c in cmd_dps:
        c_as = c * 3600.0
        if lag_s > 0:
            e = np.exp(-t / lag_s)
            th = c_as * t + (w0 - c_as) * lag_s * (1 - e)
            w_end = c_as + (w0 - c_as) * e
        else:
            th = c_as * t
            w_end = np.full_like(t, c_as)
        inc = np.diff(np.r_[0.0, th])
        dth.append(inc)
        sgn.append(np.sign(inc))
        cmd.append(np.full(n_per, c))
        w0 = float(w_end[-1])
    return np.concatenate(dth), np.concatenate(sgn), np.concatenate(cmd)


def make_run(*, seed: int, s_run: float, asym_ppm: float, lag_s: float, arw_dpsh: float,
             bias_dph: float, temperature_c: float, reverse: bool, rates=RATES_DPS,
             settle_s: float = 20.0, dwell_s: float = 60.0, fs_hz: float = 10.0,
             lead_s: float = 30.0) -> dict[str, np.ndarray]:
    """One run: columns t_s, pulses (per sample), table_dps (commanded), T_C. A ``lead_s``
    zero-rate stretch precedes the sequence (power-on, not a plateau of the sweep)."""
    rng = np.random.default_rng(seed)
    sub = 10
    cmds = command_sequence(rates, reverse)
    dth, sgn, cmd = table_angle(cmds, settle_s + dwell_s, fs_hz, lag_s, sub)
    n_lead = int(round(lead_s * fs_hz))
    dt = 1.0 / (fs_hz * sub)
    # sensed angle: table + bias, split by the sign of the input, each side with its own S
    inp = dth + bias_dph * dt  # arcsec per sub-step (1 deg/h = 1 arcsec/s)
    s_pos = s_run * (1 + 0.5e-6 * asym_ppm)
    s_neg = s_run * (1 - 0.5e-6 * asym_ppm)
    pulses_sub = np.where(inp >= 0, inp / s_pos, inp / s_neg)
    per_sample = pulses_sub.reshape(-1, sub).sum(axis=1)
    lead = np.full(n_lead, bias_dph / fs_hz / s_pos)
    p = np.r_[lead, per_sample]
    # white rate noise (ARW): angle increment σ = 60·N·√τ0 arcsec per sample
    p = p + rng.normal(0.0, 60.0 * arw_dpsh * math.sqrt(1 / fs_hz), len(p)) / s_run
    cum = np.floor(np.cumsum(p) + rng.uniform())
    pulses = np.diff(np.r_[0.0, cum]).astype(np.int64)
    n = len(pulses)
    return {"t_s": np.arange(1, n + 1) / fs_hz, "pulses": pulses,
            "table_dps": np.r_[np.zeros(n_lead), cmd],
            "T_C": np.round(temperature_c + 0.02 * rng.standard_normal(n), 3)}


PROFILE = """[columns]
time = "t_s"
counts = "pulses"
temperature = ["T_C"]
table_rate = "table_dps"

[units]
table_dps = "deg/s"

[gyro]
scale_factor = {s0}
serial = "GEN-1"
"""


def write_campaign(outdir, *, seed: int, lag_s: float = 2.0, arw_dpsh: float = 0.01,
                   asym_ppm: float = 35.0, e0_ppm: float = 120.0, rep_ppm: float = 10.0,
                   bias_dph: float = 8.0, s0: float = 0.5, runs: int = 3,
                   reversed_runs=(1,), temperatures_c=None, rates=RATES_DPS,
                   settle_s: float = 20.0, dwell_s: float = 60.0, fs_hz: float = 10.0) -> dict:
    """Write ``runs`` CSV logs + one profile to ``outdir``; return the truth (JSON-ready).
    Run-to-run SF changes δ_r ~ N(0, rep_ppm); the truth repeatability is their actual sample
    standard deviation."""
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    delta = rng.normal(0.0, rep_ppm, runs) if rep_ppm > 0 else np.zeros(runs)
    temps = list(temperatures_c) if temperatures_c is not None else [22.0] * runs
    logs, s_runs = [], []
    for r in range(runs):
        s_r = s0 * (1 + 1e-6 * (e0_ppm + delta[r]))
        d = make_run(seed=seed * 1000 + r, s_run=s_r, asym_ppm=asym_ppm, lag_s=lag_s,
                     arw_dpsh=arw_dpsh, bias_dph=bias_dph, temperature_c=temps[r],
                     reverse=r in reversed_runs, rates=rates, settle_s=settle_s,
                     dwell_s=dwell_s, fs_hz=fs_hz)
        path = out / f"run{r + 1}.csv"
        with open(path, "w") as f:
            f.write("t_s,pulses,table_dps,T_C\n")
            np.savetxt(f, np.column_stack([d["t_s"], d["pulses"], d["table_dps"], d["T_C"]]),
                       fmt=["%.1f", "%d", "%g", "%.3f"], delimiter=",")
        logs.append(str(path))
        s_runs.append(s_r)
    prof = out / "bench.toml"
    prof.write_text(PROFILE.format(s0=s0))
    s_arr = np.array(s_runs)
    truth = {"logs": logs, "profile": str(prof), "seed": seed, "lag_s": lag_s,
             "arw_dpsh": arw_dpsh, "scale_factor_per_run_arcsec_per_pulse": s_runs,
             "scale_factor_arcsec_per_pulse": float(s_arr.mean()),
             "asymmetry_ppm": asym_ppm,
             "asymmetry_definition": "(S+ - S-)/(0.5(S+ + S-))*1e6, S = input per output pulse",
             "repeatability_ppm": float(np.std(s_arr / s_arr.mean(), ddof=1) * 1e6)
             if runs > 1 else math.nan,
             "temperatures_c": temps}
    (out / "truth.json").write_text(json.dumps(truth, indent=1))
    return truth
