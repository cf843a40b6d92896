"""A quick look at a raw log (``gyrotest info LOG --plot``): one page with the gyro output of
every axis, the temperatures, the magnetic field, the supply voltage and the rate table
against time, the gaps shaded on every panel and the spikes marked -- what a lab looks at
before any analysis (is the thermocouple connected, did the coil sequence run, where did the
logger drop samples).

Long logs are drawn as the envelope (minimum … maximum) of about 2000 time bins with the bin
means on top, so a 10⁸-sample record plots as fast as a short one and a single spike still
shows. Units: rates in the display unit (deg/h unless ``--unit``), temperatures degC, field
µT, supply V, table rate deg/s; time in s, min or h by the record length.
"""

from __future__ import annotations

import numpy as np

from ..core.plotting import COLORS, new_figure, save_figure

#: time bins of the envelope (about the width of the figure in pixels)
BINS = 2000
#: spikes marked at most (the first ones in time; ``gyrotest info`` lists them all)
MAX_SPIKES = 200


def envelope(t: np.ndarray, x: np.ndarray, bins: int = BINS
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Bin centres, means, minima and maxima of ``x`` over about ``bins`` equal-count bins
    (the samples themselves when there are fewer)."""
    n = len(x)
    if n <= 2 * bins:
        return t, x, x, x
    k = n // bins
    edges = np.arange(0, n, k)  # the last bin holds the remainder (fewer than 2k samples)
    with np.errstate(all="ignore"):
        tb = np.add.reduceat(t, edges) / np.diff(np.append(edges, n))
        return (tb, np.add.reduceat(x, edges) / np.diff(np.append(edges, n)),
                np.minimum.reduceat(x, edges), np.maximum.reduceat(x, edges))


def time_scale(duration_s: float) -> tuple[float, str]:
    """(seconds per unit, label) of the time axis: s below 10 min, min below 5 h, else h."""
    if duration_s < 600:
        return 1.0, "s"
    if duration_s < 5 * 3600:
        return 60.0, "min"
    return 3600.0, "h"


def panels_of(log) -> list[tuple[str, str, dict[str, np.ndarray]]]:
    """The auxiliary panels a log has: (title, unit, {label: samples}) for temperatures,
    field, supply and rate table, in that order."""
    out = []
    if log.temperature:
        out.append(("temperatures", "°C", dict(log.temperature)))
    if log.field_uT:
        out.append(("magnetic field", "µT", dict(log.field_uT)))
    if log.supply is not None:
        out.append(("supply voltage", "V", {"supply": log.supply}))
    if log.table_rate is not None:
        out.append(("rate table", "deg/s", {"table rate": log.table_rate / 3600.0}))
    return out


def figure_quicklook(log, *, axes: list[str] | None = None, unit=None, outliers=None,
                     size: tuple[float, float] | None = None):
    """The quick-look figure of ``log`` (a :class:`~gyrotest.core.data.GyroLog`): a panel for the
    gyro output of ``axes`` (default every axis), one per auxiliary group
    (:func:`panels_of`), gaps shaded, ``outliers`` (reports of
    :func:`gyrotest.noise.outliers.detect_outliers`, one per axis) marked. ``unit``: a
    :class:`~gyrotest.core.display.DisplayUnit` for the rate (default deg/h). Returns the
    matplotlib figure."""
    from pathlib import Path

    from ..core.display import DEFAULT

    u = unit or DEFAULT
    axes = list(axes or log.axes)
    aux = panels_of(log)
    nrow = 1 + len(aux)
    fig, axs = new_figure(nrow, 1, size=size or (9.0, 2.3 + 1.9 * nrow), sharex=True,
                          height_ratios=[1.6] + [1.0] * len(aux))
    axs = np.atleast_1d(axs)
    t = log.t
    scale, tlab = time_scale(float(t[-1] - t[0]) if log.n > 1 else 0.0)
    ts = t / scale
    ax = axs[0]
    for i, a in enumerate(axes):
        col = COLORS[i % len(COLORS)]
        tb, mean, lo, hi = envelope(ts, log.rates[a] * u.f)
        if lo is not mean:
            ax.fill_between(tb, lo, hi, color=col, alpha=0.25, lw=0)
        ax.plot(tb, mean, color=col, lw=0.8, label=f"{a}" + (" (min … max, mean per bin)"
                                                              if lo is not mean else ""))
    # at the time of the spike's first sample (the log's own time axis, gaps included)
    spikes = sorted(float(t[min(e.start, log.n - 1)]) for rep in outliers or []
                    for e in getattr(rep, "events", []))
    for j, x in enumerate(spikes[:MAX_SPIKES]):
        ax.axvline(x / scale, color="#b00020", lw=0.8, alpha=0.6,
                   label=f"spike ({len(spikes)}, Hampel filter)" if j == 0 else None)
    ax.set_ylabel(f"gyro output, {u.rate}")
    kind = {"counts": "pulse counts", "updown": "up/down pulses", "counter": "counter",
            "voltage": "voltage"}.get(log.gyro.output_kind, log.gyro.output_kind)
    ax.set_title(f"{Path(str(log.source)).name}: {log.n:,} samples at "
                 f"{1.0 / log.tau0:.6g} Hz, gyro output: {kind}"
                 + (f", {len(log.timing.gaps)} gap(s) shaded" if log.timing.gaps else
                    ", no gaps"), loc="left", fontsize=10)
    ax.legend(loc="upper right", fontsize=8)
    for axp, (title, un, chans) in zip(axs[1:], aux):
        for j, (name, x) in enumerate(chans.items()):
            tb, mean, lo, hi = envelope(ts, np.asarray(x, dtype=float))
            axp.plot(tb, mean, color=COLORS[(j + 1) % len(COLORS)], lw=1.0, label=name)
        axp.set_ylabel(f"{title}, {un}")
        axp.legend(loc="best", fontsize=8, ncol=min(3, len(chans)))
    for axp in axs:
        for g in log.timing.gaps:
            start = (g.time_s - g.duration_s) / scale
            axp.axvspan(start, g.time_s / scale, color="#b00020", alpha=0.15, lw=0)
    axs[-1].set_xlabel(f"time, {tlab}")
    return fig


def plot_quicklook(log, path, **kw):
    """Write :func:`figure_quicklook` to ``path`` (.png/.svg/.pdf); returns the path."""
    return save_figure(figure_quicklook(log, **kw), path)
