"""Layout helpers of the spec sheet: numbers with provenance (:class:`Src`), paragraphs and
tables that carry the numbers quoted in them (:func:`P`, :func:`T`), the check table, and the
unit spellings of the sheet."""

from __future__ import annotations

import math
from typing import Any

from . import adapters as ad
from .sheet import NOT_TESTED, Check, Num, Para, Section, Table, fmt_number

U_DPH = "°/h"
U_ARW = "°/√h"
U_RRW = "(°/h)/√h"
U_RR = "(°/h)/h"

# ============================================================================ helpers
_MISSING = object()


def dig(d: Any, path: list) -> Any:
    """Walk ``path`` (keys and indices) into a JSON document; None when absent."""
    for k in path:
        try:
            d = d[k]
        except (KeyError, IndexError, TypeError):
            return None
    return d


class Src:
    """Makes :class:`Num` values out of one analysis result, recording their paths.
    :meth:`t` returns a number's text for running prose and keeps the :class:`Num` in
    ``sink`` (attached to the next paragraph or table, so it stays checkable)."""

    sink: list[Num] = []
    k: float = 1.0  # coverage factor of the ± shown (set per sheet by build_sheet)

    def __init__(self, a: ad.Analysis):
        self.a = a

    def t(self, path: list, unit: str = "", sigma: list | None = None, **kw) -> str:
        """Text of :meth:`num` (with unit) for use inside prose; the Num goes to ``sink``."""
        n = self.num(path, unit, sigma, **kw)
        Src.sink.append(n)
        return n.text()

    def get(self, path: list) -> Any:
        """Raw value at ``path``."""
        return dig(self.a.result, path)

    def num(self, path: list, unit: str = "", sigma: list | None = None, *,
            bound: bool = False, digits: int = 4, prefix: str = "") -> Num:
        """A :class:`Num` from the value at ``path`` (and 1σ at ``sigma``)."""
        v = dig(self.a.result, path)
        s = dig(self.a.result, sigma) if sigma else None
        return Num(float(v) if _isnum(v) else None, unit, float(s) if _isnum(s) else None,
                   bound, {"analysis": self.a.key, "path": list(path)},
                   {"analysis": self.a.key, "path": list(sigma)} if sigma and _isnum(s)
                   else None, digits, prefix, Src.k)


def P(text: str, style: str = "normal") -> Para:
    """A paragraph carrying the numbers quoted in it (from :meth:`Src.t`)."""
    nums, Src.sink[:] = list(Src.sink), []
    return Para(text, style, nums)


def T(columns: list[str], rows: list, **kw) -> Table:
    """A table carrying the numbers quoted inside its text cells (from :meth:`Src.t`)."""
    nums, Src.sink[:] = list(Src.sink), []
    return Table(columns, rows, nums=nums, **kw)


def _isnum(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _not_tested(section: Section, what: str) -> Section:
    section.status = NOT_TESTED
    section.add(P(f"Not tested: {what}", "note"))
    return section


def _check_table(checks: list[Check], title: str = "", standard: str = "IEEE 952") -> Table:
    rows = []
    for c in checks:
        lim = "—" if c.limit is None else f"≤ {fmt_number(c.limit)} {c.unit}".strip()
        rows.append([c.label, c.ieee, c.measured if c.measured else "not tested", lim,
                     c.verdict])
    return T(["item", standard, "measured", "limit (|value| shall not exceed)",
                  "verdict"], rows, title=title, widths=[3.2, 1.2, 2.6, 2.0, 1.3], key="checks")



def _fig(name: str, *args):
    from . import figures

    return getattr(figures, name)(*args)


def _unit(u: str) -> str:
    """Sheet spelling of a core unit string."""
    rep = {"deg/sqrt(h)": U_ARW, "deg/h/sqrt(h)": U_RRW, "deg/h/h": U_RR, "deg/h": U_DPH,
           "deg/(h·degC)": "(°/h)/°C", "deg/(h·degC^2)": "(°/h)/°C²",
           "deg/degC = (deg/h)/(degC/h)": "(°/h)/(°C/h)", "(deg/h)/degC": "(°/h)/°C",
           "(deg/h)/(degC/h)": "(°/h)/(°C/h)", "deg/h per 100 uT": "°/h per 100 µT",
           "(deg/h)/V": "(°/h)/V", "deg/s": "°/s", "degC": "°C",
           # accelerometers (IEEE Std 1293 terms)
           "m/s/sqrt(h)": "m/s/√h", "m/s/h/sqrt(h)": "m/s/h/√h", "ug": "µg",
           "m/s^2": "m/s²"}
    return rep.get(u, u)


def _quote(x: str) -> str:
    import shlex

    return shlex.quote(x)

