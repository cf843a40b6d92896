"""Firmware compensation tables of a drift model (``gyrotest model fit -o`` / ``thermal-fit -o``).

The model is ``drift [deg/h] = Σ coefficient·regressor`` (:mod:`gyrotest.envmodel.model`);
firmware subtracts it: ``compensated rate = measured rate − drift``. Two deliverables:

* a CSV look-up table over a temperature grid of the temperature polynomial (bias, T, T2, T3
  terms of one temperature channel), one column per term and their sum, evaluated by the
  model's own term functions (:func:`gyrotest.envmodel.terms.build_term`);
* a C header with every coefficient (value, unit, 1σ), the references, the equation in a
  comment and an inline function ``<prefix>_dph(...)`` of the instantaneous inputs.

Terms that are linear in an input the firmware measures are supported as inputs of the C
function and listed in the CSV header: dT/dt and d(T_a − T_b)/dt (degC/h, computed as the fit
did: derivative smoothed by a centred moving mean over the model's window W), magnetic field
(uT, normalised by H0), supply voltage (V − V_ref). Terms with memory or time dependence
(Tlag, warm-up, ramp, sinusoid, hysteresis, earth, custom) and the g / rate terms are not
exported; ``static_only`` leaves them out and names them in the file.
"""

from __future__ import annotations

import csv
import io
import math
import re
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..core.errors import InputError
from .common import Document, banner

if TYPE_CHECKING:
    from ..envmodel.model import EnvModel

POLY = {"bias": 0, "T": 1, "T2": 2, "T3": 3}
LINEAR_INPUT = {"dTdt", "dGdt", "Hx", "Hy", "Hz", "V"}


def c_ident(name: str) -> str:
    """A C identifier from a channel or term name (``T(T_case)`` → ``T_T_case``)."""
    s = re.sub(r"_+", "_", re.sub(r"[^A-Za-z0-9_]", "_", name)).strip("_") or "x"
    return s if re.match(r"[A-Za-z_]", s) else "_" + s


_ASCII = {"§": "sec.", "Ṫ": "Tdot", "·": "*", "²": "^2", "³": "^3", "Δ": "d", "±": "+-",
          "−": "-", "∇": "grad", "…": "...", "–": "-", "—": "-", "Ω": "Omega", "μ": "u",
          "τ": "tau", "ω": "w"}


def ascii_text(s: str) -> str:
    """C comments in plain ASCII (embedded toolchains): known symbols spelled out, others '?'."""
    return "".join(_ASCII.get(c, c) if ord(c) > 127 else c for c in s).encode(
        "ascii", "replace").decode()


@dataclass
class Plan:
    """The exportable terms of a model: (term, kind) pairs, the dropped ones, the inputs."""

    model: EnvModel
    terms: list  # ModelTerm, exportable
    dropped: list[str]
    temp_channels: list[str]  # channels of the polynomial terms
    inputs: list[tuple[str, str, str]]  # (C name, unit, description)


def load_model(doc: Document):
    from ..envmodel.model import EnvModel

    return EnvModel.from_dict(doc.data, doc.source)


def plan(doc: Document, *, static_only: bool = False) -> Plan:
    m = load_model(doc)
    keep, dropped = [], []
    temps: list[str] = []
    inputs: list[tuple[str, str, str]] = []

    def add_input(name, unit, what):
        if name not in [i[0] for i in inputs]:
            inputs.append((name, unit, what))

    for t in m.terms:
        k, ch = t.spec.key, t.spec.channels
        if len(t.coef) != t.spec.n_coef or not all(math.isfinite(c) for c in t.coef):
            raise InputError(f"{doc.source}: malformed model file: term {t.spec.label} has "
                             f"{len(t.coef)} finite coefficient(s), needs {t.spec.n_coef}; "
                             "write the model again with -o")
        if k in POLY:
            keep.append(t)
            if k != "bias":
                if ch[0] not in temps:
                    temps.append(ch[0])
                add_input(c_ident(ch[0]), "degC", f"temperature {ch[0]}")
        elif k in LINEAR_INPUT:
            keep.append(t)
            if k == "dTdt":
                add_input(f"dTdt_{c_ident(ch[0])}", "degC/h", f"dT/dt of {ch[0]}")
            elif k == "dGdt":
                add_input(f"dGdt_{c_ident(ch[0])}_{c_ident(ch[1])}", "degC/h",
                          f"d({ch[0]} - {ch[1]})/dt")
            elif k in ("Hx", "Hy", "Hz"):
                add_input(c_ident(ch[0]), "uT", f"magnetic field {ch[0]}")
            else:
                add_input("supply_V", "V", "supply voltage")
        else:
            dropped.append(t.spec.label)
    if dropped and not static_only:
        raise InputError(f"{doc.source}: term(s) {', '.join(dropped)} depend on the history or "
                         "the time, not on instantaneous inputs, and cannot go into a look-up "
                         "table or a C function; pass --static-only to export the other terms "
                         "(the file names the ones left out), or refit without them")
    if not keep:
        raise InputError(f"{doc.source}: no exportable term in the model")
    return Plan(m, keep, dropped, temps, inputs)


def regressor_text(t, refs) -> tuple[str, str]:
    """(C expression of the regressor, text form) for an exportable term."""
    k, ch = t.spec.key, t.spec.channels
    if k == "bias":
        return "1.0", "1"
    if k in ("T", "T2", "T3"):
        c = c_ident(ch[0])
        tref = refs.t_ref_c.get(ch[0], 0.0)
        p = POLY[k]
        d = f"({c} - {tref!r})"
        return "*".join([d] * p), f"({ch[0]} - {tref:g})^{p}" if p > 1 else f"({ch[0]} - {tref:g})"
    if k == "dTdt":
        return f"dTdt_{c_ident(ch[0])}", f"dT/dt of {ch[0]} [degC/h]"
    if k == "dGdt":
        return (f"dGdt_{c_ident(ch[0])}_{c_ident(ch[1])}",
                f"d({ch[0]} - {ch[1]})/dt [degC/h]")
    if k in ("Hx", "Hy", "Hz"):
        return f"({c_ident(ch[0])} / {refs.h0_ut!r})", f"{ch[0]} / {refs.h0_ut:g} uT"
    vref = refs.v_ref if refs.v_ref is not None else 0.0
    return f"(supply_V - {vref!r})", f"(V - {vref:g})"


# ----------------------------------------------------------------------------- evaluation
#: a coefficient whose |value / 1σ| is below this is not determined by the log it was fitted
#: on ("not significant" in :attr:`gyrotest.envmodel.modelfit.Coefficient.significance`)
DETERMINED_Z = 2.0


def weak_terms(doc: Document, *, static_only: bool = False) -> list[str]:
    """The exported terms the fit did not determine: some coefficient with |value| < 2·1σ
    (HAC). The constant (bias) is not judged: it is the model's offset at the reference
    temperature, whatever its size. Such a term put into firmware adds its error, not a
    correction."""
    out = []
    for t in plan(doc, static_only=static_only).terms:
        if t.spec.key == "bias":
            continue
        zs = [abs(v / s) for v, s in zip(t.coef, t.coef_stderr) if s and s > 0]
        if zs and min(zs) < DETERMINED_Z:
            out.append(f"{t.spec.label} ({t.coef[0]:.4g} ± {t.coef_stderr[0]:.2g}, "
                       f"|z| = {min(zs):.2g})")
    return out


def outside_range(doc: Document, temps: np.ndarray, *, static_only: bool = False
                  ) -> str | None:
    """The part of a look-up table's temperature grid outside the range the model was fitted
    on (rounded outward to whole degC, as the default grid is), or None: rows there are an
    extrapolation of the fit."""
    p = plan(doc, static_only=static_only)
    if len(p.temp_channels) != 1:
        return None
    ch = p.temp_channels[0]
    rng = ((p.model.data or {}).get("channel_ranges") or {}).get(f"temperature:{ch}")
    if not rng or rng[0] is None or rng[1] is None:
        return None
    lo, hi = math.floor(float(rng[0])), math.ceil(float(rng[1]))
    bad = temps[(temps < lo) | (temps > hi)]
    if not bad.size:
        return None
    return (f"--temps reaches {float(bad.min()):g} ... {float(bad.max()):g} degC but the model "
            f"was fitted on {ch} = {float(rng[0]):.4g} ... {float(rng[1]):.4g} degC: "
            f"{bad.size} row(s) would extrapolate")


def parse_grid(spec: str, what: str = "--temps") -> np.ndarray:
    """``start:stop:step`` (inclusive stop) or a comma list; InputError otherwise."""
    try:
        if ":" in spec:
            a, b, s = (float(x) for x in spec.split(":"))
            if not s > 0 or b < a:
                raise ValueError
            n = int(math.floor((b - a) / s + 1e-9)) + 1
            if n > 100_000:
                raise InputError(f"{what} {spec!r} gives {n} points; at most 100000")
            return a + s * np.arange(n)
        v = np.array([float(x) for x in spec.split(",") if x.strip()])
        if v.size == 0:
            raise ValueError
        return v
    except ValueError:
        raise InputError(f"{what} {spec!r}: use start:stop:step with step > 0 (e.g. -40:85:5) "
                         "or a comma-separated list") from None


def default_temps(p: Plan) -> np.ndarray:
    """The fitted range of the LUT channel, 1 degC steps (rounded outward)."""
    rng = ((p.model.data or {}).get("channel_ranges") or {}).get(f"temperature:{p.temp_channels[0]}")
    if not rng or rng[0] is None or rng[1] is None:
        raise InputError("the model file does not record its temperature range; give --temps")
    lo, hi = math.floor(float(rng[0])), math.ceil(float(rng[1]))
    return np.arange(lo, hi + 1, 1.0)


def poly_columns(p: Plan, temps: np.ndarray) -> dict[str, np.ndarray]:
    """drift of each polynomial term (deg/h) on the temperature grid, by the model's own term
    functions (:func:`gyrotest.envmodel.terms.build_term` on a frame holding the grid)."""
    from ..envmodel.terms import EnvFrame, build_term

    ch = p.temp_channels[0]
    n = len(temps)
    frame = EnvFrame(t=np.arange(n, dtype=float), dt=1.0, bounds=[(0, n)],
                     temperature={ch: np.asarray(temps, float)})
    out = {}
    for t in p.terms:
        if t.spec.key in POLY:
            x = build_term(frame, t.spec, t.theta, p.model.refs)
            out[t.spec.label] = x @ np.asarray(t.coef, float)
    return out


def lut_csv(doc: Document, temps: np.ndarray | None, *, static_only: bool = False
            ) -> tuple[str, dict]:
    p = plan(doc, static_only=static_only)
    if len(p.temp_channels) != 1:
        what = "no temperature term" if not p.temp_channels else \
            f"temperature terms on {len(p.temp_channels)} channels ({', '.join(p.temp_channels)})"
        raise InputError(f"{doc.source}: the model has {what}; a one-dimensional temperature "
                         "look-up table needs exactly one — export the C header (.h) instead")
    if temps is None:
        temps = default_temps(p)
    cols = poly_columns(p, temps)
    total = np.sum(list(cols.values()), axis=0)
    ch = p.temp_channels[0]
    refs = p.model.refs
    head = [f"# {banner('drift compensation look-up table', [doc.source])}",
            f"# model axis {p.model.axis}; drift [deg/h] = sum(coefficient * regressor); "
            "compensated rate = rate - drift",
            f"# drift_dph = the temperature terms of {ch} (T_ref = "
            f"{refs.t_ref_c.get(ch, 0.0):g} degC); interpolate linearly between rows"]
    rng = ((p.model.data or {}).get("channel_ranges") or {}).get(f"temperature:{ch}")
    if rng and rng[0] is not None:
        head.append(f"# fitted on {ch} = {rng[0]:.4g} ... {rng[1]:.4g} degC: rows outside "
                    "extrapolate")
    for t in p.terms:
        if t.spec.key not in POLY:
            _, txt = regressor_text(t, refs)
            head.append(f"# add: {t.coef[0]:.10g} {t.spec.effect.coef_unit} * {txt}  "
                        f"({t.spec.label}, not in the table)")
    if t_needs_window(p):
        head.append(f"# dT/dt terms: derivative smoothed by a centred moving mean over "
                    f"W = {refs.smoothing_s:g} s, as in the fit")
    for d in p.dropped:
        head.append(f"# left out (--static-only): {d}")
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    labels = list(cols)
    w.writerow(["temperature_degC", "drift_dph"] + [f"{c_ident(x)}_dph" for x in labels])
    for i, T in enumerate(temps):
        w.writerow([f"{T:.10g}", f"{total[i]:.10g}"] + [f"{cols[x][i]:.10g}" for x in labels])
    summary = {"channel": ch, "rows": int(len(temps)),
               "temperature_degC": [float(temps[0]), float(temps[-1])],
               "left_out": p.dropped}
    return "\n".join(head) + "\n" + buf.getvalue(), summary


def t_needs_window(p: Plan) -> bool:
    return any(t.spec.key in ("dTdt", "dGdt") for t in p.terms)


# ----------------------------------------------------------------------------- C header
def check_prefix(prefix: str) -> None:
    if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", prefix):
        raise InputError(f"--prefix {prefix!r} is not a C identifier")


def c_header(doc: Document, *, prefix: str = "gyro_drift", static_only: bool = False,
             guard: str | None = None) -> tuple[str, dict]:
    check_prefix(prefix)
    p = plan(doc, static_only=static_only)
    refs = p.model.refs
    P = prefix.upper()
    guard = guard or f"{P}_H"
    lines = ["/*", f" * {banner('Drift compensation', [doc.source])}.", " *",
             f" * Gyro axis {p.model.axis}. Equation (rates in deg/h):",
             " *   drift = " + " + ".join(
                 f"{P}_C{i}" + ("" if t.spec.key == "bias" else f" * {regressor_text(t, refs)[1]}")
                 for i, t in enumerate(p.terms)),
             " *   compensated_rate = measured_rate - drift", " *",
             " * Coefficients (value, unit, 1-sigma from the fit):"]
    for i, t in enumerate(p.terms):
        se = t.coef_stderr[0] if t.coef_stderr else float("nan")
        lines.append(f" *   {P}_C{i}  {t.spec.label:<24} {t.coef[0]:.10g} "
                     f"{t.spec.effect.coef_unit} (+- {se:.3g}); {t.spec.effect.source}")
    lines.append(" * Inputs of " + f"{prefix}_dph():")
    for name, unit, what in p.inputs:
        lines.append(f" *   {name} [{unit}]: {what}")
    if t_needs_window(p):
        lines.append(f" * dT/dt inputs: the derivative smoothed by a centred moving mean over "
                     f"W = {refs.smoothing_s:g} s, as in the fit.")
    rng = (p.model.data or {}).get("channel_ranges") or {}
    for key, (lo, hi) in rng.items():
        if lo is not None and hi is not None:
            lines.append(f" * Fitted range {key}: {lo:.4g} ... {hi:.4g} (outside: extrapolation)")
    for d in p.dropped:
        lines.append(f" * Left out (--static-only): {d}")
    lines = [ascii_text(x) for x in lines]
    lines += [" */", f"#ifndef {guard}", f"#define {guard}", ""]
    for i, t in enumerate(p.terms):
        lines.append(ascii_text(f"#define {P}_C{i} ({t.coef[0]!r}) /* "
                                f"{t.spec.effect.coef_unit}, {t.spec.label} */"))
    for ch, v in refs.t_ref_c.items():
        if ch in p.temp_channels:
            lines.append(f"#define {P}_TREF_{c_ident(ch).upper()} ({v!r}) /* degC */")
    args = ", ".join(f"double {n}" for n, _, _ in p.inputs) or "void"
    body = " +\n           ".join(
        f"{P}_C{i}" + ("" if t.spec.key == "bias" else f" * {regressor_text(t, refs)[0]}")
        for i, t in enumerate(p.terms))
    lines += ["", "/* model drift in deg/h; subtract it from the measured rate */",
              f"static inline double {prefix}_dph({args})", "{",
              f"    return {body};", "}", "", f"#endif /* {guard} */"]
    summary = {"prefix": prefix, "inputs": [n for n, _, _ in p.inputs],
               "terms": [t.spec.label for t in p.terms], "left_out": p.dropped}
    return "\n".join(lines) + "\n", summary
