"""``gyrotest bias`` on every gyro axis of a multi-axis log.

:func:`analyse_bias_axes` runs :func:`gyrotest.staticbias.analysis.analyse_bias` once per axis chosen by
:func:`gyrotest.core.axes.choose_axes` and keeps the results by axis name.

Earth rate: a site gives ONE input-axis direction (``--ia`` / ``[site] ia``). It cannot hold
for two orthogonal gyro axes at once, so when several axes are analysed the earth rate is not
removed from any of them (D_F then includes it, and a note says so); name one axis with
``--axis`` to have it removed along the given IA. A multi-position test (``--positions`` or a
position column) places one axis in the named directions: without ``--axis`` it analyses the
first axis, and says so.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..core.axes import choose_axes
from .analysis import BiasAnalysis, analyse_bias


@dataclass
class BiasAxes:
    """The bias analysis of each analysed axis, in axis order."""

    per_axis: dict[str, BiasAnalysis]
    notes: list[str] = field(default_factory=list)

    @property
    def axes(self) -> list[str]:
        return list(self.per_axis)

    def to_dict(self) -> dict:
        """The JSON document of ``gyrotest bias --json``.

        The top level is the single-axis document (:meth:`BiasAnalysis.to_dict`) of the first
        analysed axis, so scripts written for one axis keep working; every run names its
        ``axis``. Added: ``axes`` (the analysed axis names), ``notes``, and with several axes
        ``per_axis``: one single-axis document per axis (each with its ``axis``), in order.
        """
        docs = [{"axis": a, **ba.to_dict()} for a, ba in self.per_axis.items()]
        out = {**docs[0], "axes": self.axes, "notes": self.notes}
        if len(docs) > 1:
            out["per_axis"] = docs
        return out


def analyse_bias_axes(logs: list, *, axis: str | None = None, skip_s: float = 0.0,
                      settle_s: float = 0.0, positions: str | list[str] | None = None,
                      earth_rate: bool = True, outliers: str = "flag",
                      warmup_band_dph: float | None = None,
                      warmup_block_s: float = 60.0) -> BiasAxes:
    """:func:`gyrotest.staticbias.analysis.analyse_bias` on every axis of ``logs`` (or the ``axis`` names,
    comma-separated). See the module docstring for the earth rate and multi-position rules."""
    names = choose_axes(logs, axis)
    notes: list[str] = []
    multi_pos = bool(positions) or any(g.position is not None for g in logs)
    if multi_pos and len(names) > 1 and not axis:
        notes.append(f"multi-position test: analysing axis {names[0]} (the axis placed in the "
                     f"named directions); the log also has {', '.join(names[1:])} — choose "
                     "with --axis")
        names = names[:1]
    if len(names) > 1 and earth_rate and any(g.site is not None for g in logs):
        notes.append(f"{len(names)} axes analysed with one IA direction: the earth rate is NOT "
                     "removed from any of them (D_F includes it); give --axis NAME to remove it "
                     "along the IA")
        earth_rate = False
    per = {a: analyse_bias(logs, skip_s=skip_s, settle_s=settle_s, axis=a, positions=positions,
                           earth_rate=earth_rate, outliers=outliers,
                           warmup_band_dph=warmup_band_dph, warmup_block_s=warmup_block_s)
           for a in names}
    return BiasAxes(per, notes)
