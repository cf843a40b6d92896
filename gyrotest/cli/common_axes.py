"""CLI helpers for multi-axis output (file names per axis)."""

from __future__ import annotations

import os
import re


def axis_plot_path(path: str, axis: str, n_axes: int) -> str:
    """``bias.png`` → ``bias_gx.png`` when several axes are plotted (one file per axis); the
    path unchanged for one axis."""
    if n_axes <= 1:
        return path
    root, ext = os.path.splitext(path)
    safe = re.sub(r"[^A-Za-z0-9_.-]+", "_", axis)
    return f"{root}_{safe}{ext}"
