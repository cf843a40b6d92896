"""Section 3 of the spec sheet: bias D_F (3.1), random drift N, B, K, R, Q (3.2), the noise
structure (3.3) and the platform vs strapdown application note (3.4)."""

from __future__ import annotations

from pathlib import Path

from .base import BuilderBase
from .layout import (
    U_ARW,
    U_DPH,
    U_RR,
    U_RRW,
    P,
    Src,
    T,
    _check_table,
    _fig,
    _not_tested,
    _unit,
    dig,
)
from .sec_axes import allan_axes_table, allan_axis_names, axis_note, bias_axes_table
from .sheet import NOT_TESTED, VERDICT_RULE, Check, Num, Section, fmt_number  # noqa: F401

WARMUP_LABEL = "warm-up time"
WARMUP_IEEE = "IEEE 952 §5.3.3 / IEEE 528"


def _finite(v) -> bool:
    return isinstance(v, (int, float)) and v == v and abs(v) != float("inf")


class DriftSections(BuilderBase):
    """Mixin of :class:`~gyrotest.specsheet.build.Builder`: section 3."""

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
            self.check("bias", "warmup_time_s", WARMUP_LABEL, WARMUP_IEEE, None, sec.number)
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
                                    "(± from the run-to-run spread)", "§5.3.3.1.1", df, sec.number))
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
        items.append(self.warmup_item(s, r, runs, sec))
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
        sec.add(_check_table(items, "Bias items" + axis_note(r.get("axes") or [])))
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
                      rows, title="Per run (after the warm-up trim)"
                      + axis_note(r.get("axes") or []), unit_in_header=True,
                      widths=[2.3, 1.0, 1.4, 1.5, 1.8, 1.6, 1.5], key="bias_runs"))
        tab = bias_axes_table(s, r)
        if tab is not None:
            sec.add(tab)
        for n in r.get("notes", []):
            self.warn("bias", n)
        t = self.c.tests["bias"]
        skip = t.opt("skip", "0")
        if not self.eng:
            sec.add(P(f"D_F = mean rate − earth-rate component along the IA after a {skip} "
                      "warm-up trim; the uncertainty of each run allows for correlated noise."))
        self.eng_only(sec, P("D_F = mean rate − earth-rate component along the IA after a "
                     f"{skip} warm-up trim; the 1σ of each run is the Allan deviation at the "
                     "record length from a fitted noise model (honest for correlated noise; "
                     "σ/√n shown only for comparison)."))
        if t.conditions:
            sec.add(P(f"Conditions between runs: {t.conditions}.", "note"))
        for run in runs:
            for n in run.get("notes", []):
                self.warn("bias", f"{Path(run['source']).name}: {n}")

    def warmup_item(self, s: Src, r: dict, runs: list, sec: Section) -> Check:
        """The warm-up time item: the longest over the runs (each log from power-on), ± the
        block resolution (1σ = block/√12); "not tested" without ``warmup_band``."""
        t = self.c.tests["bias"]
        if t.opt("warmup_band") is None:
            return self.check("bias", "warmup_time_s", WARMUP_LABEL, WARMUP_IEEE, None,
                              sec.number)
        worst = r.get("warmup_time_worst_s")
        w0 = runs[0].get("warmup_time") or {}
        band = w0.get("band_dph")
        label = (f"{WARMUP_LABEL}, bias within ± {fmt_number(band, 3)} °/h of its final value "
                 f"(longest of {len(runs)} run{'s' if len(runs) > 1 else ''}; "
                 f"{fmt_number(w0.get('block_s'), 3)} s blocks)")
        if worst is None or worst != worst:
            i = next((i for i, run in enumerate(runs)
                      if not _finite((run.get("warmup_time") or {}).get("warmup_time_s"))), 0)
            st = (runs[i].get("warmup_time") or {}).get("status", "not measured")
            self.warn("bias", f"warm-up time of {Path(runs[i]['source']).name}: {st}")
            return self.check("bias", "warmup_time_s", label, WARMUP_IEEE, None, sec.number)
        return self.check("bias", "warmup_time_s", label, WARMUP_IEEE,
                          s.num(["warmup_time_worst_s"], "s", ["warmup_time_worst_sigma_s"],
                                digits=4), sec.number)

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
                                    "only, 95 % profile likelihood; ±: 1σ)"
                             + axis_note(allan_axis_names(a.result))))
        tab = allan_axes_table(s, a.result)
        if tab is not None:
            sec.add(tab)
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
        self.eng_only(sec, P(txt))
        dg = ax.get("diagnosis")
        if dg and dg.get("verdict"):
            self.eng_only(sec, P(f"Diagnosis of missing terms: {dg['verdict']}", "note"))
        self.noise_structure(parent.sub("Noise structure", "Annex C"), a, s, base, ax)
        self.application(parent.sub("Application note: platform vs strapdown"), a, s, base, ax)
        for w in ax.get("warnings", []):
            self.warn("allan", f"{w['title']}: {w['message']}", w.get("code", ""),
                      "warning" if w.get("severity", "warning") == "warning" else "note")
        for n in ax.get("notes", []) + rr.get("notes", []):
            self.warn("allan", n, kind="note")
        fig = self.draw("allan", lambda: _fig("allan_figure", rr["source"], a.obj.axes[0],
                                              self.k))
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
                f"N_upper (95 % bound: min over τ of the upper confidence limit of σ × √τ/60) = "
                f"{s.t(base + ['slope_readoffs', 'N_upper'], U_ARW)}"
                f" (ray through the leftmost point); B_tangent = σ_min/0.664 = "
                f"{s.t(base + ['slope_readoffs', 'B_tangent'], U_DPH)} (an upper bound "
                "in a mixture); Allan floor σ_min = "
                f"{s.t(base + ['slope_readoffs', 'allan_floor_dph'], U_DPH)} at τ = "
                f"{s.t(base + ['slope_readoffs', 'allan_floor_tau_s'], 's')}.")
        lines.append("A coefficient the graph cannot establish is given as an upper bound (≤). "
                     "Noises with zero PSD at zero frequency stay bounded on a platform but "
                     "grow in strapdown: a single drift number does not describe the gyro.")
        for i, ln in enumerate(lines):
            if i == len(lines) - 1:
                sec.add(P(ln))
            else:  # input, PSD convention and graph read-offs: algorithm notes
                self.eng_only(sec, P(ln))

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
        if imp.get("extrapolated"):
            sec.add(P("Extrapolated: " + str(imp.get("extrapolation", "")), "note"))
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
        self.eng_only(sec, P("Assumptions: " + "; ".join(imp.get("assumptions", [])) + ". Method: "
                     + imp.get("method", "") + "."))

