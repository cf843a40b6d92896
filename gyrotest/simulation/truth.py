"""The truth of a simulated log: what each run's effects were (the bias, scale factor, noise
coefficients, thermal and magnetic terms and the plateau means of a rate table), written beside
the log as *.truth.json so every analysis can be checked against it, and the summary of a
simulation."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from ..core.earth import OMEGA_E_DPH
from ..noise.terms import quantization_from_scale_factor
from . import environment as env
from .specs import Scenario

if TYPE_CHECKING:
    from .simrun import SimRun

#: the reference field magnitude of the magnetic terms, uT
H0_UT = 100.0


def _plateau_truth(sc: Scenario, table: env.TableSchedule, noise_free: np.ndarray,
                   tm_end: np.ndarray, tau0: float) -> dict[str, Any]:
    spec = sc.rate_table
    tm = tm_end - 0.5 * tau0
    xs, ys, rows = [], [], []
    for p in table.plateaus:
        m = (tm - 0.5 * tau0 >= p["start_s"] + spec.exclude_s) & (tm + 0.5 * tau0 <= p["end_s"])
        if not m.any():
            continue
        y = float(np.mean(noise_free[m]))
        xs.append(p["rate_dps"] * 3600.0)
        ys.append(y)
        rows.append({**p, "window_s": [p["start_s"] + spec.exclude_s, p["end_s"]],
                     "input_dph": p["rate_dps"] * 3600.0, "noise_free_mean_dph": y})
    x, y = np.array(xs), np.array(ys)
    out: dict[str, Any] = {"plateaus": rows, "exclude_s": spec.exclude_s,
                           "settle_tau_s": spec.settle_tau_s}
    sat = sc.effects.scale_factor.saturation_dps
    if sat:  # saturated plateaus are outside the input range: not on the SF line
        inside = np.abs(x) < sat * 3600.0
        for row, ok in zip(rows, inside):
            row["saturated"] = not bool(ok)
        rows = [r for r, ok in zip(rows, inside) if ok]
        x, y = x[inside], y[inside]
        out["saturation_dps"] = sat
    if np.unique(x).size < 2:
        out["note"] = "fewer than two distinct plateau rates: no scale-factor line"
        return out
    sf, b = np.polyfit(x, y, 1)
    r = y - (sf * x + b)
    fs_out = abs(sf) * np.max(np.abs(x))
    for row, ri in zip(rows, r):
        row["residual_dph"] = float(ri)
        row["residual_ppm_fs"] = float(ri / fs_out * 1e6)
        row["residual_ppm_output"] = (float(ri / (sf * row["input_dph"]) * 1e6)
                                      if row["input_dph"] else None)
    out.update({
        "sf": float(sf),
        "sf_error_ppm": float((sf - 1.0) * 1e6),
        "intercept_dph": float(b),
        "full_scale_input_dph": float(np.max(np.abs(x))),
        "linearity_max_ppm_fs": float(np.max(np.abs(r)) / fs_out * 1e6),
        "linearity_1sigma_ppm_fs": float(np.sqrt(np.mean(r**2)) / fs_out * 1e6),
    })
    s0 = sc.gyro.scale_factor
    if sc.gyro.output in ("counts", "updown", "counter"):
        out["sf_pulse_per_arcsec"] = float(sf / s0)
        out["sf_arcsec_per_pulse"] = float(s0 / sf)
    elif sc.gyro.output == "voltage":
        out["sf_v_per_dph"] = float(sf / s0)
        out["sf_dph_per_v"] = float(s0 / sf)

    def asym(sp: float, sm: float) -> float:
        # (SF+ − SF−)/(½(SF+ + SF−)) with SF = input per output = 1/slope (the SF column's
        # convention); from the output-per-input slopes sp, sm: (|sm| − |sp|)/(½(|sp| + |sm|))
        return float((abs(sm) - abs(sp)) / (0.5 * (abs(sp) + abs(sm))) * 1e6)

    pos, neg = x > 0, x < 0
    if pos.any() and neg.any():
        # IEEE 952: SF+ from the positive inputs, SF- from the negative ones. Primary: separate
        # least-squares lines (each side with the zero-rate plateaus); with fewer than two
        # distinct inputs on a side: lines through the common intercept of the full fit.
        sp_c = float(np.sum(x[pos] * (y[pos] - b)) / np.sum(x[pos] ** 2))
        sm_c = float(np.sum(x[neg] * (y[neg] - b)) / np.sum(x[neg] ** 2))
        out["asymmetry_ppm_common_intercept"] = asym(sp_c, sm_c)
        zero = x == 0
        mp, mn = pos | zero, neg | zero
        if np.unique(x[mp]).size >= 2 and np.unique(x[mn]).size >= 2:
            sp = float(np.polyfit(x[mp], y[mp], 1)[0])
            sm = float(np.polyfit(x[mn], y[mn], 1)[0])
            out["asymmetry_method"] = "separate lines"
        else:
            sp, sm = sp_c, sm_c
            out["asymmetry_method"] = "common intercept"
        out["sf_plus"], out["sf_minus"] = sp, sm
        out["asymmetry_ppm"] = asym(sp, sm)
    return out


def _truth(sc, seed, run, n, tau0, tm, t_end, sf_off, bias_off, ntruth, pos, table, noise_free,
           I, temps, i_fs, out, envd) -> dict[str, Any]:
    g = sc.gyro
    ef = sc.effects
    truth: dict[str, Any] = {
        "format": "gyrotest-sim-truth/1",
        "scenario": sc.name,
        "description": sc.description,
        "source": sc.source,
        "seed": seed,
        "run": run,
        "runs": sc.runs.count,
        "samples": n,
        "sample_rate_hz": 1.0 / tau0,
        "tau0_s": tau0,
        "duration_s": n * tau0,
        "rate_unit": "deg/h",
        "model_equation": "S0 dN/dt = LockIn(I + E + D) / (1 + 1e-6 eps_K) (IEEE 952 §8.3)",
    }
    # output
    o: dict[str, Any] = {"kind": g.output, "model": g.model, "serial": g.serial, "type": g.type}
    if g.output == "rate":
        o["rate_unit"] = g.rate_unit
    else:
        o["scale_factor"] = g.scale_factor
        o["scale_factor_unit"] = "(deg/h)/V" if g.output == "voltage" else "arcsec/pulse"
    if g.output == "voltage":
        o["offset_v"] = g.offset_v
        o["adc_bits"] = g.adc_bits
        o["adc_range_v"] = list(g.adc_range_v)
        o["adc_lsb_v"] = out.get("adc_lsb_v")
        o["adc_clipped_samples"] = out.get("adc_clipped_samples", 0)
    if g.output == "counter":
        o["counter_bits"] = g.counter_bits
        o["counter_start"] = out["counter_start"]
        o["rollovers"] = out["rollovers"]
    if g.output == "updown":
        o["dither_counts_mean"] = g.dither_counts
    truth["output"] = o
    # noise
    q_pulse = quantization_from_scale_factor(g.scale_factor) if g.output in (
        "counts", "updown", "counter") else 0.0
    ntruth["Q_pulse_arcsec"] = q_pulse
    ntruth["Q"] = math.hypot(ntruth["Q_white_arcsec"], q_pulse)
    comps = list(ntruth["components"])
    if q_pulse:
        comps = [c for c in comps if c[0] != "quantization"] + [["quantization",
                                                                  {"Q": ntruth["Q"]}]]
    if g.output == "voltage" and g.adc_bits:
        # ADC rounding of the rate samples: white rate noise of variance (lsb S0)^2/12
        n_adc = out["adc_lsb_v"] * g.scale_factor * math.sqrt(tau0 / 12.0) / 60.0
        ntruth["N_adc"] = n_adc
        ntruth["N_total"] = math.hypot(ntruth["N"], n_adc)
        comps.append(["arw", {"N": n_adc}])
    ntruth["components"] = comps
    ntruth["components_note"] = ("[registry key, params in reported units] for "
                                 "gyrotest.noise.terms.mixture_avar(tau, components)")
    truth["noise"] = ntruth
    # bias and earth
    resid = noise_free - I
    b: dict[str, Any] = {
        "D_F_dph": g.bias_dph + bias_off,
        "D_F_nominal_dph": g.bias_dph,
        "run_offset_dph": bias_off,
        "noise_free_mean_dph": float(np.mean(resid)),
        "note": "noise_free_mean = mean of (noise-free S0 dN/dt - table rate - earth rate): what "
                "the bias analysis should find from a perfect record (includes thermal, "
                "magnetic, supply, warm-up and scale-factor effects)",
    }
    if ef.warmup_amplitude_dph:
        m = tm >= 5 * ef.warmup_tau_s
        b["noise_free_mean_after_warmup_dph"] = float(np.mean(resid[m])) if m.any() else None
        b["warmup_end_s"] = 5 * ef.warmup_tau_s
    truth["bias"] = b
    truth["earth"] = {
        "omega_e_dph": OMEGA_E_DPH,
        "latitude_deg": sc.site.latitude_deg,
        "positions": pos.windows,
        "earth_rate_ia_dph": pos.windows[0]["earth_rate_ia_dph"] if len(pos.windows) == 1
        else None,
    }
    # environment / effects
    if sc.temperature is not None:
        ts = sc.temperature
        truth["temperature"] = {
            "initial_c": ts.initial_c,
            "nodes": [{"name": nd.name, "tau_s": nd.tau_s, "input": nd.input} for nd in ts.nodes],
            "sensors": [{"column": s.column, "node": s.node, "tau_s": s.tau_s,
                         "noise_c": s.noise_c, "offset_c": s.offset_c,
                         "resolution_c": s.resolution_c} for s in ts.sensors],
            "range_c": {k: [float(np.min(v)), float(np.max(v))] for k, v in temps.items()},
        }
    therm = []
    for j, term in enumerate(ef.thermal):
        d: dict[str, Any] = {"component": f"thermal[{j}]:{term.kind}", "kind": term.kind}
        if term.kind == "poly":
            d.update(node=term.node, t_ref_c=term.t_ref_c, D_T=term.D_T, D_T2=term.D_T2,
                     D_T3=term.D_T3, units={"D_T": "(deg/h)/degC", "D_T2": "(deg/h)/degC^2",
                                            "D_T3": "(deg/h)/degC^3"})
        elif term.kind == "rate":
            d.update(node=term.node, D_Tdot=term.D_Tdot,
                     units={"D_Tdot": "(deg/h)/(degC/h) = deg/degC"})
        elif term.kind == "gradient_rate":
            d.update(nodes=list(term.nodes), D_gradTdot=term.D_gradTdot,
                     units={"D_gradTdot": "(deg/h)/(degC/h)"},
                     gradient="T[nodes[0]] - T[nodes[1]]")
        elif term.kind == "hysteresis":
            d.update(node=term.node, amplitude_dph=term.amplitude_dph, width_c=term.width_c,
                     note="heating-branch minus cooling-branch bias = amplitude_dph "
                          "(play operator of half-width width_c)")
        else:
            d.update(node=term.node, t0_c=term.t_ref_c, w0=term.w0, w1=term.D_T, w2=term.D_T2,
                     w_dV=term.D_Tdot,
                     units={"w0": "deg/h", "w1": "deg/(h degC)", "w2": "deg/(h degC^2)",
                            "w_dV": "deg/degC = (deg/h)/(degC/h)"},
                     source="Antonova & Matveev, 'Model of error of a fiber-optic gyro "
                            "exposed to thermal and magnetic fields'")
        therm.append(d)
    truth["thermal"] = therm
    if sc.field is not None:
        f = sc.field
        truth["magnetic"] = {
            "w_dph_per_100uT": list(ef.magnetic_w) if ef.magnetic_w is not None else None,
            "H0_uT": H0_UT,
            "background_uT": list(f.background_uT),
            "sensor_noise_uT": f.noise_uT,
            "helmholtz": envd.get("helmholtz") or None,
            "note": "drift = sum_i w_i H_i / H0; reversal estimate K = |dw(+300) - dw(-300)|/6",
        }
    if sc.supply is not None:
        truth["supply"] = {"nominal_v": sc.supply.nominal_v, "dph_per_v": ef.supply_dph_per_v}
    if ef.warmup_amplitude_dph:
        truth["warmup"] = {"amplitude_dph": ef.warmup_amplitude_dph, "tau_s": ef.warmup_tau_s,
                           "model": "A exp(-t/tau_w), t from power-on (start of the run)"}
    sf = ef.scale_factor
    sft: dict[str, Any] = {
        "model": {"offset_ppm": sf.offset_ppm, "run_offset_ppm": sf_off,
                  "asymmetry_ppm": sf.asymmetry_ppm, "nonlinearity_ppm": sf.nonlinearity_ppm,
                  "full_scale_dph": i_fs, "periodic_ppm": sf.periodic_ppm,
                  "periodic_period_dps": sf.periodic_period_dps,
                  "temp_ppm_per_c": sf.temp_ppm_per_c, "node": sf.node, "t_ref_c": sf.t_ref_c,
                  "lock_in_dph": sf.lock_in_dph, "saturation_dps": sf.saturation_dps},
        "sf_nominal": 1.0 / (1.0 + 1e-6 * (sf.offset_ppm + sf_off)),
        "definitions": {
            "sf": "slope of the least-squares line of noise-free plateau means (deg/h) vs "
                  "commanded rate (deg/h); dimensionless (1 = nominal S0)",
            "linearity_ppm_fs": "residual from that line / (sf * max |input|) * 1e6; max of |.| "
                                "and 1 sigma (RMS)",
            "asymmetry_ppm": "(SF+ - SF-)/(0.5(SF+ + SF-)) * 1e6 (IEEE 952) with SF = input "
                             "per unit output = 1/slope (the unit of the scale-factor column); "
                             "the slopes sf_plus, sf_minus (output per input) are least-squares "
                             "slopes of the positive (negative) plateaus "
                             "with the zero-rate plateaus (asymmetry_method 'separate lines'), or "
                             "through the intercept of the full fit ('common intercept') when a "
                             "side has fewer than two distinct rates",
        },
    }
    if table is not None:
        sft.update(_plateau_truth(sc, table, noise_free, t_end, tau0))
    truth["scale_factor"] = sft
    return truth


def _summary(sc: Scenario, seed: int, runs: list[SimRun]) -> dict[str, Any]:
    s: dict[str, Any] = {"format": "gyrotest-sim-truth-summary/1", "scenario": sc.name,
                         "seed": seed, "runs": [r.truth for r in runs]}
    sfs = [r.truth["scale_factor"].get("sf") for r in runs]
    if len(runs) > 1 and all(v is not None for v in sfs):
        a = np.array(sfs)
        s["sf_repeatability"] = {
            "sf": sfs,
            "one_sigma_ppm": float(np.std(a, ddof=1) / np.mean(a) * 1e6),
            "max_spread_ppm": float((a.max() - a.min()) / np.mean(a) * 1e6),
        }
    dfs = [r.truth["bias"]["D_F_dph"] for r in runs]
    if len(runs) > 1:
        s["bias_repeatability"] = {"D_F_dph": dfs,
                                   "one_sigma_dph": float(np.std(dfs, ddof=1)),
                                   "max_spread_dph": float(max(dfs) - min(dfs))}
    return s
