"""Krobka's checks: the ways Allan graphs get misread, each turned into a warning with a reason.

Source: N. I. Krobka, "On the topology of the Allan variance graphs and typical misconceptions
in the interpretations of the gyro noise structure" (ICINS 2015; Krobka (Allan-graph topology)), GYRO_REFERENCE §4
list 1–8 and notes-allan-topology §2.9 rules 1–16 / §3 M1–M13. Every check has a stable code
(used in ``--json``), fires on a purpose-built case and stays silent on a clean ARW + bias
instability + RRW log:

=============  ===========================================================================
code           check
=============  ===========================================================================
KROBKA-M1      ARW is a ray through (or below) the leftmost point, not a −½ segment: the
               fitted N exceeds N_upper, the 95 % upper bound of white rate noise from the
               measured curve (min over τ of the upper confidence limit of σ × √τ/60,
               Bonferroni over the τ; :func:`gyrotest.noise.noisefit.n_upper_bound`), or the
               slope-line N (read at the −½ point, MATLAB style) is above N_upper.
KROBKA-M4      B from the zero-slope tangent at the minimum: report B_fit and B_tangent =
               σ_min/0.664; warn when B_fit/B_tangent < 0.5 (the tangent over-estimates B
               in a mixture, ×4 and ×20 in the paper) or when there is no plateau (the
               minimum is a crossover of −½ and +½ lines: B is not the dominant term there).
KROBKA-M5      a hump (significant local maximum or a flattening followed by a return to
               −½, or a Markov term in the fitted/diagnosed model) screens white noise: the
               leftmost-point white-noise bound and the long-τ effective ARW N_eq are
               reported separately.
KROBKA-R11     local slope outside [−1, +1] beyond its CI: periodic content (sinusoid nulls)
               or data faults (steps, resets, gaps) — no stationary noise does that.
KROBKA-R12     slope −1 over a wide τ range: bounded-angle noise; the graph cannot tell
               quantization from white angle noise or S(0) = 0 (blue) noise; for pulse
               output Q_fit is compared with S0/√12.
KROBKA-M12     too few clusters: τ with EDF below the fit floor are not fitted ("fit
               stopped at τ = …").
KROBKA-M7      a deterministic trend leaks into the Allan variance (a mean square, not a
               variance): at long τ the Allan–Krobka dispersion is significantly below the
               Allan deviation, by more than a rate random walk's own random trend would
               explain; try ``--detrend linear``.
KROBKA-M6      the model misfits (χ² test or runs beyond 3 CI): the five-slope basis is
               incomplete and unmodelled noise becomes parameter error; the diagnosis names
               the missing term.
KROBKA-R16     a fitted component exceeds the measured curve beyond its CI (every partial
               deviation is bounded by the total, Krobka (Allan-graph topology) eq. 5.9).
=============  ===========================================================================
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .fitresult import NoiseFit

__all__ = ["KrobkaWarning", "krobka_checks", "local_slopes", "CODES"]

CODES = ("KROBKA-M1", "KROBKA-M4", "KROBKA-M5", "KROBKA-R11", "KROBKA-R12", "KROBKA-M12",
         "KROBKA-M7", "KROBKA-M6", "KROBKA-R16")
B_RATIO_WARN = 0.5
N_SLOPE_RATIO_WARN = 1.2


@dataclass
class KrobkaWarning:
    """One warning: stable ``code``, short ``title``, the ``message`` (what to do) and the
    ``reason`` (why this is a misreading, with the source), plus numeric ``evidence``."""

    code: str
    title: str
    message: str
    reason: str
    evidence: dict[str, Any] = field(default_factory=dict)
    severity: str = "warning"

    def text(self) -> str:
        return f"[{self.code}] {self.title}: {self.message}"

    def to_dict(self) -> dict[str, Any]:
        return {"code": self.code, "severity": self.severity, "title": self.title,
                "message": self.message, "reason": self.reason, "evidence": self.evidence}


def _g(v: float, d: int = 3) -> str:
    if v is None or not math.isfinite(v):
        return "—"
    a = abs(v)
    if a != 0 and (a < 1e-3 or a >= 1e5):
        return f"{v:.{d - 1}e}"
    return f"{v:.{d}g}"


def local_slopes(tau, sigma, sigma_lo, sigma_hi, *, min_ratio: float = 1.5) -> list[dict]:
    """Local log–log slopes between τ_i and the next τ_j ≥ ``min_ratio``·τ_i, with a 1σ
    uncertainty from the confidence intervals: s = Δln σ/Δln τ, δs = √(δ_i² + δ_j²)/Δln τ,
    δ = (ln σ_hi − ln σ_lo)/2 (conservative: ignores the positive correlation of the two
    estimates). notes-allan-topology §2.9 rules 9–11."""
    t = np.asarray(tau, float)
    s = np.asarray(sigma, float)
    lo = np.asarray(sigma_lo, float)
    hi = np.asarray(sigma_hi, float)
    out = []
    for i in range(t.size):
        j = int(np.searchsorted(t, t[i] * min_ratio - 1e-12))
        if j >= t.size:
            break
        vals = (s[i], s[j], lo[i], hi[i], lo[j], hi[j])
        if not all(math.isfinite(v) and v > 0 for v in vals):
            continue
        dl = math.log(t[j] / t[i])
        slope = math.log(s[j] / s[i]) / dl
        di = 0.5 * math.log(hi[i] / lo[i])
        dj = 0.5 * math.log(hi[j] / lo[j])
        out.append({"tau_lo": float(t[i]), "tau_hi": float(t[j]), "slope": slope,
                    "sigma": math.hypot(di, dj) / dl})
    return out


#: display units of the numbers in the messages (gyro: IEEE 952; accelerometer: IEEE 1293)
_UNITS = {"rate": {"N": "deg/√h", "B": "deg/h", "R": "deg/h/h", "sigma": "deg/h",
                   "what": "rate"},
          "acceleration": {"N": "m/s/√h", "B": "µg", "R": "m/s/h/h", "sigma": "m/s²",
                           "what": "acceleration"}}


def _u(fit: NoiseFit, key: str) -> str:
    return _UNITS.get(getattr(fit, "quantity", "rate"), _UNITS["rate"])[key]


def _f(fit: NoiseFit, param: str) -> float:
    """The accelerometer factor on a gyro-unit formula (1 for a gyro)."""
    q = getattr(fit, "q", None)
    return q.factor(param) if q is not None else 1.0


def _arw_checks(fit: NoiseFit, ro: dict[str, Any], out: list[KrobkaWarning]) -> None:
    N = fit.term("N")
    reason = ("white rate noise is a −½ ray over the whole τ axis through or below the leftmost "
              "point; a −½ segment elsewhere is usually a Markov tail (Krobka §5–6, "
              "AIST-100 example: N over-read by one to two orders)")
    N_up = ro.get("N_upper")
    if N is not None and N.coef > 0 and N_up is not None and math.isfinite(N_up) \
            and N.value > N_up:
        # N_upper is the 95 % upper bound of white rate noise from the measured curve (the
        # upper confidence limits of σ̂, family-wise over the τ): a fitted N above it is
        # rejected by the measurement at 5 %, whatever τ the N line crosses the curve at
        t_up = ro.get("N_upper_tau_s")
        out.append(KrobkaWarning(
            "KROBKA-M1", "ARW line above the measured curve",
            f"the fitted N = {_g(N.value)} {_u(fit, 'N')} exceeds N_upper = {_g(N_up)} "
            f"{_u(fit, 'N')}, the 95 % "
            f"upper bound of white rate noise that the measured σ allows (−½ ray lowered onto "
            f"the upper confidence limits of σ, set at τ = {_g(t_up)} s): treat N as ≤ N_upper "
            "and add the missing term (see the diagnosis)",
            reason, {"N_fit": N.value, "N_upper": N_up, "tau_s": t_up,
                     "rule": ro.get("N_upper_rule")}))
        return
    Ns = ro.get("N_slope")
    if Ns is not None and N_up:
        i = int(np.argmin(np.abs(fit.tau - ro["N_slope_tau_s"])))
        rel = (fit.sigma_hi[i] / fit.sigma[i] - 1.0) if math.isfinite(fit.sigma_hi[i]) else 0.0
        ratio = Ns / N_up
        if ratio > max(N_SLOPE_RATIO_WARN, 1.0 + 2.0 * rel) and (N is None or N.coef == 0 or
                                                                  Ns > 1.2 * N.value):
            out.append(KrobkaWarning(
                "KROBKA-M1", "−½ segment not anchored at the left",
                f"the −½ stretch at τ = {_g(ro['N_slope_tau_s'])} s gives N = {_g(Ns)} "
                f"{_u(fit, 'N')} "
                f"(slope-line reading, as MATLAB's allanvar example or allan_variance_ros), "
                f"{ratio:.1f}× the bound N_upper = {_g(N_up)} {_u(fit, 'N')} from the leftmost "
                f"points: that segment is not white {_u(fit, 'what')} noise; report N ≤ "
                f"{_g(N_up)} {_u(fit, 'N')}"
                + (f" (joint fit: {N.text()})" if N is not None else ""),
                reason, {"N_slope": Ns, "N_slope_tau_s": ro["N_slope_tau_s"], "N_upper": N_up,
                         "ratio": ratio}))


def _bias_checks(fit: NoiseFit, ro: dict[str, Any], out: list[KrobkaWarning]) -> None:
    B = fit.term("B")
    Bt = ro.get("B_tangent")
    if B is None or Bt is None or not Bt > 0:
        return
    reason = ("partial deviations add in quadrature, so the minimum of the graph is shared by "
              "several noises; even with the 1/0.664 factor the zero-slope tangent over-estimates "
              "B in a mixture (×4 and ×20 in Krobka's simulated mixtures, Krobka (Allan-graph topology) §6 M3/M4)")
    Bv = B.value if B.identified else (B.upper if B.upper is not None else B.value)
    ratio = Bv / Bt
    tmin = ro["allan_floor_tau_s"]
    comps = fit.component_avar(np.array([tmin]))
    total = sum(float(v[0]) for v in comps.values())
    share = float(comps[B.label][0]) / total if total > 0 else 0.0
    shares = {k: float(v[0]) / total for k, v in comps.items() if total > 0 and v[0] / total > 0.1}
    ev = {"B_fit": B.value, "B_status": B.status, "B_upper": B.upper, "B_tangent": Bt,
          "allan_floor": ro["allan_floor"], "allan_floor_tau_s": tmin,
          "ratio_fit_to_tangent": ratio, "B_share_at_minimum": share}
    floor_txt = (f"σ_min = {_g(ro['allan_floor'])} {_u(fit, 'sigma')} at τ = {_g(tmin)} s (tools that "
                 "omit 1/0.664 report this as B)")
    if not B.identified or share < 0.5:
        parts = ", ".join(f"{k} {100 * v:.0f} %" for k, v in sorted(shares.items(),
                                                                    key=lambda kv: -kv[1]))
        falling = tmin >= fit.fit_range[1] * (1 - 1e-9) or any(
            k in ("N", "Q") and v >= 0.9 for k, v in shares.items())
        what = (f"σ is still falling at its minimum (τ = {_g(tmin)} s; model there: {parts}), "
                "no plateau was reached" if falling else
                f"the minimum is a crossover, not a plateau: at τ = {_g(tmin)} s the model is "
                f"{parts}")
        out.append(KrobkaWarning(
            "KROBKA-M4", "no bias-instability plateau",
            f"{what}; B_tangent = σ_min/0.664 = {_g(Bt)} {_u(fit, 'B')} is only an upper bound; "
            "joint "
            f"fit: {B.text()}. {floor_txt}", reason, ev,
            severity="info" if falling and not B.identified else "warning"))
    elif ratio < B_RATIO_WARN:
        out.append(KrobkaWarning(
            "KROBKA-M4", "tangent over-estimates B",
            f"B from the joint fit is {_g(Bv)} {_u(fit, 'B')}, {1 / ratio:.1f}× below B_tangent "
            f"= σ_min/0.664 = {_g(Bt)} {_u(fit, 'B')}: report B_fit; B_tangent is an upper bound. "
            f"{floor_txt}", reason, ev))


def _significant_hump(fit: NoiseFit) -> tuple[int, int, int] | None:
    """(i, j, k): σ_j significantly above σ_i (j > i) and σ_k (k > j), CIs not overlapping."""
    s, lo, hi = fit.sigma, fit.sigma_lo, fit.sigma_hi
    n = s.size
    ok = np.isfinite(lo) & np.isfinite(hi) & (s > 0)
    best = None
    run_min_hi = math.inf
    run_arg = -1
    for j in range(n):
        if not ok[j]:
            continue
        if run_arg >= 0 and lo[j] > run_min_hi:
            after = [k for k in range(j + 1, n) if ok[k] and hi[k] < lo[j]]
            if after:
                cand = (run_arg, j, after[0])
                if best is None or s[j] / s[run_arg] > s[best[1]] / s[best[0]]:
                    best = cand
        if hi[j] < run_min_hi:
            run_min_hi, run_arg = hi[j], j
    return best


def _shoulder(fit: NoiseFit) -> tuple[int, int, int] | None:
    """A flattening then a return to ≤ −½: the local slope rises significantly above −½ (to
    ≥ −0.2) and, at longer τ, falls significantly below −0.35 again — the +½ → −½ transition
    of a Markov hump riding on white noise, which need not make a local maximum."""
    sl = local_slopes(fit.tau, fit.sigma, fit.sigma_lo, fit.sigma_hi, min_ratio=2.0)
    for i, a in enumerate(sl):
        if a["slope"] - 2.5 * a["sigma"] < -0.2:
            continue
        before = [b for b in sl[:i] if b["slope"] + 2.5 * b["sigma"] < -0.35]
        after = [b for b in sl[i + 1:] if b["tau_lo"] >= a["tau_hi"]
                 and b["slope"] + 2.5 * b["sigma"] < -0.35]
        if before and after:
            idx = lambda t: int(np.argmin(np.abs(fit.tau - t)))  # noqa: E731
            return idx(before[-1]["tau_lo"]), idx(a["tau_lo"]), idx(after[0]["tau_hi"])
    return None


#: a hump peaking at or beyond this τ (s) is treated as environmental/periodic, not a sensor
#: Markov process (FOG/MEMS correlation times are below ~100 s; a 24 h cycle peaks at 8.9 h)
LONG_HUMP_S = 1000.0


def _hump_checks(fit: NoiseFit, ro: dict[str, Any], out: list[KrobkaWarning],
                 best: NoiseFit | None = None) -> None:
    best = best or fit
    hump = _significant_hump(fit) or _shoulder(fit)
    markovs = [t for t in best.terms if t.key == "markov" and t.identified]
    sines = [t for t in best.terms if t.key == "sine" and t.identified]
    if hump is not None and not markovs and any(
            fit.tau[hump[0]] <= 0.37101 / t.shape <= fit.tau[hump[2]] for t in sines):
        hump = None  # the lobe of an identified sinusoid, not a Markov hump
    if hump is None and not markovs:
        return
    N = best.term("N")
    n_white = N.value if (N is not None and N.identified) else (N.upper if N else None)
    n_left = ro.get("N_leftmost")
    s_eq = (N.coef if N is not None else 0.0) + sum(t.coef for t in best.terms
                                                     if t.key == "markov")
    n_eq = math.sqrt(s_eq) / 60.0 * _f(fit, "N") if s_eq > 0 else None
    where = (f"the graph flattens or rises after τ = {_g(fit.tau[hump[0]])} s (around τ = "
             f"{_g(fit.tau[hump[1]])} s) and falls again by τ = {_g(fit.tau[hump[2]])} s"
             if hump else "the fit needs a Markov term (" + "; ".join(t.text() for t in markovs)
             + ")")
    peak = float(fit.tau[hump[1]]) if hump else max(
        (1.89262 * t.shape for t in markovs if t.shape), default=0.0)
    if peak >= LONG_HUMP_S:
        period = peak / 0.37101
        msg = (f"{where}: a hump this slow (peak near τ = {_g(peak)} s) is more likely an "
               f"environmental or periodic term than a sensor Markov process — a sinusoid of "
               f"period ≈ τ_peak/0.371 = {_g(period / 3600.0)} h (diurnal temperature?) or a "
               "thermal drift; a higher output rate cannot move it. Find it with gyrotest model "
               "diagnose, then remove it before the noise fit: gyrotest allan --model m.json "
               f"(from gyrotest model fit -o m.json) or --detrend sine:{_g(period / 3600.0)}h; "
               "the long-τ terms (B, K, R) are not trustworthy until then")
    else:
        msg = (f"{where}: a short-correlation (Markov) hump screens the white noise. White rate "
               f"noise up to the sampling frequency is bounded by the leftmost point: N ≤ "
               f"{_g(n_left)} {_u(fit, 'N')} (fit: {_g(n_white)}); the long-τ effective ARW, "
               "which "
               f"drives the angle random walk for t ≫ T_c, is N_eq = √(N² + Σ(q_c·T_c)²) = "
               f"{_g(n_eq)} {_u(fit, 'N')}. Quote both; to move the hump, re-run at a higher "
               "output rate "
               "or with other loop/filter settings and overlay the runs (gyrotest allan a.csv "
               "b.csv)")
    title = ("slow hump: an environmental or periodic term" if peak >= LONG_HUMP_S
             else "Markov hump screens white noise")
    out.append(KrobkaWarning(
        "KROBKA-M5", title, msg,
        "humps at the left of FOG graphs are Markov processes with short correlation time; "
        "they hide the white noise (Optolink OIUS 1000: bound lowered from 3.7e-4 to <1e-6 "
        "deg/√h by moving the hump), while a Markov tail at long τ is indistinguishable from "
        "ARW (Krobka (Allan-graph topology) §6 M5; notes §8 caveat)",
        {"N_leftmost": n_left, "N_fit": n_white, "N_eq": n_eq,
         "hump_tau_s": None if hump is None else [float(fit.tau[i]) for i in hump]}))


def _slope_checks(fit: NoiseFit, out: list[KrobkaWarning], z: float = 2.5) -> None:
    sl = local_slopes(fit.tau, fit.sigma, fit.sigma_lo, fit.sigma_hi)
    bad = [d for d in sl if d["slope"] - z * d["sigma"] > 1.0 or d["slope"] + z * d["sigma"] < -1.0]
    if not bad:
        return
    worst = max(bad, key=lambda d: abs(d["slope"]) - 1.0)
    spans = "; ".join(f"τ {_g(d['tau_lo'])}–{_g(d['tau_hi'])} s: slope {d['slope']:+.2f} ± "
                      f"{d['sigma']:.2f}" for d in bad[:4])
    out.append(KrobkaWarning(
        "KROBKA-R11", "local slope outside [−1, +1]",
        f"{spans}. No stationary noise of the IEEE catalogue rises faster than τ or falls faster "
        "than 1/τ: look for a periodic component (nulls at τ = k/f0: check the PSD, try --terms "
        "…,sine) or data faults (steps, resets, gaps, a rate-table move)",
        "local slopes of a mixture are weighted averages of the component slopes, within [−1, +1] "
        "for every catalogue noise except the sinusoid (notes-allan-topology §2.9 rules 9–11)",
        {"segments": bad, "worst_slope": worst["slope"]}))


def _minus_one_checks(fit: NoiseFit, out: list[KrobkaWarning], quantum_arcsec: float | None
                      ) -> None:
    lab = [t for t in fit.terms if t.key in ("Q", "blue") and t.identified and t.dominant_tau]
    for t in lab:
        lo, hi = t.dominant_tau
        if hi < 10.0 * fit.tau0 and t.key == "Q":
            continue
        ev: dict[str, Any] = {"term": t.label, "dominant_tau_s": [lo, hi]}
        extra = ""
        sev = "warning"
        if t.key == "Q" and quantum_arcsec:
            q_exp = quantum_arcsec / math.sqrt(12.0)
            ev.update({"Q_fit": t.value, "Q_expected_S0_sqrt12": q_exp,
                       "ratio": t.value / q_exp})
            if abs(t.value / q_exp - 1.0) <= 0.3:
                extra = (f" For this pulse output Q_fit = {_g(t.value)}″ matches S0/√12 = "
                         f"{_g(q_exp)}″, consistent with pulse quantization.")
                sev = "info"
            else:
                extra = (f" Q_fit = {_g(t.value)}″ differs from the pulse quantization S0/√12 = "
                         f"{_g(q_exp)}″ ({t.value / q_exp:.2f}×): another bounded-angle noise "
                         "is present.")
        out.append(KrobkaWarning(
            "KROBKA-R12", "slope −1: bounded-angle noise, type not identifiable",
            f"{t.label} dominates τ {_g(lo)}–{_g(hi)} s with slope −1. That slope only says the "
            "integrated angle error is bounded (stationary): quantization, white angle noise, "
            "dither residue and S(0) = 0 (blue) noises all give it; Q is then the RMS of the "
            "stationary angle error. For strapdown use the spectral shape matters (see the PSD "
            "and the impact section)." + extra,
            "σ(τ) → √3·σ_θ/τ for any noise with S(0) = 0 and ∫S/f² < ∞ (notes-allan-topology §2.9 "
            "rule 12; Krobka (Allan-graph topology) Table 7.2/7.3)", ev, severity=sev))


def _cluster_checks(fit: NoiseFit, out: list[KrobkaWarning]) -> None:
    dropped = np.isfinite(fit.edf) & (fit.edf < fit.min_edf)
    if not np.any(dropped):
        return
    lo, hi = fit.fit_range
    t = fit.tau[dropped]
    out.append(KrobkaWarning(
        "KROBKA-M12", "too few clusters at long τ",
        f"fit stopped at τ = {_g(hi)} s: the {t.size} longer τ ({_g(t.min())}–{_g(t.max())} s) "
        f"have EDF < {fit.min_edf:g} (fewer than ~{fit.min_edf:g} independent clusters; their "
        "confidence intervals blow up) and are plotted but not fitted. Conclusions about slopes "
        "there (K, R, B plateau) need a longer record",
        "the reliability of σ(τ) falls with the number of clusters; do not fit where the CI "
        "blows up (Krobka (Allan-graph topology) footnote on σ(ΔT)-graphs; notes M12)",
        {"fit_range_s": [lo, hi], "excluded_tau_s": t.tolist(),
         "excluded_edf": fit.edf[dropped].tolist()}))


def _trend_pairs(fit: NoiseFit, akdev) -> list[tuple[int, float, float]]:
    """(fit row, τ, σ_AK) where the Allan–Krobka dispersion lies below the Allan deviation's
    confidence interval (the KROBKA-M7 evidence)."""
    out = []
    for t, s_o in zip(np.asarray(akdev.tau, float), np.asarray(akdev.sigma, float)):
        i = int(np.argmin(np.abs(fit.tau - t)))
        if abs(fit.tau[i] / t - 1) > 1e-6 or not math.isfinite(fit.sigma_lo[i]):
            continue
        if s_o < fit.sigma_lo[i] and fit.sigma[i] > 0:
            out.append((i, float(t), float(s_o)))
    return out


def trend_needs_hadamard(fit: NoiseFit, akdev) -> bool:
    """Whether the trend check can warn (two or more τ with the Allan–Krobka dispersion below
    the Allan deviation's interval), so that the Hadamard deviation at those τ is needed as
    evidence; ``allan`` computes the OHDEV of the trend check only then (issue #13)."""
    return akdev is not None and len(_trend_pairs(fit, akdev)) >= 2


def _trend_checks(fit: NoiseFit, out: list[KrobkaWarning], akdev=None, ohdev=None,
                  record_s: float | None = None) -> None:
    if akdev is None:
        return
    rows = []
    for i, t, s_o in _trend_pairs(fit, akdev):
        diff = max(fit.sigma[i] ** 2 - s_o**2, 0.0)
        R = math.sqrt(2.0 * diff) / t * 3600.0 * _f(fit, "R")  # deg/h/h: a ramp adds ½(Rτ)²
        row = {"tau_s": t, "allan": float(fit.sigma[i]), "allan_krobka": s_o,
               "ramp_deg_h_per_h": R}
        if ohdev is not None:
            j = int(np.argmin(np.abs(np.asarray(ohdev.tau) - t)))
            row["hadamard"] = float(ohdev.sigma[j])
        rows.append(row)
    if len(rows) < 2:
        return
    R_est = float(np.median([r["ramp_deg_h_per_h"] for r in rows]))
    # a rate random walk realisation has a random end-to-end trend too: least-squares slope of
    # Brownian motion over T has variance 6K²/(5T); require the ramp to stand 3σ above it
    K = fit.term("K")
    T = float(record_s) if record_s else 4.0 * float(np.nanmax(fit.tau))
    # K: its value, or its upper bound when the fit could not establish it
    k_int = (0.0 if K is None else K.value if K.identified else (K.upper or 0.0)) / (
        60.0 * _f(fit, "K"))
    R_rrw = 3.0 * k_int * math.sqrt(6.0 / (5.0 * T)) * 3600.0 * _f(fit, "R")
    if R_est <= R_rrw:  # a rate random walk of the fitted size explains the trend
        return
    out.append(KrobkaWarning(
        "KROBKA-M7", "deterministic trend in the Allan variance",
        f"at τ {_g(rows[0]['tau_s'])}–{_g(rows[-1]['tau_s'])} s the Allan–Krobka dispersion is "
        f"below the Allan deviation's confidence interval at {len(rows)} τ: a deterministic "
        f"drift (ramp ≈ {_g(R_est)} {_u(fit, 'R')}, or a thermal trend) leaks in and "
        "masquerades "
        "as rate random walk / rate ramp. Remove it first (--detrend linear or quadratic, "
        "--detrend sine:PERIOD for a periodic term such as a 24 h cycle, or --model m.json for "
        "a thermal/environmental model from gyrotest model fit) and compare",
        "the Allan variance is a mean square, not a variance: deterministic signals contribute; "
        "the Allan–Krobka dispersion subtracts the squared mean difference and the Hadamard "
        "variance is blind to a ramp (Krobka (Allan-graph topology) §5, eq. 5.10; notes M7)",
        {"rows": rows, "ramp_estimate_deg_h_per_h": R_est,
         "rrw_trend_3sigma_deg_h_per_h": R_rrw}))


def _misfit_checks(fit: NoiseFit, out: list[KrobkaWarning], diagnosis=None) -> None:
    if fit.consistent:
        return
    regions = diagnosis.regions if diagnosis is not None else []
    txt = "; ".join(r.text() for r in regions[:3])
    sug = ""
    if diagnosis is not None and not diagnosis.no_missing_term:
        sug = " Diagnosis: " + diagnosis.verdict
    out.append(KrobkaWarning(
        "KROBKA-M6", "the noise model does not fit",
        f"χ²/dof = {fit.chi2_dof:.2f} (p = {fit.p_value:.2g}) with terms "
        f"{','.join(fit.requested)}" + (f"; {txt}" if txt else "") + ". The coefficients of a "
        "model that misfits absorb the missing noise: do not quote them without the "
        "residuals." + sug,
        "the five-slope IEEE basis is incomplete; unmodelled noises turn into parameter error "
        "(Krobka (Allan-graph topology) §6 example 3; notes M6)",
        {"chi2_per_dof": fit.chi2_dof, "p_value": fit.p_value}))


def _component_checks(fit: NoiseFit, out: list[KrobkaWarning]) -> None:
    if not fit.consistent:
        return  # a misfitting model trades terms anyway: KROBKA-M6 says so
    for t in fit.terms:
        if t.key == "N" or t.coef <= 0:
            continue
        sig = np.sqrt(t.avar(fit.tau))
        width = np.maximum(fit.sigma_hi - fit.sigma, 1e-300)
        # only where the interval is reliable (EDF ≥ 10): single long-τ points scatter widely
        ok = np.isfinite(fit.sigma_hi) & fit.used & (fit.edf >= 10.0)
        ex = np.where(ok, (sig - fit.sigma) / width, 0.0)
        k = int(np.argmax(ex))
        if ex[k] > 3.0:
            out.append(KrobkaWarning(
                "KROBKA-R16", f"component {t.label} exceeds the measurement",
                f"{t.text()} alone is above the measured σ at τ = {_g(fit.tau[k])} s by "
                f"{ex[k]:.1f} CI: the fit traded it against another term; treat it as an upper "
                "bound", "every partial deviation is bounded by the total, σ_i(τ) ≤ σ_Σ(τ) "
                "(Krobka (Allan-graph topology) eq. 5.9; notes §2.9 rule 16)",
                {"term": t.label, "tau_s": float(fit.tau[k]), "excess_ci": float(ex[k])}))


def krobka_checks(fit: NoiseFit, readoffs: dict[str, Any], *, akdev=None, ohdev=None,
                  quantum_arcsec: float | None = None, diagnosis=None,
                  record_s: float | None = None) -> list[KrobkaWarning]:
    """Run every check (module docstring) on a fitted Allan table.

    ``fit``: the :class:`NoiseFit` of the OADEV table (its τ, σ, CI and EDF are used);
    ``readoffs``: :func:`gyrotest.noise.noisefit.slope_readoffs` of the same table; ``akdev`` /
    ``ohdev``: Allan–Krobka and Hadamard deviation results at (some of) the same τ, for the
    trend check (the Hadamard values are reported, the test uses Allan–Krobka: the Hadamard
    variance differs from the Allan variance for RRW and flicker); ``record_s``: record length; ``quantum_arcsec``: pulse scale factor S0 for the Q comparison; ``diagnosis``:
    a :class:`gyrotest.noise.diagnose.Diagnosis` to quote in the misfit warning.
    Returns the warnings in the order of the table above (codes in :data:`CODES`).
    """
    out: list[KrobkaWarning] = []
    _arw_checks(fit, readoffs, out)
    _bias_checks(fit, readoffs, out)
    _hump_checks(fit, readoffs, out,
                 diagnosis.final if diagnosis is not None else None)
    _slope_checks(fit, out)
    _minus_one_checks(fit, out, quantum_arcsec)
    _cluster_checks(fit, out)
    _trend_checks(fit, out, akdev, ohdev, record_s)
    _misfit_checks(fit, out, diagnosis)
    _component_checks(fit, out)
    return out
