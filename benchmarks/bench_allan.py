#!/usr/bin/env python3
"""Benchmark of ``gyrotest allan``: end-to-end speed against pandas + AllanTools, and the
accuracy of the noise-model fit on simulated logs with known truth.

Not part of the test suite. Run from the repository root:

    python benchmarks/bench_allan.py                  # both parts (10^7-row CSV; full sweep)
    python benchmarks/bench_allan.py --perf --rows 2e6
    python benchmarks/bench_allan.py --accuracy --seeds 3

Performance (``--perf``)
------------------------
A CSV with ``--rows`` rows (default 10^7; columns t_s, omega_dph at 100 Hz; white rate noise
plus rate random walk) is written once. Each measurement runs in a fresh subprocess and is
timed by wall clock and by child CPU time (less sensitive to other jobs on the machine):

* **gyrotest**: ``gyrotest allan FILE --rate-unit deg/h --json`` — ingest, OADEV with noise
  identification, Greenhall EDF and χ² intervals at 10 τ per decade up to T/4, the joint noise
  fit with uncertainties and bounds, the missing-term diagnosis, Welch PSD, autocorrelation,
  Allan–Krobka/Hadamard trend check, Krobka's warnings, impact prediction, JSON output;
* **baseline**: ``pandas.read_csv`` + ``allantools.oadev(data_type="freq")`` on the *same τ
  list* (taken from gyrotest's output) — a deviation table without CIs or any analysis.

The ratio gyrotest/baseline is reported, and a breakdown of gyrotest's time (ingest, the
deviation itself — benchmarked against AllanTools in bench_oadev.py — and everything else).

Accuracy (``--accuracy``)
-------------------------
Simulated records (``gyrotest.simulation``, exact noise generators) of 8–24 h at 10–100 Hz, several
seeds each; the default Q,N,B,K,R fit (plus the diagnosis) is compared with the truth:
N within 5 %, B within 25 %, K within 35 % where the record shows them; Q from pulse data
within 10 % of S0/√12; a hidden Markov hump's T_c and a hidden sinusoid's period within 10 %;
the coverage of the ±1σ intervals; and the fraction of clean ARW+B+K logs with no warning.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)

BASELINE = r"""
import json, sys, time
t0 = time.perf_counter()
import numpy as np, pandas as pd, allantools
path, taus_file = sys.argv[1], sys.argv[2]
taus = json.load(open(taus_file))
df = pd.read_csv(path)
x = df["omega_dph"].to_numpy(dtype=np.float64)
tau0 = float(df["t_s"].iloc[1] - df["t_s"].iloc[0])
t1 = time.perf_counter()
t, dev, err, n = allantools.oadev(x, rate=1.0 / tau0, data_type="freq", taus=taus)
t2 = time.perf_counter()
print(json.dumps({"read_s": t1 - t0, "oadev_s": t2 - t1, "n_tau": len(t)}))
"""

BREAKDOWN = r"""
import json, sys, time
path = sys.argv[1]
t0 = time.perf_counter()
from gyrotest.io.ingest import read_log
from gyrotest.noise.analysis import analyse_allan
from gyrotest.noise.deviations import compute_deviation
t1 = time.perf_counter()
log = read_log(path, overrides={"gyro": {"rate_unit": "deg/h"}})
t2 = time.perf_counter()
d = compute_deviation(log.rate, log.tau0, input_kind="rate", segments=log.segments)
t3 = time.perf_counter()
a = analyse_allan(log)
t4 = time.perf_counter()
print(json.dumps({"import_s": t1 - t0, "ingest_s": t2 - t1, "deviation_s": t3 - t2,
                  "analyse_allan_s": t4 - t3}))
"""


def _run(cmd: list[str], stdout=None) -> tuple[float, float, subprocess.CompletedProcess]:
    r0 = os.times()
    t0 = time.perf_counter()
    p = subprocess.run(cmd, stdout=stdout if stdout is not None else subprocess.PIPE,
                       stderr=subprocess.PIPE, text=True, cwd=ROOT)
    wall = time.perf_counter() - t0
    r1 = os.times()
    cpu = (r1.children_user - r0.children_user) + (r1.children_system - r0.children_system)
    if p.returncode != 0:
        sys.exit(f"failed: {' '.join(cmd)}\n{p.stderr}")
    return wall, cpu, p


def write_csv(path: str, rows: int, tau0: float = 0.01, seed: int = 1) -> None:
    import pyarrow as pa
    import pyarrow.csv as pacsv

    rng = np.random.default_rng(seed)
    N_int, K_int = 0.6, 0.05 / 60.0  # N = 0.01 deg/√h, K = 0.05 deg/h/√h
    x = rng.standard_normal(rows) * (N_int / math.sqrt(tau0))
    x += np.cumsum(rng.standard_normal(rows)) * (K_int * math.sqrt(tau0)) + 0.35
    t = np.arange(1, rows + 1) * tau0
    pacsv.write_csv(pa.table({"t_s": t, "omega_dph": x}), path)


def perf(rows: int, repeat: int) -> dict:
    tmp = tempfile.mkdtemp(prefix="bench_allan_")
    path = os.path.join(tmp, "big.csv")
    t0 = time.perf_counter()
    write_csv(path, rows)
    print(f"wrote {rows:.3g} rows ({os.path.getsize(path) / 1e6:.0f} MB) in "
          f"{time.perf_counter() - t0:.1f} s")
    gy = [sys.executable, "-c", "from gyrotest.cli import main; main()", "-q", "allan", path,
          "--rate-unit", "deg/h", "--json"]
    best = {"gyrotest": (math.inf, math.inf), "baseline": (math.inf, math.inf)}
    taus_file = os.path.join(tmp, "taus.json")
    n_tau = None
    for _ in range(repeat):
        out = os.path.join(tmp, "out.json")
        with open(out, "w") as fh:
            wall, cpu, _p = _run(gy, stdout=fh)
        best["gyrotest"] = min(best["gyrotest"], (wall, cpu))
        doc = json.load(open(out))
        taus = [row["tau"] for row in doc["logs"][0]["axes"][0]["table"]]
        n_tau = len(taus)
        json.dump(taus, open(taus_file, "w"))
        wall, cpu, p = _run([sys.executable, "-c", BASELINE, path, taus_file])
        best["baseline"] = min(best["baseline"], (wall, cpu))
        base_parts = json.loads(p.stdout)
    _, _, p = _run([sys.executable, "-c", BREAKDOWN, path])
    parts = json.loads(p.stdout)
    res = {
        "rows": rows, "n_tau": n_tau,
        "gyrotest_wall_s": best["gyrotest"][0], "gyrotest_cpu_s": best["gyrotest"][1],
        "baseline_wall_s": best["baseline"][0], "baseline_cpu_s": best["baseline"][1],
        "ratio_wall": best["gyrotest"][0] / best["baseline"][0],
        "ratio_cpu": best["gyrotest"][1] / best["baseline"][1],
        "baseline_parts": base_parts, "gyrotest_parts": parts,
    }
    print(f"\nend to end, {rows:.3g} rows, {n_tau} τ (best of {repeat}):")
    print(f"  gyrotest allan            {res['gyrotest_wall_s']:7.1f} s wall  "
          f"{res['gyrotest_cpu_s']:7.1f} s CPU")
    print(f"  pandas + AllanTools oadev {res['baseline_wall_s']:7.1f} s wall  "
          f"{res['baseline_cpu_s']:7.1f} s CPU   (read {base_parts['read_s']:.1f} s, "
          f"oadev {base_parts['oadev_s']:.1f} s)")
    print(f"  ratio gyrotest/baseline   {res['ratio_wall']:7.2f} wall      "
          f"{res['ratio_cpu']:7.2f} CPU")
    print(f"  gyrotest breakdown (one in-process run): import {parts['import_s']:.1f} s, "
          f"ingest {parts['ingest_s']:.1f} s, OADEV+noise ID+EDF {parts['deviation_s']:.1f} s, "
          f"analyse_allan total {parts['analyse_allan_s']:.1f} s (fit, diagnosis, PSD, "
          f"trend check, warnings, impact ≈ {parts['analyse_allan_s'] - parts['deviation_s']:.1f}"
          " s on top of the deviation)")
    return res


# ---------------------------------------------------------------------------------------------
# Accuracy sweep
# ---------------------------------------------------------------------------------------------

SCENARIOS = [
    # name, noise, hours, fs, checks {param: tolerance}; N, B, K chosen so that each checked
    # term dominates σ² over at least a decade of τ inside the fitted range ("where the
    # record can show them")
    ("ARW+B 8h@10Hz", {"N": 0.005, "B": 0.02, "K": 0.01}, 8, 10.0, {"N": 0.05, "B": 0.25}),
    ("ARW+K 8h@10Hz", {"N": 0.005, "B": 0.005, "K": 0.1}, 8, 10.0, {"N": 0.05, "K": 0.35}),
    ("ARW+B+K 24h@10Hz", {"N": 0.002, "B": 0.02, "K": 0.05}, 24, 10.0,
     {"N": 0.05, "B": 0.25, "K": 0.35}),
    ("ARW+B+K 8h@100Hz", {"N": 0.002, "B": 0.05, "K": 0.2}, 8, 100.0,
     {"N": 0.05, "B": 0.25, "K": 0.35}),
    ("K marginal 24h@10Hz", {"N": 0.005, "B": 0.02, "K": 0.02}, 24, 10.0, {"K": 0.35}),
    ("Markov hump 8h@10Hz", {"N": 0.005, "B": 0.01, "K": 0.01,
                             "markov": [{"q_c": 30.0, "T_c": 2.0}]}, 8, 10.0,
     {"N": 0.05, "T_c": 0.10}),
    ("sinusoid 8h@10Hz", {"N": 0.01, "B": 0.01, "sinusoid": [
        {"amplitude_dph": 0.3, "freq_hz": 0.05}]}, 8, 10.0, {"N": 0.05, "period": 0.10}),
]
TRUE_EXTRA = {"T_c": 2.0, "period": 20.0}


def _log(rate, tau0, kind="rate", s0=None):
    from gyrotest.core.data import GyroConstants, GyroLog, Timing

    n = rate.size
    return GyroLog(source="sim", rates={"gyro": rate}, tau0=tau0,
                   timing=Timing(n=n, tau0=tau0, duration_s=n * tau0, source="bench"),
                   gyro=GyroConstants(output_kind=kind, scale_factor=s0))


def accuracy(seeds: int) -> dict:
    from gyrotest.noise.analysis import analyse_allan
    from gyrotest.simulation import simulate

    rows = []
    bounds: list[dict] = []
    z = {"N": [], "B": [], "K": []}
    clean_silent = []
    print(f"\n{'scenario':24s} {'seed':>4s} {'param':>6s} {'truth':>9s} {'fit':>10s} "
          f"{'±1σ':>9s} {'err %':>7s} {'ok':>3s}  warnings  time")
    for name, noise, hours, fs, checks in SCENARIOS:
        n_seeds = seeds if hours * fs <= 80 else max(2, seeds // 2)
        for seed in range(1, n_seeds + 1):
            sc = {"record": {"sample_rate_hz": fs, "duration_s": hours * 3600},
                  "gyro": {"output": "rate", "noise": noise}}
            r = simulate(sc, seed=100 + seed)
            t0 = time.perf_counter()
            a = analyse_allan(_log(r.rate_dph, 1.0 / fs), spectral=True)
            dt = time.perf_counter() - t0
            ax = a.axes[0]
            fit = ax.best_fit
            codes = ",".join(w.code.replace("KROBKA-", "") for w in ax.warnings) or "-"
            if name.startswith("ARW+B"):
                clean_silent.append(not [w for w in ax.warnings if w.severity == "warning"])
            for p, tol in checks.items():
                if p in ("N", "B", "K"):
                    t = fit.term(p)
                    val = t.value if t.identified else math.nan
                    sig = t.sigma.get(p) if t.identified else None
                    truth = noise[p]
                    if sig:
                        z[p].append((val - truth) / sig)
                    if not t.identified:
                        bounds.append({"scenario": name, "param": p, "truth": truth,
                                       "upper": t.upper, "covers": (t.upper or 0) >= truth})
                elif p == "T_c":
                    t = fit.term("markov")
                    val = t.params["T_c"] if (t and t.identified) else math.nan
                    sig, truth = (t.sigma.get("T_c") if t else None), TRUE_EXTRA[p]
                else:
                    t = fit.term("sine")
                    val = 1.0 / t.params["f0"] if (t and t.identified) else math.nan
                    sig, truth = None, TRUE_EXTRA[p]
                err = (val / truth - 1.0) if math.isfinite(val) else math.nan
                ok = math.isfinite(err) and abs(err) <= tol
                rows.append({"scenario": name, "seed": seed, "param": p, "truth": truth,
                             "fit": val, "sigma": sig, "err": err, "ok": ok, "tol": tol,
                             "warnings": codes, "time_s": dt})
                print(f"{name:24s} {seed:4d} {p:>6s} {truth:9.4g} {val:10.4g} "
                      f"{(sig if sig else math.nan):9.2g} {100 * err:7.1f} "
                      f"{'✓' if ok else '✗':>3s}  {codes:9s} {dt:5.1f}")
    # pulse output: Q vs S0/√12
    for seed in range(1, seeds + 1):
        S0 = 0.2
        sc = {"record": {"sample_rate_hz": 100.0, "duration_s": 7200},
              "gyro": {"output": "counts", "scale_factor": S0, "bias_dph": 0.3,
                       "noise": {"N": 0.01}}, "site": {"latitude_deg": 48.1, "ia": "up"}}
        r = simulate(sc, seed=200 + seed)
        a = analyse_allan(_log(r.rate_dph, 0.01, "counts", S0), spectral=False)
        q = a.axes[0].fit.term("Q")
        truth = S0 / math.sqrt(12.0)
        err = q.value / truth - 1.0 if q.identified else math.nan
        ok = math.isfinite(err) and abs(err) <= 0.10
        rows.append({"scenario": "pulse counts 2h@100Hz", "seed": seed, "param": "Q",
                     "truth": truth, "fit": q.value, "err": err, "ok": ok, "tol": 0.10})
        print(f"{'pulse counts 2h@100Hz':24s} {seed:4d} {'Q':>6s} {truth:9.4g} {q.value:10.4g} "
              f"{(q.sigma.get('Q') or math.nan):9.2g} {100 * err:7.1f} {'✓' if ok else '✗':>3s}")
    summary = {}
    print("\nsummary:")
    for p in sorted({r["param"] for r in rows}):
        sel = [r for r in rows if r["param"] == p]
        errs = np.array([abs(r["err"]) for r in sel if math.isfinite(r["err"])])
        passed = sum(r["ok"] for r in sel)
        summary[p] = {"cases": len(sel), "within_tolerance": passed,
                      "max_abs_err": float(errs.max()) if errs.size else None,
                      "rms_err": float(np.sqrt(np.mean(errs**2))) if errs.size else None}
        print(f"  {p:7s} {passed}/{len(sel)} within ±{100 * sel[0]['tol']:.0f} %; |err| max "
              f"{100 * summary[p]['max_abs_err']:.1f} %, rms {100 * summary[p]['rms_err']:.1f} %")
    for p, zz in z.items():
        if zz:
            zz = np.array(zz)
            cov = float(np.mean(np.abs(zz) <= 1.0))
            summary[f"coverage_{p}"] = cov
            print(f"  ±1σ coverage of {p}: {100 * cov:.0f} % of {zz.size} (ideal 68 %), "
                  f"rms z = {np.sqrt(np.mean(zz ** 2)):.2f}")
    if bounds:
        cov = sum(b["covers"] for b in bounds)
        summary["bounds_cover_truth"] = f"{cov}/{len(bounds)}"
        print(f"  terms reported as upper bounds: {len(bounds)}; bound ≥ truth in {cov}")
    if clean_silent:
        summary["clean_silent"] = float(np.mean(clean_silent))
        print(f"  clean ARW+B(+K) logs with no Krobka warning: {sum(clean_silent)}/"
              f"{len(clean_silent)}")
    return {"rows": rows, "bounds": bounds, "summary": summary}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--perf", action="store_true", help="only the speed comparison")
    ap.add_argument("--accuracy", action="store_true", help="only the accuracy sweep")
    ap.add_argument("--rows", type=float, default=1e7)
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--json", dest="json_out", default=None, help="write results to this file")
    args = ap.parse_args()
    both = not (args.perf or args.accuracy)
    out = {}
    if args.perf or both:
        out["perf"] = perf(int(args.rows), args.repeat)
    if args.accuracy or both:
        out["accuracy"] = accuracy(args.seeds)
    if args.json_out:
        with open(args.json_out, "w") as fh:
            json.dump(out, fh, indent=2, default=float)


if __name__ == "__main__":
    main()
