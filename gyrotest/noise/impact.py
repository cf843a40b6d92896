"""Application impact of a fitted noise model: attitude-error growth on a platform vs strapdown.

Krobka (platform vs strapdown noise accumulation, "35 years later", and Krobka (Allan-graph topology) Part I; notes-platform-vs-strapdown §1.3–1.4,
GYRO_REFERENCE §4 "Platform vs strapdown"): the same three gyros give different orientation
accuracy in an inertially stabilised platform and in a strapdown system, because in strapdown
the gyro errors are rotated by the vehicle attitude before they are integrated.

First-order model (small errors; "equations in variations", Krobka (Allan-graph topology) eq. 2.31), three equal,
uncorrelated gyros, constant vehicle rate ω about one gyro axis (z):

* platform:  φ(t) = ∫ ε(s) ds                     → ⟨|φ|²⟩ = 3·V_ax(t)
* strapdown: φ(t) = ∫ R_z(ωs)·ε(s) ds             → ⟨|φ|²⟩ = V_ax(t) + 2·V_tr(t, ω)

with V_ax the angle variance of one gyro's error integrated without modulation and V_tr that
of one transverse gyro modulated at ω. For stationary noise with (two-sided, IEEE) rate PSD S,
V_ax → S(0)·t and V_tr → S(f_ω)·t, f_ω = |ω|/2π, so the strapdown diffusion coefficient is
**S(0) + 2·S(f_ω)** against **3·S(0)** on the platform (Krobka & Sviridov 1984 eq. 3.6; seed
001 eq. 2.47). Per fitted term (internal units deg/h = arcsec/s, angles in arcsec):

==========  ====================================  ==========================================
term        V_ax(t) (platform, per axis)            V_tr(t, ω) (strapdown transverse axis)
==========  ====================================  ==========================================
N           N²·t                                    N²·t (identical: white noise is isotropic)
Q           2Q² (bounded)                           2Q² + ω²·τ0·Q²·t  (→ the white-angle term
                                                    2Q²τ0∫|ω|²dt for two axes, Krobka (Allan-graph topology) 2.48)
markov      (q_cT_c)²[t − T_c(1 − e^(−t/T_c))]      (q_cT_c)²/(1 + (ωT_c)²)·t  (strapdown better)
B (flicker) 2∫ B²/(2πf)·sin²(πft)/(πf)² df,         B²/|ω|·t for f_ω ≤ f0 (else 0)
            f from 1/T_record to f0
K           K²t³/3 (rate random walk from t = 0)    2K²/ω²·(t − sin(ωt)/ω)  (exact, W(0) = 0)
R           (R t²/2)² (deterministic ramp)          R²·|t e^(iωt)/(iω) + (e^(iωt) − 1)/ω²|²
sine        Ω0²(1 − cos 2πf0t)/(2πf0)²  (bounded)  ¼Ω0²(|I(2πf0 + ω)|² + |I(ω − 2πf0)|²),
                                                    |I(b)|² = 2(1 − cos bt)/b²
blue        2·α/(4πβ)·(1 − e^(−2πβt)) (bounded)     same bounded part + α f_ω²/(β² + f_ω²)·t
==========  ====================================  ==========================================

Terms with S(0) = 0 (Q, sinusoid, blue) stay bounded on a platform but grow ∝ t in strapdown:
they are flagged "platform-benign / strapdown-critical". The prediction is checked against a
Monte-Carlo integration of the first-order attitude error (:func:`monte_carlo_attitude`) with the
validated numbers of notes-platform-vs-strapdown §3.1.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..core.errors import InputError
from ..core.units import factor, parse_duration
from .terms import PLATFORM_BENIGN_LABEL

__all__ = [
    "Component",
    "ImpactResult",
    "attitude_impact",
    "axial_variance",
    "monte_carlo_attitude",
    "parse_vehicle_rate",
    "predict_attitude_variance",
    "transverse_variance",
]

ARCSEC_PER_DEG = 3600.0
RAD_PER_ARCSEC = math.pi / (180.0 * 3600.0)


@dataclass(frozen=True)
class Component:
    """One noise term for the attitude prediction, in internal units (deg/h = arcsec/s, s):
    ``key`` (N, Q, markov, B, K, R, sine, blue), ``c`` its Allan-variance coefficient as in
    :mod:`gyrotest.noise.noisefit` (N², Q², (q_cT_c)², B², K², R², Ω0², α), ``shape`` (T_c s, f0 Hz
    or β Hz), ``f_hi`` the band edge of B (Hz), ``label``."""

    key: str
    c: float
    shape: float | None = None
    f_hi: float | None = None
    label: str = ""

    @property
    def zero_dc_psd(self) -> bool:
        return self.key in ("Q", "sine", "blue")

    def psd(self, f: float, tau0: float) -> float:
        """Two-sided rate PSD (arcsec/s)²/Hz at f ≥ 0 (0 for the deterministic ramp; the
        sinusoid's lines are not a density)."""
        c, k = self.c, self.key
        if k == "N":
            return c
        if k == "Q":
            return (2 * math.pi * f) ** 2 * tau0 * c if f < 0.5 / tau0 else 0.0
        if k == "markov":
            return c / (1.0 + (2 * math.pi * f * self.shape) ** 2)
        if k == "B":
            if f <= 0:
                return math.inf
            return c / (2 * math.pi * f) if f <= (self.f_hi or math.inf) else 0.0
        if k == "K":
            return math.inf if f <= 0 else c / (2 * math.pi * f) ** 2
        if k == "blue":
            return c * f * f / (self.shape**2 + f * f)
        return 0.0


def _sinc2_cube_antiderivative(x: float) -> float:
    """F(x) = −sin²x/(2x²) − sin 2x/(2x) + Ci(2x), an antiderivative of sin²x/x³ (x > 0):
    two integrations by parts, d/dx[−sin²x/(2x²)] = sin²x/x³ − sin 2x/(2x²) and
    d/dx[−sin 2x/(2x)] = sin 2x/(2x²) − cos 2x/x, with Ci the cosine integral (Abramowitz &
    Stegun, Handbook of Mathematical Functions, 1964, 5.2.2; ``scipy.special.sici``)."""
    from scipy.special import sici

    s = math.sin(x)
    return -s * s / (2.0 * x * x) - math.sin(2.0 * x) / (2.0 * x) + float(sici(2.0 * x)[1])


def _flicker_angle_var(c: float, t: float, f_lo: float, f_hi: float) -> float:
    """2∫_{f_lo}^{f_hi} c/(2πf)·sin²(πft)/(πf)² df (arcsec² for c in arcsec²/s per Hz·Hz).

    Up to f_c = 20/t it is (c t²/π)·[F(πft)] with F the antiderivative of sin²x/x³
    (:func:`_sinc2_cube_antiderivative`; closed form, equal to an adaptive quadrature at
    1e-13 to within that quadrature's tolerance); above f_c, sin² → ½ and the tail
    c/(4π³)(1/f_c² − 1/f_hi²) is analytic."""
    if f_hi <= f_lo:
        return 0.0
    f_c = min(max(20.0 / t, f_lo), f_hi)
    val = 0.0
    if f_c > f_lo:
        val += c * t * t / math.pi * (_sinc2_cube_antiderivative(math.pi * f_c * t)
                                      - _sinc2_cube_antiderivative(math.pi * f_lo * t))
    if f_hi > f_c:
        val += c / (4 * math.pi**3) * (1.0 / f_c**2 - 1.0 / f_hi**2)
    return float(val)


def axial_variance(comp: Component, t: float, *, tau0: float, record_s: float) -> float:
    """Angle variance (arcsec²) at time t of one gyro's error integrated without modulation
    (platform axis, or the strapdown axis along the rotation); table in the module docstring.
    ``record_s``: the low-frequency cut-off 1/record_s of the flicker (B) term."""
    c, k = comp.c, comp.key
    if c <= 0:
        return 0.0
    if k == "N":
        return c * t
    if k == "Q":
        return 2.0 * c
    if k == "markov":
        T = comp.shape
        return c * (t + T * math.expm1(-t / T))
    if k == "B":
        return _flicker_angle_var(c, t, 1.0 / record_s, comp.f_hi or 0.5 / tau0)
    if k == "K":
        return c * t**3 / 3.0
    if k == "R":
        return c * t**4 / 4.0
    if k == "sine":
        a = 2 * math.pi * comp.shape
        return c * (1.0 - math.cos(a * t)) / a**2
    if k == "blue":
        return 2.0 * c / (4 * math.pi * comp.shape) * (-math.expm1(-2 * math.pi * comp.shape * t))
    raise KeyError(k)


def _I2(b: float, t: float) -> float:
    """|∫_0^t e^{ibs} ds|² = 2(1 − cos bt)/b² (→ t² as b → 0)."""
    if abs(b * t) < 1e-6:
        return t * t
    return 2.0 * (1.0 - math.cos(b * t)) / (b * b)


def transverse_variance(comp: Component, t: float, omega: float, *, tau0: float,
                        record_s: float) -> float:
    """Angle variance (arcsec²) at t of one gyro's error rotated at ω rad/s in the plane
    transverse to the rotation axis (module docstring); ω = 0 gives :func:`axial_variance`."""
    w = abs(float(omega))
    if w == 0.0:
        return axial_variance(comp, t, tau0=tau0, record_s=record_s)
    c, k = comp.c, comp.key
    if c <= 0:
        return 0.0
    f_w = w / (2 * math.pi)
    if k == "N":
        return c * t
    if k == "Q":
        return 2.0 * c + (w * w * tau0 * c * t if f_w < 0.5 / tau0 else 0.0)
    if k == "markov":
        return c / (1.0 + (w * comp.shape) ** 2) * t
    if k == "B":
        return (c / w * t) if f_w <= (comp.f_hi or 0.5 / tau0) else 0.0
    if k == "K":
        return 2.0 * c / w**2 * (t - math.sin(w * t) / w)
    if k == "R":
        z = t * complex(math.cos(w * t), math.sin(w * t)) / complex(0.0, w) + (
            complex(math.cos(w * t), math.sin(w * t)) - 1.0) / w**2
        return c * abs(z) ** 2
    if k == "sine":
        a = 2 * math.pi * comp.shape
        return 0.25 * c * (_I2(a + w, t) + _I2(w - a, t))
    if k == "blue":
        b = comp.shape
        bounded = 2.0 * c / (4 * math.pi * b) * (-math.expm1(-2 * math.pi * b * t))
        return bounded + c * f_w**2 / (b * b + f_w**2) * t
    raise KeyError(k)


def predict_attitude_variance(components: Sequence[Component], t: float, omega: float = 0.0, *,
                              tau0: float, record_s: float) -> dict[str, Any]:
    """⟨|φ|²⟩ (arcsec², sum over three axes) of the first-order attitude error at time t.

    platform = 3·ΣV_ax; strapdown (rotation ω rad/s about one gyro axis) = ΣV_ax + 2·ΣV_tr
    (Krobka & Sviridov 1984 eq. 3.6 / Krobka (Allan-graph topology) eq. 2.47 for stationary noise; exact forms for
    RRW, ramp and sinusoid; module docstring). Returns totals and per-component values."""
    per: dict[str, dict[str, float]] = {}
    plat = sd = 0.0
    for comp in components:
        ax = axial_variance(comp, t, tau0=tau0, record_s=record_s)
        tr = transverse_variance(comp, t, omega, tau0=tau0, record_s=record_s)
        per[comp.label or comp.key] = {"platform": 3.0 * ax, "strapdown": ax + 2.0 * tr}
        plat += 3.0 * ax
        sd += ax + 2.0 * tr
    return {"platform": plat, "strapdown": sd, "components": per}


_RATE_RE = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*([^\s]*)\s*$")


def parse_vehicle_rate(text: str | float) -> float:
    """Parse a vehicle rate like ``10deg/s``, ``0.5 rad/s``, ``30 rpm``, ``100deg/h`` (a bare
    number is deg/s) → rad/s. Units: any angular-rate unit of :mod:`gyrotest.core.units`."""
    if isinstance(text, (int, float)):
        return _sane_vehicle_rate(math.radians(float(text)), text)
    m = _RATE_RE.match(str(text))
    if not m:
        raise InputError(f"bad vehicle rate {text!r}; use e.g. 10deg/s, 0.5rad/s, 30rpm")
    val = float(m.group(1))
    unit = m.group(2) or "deg/s"
    dph = val * factor(unit, "rate", what="--vehicle-rate")
    return _sane_vehicle_rate(math.radians(dph / 3600.0), text)


def _sane_vehicle_rate(w: float, text) -> float:
    """|ω| from 1e-9 rad/s (0.2 mdeg/h: below it ωT underflows the closed forms) to 1e5 rad/s
    (16 000 rev/s, beyond any vehicle); 0 is the platform case."""
    if w != 0 and not 1e-9 <= abs(w) <= 1e5:
        raise InputError(f"--vehicle-rate {text!r} is outside 1e-9…1e5 rad/s; use e.g. 10deg/s")
    return w



def parse_horizon(text: str | float) -> float:
    """The prediction horizon (``--horizon``, e.g. ``1h``) in seconds; at least 1 µs (shorter,
    no attitude error accumulates, and the closed forms' argument πf·T underflows)."""
    horizon_s = parse_duration(text, what="--horizon")
    if not horizon_s >= 1e-6:
        raise InputError(f"--horizon must be at least 1 us (e.g. 1h), got {text!r}")
    return horizon_s

@dataclass
class ImpactResult:
    """Predicted attitude error at ``horizon_s`` for a platform and for strapdown at each
    vehicle rate (rad/s in ``rates_rad_s``). σ values in deg (sum over three axes, first
    order); ``conservative`` uses the upper bounds of the terms that are bounds only."""

    horizon_s: float
    rates_rad_s: list[float]
    platform_sigma_deg: float
    strapdown_sigma_deg: list[float]
    ratio: list[float]
    conservative_platform_sigma_deg: float
    conservative_strapdown_sigma_deg: list[float]
    components: list[dict[str, Any]]
    flags: list[dict[str, Any]]
    assumptions: list[str] = field(default_factory=list)
    model_terms: list[str] = field(default_factory=list)
    record_s: float | None = None
    extrapolation: str | None = None

    @property
    def extrapolated(self) -> bool:
        """The horizon lies beyond the record: the prediction extrapolates the noise model to
        times (frequencies below 1/T) the log never measured."""
        return self.extrapolation is not None

    def to_dict(self) -> dict[str, Any]:
        rows = []
        for i, w in enumerate(self.rates_rad_s):
            rows.append({
                "vehicle_rate_deg_s": math.degrees(w),
                "vehicle_rate_rad_s": w,
                "sigma_att_deg": self.strapdown_sigma_deg[i],
                "sigma_att_arcsec": self.strapdown_sigma_deg[i] * 3600.0,
                "sins_to_ins_ratio": self.ratio[i],
                "conservative_sigma_att_deg": self.conservative_strapdown_sigma_deg[i],
            })
        return {
            "method": "first-order attitude error of three equal uncorrelated gyros; platform "
                      "3*S(0)*t, strapdown [S(0) + 2 S(f_w)]*t plus bounded S(0)=0 terms and "
                      "exact forms for RRW, ramp, sinusoid (Krobka)",
            "horizon_s": self.horizon_s,
            "record_s": self.record_s,
            "extrapolated": self.extrapolated,
            "extrapolation": self.extrapolation,
            "model_terms": list(self.model_terms),
            "platform": {"sigma_att_deg": self.platform_sigma_deg,
                         "sigma_att_arcsec": self.platform_sigma_deg * 3600.0,
                         "conservative_sigma_att_deg": self.conservative_platform_sigma_deg},
            "strapdown": rows,
            "components": self.components,
            "flags": self.flags,
            "assumptions": list(self.assumptions),
        }


def components_from_fit(fit, *, conservative: bool = False) -> list[Component]:
    """:class:`Component` list from a :class:`gyrotest.noise.noisefit.NoiseFit` (point estimates; with
    ``conservative`` the terms that are upper bounds enter at their bound)."""
    out = []
    for t in fit.terms:
        c = t.coef
        shape = t.shape
        if t.key in _SHAPED and shape is None:
            # a two-parameter term that was never found: its bound has no shape (T_c or β), so
            # it cannot enter the prediction at all (see unshaped_bounds)
            out.append(Component(t.key, 0.0, 1.0, None, t.label))
            continue
        if conservative and not t.identified and t.upper is not None:
            c = _coef_from_value(t.key, t.upper, shape, fit.q)
        f_hi = (t.bi_f0 if t.bi_f0 is not None else 0.5 / fit.tau0) if t.key == "B" else None
        out.append(Component(t.key, float(c), shape, f_hi, t.label))
    return out


_SHAPED = ("markov", "sine", "blue")


def unshaped_bounds(fit) -> list[str]:
    """Labels of the two-parameter terms that are bounds without a shape (T_c, f0 or β was
    never identified): they are left out of the attitude prediction, also the conservative
    one."""
    return [t.label for t in fit.terms if t.key in _SHAPED and t.shape is None]


def _coef_from_value(key: str, v: float, shape: float | None, q=None) -> float:
    """The fit's coefficient c of a term from its reported main value (the inverse of
    :func:`gyrotest.noise.noisefit._reported`; ``q`` the table's
    :class:`~gyrotest.noise.quantity.Quantity`, default gyro)."""
    if q is not None:
        main = {"markov": "q_c", "sine": "Omega0", "blue": "alpha"}.get(key, key)
        v = v / q.factor(main)
    if key == "N":
        return (60.0 * v) ** 2
    if key == "K":
        return (v / 60.0) ** 2
    if key == "R":
        return (v / 3600.0) ** 2
    if key in ("Q", "B", "sine"):
        return v * v
    if key == "markov":
        return (v / 60.0 * shape) ** 2
    if key == "blue":
        return v
    raise KeyError(key)


def extrapolation_reason(fit, horizon_s: float, record_s: float) -> str | None:
    """Why a prediction at ``horizon_s`` is an extrapolation, or None when it is not.

    The attitude error at t integrates the rate noise down to frequencies ≈ 1/t; a record of
    length T measured them down to 1/T, and the Allan fit only to τ_max (≈ T/4). Past T the
    prediction rests on the fitted slopes continuing (a rate ramp or random walk read from a
    few long-τ clusters grows as t² or t^1.5 there): it is printed as "extrapolated" with this
    reason, never as a measurement."""
    if not horizon_s > record_s * (1.0 + 1e-9):
        return None
    from ..core.units import format_duration

    t_max = float(np.max(fit.tau[fit.used])) if np.any(fit.used) else float(np.max(fit.tau))
    slow = [t.label for t in fit.terms if t.key in ("B", "K", "R", "markov", "sine")
            and t.coef > 0]
    return (f"the horizon {format_duration(horizon_s)} is {horizon_s / record_s:.3g}× the "
            f"record ({format_duration(record_s)}; model fitted to τ ≤ "
            f"{format_duration(t_max)}): the noise below 1/T was never measured"
            + (f", and {', '.join(slow)} are extrapolated as their fitted slopes"
               if slow else "") + "; shorten --horizon or record longer")


def attitude_impact(fit, *, horizon_s: float = 3600.0,
                    vehicle_rates_rad_s: Sequence[float] = (), record_s: float | None = None
                    ) -> ImpactResult:
    """Platform vs strapdown attitude error predicted from a fitted noise model.

    σ_att(horizon) = √⟨|φ|²⟩ in deg (three axes, first order) on an inertially stabilised
    platform and in strapdown at each constant vehicle rate, their ratio SINS/INS, and the
    per-component contributions; S(0) = 0 components are flagged "platform-benign /
    strapdown-critical" with their strapdown diffusion 2·S(f_ω) (rad²/s). ``record_s``: the
    record length (flicker low cut-off); default the longest τ × 4.
    """
    if horizon_s <= 0:
        raise InputError("impact horizon must be > 0 s")
    tau0 = fit.tau0
    rec = float(record_s) if record_s else float(np.nanmax(fit.tau)) * 4.0
    rates = [float(w) for w in vehicle_rates_rad_s]
    comps = components_from_fit(fit)
    cons = components_from_fit(fit, conservative=True)
    p0 = predict_attitude_variance(comps, horizon_s, 0.0, tau0=tau0, record_s=rec)
    c0 = predict_attitude_variance(cons, horizon_s, 0.0, tau0=tau0, record_s=rec)
    sd, ratio, csd, per_rate = [], [], [], []
    for w in rates:
        p = predict_attitude_variance(comps, horizon_s, w, tau0=tau0, record_s=rec)
        c = predict_attitude_variance(cons, horizon_s, w, tau0=tau0, record_s=rec)
        sd.append(math.sqrt(p["strapdown"]) / ARCSEC_PER_DEG)
        csd.append(math.sqrt(c["strapdown"]) / ARCSEC_PER_DEG)
        ratio.append(math.sqrt(p["strapdown"] / p0["platform"]) if p0["platform"] > 0
                     else math.inf)
        per_rate.append(p["components"])
    comp_rows = []
    for comp in comps:
        lab = comp.label or comp.key
        row = {"term": lab, "zero_dc_psd": comp.zero_dc_psd,
               "platform_sigma_deg": math.sqrt(p0["components"][lab]["platform"]) / 3600.0,
               "strapdown_sigma_deg": [math.sqrt(pr[lab]["strapdown"]) / 3600.0
                                       for pr in per_rate]}
        comp_rows.append(row)
    flags = []
    unshaped = unshaped_bounds(fit)
    for comp, ccomp, t in zip(comps, cons, fit.terms):
        if t.label in unshaped:
            continue
        if comp.zero_dc_psd:
            use = comp if comp.c > 0 else ccomp  # a bound-only term: its diffusion at the bound
            diff = [2.0 * use.psd(w / (2 * math.pi), tau0) * RAD_PER_ARCSEC**2 for w in rates]
            flags.append({
                "term": comp.label, "label": PLATFORM_BENIGN_LABEL, "status": t.status,
                "strapdown_diffusion_rad2_per_s": diff,
                "text": (f"{t.label} ({t.text()}): S(0) = 0 — bounded angle error on a platform, "
                         "grows ∝ t in strapdown" + ("" if not rates else ": diffusion 2·S(f_ω) "
                         + ("= " if comp.c > 0 else "≤ ")
                         + ", ".join(f"{d:.3g} rad²/s at {math.degrees(w):g} deg/s"
                                     for d, w in zip(diff, rates))))})
        elif comp.key == "markov" and rates:
            flags.append({"term": comp.label, "label": "strapdown-better (rotation averages it)",
                          "status": t.status,
                          "text": f"{t.label}: S(f_ω) < S(0), strapdown rotation averages it"})
    return ImpactResult(
        record_s=rec, extrapolation=extrapolation_reason(fit, horizon_s, rec),
        model_terms=list(fit.requested), horizon_s=float(horizon_s), rates_rad_s=rates,
        platform_sigma_deg=math.sqrt(p0["platform"]) / ARCSEC_PER_DEG,
        strapdown_sigma_deg=sd, ratio=ratio,
        conservative_platform_sigma_deg=math.sqrt(c0["platform"]) / ARCSEC_PER_DEG,
        conservative_strapdown_sigma_deg=csd, components=comp_rows, flags=flags,
        assumptions=[
            "first order (small angles): platform phi = integral of eps dt, strapdown phi = "
            "integral of R_z(w t) eps dt",
            "three equal, uncorrelated gyros with the fitted model; constant vehicle rate about "
            "one gyro axis",
            "terms that are upper bounds only enter at their point estimate (conservative: at "
            "their bound)",
            f"bias instability (flicker) integrated from 1/T_record = {1 / rec:.3g} Hz; rate "
            "random walk and ramp start at t = 0",
        ] + ([f"left out (bounds whose T_c/f0/β was never identified, so they have no "
              f"spectrum): {', '.join(unshaped)}"] if unshaped else []))


# ---------------------------------------------------------------------------------------------
# Monte Carlo
# ---------------------------------------------------------------------------------------------


def monte_carlo_attitude(components: Sequence[Component], *, duration_s: float, dt: float,
                         omega: float | Sequence[float], runs: int = 300, seed: int = 0,
                         chunk: int = 16) -> dict[str, Any]:
    """Monte-Carlo ⟨|φ|²⟩ − |⟨φ⟩|² (arcsec², three axes: Krobka's dispersion, Krobka (Allan-graph topology) eq.
    2.33) of the first-order attitude error at ``duration_s``, for the validation of
    :func:`predict_attitude_variance` (notes-platform-vs-strapdown §3.1, Appendix A script 1).

    Each run draws the three gyros' rate errors ε_k (arcsec/s) at step ``dt`` for the N
    (white, std √c/√dt), Q (white angle w_k ~ N(0, c), ε = Δw/dt) and markov (AR(1) of
    variance c/(2T_c), point samples) components, and sums platform φ = Σ ε_k dt and strapdown
    φ = Σ R_z(ω t_k) ε_k dt. Vectorised over ``chunk`` runs at a time. ``omega`` (rad/s) may be
    a list: every rate uses the same noise draws. Returns the platform dispersion and the
    strapdown dispersion (a list when ``omega`` is a list)."""
    n = int(round(duration_s / dt))
    t = np.arange(1, n + 1) * dt
    omegas = [float(omega)] if np.isscalar(omega) else [float(w) for w in omega]
    CS = np.empty((n, 2 * len(omegas)), dtype=np.float32)
    for i, w in enumerate(omegas):
        CS[:, 2 * i] = np.cos(w * t)
        CS[:, 2 * i + 1] = np.sin(w * t)
    rng = np.random.default_rng(seed)
    plat = np.zeros((runs, 3))
    sd = np.zeros((len(omegas), runs, 3))
    for r0 in range(0, runs, chunk):
        k = min(chunk, runs - r0)
        eps = np.zeros((k, 3, n), dtype=np.float32)
        for comp in components:
            if comp.c <= 0:
                continue
            if comp.key == "N":
                eps += rng.standard_normal((k, 3, n), dtype=np.float32) * np.float32(
                    math.sqrt(comp.c / dt))
            elif comp.key == "Q":
                w = rng.standard_normal((k, 3, n + 1), dtype=np.float32)
                w *= np.float32(math.sqrt(comp.c) / dt)
                eps += np.diff(w, axis=-1)
            elif comp.key == "markov":
                from scipy.signal import lfilter

                T = comp.shape
                phi = math.exp(-dt / T)
                var = comp.c / (2.0 * T)
                e = rng.standard_normal((k, 3, n), dtype=np.float32) * np.float32(
                    math.sqrt(var * (1.0 - phi * phi)))
                x0 = rng.standard_normal((k, 3)) * math.sqrt(var)
                zi = (phi * x0)[..., None].astype(np.float32)
                x, _ = lfilter(np.array([1.0], np.float32), np.array([1.0, -phi], np.float32),
                               e, axis=-1, zi=zi)
                eps += x
            else:
                raise InputError(f"monte_carlo_attitude: {comp.key} not simulated (N, Q, markov)")
        plat[r0:r0 + k] = eps.sum(axis=-1, dtype=np.float64) * dt
        px = (eps[:, 0] @ CS).astype(np.float64) * dt  # (k, 2*len(omegas)): Σ ε_x cos, Σ ε_x sin
        py = (eps[:, 1] @ CS).astype(np.float64) * dt
        for i in range(len(omegas)):
            c_x, s_x = px[:, 2 * i], px[:, 2 * i + 1]
            c_y, s_y = py[:, 2 * i], py[:, 2 * i + 1]
            sd[i, r0:r0 + k, 0] = c_x - s_y
            sd[i, r0:r0 + k, 1] = s_x + c_y
            sd[i, r0:r0 + k, 2] = plat[r0:r0 + k, 2]

    def disp(a: np.ndarray) -> float:
        return float(np.mean(np.sum(a * a, axis=1)) - np.sum(np.mean(a, axis=0) ** 2))

    strap = [disp(sd[i]) for i in range(len(omegas))]
    return {"platform": disp(plat), "strapdown": strap[0] if np.isscalar(omega) else strap,
            "runs": runs, "steps": n}
