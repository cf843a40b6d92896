"""Figures of the model workbench (matplotlib, shared gyrotest style).

Every function takes result dataclasses and a path; ``.png``/``.svg`` write one file per figure
(the first at the given path, the others beside it as ``<stem>-<name><suffix>``), ``.pdf`` writes
all figures as pages of one document. Files are written atomically.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..core.output import atomic_path
from ..core.plotting import COLORS, STYLE, check_plot_path, new_figure, save_figure


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


def _block_means(t: np.ndarray, x: np.ndarray, target: int) -> tuple[np.ndarray, np.ndarray]:
    """Means of consecutive blocks of ``x`` (and ``t``), about ``target`` points."""
    k = max(1, len(x) // target)
    m = (len(x) // k) * k
    if m == 0:
        return t, x
    return t[:m].reshape(-1, k).mean(axis=1), np.nanmean(x[:m].reshape(-1, k), axis=1)


def _excursion_spans(ax, excursions, tscale: float) -> None:
    for i, e in enumerate(excursions, 1):
        # light and behind the traces: a long excursion must not hide the residual
        ax.axvspan(e.t_start_s / tscale, e.t_end_s / tscale, color="#E69F00", alpha=0.12, lw=0,
                   zorder=0)
        ax.annotate(str(i), ((e.t_start_s + e.t_end_s) / 2 / tscale, 0.98),
                    xycoords=("data", "axes fraction"), ha="center", va="top", fontsize=8,
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
    # legend and RMS line above the panel (inside they covered the trace)
    ax.legend(loc="lower right", bbox_to_anchor=(1.0, 1.0), ncol=2, fontsize=8, frameon=False,
              borderaxespad=0.1)
    txt = (f"RMS fit {res.rms_fit:.3g}, held-out {res.rms_holdout:.3g} deg/h"
           + (f"; noise floor {res.floor.rms_dph:.3g}" if res.floor else "")
           + ("; shaded: excursions" if res.excursions else ""))
    ax.set_title(txt, loc="left", fontsize=8.5)
    if nrow == 3:
        ax = axes[2]
        for i, (name, v) in enumerate(chans):
            # block means: the raw sensor noise drew a solid band that hid the other traces
            tb, vb = _block_means(wd.frame.t / tscale, np.asarray(v, float), 600)
            ax.plot(tb, vb, color=COLORS[2 + i], lw=1.0, label=f"{name}, °C (block means)")
        ax.set_ylabel("temperature, °C" if chans else "")
        if chans:  # at least 1 °C shown: sensor noise on a steady temperature stays flat
            lo, hi = ax.get_ylim()
            mid, half = (lo + hi) / 2, max((hi - lo) / 2, 0.5)
            ax.set_ylim(mid - half, mid + half)
            ax.ticklabel_format(axis="y", useOffset=False)
        ax2 = None
        if wd.frame.field_uT:
            ax2 = ax.twinx()
            for i, (name, v) in enumerate(wd.frame.field_uT.items()):
                ax2.plot(wd.frame.t / tscale, v, lw=1.1, ls="--", color=COLORS[4 + i % 3],
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
            ax.legend(h1 + h2, l1 + l2, loc="lower right", bbox_to_anchor=(1.0, 1.0), ncol=4,
                      fontsize=7.5, frameon=False, borderaxespad=0.1)
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
        from matplotlib.ticker import MaxNLocator

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
            # few ticks, no offset: a narrow range (22 ± 0.008 °C) made overlapping labels
            ax.xaxis.set_major_locator(MaxNLocator(5))
            ax.ticklabel_format(axis="x", useOffset=False)
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
            f = res.floor
            pred = np.sqrt(f.white_N ** 2 / tt + f.flicker_B ** 2
                           + f.random_walk_K ** 2 * tt / 3.0)
            p = res.noise.params
            ax.loglog(tt, pred, "--", color=COLORS[1],
                      label=f"noise model: N = {p.N:.3g} deg/√h, B = {p.B:.3g} deg/h, "
                            f"K = {p.K:.3g} deg/h/√h")
        ax.set_xlabel("averaging time τ, s")
        ax.set_ylabel("Allan deviation σ(τ), deg/h")
        ax.set_title("residual Allan deviation: above the noise model's line = unmodelled drift",
                     loc="left", fontsize=9.5)
        ax.legend(loc="best")
        figs.append(("allan", fig))
    return figs


def diagnosis_figures(diag) -> list[tuple[str, object]]:
    """The base residual with excursions, and the candidates' likelihood ratios (bars)
    against the one a candidate needs to pass at the family-wise α."""
    base = diag.base
    figs = fit_figures(base, title=f"base model: {' + '.join(base.terms)}")[:1]
    cands = [c for c in diag.candidates if math.isfinite(c.lr) and math.isfinite(c.p_family)][:15]
    if cands:
        fig, ax = new_figure(size=(9, 0.38 * len(cands) + 1.6))
        names = [c.term for c in cands][::-1]
        vals = [max(c.lr, 1e-3) for c in cands][::-1]
        cols = [COLORS[2] if c.significant else "#bbbbbb" for c in cands][::-1]
        ax.barh(names, vals, color=cols)
        ax.set_xscale("log")
        ax.set_xlabel("likelihood ratio Λ = 2Δℓ (log scale)")
        ax.set_title(f"candidate terms (green: missing effect at family-wise α = "
                     f"{diag.alpha:g})", loc="left")
        for y, (v, c) in enumerate(zip(vals, cands[::-1])):
            ax.text(v * 1.08, y, f"p_fw = {c.p_family:.2g}", va="center", fontsize=7.5)
        figs.append(("candidates", fig))
    return figs


def history_figures(steps, *, size: tuple[float, float] = (8, 6)) -> list[tuple[str, object]]:
    """Residual RMS (fit, held-out, noise floor) and AIC per history step (``size`` inches);
    each step is labelled under the x axis with its number and the terms it added/removed."""
    fig, axes = new_figure(2, 1, size=size, sharex=True, height_ratios=[1.4, 1])
    x = np.arange(1, len(steps) + 1)
    ax = axes[0]
    ax.plot(x, [s.rms_fit_dph for s in steps], "o-", color=COLORS[0], label="fit")
    ax.plot(x, [s.rms_holdout_dph for s in steps], "s-", color=COLORS[1], label="held-out")
    fl = [s.noise_floor_dph if s.noise_floor_dph is not None else np.nan for s in steps]
    if np.isfinite(fl).any():
        # the noise model is fitted with each step's model: its level falls as the effects
        # it had absorbed are modelled; each step's value is drawn
        ax.plot(x, fl, ":", marker=".", color="k",
                label="the noise model's RMS at the working resolution")
    ax.set_yscale("log")
    hi = max(max(s.rms_fit_dph, s.rms_holdout_dph) for s in steps)
    lo = min(min([s.rms_fit_dph, s.rms_holdout_dph] + [f for f in fl if np.isfinite(f)])
             for s in steps)
    ax.set_ylim(lo / 1.3, hi * 2.0)
    ax.set_ylabel("residual RMS, deg/h")
    ax.legend(loc="best")
    ax.set_title("model history: watch the error fall", loc="left")
    ax = axes[1]
    ax.plot(x, [s.aic for s in steps], "o-", color=COLORS[2], label="AIC")
    ax.plot(x, [s.bic for s in steps], "s--", color=COLORS[3], label="BIC")
    ax.set_ylabel("information criterion")
    ax.set_xlabel("step: terms added (+) or removed (−)")
    # the step labels go under the axis, where the layout makes room for them (annotations
    # beside the points ran into the title and out of the axes)
    labels = [f"{s.step}\n" + ("\n".join([f"+{a}" for a in s.added]
                                          + [f"−{a}" for a in s.removed]) or "(same)")
              for s in steps]
    many = len(steps) > 5
    ax.set_xticks(x, labels, fontsize=7.5, rotation=30 if many else 0,
                  ha="right" if many else "center", rotation_mode="anchor")
    ax.legend(loc="best")
    return [("history", fig)]


def thermal_figures(th) -> list[tuple[str, object]]:
    """Rate against temperature, heating and cooling coloured, with the Antonova–Matveev
    static curve; then the fit's time/residual figures."""
    from .terms import temperature_rate

    res = th.am
    wd = res.wd
    T = wd.bmean(wd.frame.temperature[th.sensor])
    rate = wd.bmean(temperature_rate(wd.frame.temperature[th.sensor], wd.frame.dt,
                                     wd.refs.smoothing_s, wd.frame.bounds))
    thr = th.hysteresis.get("threshold_degC_per_h", 0.5)
    fig, axes = new_figure(1, 2, size=(12, 4.8))
    ax = axes[0]
    for code, col, lab in ((0, "#999999", "steady"), (1, COLORS[1], "heating"),
                           (-1, COLORS[0], "cooling")):
        m = np.where(rate > thr, 1, np.where(rate < -thr, -1, 0)) == code
        if m.any():
            ax.scatter(T[m], res.y[m], s=5, color=col, alpha=0.6, lw=0, label=lab)
    c = {x.name: x.value for x in th.coefficients}
    tt = np.linspace(T.min(), T.max(), 200)
    dT = tt - th.t0_c
    ax.plot(tt, c["w0"] + c["w1"] * dT + c["w2"] * dT ** 2, color="k", lw=1.5,
            label="w0 + w1·ΔT + w2·ΔT² (dT/dt = 0)")
    ax.set_xlabel(f"{th.sensor}, °C")
    ax.set_ylabel("rate − input, deg/h")
    ax.set_title("drift vs temperature: loops = rate/lag effects", loc="left")
    # below the axes: inside, it covered a branch of the loop
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.15), ncol=2, markerscale=3,
              fontsize=8, frameon=False)
    ax = axes[1]
    part = res.y - (c["w0"] + c["w1"] * (T - th.t0_c) + c["w2"] * (T - th.t0_c) ** 2)
    ax.scatter(rate, part, s=5, color=COLORS[2], alpha=0.6, lw=0, label="data − static part")
    rr = np.linspace(rate.min(), rate.max(), 50)
    ax.plot(rr, c["w_dV"] * rr, color="k", lw=1.5, label=f"w_ΔV = {c['w_dV']:.4g} deg/°C")
    ax.set_xlabel("temperature rate dT/dt, °C/h")
    ax.set_ylabel("deg/h")
    ax.set_title("temperature-rate term", loc="left")
    ax.legend(loc="best", markerscale=3)
    return [("thermal", fig)] + fit_figures(res, title="Antonova–Matveev model fit")


def setpoint_figures(sp) -> list[tuple[str, object]]:
    """Set-point table with the fitted quadratic and the paper's published curve."""
    from .domain import ANTONOVA_MATVEEV_PAPER as P

    fig, ax = new_figure(size=(7.5, 4.8))
    T = np.array([p["temperature_degC"] for p in sp.points])
    y = np.array([p["dw_dph"] for p in sp.points])
    err = np.array([p.get("sigma_dph", 0.0) for p in sp.points])
    ax.errorbar(T, y, yerr=err if err.any() else None, fmt="o", color=COLORS[0], capsize=3,
                label="set-points (±σ of the output)")
    c = {x.name: x.value for x in sp.coefficients}
    tt = np.linspace(min(T.min(), sp.t0_c), T.max(), 200)
    d = tt - sp.t0_c
    ax.plot(tt, c["w0"] + c["w1"] * d + c["w2"] * d ** 2, color=COLORS[1],
            label=f"fit: w0 {c['w0']:.3g}, w1 {c['w1']:.3g}, w2 {c['w2']:.3g}")
    ax.plot(tt, P["w0"] + P["w1"] * d + P["w2"] * d ** 2, "--", color="#777777",
            label="Antonova & Matveev published coefficients")
    ax.set_xlabel("thermostat temperature, °C")
    ax.set_ylabel("Δω (from the unheated value), deg/h")
    ax.set_title(f"steady-state set-points, ΔT from t0 = {sp.t0_c:g} °C", loc="left")
    ax.legend(loc="best")
    return [("setpoints", fig)]


def mag_figures(mg, k: float = 1.0) -> list[tuple[str, object]]:
    """Plateau means against the applied level per axis (up/down sweeps marked) with the
    fitted slope; then the fit's time/residual figures. ``k``: the slopes' ± in the legend
    is k·1σ (a sheet's expanded uncertainty U); the legend's title says which."""
    from ..noise.plots import legend_pm_title

    figs = []
    axes_present = [a for a in "xyz" if any(p.axis == a for p in mg.plateaus)]
    if axes_present:
        fig, axs = new_figure(1, len(axes_present), size=(4.2 * len(axes_present), 4.2))
        axs = np.atleast_1d(axs)
        coef = {c.name: c for c in mg.coefficients}
        for ax, a in zip(axs, axes_present):
            pa = [p for p in mg.plateaus if p.axis == a]
            base = np.mean([p.rate_dph for p in pa if p.level_uT == 0.0] or
                           [np.mean([p.rate_dph for p in pa])])
            for d, mk, col in (("up", "^", COLORS[1]), ("down", "v", COLORS[0]),
                               ("start", "o", "#777777")):
                q = [p for p in pa if p.direction == d]
                if q:
                    ax.plot([p.level_uT for p in q], [p.rate_dph - base for p in q], mk,
                            color=col, ms=5, ls="none", label=f"{d} sweep" if d != "start"
                            else "start")
            if f"w{a}" in coef:
                c = coef[f"w{a}"]
                hh = np.linspace(min(p.level_uT for p in pa), max(p.level_uT for p in pa), 10)
                ax.plot(hh, c.value * hh / 100.0, color="k", lw=1.2,
                        label=f"w{a} = {c.value:.4g} ± {k * c.stderr:.2g}")
            ax.set_xlabel(f"applied field along {a.upper()}, µT")
            ax.set_ylabel("plateau mean − zero level, deg/h")
            ax.legend(loc="best", fontsize=7.5, title=legend_pm_title(k), title_fontsize=7.5)
        fig.suptitle("Helmholtz sequence: drift per level (deg/h per 100 µT slopes)",
                     fontsize=10)
        figs.append(("levels", fig))
    return figs + fit_figures(mg.fit, title="magnetic model fit")


def compensation_figures(cp) -> list[tuple[str, object]]:
    """Before/after drift (working-resolution block means) and Allan deviation."""
    fig, axes = new_figure(2, 1, size=(9, 7.5), height_ratios=[1, 1.1])
    t = cp.t_blocks
    tx, tl = _time_axis(t)
    ax = axes[0]
    ax.plot(tx, cp.y_before - np.mean(cp.y_before), color="#999999", lw=0.9,
            label=f"before: RMS {cp.rms_before_dph:.3g} deg/h")
    ax.plot(tx, cp.y_after - np.mean(cp.y_after), color=COLORS[0], lw=1.0,
            label=f"after: RMS {cp.rms_after_dph:.3g} deg/h (predicted "
                  f"{cp.predicted_rms_after_dph:.3g})")
    ax.set_xlabel(tl)
    ax.set_ylabel("drift (mean removed), deg/h")
    ax.set_title(f"compensation: drift reduced ×{cp.factor:.3g} (model predicts "
                 f"×{cp.predicted_factor:.3g})", loc="left")
    ax.legend(loc="best")
    ax = axes[1]
    ax.loglog(cp.adev_tau, cp.adev_before, "o-", ms=3, color="#999999", label="before")
    ax.loglog(cp.adev_tau, cp.adev_after, "o-", ms=3, color=COLORS[0], label="after")
    ax.set_xlabel("averaging time τ, s")
    ax.set_ylabel("Allan deviation σ(τ), deg/h")
    ax.legend(loc="best")
    return [("compensation", fig)]
