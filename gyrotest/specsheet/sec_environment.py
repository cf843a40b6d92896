"""Section 4 of the spec sheet: thermal (IEEE E terms and the Antonova–Matveev model),
magnetic, supply voltage and the model history."""

from __future__ import annotations

from pathlib import Path

from . import adapters as ad
from .base import BuilderBase
from .layout import (
    U_DPH,
    P,
    Src,
    T,
    _check_table,
    _fig,
    _not_tested,
    _unit,
    dig,
)
from .sheet import NOT_TESTED, VERDICT_RULE, Check, Num, Section, fmt_number  # noqa: F401


class EnvironmentSections(BuilderBase):
    """Mixin of :class:`~gyrotest.specsheet.build.Builder`: section 4."""

    # ---------------------------------------------------------------- 4 environment
    def environment(self, sec: Section) -> Section:
        """Section 4: thermal, magnetic, supply and model-history subsections."""
        self.thermal(sec.sub("Thermal: D_T, D_Ṫ, D_∇Ṫ and the Antonova–Matveev model"))
        self.magnetic(sec.sub("Magnetic field: w_x, w_y, w_z"))
        self.supply(sec.sub("Supply voltage"))
        if self.eng:
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
                                        f"{ch['sensor']}; ± 1σ)"))
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
            self.reconcile_dt(sec, a, ch)
            f = ch.get("fit", {})
            self.eng_only(sec, P(
                "Fit quality: residual RMS "
                f"{s.t(['chamber', 'fit', 'rms_fit_dph'], U_DPH)}, held-out "
                f"{s.t(['chamber', 'fit', 'rms_holdout_dph'], U_DPH)}, noise "
                f"floor (fixed for the log) {s.t(['chamber', 'fit', 'noise_floor_dph'], U_DPH)}; "
                f"working resolution: {f.get('resolution_note', '')}."))
            h = ch.get("hysteresis", {})
            if "heating_minus_cooling_dph" in h:
                self.eng_only(sec, P("Heating − cooling residual: "
                             f"{s.t(['chamber', 'hysteresis', 'heating_minus_cooling_dph'], U_DPH, ['chamber', 'hysteresis', 'stderr_dph'])}"
                             f" ({h.get('verdict', '')})."))
            for n in ch.get("notes", []):
                self.eng_only(sec, P(n, "note"))
            sensor = ch.get("sensor", "")
            for w in dig(ch, ["am_fit", "warnings"]) or []:
                # the warnings name the model-fit terms; on the sheet they are w1 and w2
                w = (w.replace(f"T2({sensor})", "w2 (ΔT²)").replace(f"T({sensor})", "w1 (ΔT)")
                     .replace(f"dTdt({sensor})", "w_ΔV (dT/dt)"))
                self.warn("thermal-fit", "Antonova–Matveev model: " + w
                          + ("" if "not significant" not in w else
                             " (this concerns the quadratic model's w1/w2 only; the IEEE D_T "
                             "above is a single slope and is determined)"))
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

    def reconcile_dt(self, sec: Section, a, ch: dict) -> None:
        """One explanation for D_T (IEEE) next to w1 (Antonova–Matveev): different models of
        the same run; their mean slopes over the tested range are compared."""
        co = {c["name"]: c for c in ch.get("coefficients", [])}
        ie = {c["name"]: c for c in ch.get("ieee_E_terms", [])}
        if "w1" not in co or "D_T" not in ie:
            return
        info = self.an.get(f"info:{self.c.rel(self.c.tests['thermal'].logs[0])}")
        chans = info.result.get("channels", {}) if info else {}
        tch = chans.get(f"temperature:{ch.get('sensor')}") or next(
            (v for k, v in chans.items() if k.startswith("temperature:")), None)
        t0 = float(ch.get("t0_degC", 21.0))
        w1, w2 = co["w1"]["value"], co.get("w2", {}).get("value", 0.0) or 0.0
        txt = ("D_T and w1 are not two measurements of one quantity: D_T is the slope of the "
               "IEEE 952 linear E-term model, fitted together with D_Ṫ and D_∇Ṫ; w1 is the "
               "slope at t0 of the Antonova–Matveev quadratic, which has no gradient term and "
               "whose w1 and w2 trade off against each other over a one-sided temperature "
               "range (hence the large uncertainty of w1 alone).")
        if tch and "min" in tch and "max" in tch:
            lo, hi = tch["min"] - t0, tch["max"] - t0
            mean_slope = w1 + w2 * (lo + hi)
            txt += (f" Over the tested range ΔT = {fmt_number(lo, 3)} … {fmt_number(hi, 3)} °C "
                    f"the quadratic's mean slope w1 + w2·(ΔT_min + ΔT_max) = "
                    f"{fmt_number(mean_slope, 3)} (°/h)/°C, against D_T = "
                    f"{fmt_number(ie['D_T']['value'], 3)} (°/h)/°C: ")
            sw1 = co["w1"].get("stderr")
            diff = abs(mean_slope - ie["D_T"]["value"])
            if isinstance(sw1, (int, float)) and diff <= self.k * sw1:
                txt += (f"they agree within the expanded uncertainty of w1 "
                        f"({fmt_number(self.k * sw1, 2)} (°/h)/°C).")
            else:
                txt += ("the difference is taken up by the terms one model has and the other "
                        "lacks (gradient rate, curvature).")
        txt += " The temperature sensitivity of this gyro is D_T."
        sec.add(P(txt))

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
                                    "100 µT (± 1σ)"))
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
            self.eng_only(sec, P(n, "note"))
        for w in dig(r, ["fit", "warnings"]) or []:
            self.warn("mag-fit", w)
        t = self.c.tests["magnetic"]
        if t.conditions:
            sec.add(P(f"Conditions: {t.conditions}.", "note"))
        fig = self.draw("magnetic", lambda: _fig("magnetic_figure", a.obj, self.k))
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

