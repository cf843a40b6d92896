"""``gyrotest simulate``: write a realistic bench log with known truth from a scenario."""

from __future__ import annotations

import time

import click

from ..core.units import format_duration
from .common import console, emit_json, fmt_num, json_option, note


@click.command("simulate")
@click.argument("scenario", type=click.Path(dir_okay=False))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False),
              help="Output log file (.csv, .parquet or .feather); the truth and the bench "
                   "profile are written beside it as <stem>.truth.json and <stem>.profile.toml.")
@click.option("--format", "fmt", type=click.Choice(["csv", "parquet", "feather"]), default=None,
              help="Log format (default: from the output suffix, else csv).")
@click.option("--seed", type=click.IntRange(min=0), default=None,
              help="Random seed (default: the scenario's [scenario] seed, else random; the "
                   "seed used is in the truth file).")
@click.option("--force", is_flag=True,
              help="Replace a .truth.json or .profile.toml beside the output that 'gyrotest "
                   "simulate' did not write (without it such a file is never overwritten).")
@json_option
def command(scenario, output, fmt, seed, force, as_json):
    """Simulate a gyro bench log from SCENARIO (TOML) and write it to OUTPUT.

    The model is IEEE 952 §8.3: S0·ΔN/Δt = [I + E + D]·[1 + 1e-6·ε_K]^-1 with earth rate
    (latitude, IA direction or a multi-position sequence), rate-table plateaus, thermal
    (T, dT/dt, gradient, hysteresis, the Antonova–Matveev model), magnetic, supply and warm-up
    effects, and the IEEE noise terms (N, B, K, R, Q, Markov, sinusoids, blue noise) generated
    with exact discretisations. Outputs: rate in any unit, pulse counts, up/down pairs, a
    rolling counter, or an analog voltage through an ADC. Files are written atomically.
    The scenario format is documented in sample_data/scenarios/README.md.

    \b
    Examples:
      gyrotest simulate sample_data/scenarios/fog_static.toml -o fog.csv
      gyrotest simulate sample_data/scenarios/rate_table.toml -o rt.parquet --seed 7
      gyrotest ingest fog.csv --profile fog.profile.toml -o fog.parquet
    """
    from ..api.campaign import simulate
    from ..simulation.scenario import load_scenario
    from ..simulation.writer import check_planned

    t0 = time.perf_counter()
    sc = load_scenario(scenario)
    check_planned(output, fmt, sc.runs.count)  # before any sample is drawn
    sim = simulate(sc, seed=seed)
    res = sim.core
    t1 = time.perf_counter()
    written = sim.write(output, format=fmt)
    t2 = time.perf_counter()
    if as_json:
        doc = sim.to_dict(written=written)
        truth = doc.pop("truth")
        emit_json({**doc, "simulate_s": t1 - t0, "write_s": t2 - t1, "truth": truth})
        return
    r0 = res.runs[0]
    note(f"simulated {sum(r.n for r in res.runs):,} samples "
         f"({len(res.runs)} run(s) of {format_duration(r0.n * r0.tau0)}) in {t1 - t0:.2f} s, "
         f"wrote {written.format} in {t2 - t1:.2f} s (seed {res.seed})")
    c = console()
    for run, log, truth, prof in zip(res.runs, written.logs, written.truths, written.profiles):
        t = run.truth
        earth = t["earth"]["earth_rate_ia_dph"]
        bits = [f"D_F {fmt_num(t['bias']['D_F_dph'])} deg/h"]
        if earth is not None:
            bits.append(f"earth {fmt_num(earth)} deg/h")
        sf = t["scale_factor"].get("sf")
        if sf is not None:
            bits.append(f"SF {sf:.9f}")
        c.print(f"{log}  ({', '.join(bits)})")
        c.print(f"  truth   {truth}")
        c.print(f"  profile {prof}")
    if written.summary:
        c.print(f"summary truth {written.summary}")
