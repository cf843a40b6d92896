"""``gyrotest model``: the model workbench (fit, diagnose, history).

Also hosts the option decorators and renderers shared by ``thermal-fit``, ``mag-fit`` and
``compensate``.
"""

from __future__ import annotations

import math
from pathlib import Path

import click
from rich.markup import escape

from ..errors import InputError
from ..units import format_duration
from .common import (
    console,
    emit_json,
    fmt_num,
    ingest_options,
    json_option,
    load_for_terms,
    note,
    plot_option,
    progress,
    warn,
    with_ingest,
)

# ----------------------------------------------------------------------------- shared options


def prep_options(f):
    """Options that control how a log is prepared for model fitting."""
    opts = [
        click.option("--axis", default=None, help="Gyro axis (rate column) to model; default the "
                     "first."),
        click.option("--skip", default="0", show_default=True,
                     help="Drop the start of the log (e.g. 10min); the warm-up term then counts "
                          "time from the true power-on."),
        click.option("--t-ref", "t_ref", type=float, default=None,
                     help="Reference temperature T_ref, degC (default: mean of each sensor)."),
        click.option("--v-ref", "v_ref", type=float, default=None,
                     help="Reference supply voltage, V (default: mean)."),
        click.option("--resolution", default="auto", show_default=True,
                     help="Working resolution: block length (e.g. 30s) or 'auto' (from the "
                          "noise level)."),
        click.option("--smooth", default="auto", show_default=True,
                     help="Smoother window W for dT/dt and the matched smoothing (e.g. 120s) or "
                          "'auto'."),
        click.option("--folds", type=click.IntRange(2, 20), default=5, show_default=True,
                     help="Folds of the blocked cross-validation (held-out RMS)."),
        click.option("--reference", default=None, metavar="LOG",
                     help="Static reference run of the same gyro (read with the same ingest "
                          "options): its white, flicker and random-walk noise give the noise "
                          "floor. Default: the log's own short-tau noise."),
    ]
    for o in reversed(opts):
        f = o(f)
    return f


def domain_fit_options(*, smooth_help: str, plot_help: str):
    """The log-preparation, model-file and plot options of ``thermal-fit`` and ``mag-fit``
    (``--axis --skip --resolution --smooth --folds --reference -o --plot``)."""
    opts = [
        click.option("--axis", default=None, help="Gyro axis (rate column); default the first."),
        click.option("--skip", default="0", show_default=True, help="Drop the start of the log."),
        click.option("--resolution", default="auto", show_default=True,
                     help="Working resolution (block length) or 'auto'."),
        click.option("--smooth", default="auto", show_default=True, help=smooth_help),
        click.option("--folds", type=click.IntRange(2, 20), default=5, show_default=True,
                     help="Folds of the blocked cross-validation."),
        click.option("--reference", default=None, metavar="LOG",
                     help="Static reference run of the same gyro: its noise gives the floor the "
                          "held-out RMS is judged against. Default: the log's own short-tau "
                          "noise."),
        click.option("-o", "--output", default=None,
                     help="Write the fitted model (.json/.toml) for 'gyrotest compensate'."),
        plot_option(plot_help),
    ]

    def decorate(f):
        for o in reversed(opts):
            f = o(f)
        return f

    return decorate


def term_options(f):
    opts = [
        click.option("--terms", "terms", multiple=True,
                     help="Model terms, comma-separated: T, T2, T3, dTdt, dGdt, Tlag, Hx, Hy, Hz, "
                          "V, g, g2, ramp, warmup, sin, hyst, rate, rateT; a channel in "
                          "parentheses, e.g. T2(T_coil) or dGdt(T_a,T_b). Repeatable."),
        click.option("--term", "custom", multiple=True,
                     help="A custom term NAME:EXPRESSION from any channel, e.g. "
                          "\"vib:extra.vib_g**2\" (see 'gyrotest model fit --help'). Repeatable."),
    ]
    for o in reversed(opts):
        f = o(f)
    return f


def check_output(path: str | None, suffixes: tuple[str, ...], what: str) -> Path | None:
    """Validate an output path before any work (suffix and directory)."""
    if path is None:
        return None
    from ..output import check_output_path

    return check_output_path(path, suffixes, what)


# ----------------------------------------------------------------------------- rendering
def fmt_t(seconds: float, span: float) -> str:
    """A time in the unit that suits the record length."""
    if span > 3 * 3600:
        return f"{seconds / 3600:.2f} h"
    if span > 300:
        return f"{seconds / 60:.1f} min"
    return f"{seconds:.0f} s"


def _excursion_lines(out, res, limit: int) -> None:
    span = float(res.data.get("duration_s") or (res.t[-1] if len(res.t) else 0.0))
    for i, e in enumerate(res.excursions[:limit], 1):
        out.print(f"    {i}. {fmt_t(e.t_start_s, span)} – {fmt_t(e.t_end_s, span)}: "
                  f"peak {e.peak_dph:+.3g} deg/h — {e.description}")
    if len(res.excursions) > limit:
        out.print(f"    ... {len(res.excursions) - limit} more (--json for all)")


def _short(res) -> str:
    wd = getattr(res, "wd", None)
    return getattr(wd, "resolution_short", None) or res.resolution_note


def _pm(c) -> str:
    return f"{fmt_num(c.value)} ± {fmt_num(c.stderr, 2)}"


def render_fit(res, *, title: str = "model fit") -> None:
    """Rich text of a FitResult on stdout."""
    from rich.table import Table

    out = console()
    d = res.data
    where = escape(str(d.get("file") or d.get("source")))
    out.print(f"[bold]{title}[/bold]: {where} (axis {escape(str(d.get('axis')))}, "
              f"{d.get('samples', 0):,} samples, {format_duration(d.get('duration_s', 0))})")
    out.print(f"  working resolution: {_short(res)}")
    t = Table(title="coefficients (± 1σ HAC, robust to autocorrelated residuals)")
    for col, just in (("term", "left"), ("coefficient ± 1σ", "right"), ("unit", "left"),
                      ("significance (|z|)", "left")):
        t.add_column(col, justify=just)
    for c in res.coefficients:
        z = abs(c.z)
        t.add_row(c.name, _pm(c), c.unit,
                  f"{c.significance} ({z:.3g})" if math.isfinite(z) else "n/a")
    out.print(t)
    out.print(f"  residual RMS: fit [bold]{fmt_num(res.rms_fit)}[/bold] deg/h, held-out "
              f"[bold]{fmt_num(res.rms_holdout)}[/bold] deg/h (no model: {fmt_num(res.rms_raw)})")
    out.print(f"  held-out scheme: {res.holdout_scheme}")
    if res.floor:
        f = res.floor
        out.print(f"  noise floor (fixed for this log, not from this model's residual): "
                  f"{fmt_num(f.rms_dph)} deg/h (white N = {fmt_num(f.arw_deg_rt_h, 3)} deg/√h, "
                  f"flicker plateau {fmt_num(f.flicker_B, 3)} deg/h); held-out / floor = "
                  f"{fmt_num(res.rms_holdout / f.rms_dph, 3)}")
        out.print(f"    basis: {f.basis}", markup=False)
    out.print(f"  AIC {res.aic:.1f}, BIC {res.bic:.1f} ({res.n_params} parameters, "
              f"{res.n_blocks} blocks; compare models on the same log only)")
    out.print(f"  uncertainty: {res.hac.method}, bandwidth {res.hac.bandwidth:.3g} blocks; "
              f"condition number {fmt_num(res.condition_number, 3)}")
    if res.adev_tau is not None and len(res.adev_tau):
        import numpy as np

        picks = []
        for target in (1, 10, 100, 1000, 10000):
            i = int(np.argmin(np.abs(np.log(res.adev_tau / target))))
            if abs(math.log(res.adev_tau[i] / target)) < 0.8 and i not in picks:
                picks.append(i)
        if picks:
            out.print("  residual Allan deviation: " + ", ".join(
                f"σ({res.adev_tau[i]:g} s) = {fmt_num(res.adev_sigma[i], 3)}" for i in picks)
                + " deg/h")
    if res.excursions:
        out.print(f"  where it fails ({len(res.excursions)} excursion(s) of the residual):")
        _excursion_lines(out, res, 10)
    for w in res.warnings:
        warn(w)


def load_reference(path: str | None, opts: dict, quiet: bool):
    """The ``--reference`` log, read with the same ingest options (units, gyro output, time);
    the auxiliary channels a profile names (temperatures, fields, ...) are not required of a
    static run. Errors name the option."""
    if not path:
        return None
    import dataclasses

    from ..ingest import read_log
    from ..profile import load_profile
    from .common import ingest_overrides

    aux = ("temperature", "field", "supply", "table_rate", "position", "extra")
    try:
        prof = load_profile(opts["profile"]) if opts.get("profile") else None
        if prof is not None:
            prof = dataclasses.replace(prof, columns={k: v for k, v in prof.columns.items()
                                                      if k not in aux})
        ov = ingest_overrides(opts)
        ov["columns"] = {k: v for k, v in ov["columns"].items() if k not in aux}
        return read_log(path, profile=prof, overrides=ov,
                        nan_policy=opts.get("nan_policy") or "error")
    except InputError as e:
        raise InputError(f"--reference: {e}") from None


def _rejected_label(reason: str) -> str:
    """A few words for the candidate table from the full rejection ``reason`` (the verdict
    line gives the whole sentence)."""
    from ..envmodel.rules import SPECTRAL_REJECT

    if reason.startswith(SPECTRAL_REJECT):
        return "not out of the residual's slow noise"
    if "period" in reason:
        return "period of a logged stimulus"
    if "time constant" in reason:
        return "lag as long as the record"
    if "noise floor" in reason:
        return "model at the noise floor"
    return reason.split(":")[0][:40]


def render_diagnosis(diag, top: int = 12) -> None:
    from rich.markup import escape
    from rich.table import Table

    out = console()
    b = diag.base
    out.print(f"[bold]model diagnose[/bold]: base terms {escape(' + '.join(b.terms))}; held-out "
              f"RMS {fmt_num(b.rms_holdout)} deg/h, noise floor {fmt_num(diag.noise_floor_dph)} "
              f"deg/h (held-out/floor {fmt_num(diag.ratio_to_floor, 3)})")
    out.print(f"  noise floor: {escape(diag.floor_basis)}")
    out.print(f"  working resolution: {_short(b)}")
    t = Table(title="candidate terms, best first (held-out residual; HAC significance in the "
                    "augmented model)")
    for col, just in (("#", "right"), ("term", "left"), ("physical effect", "left"),
                      ("held-out RMS, deg/h", "right"), ("gain", "right"),
                      ("evidence", "left"), ("missing?", "left")):
        t.add_column(col, justify=just)
    for i, c in enumerate(diag.candidates[:top], 1):
        eff = c.effect.split(" [")[0]
        if c.replaces:
            eff = eff.replace(f" (replaces {c.replaces})", "") + f" (replaces {c.replaces})"
        ev = (c.error or (f"z {c.z:.1f}, p·trials {c.p_trials:.1g}, p_adj {c.p_adj:.1g}"
                          if math.isfinite(c.z) else "—"))
        if c.rejected:
            ev += f"; rejected: {_rejected_label(c.rejected)}"
        if c.chance is not None:
            ev += f"; surrogate p {c.chance.p:.2f}"
        mark = ("[green]yes[/green]" + (" (chosen)" if c is diag.chosen else "")
                if c.significant else "no")
        t.add_row(str(i), escape(c.term), escape(eff), fmt_num(c.rms_holdout),
                  f"{c.improvement_pct:+.1f}%" if math.isfinite(c.improvement_pct) else "—",
                  escape(ev), mark)
    out.print(t)
    style = "green" if diag.found else "bold"
    out.print(f"[{style}]{escape(diag.verdict)}[/{style}]")
    if len(diag.path) > 1:
        out.print("  forward path (each step judged in the model with the steps before it):")
        for k, p in enumerate(diag.path, 1):
            out.print(f"    {k}. +{escape(p['term'])}: held-out "
                      f"{fmt_num(p['rms_holdout_before_dph'])} → "
                      f"{fmt_num(p['rms_holdout_after_dph'])} deg/h (held-out/floor "
                      f"{fmt_num(p['ratio_to_floor_after'], 3)}); {escape(p['add'])}")
    out.print(f"  rule: missing effect = held-out RMS down (fold consistency ≥ 1) by "
              f"≥ {diag.min_improvement_pct:g} % "
              f"and HAC p × trials × candidates < {diag.alpha:g}, or down by ≥ 5 % with p × "
              "trials < 0.01 (0.001 for ramp/warm-up/sinusoid/hysteresis; a warm-up ≥ 10 % "
              "at fold consistency ≥ 2.13 with 0.01) while the model is "
              "above 1.2x the noise floor, or (model ≥ 2x the floor) down by ≥ 10 % "
              "consistently across the folds (gain/(fold scatter/√folds) ≥ 2.13, |z| ≥ 1, "
              "or as a last resort spectral z ≥ 8 when other effects inflate the HAC error; "
              "ramp/warm-up/sinusoid/hysteresis ≥ 20 % at ≥ 3.75, a warm-up at ≥ 2.13 with "
              "spectral z ≥ 8); off the strict test, spectral (Whittle) z ≥ 8 against the "
              "residual's own spectrum (≥ 4 while the model is within 2x the floor, or when "
              "the candidate brings it within 1.25x) unless "
              "the gain is ≥ 55 % with fold consistency ≥ 5 or ≥ 40 % at ≥ 10 (a pair: ≥ 40 "
              "% at ≥ 5, then z ≥ 6; none when a member failed the test alone; a pair with "
              "a warm-up at fold consistency ≥ 2.13 with z ≥ 8; a pair's "
              "first member that alone makes the model worse only when the next step then "
              "names an effect; a pair of terms that stood out neither alone needs HAC "
              "|z| ≥ 4 each in its fit unless it gains ≥ 55 % at fold consistency ≥ 10 "
              "or ≥ 70 % at ≥ 5, with spectral z ≥ 8); far "
              "above the floor a red residual's lowest bins are floored at the power law "
              "of the band above (not for a warm-up or at HAC |z| ≥ 3.5); hysteresis "
              "needs fold consistency ≥ 4 (≥ 10 off the strict test, ≥ 100 at p × trials < 0.05); "
              "a lag with τ ≥ 95 % of the record only on the strict test; a product that is "
              "its factor's level to |r| ≥ 0.98 gives way to that level (≥ 2x the floor); "
              "within 1.1x the floor a gain ≥ 20 % (≥ 10 % "
              "strict, fold consistency ≥ 4); the model's field terms in the gyro's axes "
              "(Hvec, Hquad) at ≥ 8 %, fold consistency ≥ 2.5 (Hquad also before a new "
              "second-order field term it beats by ≥ 10 %, unless that term with one more "
              "second-order field term holds out as well; Hquad gives way to two "
              "second-order field terms that hold out as well as a pair); then (above 1.2x "
              "the floor) "
              "the largest in-sample gains (≥ 20 %) in place of each model term; then "
              "(≥ 2x the floor) three or more effects that hide one another: the 10 "
              "channel-driven candidates of largest in-sample gain fitted together and "
              "eliminated backward (a member goes at < 2 % held-out cost or HAC |z| < 4), "
              "≥ 3 left, ≥ 50 % at fold consistency ≥ 5, spectral z ≥ 8; ties go to "
              "channel-based "
              "terms and to the channels the model already uses")
    if b.excursions:
        out.print("  where the base model fails:")
        _excursion_lines(out, b, 8)


def render_history(steps, *, logs: int = 1) -> None:
    from rich.table import Table

    out = console()
    if logs > 1:
        note(f"the history holds {logs} different logs; showing the latest (use --all)")
    t = Table(title=f"model history: {steps[0].log}" if steps else "model history")
    for col, just in (("step", "right"), ("change", "left"), ("params", "right"),
                      ("RMS fit", "right"), ("RMS held-out", "right"), ("floor", "right"),
                      ("AIC", "right"), ("ΔAIC", "right")):
        t.add_column(col, justify=just, overflow="fold")
    prev_aic = None
    for s in steps:
        change = " ".join([f"+{a}" for a in s.added] + [f"−{r}" for r in s.removed]) or "(same)"
        daic = "" if prev_aic is None else f"{s.aic - prev_aic:+.1f}"
        t.add_row(str(s.step), change, str(s.n_params), fmt_num(s.rms_fit_dph, 3),
                  fmt_num(s.rms_holdout_dph, 3), fmt_num(s.noise_floor_dph, 3),
                  f"{s.aic:.0f}", daic)
        prev_aic = s.aic
    out.print(t)


def write_plot(figs, path) -> None:
    from ..envmodel.plots import write_figures

    paths = write_figures(figs, path)
    note("plot written: " + ", ".join(str(p) for p in paths))


# ----------------------------------------------------------------------------- commands
@click.group("model")
def command():
    """Model workbench: fit a drift model, find the missing effect, watch the error fall.

    \b
      gyrotest model fit LOG --terms T,T2 -o model.json     fit and save (history kept)
      gyrotest model diagnose LOG --terms T,T2              which effect is missing?
      gyrotest model fit LOG --terms T,T2,dTdt -o model.json
      gyrotest model history model.json --plot hist.png     the steps, error falling
      gyrotest model terms                                  the library of effects
    """


@command.command("fit")
@click.argument("log", type=str)
@term_options
@prep_options
@click.option("-o", "--output", "output", default=None,
              help="Write the model (.json or .toml); a history is kept beside it.")
@click.option("--session", default=None, type=click.Path(file_okay=False),
              help="Keep every step's model and the history in this directory instead.")
@click.option("--no-history", is_flag=True, help="Do not append to the model history.")
@click.option("--k", "k_sigma", type=float, default=4.0, show_default=True,
              help="Excursion threshold: |smoothed residual| > k·σ.")
@plot_option("Residual plots (.png/.svg: several files; .pdf: one document).")
@ingest_options
@json_option
@with_ingest
def fit_cmd(log, terms, custom, axis, skip, t_ref, v_ref, resolution, smooth, folds, reference,
            output, session, no_history, k_sigma, plot_path, as_json, ingest_opts):
    """Fit a drift model with the given terms and show where it fails.

    The gyro rate (minus the rate-table rate, if any) is modelled as a bias plus the TERMS, in
    physical units: D_T (deg/h)/degC, D_Tdot (deg/h)/(degC/h), w_x deg/h per 100 uT, ...
    Fitting runs on smoothed block means (the working resolution is chosen from the noise
    level and stated); uncertainties are HAC (robust to autocorrelated noise); the held-out RMS
    comes from blocked cross-validation. Custom terms (--term NAME:EXPR) use temp.NAME,
    field.NAME, extra.NAME, supply, table_rate, t, t_h, + - * / **, abs sqrt exp log log10
    sin cos tan tanh arctan sign square minimum maximum clip, ddt(x) and lag(x, tau_s).

    \b
    Examples:
      gyrotest model fit sample_data/thermal.parquet --profile sample_data/thermal.profile.toml \\
          --terms T,T2,dTdt -o model.json
      gyrotest model fit sample_data/thermal.parquet --profile sample_data/thermal.profile.toml \\
          --terms "T(T_coil_a_C),Tlag(T_chamber_C)" --plot fit.png
      gyrotest model fit vib_run.csv --terms T --term "vib:extra.vib_g**2" --json   # your log
    """
    from ..envmodel.fit import fit_document, fit_log
    from ..envmodel.history import append_history, session_paths
    from ..envmodel.prepare import collect_terms

    specs = collect_terms(terms, custom)
    out_path = check_output(output, (".json", ".toml"), "model file")
    if plot_path:
        from ..plotting import check_plot_path

        check_plot_path(plot_path)
    if session:
        sp = Path(session)
        if sp.exists() and not sp.is_dir():
            raise InputError(f"--session {session}: not a directory")
        parent = sp.parent if str(sp.parent) else Path(".")
        if not parent.is_dir():
            raise InputError(f"--session {session}: directory {parent} does not exist")
    g = load_for_terms(log, ingest_opts, specs, announce=not as_json)
    ref = load_reference(reference, ingest_opts, as_json)
    res = fit_log(g, specs, path=log, axis=axis, skip=skip, t_ref=t_ref, v_ref=v_ref,
                  resolution=resolution, smooth=smooth, folds=folds, k_sigma=k_sigma,
                  reference=ref)
    written: dict = {}
    if session:
        from ..envmodel.history import load_history

        sp = Path(session)
        sp.mkdir(exist_ok=True)
        hist_file = sp / "history.json"
        n = len(load_history(hist_file)) + 1 if hist_file.is_file() else 1
        mpath, hpath = session_paths(sp, n, out_path.suffix if out_path else ".json")
        res.model.save(mpath)
        step = append_history(hpath, res, model_file=mpath.name)
        written.update(model_file=str(mpath), history_file=str(hpath), step=step.step)
    if out_path:
        res.model.save(out_path)
        written["model_file"] = str(out_path)
        if not no_history and not session:
            from ..envmodel.history import history_path_for

            hp = history_path_for(out_path)
            step = append_history(hp, res, model_file=out_path.name)
            written.update(history_file=str(hp), step=step.step)
    if plot_path:
        from ..envmodel.plots import fit_figures

        write_plot(fit_figures(res), plot_path)
    if as_json:
        emit_json(fit_document(res, written=written))
        return
    render_fit(res)
    if written.get("model_file"):
        extra = (f"; history {written['history_file']} step {written['step']}"
                 if written.get("history_file") else "")
        console().print(f"  model written to {written['model_file']}{extra}")
    if not out_path and not session and not as_json:
        note("add -o model.json to keep the model and its history; run 'gyrotest model "
             "diagnose' to find a missing effect")


@command.command("diagnose")
@click.argument("log", type=str)
@term_options
@prep_options
@click.option("--candidates", default=None,
              help="Only try these terms (comma-separated); default every term the channels "
                   "allow.")
@click.option("--alpha", type=float, default=None,
              help="Family-wise significance level (default 0.001).")
@click.option("--min-improvement", type=float, default=1.0, show_default=True,
              help="Smallest held-out RMS improvement (%) that counts as a missing effect.")
@click.option("--path", "path_steps", type=click.IntRange(1, 10), default=3, show_default=True,
              help="Steps of the forward path: after the missing effect, look for the next "
                   "one in the model that has it (several effects are often missing at once).")
@click.option("--top", type=int, default=12, show_default=True, help="Rows to show.")
@plot_option("Base residual and candidate bar chart (.png/.svg/.pdf).")
@ingest_options
@json_option
@with_ingest
def diagnose_cmd(log, terms, custom, axis, skip, t_ref, v_ref, resolution, smooth, folds,
                 reference, candidates, alpha, min_improvement, path_steps, top, plot_path,
                 as_json, ingest_opts):
    """Which physical effect does the model lack? Try every candidate and rank them.

    Candidates: every library term the log's channels allow and the model lacks, and a screen
    of every logged channel (level, square, |x|, rate of change, first-order lag with a fitted
    time constant, rate of that lag; H_i², H_i·H_j, |H|², g_i·g_j). Each is added in turn
    and scored by its held-out residual RMS (blocked cross-validation), with a HAC test of
    its coefficient in the augmented model. A missing effect needs its held-out gain more
    often a gain than not across the folds (gain / (fold scatter / sqrt(folds)) >= 1) and
    either passes the strict test
    (p x trials x candidates < alpha, gain >= --min-improvement) or gives a clear gain (>= 5 %
    while the model is above 1.2x the noise floor, p x trials < 0.01; a warm-up, which most
    folds cannot see, also >= 10 % at fold consistency >= 2.13), or, when the model is
    at least 2x the noise floor, cuts the held-out RMS by >= 10 % consistently across the
    folds (gain / (fold scatter / sqrt(folds)) >= 2.13, |z| >= 1; ramp, warm-up, sinusoid
    and hysteresis >= 20 % at >= 3.75, a warm-up, which most folds cannot see, at >= 2.13
    with spectral z >= 8); there, when no single
    term qualifies (or a pair of two others halves the held-out RMS of the one that does),
    the best candidates, further channels and the largest in-sample gains are also tried
    in pairs, and so are the level and square of each channel and a ramp beside each of
    them (two effects that hide each other are named one after the other; a pair with a
    warm-up at fold consistency >= 2.13 when its spectral z is >= 8; when the best pair
    fails the joint HAC test (both members |z| < 1 alone), a qualifying pair naming the
    same member first stands in (such a pair passes without that test at a gain >= 55 %
    with fold consistency >= 10, or >= 70 % with >= 5, and spectral z >= 8); a pair whose
    first member alone makes the model worse only when the next step then names an
    effect, so the loop cannot add and remove it in turn); last of all, a term whose |z| < 1 only
    because other missing effects inflate its error, when its coefficient stands out of the
    residual's spectrum (spectral z >= 8). A
    sinusoid on the period of a logged stimulus is rejected when a term of that channel
    gets half its gain; otherwise it stands, and the verdict says whose period it shares.
    Off the strict test, the added coefficients must also stand out of the candidate
    model's residual spectrum (frequency-domain GLS z >= 8; >= 4 while the model is
    within 2x the floor, or when the candidate brings it within 1.25x), unless the held-out
    gain is >= 55 % with fold consistency >= 5 or >= 40 % at >= 10 (a pair: >= 40 % at >= 5, then z >= 6; no exemption for a pair with a
    member that failed the test alone): a smooth channel fitted to the gyro's own slow
    wander is not named. Far above the floor the lowest bins of a red residual's spectrum
    are raised to the power law of the band above (not for a warm-up, nor for a coefficient
    at HAC |z| >= 3.5). A hysteresis branch also needs fold consistency >= 4 (>= 10 with
    p x trials < 0.01 off the strict test, or >= 100 with p x trials < 0.05) and is paired
    only with the level or square of its own temperature, hyst(c) with T(c) or T2(c), each
    coefficient at HAC z >= 4 in the pair's fit (a warm-up, one transient with about one
    degree of freedom, at spectral z >= 8 instead; a hysteresis at spectral z >= 8 when the
    pair's fold consistency is >= 100); the same joint test (and a gain >= 40 % at fold
    consistency >= 5) admits a hysteresis or a term set aside by the spectral test beside
    another candidate (a warm-up hidden by a missing hysteresis). A pair tested jointly
    that fails the joint test still qualifies on decisive evidence (gain >= 55 % at fold
    consistency >= 10, or >= 70 % at >= 5, and spectral z >= 8) against the model and
    against its better member alone: a tilt table of few positions leaves a member few
    effective degrees of freedom. At >= 2x the floor, tied candidates (within 2 %, or
    a gain over them with fold consistency < 2.13) are told apart by the step after them
    (each fitted with the pair pool, second-order forms and channel cross terms), and a lag (Tlag, chanlag) gives way to its
    plain form when that does >= 10 % better beside a missing rate term of another channel
    (and a level T, chan to its lag when the lag does >= 10 % better beside a rate term, its
    channel's own included: a lagged node and its sensor's rate hide each other);
    a lag whose time constant reaches the record length is named only on the strict test
    (lagged that long, a channel is a slow trend that fits the gyro's own drift).
    A ramp, warm-up or hysteresis added as the missing effect (not in place of a model
    term) must also beat a
    look-elsewhere surrogate test: the best gain any candidate reaches on 39
    phase-randomised surrogates of the residual (held out fold by fold as the diagnosis
    holds out the log) may reach its gain in at most 3 of them
    (surrogate p <= 0.1); otherwise the best other qualifying candidate whose own gain
    passes that test is named, or none. A channel term is set aside (left "possible") when
    those surrogates reach its gain and so do 39 circular shifts and reversals of the
    residual it leaves (the gyro's own excursions kept); a pair when the best pair of the
    step's eight best candidates reaches its gain on the surrogates (at 2-10x the floor).
    A channel term set aside with no other single to name may be one of two effects that
    hide each other (the missed one is in every surrogate): the step's best qualifying pair
    is named instead when it beats that pair test.
    A product of two channels gives way to the level terms of its factors when those do
    >= 10 % better together (no interaction without its main effects), and to the level of
    a factor when, over this log, it is that level to |r| >= 0.98 (the other factor nearly
    constant: a tilt table's vertical gravity component) and the level qualifies, leaving the
    model >= 2x the floor; the next step tests the product beside it. A model within 1.1x
    the floor takes a new term only at a gain >= 20 %, or >= 10 % on the strict test with
    fold consistency >= 4. When no new effect qualifies, the model's own field terms of an
    order are tried in the gyro's axes: the block over every moving field axis (Hvec for
    Hx/Hy/Hz, Hquad for Hsq/Hprod/Hmag2) replaces them when it cuts the held-out RMS by
    >= 8 % at fold consistency >= 2.5 and what it adds beyond them has |z| >= 1, or by
    >= 5 % when fold consistency and |z| are each >= 1 and (t + |z|)/sqrt(2) >= 2.5 (a gyro
    mounted a few degrees off the coils; a sequence that moves coils together in few blocks
    shows the cross-axis parts in few folds); the quadratic block is also chosen before a new
    second-order field term (Hsq, Hprod, Hmag2) when it holds out >= 10 % better than that
    term (the cross-axis parts of a large second-order effect would each qualify and take
    the steps one by one), unless that term with one more second-order field term holds
    out as well as the block; a chosen quadratic block gives way to two second-order field
    terms added beside the model that hold out as well (>= 10 % gain at fold consistency
    >= 2.13), named "together with" each other: two coefficients extrapolate to field
    settings the held-out folds did not see where the block's six do not; with all but one
    field axis in the model, that axis's term (Hx, Hy or Hz) is named instead. When still none qualifies above 1.2x the
    floor, the three candidates with the largest in-sample gains (>= 20 %) are judged in
    place of each model term: a term of your model that stood in for the missing effect
    (collinear with it over the record) is named for replacement ("replaces X") when the
    swap qualifies, fits the record no worse, holds out better than the candidate beside
    the term at fold consistency >= 2.13, and the candidate's p x trials beside the term
    is < 0.01 (< 0.001 for a ramp, warm-up, sinusoid or hysteresis). When still none
    qualifies and the model is >= 2x the floor, three or more effects may hide one
    another (each alone and in pairs holds out worse than all together): the ten
    channel-driven candidates with the largest in-sample gains (no ramp, warm-up,
    sinusoid or hysteresis) are fitted together and eliminated backward (a member goes
    while leaving it out costs < 2 % held-out RMS, or while its HAC |z| in the group's fit
    is < 4); at least three must remain, cut the held-out RMS by >= 50 % at fold
    consistency >= 5, hold out at most half of the best member alone and stand out of the
    residual's spectrum (z >= 8). The member best alone is named first, "together with"
    the others, which the next steps test.
    When no missing effect is found, each term of the model is left out once: one whose
    removal lowers the held-out RMS by >= 5 % (fold consistency >= 1) is named for removal
    ("the model does better without X: remove it"). The noise floor is
    fixed before any model is fitted: from the log's short-tau noise (differences across
    steps of a logged channel left out), or from --reference.
    The verdict names the effect, how to add it (--terms or the equivalent --term), the
    explanations this log cannot tell apart, and the forward path (--path) to the floor.

    \b
    Examples:
      gyrotest model diagnose sample_data/thermal.parquet \\
          --profile sample_data/thermal.profile.toml --terms T,T2
      gyrotest model diagnose sample_data/thermal.parquet \\
          --profile sample_data/thermal.profile.toml --terms T --candidates dTdt,Tlag,dGdt --json
    """
    from ..envmodel.diagnose import diagnose_log
    from ..envmodel.prepare import collect_terms
    from ..envmodel.terms import split_terms

    specs = collect_terms(terms, custom)
    if plot_path:
        from ..plotting import check_plot_path

        check_plot_path(plot_path)
    cand = split_terms(candidates) if candidates else None
    g = load_for_terms(log, ingest_opts, specs, announce=not as_json)
    ref = load_reference(reference, ingest_opts, as_json)
    with progress("trying candidate terms") as advance:
        diag = diagnose_log(g, specs, cand, path=log, axis=axis, skip=skip, t_ref=t_ref,
                            v_ref=v_ref, resolution=resolution, smooth=smooth, alpha=alpha,
                            min_improvement_pct=min_improvement, folds=folds,
                            reference=ref, path_steps=path_steps,
                            progress=lambda i, n, label: advance(
                                1 if i else 0, total=n, description=f"trying {label}"))
    if plot_path:
        from ..envmodel.plots import diagnosis_figures

        write_plot(diagnosis_figures(diag), plot_path)
    if as_json:
        emit_json(diag.to_dict())
        return
    render_diagnosis(diag, top=top)
    for w in diag.base.warnings:
        warn(w)


@command.command("history")
@click.argument("path", type=str, default="model.json")
@click.option("--all", "show_all", is_flag=True, help="Show the steps of every log.")
@plot_option("Residual RMS and AIC per step (.png/.svg/.pdf).")
@json_option
def history_cmd(path, show_all, plot_path, as_json):
    """Show the successive fits of a log: terms added, residual RMS, held-out RMS, AIC.

    PATH is a model file (its MODEL.history.json is read), a history file, or a --session
    directory.

    \b
    Example:
      gyrotest model history model.json --plot history.png
    """
    from ..envmodel.history import load_history, steps_for_log

    if plot_path:
        from ..plotting import check_plot_path

        check_plot_path(plot_path)
    steps = load_history(path)
    logs = len({s.sha256 or s.log for s in steps})
    shown = steps if show_all else steps_for_log(steps)
    if not shown:
        raise InputError(f"{path}: the history is empty")
    if plot_path:
        from ..envmodel.plots import history_figures

        write_plot(history_figures(shown), plot_path)
    if as_json:
        emit_json({"history": str(path), "logs": logs, "steps": [s.to_dict() for s in shown]})
        return
    render_history(shown, logs=1 if show_all else logs)



@command.command("terms")
@json_option
def terms_cmd(as_json):
    """List the library of physical effects (term, effect, regressor, coefficient unit, source).

    Terms take an optional channel: T(T_coil), dGdt(T_a,T_b), Hx(Mag_X), g(acc_z). Groups:
    H = Hx,Hy,Hz; poly2 = T,T2; poly3 = T,T2,T3. Custom terms: --term NAME:EXPRESSION.
    """
    from rich.markup import escape
    from rich.table import Table

    from ..envmodel.terms import effect_table

    rows = effect_table()
    if as_json:
        emit_json(rows)
        return
    t = Table(title="model terms (gyrotest.envmodel.terms)")
    for col in ("term", "effect", "regressor", "coefficient unit", "source"):
        t.add_column(col, overflow="fold")
    for r in rows:
        reg = r["formula"] + (f"  [fitted: {', '.join(r['nonlinear'])}]" if r["nonlinear"]
                              else "")
        t.add_row(*(escape(str(x)) for x in (r["term"], r["effect"], reg, r["unit"],
                                              r["source"])))
    console().print(t)
