"""The spec sheet as a document model, independent of the output format.

A :class:`Sheet` is a title block plus numbered :class:`Section` objects holding blocks:
:class:`Para` (text), :class:`Table` (cells are text or :class:`Num`), :class:`Equation`
(monospaced lines) and :class:`Figure` references. Every number is a :class:`Num` that carries
its provenance -- the analysis (command) it came from and the path of the value in that
command's ``--json`` document -- so the sheet can be checked number by number against the
individual commands. Spec limits become :class:`Check` rows with a verdict.

Decision rule (stated on the sheet; ILAC-G8:09/2019 "Guidelines on decision rules and
statements of conformity"): with the expanded uncertainty U = k·u (k = 2 by default, about
95 % coverage) and the limit L on |value|,

* guard-banded rule (default, guard band w = U): PASS when |x| + U ≤ L; FAIL when |x| − U > L;
  CONDITIONAL PASS when |x| ≤ L < |x| + U; CONDITIONAL FAIL when |x| − U ≤ L < |x|;
* simple acceptance (w = 0): PASS when |x| ≤ L, FAIL otherwise.

An item given only as an upper bound (95 %) passes when the bound is within the limit and is
INCONCLUSIVE otherwise; an item without an evaluated uncertainty (a maximum or spread of the
data) is decided on its value.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

PASS, FAIL, INCONCLUSIVE, NO_LIMIT, NOT_TESTED = ("PASS", "FAIL", "INCONCLUSIVE",
                                                  "no limit given", "not tested")
COND_PASS, COND_FAIL = "CONDITIONAL PASS", "CONDITIONAL FAIL"
#: overall verdict: the worst item, in this order
SEVERITY = (FAIL, COND_FAIL, INCONCLUSIVE, COND_PASS, PASS)

GUARD_BAND, SIMPLE = "guard-band", "simple"


def verdict_rule(rule: str = GUARD_BAND, k: float = 2.0) -> str:
    """The decision rule as stated on the sheet."""
    kk = f"{k:g}"
    common = (f"U is the expanded uncertainty U = k·u with coverage factor k = {kk} "
              f"(about {_coverage(k)} coverage for a normal distribution; GUM, JCGM 100:2008); "
              "the limit L applies to the magnitude |x| of the measured value x. An item "
              "established only as an upper bound (95 % confidence) passes when the bound is "
              "within L and is INCONCLUSIVE otherwise. Items without an evaluated uncertainty "
              "(maxima and spreads of the data) are decided on their value (U = 0).")
    if rule == SIMPLE:
        return ("Simple acceptance (ILAC-G8:09/2019 §4.2.1, guard band w = 0): PASS when "
                "|x| ≤ L, FAIL when |x| > L; the uncertainty is stated but not used for the "
                "decision, so the risk of a false accept reaches 50 % at the limit. " + common)
    return ("Guarded acceptance (ILAC-G8:09/2019 §4.2.3, guard band w = U): PASS when "
            "|x| + U ≤ L; FAIL when |x| − U > L; CONDITIONAL PASS when |x| ≤ L < |x| + U "
            "(the value is within the limit, but the uncertainty interval extends beyond it); "
            "CONDITIONAL FAIL when |x| − U ≤ L < |x|. " + common)


def _coverage(k: float) -> str:
    p = math.erf(k / math.sqrt(2.0)) * 100
    return f"{p:.0f} %" if p < 99.5 else f"{p:.1f} %"


VERDICT_RULE = verdict_rule()


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
    k: float = 1.0  # coverage factor of the ± shown: 1 (1σ) or 2 (expanded, customer sheet)

    @property
    def expanded(self) -> float | None:
        """The uncertainty shown after ±: k·σ (None without σ)."""
        if self.sigma is None or not math.isfinite(self.sigma):
            return None
        return self.k * self.sigma

    def text(self, unit: bool = True) -> str:
        """Formatted value (``≤`` for bounds, ``±`` k·σ), with the unit unless ``unit`` is
        False (the unit is then in the column header)."""
        if self.value is None or (isinstance(self.value, float) and not math.isfinite(self.value)):
            return "—"
        if self.bound:
            t = "≤ " + fmt_number(self.value, self.digits)
        else:
            t = fmt_pm(self.value, self.expanded, self.digits)
        t = self.prefix + t
        if unit and self.unit:
            t += f" {self.unit}"
        return t

    def to_dict(self) -> dict[str, Any]:
        """JSON form."""
        d: dict[str, Any] = {"value": self.value, "unit": self.unit, "text": self.text()}
        if self.sigma is not None:
            d["sigma"] = self.sigma
            if self.k != 1.0:
                d["coverage_factor"] = self.k
                d["expanded_uncertainty"] = self.expanded
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
    rule: str = GUARD_BAND
    k: float = 2.0

    @property
    def expanded_uncertainty(self) -> float | None:
        """U = k·σ of the measured value; None when no σ was evaluated or for a bound (the
        sheet says "not evaluated" / "upper bound", the JSON null)."""
        m = self.measured
        if m is None or m.bound or m.sigma is None or not math.isfinite(m.sigma):
            return None
        return self.k * m.sigma

    @property
    def verdict(self) -> str:
        """PASS / FAIL / CONDITIONAL PASS / CONDITIONAL FAIL / INCONCLUSIVE /
        "no limit given" / "not tested" under the decision rule (module docstring)."""
        m = self.measured
        if m is None or m.value is None or not math.isfinite(m.value):
            return NOT_TESTED
        if self.limit is None:
            return NO_LIMIT
        x = abs(m.value)
        if m.bound:
            return PASS if x <= self.limit else INCONCLUSIVE
        u = (self.expanded_uncertainty or 0.0) if self.rule == GUARD_BAND else 0.0
        if x + u <= self.limit:
            return PASS
        if x - u > self.limit:
            return FAIL
        return COND_PASS if x <= self.limit else COND_FAIL

    def to_dict(self) -> dict[str, Any]:
        """JSON form."""
        d = {"key": self.key, "item": self.label, "ieee": self.ieee, "section": self.section,
             "measured": self.measured.to_dict() if self.measured else None,
             "limit": self.limit, "unit": self.unit, "verdict": self.verdict}
        if self.limit is not None and self.measured is not None:
            d["decision_rule"] = self.rule
            d["coverage_factor"] = self.k
            d["expanded_uncertainty"] = self.expanded_uncertainty
        return d


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
        if self.ieee:  # a reference naming its own standard (IEEE Std 1293) stands alone
            t += f" ({self.ieee})" if self.ieee.startswith("IEEE") else f" (IEEE 952 {self.ieee})"
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
    variant: str = "customer"  # customer | engineering
    rule_text: str = VERDICT_RULE
    logo: bytes | None = None  # lab logo (PNG/JPEG bytes) for the title block
    lab: dict[str, Any] = field(default_factory=dict)
    kind: str = "gyro specification sheet (IEEE 952 style)"  # running header, PDF subject

    def walk(self):
        """Every section and subsection in order."""
        for s in self.sections:
            yield from s.walk()

    def overall(self) -> str:
        """Overall verdict: the worst item verdict in the order FAIL, CONDITIONAL FAIL,
        INCONCLUSIVE, CONDITIONAL PASS, PASS; "no limit given" when no item has a limit."""
        v = {c.verdict for c in self.checks}
        for s in SEVERITY:
            if s in v:
                return s
        return NO_LIMIT

    def to_dict(self) -> dict[str, Any]:
        """JSON form."""
        return {"format": "gyrotest-spec-sheet", "version": 1, "title": self.title,
                "variant": self.variant,
                "title_block": [{"label": a, "text": b} for a, b in self.identity],
                "overall_verdict": self.overall(), "verdict_rule": self.rule_text,
                "checks": [c.to_dict() for c in self.checks],
                "sections": [s.to_dict() for s in self.sections],
                "figures": [f.to_dict() for f in self.figures],
                "warnings": self.warnings, "provenance": self.provenance}
