"""Firmware compensation of the scale-factor model (``gyrotest scale-factor --json``).

IEEE Std 952-1997 §8.3 model equation, as :mod:`gyrotest.scalefactor.tablefit` fits it::

    S0·out = (I + D)·(1 + 1e-6·ε_K)⁻¹,   ε_K = ε_0 + ε_T·(T − T_ref) + f(I)

with I the input rate, D the input-referred bias (D_F), S0 the nominal scale factor (S0·out is
the log's rate) and f(I) = Σ e_j·g_j(u), u = I/FS, the rate-dependent terms the data support:

* asymmetry ``(A/2)·sgn(u)``; power terms ``c1·u``, ``c2·u²``, ``c3·u³``, ``c4·u⁴``;
* periodic ``p·sin(2π·I[deg/s]/P + φ)``;
* Adler lock-in (ring-laser dead band |I| ≤ Ω_L): the output is ``S0·out ∝ sgn(I)·√(I² − Ω_L²)``,
  so f(I) = (I/I' − 1)·1e6 with I' = sgn(I)·√(I² − Ω_L²) (plus the other terms taken at I').

T_ref is the mean of the runs' mean temperatures (ε_0 is the scale-factor error over those
runs and ε_T the slope of their scale factors against temperature). Compensation inverts the
equation: ``I = S0·out·(1 + 1e-6·ε_K(I)) − D``, solved by fixed-point iteration from
I = S0·out − D (each step multiplies the error by about 1e-6·|d(I·f)/dI| < 1e-3).

Two deliverables: a CSV look-up table of f(I) and ε_K(I) (at T_ref) with the bias-free model
output for each input rate (firmware interpolates input against output), and a C header with
the coefficients, the equation and inline functions ``<prefix>_eps_k_ppm(I, T)`` and
``<prefix>_input_dps(rate, T)``.
"""

from __future__ import annotations

import csv
import io
import math
import re
from dataclasses import dataclass, field

import numpy as np

from ..core.errors import InputError
from ..scalefactor.tablefit import TERM_ALIASES, TERMS
from .common import Document, banner, need, number
from .envlut import ascii_text

#: the power of u = I/FS of each power term of f(I) (u1 … u4: one name everywhere)
POWERS = {"u1": 1, "u2": 2, "u3": 3, "u4": 4}
KNOWN = set(POWERS) | {"asymmetry", "periodic", "lockin"}


@dataclass
class SFModel:
    """The scale-factor model of a ``scale-factor --json`` document (rates in deg/s)."""

    source: str
    eps0_ppm: float
    epsT_ppm_per_degC: float | None
    t_ref_degC: float | None
    fs_dps: float
    bias_dps: float
    terms: dict[str, float] = field(default_factory=dict)  # name -> coefficient, ppm
    sigma: dict[str, float] = field(default_factory=dict)
    period_dps: float | None = None
    phase_deg: float | None = None
    lockin_dps: float | None = None
    points_I_dps: np.ndarray | None = None  # the plateaus' inputs and the fit's own f(I)
    points_f_ppm: np.ndarray | None = None

    # ------------------------------------------------------------------ evaluation
    def f_terms(self, I_dps) -> dict[str, np.ndarray]:
        """Each rate-dependent term of f(I) in ppm (lock-in: the Adler part; NaN inside the
        dead band)."""
        I = np.asarray(I_dps, dtype=float)
        Ie = self._adler(I)
        u = Ie / self.fs_dps
        out: dict[str, np.ndarray] = {}
        for name, c in self.terms.items():
            if name == "asymmetry":
                out[name] = c * 0.5 * np.sign(u)
            elif name in POWERS:
                out[name] = c * u ** POWERS[name]
            elif name == "periodic":
                out[name] = c * np.sin(2 * math.pi * Ie / self.period_dps
                                       + math.radians(self.phase_deg))
        if self.lockin_dps:
            with np.errstate(divide="ignore", invalid="ignore"):
                rest = sum(out.values()) if out else np.zeros_like(I)
                # I/(I'·(1 − 1e-6 Σ)) − 1 in ppm, minus the other terms' share
                total = (I / (Ie * (1.0 - 1e-6 * rest)) - 1.0) * 1e6
                out["lockin"] = np.where(np.abs(I) > self.lockin_dps, total - rest, np.nan)
        return out

    def _adler(self, I: np.ndarray) -> np.ndarray:
        if not self.lockin_dps:
            return I
        return np.sign(I) * np.sqrt(np.maximum(I * I - self.lockin_dps ** 2, 0.0))

    def f_ppm(self, I_dps) -> np.ndarray:
        terms = self.f_terms(I_dps)
        return sum(terms.values()) if terms else np.zeros_like(np.asarray(I_dps, float))

    def eps_k_ppm(self, I_dps, temp_degC: float | None = None) -> np.ndarray:
        e = self.eps0_ppm + self.f_ppm(I_dps)
        if temp_degC is not None and self.epsT_ppm_per_degC is not None:
            e = e + self.epsT_ppm_per_degC * (temp_degC - self.t_ref_degC)
        return e

    def output_dps(self, I_dps, temp_degC: float | None = None) -> np.ndarray:
        """Model output S0·out for input I (deg/s), bias included."""
        I = np.asarray(I_dps, dtype=float)
        return (I + self.bias_dps) / (1.0 + 1e-6 * self.eps_k_ppm(I, temp_degC))


def load(doc: Document) -> SFModel:
    d, src = doc.data, doc.source
    ek = need(d, "epsilon_k", src)
    nm = need(d, "nonlinearity_model", src)
    fs = number(need(ek, "full_scale_dps", src, "epsilon_k"), src, "epsilon_k.full_scale_dps")
    if not (math.isfinite(fs) and fs > 0):
        raise InputError(f"{src}: epsilon_k.full_scale_dps must be a positive number, got {fs}")
    eps0 = number(need(ek, "epsilon_0_ppm", src, "epsilon_k"), src, "epsilon_0_ppm")
    epsT = ek.get("epsilon_T_ppm_per_degC")
    epsT = None if epsT is None else number(epsT, src, "epsilon_T_ppm_per_degC")
    temps = [r.get("temperature_mean_degC") for r in d.get("runs") or []
             if isinstance(r, dict) and r.get("temperature_mean_degC") is not None]
    t_ref = float(np.mean([number(t, src, "runs[].temperature_mean_degC") for t in temps])) \
        if temps else None
    if epsT is not None and t_ref is None:
        epsT = None  # a slope without its reference cannot be applied
    bias_dph = d.get("bias_dph")
    bias = 0.0 if bias_dph is None else number(bias_dph, src, "bias_dph") / 3600.0
    m = SFModel(src, eps0, epsT, t_ref, fs, bias)
    for i, c in enumerate(need(ek, "f_terms", src, "epsilon_k")):
        if not isinstance(c, dict):
            raise InputError(f"{src}: epsilon_k.f_terms[{i}] is not an object")
        name = TERM_ALIASES.get(c.get("term"), c.get("term"))  # an older document: cubic → u2
        if name not in KNOWN:
            raise InputError(f"{src}: epsilon_k.f_terms[{i}]: unknown term {name!r}; known: "
                             f"{', '.join(sorted(KNOWN))}")
        coef = number(c.get("coefficient_ppm"), src, f"f_terms[{i}].coefficient_ppm")
        if not math.isfinite(coef):
            raise InputError(f"{src}: f_terms[{i}] ({name}) has no finite coefficient")
        m.terms[name] = coef
        m.sigma[name] = c.get("sigma_ppm")
        if name == "periodic":
            m.period_dps = number(c.get("period_dps"), src, "f_terms.periodic.period_dps")
            m.phase_deg = number(c.get("phase_deg"), src, "f_terms.periodic.phase_deg")
            if not m.period_dps > 0:
                raise InputError(f"{src}: periodic term with period {m.period_dps} deg/s")
        if name == "lockin":
            m.lockin_dps = number(c.get("lock_in_rate_dps"), src, "f_terms.lockin.lock_in_rate_dps")
    m.terms.pop("lockin", None)  # evaluated through the Adler transform
    if nm.get("full_scale_dps") not in (None, fs):
        raise InputError(f"{src}: full scale differs between epsilon_k and nonlinearity_model")
    pts = [p for p in d.get("points") or [] if isinstance(p, dict)
           and p.get("f_model_ppm") is not None and p.get("input_rate_dph") is not None]
    if pts:
        m.points_I_dps = np.array([float(p["input_rate_dph"]) / 3600.0 for p in pts])
        m.points_f_ppm = np.array([float(p["f_model_ppm"]) for p in pts])
    return m


def default_rates(m: SFModel) -> np.ndarray:
    """−FS … +FS in 101 steps."""
    return np.linspace(-m.fs_dps, m.fs_dps, 101)


def _equation(m: SFModel) -> list[str]:
    parts = []
    for name, c in m.terms.items():
        if name == "asymmetry":
            parts.append(f"{c:.10g}/2*sgn(I)")
        elif name in POWERS:
            p = POWERS[name]
            parts.append(f"{c:.10g}*(I/{m.fs_dps:g})" + (f"^{p}" if p > 1 else ""))
        elif name == "periodic":
            parts.append(f"{c:.10g}*sin(2*pi*I/{m.period_dps:.10g} + {m.phase_deg:.10g} deg)")
    f = " + ".join(parts) or "0"
    lines = [f"f(I) [ppm] = {f}   (I in deg/s)"]
    if m.lockin_dps:
        lines.append(f"lock-in (Adler): the terms above at I' = sgn(I)*sqrt(I^2 - "
                     f"{m.lockin_dps:.6g}^2), f = (I/(I'(1 - 1e-6 f(I'))) - 1)*1e6; "
                     f"no output inside |I| <= {m.lockin_dps:.6g} deg/s")
    t = (f" + {m.epsT_ppm_per_degC:.6g}*(T - {m.t_ref_degC:.4g} degC)"
         if m.epsT_ppm_per_degC is not None else "")
    lines.append(f"eps_K [ppm] = {m.eps0_ppm:.10g}{t} + f(I)")
    lines.append(f"rate = (I + D)/(1 + 1e-6*eps_K), D = {m.bias_dps:.10g} deg/s; "
                 "compensation: I = rate*(1 + 1e-6*eps_K(I)) - D")
    return lines


def lut_csv(doc: Document, rates: np.ndarray | None) -> tuple[str, dict]:
    m = load(doc)
    if m.lockin_dps is None and not m.terms and m.epsT_ppm_per_degC is None:
        pass  # a straight line: the table is constant, still a valid deliverable
    I = default_rates(m) if rates is None else np.asarray(rates, float)
    cols = m.f_terms(I)
    f = sum(cols.values()) if cols else np.zeros_like(I)
    eps = m.eps0_ppm + f
    out = I / (1.0 + 1e-6 * eps)
    head = [f"# {banner('scale-factor compensation look-up table', [doc.source])}",
            "# IEEE 952 model equation; rates in deg/s, errors in ppm of scale factor:"]
    head += [f"#   {x}" for x in _equation(m)]
    head.append("# columns: input_rate_dps = I; f_ppm = f(I); epsilon_k_ppm = eps_K at T_ref"
                + (f" = {m.t_ref_degC:.4g} degC" if m.t_ref_degC is not None else "")
                + "; output_rate_dps = the bias-free model output I/(1 + 1e-6 eps_K); then "
                "each term of f(I)")
    head.append("# firmware: subtract the bias, interpolate input_rate_dps against "
                "output_rate_dps (monotonic) or apply eps_K from the C header")
    if m.lockin_dps:
        head.append(f"# lock-in dead band |I| <= {m.lockin_dps:.6g} deg/s: f is nan there "
                    "(no output to compensate)")
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    names = list(cols)
    w.writerow(["input_rate_dps", "f_ppm", "epsilon_k_ppm", "output_rate_dps"]
               + [f"{n}_ppm" for n in names])
    for i in range(len(I)):
        w.writerow([f"{I[i]:.10g}", f"{f[i]:.10g}", f"{eps[i]:.10g}", f"{out[i]:.12g}"]
                   + [f"{cols[n][i]:.10g}" for n in names])
    summary = {"rows": int(len(I)), "rate_range_dps": [float(I.min()), float(I.max())],
               "terms": names, "t_ref_degC": m.t_ref_degC}
    return "\n".join(head) + "\n" + buf.getvalue(), summary


def c_header(doc: Document, *, prefix: str = "gyro_sf") -> tuple[str, dict]:
    if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", prefix):
        raise InputError(f"--prefix {prefix!r} is not a C identifier")
    m = load(doc)
    if m.lockin_dps:
        raise InputError(f"{doc.source}: the model has a lock-in dead band (|I| <= "
                         f"{m.lockin_dps:.4g} deg/s): there is no output to compensate inside "
                         "it, so no C function; export the .csv table instead")
    P = prefix.upper()
    lines = ["/*", f" * {banner('Scale-factor compensation', [doc.source])}.", " *",
             " * IEEE 952 model equation, rates in deg/s, errors in ppm of scale factor:"]
    lines += [f" *   {x}" for x in _equation(m)]
    lines += [" * Coefficients (value, 1-sigma from the fit):",
              f" *   {P}_EPS0_PPM = {m.eps0_ppm:.10g} ppm"]
    if m.epsT_ppm_per_degC is not None:
        lines.append(f" *   {P}_EPST_PPM_PER_DEGC = {m.epsT_ppm_per_degC:.6g} ppm/degC, "
                     f"T_ref = {m.t_ref_degC:.6g} degC (mean temperature of the runs)")
    for name, c in m.terms.items():
        s = m.sigma.get(name)
        lines.append(f" *   {P}_{name.upper()}_PPM = {c:.10g} ppm"
                     + (f" (+- {s:.3g})" if isinstance(s, (int, float)) else "")
                     + (f": f(I) term {name}, {TERMS[name].formula}, u = I/FS" if name in POWERS
                        else ""))
    lines.append(" * Inputs: the rate as the gyro reports it (S0*out, deg/s) and the "
                 "temperature (degC).")
    lines = [ascii_text(x) for x in lines]
    guard = f"{P}_H"
    lines += [" */", f"#ifndef {guard}", f"#define {guard}", "", "#include <math.h>", "",
              f"#define {P}_EPS0_PPM ({m.eps0_ppm!r})",
              f"#define {P}_EPST_PPM_PER_DEGC ({(m.epsT_ppm_per_degC or 0.0)!r})",
              f"#define {P}_TREF_DEGC ({(m.t_ref_degC or 0.0)!r})",
              f"#define {P}_FS_DPS ({m.fs_dps!r})",
              f"#define {P}_BIAS_DPS ({m.bias_dps!r}) /* input-referred bias D */"]
    body = []
    for name, c in m.terms.items():
        lines.append(f"#define {P}_{name.upper()}_PPM ({c!r})")
        if name == "asymmetry":
            body.append(f"{P}_ASYMMETRY_PPM * 0.5 * ((u > 0.0) - (u < 0.0))")
        elif name in POWERS:
            body.append(f"{P}_{name.upper()}_PPM" + " * u" * POWERS[name])
        elif name == "periodic":
            lines += [f"#define {P}_PERIOD_DPS ({m.period_dps!r})",
                      f"#define {P}_PHASE_RAD ({math.radians(m.phase_deg)!r})"]
            body.append(f"{P}_PERIODIC_PPM * sin(6.283185307179586 * i_dps / {P}_PERIOD_DPS "
                        f"+ {P}_PHASE_RAD)")
    f_expr = " +\n           ".join(body) if body else "0.0"
    lines += ["", "/* rate-dependent scale-factor error f(I), ppm; I in deg/s */",
              f"static inline double {prefix}_f_ppm(double i_dps)", "{",
              f"    double u = i_dps / {P}_FS_DPS;", "    (void)u;",
              f"    return {f_expr};", "}", "",
              "/* eps_K(I, T) = eps_0 + eps_T (T - T_ref) + f(I), ppm */",
              f"static inline double {prefix}_eps_k_ppm(double i_dps, double temp_degC)", "{",
              f"    return {P}_EPS0_PPM + {P}_EPST_PPM_PER_DEGC * (temp_degC - {P}_TREF_DEGC) +",
              f"           {prefix}_f_ppm(i_dps);", "}", "",
              "/* compensated input rate, deg/s, from the rate the gyro reports (S0*out, deg/s):",
              " * I = rate*(1 + 1e-6 eps_K(I)) - D, three fixed-point steps from I = rate - D */",
              f"static inline double {prefix}_input_dps(double rate_dps, double temp_degC)", "{",
              f"    double i = rate_dps - {P}_BIAS_DPS;", "    int k;",
              "    for (k = 0; k < 3; k++)",
              f"        i = rate_dps * (1.0 + 1e-6 * {prefix}_eps_k_ppm(i, temp_degC)) - "
              f"{P}_BIAS_DPS;",
              "    return i;", "}", "", f"#endif /* {guard} */"]
    summary = {"prefix": prefix, "terms": list(m.terms), "t_ref_degC": m.t_ref_degC}
    return "\n".join(lines) + "\n", summary
