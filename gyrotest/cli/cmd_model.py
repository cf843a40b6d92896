"""``gyrotest model``: the model workbench (fit, diagnose, history).

Also hosts the option decorators and renderers shared by ``thermal-fit``, ``mag-fit`` and
``compensate``.
"""

from __future__ import annotations

import math
from pathlib import Path

import click
from rich.markup import escape

from ..core.errors import InputError
from ..core.units import format_duration
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
    plots_written,
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
        click.option("--skip", default="0s", show_default=True,
                     help="Drop the start of the log: a duration, e.g. 10min, 90s (a plain "
                          "number is seconds); the warm-up term then counts time from the true "
                          "power-on."),
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
                          "options): its white, flicker and random-walk noise, fitted by "
                          "maximum likelihood, are fixed for every model of the log. Default: "
                          "the noise model is fitted on the log itself."),
    ]
    for o in reversed(opts):
        f = o(f)
    return f


def domain_fit_options(*, smooth_help: str, plot_help: str, figures: str | None = None):
    """The log-preparation, model-file and plot options of ``thermal-fit`` and ``mag-fit``
    (``--axis --skip --resolution --smooth --folds --reference -o --plot``)."""
    opts = [
        click.option("--axis", default=None, help="Gyro axis (rate column); default the first."),
        click.option("--skip", default="0s", show_default=True,
                     help="Drop the start of the log: a duration, e.g. 10min, 90s (a plain "
                          "number is seconds)."),
        click.option("--resolution", default="auto", show_default=True,
                     help="Working resolution (block length) or 'auto'."),
        click.option("--smooth", default="auto", show_default=True, help=smooth_help),
        click.option("--folds", type=click.IntRange(2, 20), default=5, show_default=True,
                     help="Folds of the blocked cross-validation."),
        click.option("--reference", default=None, metavar="LOG",
                     help="Static reference run of the same gyro: its noise model (N, B, K) is "
                          "fixed for the fit. Default: fitted on the log itself."),
        click.option("-o", "--output", default=None,
                     help="Write the fitted model (.json/.toml) for 'gyrotest compensate'."),
        plot_option(plot_help, figures),
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
    from ..core.output import check_output_path

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
    return (wd.resolution_short if wd is not None else "") or res.resolution_note


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
    t = Table(title="coefficients (± 1σ, generalised least squares under the gyro's noise "
                    "model)")
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
    out.print("  " + escape(noise_line(res.noise.params)))
    if res.floor:
        f = res.floor
        out.print(f"  noise at the working resolution: {fmt_num(f.rms_dph)} deg/h RMS; "
                  f"held-out / noise = {fmt_num(res.rms_holdout / f.rms_dph, 3)}")
    out.print(f"  log-likelihood {res.loglik:.1f}; AIC {res.aic:.1f}, BIC {res.bic:.1f} "
              f"({res.n_params} parameters + the noise model; compare models on the same log "
              f"only); condition number {fmt_num(res.condition_number, 3)}")
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
    from ..api.models import read_reference

    return read_reference(path or None, opts.get("profile"), opts)


def noise_line(p) -> str:
    """The noise model in one line (IEEE 952 terms)."""
    src = ("fixed from the reference run" if p.fixed else
           "maximum likelihood on this log with this model")
    gm = (f", Gauss–Markov σ = {p.gm_sigma:.3g} deg/h with T_c = {p.gm_tau_s:.3g} s"
          if getattr(p, "markov", False) else "")
    return (f"noise model ({src}): N = {p.N:.3g} deg/√h (angle random walk), B = {p.B:.3g} "
            f"deg/h (bias instability), K = {p.K:.3g} deg/h/√h (rate random walk){gm}")


def render_diagnosis(diag, top: int = 12) -> None:
    from rich.markup import escape
    from rich.table import Table

    out = console()
    b = diag.base
    out.print(f"[bold]model diagnose[/bold]: base terms {escape(' + '.join(b.terms))}; held-out "
              f"RMS {fmt_num(b.rms_holdout)} deg/h, log-likelihood {b.loglik:.1f}")
    out.print("  " + escape(noise_line(diag.noise)))
    out.print(f"  working resolution: {_short(b)}")
    t = Table(title="candidate terms, most significant first (likelihood ratio under the "
                    "noise model)")
    for col, just in (("#", "right"), ("term", "left"), ("physical effect", "left"),
                      ("Λ", "right"), ("coef.", "right"), ("local p", "right"),
                      ("family-wise p", "right"), ("ΔBIC", "right"), ("missing?", "left")):
        t.add_column(col, justify=just)
    for i, c in enumerate(diag.candidates[:top], 1):
        eff = c.effect.split(" [")[0]
        if c.replaces:
            eff += f" (in place of {c.replaces})"
        if c.searched:
            eff += f"; {c.searched.split(' over ')[0]} = " + ", ".join(
                f"{v:.4g}" for v in c.theta.values())
        bad = c.error or c.degenerate
        mark = ("[green]yes[/green]" + (" (chosen)" if c is diag.chosen else "")
                if c.significant else ("degenerate" if c.degenerate else "no"))
        t.add_row(str(i), escape(c.term), escape(eff),
                  fmt_num(c.lr, 3) if not bad else "—", str(c.df),
                  f"{c.p:.2g}" if math.isfinite(c.p) else "—",
                  f"{c.p_family:.2g}" if math.isfinite(c.p_family) else "—",
                  f"{c.dbic:+.1f}" if math.isfinite(c.dbic) else "—", mark)
    out.print(t)
    style = "green" if diag.found else "bold"
    out.print(f"[{style}]{escape(diag.verdict)}[/{style}]")
    if len(diag.path) > 1:
        out.print("  forward path (each step judged in the model with the steps before it; "
                  "the options fit the model up to that step):")
        for k, p in enumerate(diag.path, 1):
            out.print(f"    {k}. +{escape(p['term'])}: held-out "
                      f"{fmt_num(p['rms_holdout_before_dph'])} → "
                      f"{fmt_num(p['rms_holdout_after_dph'])} deg/h "
                      f"(family-wise p {p['p_family']:.2g}); {escape(p['add'])}")
    out.print("  rule: " + escape(diag.rule))
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

    plots_written(write_figures(figs, path))


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
@plot_option("Residuals against time, the channels and the residual's Allan deviation "
             "(.png/.svg/.pdf).", figures="time, channels, allan")
@ingest_options
@json_option
@with_ingest
def fit_cmd(log, terms, custom, axis, skip, t_ref, v_ref, resolution, smooth, folds, reference,
            output, session, no_history, k_sigma, plot_path, as_json, ingest_opts):
    """Fit a drift model with the given terms and show where it fails.

    The gyro rate (minus the rate-table rate, if any) is modelled as a bias plus the TERMS, in
    physical units: D_T (deg/h)/degC, D_Tdot (deg/h)/(degC/h), w_x deg/h per 100 uT, ...
    Fitting runs on smoothed block means (the working resolution is chosen from the noise
    level and stated); the held-out RMS comes from blocked cross-validation. Coefficients are generalised least squares under
    the gyro's own noise model (white, flicker and random-walk rate noise fitted by maximum
    likelihood on the log, or fixed from --reference), with its standard errors. Custom terms (--term NAME:EXPR) use temp.NAME,
    field.NAME, extra.NAME, supply, table_rate, t, t_h, + - * / **, abs sqrt exp log log10
    sin cos tan tanh arctan sign square minimum maximum clip, ddt(x) and lag(x, tau_s).

    \b
    Examples:
      gyrotest model fit sample_data/thermal.parquet --profile sample_data/thermal.profile.toml \\
          --terms T,T2,dTdt -o model.json
      gyrotest model fit sample_data/thermal.parquet --profile sample_data/thermal.profile.toml \\
          --terms "T(T_coil_a_C),Tlag(T_chamber_C)" --plot fit.png
      gyrotest model fit sample_data/thermal.parquet --profile sample_data/thermal.profile.toml \\
          --terms "T(T_chamber_C)" --term "grad:temp.T_coil_a_C - temp.T_coil_b_C" --json
    """
    from ..api.models import Model
    from ..envmodel.history import append_history, session_paths

    model = Model(list(terms), custom=list(custom), axis=axis, skip=skip, t_ref=t_ref,
                  v_ref=v_ref, resolution=resolution, smooth=smooth, folds=folds)
    specs = model.specs
    out_path = check_output(output, (".json", ".toml"), "model file")
    if plot_path:
        from ..core.plotting import check_plot_path

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
    model.reference = ref
    res = model.fit(g, k=k_sigma)
    written: dict = {}
    if session:
        from ..envmodel.history import load_history

        sp = Path(session)
        sp.mkdir(exist_ok=True)
        hist_file = sp / "history.json"
        n = len(load_history(hist_file)) + 1 if hist_file.is_file() else 1
        mpath, hpath = session_paths(sp, n, out_path.suffix if out_path else ".json")
        res.model.save(mpath)
        step = append_history(hpath, res.core, model_file=mpath.name)
        written.update(model_file=str(mpath), history_file=str(hpath), step=step.step)
    if out_path:
        res.model.save(out_path)
        written["model_file"] = str(out_path)
        if not no_history and not session:
            from ..envmodel.history import history_path_for

            hp = history_path_for(out_path)
            step = append_history(hp, res.core, model_file=out_path.name)
            written.update(history_file=str(hp), step=step.step)
    if plot_path:
        from ..envmodel.plots import fit_figures

        write_plot(fit_figures(res.core), plot_path)
    if as_json:
        emit_json(res.to_dict(written=written))
        return
    render_fit(res.core)
    if written.get("model_file"):
        extra = (f"; history {written['history_file']} step {written['step']}"
                 if written.get("history_file") else "")
        console().print(f"  model written to {written['model_file']}{extra}")
    if not out_path and not session and not as_json:
        note("add -o model.json to keep the model and its history; run 'gyrotest model "
             "diagnose' to find a missing effect")


def _print_rules(ctx, _param, value):
    """--rules: the verdict's decision rules (:mod:`gyrotest.envmodel.workbench_rules`), then exit."""
    if not value or ctx.resilient_parsing:
        return
    import shutil

    from ..envmodel.workbench_rules import rules_text

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
@click.option("--alpha", type=click.FloatRange(1e-6, 0.5), default=0.01, show_default=True,
              help="Family-wise probability of naming a missing effect that does not exist, "
                   "per step.")
@click.option("--power-on/--no-power-on", "power_on", default=None,
              help="The log starts at the gyro's power-on, so a warm-up transient is a "
                   "candidate (default: the profile's [gyro] power_on_at_start, else no).")
@click.option("--path", "path_steps", type=click.IntRange(1, 10), default=3, show_default=True,
              help="Steps of the forward path: after the missing effect, look for the next "
                   "one in the model that has it (several effects are often missing at once).")
@click.option("--top", type=int, default=12, show_default=True, help="Rows to show.")
@click.option("--rules", is_flag=True, is_eager=True, expose_value=False,
              callback=_print_rules,
              help="Print every decision rule of the verdict with its thresholds and exit.")
@plot_option("Base residual and candidate bar chart (.png/.svg/.pdf).",
             figures="the base model's time, channels and allan, then candidates")
@ingest_options
@json_option
@with_ingest
def diagnose_cmd(log, terms, custom, axis, skip, t_ref, v_ref, resolution, smooth, folds,
                 reference, candidates, alpha, power_on, path_steps, top, plot_path,
                 as_json, ingest_opts):
    """Which physical effect does the model lack? Test every candidate under the gyro's noise.

    The model is fitted under the gyro's own noise model: white, flicker and random-walk rate
    noise (N, B, K) fitted by maximum likelihood on the log (or fixed from --reference).
    Candidates: every library term the log's channels allow and the model lacks, a screen of
    every logged channel (level, square, rate; a lagged node's level, square and rate with a
    fitted time constant; products where physics has them), the field blocks in the gyro's
    own axes, and ramp, sinusoid, hysteresis (a warm-up with --power-on). Each is scored by
    its likelihood ratio; a candidate is a missing effect when its family-wise p-value (a
    parametric bootstrap over every candidate and every searched time constant, frequency
    and width) is at most --alpha. Candidates within ΔBIC 2 are named together with the
    measurement that would separate them. When nothing is missing, the residual is tested
    against the noise model (Ljung-Box) and a model term the data do not support is named
    for removal. Every rule: --rules (and the
    man page, WORKBENCH VERDICT RULES). The verdict names the effect, the complete --terms to
    paste, and the forward path (--path).

    \b
    Examples:
      gyrotest simulate sample_data/scenarios/hidden_coil.toml -o coil.csv --seed 1
      gyrotest model diagnose coil.csv --profile coil.profile.toml --terms "T(T_case_C)"
      gyrotest model diagnose sample_data/thermal.parquet \\
          --profile sample_data/thermal.profile.toml --terms T --candidates dTdt,Tlag,dGdt --json
    """
    from ..api.models import Model
    from ..envmodel.terms import split_terms

    model = Model(list(terms), custom=list(custom), axis=axis, skip=skip, t_ref=t_ref,
                  v_ref=v_ref, resolution=resolution, smooth=smooth, folds=folds)
    specs = model.specs
    if plot_path:
        from ..core.plotting import check_plot_path

        check_plot_path(plot_path)
    cand = split_terms(candidates) if candidates else None
    g = load_for_terms(log, ingest_opts, specs, announce=not as_json)
    ref = load_reference(reference, ingest_opts, as_json)
    with progress("trying candidate terms") as advance:
        model.reference = ref
        model.power_on = power_on
        diag = model.diagnose(g, candidates=cand, alpha=alpha, path=path_steps,
                              progress=lambda i, n, label: advance(
                                  1 if i else 0, total=n, description=f"trying {label}"))
    if plot_path:
        from ..envmodel.plots import diagnosis_figures

        write_plot(diagnosis_figures(diag.core), plot_path)
    if as_json:
        emit_json(diag.to_dict())
        return
    render_diagnosis(diag.core, top=top)
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
      gyrotest model fit sample_data/thermal.parquet --profile sample_data/thermal.profile.toml \\
          --terms T,T2,dTdt -o model.json
      gyrotest model history model.json --plot history.png
    """
    from ..envmodel.history import load_history, steps_for_log

    if plot_path:
        from ..core.plotting import check_plot_path

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
