"""Run a campaign's analyses and lay out the spec sheet in IEEE 952 order.

:func:`run_campaign` runs every test through its adapter (:mod:`.adapters`; the same core
calls as the individual commands) and :func:`build_sheet` turns the results into a
:class:`~gyrotest.specsheet.sheet.Sheet`:

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
``--json`` and carries that provenance (:class:`~gyrotest.specsheet.sheet.Num`).
"""

from __future__ import annotations

import time
from collections.abc import Callable

from .. import __version__
from ..core.errors import GyrotestError, InputError
from ..scalefactor.tablefit import TERM_LABELS
from . import adapters as ad
from .base import SF_UNIT_TEXT
from .campaign import Campaign
from .layout import (  # noqa: F401 - re-exported for the section modules and callers
    U_ARW,
    U_DPH,
    U_RR,
    U_RRW,
    P,
    Src,
    T,
    _check_table,
    _fig,
    _isnum,
    _not_tested,
    _quote,
    _unit,
    dig,
)
from .sec_accel import AccelSections
from .sec_drift import DriftSections
from .sec_environment import EnvironmentSections
from .sec_lab import LabSections
from .sheet import (
    NOT_TESTED,
    Check,
    Equation,
    Num,
    Para,
    Section,
    Sheet,
    Table,
    fmt_number,
    verdict_rule,
)

VARIANTS = ("customer", "engineering")
#: sheet names of the f(I) terms: each named once, by its power of u = I/FS in f(I) (u¹ for
#: the term the terminal, the JSON and the C header call u1); its output power is said once,
#: under the table (:data:`gyrotest.scalefactor.tablefit.OUTPUT_POWER_NOTE`)
F_OF_I_NAMES = TERM_LABELS


def asymmetry_explanation(r: dict) -> str:
    """One explanation for the two asymmetry numbers: the IEEE straight-line asymmetry and the
    model's A. The u¹ term of f(I) also makes |SF+| ≠ |SF−| (by 2·c1·|I|/FS at rate I), so at
    full scale the straight-line asymmetry approaches A − 2·c1."""
    asy = r.get("asymmetry", {})
    coefs = {c["term"]: c for c in r.get("nonlinearity_model", {}).get("coefficients", [])}
    if asy.get("status") != "ok" or "asymmetry" not in coefs:
        return ""
    A = coefs["asymmetry"]["coefficient_ppm"]
    c1 = coefs.get("u1", {}).get("coefficient_ppm", 0.0) or 0.0
    ieee = asy["asymmetry_ppm"]
    txt = (f"Two asymmetry numbers, one explanation: the IEEE 952 asymmetry "
           f"({fmt_number(ieee, 4)} ppm, §5.3.2.1 b) compares straight lines fitted to the "
           f"positive and the negative rates; A ({fmt_number(A, 4)} ppm) is only the "
           f"rate-independent step of the model. The u¹ term of f(I) (c1 = {fmt_number(c1, 4)} "
           "ppm) also makes |SF+| differ from |SF−|, by "
           "2·c1·|I|/FS at rate I")
    per = asy.get("per_rate") or []
    if per and c1:
        top = max(per, key=lambda x: x["rate_dps"])
        fs = r.get("full_scale_dps") or top["rate_dps"]
        pred = A - 2 * c1 * top["rate_dps"] / fs
        txt += (f": at {fmt_number(top['rate_dps'])} °/s the model gives A − 2·c1·|I|/FS = "
                f"{fmt_number(pred, 4)} ppm and the data {fmt_number(top['asymmetry_ppm'], 4)}"
                " ppm. The straight-line fits are dominated by the highest rates, so the IEEE "
                "number lies near the full-scale value.")
    else:
        txt += "."
    return txt


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
            t0 = ad.thermal_t_ref(test)
            for i, terms in enumerate(test.opt("model_steps", []) if test.logs else [], 1):
                k = f"thermal.step{i}"
                out[k] = step(f"thermal model step {i}: {terms}",
                              lambda t=test, tm=terms, k=k, t0=t0: ad.run_model_fit(
                                  t, campaign, cache, tm, k, t_ref=t0))
        elif name == "magnetic":
            out[name] = step(name, lambda t=test: ad.run_magnetic(t, campaign, cache))
        elif name == "accel":
            out[name] = step(name, lambda t=test: ad.run_accel(t, campaign, cache))
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


class Builder(DriftSections, EnvironmentSections, LabSections, AccelSections):
    """Builds the sections of one sheet."""

    # ---------------------------------------------------------------- sections
    def build(self) -> Sheet:
        """The whole sheet (customer or engineering variant)."""
        sec_model = Section("1", "Model equation", "§8.3")
        sec_sf = self.scale_factor(Section("2", "Scale factor", "§5.3.2"))
        sec_drift = self.drift(Section("3", "Drift rate: bias and random drift", "§5.3.3.1"))
        sec_env = self.environment(Section("4", "Environmental sensitivities (E terms)",
                                           "§5.3.3.2, §8.3"))
        sec_ia = self.alignment(Section("5", "IA alignment", "§5.3.4"))
        self.model_equation(sec_model)  # after the others: it substitutes their numbers
        extra = []
        if "accel" in self.an:  # the campaign asks for the accelerometers ([tests.accel])
            extra.append(self.accelerometers(Section("6", "Accelerometer noise",
                                                     "IEEE Std 1293")))
        sec_cond = self.conditions(Section(str(6 + len(extra)),
                                           "Test conditions, equipment and traceability"))
        self.identity_checks()
        self.equipment_checks()
        sections = [sec_model, sec_sf, sec_drift, sec_env, sec_ia, *extra, sec_cond]
        n = len(sections)
        if self.eng:
            n += 1
            sections.append(self.warnings_section(Section(str(n), "Warnings raised by the "
                                                                  "analyses")))
        sections.append(self.compliance(Section(str(n + 1), "Compliance with the spec limits")))
        sections.append(self.references(Section(str(n + 2), "References")))
        sections.append(self.revision_history(Section(str(n + 3), "Revision history")))
        sections.append(self.approval(Section(str(n + 4), "Approval")))
        g = self.c.gyro
        title = f"{g['model']} s/n {g['serial']}: gyro specification sheet"
        if self.eng:
            title += " (engineering report)"
        ident = self.identity()
        prov = {
            "gyrotest_version": __version__,
            "variant": self.variant,
            "campaign": {"file": str(self.c.path), "name": self.c.path.name,
                         "sha256": self.c.sha256},
            "inputs": self.input_files(),
            "commands": [a.to_dict() for a in self.an.values()],
            "working_directory": "paths in the commands are relative to the campaign file's "
                                 "directory; run them there",
            "options": self.c.to_dict()["tests"],
            "timing_s": self.timing,
        }
        logo = self.c.lab.get("logo")
        sheet = Sheet(title=title, identity=ident, sections=sections, checks=self.checks,
                      figures=self.figures, warnings=self.warnings, provenance=prov,
                      header=f"{g['model']} s/n {g['serial']}", notes=self.c.meta.get("notes", ""),
                      variant=self.variant, rule_text=verdict_rule(self.rule, self.k),
                      logo=logo.read_bytes() if logo else None,
                      lab={k: v for k, v in self.c.lab.items() if k != "logo"})
        ident.append(("Compliance", self.summary_line(sheet)))
        expand_uncertainties(sheet, self.k)
        return sheet

    def identity(self) -> list[tuple[str, str]]:
        """Title-block rows: gyro, report, lab, operator, date, site, tests, software."""
        g = self.c.gyro
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
            rev = self.c.revisions[-1]["revision"] if self.c.revisions else m.get("revision")
            ident.append(("Report", m["report_id"] + (f", revision {rev}" if rev else "")))
        if m.get("customer"):
            ident.append(("Customer", m["customer"]))
        lab = self.c.lab
        if lab.get("name"):
            ident.append(("Laboratory", ", ".join(x for x in (lab["name"], lab.get("address"))
                                                  if x)
                          + (f" ({lab['accreditation']})" if lab.get("accreditation") else "")))
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
        if "accel" in self.c.tests:
            tested.append("accelerometer noise (IEEE Std 1293)")
        missing = [v for k, v in names.items() if k not in self.c.tests]
        ident.append(("Tests", (", ".join(tested) or "none")
                      + (f"; not tested: {', '.join(missing)}" if missing else "")))
        ident.append(("Uncertainty", f"expanded uncertainty U = k·u, k = {self.k:g} "
                                     f"(± values in this sheet)"))
        ident.append(("Decision rule", "guarded acceptance, guard band w = U (ILAC-G8)"
                      if self.rule == "guard-band" else "simple acceptance (ILAC-G8)"))
        ident.append(("Software", f"gyrotest {__version__}"))
        ident.append(("Campaign file", f"{self.c.path.name} (SHA-256 {self.c.sha256[:16]}…)"))
        return ident

    def summary_line(self, sheet: Sheet) -> str:
        """One line: overall verdict and counts."""
        v = [c.verdict for c in self.checks]
        n_lim = sum(1 for c in self.checks if c.limit is not None)
        if not n_lim:
            return "no limits given in the campaign"
        parts = [f"{sheet.overall()}: {v.count('PASS')} of {n_lim} limited items pass"]
        for k in ("FAIL", "CONDITIONAL FAIL", "INCONCLUSIVE", "CONDITIONAL PASS"):
            if v.count(k):
                parts.append(f"{v.count(k)} {k}")
        nt = sum(1 for c in self.checks if c.verdict == NOT_TESTED and c.limit is not None)
        if nt:
            parts.append(f"{nt} limited item(s) not tested")
        return "; ".join(parts)

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
            rows.append([F_OF_I_NAMES.get(cf["term"], cf["term"]), cf["f_of_I"] + extra,
                         s.num(["nonlinearity_model", "coefficients", i, "coefficient_ppm"],
                               "ppm", ["nonlinearity_model", "coefficients", i, "sigma_ppm"]),
                         "yes" if cf.get("supported_by_data") else "no (shown for scale)"])
        if rows:
            sec.add(T(["term of f(I)", "f(I), u = I/FS",
                       "coefficient ± 1σ, ppm", "supported by the data"], rows,
                      title="Rate-dependent scale-factor error f(I) of ε_K (§8.3)",
                      unit_in_header=True, widths=[2.6, 2.4, 2.2, 1.8], key="sf_model"))
            sec.add(P("The output error is I·f(I): the term c_k·u^k of f(I) is a nonlinearity "
                      "of order k + 1 in the output (u¹ quadratic, u² cubic)."))
            asym_text = asymmetry_explanation(r)
            if asym_text:
                sec.add(P(asym_text))
        if nl.get("statement"):
            self.eng_only(sec, P(f"Nonlinearity model: {nl['statement']} Selection: "
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
        t0v = f"{fmt_number(ad.thermal_t_ref(t0))} °C" if t0 else "the reference"
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


def expand_uncertainties(sheet: Sheet, k: float) -> None:
    """Show every ± as the expanded uncertainty U = k·σ and say so in the headings (the JSON
    keeps σ and adds ``expanded_uncertainty``)."""
    lab = f"± U (k = {k:g})"

    def fix(t: str) -> str:
        return (t.replace("± 1σ HAC", f"{lab}, GLS standard errors").replace("± 1σ", lab)
                .replace("±: 1σ", f"±: U, k = {k:g}"))

    def nums(block):
        if isinstance(block, Table):
            for r in block.rows:
                for c in r:
                    if isinstance(c, Num):
                        yield c
        yield from getattr(block, "nums", [])

    for sec in sheet.walk():
        for b in sec.blocks:
            for n in nums(b):
                n.k = k
            if isinstance(b, Table):
                b.title = fix(b.title)
                b.columns = [fix(c) for c in b.columns]
                b.rows = [[fix(c) if isinstance(c, str) else c for c in r] for r in b.rows]
            elif isinstance(b, Para):
                b.text = fix(b.text)
    for c in sheet.checks:
        c.label = fix(c.label)
        if c.measured is not None:
            c.measured.k = k


def build_sheet(campaign: Campaign, analyses: dict[str, ad.Analysis], *, figures: bool = True,
                variant: str = "customer") -> Sheet:
    """Lay out the sheet from the analyses (figures drawn when ``figures``); ``variant`` is
    "customer" (results, uncertainties, limits, decision rule, conditions, equipment,
    references, sign-off) or "engineering" (adds the diagnostics, algorithm notes and
    warnings)."""
    if variant not in VARIANTS:
        raise InputError(f"unknown report variant {variant!r}: use {' or '.join(VARIANTS)}")
    Src.sink.clear()
    Src.k = float(campaign.decision.get("coverage_factor", 2.0))
    b = Builder(campaign, analyses, figures, variant)
    sheet = b.build()
    sheet.provenance["timing_s"] = {**{a.key: a.seconds for a in analyses.values()},
                                    **b.timing}
    return sheet


def make_report(campaign: Campaign, *, figures: bool = True,
                progress: Callable[[str], None] | None = None,
                variant: str = "customer") -> Sheet:
    """Run the campaign and build its sheet (``variant``: customer or engineering)."""
    t0 = time.perf_counter()
    an = run_campaign(campaign, progress=progress)
    t1 = time.perf_counter()
    sheet = build_sheet(campaign, an, figures=figures, variant=variant)
    sheet.provenance["timing_s"]["analyses_total"] = t1 - t0
    sheet.provenance["timing_s"]["layout_and_figures"] = time.perf_counter() - t1
    return sheet
