"""Plot for ``gyrotest bias``: the rate of each run with D_F and its 2σ band."""

from __future__ import annotations

import os

import numpy as np

from ..core.plotting import COLORS, new_figure, save_figure


def block_means(t: np.ndarray, x: np.ndarray, target: int = 2000) -> tuple[np.ndarray, np.ndarray]:
    """Average ``x`` in consecutive blocks so that about ``target`` points remain."""
    n = len(x)
    k = max(1, n // target)
    m = (n // k) * k
    if m == 0:
        return t, x
    return t[:m].reshape(-1, k).mean(axis=1), x[:m].reshape(-1, k).mean(axis=1)


def plot_bias(analysis, path, *, size: tuple[float, float] | None = None, unit=None):
    """Write :func:`figure_bias` to ``path`` (.png/.svg/.pdf); returns the path."""
    return save_figure(figure_bias(analysis, size=size, unit=unit), path)


def figure_bias(analysis, *, size: tuple[float, float] | None = None, unit=None):
    """Rate (block means) vs time per run, the warm-up trim shaded, D_F ± 2σ; and for a
    multi-position test the position means against the fitted model. ``analysis`` is a
    :class:`~gyrotest.staticbias.analysis.BiasAnalysis`; ``size`` in inches (default 8 wide, 4.6 per panel
    high); ``unit`` a :class:`~gyrotest.core.display.DisplayUnit` for the rate axis (default
    deg/h). Returns the matplotlib figure."""
    from ..core.display import DEFAULT

    u = unit or DEFAULT
    f, lab = u.f, u.rate
    logs, runs, multi = analysis.parts, analysis.runs, analysis.multi
    skip_s = analysis.parts_skip_s
    nrow = 2 if multi else 1
    fig, axes = new_figure(nrow, 1, size=size or (8, 4.6 * nrow))
    ax = axes[0] if multi else axes
    for i, (g, r) in enumerate(zip(logs, runs)):
        col = COLORS[i % len(COLORS)]
        name = os.path.basename(r.label) if not multi else r.label
        th = g.t / 3600.0
        t, x = block_means(th, g.rates[r.axis] * f, 3000)
        ax.plot(t, x, color=col, lw=0.6, alpha=0.35)
        t2, x2 = block_means(th, g.rates[r.axis] * f, 150)
        if multi:
            ax.plot(t2, x2, color=col, lw=1.6, label=f"{name}: indicated rate")
        else:  # one legend entry per run; the line styles are explained once, below
            ax.plot(t2, x2, color=col, lw=1.6,
                    label=f"{name}: D_F = {r.bias_dph * f:.5g} ± {r.sigma_dph * f:.2g} {lab} "
                          "(1σ)")
        if not multi:
            er = (r.earth_rate_ia_dph or 0.0) * f
            t_end = th[-1] if len(th) else 0.0
            mean, sig = r.mean_output_dph * f, r.sigma_dph * f
            lo = mean - 2 * sig
            ax.hlines(mean, skip_s / 3600.0, t_end, color=col, ls="--", lw=1.3)
            ax.fill_between([skip_s / 3600.0, t_end], lo, lo + 4 * sig, color=col, alpha=0.18)
    if not multi:
        er = (runs[0].earth_rate_ia_dph or 0.0) * f if runs else 0.0
        ax.plot([], [], color="0.35", lw=0.6, alpha=0.6,
                label="thin: fine means; thick: coarse means")
        ax.plot([], [], color="0.35", ls="--", lw=1.3,
                label=f"dashed: mean = D_F + Ω_IA (Ω_IA = {er:.5g} {lab})")
        ax.fill_between([], [], [], color="0.35", alpha=0.18, label="band: mean ± 2σ")
    if skip_s > 0:
        ax.axvspan(0, skip_s / 3600.0, color="0.5", alpha=0.15, label="warm-up trim")
    ax.set_xlabel("time, h")
    ax.set_ylabel(f"indicated rate, {lab}")
    ax.set_title("Static run(s): indicated rate and bias estimate"
                 + (f", axis {runs[0].axis}" if runs else ""))
    if multi:
        ax.legend(loc="best")
    else:  # below the axes: inside, one entry per run and style covered half the data
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=2, fontsize=8,
                  frameon=False)
    if multi:
        ax2 = axes[1]
        labels = [p.label for p in multi.positions]
        m = np.array([p.mean_output_dph for p in multi.positions]) * f
        s = np.array([p.sigma_dph for p in multi.positions]) * f
        x = np.arange(len(m))
        ax2.errorbar(x, m, yerr=2 * s, fmt="o", color=COLORS[0], capsize=4,
                     label="position mean ± 2σ")
        model = m - np.array(multi.residuals_dph) * f
        ax2.plot(x, model, "x", color=COLORS[1], ms=9, mew=2, label="fit: D_F + Ω_E·u")
        ax2.axhline(multi.bias_dph * f, color=COLORS[2], ls="--",
                    label=f"D_F = {multi.bias_dph * f:.4g} ± {multi.bias_sigma_dph * f:.2g} {lab}")
        ax2.set_xticks(x, labels, rotation=15)
        ax2.set_ylabel(f"mean output, {lab}")
        ax2.set_title("Multi-position test")
        ax2.legend(loc="best")
    return fig
