"""Run a campaign's analyses and lay out the spec sheet in IEEE 952 order.

:func:`run_campaign` runs every test through its adapter (:mod:`.adapters`; the same core
calls as the individual commands) and :func:`build_sheet` turns the results into a
:class:`~gyrotest.report.sheet.Sheet`:

0. title block (identity, operator, date, gyrotest version, campaign file and its SHA-256);
1. the model equation (IEEE 952 §8.3) with the fitted coefficients substituted;
2. scale factor (§5.3.2);
3. drift rate (§5.3.3.1): bias D_F and repeatability, random drift N, B, K, R and Q (≤ for
   bounds), the noise structure (Krobka) and the platform vs strapdown application note;
4. environmental sensitivities (§5.3.3.2, E terms): thermal (D_T, D_Ṫ, D_∇Ṫ and the
   Antonova–Matveev w0 … w_ΔV), magnetic (w_x, w_y, w_z), supply voltage, model history;
5. IA alignment (§5.3.4) from a multi-position test;
6. test conditions and reproducibility (files with SHA-256, options, command lines);
7. warnings raised by the analyses;
8. compliance with the spec limits.

Every number is taken from the analysis result exactly as the command prints it with
``--json`` and carries that provenance (:class:`~gyrotest.report.sheet.Num`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from .. import __version__
from ..errors import GyrotestError, InputError
from . import adapters as ad
from .campaign import LIMITS, Campaign
from .sheet import (
    NOT_TESTED,
    VERDICT_RULE,
    Check,
    Equation,
    Figure,
    Num,
    Para,
    Section,
    Sheet,
    Table,
    fmt_number,
)

U_DPH = "°/h"
U_ARW = "°/√h"
U_RRW = "(°/h)/√h"
U_RR = "(°/h)/h"
SF_UNIT_TEXT = {"arcsec/pulse": "arcsec/pulse", "(deg/h)/V": "(°/h)/V", "1": ""}


# ============================================================================ running
def run_campaign(campaign: Campaign, *, progress: Callable[[str], None] | None = None
                 ) -> dict[str, ad.Analysis]:
    """Run every test of ``campaign`` (IEEE order) and the log summaries; returns the
    analyses by key. An error names the test: ``campaign.toml [tests.bias]: ...``."""
    cache = ad.LogCache()
    out: dict[str, ad.Analysis] = {}

    def step(name: str, fn, announce: bool = True):
        """Run one adapter; a gyrotest error is re-raised naming the campaign and test."""
        if progress and announce:
            progress(name.replace("scale_factor", "scale factor"))
        try:
            return fn()
        except GyrotestError as e:
            test = name.split(" ")[0].split(".")[0]
            raise InputError(f"{campaign.path.name} [tests.{test}]: {e}") from None

    for name, test in campaign.tests.items():
        if name in ("bias", "multiposition"):
            a = step(name, lambda t=test, n=name: ad.run_bias(t, campaign, cache, key=n))
            out[name] = a
        elif name == "allan":
            out[name] = step(name, lambda t=test: ad.run_allan(t, campaign, cache))
        elif name == "scale_factor":
            out[name] = step(name, lambda t=test: ad.run_scale_factor(t, campaign, cache))
        elif name == "thermal":
            out[name] = step(name, lambda t=test: ad.run_thermal(t, campaign, cache))
            t0 = float(test.opt("t0", 21.0))
            for i, terms in enumerate(test.opt("model_steps", []) if test.logs else [], 1):
                k = f"thermal.step{i}"
                out[k] = step(f"thermal model step {i}: {terms}",
                              lambda t=test, tm=terms, k=k, t0=t0: ad.run_model_fit(
                                  t, campaign, cache, tm, k, t_ref=t0))
        elif name == "magnetic":
            out[name] = step(name, lambda t=test: ad.run_magnetic(t, campaign, cache))
        elif name == "supply":
            out[name] = step(name, lambda t=test: ad.run_model_fit(
                t, campaign, cache, t.opt("terms", "V"), "supply"))
    for name, test in campaign.tests.items():
        for p in test.logs:
            k = f"info:{campaign.rel(p)}"
            if k not in out:
                out[k] = step(name, lambda p=p, t=test: ad.run_info(p, t, campaign, cache),
                              announce=False)
    return out


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
                   else None, digits, prefix)


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


def _check_table(checks: list[Check], title: str = "") -> Table:
    rows = []
    for c in checks:
        lim = "—" if c.limit is None else f"≤ {fmt_number(c.limit)} {c.unit}".strip()
        rows.append([c.label, c.ieee, c.measured if c.measured else "not tested", lim,
                     c.verdict])
    return T(["item", "IEEE 952", "measured", "limit (|value| shall not exceed)",
                  "verdict"], rows, title=title, widths=[3.2, 1.2, 2.6, 2.0, 1.3], key="checks")


class Builder:
    """Builds the sections of one sheet."""

    def __init__(self, campaign: Campaign, analyses: dict[str, ad.Analysis], figures: bool):
        self.c = campaign
        self.an = analyses
        self.figures_on = figures
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
        ch = Check(f"{test}.{key}", label, ieee, measured, lim, u, section)
        self.checks.append(ch)
        return ch

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

    # ---------------------------------------------------------------- sections
    def build(self) -> Sheet:
        """The whole sheet."""
        sec_model = Section("1", "Model equation", "§8.3")
        sec_sf = self.scale_factor(Section("2", "Scale factor", "§5.3.2"))
        sec_drift = self.drift(Section("3", "Drift rate: bias and random drift", "§5.3.3.1"))
        sec_env = self.environment(Section("4", "Environmental sensitivities (E terms)",
                                           "§5.3.3.2, §8.3"))
        sec_ia = self.alignment(Section("5", "IA alignment", "§5.3.4"))
        self.model_equation(sec_model)  # after the others: it substitutes their numbers
        sec_cond = self.conditions(Section("6", "Test conditions and reproducibility"))
        self.identity_checks()
        sec_warn = self.warnings_section(Section("7", "Warnings raised by the analyses"))
        sec_comp = self.compliance(Section("8", "Compliance with the spec limits"))
        sections = [sec_model, sec_sf, sec_drift, sec_env, sec_ia, sec_cond, sec_warn, sec_comp]
        g = self.c.gyro
        title = f"{g['model']} s/n {g['serial']}: gyro specification sheet"
        m = self.c.meta
        s0 = g.get("nominal_scale_factor")
        ident = [("Gyro", f"{g['model']}, serial {g['serial']}"
                  + (f" ({g['type']})" if g.get("type") else "")),
                 ("Nominal scale factor S0",
                  f"{fmt_number(s0)} {SF_UNIT_TEXT.get(g.get('scale_factor_unit', ''), '')}"
                  .strip() if s0 is not None else "not given")]
        if m.get("title"):
            ident.insert(0, ("Test", m["title"]))
        if m.get("report_id"):
            ident.append(("Report", m["report_id"]))
        ident += [("Operator", m["operator"]), ("Date of test", m["date"])]
        if m.get("organisation"):
            ident.append(("Organisation", m["organisation"]))
        site = self.c.site
        if site:
            txt = ", ".join(x for x in [site.get("name"), (
                f"latitude {site['latitude_deg']:g}°" if "latitude_deg" in site else None)] if x)
            ident.append(("Site", txt))
        names = {"scale_factor": "scale factor", "bias": "bias", "allan": "random drift (Allan)",
                 "thermal": "thermal", "magnetic": "magnetic", "supply": "supply voltage",
                 "multiposition": "IA alignment (multi-position)"}
        tested = [v for k, v in names.items() if k in self.c.tests]
        missing = [v for k, v in names.items() if k not in self.c.tests]
        ident.append(("Tests", (", ".join(tested) or "none")
                      + (f"; not tested: {', '.join(missing)}" if missing else "")))
        ident.append(("Software", f"gyrotest {__version__}"))
        ident.append(("Campaign file", f"{self.c.path.name} (SHA-256 {self.c.sha256[:16]}…)"))
        prov = {
            "gyrotest_version": __version__,
            "campaign": {"file": str(self.c.path), "name": self.c.path.name,
                         "sha256": self.c.sha256},
            "inputs": self.input_files(),
            "commands": [a.to_dict() for a in self.an.values()],
            "working_directory": "paths in the commands are relative to the campaign file's "
                                 "directory; run them there",
            "options": self.c.to_dict()["tests"],
            "timing_s": self.timing,
        }
        sheet = Sheet(title=title, identity=ident, sections=sections, checks=self.checks,
                      figures=self.figures, warnings=self.warnings, provenance=prov,
                      header=f"{g['model']} s/n {g['serial']}", notes=m.get("notes", ""))
        ident.append(("Compliance", self.summary_line(sheet)))
        return sheet

    def summary_line(self, sheet: Sheet) -> str:
        """One line: overall verdict and counts."""
        v = [c.verdict for c in self.checks]
        n_lim = sum(1 for c in self.checks if c.limit is not None)
        if not n_lim:
            return "no limits given in the campaign"
        parts = [f"{sheet.overall()}: {v.count('PASS')} of {n_lim} limited items pass"]
        for k in ("FAIL", "INCONCLUSIVE"):
            if v.count(k):
                parts.append(f"{v.count(k)} {k}")
        nt = sum(1 for c in self.checks if c.verdict == NOT_TESTED and c.limit is not None)
        if nt:
            parts.append(f"{nt} limited item(s) not tested")
        return "; ".join(parts)

    def input_files(self) -> list[dict[str, Any]]:
        """Every input file with its SHA-256 (logs, profiles, tables)."""
        seen: dict[str, dict] = {}
        for name, t in self.c.tests.items():
            for f, sha in t.files.items():
                seen.setdefault(f, {"file": f, "sha256": sha, "tests": []})["tests"].append(name)
        return list(seen.values())

    # ---------------------------------------------------------------- 2 scale factor
    def scale_factor(self, sec: Section) -> Section:
        """Section 2: the §5.3.2 items, per-run lines, f(I) model and the linearity figure."""
        a = self.an.get("scale_factor")
        if a is None:
            for key, lab, ieee in (("scale_factor_error_ppm", "scale-factor error ε0",
                                    "§5.3.2"),
                                   ("linearity_max_ppm_fs", "linearity error (max)",
                                    "§5.3.2.1 a"),
                                   ("asymmetry_ppm", "asymmetry", "§5.3.2.1 b"),
                                   ("repeatability_1sigma_ppm", "repeatability (1σ)",
                                    "§5.3.2.1 c"),
                                   ("stability_1sigma_ppm", "stability (1σ)", "§5.3.2.1 d"),
                                   ("temperature_ppm_per_degC", "temperature sensitivity",
                                    "§5.3.2.2 a")):
                self.check("scale_factor", key, lab, ieee, None, sec.number)
            self.coef.update({"SF": None, "eps0": None, "epsT": None})
            return _not_tested(sec, "no rate-table runs in the campaign ([tests.scale_factor]).")
        s = Src(a)
        r = a.result
        key = {"arcsec/pulse": "arcsec_per_pulse", "(deg/h)/V": "dph_per_v"}.get(
            r.get("scale_factor_unit"), "dimensionless")
        u = self.sf_unit()
        sfu = u or "(1)"
        runs = r.get("runs", [])
        nom = s.num([f"nominal_scale_factor_{key}"], u, digits=6)
        sf = s.num([f"scale_factor_{key}"], u, [f"scale_factor_sigma_{key}"], digits=8)
        eps0 = s.num(["scale_factor_error_ppm"], "ppm", digits=4)
        self.coef.update({"SF": sf, "eps0": eps0})
        items = [
            Check("scale_factor.nominal", "nominal scale factor S0", "§8.3", nom, None, u),
            Check("scale_factor.sf", f"scale factor SF (mean of {len(runs)} run(s), "
                  "least-squares line)", "§12.9.4.1", sf, None, u),
        ]
        self.checks += items
        items.append(self.check("scale_factor", "scale_factor_error_ppm",
                                "scale-factor error ε0 = SF/S0 − 1", "§8.3 ε_K", eps0,
                                sec.number))
        lin = ["linearity"]
        items.append(self.check("scale_factor", "linearity_max_ppm_fs",
                                "linearity error, maximum", "§5.3.2.1 a",
                                s.num(lin + ["linearity_max_ppm_fs"], "ppm of FS"), sec.number))
        items.append(self.check("scale_factor", "linearity_1sigma_ppm_fs", "linearity error, 1σ",
                                "§5.3.2.1 a", s.num(lin + ["linearity_1sigma_ppm_fs"],
                                                    "ppm of FS"), sec.number))
        ch = Check("scale_factor.linearity_max_ppm_output", "linearity error, maximum of output",
                   "§5.3.2.1 a", s.num(lin + ["linearity_max_ppm_output"], "ppm of output"),
                   None, "ppm of output", sec.number)
        self.checks.append(ch)
        items.append(ch)
        ch = Check("scale_factor.linearity_after_model", "linearity error after the f(I) "
                   "model, maximum", "§12.9.4.2.1", s.num(["linearity_after_model",
                                                         "linearity_max_ppm_fs"], "ppm of FS"),
                   None, "ppm of FS", sec.number)
        self.checks.append(ch)
        items.append(ch)
        if r.get("asymmetry", {}).get("status") == "ok":
            asym = s.num(["asymmetry", "asymmetry_ppm"], "ppm", ["asymmetry", "asymmetry_sigma_ppm"])
        else:
            asym = None
            self.warn("scale-factor", f"asymmetry: {dig(r, ['asymmetry', 'status'])}")
        items.append(self.check("scale_factor", "asymmetry_ppm", "asymmetry "
                                f"(SF+ − SF−)/(½(SF+ + SF−)), SF in {sfu}", "§5.3.2.1 b", asym,
                                sec.number))
        rep = r.get("repeatability")
        multi = [g for g in (rep or {}).get("groups", []) if g.get("n_runs", 0) > 1]
        where = "; ".join(f"{fmt_number(g['temperature_degC'], 3)} °C: {g['n_runs']} runs, "
                          f"{g['kind']}" for g in multi) or f"{len(runs)} runs"
        items.append(self.check("scale_factor", "repeatability_1sigma_ppm", "repeatability, 1σ "
                                f"at one temperature ({where})", "§5.3.2.1 c",
                                s.num(["repeatability", "repeatability_1sigma_ppm"], "ppm",
                                      ["repeatability", "repeatability_1sigma_uncertainty_ppm"])
                                if rep and multi else None, sec.number))
        items.append(self.check("scale_factor", "repeatability_max_spread_ppm",
                                "repeatability, max spread", "§5.3.2.1 c",
                                s.num(["repeatability", "repeatability_max_spread_ppm"], "ppm")
                                if rep and multi else None, sec.number))
        rep_note = None
        if rep and len(rep.get("groups", [])) > 1:
            rep_note = P(f"All {rep['n_runs']} runs together span several temperatures: 1σ "
                      f"{s.t(['repeatability', 'all_runs_1sigma_ppm'], 'ppm')}, max spread "
                      f"{s.t(['repeatability', 'all_runs_max_spread_ppm'], 'ppm')}; that spread "
                      "holds ε_T·ΔT and is not the repeatability (IEEE 952 §5.3.2.1 c vs "
                      "§5.3.2.2 a).", "note")
        for i, run in enumerate(runs):
            st = run.get("stability")
            items.append(self.check(
                "scale_factor", "stability_1sigma_ppm",
                f"stability within run {run['run']}, 1σ over {run['n_sweeps']} sweeps",
                "§5.3.2.1 d", s.num(["runs", i, "stability", "stability_1sigma_ppm"], "ppm")
                if st else None, sec.number))
        ts = r.get("temperature_sensitivity", {})
        if ts.get("status") == "ok":
            tnum = s.num(["temperature_sensitivity", "sensitivity_ppm_per_degC"], "ppm/°C",
                         ["temperature_sensitivity", "sensitivity_sigma_ppm_per_degC"])
            lab = (f"temperature sensitivity ε_T ({fmt_number(ts['t_min_degC'], 3)} … "
                   f"{fmt_number(ts['t_max_degC'], 3)} °C)")
        else:
            tnum, lab = None, "temperature sensitivity ε_T"
            self.warn("scale-factor", f"temperature sensitivity: {ts.get('status')}")
        self.coef["epsT"] = tnum
        items.append(self.check("scale_factor", "temperature_ppm_per_degC", lab, "§5.3.2.2 a",
                                tnum, sec.number))
        if ts.get("status") == "ok":
            ch = Check("scale_factor.temperature_max_change", "max SF change ÷ temperature range",
                       "§12.9.4.3.1", s.num(["temperature_sensitivity",
                                             "max_change_over_range_ppm_per_degC"], "ppm/°C"),
                       None, "ppm/°C", sec.number)
            self.checks.append(ch)
            items.append(ch)
        ch = Check("scale_factor.full_scale", "full-scale input rate (±)", "§5.3.1",
                   s.num(["full_scale_dps"], "°/s"), None, "°/s", sec.number)
        self.checks.append(ch)
        items.append(ch)
        # threshold, resolution, input range: "not tested" unless the runs hold the sequence
        for key_, lab, ieee in (("threshold", "threshold (50 % of expected output)", "§5.3.2"),
                                ("resolution", "resolution (50 % of expected change)", "§5.3.2")):
            tr = r.get(key_) or {}
            ok = tr.get("status") == "ok"
            lab2 = lab + (f", above {fmt_number(tr['above_dps'])} °/s"
                          if ok and _isnum(tr.get("above_dps")) else "")
            ch = Check(f"scale_factor.{key_}", lab2 + (", at most" if ok else ""), ieee,
                       s.num([key_, "at_most_dps"], "°/s") if ok else None, None, "°/s",
                       sec.number)
            self.checks.append(ch)
            items.append(ch)
        ir = r.get("input_range") or {}
        if ir:
            sat = ir.get("saturation_detected")
            ch = Check("scale_factor.input_range", "input range (output follows the table)"
                       + (f"; saturates at {', '.join(f'{v:+g}' for v in ir['saturated_rates_dps'])} °/s"
                          if sat else ", at least"), "§5.3.1",
                       s.num(["input_range", "input_range_positive_dps"], "°/s"), None, "°/s",
                       sec.number)
            self.checks.append(ch)
            items.append(ch)
        sec.add(_check_table(items, "Scale-factor items"))
        if rep_note is not None:
            sec.add(rep_note)
        # per-run table
        rows = []
        for i, run in enumerate(runs):
            rows.append([run["run"], s.num(["runs", i, "temperature_mean_degC"], "°C", digits=3),
                         s.num(["runs", i, f"scale_factor_{key}"], u,
                               ["runs", i, f"scale_factor_sigma_{key}"], digits=8),
                         s.num(["runs", i, "scale_factor_error_ppm"], "ppm"),
                         s.num(["runs", i, "bias_dph"], U_DPH, ["runs", i, "bias_sigma_dph"]),
                         s.num(["runs", i, "linearity", "linearity_max_ppm_fs"], "ppm of FS",
                               digits=3),
                         str(run.get("n_points_used"))])
        sec.add(T(["run", "mean temperature, °C", f"SF ± 1σ, {sfu}", "ε0, ppm",
                       "bias (table fit) ± 1σ, °/h", "linearity max, ppm of FS", "points"],
                      rows, title="Per run (IEEE straight line, §12.9.4.1)", unit_in_header=True,
                      widths=[2.2, 1.4, 2.6, 1.1, 2.0, 1.5, 0.8], key="sf_runs"))
        # nonlinearity model
        nl = r.get("nonlinearity_model", {})
        rows = []
        for i, cf in enumerate(nl.get("coefficients", [])):
            extra = ""
            if cf.get("period_dps") is not None:
                extra = f" (period {fmt_number(cf['period_dps'])} °/s)"
            if cf.get("lock_in_rate_dps") is not None:
                extra = f" (Ω_L {fmt_number(cf['lock_in_rate_dps'])} °/s)"
            rows.append([cf["term"], cf["f_of_I"] + extra,
                         s.num(["nonlinearity_model", "coefficients", i, "coefficient_ppm"],
                               "ppm", ["nonlinearity_model", "coefficients", i, "sigma_ppm"]),
                         "yes" if cf.get("supported_by_data") else "no (shown for scale)"])
        if rows:
            sec.add(T(["term", "f(I), u = I/FS", "coefficient ± 1σ, ppm",
                           "supported by the data"], rows,
                          title="Rate-dependent scale-factor error f(I) of ε_K (§8.3)",
                          unit_in_header=True, widths=[1.5, 3.2, 2.2, 1.8], key="sf_model"))
        if nl.get("statement"):
            sec.add(P(f"Nonlinearity model: {nl['statement']} Selection: "
                         f"{nl.get('selection', '')}."))
        per = r.get("periodic", {})
        if per.get("supported_by_data"):
            sec.add(P("Rate-periodic error (optical feedback, §5.3.2.1 a): amplitude "
                         f"{s.t(['periodic', 'amplitude_ppm'], 'ppm', ['periodic', 'amplitude_sigma_ppm'])}"
                         f", period {s.t(['periodic', 'period_dps'], '°/s')}."))
        t = self.c.tests["scale_factor"]
        if t.conditions:
            sec.add(P(f"Conditions: {t.conditions}.", "note"))
        pe = [x for x in r.get("plateau_extraction", []) if x.get("settling_per_step")]
        if pe:
            w = max(pe, key=lambda x: x.get("settling_worst_s") or 0.0)
            step = w.get("settling_worst_step_dps") or [None, None]
            frm = f"{step[0]:+g}" if _isnum(step[0]) else "start"
            auto = all(x.get("settling_from_data") for x in pe)
            sec.add(P(f"Settling {'found in each plateau’s data' if auto else 'fixed'} (transient "
                      "against the plateau’s own noise floor): worst case "
                      f"{fmt_number(w['settling_worst_s'], 3)} s ({w['run']}, step {frm} → "
                      f"{step[1]:+g} °/s); every plateau’s settling time is in the JSON "
                      "(plateau_extraction.settling_per_step).", "note"))
        for n in r.get("notes", []):
            self.warn("scale-factor", n)
        fig = self.draw("scale_factor", lambda: _fig("scale_factor_figure", a.obj))
        self.figure(sec, fig, "Scale-factor linearity: deviation of each plateau from its run's "
                    "least-squares line (ppm of full scale, ±1σ) with the selected nonlinearity "
                    "model, and the model history.")
        return sec

    # ---------------------------------------------------------------- 3 drift
    def drift(self, sec: Section) -> Section:
        """Section 3: bias (3.1), random drift (3.2), noise structure (3.3), application (3.4)."""
        self.bias(sec.sub("Bias D_F", "§5.3.3.1.1"))
        self.random_drift(sec)
        return sec

    def bias(self, sec: Section) -> None:
        """Subsection 3.1: D_F ± 1σ, repeatability, per-run table, multi-position cross-check."""
        a = self.an.get("bias")
        if a is None:
            self.check("bias", "bias_dph", "bias D_F", "§5.3.3.1.1", None, sec.number)
            self.check("bias", "repeatability_1sigma_dph", "bias repeatability (1σ)",
                       "§5.3.3.1.1", None, sec.number)
            self.coef["D_F"] = None
            _not_tested(sec, "no static runs in the campaign ([tests.bias]).")
            return
        s = Src(a)
        r = a.result
        runs = r.get("runs", [])
        items = []
        if r.get("repeatability"):
            df = s.num(["repeatability", "mean_bias_dph"], U_DPH,
                       ["repeatability", "repeatability_1sigma_dph"])
            items.append(self.check("bias", "bias_dph", f"bias D_F, mean of {len(runs)} runs "
                                    "± 1σ run to run", "§5.3.3.1.1", df, sec.number))
            items.append(self.check("bias", "repeatability_1sigma_dph", "repeatability, 1σ",
                                    "§5.3.3.1.1", s.num(["repeatability",
                                                         "repeatability_1sigma_dph"], U_DPH),
                                    sec.number))
            items.append(self.check("bias", "repeatability_max_spread_dph",
                                    "repeatability, max spread", "§5.3.3.1.1",
                                    s.num(["repeatability", "repeatability_max_spread_dph"],
                                          U_DPH), sec.number))
            ch = Check("bias.within_run", "within-run 1σ of D_F (RMS over runs)", "§12.11.4.1.1",
                       s.num(["repeatability", "within_run_sigma_rms_dph"], U_DPH), None, U_DPH,
                       sec.number)
            self.checks.append(ch)
            items.append(ch)
            for n in r["repeatability"].get("notes", []):
                self.warn("bias", n)
        else:
            df = s.num(["runs", 0, "bias_D_F_dph"], U_DPH, ["runs", 0, "bias_sigma_dph"])
            items.append(self.check("bias", "bias_dph", "bias D_F ± 1σ", "§5.3.3.1.1", df,
                                    sec.number))
            items.append(self.check("bias", "repeatability_1sigma_dph", "repeatability (1σ)",
                                    "§5.3.3.1.1", None, sec.number))
        self.coef["D_F"] = df
        mp = self.an.get("multiposition")
        if mp is not None and mp.result.get("multi_position"):
            ch = Check("bias.multiposition", "bias D_F from the multi-position fit ± 1σ "
                       "(cross-check)", "§12.11.4.1.1",
                       Src(mp).num(["multi_position", "bias_D_F_dph"], U_DPH,
                                   ["multi_position", "bias_sigma_dph"]), None, U_DPH,
                       sec.number)
            self.checks.append(ch)
            items.append(ch)
        sec.add(_check_table(items, "Bias items"))
        rows = []
        for i, run in enumerate(runs):
            rows.append([Path(run["source"]).name,
                         s.num(["runs", i, "duration_s"], "s", digits=5),
                         s.num(["runs", i, "mean_output_dph"], U_DPH, digits=6),
                         s.num(["runs", i, "earth_rate_ia_dph"], U_DPH, digits=6),
                         s.num(["runs", i, "bias_D_F_dph"], U_DPH, ["runs", i, "bias_sigma_dph"]),
                         s.num(["runs", i, "uncertainty", "naive_sigma_over_sqrt_n_dph"], U_DPH,
                               digits=2),
                         s.num(["runs", i, "mean_temperature_c"], "°C", digits=3)])
        sec.add(T(["run", "used, s", "mean output, °/h", "earth rate along IA, °/h",
                       "D_F ± 1σ, °/h", "σ/√n, °/h (for comparison)", "temperature, °C"],
                      rows, title="Per run (after the warm-up trim)", unit_in_header=True,
                      widths=[2.3, 1.0, 1.4, 1.5, 1.8, 1.6, 1.5], key="bias_runs"))
        t = self.c.tests["bias"]
        skip = t.opt("skip", "0")
        sec.add(P("D_F = mean rate − earth-rate component along the IA after a "
                     f"{skip} warm-up trim; the 1σ of each run is the Allan deviation at the "
                     "record length from a fitted noise model (honest for correlated noise; "
                     "σ/√n shown only for comparison)."))
        if t.conditions:
            sec.add(P(f"Conditions between runs: {t.conditions}.", "note"))
        for run in runs:
            for n in run.get("notes", []):
                self.warn("bias", f"{Path(run['source']).name}: {n}")

    def random_drift(self, parent: Section) -> None:
        """Subsections 3.2-3.4 from the Allan analysis: N, B, K, R, Q with ≤ for bounds."""
        a = self.an.get("allan")
        sec = parent.sub("Random drift D_R and quantization D_Q", "§5.3.3.1.2, §5.3.3.1.3")
        labels = {"N": ("angle random walk N", "§5.3.3.1.2 a", U_ARW),
                  "B": ("bias instability B", "§5.3.3.1.2 b", U_DPH),
                  "K": ("rate random walk K", "§5.3.3.1.2 c", U_RRW),
                  "R": ("rate ramp R", "§5.3.3.1.2 d", U_RR),
                  "Q": ("quantization noise Q", "§5.3.3.1.3", "arcsec")}
        if a is None:
            for k, (lab, ieee, u) in labels.items():
                self.check("allan", k, lab, ieee, None, sec.number, u)
                self.coef[k] = None
            _not_tested(sec, "no Allan run in the campaign ([tests.allan]).")
            _not_tested(parent.sub("Noise structure"), "needs the Allan analysis.")
            _not_tested(parent.sub("Application note: platform vs strapdown"),
                        "needs the Allan analysis.")
            return
        s = Src(a)
        base = ["logs", 0, "axes", 0]
        ax = dig(a.result, base)
        fit = ax["fit"]
        terms = fit["terms"]
        idx = {t["key"]: i for i, t in enumerate(terms)}
        items = []
        for k, (lab, ieee, u) in labels.items():
            if k not in idx:
                self.coef[k] = None
                items.append(self.check("allan", k, lab + " (not fitted)", ieee, None,
                                        sec.number, u))
                continue
            i = idx[k]
            tp = base + ["fit", "terms", i]
            if terms[i]["status"] == "identified":
                n = s.num(tp + ["params", k], u, tp + ["sigma", k])
            else:
                n = s.num(tp + ["upper_95"], u, bound=True)
            self.coef[k] = n
            items.append(self.check("allan", k, lab, ieee, n, sec.number, u))
        sec.add(_check_table(items, "Allan-variance coefficients (joint fit; ≤: upper bound "
                                    "only, 95 % profile likelihood; ±: 1σ)"))
        rr = dig(a.result, ["logs", 0])
        fp = base + ["fit"]
        txt = (f"Joint fit of {','.join(fit['terms_requested'])} to the overlapping Allan "
               f"deviation over τ = {s.t(fp + ['fit_range_s', 0], 's')} … "
               f"{s.t(fp + ['fit_range_s', 1], 's')}: χ²/dof = "
               f"{s.t(fp + ['chi2_per_dof'], digits=3)}, p = {s.t(fp + ['p_value'], digits=2)}"
               f" ({'consistent' if fit.get('consistent') else 'the model misfits'}). Record: "
               f"{s.t(['logs', 0, 'duration_s'], 's', digits=6)} after the "
               f"{self.c.tests['allan'].opt('skip', '0')} warm-up trim, τ0 = "
               f"{s.t(['logs', 0, 'tau0_s'], 's')}.")
        sec.add(P(txt))
        dg = ax.get("diagnosis")
        if dg and dg.get("verdict"):
            sec.add(P(f"Diagnosis of missing terms: {dg['verdict']}", "note"))
        self.noise_structure(parent.sub("Noise structure", "Annex C"), a, s, base, ax)
        self.application(parent.sub("Application note: platform vs strapdown"), a, s, base, ax)
        for w in ax.get("warnings", []):
            self.warn("allan", f"{w['title']}: {w['message']}", w.get("code", ""),
                      "warning" if w.get("severity", "warning") == "warning" else "note")
        for n in ax.get("notes", []) + rr.get("notes", []):
            self.warn("allan", n, kind="note")
        fig = self.draw("allan", lambda: _fig("allan_figure", rr["source"], a.obj.axes[0]))
        self.figure(sec, fig, "Overlapping Allan deviation of the static run with χ² "
                    "confidence intervals, the fitted noise model and its components; below, "
                    "the residual per τ in units of the confidence interval.")

    def noise_structure(self, sec: Section, a, s: Src, base: list, ax: dict) -> None:
        """Subsection 3.3: Krobka's noise-structure table (value, status, τ range, S(0))."""
        terms = ax["fit"]["terms"]
        rows = []
        for i, t in enumerate(terms):
            tp = base + ["fit", "terms", i]
            main = next(iter(t["params"]))
            unit = _unit(t["units"].get(main, ""))
            if t["status"] == "identified":
                val = s.num(tp + ["params", main], unit, tp + ["sigma", main])
            else:
                val = s.num(tp + ["upper_95"], unit, bound=True)
            dom = t.get("dominant_tau_s")
            domt = (f"{fmt_number(dom[0], 3)} … {fmt_number(dom[1], 3)}" if dom else
                    "nowhere dominant")
            extra = [f"{k} = {fmt_number(v)} {_unit(t['units'].get(k, ''))}".strip()
                     for k, v in t["params"].items() if k != main]
            rows.append([f"{t['label']} ({t['title']})" + (f"; {', '.join(extra)}" if extra
                                                          else ""),
                         val, t["status"], domt,
                         "0: " + t["label_impact"] if t.get("zero_dc_psd") else "> 0"])
        sec.add(T(["component", "value", "status", "dominates at τ, s",
                       "PSD at f = 0 (strapdown note)"], rows,
                      title="Noise components (what drives the error, and where)",
                      widths=[3.0, 2.2, 1.4, 1.6, 2.6], key="noise_structure"))
        ro = ax.get("slope_readoffs", {})
        lines = [
            f"Input: {ax.get('input', '')}. Output rate {s.t(['logs', 0, 'sample_rate_hz'], 'Hz')} "
            f"(τ0 = {s.t(['logs', 0, 'tau0_s'], 's')}); no filter applied by gyrotest (each sample is "
            "the average rate over τ0, as a pulse integrator delivers it).",
            "PSD normalisation: two-sided rate PSD in the IEEE 952 convention (white rate noise "
            "S = N²); the Allan variance is σ²(τ) = 4∫S(f)·sin⁴(πfτ)/(πfτ)² df.",
        ]
        if "N_upper" in ro:
            lines.append(
                "Graph read-offs for comparison (Krobka): "
                f"N_upper = min σ√τ/60 = {s.t(base + ['slope_readoffs', 'N_upper'], U_ARW)}"
                f" (ray through the leftmost point); B_tangent = σ_min/0.664 = "
                f"{s.t(base + ['slope_readoffs', 'B_tangent'], U_DPH)} (an upper bound "
                "in a mixture); Allan floor σ_min = "
                f"{s.t(base + ['slope_readoffs', 'allan_floor_dph'], U_DPH)} at τ = "
                f"{s.t(base + ['slope_readoffs', 'allan_floor_tau_s'], 's')}.")
        lines.append("A coefficient the graph cannot establish is given as an upper bound (≤). "
                     "Noises with zero PSD at zero frequency stay bounded on a platform but "
                     "grow in strapdown: a single drift number does not describe the gyro.")
        for ln in lines:
            sec.add(P(ln))

    def application(self, sec: Section, a, s: Src, base: list, ax: dict) -> None:
        """Subsection 3.4: platform vs strapdown attitude error at the vehicle rates."""
        imp = ax.get("impact")
        if not imp:
            _not_tested(sec, "the analysis gave no impact prediction.")
            return
        ip = base + ["impact"]
        hz = imp["horizon_s"]
        rows = [["inertially stabilised platform", "—",
                 s.num(ip + ["platform", "sigma_att_deg"], "°", digits=3),
                 "1", s.num(ip + ["platform", "conservative_sigma_att_deg"], "°", digits=3)]]
        for i in range(len(imp.get("strapdown", []))):
            rows.append(["strapdown, constant rate about one gyro axis",
                         s.num(ip + ["strapdown", i, "vehicle_rate_deg_s"], "°/s", digits=3),
                         s.num(ip + ["strapdown", i, "sigma_att_deg"], "°", digits=3),
                         s.num(ip + ["strapdown", i, "sins_to_ins_ratio"], "", digits=3),
                         s.num(ip + ["strapdown", i, "conservative_sigma_att_deg"], "°",
                               digits=3)])
        if not imp.get("strapdown"):
            sec.add(P("No vehicle rates given ([tests.allan] vehicle_rates): only the "
                      "platform case is predicted.", "note"))
        sec.add(T(["system", "vehicle rate", f"attitude error σ after {fmt_number(hz)} s",
                       "σ ratio strapdown/platform", "σ with the bounds at their limit"], rows,
                      title="Predicted attitude error of three such gyros (first order)",
                      widths=[3.2, 1.3, 2.0, 1.5, 1.8], key="impact"))
        comps = imp.get("components", [])
        if comps:
            rates = imp.get("strapdown", [])
            crow = []
            for i, c in enumerate(comps):
                cp = ip + ["components", i]
                crow.append([c["term"] + ("  (S(0) = 0)" if c.get("zero_dc_psd") else ""),
                             s.num(cp + ["platform_sigma_deg"], "", digits=3)]
                            + [s.num(cp + ["strapdown_sigma_deg", j], "", digits=3)
                               for j in range(len(rates))])
            sec.add(T(["component", "platform σ, °"]
                      + [f"strapdown at {fmt_number(r['vehicle_rate_deg_s'], 3)} °/s, σ, °"
                         for r in rates], crow,
                      title=f"Contribution of each noise component after {fmt_number(hz)} s",
                      unit_in_header=True, key="impact_components"))
        tab = ax.get("table", [])
        k100 = next((i for i, row in enumerate(tab) if abs(row["tau"] / 100.0 - 1) < 0.01
                     and row.get("sigma") is not None), None)
        if k100 is not None:
            sec.add(P("For comparison, the drift in the old integral sense, σ(τ = "
                      f"{s.t(base + ['table', k100, 'tau'], 's')}) = "
                      f"{s.t(base + ['table', k100, 'sigma'], U_DPH)}, is one number: it cannot "
                      "tell how the error grows in a strapdown system, where the components "
                      "above add differently.", "note"))
        for fl in imp.get("flags", []):
            sec.add(P(fl.get("text", ""), "note"))
        sec.add(P("Assumptions: " + "; ".join(imp.get("assumptions", [])) + ". Method: "
                     + imp.get("method", "") + "."))

    # ---------------------------------------------------------------- 4 environment
    def environment(self, sec: Section) -> Section:
        """Section 4: thermal, magnetic, supply and model-history subsections."""
        self.thermal(sec.sub("Thermal: D_T, D_Ṫ, D_∇Ṫ and the Antonova–Matveev model"))
        self.magnetic(sec.sub("Magnetic field: w_x, w_y, w_z"))
        self.supply(sec.sub("Supply voltage"))
        self.history(sec.sub("Model history: the error falling as terms are added"))
        st = [s.status for s in sec.subsections]
        if all(x == NOT_TESTED for x in st):
            sec.status = NOT_TESTED
        elif NOT_TESTED in st:
            sec.status = "partly tested"
        return sec

    def thermal(self, sec: Section) -> None:
        """Subsection 4.1: IEEE E terms and the Antonova–Matveev coefficients."""
        a = self.an.get("thermal")
        ieee_lab = {"D_T": ("drift temperature sensitivity D_T", "(°/h)/°C"),
                    "D_Tdot": ("temperature-ramp sensitivity D_Ṫ", "(°/h)/(°C/h)"),
                    "D_gradTdot": ("gradient-rate sensitivity D_∇Ṫ", "(°/h)/(°C/h)")}
        ch = (a.result.get("chamber") if a else None) or None
        if ch is None:
            for k, (lab, u) in ieee_lab.items():
                self.check("thermal", k, lab, "§8.3 E", None, sec.number, u)
                self.coef[k] = None
            if a is None or not a.result.get("setpoints"):
                _not_tested(sec, "no thermal-chamber run in the campaign ([tests.thermal]).")
                return
        s = Src(a)
        if ch is not None:
            items = []
            for i, c in enumerate(ch.get("ieee_E_terms", [])):
                lab, u = ieee_lab.get(c["name"], (c["name"], _unit(c["unit"])))
                n = s.num(["chamber", "ieee_E_terms", i, "value"], u,
                          ["chamber", "ieee_E_terms", i, "stderr"])
                self.coef[c["name"]] = n
                items.append(self.check("thermal", c["name"], lab, "§8.3 E", n, sec.number, u))
            for k, (lab, u) in ieee_lab.items():
                if k not in self.coef:
                    self.coef[k] = None
                    items.append(self.check("thermal", k, lab + " (not fitted)", "§8.3 E", None,
                                            sec.number, u))
            sec.add(_check_table(items, f"IEEE 952 E terms (ΔT from t0 = "
                                        f"{fmt_number(ch['t0_degC'])} °C, sensor "
                                        f"{ch['sensor']}; ± 1σ HAC)"))
            rows = []
            am_lab = {"w0": "offset w0", "w1": "linear w1", "w2": "quadratic w2",
                      "w_dV": "temperature-rate w_ΔV"}
            for i, c in enumerate(ch.get("coefficients", [])):
                rows.append([am_lab.get(c["name"], c["name"]),
                             s.num(["chamber", "coefficients", i, "value"], _unit(c["unit"]),
                                   ["chamber", "coefficients", i, "stderr"])])
            sec.add(T(["coefficient", "value ± 1σ"], rows,
                          title="Antonova–Matveev model Δω = w0 + w1·ΔT + w2·ΔT² + "
                                "w_ΔV·dT/dt (ΔT in °C, dT/dt in °C/h)",
                          widths=[3.0, 4.0], key="am"))
            f = ch.get("fit", {})
            sec.add(P(
                "Fit quality: residual RMS "
                f"{s.t(['chamber', 'fit', 'rms_fit_dph'], U_DPH)}, held-out "
                f"{s.t(['chamber', 'fit', 'rms_holdout_dph'], U_DPH)}, noise "
                f"floor (fixed for the log) {s.t(['chamber', 'fit', 'noise_floor_dph'], U_DPH)}; "
                f"working resolution: {f.get('resolution_note', '')}."))
            h = ch.get("hysteresis", {})
            if "heating_minus_cooling_dph" in h:
                sec.add(P("Heating − cooling residual: "
                             f"{s.t(['chamber', 'hysteresis', 'heating_minus_cooling_dph'], U_DPH, ['chamber', 'hysteresis', 'stderr_dph'])}"
                             f" ({h.get('verdict', '')})."))
            for n in ch.get("notes", []):
                sec.add(P(n, "note"))
            for w in dig(ch, ["am_fit", "warnings"]) or []:
                self.warn("thermal-fit", w)
        sp = a.result.get("setpoints")
        if sp:
            rows = []
            for i, c in enumerate(sp.get("coefficients", [])):
                rows.append([c["name"], s.num(["setpoints", "coefficients", i, "value"],
                                              _unit(c["unit"]),
                                              ["setpoints", "coefficients", i, "stderr"])])
            sec.add(T(["coefficient", "value ± 1σ"], rows,
                          title="Steady-state set-points: Δω = w0 + w1·ΔT + w2·ΔT²",
                          key="setpoints"))
        t = self.c.tests["thermal"]
        if t.conditions:
            sec.add(P(f"Conditions: {t.conditions}.", "note"))
        if ch is not None:
            figs = self.draw("thermal", lambda: _fig("thermal_figures", a.obj.chamber)) or []
            caps = {"thermal_thermal": "Thermal run: drift against temperature (heating and "
                    "cooling coloured) with the static Antonova–Matveev curve, and the "
                    "temperature-rate term.",
                    "thermal_time": "Thermal run: measured drift and the Antonova–Matveev model "
                    "over time, the residual, and the temperatures."}
            for f in figs:
                self.figure(sec, f, caps.get(f.key, ""))

    def magnetic(self, sec: Section) -> None:
        """Subsection 4.2: w_x, w_y, w_z with the reversal and hysteresis cross-checks."""
        a = self.an.get("magnetic")
        if a is None:
            for k in ("wx", "wy", "wz"):
                self.check("magnetic", k, f"magnetic sensitivity w_{k[1]}", "§5.3.3.2", None,
                           sec.number, "°/h per 100 µT")
                self.coef[k] = None
            _not_tested(sec, "no Helmholtz-coil run in the campaign ([tests.magnetic]).")
            return
        s = Src(a)
        r = a.result
        items = []
        for i, c in enumerate(r.get("coefficients", [])):
            n = s.num(["coefficients", i, "value"], "°/h per 100 µT", ["coefficients", i, "stderr"])
            self.coef[c["name"]] = n
            items.append(self.check("magnetic", c["name"], f"magnetic sensitivity w_{c['name'][1]}",
                                    "§5.3.3.2", n, sec.number, "°/h per 100 µT"))
        for k in ("wx", "wy", "wz"):
            self.coef.setdefault(k, None)
        sec.add(_check_table(items, "Δω(H) = w0 + w_x·H_x/H0 + w_y·H_y/H0 + w_z·H_z/H0, H0 = "
                                    "100 µT (± 1σ HAC)"))
        rows = []
        for ax_ in "xyz":
            rv = r.get("reversal_K", {}).get(ax_)
            hy = r.get("sweep_hysteresis", {}).get(ax_)
            if not rv and not hy:
                continue
            rows.append([ax_.upper(),
                         s.num(["reversal_K", ax_, "signed_dph_per_100uT"], "°/h per 100 µT")
                         if rv else "—",
                         s.num(["sweep_hysteresis", ax_, "up_minus_down_dph"], U_DPH,
                               ["sweep_hysteresis", ax_, "stderr_dph"]) if hy else "—",
                         hy.get("verdict", "") if hy else ""])
        if rows:
            sec.add(T(["axis", "reversal estimate K = Δω/(2·max/H0)",
                           "up − down sweep", "hysteresis"], rows,
                          title="Cross-checks (Antonova & Matveev's reversal estimate; sweep "
                                "hysteresis)", widths=[0.8, 2.6, 2.2, 3.6], key="mag_checks"))
        for n in r.get("notes", []):
            sec.add(P(n, "note"))
        for w in dig(r, ["fit", "warnings"]) or []:
            self.warn("mag-fit", w)
        t = self.c.tests["magnetic"]
        if t.conditions:
            sec.add(P(f"Conditions: {t.conditions}.", "note"))
        fig = self.draw("magnetic", lambda: _fig("magnetic_figure", a.obj))
        self.figure(sec, fig, "Helmholtz-coil run: mean drift of each field level against the "
                    "applied field, per axis, with the fitted sensitivity.")

    def supply(self, sec: Section) -> None:
        """Subsection 4.3: supply-voltage sensitivity ('model fit --terms V')."""
        a = self.an.get("supply")
        if a is None:
            self.check("supply", "supply_dph_per_v", "supply-voltage sensitivity", "§8.3 E",
                       None, sec.number, "(°/h)/V")
            self.coef["V"] = None
            _not_tested(sec, "no supply-voltage run in the campaign ([tests.supply]).")
            return
        s = Src(a)
        coefs = a.result.get("coefficients", [])
        i = next((j for j, c in enumerate(coefs) if c.get("term", "").startswith("V")), None)
        n = None
        if i is not None:
            n = s.num(["coefficients", i, "value"], _unit(coefs[i]["unit"]),
                      ["coefficients", i, "stderr"])
        self.coef["V"] = n
        sec.add(_check_table([self.check("supply", "supply_dph_per_v",
                                         "supply-voltage sensitivity", "§8.3 E", n, sec.number,
                                         "(°/h)/V")]))
        for w in a.result.get("warnings", []) or []:
            self.warn("model fit (supply)", w)

    def history(self, sec: Section) -> None:
        """Subsection 4.4: the model-fit steps of the thermal run, error falling."""
        steps = [self.an[k] for k in sorted((k for k in self.an if k.startswith("thermal.step")),
                                            key=lambda k: int(k[len("thermal.step"):]))]
        if not steps:
            _not_tested(sec, "no model steps given ([tests.thermal] model_steps).")
            return
        rows = []
        prev: list[str] = []
        for a in steps:
            s = Src(a)
            terms = [t for t in a.result.get("terms", []) if t != "bias"]
            added = [t for t in terms if t not in prev]
            prev = terms
            rows.append([", ".join(terms) or "(bias only)",
                         " ".join("+" + t for t in added) or "(same)",
                         s.num(["n_params"], "", digits=3),
                         s.num(["rms_fit_dph"], U_DPH, digits=3),
                         s.num(["rms_holdout_dph"], U_DPH, digits=3),
                         s.num(["noise_floor", "rms_dph"], U_DPH, digits=3),
                         s.num(["aic"], "", digits=6)])
        sec.add(T(["terms", "added", "params", "RMS fit, °/h", "RMS held-out, °/h",
                       "noise floor, °/h", "AIC"], rows,
                      title=f"Successive 'gyrotest model fit' steps on "
                            f"{Path(steps[0].argv[2]).name}", unit_in_header=True,
                      widths=[3.0, 1.7, 1.0, 1.2, 1.4, 1.3, 1.2], key="history"))
        last = steps[-1].result
        ho = last.get("rms_holdout_dph")
        fl = (last.get("noise_floor") or {}).get("rms_dph")
        end = ""
        if isinstance(ho, (int, float)) and isinstance(fl, (int, float)) and fl > 0:
            r = ho / fl
            end = (f" The last step's held-out RMS is {r:.2g}× the noise floor (fixed for the "
                   "log, from its short-τ noise): "
                   + ("the model has reached the floor." if r <= 1.1 else
                      "drift remains that these terms do not explain; 'gyrotest model "
                      "diagnose' tries every candidate term on it."))
        sec.add(P("Each step adds a physical term; the held-out RMS (blocked cross-"
                     "validation) falls while the term explains real drift and stops falling "
                     "at the noise floor." + end))
        fig = self.draw("history", lambda: _fig("history_figure",
                                                ad.history_steps(steps)))
        self.figure(sec, fig, "Model history of the thermal run: residual RMS (fit, held-out, "
                    "noise floor) and information criteria per step.")

    # ---------------------------------------------------------------- 5 alignment
    def alignment(self, sec: Section) -> Section:
        """Section 5: IA alignment from the multi-position fit."""
        a = self.an.get("multiposition")
        mp = a.result.get("multi_position") if a else None
        if mp is None:
            self.check("multiposition", "azimuth_misalignment_deg", "IA azimuth misalignment",
                       "§5.3.4.1", None, sec.number, "°")
            self.coef["theta"] = None
            why = ("no multi-position run in the campaign ([tests.multiposition])." if a is None
                   else "the multi-position log has a single IA direction.")
            return _not_tested(sec, why)
        s = Src(a)
        p = ["multi_position"]
        mis = s.num(p + ["azimuth_misalignment_deg"], "°", p + ["azimuth_misalignment_sigma_deg"])
        self.coef["theta"] = mis
        items = [self.check("multiposition", "azimuth_misalignment_deg",
                            "IA azimuth misalignment (about the vertical, from the fitted east "
                            "earth-rate component)", "§5.3.4.1", mis, sec.number, "°")]
        for k in ("north", "east", "up"):
            if mp["earth_rate_fit_dph"].get(k) is not None:
                ch = Check(f"multiposition.earth_{k}", f"earth rate, {k} component (fitted)",
                           "§12.11.4.1.1", s.num(p + ["earth_rate_fit_dph", k], U_DPH,
                                                 p + ["earth_rate_fit_sigma_dph", k], digits=6),
                           None, U_DPH, sec.number)
                self.checks.append(ch)
                items.append(ch)
        if mp.get("latitude_est_deg") is not None:
            ch = Check("multiposition.latitude", "latitude check (given "
                       f"{fmt_number(mp.get('latitude_given_deg'), 6)}°)", "—",
                       s.num(p + ["latitude_est_deg"], "°", p + ["latitude_est_sigma_deg"]),
                       None, "°", sec.number)
            self.checks.append(ch)
            items.append(ch)
        if mp.get("ia_tilt_north_deg") is not None:
            ch = Check("multiposition.tilt", "apparent IA tilt towards north", "§5.3.4.1",
                       s.num(p + ["ia_tilt_north_deg"], "°"), None, "°", sec.number)
            self.checks.append(ch)
            items.append(ch)
        sec.add(_check_table(items, "Alignment items"))
        rows = []
        for i, q in enumerate(mp.get("positions", [])):
            rows.append([q["label"].split(" (")[0],
                         s.num(p + ["positions", i, "ia_azimuth_deg"], "°", digits=4),
                         s.num(p + ["positions", i, "ia_elevation_deg"], "°", digits=3),
                         s.num(p + ["positions", i, "mean_output_dph"], U_DPH,
                               p + ["positions", i, "sigma_dph"]),
                         s.num(p + ["positions", i, "residual_dph"], U_DPH, digits=3)])
        sec.add(T(["position", "nominal IA azimuth, °", "nominal IA elevation, °",
                       "mean output ± 1σ, °/h", "fit residual, °/h"], rows,
                      title="Positions (mean output = D_F + earth rate along the IA)",
                      unit_in_header=True, widths=[1.5, 1.6, 1.6, 2.2, 1.6], key="positions"))
        chi = mp.get("chi2_per_dof")
        sec.add(P("The fixture indexes the IA through the listed directions; the fit "
                     "m_p = D_F + Ω_E·u_p separates the bias from the earth rate. The azimuth "
                     "misalignment is the rotation of the horizontal IA positions about the "
                     "vertical with respect to their nominal directions (fixture and IA "
                     "together)" + (f"; χ²/dof of the position fit "
                                    f"{s.t(p + ['chi2_per_dof'], digits=3)}"
                                    if chi is not None else "") + "."))
        for n in mp.get("notes", []):
            self.warn("bias (multi-position)", n)
        t = self.c.tests["multiposition"]
        if t.conditions:
            sec.add(P(f"Conditions: {t.conditions}.", "note"))
        return sec

    # ---------------------------------------------------------------- 1 model equation
    def model_equation(self, sec: Section) -> None:
        """Section 1: the §8.3 model equation with the coefficients of sections 2-5."""
        c = self.coef

        def v(key: str, digits: int = 3, signed: bool = False) -> str:
            """A coefficient as equation text (signed: with its sign operator)."""
            n = c.get(key)
            if n is None or n.value is None:
                return "(not tested)"
            txt = fmt_number(n.value, digits, strip=False)
            if signed:
                txt = ("− " + txt[1:]) if txt.startswith("−") else ("+ " + txt)
            return ("≤ " if n.bound else "") + txt

        def eq(key: str, unit: str) -> str:
            """"= value unit", "≤ bound unit" or "not tested"."""
            t = v(key)
            if t == "(not tested)":
                return "not tested"
            return (t if t.startswith("≤") else "= " + t) + " " + unit

        def vu(key: str, unit: str, digits: int = 3) -> str:
            """Value with unit, or "(not tested)"."""
            t = v(key, digits)
            return t if t == "(not tested)" else f"{t}{unit}"

        def have(*keys: str) -> bool:
            """True when any of the coefficients was measured."""
            return any(c.get(k) is not None and c[k].value is not None for k in keys)

        u = self.sf_unit()
        s0 = self.c.gyro.get("nominal_scale_factor")
        pulse = u == "arcsec/pulse"
        lhs = "S0·ΔN/Δt" if pulse or not u else "S0·V"
        t0 = self.c.tests.get("thermal")
        t0v = f"{fmt_number(float(t0.opt('t0', 21.0)))} °C" if t0 else "the reference"
        e_terms = []
        if have("D_T", "D_Tdot", "D_gradTdot"):
            e_terms.append(f"{v('D_T')}·ΔT {v('D_Tdot', 3, True)}·dT/dt "
                           f"{v('D_gradTdot', 3, True)}·d(∇T)/dt")
        else:
            e_terms.append("(thermal terms not tested)")
        if have("wx", "wy", "wz"):
            e_terms.append(f"({v('wx')}·H_x {v('wy', 3, True)}·H_y {v('wz', 3, True)}·H_z)"
                           "/100 µT")
        else:
            e_terms.append("(magnetic terms not tested)")
        if have("V"):
            e_terms.append(f"{v('V')}·ΔV")
        lines = [
            f"{lhs} = [I + E + D]·[1 + 10⁻⁶·ε_K]⁻¹",
            "",
            f"S0  = {fmt_number(s0) if s0 is not None else '(not given)'} {u} (nominal);"
            f" fitted SF = {vu('SF', ' ' + u, 8)}",
            "I   = ω_IRA + ω_XRA·sinΘ_Y − ω_YRA·sinΘ_X",
            f"      IA azimuth misalignment = {vu('theta', '°')}",
            "E   = D_T·ΔT + D_Ṫ·dT/dt + D_∇Ṫ·d(∇T)/dt + (w_x·H_x + w_y·H_y + w_z·H_z)/H0",
            f"    = {e_terms[0]}",
            *[f"      + {t}" for t in e_terms[1:]],
            f"      [°/h; ΔT in °C from {t0v}, dT/dt in °C/h, H in µT]",
            "D   = D_F + D_R + D_Q",
            f"D_F = {vu('D_F', ' °/h', 4)}",
            f"D_R : N {eq('N', '°/√h')}, B {eq('B', '°/h')},",
            f"      K {eq('K', '(°/h)/√h')}, R {eq('R', '(°/h)/h')}",
            f"D_Q : Q {eq('Q', 'arcsec')}",
            "ε_K = ε_0 + ε_T·ΔT + f(I)",
            (f"    = {v('eps0', 4)} {v('epsT', 3, True)}·ΔT + f(I) ppm   (f(I): §2)"
             if have("eps0") else "    = (scale factor not tested)")
            if have("epsT") or not have("eps0") else
            f"    = {v('eps0', 4)} + f(I) ppm   (ε_T not measured; f(I): §2)",
        ]
        sec.add(Equation(lines))
        rows = []
        names = [("SF", "scale factor SF", "2"), ("eps0", "scale-factor error ε_0", "2"),
                 ("epsT", "SF temperature sensitivity ε_T", "2"),
                 ("D_F", "bias D_F", "3.1"), ("N", "angle random walk N", "3.2"),
                 ("B", "bias instability B", "3.2"), ("K", "rate random walk K", "3.2"),
                 ("R", "rate ramp R", "3.2"), ("Q", "quantization Q", "3.2"),
                 ("D_T", "D_T", "4.1"), ("D_Tdot", "D_Ṫ", "4.1"), ("D_gradTdot", "D_∇Ṫ", "4.1"),
                 ("wx", "w_x", "4.2"), ("wy", "w_y", "4.2"), ("wz", "w_z", "4.2"),
                 ("V", "supply sensitivity", "4.3"),
                 ("theta", "IA azimuth misalignment", "5")]
        for k, lab, where in names:
            n = c.get(k)
            rows.append([lab, n if n is not None else "not tested", where])
        sec.add(T(["coefficient", "value", "section"], rows,
                      title="Coefficients substituted above (± 1σ; ≤: upper bound)",
                      widths=[3.0, 3.4, 0.9], key="coefficients"))
        sec.add(P("I: inertial input (ω along the reference axes), E: environmental terms, "
                     "D: drift (bias D_F, random drift D_R, quantization D_Q), ε_K: scale-factor "
                     "error in ppm. A term that was not measured reads \"not tested\"."))

    # ---------------------------------------------------------------- 6 conditions
    def conditions(self, sec: Section) -> Section:
        """Section 6: logs as read, input files with SHA-256, equivalent commands."""
        titles = {"bias": "bias runs", "allan": "Allan run", "scale_factor": "rate-table runs",
                  "thermal": "thermal-chamber run", "magnetic": "Helmholtz-coil run",
                  "multiposition": "multi-position run", "supply": "supply-voltage run"}
        used: dict[str, list[str]] = {}
        for name, t in self.c.tests.items():
            for p in t.logs:
                used.setdefault(self.c.rel(p), []).append(titles[name])
        rows = []
        for rel, tests in used.items():
            a = self.an.get(f"info:{rel}")
            if a is None:
                continue
            s = Src(a)
            r = a.result
            chans = r.get("channels", {})
            temps = [k for k in chans if k.startswith("temperature:")]
            trange = "—"
            if temps:
                k = temps[0]
                trange = (f"{s.t(['channels', k, 'min'], '', digits=3)} … "
                          f"{s.t(['channels', k, 'max'], '', digits=3)}")
            extra = []
            if "table_rate" in chans:
                extra.append(f"table {s.t(['channels', 'table_rate', 'min'], '', digits=3)}"
                             f" … {s.t(['channels', 'table_rate', 'max'], '', digits=3)}"
                             " °/s")
            fields = [k for k in chans if k.startswith("field:")]
            if fields:
                lo = min(chans[k]["min"] for k in fields)
                extra.append(f"field ({len(fields)} axes) {fmt_number(lo, 3)} … "
                             f"{fmt_number(max(chans[k]['max'] for k in fields), 3)} µT")
            if r.get("positions"):
                extra.append("positions " + ", ".join(r["positions"]))
            if len(temps) > 1:
                extra.append(f"{len(temps)} temperature channels")
            gaps = dig(r, ["timing", "gaps"]) or []
            if gaps:
                extra.append(f"{len(gaps)} gap(s)")
            rows.append([", ".join(tests), rel,
                         s.num(["timing", "samples"], "", digits=7),
                         s.num(["timing", "sample_rate_hz"], "", digits=4),
                         s.num(["timing", "duration_s"], "", digits=6),
                         trange, "; ".join(extra) or "—"])
        if rows:
            sec.add(T(["test", "file", "samples", "sample rate, Hz", "duration, s",
                           "temperature, °C (min … max)", "other"], rows,
                          title="Logs (as read by 'gyrotest info')", unit_in_header=True,
                          widths=[1.6, 2.2, 1.1, 0.9, 1.1, 1.6, 2.2], key="logs"))
        else:
            sec.add(P("No logs.", "note"))
        rows = [[f["file"], f["sha256"]] for f in self.input_files()]
        rows.insert(0, [self.c.path.name + " (campaign)", self.c.sha256])
        sec.add(T(["input file", "SHA-256"], rows, title="Input files", widths=[2.4, 6.4],
                      key="files"))
        rows = [[a.key.split(":")[0] if not a.key.startswith("info:") else "info",
                 " ".join(_quote(x) for x in ["gyrotest", *a.argv])]
                for a in self.an.values() if not a.key.startswith("info:")]
        sec.add(T(["analysis", "equivalent command (run in the campaign directory; add "
                       "--json for the numbers)"], rows, title="Commands", widths=[1.3, 7.5],
                      key="commands"))
        sec.add(P(f"Generated by gyrotest {__version__} from {self.c.path.name}; "
                     "'gyrotest report' calls the same analysis functions as these commands, so "
                     "each number in this sheet equals the one the command prints."))
        return sec

    def identity_checks(self) -> None:
        """Warn when a log's profile names another model, serial or S0 than the campaign."""
        g = self.c.gyro
        seen = set()
        for a in self.an.values():
            for lg in a.logs:
                if id(lg) in seen:
                    continue
                seen.add(id(lg))
                gy = lg.gyro
                name = Path(lg.source).name
                if gy.model and gy.model != g["model"]:
                    self.warn("campaign", f"{name}: gyro model {gy.model!r} in its profile, "
                              f"{g['model']!r} in the campaign")
                if gy.serial and gy.serial != g["serial"]:
                    self.warn("campaign", f"{name}: serial {gy.serial!r} in its profile, "
                              f"{g['serial']!r} in the campaign")
                s0 = g.get("nominal_scale_factor")
                if s0 is not None and gy.scale_factor is not None and \
                        abs(gy.scale_factor / s0 - 1) > 1e-12:
                    self.warn("campaign", f"{name}: S0 = {gy.scale_factor:g} in its profile, "
                              f"{s0:g} in the campaign")

    # ---------------------------------------------------------------- 7, 8
    def warnings_section(self, sec: Section) -> Section:
        """Section 7: warnings first, then notes, with their source."""
        if not self.warnings:
            sec.add(P("None."))
            return sec
        order = sorted(self.warnings, key=lambda w: w.get("kind") != "warning")
        rows = [[w["source"], w.get("kind", "warning") + (f" {w['code']}" if w.get("code")
                                                           else ""), w["text"]]
                for w in order]
        sec.add(T(["from", "kind", "text"], rows, widths=[1.4, 1.5, 7.0], key="warnings"))
        return sec

    def compliance(self, sec: Section) -> Section:
        """Section 8: every item with a limit, the verdict rule, and what was not tested."""
        limited = [c for c in self.checks if c.limit is not None]
        if not limited:
            sec.add(P("No limits given in the campaign: every item reads \"no limit given\"."))
        else:
            sec.add(_check_table(limited, "Items with a limit"))
        sec.add(P("Rule: " + VERDICT_RULE))
        nolim = [c for c in self.checks if c.limit is None and c.verdict != NOT_TESTED
                 and c.key.split(".")[1] in LIMITS.get(c.key.split(".")[0], {})]
        if nolim:
            sec.add(P("No limit given for: " + "; ".join(sorted({c.label for c in nolim}))
                      + "."))
        nt = sorted({c.label for c in self.checks if c.verdict == NOT_TESTED})
        if nt:
            sec.add(P("Not tested: " + "; ".join(nt) + "."))
        return sec


def _fig(name: str, *args):
    from . import figures

    return getattr(figures, name)(*args)


def _unit(u: str) -> str:
    """Sheet spelling of a core unit string."""
    rep = {"deg/sqrt(h)": U_ARW, "deg/h/sqrt(h)": U_RRW, "deg/h/h": U_RR, "deg/h": U_DPH,
           "deg/(h·degC)": "(°/h)/°C", "deg/(h·degC^2)": "(°/h)/°C²",
           "deg/degC = (deg/h)/(degC/h)": "(°/h)/(°C/h)", "(deg/h)/degC": "(°/h)/°C",
           "(deg/h)/(degC/h)": "(°/h)/(°C/h)", "deg/h per 100 uT": "°/h per 100 µT",
           "(deg/h)/V": "(°/h)/V", "deg/s": "°/s", "degC": "°C"}
    return rep.get(u, u)


def _quote(x: str) -> str:
    import shlex

    return shlex.quote(x)


def build_sheet(campaign: Campaign, analyses: dict[str, ad.Analysis], *, figures: bool = True
                ) -> Sheet:
    """Lay out the sheet from the analyses (figures drawn when ``figures``)."""
    Src.sink.clear()
    b = Builder(campaign, analyses, figures)
    sheet = b.build()
    sheet.provenance["timing_s"] = {**{a.key: a.seconds for a in analyses.values()},
                                    **b.timing}
    return sheet


def make_report(campaign: Campaign, *, figures: bool = True,
                progress: Callable[[str], None] | None = None) -> Sheet:
    """Run the campaign and build its sheet."""
    t0 = time.perf_counter()
    an = run_campaign(campaign, progress=progress)
    t1 = time.perf_counter()
    sheet = build_sheet(campaign, an, figures=figures)
    sheet.provenance["timing_s"]["analyses_total"] = t1 - t0
    sheet.provenance["timing_s"]["layout_and_figures"] = time.perf_counter() - t1
    return sheet
