"""Accelerometer noise on the spec sheet (IEEE Std 1293), when the campaign asks for it with
``[tests.accel]``: velocity random walk, bias instability, acceleration random walk, ramp and
velocity quantization of every accelerometer axis, from the same joint Allan fit as the gyro
(``gyrotest allan LOG --axis ax,ay,az``), with limits per axis and the Allan figure."""

from __future__ import annotations

from .base import BuilderBase
from .layout import P, Src, T, _check_table, _fig, _unit, dig
from .sheet import Section

IEEE1293 = "Allan variance"
#: (key, label, unit) of the sheet rows; the limits of [tests.accel] use the same keys
ACCEL_TERMS = (("N", "velocity random walk VRW", "m/s/√h"),
               ("B", "bias instability B", "µg"),
               ("K", "acceleration random walk K", "m/s/h/√h"),
               ("R", "acceleration ramp R", "m/s/h/h"),
               ("Q", "velocity quantization Q", "m/s"))


class AccelSections(BuilderBase):
    """Mixin of :class:`~gyrotest.specsheet.build.Builder`: the accelerometer section."""

    def accelerometers(self, sec: Section) -> Section:
        """The accelerometer noise section: one check per axis and term, the fit summary,
        the conversions (µg/√Hz, Kalibr), the warnings and the figure."""
        a = self.an["accel"]
        s = Src(a)
        axes = dig(a.result, ["logs", 0, "axes"]) or []
        items = []
        for j, ax in enumerate(axes):
            terms = ax["fit"]["terms"]
            for key, lab, unit in ACCEL_TERMS:
                i = next((k for k, t in enumerate(terms) if t["key"] == key), None)
                if i is None:
                    items.append(self.check("accel", key, f"{lab}, {ax['axis']} (not fitted)",
                                            IEEE1293, None, sec.number, unit))
                    continue
                tp = ["logs", 0, "axes", j, "fit", "terms", i]
                u = _unit(terms[i]["units"].get(key, ""))
                if terms[i]["status"] == "identified":
                    n = s.num(tp + ["params", key], u, tp + ["sigma", key])
                else:
                    n = s.num(tp + ["upper_95"], u, bound=True)
                items.append(self.check("accel", key, f"{lab}, {ax['axis']}", IEEE1293, n,
                                        sec.number, unit))
        sec.add(_check_table(items, "Accelerometer noise coefficients per axis (joint Allan "
                                    "fit; ≤: upper bound only, 95 % profile likelihood; ±: 1σ)",
                             standard="IEEE Std 1293"))
        rows = []
        for j, ax in enumerate(axes):
            cp = ["logs", 0, "axes", j, "conversions"]
            if dig(a.result, cp + ["N"]) is None:
                continue
            rows.append([ax["axis"], s.num(cp + ["N", "ug_per_rt_hz"], "µg/√Hz"),
                         s.num(cp + ["kalibr", "accelerometer_noise_density"], "m/s²/√Hz"),
                         s.num(cp + ["kalibr", "accelerometer_random_walk"], "m/s³/√Hz")])
        if rows:
            sec.add(T(["axis", "noise density", "Kalibr accelerometer_noise_density",
                       "Kalibr accelerometer_random_walk"], rows,
                      title="Noise densities (continuous time; bounds at their bound)",
                      widths=[1.4, 2.2, 2.6, 2.6], key="accel_densities"))
        if axes:
            fp = ["logs", 0, "axes", 0, "fit"]
            self.eng_only(sec, P(
                f"Joint fit of {','.join(axes[0]['fit']['terms_requested'])} to the overlapping "
                "Allan deviation of the acceleration (σ in m/s²), the same estimator, EDF, "
                "intervals and identification rule as for the gyro (section 3); first axis: "
                f"τ = {s.t(fp + ['fit_range_s', 0], 's')} … {s.t(fp + ['fit_range_s', 1], 's')}"
                f", χ²/dof = {s.t(fp + ['chi2_per_dof'], digits=3)}. Units (IEEE Std 1293): "
                "VRW in m/s/√h (= 60 × m/s²/√Hz), B in µg (g = 9.80665 m/s²), K in m/s/h/√h."))
        for ax in axes:
            for w in ax.get("warnings", []):
                self.warn("accel", f"[{ax['axis']}] {w['title']}: {w['message']}",
                          w.get("code", ""),
                          "warning" if w.get("severity", "warning") == "warning" else "note")
        rr = dig(a.result, ["logs", 0]) or {}
        for n in rr.get("notes", []):
            self.warn("accel", n, kind="note")
        fig = self.draw("accel", lambda: _fig("accel_figure", rr.get("source", ""),
                                              list(a.obj.axes)))
        self.figure(sec, fig, "Overlapping Allan deviation of every accelerometer axis with χ² "
                    "confidence intervals and the fitted noise models; below, the residuals in "
                    "units of the confidence interval.")
        return sec
