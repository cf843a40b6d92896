"""Figures of the Allan analysis: σ(τ) with the fitted model and its residuals, and the PSD/ACF.

* :func:`plot_allan`: log–log σ(τ) with the confidence interval of every point (hollow markers:
  τ not fitted, too few clusters), the fitted total, each component dashed and labelled with
  its value ("≤" bounds dotted), a fan of slope guides (−1, −½, 0, +½, +1; IEEE 952 Annex C),
  and a residual panel in CI units with the ±1/±2 bands. Several runs or axes overlay on one τ
  axis in seconds (Krobka's experiment: the same gyro at different output rates).
* :func:`plot_psd`: the Welch rate PSD (two-sided, (deg/h)²/Hz), the fitted model's PSD, the
  detected lines, and the autocorrelation with its white-noise band.

Each has a figure-returning variant with a ``size`` (inches): :func:`figure_allan`,
:func:`figure_psd` (the spec-sheet report lays them out at its own size); the ``plot_*``
functions save that figure to .png/.svg/.pdf via :func:`gyrotest.core.plotting.save_figure`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..core.plotting import COLORS, new_figure, save_figure

__all__ = ["figure_allan", "figure_psd", "plot_allan", "plot_psd"]

ALLAN_SIZE = (11.5, 6.8)
PSD_SIZE = (8.2, 6.6)

_COMP_COLORS = ["#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#8C564B", "#999999",
                "#F0E442"]
_SLOPES = [(-1.0, "−1 Q"), (-0.5, "−½ N"), (0.0, "0 B"), (0.5, "+½ K"), (1.0, "+1 R")]


def _label_for(a, many_sources: bool, many_axes: bool, label: str | None) -> str:
    if label:
        return label
    parts = []
    if many_sources:
        parts.append(a[0])
    if many_axes or not parts:
        parts.append(a[1].axis)
    return " ".join(parts)


def _slope_fan(ax) -> None:
    """Five reference slopes from a common origin in the upper right of the (already scaled)
    log–log axes, drawn in data coordinates so that the slopes are true."""
    x_lo, x_hi = ax.get_xlim()
    y_lo, y_hi = ax.get_ylim()
    xr = math.log10(x_hi / x_lo)
    yr = math.log10(y_hi / y_lo)
    dec = min(0.16 * xr, 0.2 * yr)  # decades of τ spanned by each guide
    x0 = x_lo * 10 ** (0.70 * xr)
    y0 = y_lo * 10 ** (0.72 * yr)
    for sl, txt in _SLOPES:
        x1 = x0 * 10**dec
        y1 = y0 * 10 ** (sl * dec)
        ax.plot([x0, x1], [y0, y1], color="0.55", lw=0.9, zorder=1)
        ax.text(x1 * 10 ** (0.01 * xr), y1, txt, fontsize=7, color="0.35", va="center")
    ax.text(x0, y0 * 10 ** (0.06 * yr), "slope guides", fontsize=7, color="0.35", ha="left")


def legend_pm_title(k: float = 1.0) -> str:
    """What a legend's ± means: one standard deviation, or the expanded uncertainty U = k·1σ
    of the sheet the figure is on (so a legend and the table beside it read alike)."""
    return "± = 1σ" if k == 1.0 else f"± = U (k = {k:g})"


def _components(ax, fit, tf, unit=None, k: float = 1.0) -> None:
    """The fitted model's terms as dashed curves (bounds dotted); ``k``: the legend's ± is
    k·1σ."""
    from ..core.display import DEFAULT, term_text
    from .fitmodel import _basis
    from .impact import _coef_from_value

    u = unit or DEFAULT

    i = 0
    for t in fit.terms:
        cc = _COMP_COLORS[i % len(_COMP_COLORS)]
        if t.coef > 0:
            ax.plot(tf, np.sqrt(t.avar(tf)) * u.f, ls="--", lw=1.2, color=cc,
                    label=f"{t.label} ({t.title}): {term_text(t, u, k=k)}"
                    + ("" if t.identified else " — not identified"), zorder=2)
            i += 1
        elif t.upper is not None and t.key in ("Q", "N", "B", "K", "R"):
            cu = _coef_from_value(t.key, t.upper, t.shape, getattr(fit, "q", None))
            ax.plot(tf, np.sqrt(cu * _basis(t.key, tf, None, t.bi_f0)) * u.f, ls=":", lw=1.0,
                    color=cc, alpha=0.8, label=f"{t.label} ({t.title}) bound: {term_text(t, u)}",
                    zorder=2)
            i += 1


def _unit_of(items, unit):
    """The display unit of a figure: ``unit`` (default deg/h) for gyro axes, the
    accelerometer's own for accelerometer axes; a figure holds one kind (ValueError)."""
    from ..core.display import ACCEL_DISPLAY, DEFAULT

    kinds = {getattr(a, "quantity", "rate") for _, a in items}
    if len(kinds) > 1:
        raise ValueError("one figure holds gyro or accelerometer axes, not both: plot them "
                         "apart (split_by_quantity)")
    return ACCEL_DISPLAY if kinds == {"acceleration"} else (unit or DEFAULT)


def split_by_quantity(items, path):
    """[(items, path)]: the gyro axes to ``path``, the accelerometer axes to ``path`` with
    ``_accel`` before the suffix (one entry when the items are of one kind)."""
    from pathlib import Path

    gyro = [it for it in items if getattr(it[1], "quantity", "rate") == "rate"]
    acc = [it for it in items if getattr(it[1], "quantity", "rate") != "rate"]
    if not gyro or not acc:
        return [(list(items), str(path))]
    p = Path(path)
    return [(gyro, str(p)), (acc, str(p.with_name(p.stem + "_accel" + p.suffix)))]


def plot_allan(items: Sequence[tuple[str, Any]], path, *, labels: Sequence[str] | None = None,
               title: str | None = None, show_components: bool | None = None,
               size: tuple[float, float] = ALLAN_SIZE, unit=None):
    """Write :func:`figure_allan` to ``path`` (.png/.svg/.pdf); returns the path."""
    return save_figure(figure_allan(items, labels=labels, title=title,
                                    show_components=show_components, size=size, unit=unit),
                       path)


def figure_allan(items: Sequence[tuple[str, Any]], *, labels: Sequence[str] | None = None,
                 title: str | None = None, show_components: bool | None = None,
                 size: tuple[float, float] = ALLAN_SIZE, unit=None, k: float = 1.0):
    """Allan deviation figure (module docstring), ``size`` inches. ``items`` = [(source,
    AxisAnalysis), …]; ``labels`` overrides the legend label of each item. With one item, the
    components of the fitted model are drawn; when the diagnosis added terms, the diagnosed
    model is the main curve and the requested model is shown thin and grey with its
    residuals. Returns the matplotlib figure (close it, or save it with
    :func:`gyrotest.core.plotting.save_figure`). ``unit``: a :class:`~gyrotest.core.display.DisplayUnit`
    for the σ axis and the term labels (default deg/h). ``k``: the terms' ± in the legend
    is k·1σ (a sheet's expanded uncertainty U), and the legend's title says which.
    """
    from pathlib import Path

    items = list(items)
    u = _unit_of(items, unit)
    fu = u.f

    many_sources = len({s for s, _ in items}) > 1
    many_axes = len({a.axis for _, a in items}) > 1
    single = len(items) == 1 if show_components is None else show_components
    fig, (ax, axr) = new_figure(2, 1, size=size, height_ratios=[3.2, 1.0], sharex=True)
    all_tau, all_sig = [], []
    for i, (src, a) in enumerate(items):
        col = COLORS[i % len(COLORS)]
        lab = _label_for((Path(src).name, a), many_sources, many_axes,
                         labels[i] if labels else None)
        req = a.fit
        fit = getattr(a, "best_fit", req)
        if req is None:  # plain table (no model): the deviation with its interval
            tau, sig = np.asarray(a.dev.tau, float), np.asarray(a.dev.sigma, float) * fu
            lo, hi = np.asarray(a.sigma_lo, float) * fu, np.asarray(a.sigma_hi, float) * fu
            ok = np.isfinite(sig) & (sig > 0)
            yerr = np.vstack([np.where(np.isfinite(lo), sig - lo, 0),
                              np.where(np.isfinite(hi), hi - sig, 0)])
            ax.errorbar(tau[ok], sig[ok], yerr=yerr[:, ok], fmt="o-", ms=3.2, color=col,
                        ecolor=col, elinewidth=0.8, capsize=1.5, lw=0.8,
                        label=f"{lab}: {a.dev.kind.upper()} ± CI (no model fitted)", zorder=3)
            all_tau.extend(tau[ok].tolist())
            all_sig.extend(list(sig[ok]) + list(lo[ok & np.isfinite(lo)])
                           + list(hi[ok & np.isfinite(hi)]))
            continue
        tau, sig = req.tau, req.sigma * fu
        lo, hi = req.sigma_lo * fu, req.sigma_hi * fu
        ok = np.isfinite(sig) & (sig > 0)
        used = req.used & ok
        yerr = np.vstack([np.where(np.isfinite(lo), sig - lo, 0),
                          np.where(np.isfinite(hi), hi - sig, 0)])
        ax.errorbar(tau[used], sig[used], yerr=yerr[:, used], fmt="o", ms=3.2, color=col,
                    ecolor=col, elinewidth=0.8, capsize=1.5, alpha=0.9,
                    label=f"{lab}: measured {a.fit_dev.kind.upper()} ± CI", zorder=3)
        ex = ok & ~req.used
        if np.any(ex):
            ax.errorbar(tau[ex], sig[ex], yerr=yerr[:, ex], fmt="o", ms=3.2, mfc="white",
                        color=col, ecolor=col, elinewidth=0.6, capsize=1.5, alpha=0.7,
                        label="not fitted (too few clusters)" if i == 0 else None, zorder=3)
        tf = np.geomspace(tau[ok].min(), tau[ok].max(), 300)
        diag = fit is not req
        if diag and single:
            ax.plot(tf, req.model_sigma(tf) * fu, color="0.55", lw=1.3,
                    label=f"requested model {','.join(req.requested)}: χ²/dof "
                          f"{req.chi2_dof:.3g} (misfits)", zorder=2)
        name = ("diagnosed model " + ",".join(fit.requested)) if diag else "fitted model"
        ax.plot(tf, fit.model_sigma(tf) * fu, color=col, lw=2.0, alpha=0.85,
                label=(f"{lab}: {name}, χ²/dof {fit.chi2_dof:.2f}" if not single
                       else f"{name}, χ²/dof = {fit.chi2_dof:.2f}"), zorder=4)
        if single:
            _components(ax, fit, tf, u, k)
        for f_, c_, alpha in ([(req, "0.55", 0.8)] if (diag and single) else []) + [
                (fit, col, 1.0)]:
            r = f_.residuals()
            rr = np.clip(r, -5.0, 5.0)
            fin = ok & np.isfinite(r)
            inside = fin & (np.abs(r) <= 5.0)
            clip = fin & (np.abs(r) > 5.0)
            axr.plot(tau[fin], rr[fin], "-", lw=0.7, color=c_, alpha=0.6 * alpha)
            axr.plot(tau[inside], rr[inside], "o", ms=3.2, color=c_, alpha=alpha, ls="none")
            axr.plot(tau[clip], rr[clip], "^", ms=3.6, color=c_, mfc="white", alpha=alpha,
                     ls="none")
        all_tau.extend(tau[ok].tolist())
        all_sig.extend(list(sig[ok]) + list(lo[ok & np.isfinite(lo)])
                       + list(hi[ok & np.isfinite(hi)]))
    ax.set_xscale("log")
    ax.set_yscale("log")
    s_lo, s_hi = min(v for v in all_sig if v > 0), max(all_sig)
    ax.set_ylim(s_lo / 1.8, s_hi * 2.5)
    ax.set_xlim(min(all_tau) / 1.4, max(all_tau) * 1.4)
    _slope_fan(ax)
    ax.set_ylabel(f"Allan deviation σ(τ), {u.rate}")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7.5, framealpha=0.9,
              borderaxespad=0.0, title=legend_pm_title(k), title_fontsize=7.5)
    if title is None:
        src, a = items[0]
        what = "and noise model" if a.fit is not None else "(no noise model fitted)"
        title = (f"{Path(src).name} — {a.axis}: {a.fit_dev.kind.upper()} {what}"
                 if len(items) == 1
                 else f"{a.fit_dev.kind.upper()} of {len(items)} runs/axes on one τ axis")
    ax.set_title(title)
    axr.axhspan(-2, 2, color="0.93", zorder=0)
    axr.axhspan(-1, 1, color="0.85", zorder=0)
    axr.axhline(0, color="0.3", lw=0.8)
    axr.set_ylim(-5.6, 5.6)
    axr.set_yticks([-4, -2, 0, 2, 4])
    axr.set_ylabel("residual\n(σ̂ − model)/CI")
    axr.set_xlabel("averaging time τ, s")
    if all(a.fit is None for _, a in items):  # plain table: nothing to show in the panel
        axr.text(0.5, 0.5, "no noise model fitted (--no-fit or too few τ): no residuals",
                 transform=axr.transAxes, ha="center", va="center", color="0.3",
                 bbox=dict(facecolor="white", edgecolor="0.8", boxstyle="round,pad=0.4"), zorder=5)
    axr.text(1.01, 0.5, "bands: ±1, ±2 CI\n△: beyond ±5 (clipped)", transform=axr.transAxes,
             ha="left", va="center", fontsize=7.5, color="0.3")
    return fig


def plot_psd(items: Sequence[tuple[str, Any]], path, *, labels: Sequence[str] | None = None,
             size: tuple[float, float] = PSD_SIZE, unit=None):
    """Write :func:`figure_psd` to ``path`` (.png/.svg/.pdf); returns the path."""
    return save_figure(figure_psd(items, labels=labels, size=size, unit=unit), path)


def figure_psd(items: Sequence[tuple[str, Any]], *, labels: Sequence[str] | None = None,
               size: tuple[float, float] = PSD_SIZE, unit=None):
    """Welch PSD with the fitted model PSD and detected lines, plus the autocorrelation
    (module docstring), ``size`` inches. ``items`` = [(source, AxisAnalysis), …]. Returns the
    matplotlib figure. ``unit``: a :class:`~gyrotest.core.display.DisplayUnit` for the PSD axis
    (default deg/h)."""
    items = list(items)
    u = _unit_of(items, unit)
    f2 = u.f * u.f
    what = "acceleration" if u.name == "m/s^2" else "rate"
    many_sources = len({s for s, _ in items}) > 1
    many_axes = len({a.axis for _, a in items}) > 1
    fig, (ax, axc) = new_figure(2, 1, size=size, height_ratios=[2.4, 1.3])
    for i, (src, a) in enumerate(items):
        col = COLORS[i % len(COLORS)]
        lab = _label_for((src, a), many_sources, many_axes, labels[i] if labels else None)
        if a.psd is not None:
            f, p = a.psd.f, a.psd.psd * f2
            if f.size > 4000:
                step = max(1, f.size // 4000)
                ax.plot(f[::step], p[::step], color=col, lw=0.4, alpha=0.25)
            fb, pb = a.psd.log_binned(30)
            pb = pb * f2
            ax.plot(fb, pb, color=col, lw=1.4, label=f"{lab}: Welch PSD (log-binned)")
            bf = getattr(a, "best_fit", a.fit)
            mp = bf.psd(fb) * f2 if bf is not None else np.zeros_like(fb)
            if np.any(mp > 0):
                ax.plot(fb, np.where(mp > 0, mp, np.nan), "--", color=col, lw=1.2, alpha=0.9,
                        label=f"{lab}: model PSD, terms {','.join(bf.requested)} "
                              "(sinusoid/ramp not shown)")
            for ln in a.lines:
                ax.axvline(ln.f_hz, color=col, ls=":", lw=1.0)
                ax.annotate(f"line {ln.f_hz:.4g} Hz\nΩ0 ≈ {ln.amplitude_dph * u.f:.3g} {u.rate}",
                            xy=(ln.f_hz, float(np.interp(ln.f_hz, f, p))), xytext=(6, 6),
                            textcoords="offset points", fontsize=7.5, color=col)
        if a.acf is not None:
            lag, rho = a.acf.lag_s[1:], a.acf.rho[1:]
            axc.plot(lag, rho, color=col, lw=1.0, label=f"{lab}")
            axc.axhspan(-a.acf.band, a.acf.band, color="0.88", zorder=0)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("frequency f, Hz")
    ax.set_ylabel(f"{what} PSD S(f), {u.psd}\n(two-sided, "
                  f"{'IEEE 1293' if what == 'acceleration' else 'IEEE 952'})")
    ax.set_title(f"{what.capitalize()} power spectral density (lines: sinusoids; knee: Markov "
                 "1/(2πT_c))")
    ax.legend(loc="best", fontsize=7.5)
    axc.set_xscale("log")
    axc.axhline(0, color="0.3", lw=0.7)
    axc.set_xlabel("lag, s")
    axc.set_ylabel("autocorrelation ρ")
    axc.text(0.995, 0.9, "grey band: 95 % white-noise limits", transform=axc.transAxes,
             ha="right", fontsize=7, color="0.35")
    if len(items) > 1:
        axc.legend(loc="upper right", fontsize=7.5)
    return fig
