"""The spec sheet as a document model, independent of the output format.

A :class:`Sheet` is a title block plus numbered :class:`Section` objects holding blocks:
:class:`Para` (text), :class:`Table` (cells are text or :class:`Num`), :class:`Equation`
(monospaced lines) and :class:`Figure` references. Every number is a :class:`Num` that carries
its provenance -- the analysis (command) it came from and the path of the value in that
command's ``--json`` document -- so the sheet can be checked number by number against the
individual commands. Spec limits become :class:`Check` rows with a verdict.

Verdict rule (stated on the sheet): PASS when the measured value, or the upper bound when
only a bound is established, does not exceed the limit in magnitude; FAIL when a measured
value exceeds it; INCONCLUSIVE when only an upper bound is known and it exceeds the limit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

PASS, FAIL, INCONCLUSIVE, NO_LIMIT, NOT_TESTED = ("PASS", "FAIL", "INCONCLUSIVE",
                                                  "no limit given", "not tested")

VERDICT_RULE = ("PASS: the measured value (or, where only an upper bound is established, that "
                "bound) does not exceed the limit in magnitude; FAIL: the measured value "
                "exceeds it; INCONCLUSIVE: only an upper bound is known and it exceeds the "
                "limit.")


# ----------------------------------------------------------------------------- numbers
_SUP = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")


def _sci(v: float, digits: int) -> str:
    m, e = f"{v:.{max(digits - 1, 0)}e}".split("e")
    return f"{m}·10{str(int(e)).translate(_SUP)}"


def _minus(t: str) -> str:
    return "−" + t[1:] if t.startswith("-") else t


def fmt_number(v: float | None, digits: int = 4, strip: bool = True) -> str:
    """``v`` with ``digits`` significant digits (trailing zeros dropped unless ``strip`` is
    False; integers as integers); scientific (``1.23·10⁻⁵``) outside 1e-3 … 1e6; ``—`` for
    None/NaN; a true minus sign."""
    if v is None or not isinstance(v, (int, float)) or not math.isfinite(v):
        return "—"
    if v == 0:
        return "0"
    a = abs(v)
    if float(v).is_integer() and a < 1e9:
        return _minus(str(int(v)))
    if 1e-3 <= a < 1e6:
        dec = max(0, digits - 1 - int(math.floor(math.log10(a))))
        t = f"{v:.{dec}f}"
        if strip and "." in t:
            t = t.rstrip("0").rstrip(".")
        return _minus(t)
    return _minus(_sci(v, digits))


def fmt_pm(v: float | None, s: float | None, digits: int = 4) -> str:
    """``v ± s`` with two significant digits of ``s`` and ``v`` to the same decimal place."""
    if v is None or not math.isfinite(v):
        return "—"
    if s is None or not isinstance(s, (int, float)) or not math.isfinite(s) or s <= 0:
        return fmt_number(v, digits)
    a = max(abs(v), s)
    if not 1e-3 <= a < 1e6:
        e = int(math.floor(math.log10(a)))
        sc = 10.0 ** e
        dec = max(0, 1 - int(math.floor(math.log10(s / sc))))
        return _minus(f"({v / sc:.{dec}f} ± {s / sc:.{dec}f})·10{str(e).translate(_SUP)}")
    dec = max(0, 1 - int(math.floor(math.log10(s))))
    dec = min(dec, 12)
    return _minus(f"{v:.{dec}f} ± {s:.{dec}f}")


@dataclass
class Num:
    """A number on the sheet: value (or upper bound), optional 1σ, unit, provenance.

    ``source`` = ``{"analysis": key, "path": [...]}`` (path into that analysis' ``--json``
    document); ``sigma_source`` likewise for the uncertainty."""

    value: float | None
    unit: str = ""
    sigma: float | None = None
    bound: bool = False
    source: dict[str, Any] | None = None
    sigma_source: dict[str, Any] | None = None
    digits: int = 4
    prefix: str = ""

    def text(self, unit: bool = True) -> str:
        """Formatted value (``≤`` for bounds, ``±`` 1σ), with the unit unless ``unit`` is
        False (the unit is then in the column header)."""
        if self.value is None or (isinstance(self.value, float) and not math.isfinite(self.value)):
            return "—"
        if self.bound:
            t = "≤ " + fmt_number(self.value, self.digits)
        else:
            t = fmt_pm(self.value, self.sigma, self.digits)
        t = self.prefix + t
        if unit and self.unit:
            t += f" {self.unit}"
        return t

    def to_dict(self) -> dict[str, Any]:
        """JSON form."""
        d: dict[str, Any] = {"value": self.value, "unit": self.unit, "text": self.text()}
        if self.sigma is not None:
            d["sigma"] = self.sigma
        if self.bound:
            d["upper_bound"] = True
        if self.source:
            d["source"] = self.source
        if self.sigma_source:
            d["sigma_source"] = self.sigma_source
        return d


Cell = str | Num


@dataclass
class Para:
    """A paragraph (plain text; ``style`` note/warning/normal)."""

    text: str
    style: str = "normal"
    nums: list[Num] = field(default_factory=list)  # the numbers quoted in the text

    def to_dict(self) -> dict[str, Any]:
        """JSON form."""
        d: dict[str, Any] = {"type": "paragraph", "text": self.text, "style": self.style}
        if self.nums:
            d["numbers"] = [n.to_dict() for n in self.nums]
        return d


@dataclass
class Table:
    """A table; ``columns`` carry units where a column is homogeneous; cells are text or
    :class:`Num` (shown without unit when ``unit_in_header``)."""

    columns: list[str]
    rows: list[list[Cell]]
    title: str = ""
    note: str = ""
    unit_in_header: bool = False
    widths: list[float] | None = None  # relative column widths (PDF)
    key: str = ""
    nums: list[Num] = field(default_factory=list)  # numbers quoted inside text cells

    def cell_text(self, c: Cell) -> str:
        """Text of one cell."""
        if isinstance(c, Num):
            return c.text(unit=not self.unit_in_header)
        return str(c)

    def to_dict(self) -> dict[str, Any]:
        """JSON form."""
        return {"type": "table", "key": self.key, "title": self.title, "columns": self.columns,
                "rows": [[c.to_dict() if isinstance(c, Num) else c for c in r]
                         for r in self.rows], "note": self.note,
                **({"numbers": [n.to_dict() for n in self.nums]} if self.nums else {})}


@dataclass
class Equation:
    """Monospaced lines (the model equation)."""

    lines: list[str]

    def to_dict(self) -> dict[str, Any]:
        """JSON form."""
        return {"type": "equation", "lines": self.lines}


@dataclass
class Figure:
    """A figure: PNG bytes (and optionally SVG text) with a caption."""

    key: str
    caption: str
    png: bytes | None = None
    svg: str | None = None
    width_in: float = 0.0
    height_in: float = 0.0
    number: int = 0

    def to_dict(self) -> dict[str, Any]:
        """JSON form."""
        return {"type": "figure", "key": self.key, "number": self.number,
                "caption": self.caption, "embedded": self.png is not None}


@dataclass
class Check:
    """A spec item with a limit: measured value against "shall not exceed"."""

    key: str
    label: str
    ieee: str
    measured: Num | None
    limit: float | None
    unit: str
    section: str = ""

    @property
    def verdict(self) -> str:
        """PASS / FAIL / INCONCLUSIVE / "no limit given" / "not tested"."""
        m = self.measured
        if m is None or m.value is None or not math.isfinite(m.value):
            return NOT_TESTED
        if self.limit is None:
            return NO_LIMIT
        if abs(m.value) <= self.limit:
            return PASS
        return INCONCLUSIVE if m.bound else FAIL

    def to_dict(self) -> dict[str, Any]:
        """JSON form."""
        return {"key": self.key, "item": self.label, "ieee": self.ieee, "section": self.section,
                "measured": self.measured.to_dict() if self.measured else None,
                "limit": self.limit, "unit": self.unit, "verdict": self.verdict}


Block = Para | Table | Equation | Figure


@dataclass
class Section:
    """A numbered section (``number`` like "3" or "3.2") with blocks and subsections."""

    number: str
    title: str
    ieee: str = ""
    status: str = "tested"  # tested | not tested | partly tested
    blocks: list[Block] = field(default_factory=list)
    subsections: list[Section] = field(default_factory=list)

    def add(self, *blocks: Block) -> Section:
        """Append blocks; returns self."""
        self.blocks.extend(b for b in blocks if b is not None)
        return self

    def sub(self, title: str, ieee: str = "", status: str = "tested") -> Section:
        """Append and return a new numbered subsection."""
        s = Section(f"{self.number}.{len(self.subsections) + 1}", title, ieee, status)
        self.subsections.append(s)
        return s

    @property
    def heading(self) -> str:
        """Number, title and IEEE 952 reference."""
        t = f"{self.number} {self.title}"
        if self.ieee:
            t += f" (IEEE 952 {self.ieee})"
        return t

    def walk(self):
        """This section and all subsections, depth first."""
        yield self
        for s in self.subsections:
            yield from s.walk()

    def to_dict(self) -> dict[str, Any]:
        """JSON form."""
        return {"number": self.number, "title": self.title, "ieee": self.ieee,
                "status": self.status, "blocks": [b.to_dict() for b in self.blocks],
                "subsections": [s.to_dict() for s in self.subsections]}


@dataclass
class Sheet:
    """The whole spec sheet."""

    title: str
    identity: list[tuple[str, str]]  # title-block rows (label, text)
    sections: list[Section]
    checks: list[Check]
    figures: list[Figure]
    warnings: list[dict[str, str]]
    provenance: dict[str, Any]
    header: str = ""  # running header (PDF): model and serial
    notes: str = ""

    def walk(self):
        """Every section and subsection in order."""
        for s in self.sections:
            yield from s.walk()

    def overall(self) -> str:
        """Overall verdict: FAIL if any check fails, INCONCLUSIVE if any is inconclusive,
        PASS if every limited item passes, else "no limit given"."""
        v = [c.verdict for c in self.checks]
        if FAIL in v:
            return FAIL
        if INCONCLUSIVE in v:
            return INCONCLUSIVE
        if PASS in v:
            return PASS
        return NO_LIMIT

    def to_dict(self) -> dict[str, Any]:
        """JSON form."""
        return {"format": "gyrotest-spec-sheet", "version": 1, "title": self.title,
                "title_block": [{"label": a, "text": b} for a, b in self.identity],
                "overall_verdict": self.overall(), "verdict_rule": VERDICT_RULE,
                "checks": [c.to_dict() for c in self.checks],
                "sections": [s.to_dict() for s in self.sections],
                "figures": [f.to_dict() for f in self.figures],
                "warnings": self.warnings, "provenance": self.provenance}
