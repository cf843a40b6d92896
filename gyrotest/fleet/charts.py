"""Control charts of the lot: one panel per spec item, the serials along x.

Each panel shows, per serial, the latest test's value with its expanded uncertainty U (bar);
an upper bound (▼) has no bar; colour = verdict. The spec limit L (and −L when values are
negative) is a solid red line; the lot median (dashed) and median ± c(n)·robust σ (dotted: the
outlier fence of :func:`gyrotest.fleet.core.flag_outliers`) are grey. Earlier acceptance
tests of the same serial are hollow grey markers left of the current value, joined to it.
Flagged outliers are ringed and labelled.
"""

from __future__ import annotations

import math

from .core import Fleet

VERDICT_COLOR = {"PASS": "#009E73", "CONDITIONAL PASS": "#E69F00",
                 "CONDITIONAL FAIL": "#D55E00", "FAIL": "#b00020", "INCONCLUSIVE": "#CC79A7"}


def key_items(fleet: Fleet) -> list[str]:
    """Spec items charted: every item with a limit and a value for at least one serial."""
    return [s.key for s in fleet.stats if s.limit is not None and s.n > 0]


def control_charts(fleet: Fleet, keys: list[str] | None = None, ncols: int = 2):
    """The control-chart figure (matplotlib) for the spec items ``keys`` (default
    :func:`key_items`); None when there is nothing to chart."""
    import matplotlib.pyplot as plt

    from ..core.plotting import STYLE

    keys = key_items(fleet) if keys is None else keys
    if not keys:
        return None
    stats = {s.key: s for s in fleet.stats}
    serials = [r["serial"] for r in fleet.lot]
    xpos = {s: i for i, s in enumerate(serials)}
    nrows = math.ceil(len(keys) / ncols)
    with plt.rc_context(STYLE):
        fig, axes = plt.subplots(nrows, ncols, figsize=(4.2 * ncols, 2.5 * nrows + 0.5),
                                 squeeze=False)
    for ax in axes.flat[len(keys):]:
        ax.set_visible(False)
    for ax, key in zip(axes.flat, keys):
        s = stats[key]
        lo_vals = []  # what the y range must show: values ± U, earlier values, limits
        for r in fleet.lot:
            it = fleet.item(r, key)
            if it is None or it["value"] is None:
                continue
            x, v = xpos[r["serial"]], it["value"]
            u = it["expanded_uncertainty"] or 0.0
            lo_vals += [v - u, v + u]
            col = VERDICT_COLOR.get(it["verdict"], "#606060")
            if it["bound"]:
                ax.plot(x, v, "v", color=col, ms=6, zorder=3)
            else:
                ax.errorbar(x, v, yerr=it["expanded_uncertainty"] or None, fmt="o", color=col,
                            ms=4.5, capsize=2.5, lw=1, zorder=3)
            for j, e in enumerate(reversed(fleet.earlier.get(r["serial"], []))):
                ie = fleet.item(e, key)
                if ie is None or ie["value"] is None:
                    continue
                xe = x - 0.22 * (j + 1)
                lo_vals.append(ie["value"])
                ax.plot([xe, x], [ie["value"], v], color="#909090", lw=0.8, zorder=2)
                ax.plot(xe, ie["value"], "v" if ie["bound"] else "o", mfc="white",
                        mec="#707070", ms=4.5, zorder=3)
            if r["serial"] in s.outliers:
                ax.plot(x, v, "o", mfc="none", mec="#b00020", ms=11, mew=1.3, zorder=4)
                ax.annotate(f"M = {s.z[r['serial']]:.1f}", (x, v), xytext=(6, 4),
                            textcoords="offset points", fontsize=7, color="#b00020")
        neg = min(lo_vals, default=0) < 0
        if s.limit is not None:
            ax.axhline(s.limit, color="#b00020", lw=1.2)
            lo_vals.append(s.limit)
            if neg:
                ax.axhline(-s.limit, color="#b00020", lw=1.2)
                lo_vals.append(-s.limit)
        if s.median is not None:
            ax.axhline(s.median, color="#606060", lw=0.9, ls="--")
            if math.isfinite(s.threshold) and s.robust_sigma:
                for sign in (-1, 1):
                    ax.axhline(s.median + sign * s.threshold * s.robust_sigma, color="#909090",
                               lw=0.8, ls=":")
        ax.set_xticks(range(len(serials)))
        ax.set_xticklabels(serials, rotation=45 if len(serials) > 8 else 0, fontsize=7.5)
        ax.set_xlim(-0.7, len(serials) - 0.5)
        ax.tick_params(axis="y", labelsize=7.5)
        unit = f" ({s.unit})" if s.unit else ""
        ax.set_title(f"{s.item}{unit}", fontsize=8.5, loc="left")
        if lo_vals:  # the fence may lie outside: the chart shows the data and the limits
            lo, hi = min(lo_vals + [0.0]), max(lo_vals)
            pad = 0.12 * (hi - lo or abs(hi) or 1.0)
            ax.set_ylim(lo - pad if lo < 0 else max(0.0, lo - pad) if lo > 0 else 0.0,
                        hi + pad)
    from matplotlib.lines import Line2D

    handles = [Line2D([], [], color="#b00020", lw=1.2, label="limit L"),
               Line2D([], [], color="#606060", lw=0.9, ls="--", label="lot median"),
               Line2D([], [], color="#909090", lw=0.8, ls=":",
                      label="outlier fence: median ± c(n)·robust σ"),
               Line2D([], [], color="#009E73", marker="o", ls="", label="value ± U (colour: verdict) per serial"),
               Line2D([], [], color="#009E73", marker="v", ls="", label="upper bound"),
               Line2D([], [], mfc="white", mec="#707070", marker="o", ls="",
                      label="earlier test of the serial")]
    fig.legend(handles=handles, loc="outside lower center", ncol=3, fontsize=7.5, frameon=False)
    return fig
