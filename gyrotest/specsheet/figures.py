"""Figures of the spec sheet, drawn by the analysis modules' own plotting functions.

* Allan deviation with the fit, components and residuals: :func:`gyrotest.noise.plots.figure_allan`;
* scale-factor linearity residuals: :func:`gyrotest.scalefactor.plots.figure_scale_factor`;
* thermal model vs measurement and residual: :func:`gyrotest.envmodel.plots.thermal_figures`;
* magnetic response per axis: :func:`gyrotest.envmodel.plots.mag_figures`;
* model history (error falling as terms are added): :func:`gyrotest.envmodel.plots.history_figures`.

Each returns matplotlib figures (the ``plot_*`` functions the commands use save the same
figures to files); those that take a size are drawn at the report's size, the others are
resized before saving. Every figure is rendered at :data:`DPI` so that it stays sharp when
scaled to the page width.
"""

from __future__ import annotations

import io

from .sheet import Figure

DPI = 150
#: report size (inches) of each figure: about the PDF text width, so that the modules' fonts
#: (8-10 pt) print at 7-9 pt
SIZES = {"allan": (8.0, 5.4), "scale_factor": (9.6, 6.2), "thermal": (8.0, 3.4),
         "time": (8.0, 5.6), "levels": (9.0, 3.6), "history": (8.5, 5.0)}


def _png_size(data: bytes) -> tuple[float, float]:
    import struct

    w, h = struct.unpack(">II", data[16:24])
    return w / DPI, h / DPI


def _png_from_fig(fig, size: tuple[float, float] | None = None) -> tuple[bytes, float, float]:
    """PNG bytes of ``fig`` (resized to ``size`` inches first, if given) and its size (in);
    the figure is closed."""
    import matplotlib.pyplot as plt

    from ..core.plotting import STYLE

    if size is not None:
        fig.set_size_inches(*size)
    buf = io.BytesIO()
    try:
        with plt.rc_context(STYLE):
            fig.savefig(buf, format="png", dpi=DPI)
    finally:
        plt.close(fig)
    data = buf.getvalue()
    return data, *_png_size(data)


def _close(figs) -> None:
    import matplotlib.pyplot as plt

    for _, f in figs:
        plt.close(f)


def accel_figure(source: str, axis_analyses) -> Figure:
    """The Allan figure of the accelerometer axes (all on one τ axis, σ in m/s²)."""
    from ..noise.plots import figure_allan

    png, w, h = _png_from_fig(figure_allan([(source, a) for a in axis_analyses],
                                           size=SIZES["allan"]))
    return Figure("accel", "", png, None, w, h)


def allan_figure(source: str, axis_analysis, k: float = 2.0) -> Figure:
    """Allan deviation, fitted model, its components and the residuals in CI units; the
    terms' ± in the legend is the sheet's U = k·1σ, as in its tables."""
    from ..noise.plots import figure_allan

    png, w, h = _png_from_fig(figure_allan([(source, axis_analysis)], size=SIZES["allan"],
                                           k=k))
    return Figure("allan", "", png, None, w, h)


def scale_factor_figure(result) -> Figure:
    """Linearity error per rate with the nonlinearity model (residuals of the IEEE line)."""
    from ..scalefactor.plots import figure_scale_factor

    png, w, h = _png_from_fig(figure_scale_factor(result, size=SIZES["scale_factor"]))
    return Figure("scale_factor", "", png, None, w, h)


def thermal_figures(th) -> list[Figure]:
    """Drift vs temperature (model curve, heating/cooling) and the model fit over time with
    its residual."""
    from ..envmodel.plots import thermal_figures as figs_of

    figs = figs_of(th)
    out = []
    try:
        for name, fig in figs:
            if name in ("thermal", "time"):
                png, w, h = _png_from_fig(fig, SIZES[name])
                out.append(Figure(f"thermal_{name}", "", png, None, w, h))
    finally:
        _close(figs)
    return out


def magnetic_figure(mg, k: float = 2.0) -> Figure | None:
    """Plateau means against the applied field per axis with the fitted slopes (± the
    sheet's U = k·1σ, as in its tables)."""
    from ..envmodel.plots import mag_figures

    figs = mag_figures(mg, k)
    try:
        for name, fig in figs:
            if name == "levels":
                png, w, h = _png_from_fig(fig, SIZES["levels"])
                return Figure("magnetic", "", png, None, w, h)
    finally:
        _close(figs)
    return None


def history_figure(steps) -> Figure:
    """Residual RMS (fit, held-out, noise floor) and AIC/BIC per model step."""
    from ..envmodel.plots import history_figures

    figs = history_figures(steps, size=SIZES["history"])
    try:
        png, w, h = _png_from_fig(figs[0][1])
    finally:
        _close(figs)
    return Figure("history", "", png, None, w, h)
