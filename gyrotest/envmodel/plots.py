"""Figures of the model workbench (matplotlib, shared gyrotest style).

Every function takes result dataclasses and a path; ``.png``/``.svg`` write one file per figure
(the first at the given path, the others beside it as ``<stem>-<name><suffix>``), ``.pdf`` writes
all figures as pages of one document. Files are written atomically.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..output import atomic_path
from ..plotting import COLORS, STYLE, check_plot_path, new_figure, save_figure


def _time_axis(t_s: np.ndarray) -> tuple[np.ndarray, str]:
    span = float(t_s[-1] - t_s[0]) if len(t_s) else 0.0
    if span > 3 * 3600:
        return t_s / 3600.0, "time since start, h"
    if span > 300:
        return t_s / 60.0, "time since start, min"
    return t_s, "time since start, s"


def write_figures(figs: list[tuple[str, object]], path: str | Path) -> list[Path]:
    """Save [(name, fig), ...]: one PDF with a page per figure, or one file per figure."""
    import matplotlib.pyplot as plt
    from matplotlib.backends.backend_pdf import PdfPages

    p = check_plot_path(path)
    if p.suffix.lower() == ".pdf":
        try:
            with plt.rc_context(STYLE), atomic_path(p) as tmp:
                with PdfPages(tmp) as pdf:
                    for _, fig in figs:
                        pdf.savefig(fig)
        finally:
            for _, fig in figs:
                plt.close(fig)
        return [p]
    out = []
    for i, (name, fig) in enumerate(figs):
        q = p if i == 0 else p.with_name(f"{p.stem}-{name}{p.suffix}")
        out.append(save_figure(fig, q))
    return out


def _excursion_spans(ax, excursions, tscale: float) -> None:
    for i, e in enumerate(excursions, 1):
        ax.axvspan(e.t_start_s / tscale, e.t_end_s / tscale, color="#E69F00", alpha=0.25, lw=0)
        ax.annotate(str(i), ((e.t_start_s + e.t_end_s) / 2 / tscale, 1.0),
                    xycoords=("data", "axes fraction"), ha="center", va="bottom", fontsize=8,
                    color="#8a5a00")


def fit_figures(res, *, title: str | None = None) -> list[tuple[str, object]]:
    """Figures of a model fit: time series and residual with excursions; residual against each
    channel (heating/cooling coloured); residual Allan deviation with the noise floor."""
    figs = []
    t = res.t
    tx, tlabel = _time_axis(t)
    tscale = float(t[-1] / tx[-1]) if len(t) and tx[-1] else 1.0
    wd = res.wd
    # ---------- 1: time series
    chans = list(wd.frame.temperature.items())[:2]
    nrow = 3 if chans or wd.frame.field_uT or wd.frame.supply is not None else 2
    fig, axes = new_figure(nrow, 1, size=(10, 3.0 * nrow), sharex=True,
                           height_ratios=[1.2, 1.0] + ([0.8] if nrow == 3 else []))
    ax = axes[0]
    ax.plot(tx, res.y, color="#999999", lw=0.9, label="measured (smoothed block means)")
    ax.plot(tx, res.yhat, color=COLORS[0], lw=1.3, label="model")
    ax.set_ylabel("rate − input, deg/h")
    terms = " + ".join(res.terms)
    ax.set_title(title or f"model fit: {terms}", loc="left")
    ax.legend(loc="best")
    ax = axes[1]
    r = res.resid
    ax.plot(tx, r, color=COLORS[1], lw=0.9, label="residual")
    if res.holdout_resid is not None and np.isfinite(res.holdout_resid).any():
        ax.plot(tx, res.holdout_resid, color=COLORS[5], lw=0.6, alpha=0.8,
                label="held-out residual")
    ax.axhline(0, color="k", lw=0.6)
    _excursion_spans(ax, res.excursions, tscale)
    ax.set_ylabel("residual, deg/h")
    ax.legend(loc="upper right", ncol=2)
    txt = (f"RMS fit {res.rms_fit:.3g}, held-out {res.rms_holdout:.3g} deg/h"
           + (f"; noise floor {res.floor.rms_dph:.3g}" if res.floor else ""))
    ax.text(0.01, 0.02, txt, transform=ax.transAxes, fontsize=8.5, va="bottom",
            bbox={"facecolor": "white", "alpha": 0.8, "lw": 0})
    if nrow == 3:
        ax = axes[2]
        for i, (name, v) in enumerate(chans):
            ax.plot(wd.frame.t / tscale, v, color=COLORS[2 + i], lw=1.0, label=f"{name}, °C")
        ax.set_ylabel("temperature, °C" if chans else "")
        ax2 = None
        if wd.frame.field_uT:
            ax2 = ax.twinx()
            for i, (name, v) in enumerate(wd.frame.field_uT.items()):
                ax2.plot(wd.frame.t / tscale, v, lw=0.7, ls="--", color=COLORS[4 + i % 3],
                         label=f"{name}, µT")
            ax2.set_ylabel("field, µT")
            ax2.spines["right"].set_visible(True)
        elif wd.frame.supply is not None:
            ax2 = ax.twinx()
            ax2.plot(wd.frame.t / tscale, wd.frame.supply, lw=0.8, ls="--", color=COLORS[4],
                     label="supply, V")
            ax2.set_ylabel("supply, V")
            ax2.spines["right"].set_visible(True)
        h1, l1 = ax.get_legend_handles_labels()
        h2, l2 = ax2.get_legend_handles_labels() if ax2 else ([], [])
        if h1 or h2:
            ax.legend(h1 + h2, l1 + l2, loc="upper right", ncol=3, fontsize=7.5)
    axes[-1].set_xlabel(tlabel)
    if res.excursions:
        lines = [f"{i}: {e.t_start_s / tscale:.3g}–{e.t_end_s / tscale:.3g} "
                 f"{tlabel.split(', ')[-1]}, peak {e.peak_dph:+.3g} deg/h — {e.description}"
                 for i, e in enumerate(res.excursions[:6], 1)]
        if len(res.excursions) > 6:
            lines.append(f"... {len(res.excursions) - 6} more")
        fig.text(0.01, -0.01, "excursions (|smoothed residual| > k·σ):\n" + "\n".join(lines),
                 fontsize=7.5, va="top", ha="left", family="monospace")
    figs.append(("time", fig))
    # ---------- 2: residual vs channels
    ch = []
    frame = wd.frame
    for name, v in frame.temperature.items():
        ch.append((f"{name}, °C", v))
    for name, v in frame.field_uT.items():
        ch.append((f"{name}, µT", v))
    if frame.supply is not None:
        ch.append(("supply, V", frame.supply))
    for name, v in list(frame.extra.items())[:3]:
        ch.append((name, v))
    ch = ch[:8]
    if ch:
        from .terms import temperature_rate

        ncol = min(3, len(ch))
        nr = int(math.ceil(len(ch) / ncol))
        fig, axes = new_figure(nr, ncol, size=(4.0 * ncol, 3.2 * nr))
        axes = np.atleast_1d(axes).ravel()
        heat = None
        if frame.temperature:
            T0 = next(iter(frame.temperature.values()))
            rate = wd.bmean(temperature_rate(T0, frame.dt, wd.refs.smoothing_s, frame.bounds))
            thr = max(0.5, next(iter(wd.refs.hyst_threshold_c_per_h.values()), 0.5))
            heat = np.where(rate > thr, 1, np.where(rate < -thr, -1, 0))
        for ax, (label, v) in zip(axes, ch):
            xb = wd.bmean(v)
            if heat is not None:
                for code, col, lab in ((0, "#999999", "steady"), (1, COLORS[1], "heating"),
                                       (-1, COLORS[0], "cooling")):
                    m = heat == code
                    if m.any():
                        ax.scatter(xb[m], r[m], s=4, color=col, alpha=0.6, label=lab, lw=0)
            else:
                ax.scatter(xb, r, s=4, color=COLORS[0], alpha=0.6, lw=0)
            ax.axhline(0, color="k", lw=0.6)
            ax.set_xlabel(label)
            ax.set_ylabel("residual, deg/h")
        if heat is not None:
            axes[0].legend(loc="best", markerscale=3)
        for ax in axes[len(ch):]:
            ax.set_visible(False)
        fig.suptitle("residual against each channel (a pattern here is a missing term)",
                     fontsize=10)
        figs.append(("channels", fig))
    # ---------- 3: residual Allan deviation
    if res.adev_tau is not None and len(res.adev_tau):
        fig, ax = new_figure(size=(7, 4.6))
        ax.loglog(res.adev_tau, res.adev_sigma, "o-", ms=3.5, color=COLORS[0],
                  label="residual (fine grid)")
        if res.floor and math.isfinite(res.floor.white_N):
            tt = np.asarray(res.adev_tau, float)
            pred = np.sqrt(res.floor.white_N ** 2 / tt + res.floor.flicker_B ** 2)
            ax.loglog(tt, pred, "--", color=COLORS[1],
                      label=f"white + flicker noise: N = {res.floor.arw_deg_rt_h:.3g} deg/√h, "
                            f"B = {res.floor.flicker_B:.3g} deg/h")
        ax.set_xlabel("averaging time τ, s")
        ax.set_ylabel("Allan deviation σ(τ), deg/h")
        ax.set_title("residual Allan deviation: rising above the noise line = unmodelled drift",
                     loc="left", fontsize=9.5)
        ax.legend(loc="best")
        figs.append(("allan", fig))
    return figs


def diagnosis_figures(diag) -> list[tuple[str, object]]:
    """Ranked candidate improvements (bars) and the base residual with excursions."""
    base = diag.base
    figs = fit_figures(base, title=f"base model: {' + '.join(base.terms)}")[:1]
    cands = [c for c in diag.candidates if math.isfinite(c.improvement_pct)][:15]
    if cands:
        fig, ax = new_figure(size=(9, 0.38 * len(cands) + 1.6))
        names = [c.term for c in cands][::-1]
        vals = [c.improvement_pct for c in cands][::-1]
        cols = [COLORS[2] if c.significant else "#bbbbbb" for c in cands][::-1]
        ax.barh(names, vals, color=cols)
        ax.axvline(0, color="k", lw=0.6)
        ax.set_xlabel("held-out residual RMS improvement, %")
        ax.set_title("candidate terms (green: significant missing effect)", loc="left")
        for y, (v, c) in enumerate(zip(vals, cands[::-1])):
            ax.text(max(v, 0) + 0.5, y, f"z = {c.z:.1f}" if math.isfinite(c.z) else "",
                    va="center", fontsize=7.5)
        figs.append(("candidates", fig))
    return figs


def history_figures(steps) -> list[tuple[str, object]]:
    """Residual RMS (fit, held-out, noise floor) and AIC per history step."""
    fig, axes = new_figure(2, 1, size=(8, 6), sharex=True, height_ratios=[1.4, 1])
    x = np.arange(1, len(steps) + 1)
    ax = axes[0]
    ax.plot(x, [s.rms_fit_dph for s in steps], "o-", color=COLORS[0], label="fit")
    ax.plot(x, [s.rms_holdout_dph for s in steps], "s-", color=COLORS[1], label="held-out")
    fl = [s.noise_floor_dph if s.noise_floor_dph is not None else np.nan for s in steps]
    if np.isfinite(fl).any():
        ax.plot(x, fl, ":", color="k", label="noise floor")
    ax.set_yscale("log")
    ax.set_ylabel("residual RMS, deg/h")
    ax.legend(loc="best")
    ax.set_title("model history: watch the error fall", loc="left")
    for xi, s in zip(x, steps):
        lab = " ".join([f"+{a}" for a in s.added] + [f"−{a}" for a in s.removed]) or "(same)"
        ax.annotate(lab, (xi, s.rms_holdout_dph), textcoords="offset points", xytext=(4, 6),
                    fontsize=7.5, rotation=20)
    ax = axes[1]
    ax.plot(x, [s.aic for s in steps], "o-", color=COLORS[2], label="AIC")
    ax.plot(x, [s.bic for s in steps], "s--", color=COLORS[3], label="BIC")
    ax.set_ylabel("information criterion")
    ax.set_xlabel("step")
    ax.set_xticks(x)
    ax.legend(loc="best")
    return [("history", fig)]
