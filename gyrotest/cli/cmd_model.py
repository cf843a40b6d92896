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
    FiniteRange,
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
        click.option("--t-ref", "t_ref", type=FiniteRange(-273.15, 1000.0), default=None,
                     help="Reference temperature T_ref, degC (default: mean of each sensor)."),
        click.option("--v-ref", "v_ref", type=FiniteRange(-1e4, 1e4), default=None,
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
                        nan_policy=opts.get("nan_policy") or "error", dead="error")
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

    from ..workbench_rules import SUMMARY

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
    out.print("  rule: " + escape(SUMMARY.format(min_pct=diag.min_improvement_pct,
                                                   alpha=diag.alpha)))
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


def _print_rules(ctx, _param, value):
    """--rules: the verdict's decision rules (:mod:`gyrotest.workbench_rules`), then exit."""
    if not value or ctx.resilient_parsing:
        return
    import shutil

    from ..workbench_rules import rules_text

    width = min(100, max(60, shutil.get_terminal_size((88, 24)).columns - 2))
    click.echo(rules_text(width))
    ctx.exit(0)


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
@click.option("--rules", is_flag=True, is_eager=True, expose_value=False,
              callback=_print_rules,
              help="Print every decision rule of the verdict with its thresholds and exit.")
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
    its coefficient in the augmented model.

    A missing effect is named when its held-out gain repeats across the folds and passes the
    HAC test (p x trials x candidates < alpha, gain >= --min-improvement), or, off that test,
    when a clear gain also stands out of the residual's own spectrum and beats a
    look-elsewhere test on surrogates of the residual, so that a smooth channel or a ramp
    fitted to the gyro's own slow wander is not named. Effects that hide each other are
    tried in pairs and groups, a term of your model that stood in for the missing effect is
    named for replacement, and a term the model does better without is named for removal.
    Every rule with its thresholds: --rules (and the man page, WORKBENCH VERDICT RULES).
    The noise floor is fixed before any model is fitted: from the log's short-tau noise
    (differences across steps of a logged channel left out), or from --reference.
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
