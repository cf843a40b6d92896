"""Shared matplotlib style and figure saving for every gyrotest plot.

Use :func:`new_figure` for a consistently styled figure and :func:`save_figure` to write it
(format from the suffix: .png, .svg or .pdf; written atomically). Plots are for people: label
every axis with its quantity and unit, e.g. ``"Allan deviation σ(τ), deg/h"``.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import matplotlib

if "ipykernel" not in sys.modules:
    # no display needed; never opens windows. In a Jupyter kernel the notebook's own backend
    # stays, so that the figures of the API's ``.plot()`` show in the notebook
    matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402

from .output import atomic_path, check_output_path  # noqa: E402

FORMATS = (".png", ".svg", ".pdf")

STYLE = {
    "figure.dpi": 100,
    "savefig.dpi": 150,
    "font.size": 10,
    "axes.titlesize": 11,
    "axes.labelsize": 10,
    "legend.fontsize": 8.5,
    "xtick.labelsize": 9,
    "ytick.labelsize": 9,
    "axes.grid": True,
    "grid.alpha": 0.35,
    "grid.linewidth": 0.6,
    "axes.spines.top": False,
    "axes.spines.right": False,
    "lines.linewidth": 1.4,
    "figure.constrained_layout.use": True,
    "svg.fonttype": "none",
    "pdf.fonttype": 42,
}

#: colour cycle used for components/runs (colour-blind friendly, Okabe–Ito)
COLORS = ["#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#F0E442", "#000000"]


def new_figure(nrows: int = 1, ncols: int = 1, *, size=(7.5, 4.8), height_ratios=None,
               sharex: bool = False):
    """A styled figure and its axes (like ``plt.subplots``)."""
    with plt.rc_context(STYLE):
        kw = {}
        if height_ratios is not None:
            kw["gridspec_kw"] = {"height_ratios": height_ratios}
        fig, axes = plt.subplots(nrows, ncols, figsize=size, sharex=sharex, **kw)
    for ax in (axes.flat if hasattr(axes, "flat") else [axes]):
        ax.set_prop_cycle(color=COLORS)
    return fig, axes


def check_plot_path(path: str | os.PathLike) -> Path:
    """Validate a plot path before any work is done (suffix and directory)."""
    return check_output_path(path, FORMATS, "plot file", formats=".png, .svg or .pdf")


def save_figure(fig, path: str | os.PathLike) -> Path:
    """Save ``fig`` to ``path`` (.png/.svg/.pdf) atomically and close it."""
    p = check_plot_path(path)
    try:
        with plt.rc_context(STYLE), atomic_path(p) as tmp:
            fig.savefig(tmp, format=p.suffix.lower().lstrip("."))
    finally:
        plt.close(fig)
    return p
