"""The simulator: scenario -> bench-log arrays plus the truth.

Model (IEEE 952 §8.3, GYRO_REFERENCE §1), per sample interval k (interval averages):

    S0 dN/dt = LockIn(I + E + D) / (1 + 1e-6 eps_K)

* I = table rate + earth-rate component along the IA (position dependent);
* E = thermal terms (D_T dT + D_T2 dT^2 + D_T3 dT^3, D_Tdot dT/dt, D_gradTdot d(Ta - Tb)/dt,
  heating/cooling hysteresis, the Antonova-Matveev model) + magnetic w.H/H0 + supply
  sensitivity (V - V_nom);
* D = D_F (bias, + run-to-run offset) + warm-up A e^(-t/tau_w) + rate ramp R t + random drift
  (ARW N, bias instability B, RRW K, white angle Q, Markov, sinusoids, blue families);
* eps_K = sf offset + run offset - asym/2 sign(I) + sum_k c_k (I/I_fs)^k
  + periodic sin(2 pi I/period + phase) + eps_T (T - T_ref)   [ppm];
* LockIn(x) = sign(x) sqrt(x^2 - L^2) for |x| > L, else 0 (RLG dead band, Adler equation).

The output encoding (pulses with remainder carry, up/down pairs, roll-over counter, voltage
with ADC, rate in any unit) comes last.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from ..core.errors import InputError
from ..core.profile import profile_from_dict
from ..core.units import rate_factor
from ..noise.terms import TERMS
from . import environment as env
from . import noise as gen
from .scenario import load_scenario
from .simrun import SimResult, SimRun
from .specs import Scenario
from .truth import H0_UT, _summary, _truth

MAX_SAMPLES = 400_000_000

# fixed component ids for independent random streams (adding a term never changes another)
_RNG_IDS = {
    "arw": 1, "bias_instability": 2, "rrw": 3, "white_angle": 4, "markov": 100,
    "sinusoid": 200, "blue": 300, "sensor": 400, "field": 500, "supply": 600, "faults": 700,
    "pulse_phase": 800, "dither": 900, "runs": 1000,
}

_RATE_COLUMN = {"deg/h": "omega_dph", "deg/s": "omega_dps", "rad/s": "omega_rads",
                "mrad/s": "omega_mrads"}


def _rng(seed: int, run: int, key: str, sub: int = 0) -> np.random.Generator:
    return np.random.default_rng(
        np.random.SeedSequence(seed, spawn_key=(run, _RNG_IDS[key] + sub))
    )


# ------------------------------------------------------------------------------------------


def simulate(scenario: dict | str | Path | Scenario, seed: int | None = None) -> SimResult:
    """Simulate a bench log from a scenario (TOML path, parsed dict or :class:`Scenario`).

    ``seed`` (else ``[scenario] seed``, else fresh entropy) makes the result reproducible; the
    seed used is in the truth. Each noise term, sensor and run has its own random stream.
    """
    sc = load_scenario(scenario)
    if seed is None:
        seed = sc.seed
    if seed is None:
        seed = int(np.random.SeedSequence().entropy % (2**63))
    seed = int(seed)
    if seed < 0:
        raise InputError(f"seed must be >= 0, got {seed}")
    runs = sc.runs
    rr = _rng(seed, 0, "runs")
    if runs.sf_offsets_ppm is not None:
        sf_off = list(runs.sf_offsets_ppm)
    else:
        sf_off = list(rr.normal(0.0, runs.sf_sigma_ppm, runs.count)) if runs.sf_sigma_ppm else [
            0.0] * runs.count
    if runs.bias_offsets_dph is not None:
        b_off = list(runs.bias_offsets_dph)
    else:
        b_off = list(rr.normal(0.0, runs.bias_sigma_dph, runs.count)) if runs.bias_sigma_dph \
            else [0.0] * runs.count
    res = SimResult(name=sc.name, seed=seed, scenario=sc)
    for i in range(runs.count):
        res.runs.append(_simulate_run(sc, seed, i + 1, float(sf_off[i]), float(b_off[i])))
    res.summary = _summary(sc, seed, res.runs)
    return res


def _duration(sc: Scenario) -> float:
    if sc.record.duration_s is not None:
        return sc.record.duration_s
    cands = []
    if sc.site.positions:
        cands.append(sum(p.dwell_s for p in sc.site.positions))
    if sc.rate_table is not None:
        cands.append(sum(sc.rate_table.dwell_s))
    if sc.temperature is not None and sc.temperature.segments:
        cands.append(env.profile_end(sc.temperature))
    if sc.field is not None and sc.field.helmholtz is not None:
        sched = env.helmholtz_schedule(sc.field.helmholtz)
        if sched:
            cands.append(sched[-1]["end_s"])
    if not cands or max(cands) <= 0:
        raise InputError(f"{sc.source}: [record] duration_s is missing and no sequence (positions, "
                         "rate table, temperature profile, Helmholtz test) defines a length; "
                         "add e.g. duration_s = \"1h\"")
    return float(max(cands))


def _lock_in(x: np.ndarray, L: float) -> np.ndarray:
    if L <= 0:
        return x
    return np.sign(x) * np.sqrt(np.maximum(x * x - L * L, 0.0))


def _eps_k(sc: Scenario, I: np.ndarray, node_T: dict[str, np.ndarray], sf_off: float,
           i_fs: float) -> np.ndarray | float:
    sf = sc.effects.scale_factor
    eps: np.ndarray | float = sf.offset_ppm + sf_off
    if sf.asymmetry_ppm:
        eps = eps + 0.5 * sf.asymmetry_ppm * np.sign(I)
    for k, c in enumerate(sf.nonlinearity_ppm, start=1):
        if c:
            eps = eps + c * (I / i_fs) ** k
    if sf.periodic_ppm:
        eps = eps + sf.periodic_ppm * np.sin(
            2 * math.pi * (I / 3600.0) / sf.periodic_period_dps + math.radians(sf.periodic_phase_deg)
        )
    if sf.temp_ppm_per_c:
        eps = eps + sf.temp_ppm_per_c * (node_T[sf.node] - sf.t_ref_c)
    return eps


def _simulate_run(sc: Scenario, seed: int, run: int, sf_off: float, bias_off: float) -> SimRun:
    fs = sc.record.sample_rate_hz
    tau0 = 1.0 / fs
    duration = _duration(sc)
    from ..core.limits import SIMULATE_BYTES_PER_SAMPLE, check_samples

    n = check_samples(duration * fs, bytes_per_sample=SIMULATE_BYTES_PER_SAMPLE,
                      what=f"{sc.source}: {duration:g} s at {fs:g} Hz", cap=MAX_SAMPLES,
                      fix="shorten [record] duration_s or lower sample_rate_hz")  # before any
    if n < 16:
        raise InputError(f"{sc.source}: only {n} samples ({duration:g} s at {fs:g} Hz); "
                         "lengthen [record] duration_s or raise sample_rate_hz")
    t_end = np.arange(1, n + 1, dtype=np.float64) * tau0
    tm = t_end - 0.5 * tau0
    comps: dict[str, np.ndarray] = {}
    envd: dict[str, Any] = {}

    # ---- input: earth rate (positions) + rate table
    pos = env.position_schedule(sc.site.positions, sc.site.ia, sc.site.latitude_deg, tm)
    earth = pos.earth_dph
    comps["earth"] = earth
    if pos.index is not None:
        envd["position_index"] = pos.index
    table = None
    if sc.rate_table is not None:
        table = env.table_schedule(sc.rate_table, tm)
        envd["table_cmd_dps"] = table.cmd_dps
        envd["table_actual_dps"] = table.actual_dps
        comps["table"] = table.actual_dps * 3600.0
        I = comps["table"] + earth
    else:
        I = earth

    # ---- environment
    temps: dict[str, np.ndarray] = {}
    trates: dict[str, np.ndarray] = {}
    sensors: dict[str, np.ndarray] = {}
    if sc.temperature is not None:
        temps, trates = env.thermal_nodes(sc.temperature, tm, tau0)
        for j, sen in enumerate(sc.temperature.sensors):
            sensors[sen.column] = env.sensor_reading(sen, temps[sen.node], tau0,
                                                     _rng(seed, run, "sensor", j))
    else:  # no temperature section: a constant 21 degC ambient (read-only views, no memory)
        temps = {"ambient": np.broadcast_to(np.float64(21.0), (n,))}
        trates = {"ambient": np.broadcast_to(np.float64(0.0), (n,))}
    for name in temps:
        envd[f"T.{name}"] = temps[name]
        envd[f"dTdt.{name}"] = trates[name]
    H = None
    if sc.field is not None:
        H, helm = env.magnetic_field(sc.field, tm, tau0, _rng(seed, run, "field"))
        envd["H_uT"] = H
        envd["helmholtz"] = helm
    V = None
    if sc.supply is not None:
        V = env.supply_voltage(sc.supply, tm, tau0)
        envd["supply_v"] = V

    # ---- deterministic drift and environmental terms (deg/h)
    g = sc.gyro
    ef = sc.effects
    comps["bias"] = np.broadcast_to(np.float64(g.bias_dph + bias_off), (n,))
    det: Any = np.float64(g.bias_dph + bias_off)
    if ef.warmup_amplitude_dph:
        comps["warmup"] = ef.warmup_amplitude_dph * np.exp(-tm / ef.warmup_tau_s)
        det = det + comps["warmup"]
    if g.noise.R:
        comps["rate_ramp"] = TERMS["rate_ramp"].to_internal(R=g.noise.R)["R"] * tm
        det = det + comps["rate_ramp"]
    for j, term in enumerate(ef.thermal):
        c = _thermal_term(term, temps, trates)
        comps[f"thermal[{j}]:{term.kind}"] = c
        det = det + c
    if ef.magnetic_w is not None and H is not None:
        c = sum(ef.magnetic_w[i] * H[i] / H0_UT for i in range(3))
        comps["magnetic"] = np.asarray(c)
        det = det + c
    if ef.supply_dph_per_v and V is not None:
        comps["supply"] = ef.supply_dph_per_v * (V - sc.supply.nominal_v)
        det = det + comps["supply"]

    # ---- random drift (deg/h)
    noise, ntruth = _noise(sc, seed, run, n, tau0)
    comps.update(noise)
    rand: np.ndarray | None = None
    for v in noise.values():
        if rand is None:
            rand = v.copy()
        else:
            rand += v

    # ---- scale factor and lock-in
    sf = ef.scale_factor
    if sf.full_scale_dps:
        i_fs = sf.full_scale_dps * 3600.0
    elif sc.rate_table is not None:
        i_fs = max(abs(r) for r in sc.rate_table.rates_dps) * 3600.0 or 3600.0
    else:
        i_fs = 3600.0
    eps = _eps_k(sc, I, temps, sf_off, i_fs)
    gain = 1.0 / (1.0 + 1e-6 * np.asarray(eps))
    x_det = np.asarray(I + det, dtype=np.float64)  # I is a full-length array: a new array
    noise_free = _lock_in(x_det, sf.lock_in_dph) * gain
    if noise_free.shape != (n,):
        noise_free = np.broadcast_to(noise_free, (n,)).copy()
    if rand is not None:
        rand += x_det
        ideal = _lock_in(rand, sf.lock_in_dph)
        ideal *= gain
    else:
        ideal = noise_free.copy()
    del rand
    if sf.saturation_dps:  # the output stops following beyond the input range
        lim = sf.saturation_dps * 3600.0
        np.clip(noise_free, -lim, lim, out=noise_free)
        np.clip(ideal, -lim, lim, out=ideal)

    # ---- output encoding
    out = _encode(sc, seed, run, ideal, tau0)

    # ---- truth
    truth = _truth(sc, seed, run, n, tau0, tm, t_end, sf_off, bias_off, ntruth, pos, table,
                   noise_free, I, temps, i_fs, out, envd)
    # ---- file columns, faults, profile
    columns, fault_truth = _columns(sc, seed, run, out, t_end, tau0, pos, table, sensors, H, V)
    truth["file"] = fault_truth
    profile = _profile(sc, out, columns)
    truth["profile"] = profile
    return SimRun(index=run, tau0=tau0, t=t_end, rate_dph=out["rate_dph"], ideal_rate_dph=ideal,
                  noise_free_rate_dph=noise_free, input_dph=I, components=comps, env=envd,
                  columns=columns, truth=truth, profile=profile)


def _thermal_term(term, temps, trates) -> np.ndarray:
    if term.kind == "poly":
        dT = temps[term.node] - term.t_ref_c
        return term.D_T * dT + term.D_T2 * dT**2 + term.D_T3 * dT**3
    if term.kind == "rate":
        return term.D_Tdot * trates[term.node]
    if term.kind == "gradient_rate":
        a, b = term.nodes
        return term.D_gradTdot * (trates[a] - trates[b])
    if term.kind == "hysteresis":
        return 0.5 * term.amplitude_dph * env.play_operator(temps[term.node], term.width_c)
    # antonova-matveev
    dT = temps[term.node] - term.t_ref_c
    return term.w0 + term.D_T * dT + term.D_T2 * dT**2 + term.D_Tdot * trates[term.node]


def _noise(sc: Scenario, seed: int, run: int, n: int, tau0: float
           ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    ns = sc.gyro.noise
    out: dict[str, np.ndarray] = {}
    fs = 1.0 / tau0
    comps: list[list[Any]] = []
    t: dict[str, Any] = {
        "units": {"N": "deg/sqrt(h)", "B": "deg/h", "B_f0_hz": "Hz", "K": "deg/h/sqrt(h)",
                  "R": "deg/h/h", "Q": "arcsec"},
        "N": ns.N, "B": ns.B, "B_f0_hz": None, "K": ns.K, "R": ns.R, "Q_white_arcsec": ns.Q,
    }
    if ns.N:
        out["noise.arw"] = gen.white_rate(_rng(seed, run, "arw"), n, tau0,
                                          TERMS["arw"].to_internal(N=ns.N)["N"])
        comps.append(["arw", {"N": ns.N}])
    if ns.B:
        f0 = ns.B_f0_hz if ns.B_f0_hz is not None else 0.5 * fs
        t["B_f0_hz"] = f0
        out["noise.bias_instability"] = gen.flicker_rate(_rng(seed, run, "bias_instability"), n,
                                                         tau0, ns.B, f0, ns.fft_padding)
        comps.append(["bias_instability", {"B": ns.B, "f0": f0}])
    if ns.K:
        out["noise.rrw"] = gen.random_walk_rate(_rng(seed, run, "rrw"), n, tau0,
                                                TERMS["rrw"].to_internal(K=ns.K)["K"])
        comps.append(["rrw", {"K": ns.K}])
    if ns.R:
        comps.append(["rate_ramp", {"R": ns.R}])
    if ns.Q:
        out["noise.white_angle"] = gen.white_angle(_rng(seed, run, "white_angle"), n, tau0, ns.Q)
        comps.append(["quantization", {"Q": ns.Q}])
    t["markov"] = []
    for j, m in enumerate(ns.markov):
        q_int = TERMS["markov"].to_internal(q_c=m.q_c)["q_c"]
        out[f"noise.markov[{j}]"] = gen.markov_rate(_rng(seed, run, "markov", j), n, tau0,
                                                     q_int, m.T_c)
        comps.append(["markov", {"q_c": m.q_c, "T_c": m.T_c}])
        t["markov"].append({"q_c": m.q_c, "q_c_unit": "deg/h/sqrt(h)", "T_c_s": m.T_c,
                            "sigma_dph": q_int * math.sqrt(m.T_c / 2.0),
                            "N_eq": q_int * m.T_c / 60.0, "N_eq_unit": "deg/sqrt(h)",
                            "S0_dph2_per_hz": (q_int * m.T_c) ** 2})
    t["sinusoid"] = []
    for j, s in enumerate(ns.sinusoid):
        r = _rng(seed, run, "sinusoid", j)
        ph = math.radians(s.phase_deg) if s.phase_deg is not None else r.uniform(0, 2 * math.pi)
        out[f"noise.sinusoid[{j}]"] = gen.sinusoid_rate(n, tau0, s.amplitude_dph, s.freq_hz, ph)
        comps.append(["sinusoid", {"Omega0": s.amplitude_dph, "f0": s.freq_hz}])
        t["sinusoid"].append({"amplitude_dph": s.amplitude_dph, "freq_hz": s.freq_hz,
                              "phase_deg": math.degrees(ph)})
    t["blue"] = []
    for j, b in enumerate(ns.blue):
        r = _rng(seed, run, "blue", j)
        if b.family == "blue_markov_derivative":
            out[f"noise.blue[{j}]"] = gen.markov_derivative_rate(r, n, tau0, b.alpha, b.beta)
            params = {"alpha": b.alpha, "beta": b.beta}
        else:
            params = {"alpha": b.alpha, "beta": b.beta, "n": b.n}
            term = TERMS[b.family]
            out[f"noise.blue[{j}]"] = gen.fft_shaped_rate(
                r, n, tau0, lambda f, term=term, params=params: term.psd(f, **params),
                ns.fft_padding)
        comps.append([b.family, params])
        t["blue"].append({"family": b.family, **params})
    t["components"] = comps
    return out, t


# ------------------------------------------------------------------------------ encoding


def _encode(sc: Scenario, seed: int, run: int, ideal: np.ndarray, tau0: float) -> dict[str, Any]:
    g = sc.gyro
    kind = g.output
    out: dict[str, Any] = {"kind": kind}
    if kind == "rate":
        f = rate_factor(g.rate_unit)
        col = ideal / f if f != 1.0 else ideal
        out["values"] = {"rate": col}
        out["rate_dph"] = col * f if f != 1.0 else col
        return out
    s0 = float(g.scale_factor)
    if kind == "voltage":
        v = g.offset_v + ideal / s0
        lo, hi = g.adc_range_v
        clipped = 0
        if g.adc_bits:
            lsb = (hi - lo) / 2**g.adc_bits
            code = np.round((v - lo) / lsb)
            clipped = int(np.count_nonzero((code < 0) | (code > 2**g.adc_bits - 1)))
            code = np.clip(code, 0, 2**g.adc_bits - 1)
            v = lo + code * lsb
            out["adc_lsb_v"] = lsb
        out["adc_clipped_samples"] = clipped
        out["values"] = {"voltage": v}
        out["rate_dph"] = (v - g.offset_v) * s0
        return out
    # pulse outputs: integrate the true angle, emit floor(angle/S0) pulses, carry the remainder
    phase = _rng(seed, run, "pulse_phase").uniform(0.0, s0)
    angle = np.cumsum(ideal * tau0)
    angle += phase
    pulses = np.floor(angle / s0).astype(np.int64)
    counts = np.diff(pulses, prepend=np.int64(0))
    del angle, pulses
    out["rate_dph"] = counts * (s0 / tau0)
    if kind == "counts":
        out["values"] = {"counts": counts}
    elif kind == "updown":
        if g.dither_counts > 0:
            d = _rng(seed, run, "dither").poisson(g.dither_counts, counts.size).astype(np.int64)
        else:
            d = np.zeros(counts.size, dtype=np.int64)
        out["values"] = {"up": np.maximum(counts, 0) + d, "down": np.maximum(-counts, 0) + d}
    else:  # counter
        bits = g.counter_bits
        mod = 2**bits
        big = int(np.max(np.abs(counts))) if counts.size else 0
        if big >= mod // 2:
            raise InputError(f"{sc.source}: {big} pulses in one sample do not fit a {bits}-bit "
                             "counter (the reader unwraps modulo 2^bits); raise counter_bits, "
                             "the sample rate or scale_factor")
        if g.counter_start is not None:
            start = g.counter_start
        else:  # start near a roll-over that happens within the first 10 % of the record
            c10 = int(np.sum(counts[: max(1, counts.size // 10)]))
            if c10 > 0:
                start = mod - max(1, c10 // 2)
            elif c10 < 0:
                start = max(1, -c10 // 2) - 1
            else:
                start = mod - 1
        cum = np.concatenate(([0], np.cumsum(counts)))
        cnt = np.mod(cum + start, mod)
        out["values"] = {"counter": cnt.astype(np.int64 if bits < 63 else np.uint64)}
        out["counter_start"] = int(start)
        out["rollovers"] = int(np.count_nonzero(np.abs(np.diff(cnt)) > mod // 2))
    return out


# ------------------------------------------------------------------------------ truth


# ------------------------------------------------------------------------------ columns


def _columns(sc, seed, run, out, t_end, tau0, pos, table, sensors, H, V
             ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    g = sc.gyro
    fspec = sc.file
    kind = g.output
    cols: dict[str, np.ndarray] = {}
    counter = kind == "counter"

    def aux(v: np.ndarray) -> np.ndarray:
        return np.concatenate((v[:1], v)) if counter else v

    t_rel = np.concatenate(([0.0], t_end)) if counter else t_end
    tcol = None
    if fspec.time != "none":
        tcol = fspec.time_column or ("timestamp" if fspec.time == "iso" else "t_s")
        cols[tcol] = t_rel + fspec.t0_s if fspec.t0_s else t_rel
    vals = out["values"]
    if kind == "rate":
        name = fspec.output_column or _RATE_COLUMN.get(g.rate_unit, "omega")
        cols[name] = vals["rate"]
    elif kind == "counts":
        cols[fspec.output_column or "pulses"] = vals["counts"]
    elif kind == "updown":
        cols[fspec.up_column] = vals["up"]
        cols[fspec.down_column] = vals["down"]
    elif kind == "counter":
        cols[fspec.output_column or "cnt"] = vals["counter"]
    else:
        cols[fspec.output_column or "v_out"] = vals["voltage"]
    for name, v in sensors.items():
        cols[name] = aux(v)
    if H is not None and sc.field.columns:
        r = _rng(seed, run, "field", 1)
        for i, name in enumerate(sc.field.columns):
            h = H[i]
            if sc.field.noise_uT:
                h = h + r.standard_normal(h.size) * sc.field.noise_uT
            cols[name] = aux(h)
    if V is not None and sc.supply.column:
        v = V
        if sc.supply.noise_v:
            v = V + _rng(seed, run, "supply").standard_normal(V.size) * sc.supply.noise_v
        cols[sc.supply.column] = aux(v)
    if table is not None and sc.rate_table.column:
        cols[sc.rate_table.column] = aux(table.cmd_dps)
    if sc.site.positions:
        cols[fspec.position_column] = aux(pos.labels)
    names = list(cols)
    dup = {x for x in names if names.count(x) > 1}
    if len(cols) != len(names) or dup:
        raise InputError(f"{sc.source}: column name(s) {sorted(dup)} used twice; rename them")
    # ---- faults
    fl = fspec.faults
    ftruth: dict[str, Any] = {"time": fspec.time, "time_column": tcol, "t0_s": fspec.t0_s,
                              "rows": int(t_rel.size), "dropped_rows": 0, "gaps": [],
                              "duplicated_rows": [], "jitter_s": fl.jitter_s}
    if fl.drop or fl.drop_random or fl.jitter_s or fl.duplicate_rows:
        r = _rng(seed, run, "faults")
        nrow = t_rel.size
        keep = np.ones(nrow, dtype=bool)
        for start, dur in fl.drop:
            keep &= ~((t_rel >= start) & (t_rel < start + dur))
        if fl.drop_random:
            cand = np.flatnonzero(keep[1:-1]) + 1
            pick = r.choice(cand, size=min(fl.drop_random, cand.size), replace=False)
            keep[pick] = False
        if fl.jitter_s:
            cols[tcol] = cols[tcol] + r.normal(0.0, fl.jitter_s, nrow)
        idx = np.flatnonzero(keep)
        reps = np.ones(idx.size, dtype=np.int64)
        if fl.duplicate_rows:
            dpick = r.choice(np.arange(1, idx.size - 1), size=min(fl.duplicate_rows, idx.size - 2),
                             replace=False)
            reps[dpick] = 2
            ftruth["duplicated_rows"] = [float(cols[tcol][idx[i]]) for i in sorted(dpick)]
        sel = np.repeat(idx, reps)
        cols = {k: v[sel] for k, v in cols.items()}
        ftruth["dropped_rows"] = int(nrow - idx.size)
        steps = np.diff(t_rel[idx])
        gi = np.flatnonzero(steps > 1.5 * tau0)
        ftruth["gaps"] = [{"after_s": float(t_rel[idx[i]]), "duration_s": float(steps[i])}
                          for i in gi]
        ftruth["rows"] = int(sel.size)
        ftruth["note"] = ("gaps and duplicated rows are given as times relative to the run start "
                          "(t0_s not added); duplicated_rows lists the file times of the repeats")
    if fspec.time == "iso":
        start = np.datetime64(fspec.start_iso.rstrip("Z"), "us")
        us = np.round(cols[tcol] * 1e6).astype("timedelta64[us]")
        cols[tcol] = np.datetime_as_string(start + us, unit="us").astype(object)
        ftruth["start_iso"] = fspec.start_iso
    return cols, ftruth


def _profile(sc: Scenario, out: dict[str, Any], columns: dict[str, np.ndarray]) -> dict[str, Any]:
    g = sc.gyro
    f = sc.file
    names = list(columns)
    i = 0
    c: dict[str, Any] = {}
    u: dict[str, str] = {}
    if f.time != "none":
        c["time"] = names[0]
        i = 1
    kind = g.output
    if kind == "updown":
        c["up"], c["down"] = names[i], names[i + 1]
    else:
        c[kind] = names[i]
    if kind == "rate":
        u[names[i]] = g.rate_unit
    if sc.temperature is not None and sc.temperature.sensors:
        c["temperature"] = [s.column for s in sc.temperature.sensors]
    if sc.field is not None and sc.field.columns:
        c["field"] = list(sc.field.columns)
    if sc.supply is not None and sc.supply.column:
        c["supply"] = sc.supply.column
    if sc.rate_table is not None and sc.rate_table.column:
        c["table_rate"] = sc.rate_table.column
        u[sc.rate_table.column] = "deg/s"
    if sc.site.positions:
        c["position"] = f.position_column
    gy: dict[str, Any] = {}
    if kind == "rate":
        gy["rate_unit"] = g.rate_unit
    else:
        gy["scale_factor"] = float(g.scale_factor)
    if kind == "voltage":
        gy["offset_v"] = float(g.offset_v)
    if kind == "counter":
        gy["counter_bits"] = int(g.counter_bits)
    if f.time == "none":
        gy["sample_rate_hz"] = float(sc.record.sample_rate_hz)
    for key in ("model", "serial", "type"):
        if getattr(g, key):
            gy[key] = getattr(g, key)
    prof: dict[str, Any] = {"columns": c}
    if u:
        prof["units"] = u
    prof["gyro"] = gy
    if sc.site.given:
        site: dict[str, Any] = {"latitude_deg": float(sc.site.latitude_deg)}
        ia = sc.site.ia
        if ia is not None:
            if ia.named:
                site["ia"] = ia.label if ia.label in ("up", "down", "north", "south", "east",
                                                      "west") else _named(ia)
            else:
                site["ia_azimuth_deg"] = float(ia.azimuth_deg)
                site["ia_elevation_deg"] = float(ia.elevation_deg)
        prof["site"] = site
    profile_from_dict(prof, source="simulated profile")  # must be readable by ingest
    return prof


def _named(ia) -> str:
    for name, (az, el) in {"up": (0.0, 90.0), "down": (0.0, -90.0), "north": (0.0, 0.0),
                           "south": (180.0, 0.0), "east": (90.0, 0.0),
                           "west": (270.0, 0.0)}.items():
        if abs(ia.azimuth_deg - az) < 1e-9 and abs(ia.elevation_deg - el) < 1e-9:
            return name
    return "up"
