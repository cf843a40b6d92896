"""The state and plumbing every section of the sheet uses: the campaign and its analyses, the
spec items (:meth:`BuilderBase.check`), figures, warnings and the model-equation coefficients.
The section mixins (``sec_*.py``) and :class:`~gyrotest.specsheet.build.Builder` derive from
it, so each section module sees the attributes it uses."""

from __future__ import annotations

import time
from typing import Any

from . import adapters as ad
from .campaign import LIMITS, Campaign
from .sheet import Check, Figure, Num, Section

SF_UNIT_TEXT = {"arcsec/pulse": "arcsec/pulse", "(deg/h)/V": "(°/h)/V", "1": ""}


class BuilderBase:
    """The state of one sheet being built, and the helpers every section calls."""

    def __init__(self, campaign: Campaign, analyses: dict[str, ad.Analysis], figures: bool,
                 variant: str = "customer"):
        self.c = campaign
        self.an = analyses
        self.figures_on = figures
        self.variant = variant
        self.eng = variant == "engineering"  # diagnostics, algorithm notes, warnings
        self.rule = campaign.decision.get("rule", "guard-band")
        self.k = float(campaign.decision.get("coverage_factor", 2.0))
        self.checks: list[Check] = []
        self.figures: list[Figure] = []
        self.warnings: list[dict[str, str]] = []
        self.coef: dict[str, Num | None] = {}  # model-equation coefficients by symbol
        self.timing: dict[str, float] = {}

    # ---------------------------------------------------------------- plumbing
    def check(self, test: str, key: str, label: str, ieee: str, measured: Num | None,
              section: str, unit: str | None = None) -> Check:
        """A spec item; its limit comes from ``[tests.<test>] limits.<key>``."""
        t = self.c.tests.get(test)
        lim = t.limits.get(key) if t else None
        u = unit if unit is not None else LIMITS.get(test, {}).get(key, ("", ""))[1]
        ch = Check(f"{test}.{key}", label, ieee, measured, lim, u, section, self.rule, self.k)
        self.checks.append(ch)
        return ch

    def eng_only(self, sec: Section, *blocks) -> None:
        """Add blocks (algorithm notes, diagnostics) to the engineering sheet only."""
        if self.eng:
            sec.add(*blocks)

    def figure(self, section: Section, fig: Figure | None, caption: str) -> None:
        """Number, caption and attach a figure."""
        if fig is None:
            return
        fig.number = len(self.figures) + 1
        fig.caption = caption
        self.figures.append(fig)
        section.add(fig)

    def draw(self, name: str, fn):
        """Run a figure function when figures are wanted; a plotting failure becomes a
        warning, never a missing sheet."""
        if not self.figures_on:
            return None
        t0 = time.perf_counter()
        try:
            return fn()
        except Exception as e:  # noqa: BLE001 - a figure must not sink the sheet
            self.warn("report", f"figure '{name}' could not be drawn: {type(e).__name__}: {e}")
            return None
        finally:
            self.timing[f"figure:{name}"] = time.perf_counter() - t0

    def warn(self, source: str, text: str, code: str = "", kind: str = "warning") -> None:
        """Record a warning (or, with ``kind="note"``, a note) for section 7."""
        w = {"source": source, "kind": kind, "text": text}
        if code:
            w["code"] = code
        if w not in self.warnings:
            self.warnings.append(w)

    def sf_unit(self) -> str:
        """Sheet spelling of the scale-factor unit (from the analysis, else the campaign)."""
        sf = self.an.get("scale_factor")
        u = sf.result.get("scale_factor_unit") if sf else self.c.gyro.get("scale_factor_unit")
        return SF_UNIT_TEXT.get(u or "", u or "")

    def input_files(self) -> list[dict[str, Any]]:
        """Every input file with its SHA-256 (logs, profiles, tables)."""
        seen: dict[str, dict] = {}
        for name, t in self.c.tests.items():
            for f, sha in t.files.items():
                seen.setdefault(f, {"file": f, "sha256": sha, "tests": []})["tests"].append(name)
        return list(seen.values())
