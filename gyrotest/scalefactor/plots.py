"""Figures for ``gyrotest scale-factor``: model vs measurement.

:func:`figure_scale_factor` draws (and :func:`plot_scale_factor` saves)

1. the linearity error of every plateau (ppm of full-scale output, IEEE 952 §12.9.4.2.1)
   vs input rate with ±1 SE error bars, one colour per run, the fitted f(I) model projected
   the same way (the part a straight line cannot follow) and each supported term;
2. what is left after the model (ppm FS) — the misfit the selected terms could not remove;
3. the model history: residual RMS after each added term;
4. the raw output vs time of each run with the averaging windows of the detected plateaus.
"""

from __future__ import annotations

import math

import numpy as np

from ..core.plotting import COLORS, new_figure, save_figure
from .tablefit import TERM_LABELS, TERM_SHORT, term_order

DPS = 3600.0


def _envelope(t: np.ndarray, y: np.ndarray, bins: int = 3000):
    """(t, lo, hi) min/max envelope of a long series for plotting (every sample counted)."""
    n = len(y)
    if n <= 2 * bins:
        return t, y, y
    edges = np.linspace(0, n, bins + 1).astype(np.int64)[:-1]
    return t[edges], np.minimum.reduceat(y, edges), np.maximum.reduceat(y, edges)


def _project(model, I_pts: np.ndarray, I_grid: np.ndarray, k: float, fs: float,
             contrib=None) -> np.ndarray:
    """Model nonlinear output minus its own least-squares line over the test inputs, ppm FS."""
    f = contrib if contrib is not None else model.nonlinear_output
    n_pts = f(I_pts)
    X = np.column_stack([np.ones_like(I_pts), I_pts])
    beta, *_ = np.linalg.lstsq(X, n_pts, rcond=None)
    return (f(I_grid) - beta[0] - beta[1] * I_grid) / (k * fs) * 1e6


def _grid(I: np.ndarray, lin: float) -> np.ndarray:
    lo, hi = float(np.min(I)), float(np.max(I))
    parts = [np.linspace(-lin, lin, 41)]
    if hi > lin:
        parts.append(np.geomspace(lin, hi, 200))
    if lo < -lin:
        parts.append(-np.geomspace(lin, -lo, 200))
    g = np.unique(np.concatenate(parts))
    return g[(g >= min(lo, 0)) & (g <= max(hi, 0))]


def _formula(t: str) -> str:
    """The term's f(I) formula as the tables print it (``c2·u²``), without the lock-in's
    explanation."""
    from .tablefit import TERMS

    return TERMS[t].formula.split(" (")[0] if t in TERMS else t


def _history(fig, ax2, history) -> None:
    """Split the residual panel: a bar chart of the model history on its right."""
    spec = ax2.get_subplotspec().subgridspec(1, 2, width_ratios=[3.2, 1.0], wspace=0.05)
    ax2.set_subplotspec(spec[0])
    axh = fig.add_subplot(spec[1])
    labels, vals, cols = [], [], []
    for h in history:
        labels.append(("+ " + TERM_SHORT.get(h.added, h.added)) if h.terms else "line")
        vals.append(max(h.rms_ppm_fs, 1e-6))
        cols.append(COLORS[0] if h.accepted else "0.7")
    y = np.arange(len(vals))[::-1]
    axh.barh(y, vals, color=cols, height=0.7)
    axh.set_yticks(y, labels, fontsize=8)
    axh.set_xscale("log")
    axh.set_xlabel("residual RMS, ppm FS", fontsize=8.5)
    axh.set_title("add a term: blue kept, grey not", fontsize=8.5)
    axh.tick_params(axis="x", labelsize=8)
    axh.grid(axis="y", visible=False)


def plot_scale_factor(res, path, *, logs=None, size: tuple[float, float] | None = None):
    """Write :func:`figure_scale_factor` to ``path`` (.png/.svg/.pdf); returns the path."""
    return save_figure(figure_scale_factor(res, logs=logs, size=size), path)


def figure_scale_factor(res, *, logs=None, size: tuple[float, float] | None = None):
    """The scale-factor figure (see module doc) of a
    :class:`~gyrotest.scalefactor.ScaleFactorResult`; ``logs`` adds the output-vs-time panels
    of up to four runs. ``size`` in inches (default 10 wide, 6.2 + 1.9 per run panel high).
    Returns the matplotlib figure."""
    runs = res.runs
    show_logs = [lg for lg in (logs or [])][:4]
    n_raw = len(show_logs)
    ratios = [3.0, 1.5] + [1.25] * n_raw
    fig, axes = new_figure(2 + n_raw, 1, size=size or (10.0, 6.2 + 1.9 * n_raw),
                           height_ratios=ratios)
    axes = np.atleast_1d(axes)
    ax, ax2 = axes[0], axes[1]
    fs = res.full_scale_dph
    pts = res.points
    pt = res.point_table
    table = np.array([p.table_rate_dph for p in pts]) / DPS
    I = np.array([p.input_rate_dph for p in pts])
    runidx = {r.run: i for i, r in enumerate(runs)}
    ridx = np.array([runidx[p.run] for p in pts])
    nz = np.abs(table[table != 0])
    lin = float(nz.min()) if len(nz) else 1.0
    use_sym = len(nz) > 0 and nz.max() / lin > 20
    # 1. linearity error with error bars
    for r, run in enumerate(runs):
        m = (ridx == r) & np.isfinite(pt["linearity_ppm_fs"]) & ~np.array([p.locked for p in pts])
        if not m.any():
            continue
        c = COLORS[r % len(COLORS)]
        ax.errorbar(table[m], pt["linearity_ppm_fs"][m], yerr=pt["stderr_ppm_fs"][m], fmt="o",
                    ms=4, color=c, ecolor=c, elinewidth=1, capsize=2.5, alpha=0.9,
                    label=f"{run.run} (± 1 SE)")
        ax2.errorbar(table[m], pt["model_residual_ppm_fs"][m], yerr=pt["stderr_ppm_fs"][m],
                     fmt="o", ms=3.5, color=c, ecolor=c, elinewidth=1, capsize=2, alpha=0.9)
    locked = np.array([p.locked for p in pts])
    if locked.any():
        ax.plot(table[locked], pt["linearity_ppm_fs"][locked], "x", color="k", ms=7,
                label="lock-in (excluded from the fits)")
    model = res.model.fit
    Ifit = I[np.isfinite(pt["model_residual_ppm_fs"])]
    if model is not None and model.terms and len(Ifit):
        g = _grid(Ifit / DPS, lin) * DPS
        k = float(np.median([r.slope for r in runs]))
        shown = sorted(model.terms, key=term_order)
        ax.plot(g / DPS, _project(model, Ifit, g, k, fs), color="k", lw=1.8,
                label="model f(I) = " + " + ".join(_formula(t) for t in shown) + ", u = I/FS")
        if len(model.terms) > 1:
            for j, t in enumerate(shown):
                def one(x, t=t):
                    from .tablefit import TERMS

                    u = x / model.fs_dph
                    c_, _ = model.term_coef(t)
                    if t == "periodic":
                        ph = 2 * math.pi * x / DPS / model.period_dps
                        fpp = c_[0] * np.sin(ph) + c_[1] * np.cos(ph)
                    else:
                        fpp = c_[0] * TERMS[t].g(u)
                    return -model.kref * x * 1e-6 * fpp
                ax.plot(g / DPS, _project(model, Ifit, g, k, fs, one), lw=1.0, ls="--",
                        color=COLORS[(j + 4) % len(COLORS)],
                        label=f"  {TERM_LABELS.get(t, t)} term: {_formula(t)}")
    ax.axhline(0, color="0.5", lw=0.8)
    ax2.axhline(0, color="0.5", lw=0.8)
    li = res.linearity
    ax.set_title(f"Linearity error vs input rate (IEEE 952 §12.9.4.2.1): max {li.max_ppm_fs:.3g} "
                 f"ppm FS, 1σ {li.sigma_ppm_fs:.3g} ppm FS; FS = ±{fs / DPS:g} deg/s")
    ax.set_ylabel("deviation from the\nstraight line, ppm FS")
    # the legend below the panel: inside it covered the curves
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=2, fontsize=8,
              frameon=False)
    terms_txt = (", ".join(TERM_SHORT.get(t, t) for t in sorted(res.model.terms, key=term_order))
                 or "straight line only")
    ax2.set_title(f"After the model ({terms_txt}): residual RMS "
                  f"{res.model.residual_rms_ppm_fs:.3g} ppm FS, χ²/dof {res.model.chi2_per_dof:.3g}",
                  fontsize=9.5)
    _history(fig, ax2, res.model.history)
    ax2.set_ylabel("model residual,\nppm FS")
    ax2.set_xlabel("input rate (table), deg/s")
    ax.set_xlabel("input rate (table), deg/s")
    if use_sym:
        from matplotlib.ticker import FuncFormatter

        for a_ in (ax, ax2):
            a_.set_xscale("symlog", linthresh=lin, linscale=0.6)
            a_.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    # 4. raw output vs time
    byrun = {rp.run: rp for rp in res.run_plateaus}
    for i, lg in enumerate(show_logs):
        a_ = axes[2 + i]
        name = runs[i].run if i < len(runs) else lg.source
        t = lg.t
        tb, lo, hi = _envelope(t, lg.rate / DPS)
        unit_t, tdiv = ("min", 60.0) if t[-1] > 600 else ("s", 1.0)
        if lo is hi:
            a_.plot(tb / tdiv, lo, lw=0.6, color=COLORS[0])
        else:
            a_.fill_between(tb / tdiv, lo, hi, color=COLORS[0], lw=0.4, alpha=0.7)
        rp = byrun.get(name)
        if rp is not None:
            for p in rp.plateaus:
                a_.axvspan(p.t_start_s / tdiv, p.t_end_s / tdiv,
                           color=COLORS[2] if not p.locked else "0.3", alpha=0.18, lw=0)
        if rp is not None:
            a_.set_title(f"{name}: output vs time, {len(rp.plateaus)} plateaus ({rp.method}); "
                         "shaded: averaging windows after settling", fontsize=9.5)
        a_.set_ylabel("output (S0 × raw),\ndeg/s")
        a_.set_xlabel(f"time, {unit_t}")
    return fig
