"""``gyrotest allan``: Allan noise analysis that explains itself.

Deviation table with confidence intervals (Stable32 columns), joint noise-model fit with
identified/upper-bound status, model vs measurement with the diagnosis of missing terms,
Krobka's warnings, platform vs strapdown impact, unit conversions for other tools, plots.
All numbers come from :func:`gyrotest.noise.analysis.analyse_allan`.
"""

from __future__ import annotations

import csv
import io
import math

import click

from ..errors import InputError
from ..noise.deviations import DEVIATION_KINDS
from ..noise.fit import MIN_EDF
from ..output import atomic_open
from ..units import format_duration, parse_duration
from .common import (
    console,
    emit_json,
    fmt_num,
    ingest_options,
    json_option,
    note,
    plot_option,
    warn,
    with_ingest,
)
from .pool import deviation_progress, jobs_option, map_logs

_TABLE_COLS = ("tau", "n", "alpha", "sigma_lo", "sigma", "sigma_hi")


@click.command("allan")
@click.argument("logs", nargs=-1, required=True)
@click.option("--dev", "dev_kind", type=click.Choice(DEVIATION_KINDS), default="oadev",
              show_default=True,
              help="Deviation of the table (the model is always fitted to an Allan-type one).")
@click.option("--taus", default="10/decade", show_default=True,
              help="τ grid: octave, decade, N/decade, all, or a list of τ in s (0.1,1,10).")
@click.option("--stop-ratio", type=float, default=None,
              help="Longest τ = T/ratio for generated grids (default Stable32's, 4 for OADEV).")
@click.option("--terms", default="Q,N,B,K,R", show_default=True,
              help="Noise terms to fit: Q,N,B,K,R,markov,sine,blue (markov*2 for two; "
                   "+markov adds to the default).")
@click.option("--axis", "axes", default=None,
              help="Rate axes to analyse (comma-separated); default all.")
@click.option("--confidence", type=float, default=0.683, show_default=True,
              help="Confidence of the χ² intervals.")
@click.option("--min-edf", type=float, default=MIN_EDF, show_default=True,
              help="Do not fit τ with fewer equivalent degrees of freedom.")
@click.option("--detrend", type=click.Choice(["none", "linear"]), default="none",
              show_default=True, help="Remove a least-squares rate ramp first.")
@click.option("--skip", default="0", show_default=True, help="Warm-up trim, e.g. 30min.")
@click.option("--vehicle-rate", "vehicle_rates", multiple=True,
              help="Strapdown vehicle rate for the impact prediction, e.g. 10deg/s (repeatable).")
@click.option("--horizon", default="1h", show_default=True,
              help="Time at which the attitude error is reported.")
@click.option("--bi-cutoff", type=float, default=None,
              help="Fit the full bias-instability template with this cut-off f0 (Hz).")
@click.option("--no-diagnose", is_flag=True, help="Skip the search for missing terms.")
@click.option("--allow-irregular", is_flag=True,
              help="Analyse on the nominal τ0 even if the sample interval jitters > 10 %.")
@click.option("--csv", "csv_path", type=click.Path(dir_okay=False), default=None,
              help="Write the deviation table(s) to this CSV file.")
@plot_option("σ(τ) with fit, components and residuals (.png/.svg/.pdf).")
@click.option("--psd", "psd_path", type=click.Path(dir_okay=False), default=None,
              help="Welch PSD and autocorrelation figure (.png/.svg/.pdf).")
@jobs_option
@ingest_options
@json_option
@with_ingest
def command(logs, dev_kind, taus, stop_ratio, terms, axes, confidence, min_edf, detrend, skip,
            vehicle_rates, horizon, bi_cutoff, no_diagnose, allow_irregular, csv_path,
            plot_path, psd_path, jobs, as_json, ingest_opts):
    """Allan noise analysis that explains its answers.

    Overlapping Allan deviation (or --dev) with χ² confidence intervals from the EDF (noise
    type identified per τ), a joint noise-model fit weighted by the estimator's confidence
    (Q, N, B, K, R by default; markov, sine, blue on request), each coefficient identified or
    an upper bound ("≤"), residuals in CI units, the missing-term diagnosis, Krobka's warnings,
    and the platform vs strapdown attitude error. Units: σ deg/h, N deg/√h, B deg/h,
    K deg/h/√h, R deg/h/h, Q arcsec.

    Pulse-output logs are analysed as angle increments, rate logs as rate samples (from the
    ingest layer). Several LOGS (or axes) overlay on one τ axis in --plot.

    \b
    Examples:
      gyrotest allan static.csv --profile bench.toml --plot allan.png
      gyrotest allan static.csv --terms +markov --vehicle-rate 10deg/s --json
      gyrotest allan fog_100hz.csv fog_2khz.csv --plot hump.png   # Krobka's hump experiment
    """
    from ..noise.analysis import allan_document, analyse_allan, parse_taus
    from ..noise.fit import parse_terms
    from ..noise.impact import parse_horizon, parse_vehicle_rate

    parse_duration(skip, what="--skip")  # a bad --skip fails before any log is read
    horizon_s = parse_horizon(horizon)
    rates = [parse_vehicle_rate(v) for v in vehicle_rates]
    tau_spec = parse_taus(taus)
    keys = parse_terms(terms)
    if not 0.0 < confidence < 1.0:
        raise InputError(f"--confidence must be between 0 and 1, got {confidence}")
    for p in (plot_path, psd_path):
        if p:
            from ..plotting import check_plot_path

            check_plot_path(p)
    axis_list = [a.strip() for a in axes.split(",") if a.strip()] if axes else None
    with deviation_progress():  # a bar on a terminal for τ loops longer than 2 s
        results = map_logs(  # one process per log with --jobs (identical results)
            analyse_allan, logs, ingest_opts, jobs=jobs, announce=not as_json,
            skip_s=skip, dev=dev_kind, taus=tau_spec, terms=keys, vehicle_rates=rates,
            axes=axis_list, confidence=confidence, stop_ratio=stop_ratio, min_edf=min_edf,
            detrend=detrend, run_diagnosis=not no_diagnose,
            impact_horizon_s=horizon_s, bi_cutoff_hz=bi_cutoff, allow_irregular=allow_irregular)
    items = [(r.source, a) for r in results for a in r.axes]
    if csv_path:
        _write_csv(csv_path, results)
    if plot_path:
        from ..noise.plots import plot_allan

        plot_allan(items, plot_path)
    if psd_path:
        from ..noise.plots import plot_psd

        plot_psd(items, psd_path)
    if as_json:
        _warnings(results, as_json)
        emit_json(allan_document(results, csv=csv_path, plot=plot_path, psd=psd_path))
        return
    for r in results:
        _render(r)
    _warnings(results, as_json)
    for p, what in ((csv_path, "table"), (plot_path, "plot"), (psd_path, "PSD plot")):
        if p:
            note(f"{what} written to {p}")


def _warnings(results, as_json: bool) -> None:
    """Krobka's warnings on stderr (info-level ones as notes, not with --json)."""
    for r in results:
        for a in r.axes:
            for w in a.warnings:
                if w.severity == "warning":
                    warn(f"{r.source} [{a.axis}] {w.code}: {w.title}: {w.message}")
                elif not as_json:
                    note(f"{r.source} [{a.axis}] {w.code}: {w.message}")


def _table_rows(r):
    for a in r.axes:
        tab = a.table()
        for i in range(len(tab["tau"])):
            row = {"source": r.source, "axis": a.axis, "deviation": a.dev.kind}
            row.update({k: tab[k][i] for k in _TABLE_COLS})
            row["edf"] = tab["edf"][i]
            if "model" in tab:
                row["model"] = tab["model"][i]
                row["residual_ci"] = tab["residual_ci"][i]
                row["fitted"] = bool(tab["fitted"][i])
            yield row


def _write_csv(path, results) -> None:
    buf = io.StringIO()
    cols = ["source", "axis", "deviation", *_TABLE_COLS, "edf", "model", "residual_ci", "fitted"]
    w = csv.DictWriter(buf, fieldnames=cols, lineterminator="\n")
    w.writeheader()
    for r in results:
        for row in _table_rows(r):
            out = {}
            for k in cols:
                v = row.get(k, "")
                if isinstance(v, float) or hasattr(v, "dtype"):
                    v = float(v)
                    v = "" if not math.isfinite(v) else f"{v:.8g}"
                out[k] = v
            w.writerow(out)
    with atomic_open(path, "w", encoding="utf-8", newline="") as fh:
        fh.write(buf.getvalue())


def _render(r) -> None:
    from rich.table import Table

    c = console()
    for a in r.axes:
        d = a.dev
        c.print(f"\n[bold]{r.source}[/bold] — axis {a.axis}: {len(a.dev.tau)} τ, "
                f"{r.n_samples} samples at τ0 = {r.tau0:g} s ({format_duration(r.duration_s)})")
        c.print(f"  input: {a.input_note}")
        t = Table(title=f"{d.kind.upper()} (σ in {d.unit}); CI {100 * d.confidence:.1f} % from "
                        f"the EDF: {d.ci_method}", title_justify="left")
        for col in ("tau s", "n", "alpha", "sigma_lo", "sigma", "sigma_hi", "model", "resid CI"):
            t.add_column(col, justify="right")
        tab = a.table()
        for i in range(len(tab["tau"])):
            model = fmt_num(float(tab["model"][i])) if "model" in tab else ""
            res = ""
            if "residual_ci" in tab:
                rv = float(tab["residual_ci"][i])
                res = "—" if not math.isfinite(rv) else f"{rv:+.1f}"
                if not tab["fitted"][i]:
                    res += " nf"
            t.add_row(fmt_num(float(tab["tau"][i])), str(int(tab["n"][i])),
                      str(int(tab["alpha"][i])), fmt_num(float(tab["sigma_lo"][i])),
                      fmt_num(float(tab["sigma"][i])), fmt_num(float(tab["sigma_hi"][i])),
                      model, res)
        c.print(t)
        if "residual_ci" in tab:
            c.print("  alpha: noise type per τ for the EDF (2 white angle … 0 white rate … −2 RRW); "
                    "nf = not fitted (EDF < floor)")
        _render_fit(a)
    if r.cross is not None:
        ct = Table(title="Axis cross-correlation ρ of τ-averaged rates (zero within ±b, 95 %)",
                   title_justify="left")
        ct.add_column("τ s", justify="right")
        ct.add_column("±b", justify="right")
        k = len(r.cross.axes)
        pairs = [(i, j) for i in range(k) for j in range(i + 1, k)]
        for i, j in pairs:
            ct.add_column(f"ρ {r.cross.axes[i]}/{r.cross.axes[j]}", justify="right")
        for tau, m, b in zip(r.cross.tau, r.cross.matrices, r.cross.band):
            ct.add_row(fmt_num(tau), f"{b:.3f}", *[f"{m[i, j]:+.3f}" for i, j in pairs])
        c.print(ct)
    for n in r.notes:
        note(f"{r.source}: {n}")


def _term_value(term) -> str:
    """'0.005 ± 8.1e-06' or '≤ 0.035'; two-parameter terms list both."""
    if term.status == "upper bound":
        return "≤ " + fmt_num(term.upper, 3)
    parts = []
    for k, v in term.params.items():
        sg = term.sigma.get(k)
        txt = fmt_num(v, 4) + (f" ± {fmt_num(sg, 2)}" if sg is not None else "")
        parts.append(txt if len(term.params) == 1 else f"{k} {txt} {term.units[k]}")
    return "; ".join(parts)


def _fit_table(f, title: str):
    from rich.table import Table

    lo, hi = f.fit_range
    t = Table(title=f"{title} (τ {fmt_num(lo)}–{fmt_num(hi)} s; χ²/dof = {f.chi2_dof:.2f}, "
                    f"p = {f.p_value:.2g}, n_eff = {f.n_eff:.1f})", title_justify="left")
    for col in ("term", "value", "unit", "status", "dominates τ s"):
        t.add_column(col)
    for term in f.terms:
        dom = "" if not term.dominant_tau else (f"{fmt_num(term.dominant_tau[0])}–"
                                                f"{fmt_num(term.dominant_tau[1])}")
        unit = term.units[term.main] if len(term.params) == 1 else ""
        t.add_row(f"{term.label} {term.title}", _term_value(term), unit, term.status, dom)
    return t


def _render_fit(a) -> None:
    c = console()
    f = a.fit
    c.print(_fit_table(f, "Noise model, requested terms"))
    c.print("  ≤: upper bound only (95 % profile likelihood); ±: 1σ (sandwich covariance); "
            "weights: χ²(EDF) likelihood of each σ̂²(τ)")
    if a.diagnosis is not None and a.diagnosis.final is not f:
        c.print(_fit_table(a.diagnosis.final, "Diagnosed model"))
    ro = a.readoffs
    if "N_upper" in ro:
        c.print(f"  classic read-offs (for comparison): N slope-line {fmt_num(ro['N_slope'])} at "
                f"τ {fmt_num(ro['N_slope_tau_s'])} s, N_upper = min σ√τ/60 = "
                f"{fmt_num(ro['N_upper'])} deg/√h; K slope-line {fmt_num(ro['K_slope'])} "
                f"deg/h/√h; B tangent σ_min/0.664 = {fmt_num(ro['B_tangent'])} deg/h "
                f"(Allan floor {fmt_num(ro['allan_floor_dph'])} deg/h at τ "
                f"{fmt_num(ro['allan_floor_tau_s'])} s)")
    dg = a.diagnosis
    if dg is not None:
        for reg in dg.regions:
            c.print(f"  misfit: {reg.text()}")
        if dg.candidates:
            c.print("  candidates: " + "; ".join(
                f"{cd.term} {cd.evidence()}{' ✓' if cd.accepted else ''}"
                for cd in dg.candidates[:5]))
        if len(dg.steps) > 1:
            c.print("  ladder: " + " → ".join(
                f"{s['added'] or 'base'} χ²/dof {s['chi2_per_dof']:.2f}" for s in dg.steps))
        c.print(f"  [bold]diagnosis:[/bold] {dg.verdict}")
    conv = a.conversions
    if "N" in conv:
        n = conv["N"]
        kal = conv["kalibr"]
        mat = conv["matlab_gyroparams"]
        c.print(f"  conversions: N = {fmt_num(n['deg_s_per_rt_hz'])} °/s/√Hz = "
                f"{fmt_num(n['rad_s_per_rt_hz'])} rad/s/√Hz; Kalibr gyroscope_noise_density "
                f"{fmt_num(kal['gyroscope_noise_density'])}, gyroscope_random_walk "
                f"{fmt_num(kal['gyroscope_random_walk'])}; MATLAB gyroparams NoiseDensity "
                f"{fmt_num(mat['NoiseDensity'])}, BiasInstability {fmt_num(mat['BiasInstability'])}, "
                f"RandomWalk {fmt_num(mat['RandomWalk'])} (continuous-time; bounds exported as "
                "bounds)")
    imp = a.impact
    if imp is not None:
        hz = format_duration(imp.horizon_s)
        line = (f"  attitude error after {hz} (3 gyros, first order): platform "
                f"{fmt_num(imp.platform_sigma_deg * 3600)}″")
        for w, s, q in zip(imp.rates_rad_s, imp.strapdown_sigma_deg, imp.ratio):
            line += (f"; strapdown at {math.degrees(w):g} deg/s {fmt_num(s * 3600)}″ "
                     f"(SINS/INS {q:.2f})")
        c.print(line)
        for fl in imp.flags:
            c.print(f"    {fl['text']}")
    for n in a.notes:
        note(n)
