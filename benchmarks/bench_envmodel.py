#!/usr/bin/env python3
"""Benchmark and acceptance sweep of the model workbench (gyrotest.envmodel).

Not part of the test suite. Run from the repository root:

    python benchmarks/bench_envmodel.py                  # everything, default seed counts
    python benchmarks/bench_envmodel.py --only speed     # 24-h log timing only
    python benchmarks/bench_envmodel.py --only hidden --seeds 10
    python benchmarks/bench_envmodel.py --only null --null-seeds 60 --jobs 2

Parts
-----
* speed: a simulated 24-hour log at 10 Hz (864 000 samples) with 4 temperature sensors, three
  field channels and a supply channel; wall time of ``prepare`` + ``fit_model`` of the final
  model + ``diagnose`` (every candidate), and the ratio to a plain ``numpy.linalg.lstsq`` of the
  final model's linear regressors at full rate (the cost of an OLS fit without working
  resolution, HAC, cross-validation, nonlinear search or diagnosis).
* hidden: for each of sample_data/scenarios/hidden_{rate,gradient,lag,magnetic,supply,warmup}
  and seeds 1..N: does diagnose rank the hidden effect first and call it significant; held-out
  RMS after adding it / simulated noise floor; recovered coefficient vs truth; improvement of
  the next-ranked candidate.
* null: hidden_none.toml (complete model) over many seeds: fraction with "no missing effect".
* domain: thermal-fit on thermal_antonova.toml (w0, w1, w2, w_dV vs the paper's values), mag-fit
  on magnetic_helmholtz.toml (wx, wy, wz), compensate (fit on seed s, apply to seed s+100 of
  hidden_rate.toml: achieved / predicted reduction).

Output: a human summary on stdout and, with --json FILE, every row.
"""

from __future__ import annotations

import argparse
import copy
import json
import math
import os
import sys
import time
import tomllib
from multiprocessing import Pool
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
SCEN = REPO / "sample_data" / "scenarios"
TMP = Path(os.environ.get("TMPDIR", "/tmp")) / "gyrotest_bench_envmodel"

HIDDEN = {
    "rate": ("hidden_rate.toml", "dTdt(T_case_C)", None, "dTdt(T_case_C)", 0.05),
    "gradient": ("hidden_gradient.toml", "dGdt(T_case_C,T_coil_C)", None,
                 "dGdt(T_case_C,T_coil_C)", 0.1),
    "lag": ("hidden_lag.toml", "Tlag(T_case_C)", "T(T_case_C)", "Tlag(T_case_C)", 0.05),
    "magnetic": ("hidden_magnetic.toml", "Hy", None, "Hy(Hy_uT)", -0.25),
    "supply": ("hidden_supply.toml", "V", None, "V", 0.2),
    "warmup": ("hidden_warmup.toml", "warmup", None, "warmup", 1.0),
}
BASE = ["T(T_case_C)"]


def _load(name: str) -> dict:
    with open(SCEN / name, "rb") as fh:
        return tomllib.load(fh)


def _sim(sc: dict, seed: int, stem: str):
    from gyrotest.core.profile import profile_from_dict
    from gyrotest.io.ingest import read_log
    from gyrotest.simulation import simulate, write_log

    TMP.mkdir(parents=True, exist_ok=True)
    res = simulate(sc, seed=seed)
    w = write_log(res, TMP / f"{stem}_{seed}_{os.getpid()}.parquet")
    log = read_log(w.logs[0], profile=profile_from_dict(res.profile))
    for p in w.logs + w.truths + w.profiles:
        p.unlink(missing_ok=True)
    return res, log


def _floor(res, log, wd) -> float:
    from gyrotest.envmodel.modelfit import prepare

    g = copy.copy(log)
    g.rates = {log.axes[0]: res.run.ideal_rate_dph - res.run.noise_free_rate_dph}
    w2 = prepare(g, resolution=wd.resolution_s, smoothing_s=wd.refs.smoothing_s, t_ref=21.0)
    return float(np.std(w2.y))


# ----------------------------------------------------------------------------- speed
def speed() -> dict:
    from gyrotest.envmodel import diagnose, fit_model, prepare

    sc = _load("hidden_gradient.toml")
    sc["record"]["duration_s"] = "24h"
    temp = sc["environment"]["temperature"]
    temp["profile"] = temp["profile"] * 4  # repeat the chamber profile over the day
    temp["nodes"].append({"name": "mount", "tau_s": 300, "input": "case"})
    temp["nodes"].append({"name": "base", "tau_s": 2400, "input": "case"})
    for col, node in (("T_mount_C", "mount"), ("T_base_C", "base")):
        temp["sensors"].append({"column": col, "node": node, "tau_s": 1, "noise_c": 0.01,
                                "resolution_c": 0.01})
    t0 = time.perf_counter()
    res, log = _sim(sc, 1, "speed24h")
    t_sim = time.perf_counter() - t0
    final = ["T(T_case_C)", "dGdt(T_case_C,T_coil_C)"]
    t0 = time.perf_counter()
    wd = prepare(log, t_ref=21.0)
    t1 = time.perf_counter()
    fit = fit_model(wd, final)
    t2 = time.perf_counter()
    d = diagnose(wd, final, base=fit)
    t3 = time.perf_counter()
    # plain numpy lstsq of the final model at full rate (regressors already computed)
    from gyrotest.envmodel.terms import build_term, frame_from_log, resolve_terms

    full = frame_from_log(log)
    specs = resolve_terms(fit.model.specs, full)
    X = np.column_stack([build_term(full, s, {}, fit.model.refs) for s in specs])
    y = full.rate
    tl = []
    for _ in range(3):
        a = time.perf_counter()
        np.linalg.lstsq(X, y, rcond=None)
        tl.append(time.perf_counter() - a)
    lst = min(tl)
    total = t3 - t0
    return {"samples": log.n, "sensors": len(log.temperature), "simulate_s": t_sim,
            "prepare_s": t1 - t0, "fit_s": t2 - t1, "diagnose_s": t3 - t2,
            "candidates": len(d.candidates), "fit_plus_diagnose_s": total,
            "lstsq_final_model_s": lst, "ratio_to_lstsq": total / lst,
            "blocks": wd.nb, "resolution_s": wd.resolution_s,
            "smoothing_s": wd.refs.smoothing_s, "verdict": d.verdict,
            "cpu_count": os.cpu_count()}


# ----------------------------------------------------------------------------- hidden / null
def hidden_one(args) -> dict:
    from gyrotest.envmodel import diagnose, fit_model, prepare

    which, seed = args
    scen, add, repl, coef, true = HIDDEN[which]
    res, log = _sim(_load(scen), seed, which)
    wd = prepare(log, t_ref=21.0)
    t0 = time.perf_counter()
    d = diagnose(wd, BASE)
    dt = time.perf_counter() - t0
    terms = [t for t in BASE if t != repl] + [add]
    fit = fit_model(wd, terms)
    floor = _floor(res, log, wd)
    c = fit.coef(coef)
    d2 = diagnose(wd, terms, base=fit)
    top = d.candidates[0]
    key = HIDDEN[which][1].split("(")[0]
    return {"effect": which, "seed": seed, "diagnose_s": dt, "top": top.term,
            "top_is_effect": top.term == fit.specs[-1].label or top.spec.key == key,
            "found": d.found[0].term if d.found else None,
            "ratio_to_floor": fit.rms_holdout / floor, "coef": c.value, "stderr": c.stderr,
            "true": true, "coef_ok": abs(c.value - true) <= max(0.1 * abs(true),
                                                                2 * c.stderr),
            "second": d2.candidates[0].term, "second_improvement_pct":
                d2.candidates[0].improvement_pct, "second_found": d2.found[0].term
            if d2.found else None}


def null_one(seed: int) -> dict:
    from gyrotest.envmodel import diagnose, prepare

    res, log = _sim(_load("hidden_none.toml"), seed, "null")
    wd = prepare(log, t_ref=21.0)
    d = diagnose(wd, BASE)
    return {"seed": seed, "found": d.found[0].term if d.found else None,
            "top": d.candidates[0].term, "top_improvement_pct": d.candidates[0].improvement_pct,
            "ratio_to_floor_estimate": d.ratio_to_floor, "floor_sim": _floor(res, log, wd),
            "floor_estimate": d.noise_floor_dph}


# ----------------------------------------------------------------------------- domain
def domain_one(seed: int) -> dict:
    from gyrotest.envmodel import fit_model, prepare
    from gyrotest.envmodel.compensation import compensate
    from gyrotest.envmodel.domain import mag_fit, thermal_fit

    out = {"seed": seed}
    res, log = _sim(_load("thermal_antonova.toml"), seed, "thermal")
    th = thermal_fit(prepare(log, t_ref=21.0))
    tr = res.truth["thermal"][0]
    out["thermal_rel_err"] = {n: (th.coef(n).value - tr[n]) / tr[n]
                              for n in ("w0", "w1", "w2", "w_dV")}
    res, log = _sim(_load("magnetic_helmholtz.toml"), seed, "mag")
    mg = mag_fit(prepare(log))
    w = res.truth["magnetic"]["w_dph_per_100uT"]
    out["mag_abs_err"] = {c.name: c.value - w["xyz".index(c.name[-1])] for c in mg.coefficients}
    out["mag_reversal_err"] = {a: v["signed_dph_per_100uT"] - w["xyz".index(a)]
                               for a, v in mg.reversal.items()}
    _, l1 = _sim(_load("hidden_rate.toml"), seed, "comp1")
    _, l2 = _sim(_load("hidden_rate.toml"), seed + 100, "comp2")
    fit = fit_model(prepare(l1, t_ref=21.0), ["T(T_case_C)", "dTdt(T_case_C)"])
    cp = compensate(l2, fit.model)
    out["compensate"] = {"factor": cp.factor, "predicted": cp.predicted_factor,
                         "achieved_over_predicted": cp.factor / cp.predicted_factor}
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--only", choices=["speed", "hidden", "null", "domain"], action="append")
    ap.add_argument("--seeds", type=int, default=5, help="seeds per hidden effect")
    ap.add_argument("--null-seeds", type=int, default=60)
    ap.add_argument("--domain-seeds", type=int, default=5)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--json", default=None, help="write every row to this file")
    a = ap.parse_args()
    parts = a.only or ["speed", "hidden", "null", "domain"]
    report: dict = {}
    if "speed" in parts:
        s = speed()
        report["speed"] = s
        print(f"speed: {s['samples']:,} samples, {s['sensors']} temperature sensors, "
              f"{s['blocks']} blocks of {s['resolution_s']:g} s (W = {s['smoothing_s']:g} s)")
        print(f"  prepare {s['prepare_s']:.1f} s + fit {s['fit_s']:.1f} s + diagnose "
              f"{s['diagnose_s']:.1f} s ({s['candidates']} candidates) = "
              f"{s['fit_plus_diagnose_s']:.1f} s; numpy lstsq of the final model at full rate "
              f"{s['lstsq_final_model_s']:.3f} s (ratio {s['ratio_to_lstsq']:.0f}x)")
    with Pool(a.jobs) as pool:
        if "hidden" in parts:
            jobs = [(w, s) for w in HIDDEN for s in range(1, a.seeds + 1)]
            rows = pool.map(hidden_one, jobs)
            report["hidden"] = rows
            print(f"hidden effects (seeds 1..{a.seeds}):")
            for w in HIDDEN:
                r = [x for x in rows if x["effect"] == w]
                print(f"  {w:9s} ranked first & significant {sum(x['top_is_effect'] and x['found'] == x['top'] for x in r)}/{len(r)}; "
                      f"held-out/floor max {max(x['ratio_to_floor'] for x in r):.3f}; "
                      f"coefficient ok {sum(x['coef_ok'] for x in r)}/{len(r)}; "
                      f"next candidate adds max {max(x['second_improvement_pct'] for x in r):.2f} % "
                      f"(significant: {sum(x['second_found'] is not None for x in r)}); "
                      f"diagnose {np.mean([x['diagnose_s'] for x in r]):.1f} s")
        if "null" in parts:
            rows = pool.map(null_one, range(1, a.null_seeds + 1))
            report["null"] = rows
            none = sum(r["found"] is None for r in rows)
            ratios = [r["floor_estimate"] / r["floor_sim"] for r in rows]
            print(f"null: no missing effect in {none}/{len(rows)} seeds "
                  f"({100 * none / len(rows):.1f} %); false alarms: "
                  f"{[(r['seed'], r['found']) for r in rows if r['found']]}; "
                  f"floor estimate / simulated floor {np.mean(ratios):.3f} ± {np.std(ratios):.3f}")
        if "domain" in parts:
            rows = pool.map(domain_one, range(1, a.domain_seeds + 1))
            report["domain"] = rows
            te = {n: max(abs(r["thermal_rel_err"][n]) for r in rows)
                  for n in ("w0", "w1", "w2", "w_dV")}
            me = {n: max(abs(r["mag_abs_err"][n]) for r in rows) for n in ("wx", "wy", "wz")}
            ce = [r["compensate"]["achieved_over_predicted"] for r in rows]
            print("thermal-fit max relative error: " + ", ".join(
                f"{n} {100 * v:.2f} %" for n, v in te.items()))
            print("mag-fit max abs error (deg/h per 100 uT): " + ", ".join(
                f"{n} {v:.4f}" for n, v in me.items()))
            print(f"compensate achieved/predicted: min {min(ce):.3f}, max {max(ce):.3f}")
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(report, fh, indent=1, default=lambda o: None if isinstance(o, float)
                      and not math.isfinite(o) else str(o))


if __name__ == "__main__":
    main()
