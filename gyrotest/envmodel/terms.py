"""Library of physical effects for the gyro drift model (IEEE 952 §8.3 E-terms, Antonova & Matveev).

The modelled gyro error is a sum of terms, each a known regressor times a coefficient in
physical units::

    ω_meas − Ω_in = D_F + D_T·ΔT + D_T2·ΔT² + D_Ṫ·dT/dt + D_∇Ṫ·d(T_a−T_b)/dt
                    + w_x·Hx/H0 + w_y·Hy/H0 + w_z·Hz/H0 + D_V·(V − V_ref) + ... + noise

(rates in deg/h). Every effect is one documented function in :mod:`gyrotest.envmodel.effects` (pure numpy:
arrays in, array out) plus an :class:`Effect` entry in :data:`EFFECTS` that says which channels it needs, the
unit of its coefficient, its nonlinear parameters (time constants, frequency) and where it
comes from. Terms are written as text, e.g. ``T``, ``T2(T_coil)``, ``dTdt``, ``dGdt(T_a,T_b)``,
``Tlag``, ``Hx``, ``V``, ``warmup``, ``sin``, or a custom ``name:expression``
(see :mod:`gyrotest.envmodel.expr`).

Conventions: time s, temperature degC, temperature rate degC/h, field uT normalised by
H0 = 100 uT, supply V, rates deg/h. Channels are held in an :class:`EnvFrame`, a uniformly
sampled set of channels (full rate, or block means) split into contiguous segments at gaps;
derivatives and lags never bridge a gap blindly.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..core.errors import InputError
from .effects import (  # noqa: F401  (re-exported: the effect functions live in effects.py)
    H0_UT,
    SEC_PER_HOUR,
    acceleration_power,
    bias,
    earth_rate_projection,
    first_order_lag,
    gradient_rate,
    input_rate,
    input_rate_temperature,
    lagged_temperature,
    lagged_temperature_square,
    magnetic_field,
    moving_mean,
    sinusoid,
    smooth,
    smoothed_rate,
    smoothing_half,
    supply_voltage,
    temperature_offset,
    temperature_rate,
    thermal_branch,
    time_ramp,
    warmup_transient,
)
from .expr import SafeExpression, parse_expression
from .frame import (  # noqa: F401  (re-exported)
    _AZIM_NAMES,
    _ELEV_NAMES,
    EnvFrame,
    _numeric,
    earth_projection,
    frame_from_log,
)


# ============================================================================ registry
@dataclass(frozen=True)
class NLParam:
    """A nonlinear parameter of an effect (fitted by variable projection)."""

    name: str
    unit: str
    kind: str  # "tau" (log-spaced search) or "freq" (periodogram start)


@dataclass(frozen=True)
class Effect:
    """One physical effect: what it needs, its coefficient units, its source."""

    key: str
    title: str  # the physical effect in words
    formula: str
    coef_names: tuple[str, ...]
    coef_unit: str
    source: str
    needs: str  # temperature | temperature2 | field | supply | table_rate | table+temp | extra | none
    function: Callable
    nonlinear: tuple[NLParam, ...] = ()
    smooth: bool = False  # the regressor is smooth: full-rate values may be interpolated
    prefiltered: bool = False  # already S_W-smoothed (derivatives): not smoothed again
    default_channel: int = 0  # field: X=0, Y=1, Z=2
    #: builder (frame, spec, theta, refs) -> (n, n_coef) array for effects defined outside
    #: this module (:mod:`gyrotest.envmodel.channel_terms`)
    build: Callable | None = None
    #: coefficient names from the term's channels, for effects with one column per channel
    #: or channel pair (``Hvec``, ``Hquad``); None: ``coef_names``
    coef_names_fn: Callable | None = None


EFFECTS: dict[str, Effect] = {}


def _reg(e: Effect) -> None:
    EFFECTS[e.key] = e


_reg(Effect("bias", "constant bias", "1", ("D_F",), "deg/h", "IEEE 952 §8.3 D_F", "none", bias))
_reg(Effect("T", "temperature sensitivity", "T − T_ref", ("D_T",), "deg/h/degC",
            "IEEE 952 §8.3 D_T·ΔT; Antonova & Matveev w1", "temperature", temperature_offset))
_reg(Effect("T2", "quadratic temperature sensitivity", "(T − T_ref)²", ("D_T2",), "deg/h/degC^2",
            "Antonova & Matveev eq.(3) w2·t²", "temperature", temperature_offset))
_reg(Effect("T3", "cubic temperature sensitivity", "(T − T_ref)³", ("D_T3",), "deg/h/degC^3",
            "Antonova & Matveev eq.(3) w3·t³; PX4 3rd-order polynomial", "temperature", temperature_offset))
_reg(Effect("dTdt", "temperature-rate sensitivity (thermal transient)", "dT/dt [degC/h]",
            ("D_Tdot",), "(deg/h)/(degC/h)", "IEEE 952 §8.3 D_Ṫ; Antonova & Matveev w_ΔV", "temperature",
            temperature_rate, smooth=True, prefiltered=True))
_reg(Effect("dGdt", "temperature-gradient rate (Shupe effect)", "d(T_a − T_b)/dt [degC/h]",
            ("D_gradTdot",), "(deg/h)/(degC/h)", "IEEE 952 §8.3 D_∇Ṫ", "temperature2",
            gradient_rate, smooth=True, prefiltered=True))
_reg(Effect("Tlag", "temperature of a lagging core (first-order lag τ)",
            "T_core − T_ref, τ·dT_core/dt = T − T_core", ("D_Tcore",), "deg/h/degC",
            "IEEE 952 §8.3 D_T·ΔT on the core temperature", "temperature", lagged_temperature,
            nonlinear=(NLParam("tau_s", "s", "tau"),), smooth=True))
_reg(Effect("Tlag2", "quadratic sensitivity of a lagging core (first-order lag τ)",
            "(T_core − T_ref)², τ·dT_core/dt = T − T_core", ("D_T2core",), "deg/h/degC^2",
            "Antonova & Matveev eq.(3) w2·t² on the core temperature", "temperature",
            lagged_temperature_square, nonlinear=(NLParam("tau_s", "s", "tau"),), smooth=True))
for _i, _ax in enumerate("xyz"):
    _reg(Effect(f"H{_ax}", f"magnetic field along {_ax.upper()}", f"H{_ax}/H0 (H0 = 100 uT)",
                (f"w_{_ax}",), "deg/h per 100 uT", "Antonova & Matveev eq.(2); IEEE 952 §8.3", "field",
                magnetic_field, default_channel=_i))
_reg(Effect("V", "supply-voltage sensitivity", "V − V_ref", ("D_V",), "(deg/h)/V",
            "IEEE 952 §8.3 E-terms (supply voltage)", "supply", supply_voltage))
_reg(Effect("g", "acceleration (g) sensitivity", "g", ("w_g1",), "deg/h/g",
            "Antonova & Matveev eq.(1) w1·g", "extra", acceleration_power))
_reg(Effect("g2", "g² sensitivity", "g²", ("w_g2",), "deg/h/g^2", "Antonova & Matveev eq.(1) w2·g²",
            "extra", acceleration_power))
_reg(Effect("ramp", "time ramp (ageing, rate ramp R)", "t [h]", ("R",), "deg/h/h",
            "IEEE 952 §8.3 D_R; Annex C rate ramp", "none", time_ramp, smooth=True))
_reg(Effect("warmup", "warm-up transient after power-on", "exp(−(t − t_on)/τ_w)", ("A_w",),
            "deg/h", "IEEE 952 §12.11.4.1.1 warm-up", "none", warmup_transient,
            nonlinear=(NLParam("tau_w_s", "s", "tau"),), smooth=True))
_reg(Effect("sin", "periodic disturbance (sinusoid)", "a·cos 2πft + b·sin 2πft",
            ("a", "b"), "deg/h", "IEEE 952 Annex C sinusoid", "none", sinusoid,
            nonlinear=(NLParam("f_Hz", "Hz", "freq"),), smooth=True))
_reg(Effect("hyst", "thermal hysteresis (heating vs cooling branch)",
            "play-operator branch state s ∈ [−1, 1], half-width w", ("D_hyst",), "deg/h",
            "play operator; heating/cooling check", "temperature", thermal_branch,
            nonlinear=(NLParam("width_c", "degC", "tau"),), smooth=True))
_reg(Effect("earth", "earth-rate projection on a moving input axis",
            "Ω_E (cos φ cos e cos A + sin φ sin e)", ("k_E",), "1 (deg/h per deg/h)",
            "IEEE 952 §12.11.4.1.1 earth rate along the IA", "earth", earth_rate_projection))
_reg(Effect("rate", "scale-factor error on the input rate", "Ω_in·1e-6", ("eps_K",), "ppm",
            "IEEE 952 §8.3 ε_K", "table_rate", input_rate))
_reg(Effect("rateT", "scale-factor temperature sensitivity", "Ω_in·(T − T_ref)·1e-6",
            ("eps_T",), "ppm/degC", "IEEE 952 §8.3 ε_T·ΔT", "table+temp",
            input_rate_temperature))
_reg(Effect("custom", "user term", "user expression", ("c",), "deg/h per unit", "user",
            "custom", lambda *a: None))

ALIASES = {"dT/dt": "dTdt", "Tdot": "dTdt", "dT": "dTdt", "gradTdot": "dGdt",
           "dgrad": "dGdt", "time": "ramp", "t": "ramp", "R": "ramp", "V_supply": "V",
           "supply": "V", "lag": "Tlag", "hysteresis": "hyst", "warm-up": "warmup",
           "sinusoid": "sin", "DT": "T", "dTdt2": "dTdt"}
#: groups that expand to several terms
GROUPS = {"H": ["Hx", "Hy", "Hz"], "mag": ["Hx", "Hy", "Hz"], "poly2": ["T", "T2"],
          "poly3": ["T", "T2", "T3"]}


# ============================================================================ term specs
@dataclass(frozen=True)
class TermSpec:
    """One term of a model: registry key, resolved channels, custom name/expression."""

    key: str
    channels: tuple[str, ...] = ()
    name: str | None = None  # custom terms
    expr: str | None = None

    @property
    def effect(self) -> Effect:
        return EFFECTS[self.key]

    @property
    def label(self) -> str:
        if self.key == "custom":
            return str(self.name)
        if self.channels:
            return f"{self.key}({','.join(self.channels)})"
        return self.key

    def short(self, frame_or_defaults: Any = None) -> str:
        return self.label

    @property
    def coef_symbols(self) -> tuple[str, ...]:
        """The coefficient names (the effect's, or derived from the channels)."""
        e = self.effect
        return tuple(e.coef_names_fn(self.channels)) if e.coef_names_fn else e.coef_names

    @property
    def n_coef(self) -> int:
        return len(self.coef_symbols)

    def coef_labels(self) -> list[str]:
        if self.key == "custom":
            return [f"c[{self.name}]"]
        base = self.label
        names = self.coef_symbols
        if len(names) == 1:
            return [base]
        return [f"{base}.{c}" for c in names]

    def to_dict(self) -> dict:
        d: dict[str, Any] = {"key": self.key, "label": self.label}
        if self.channels:
            d["channels"] = list(self.channels)
        if self.key == "custom":
            d["name"] = self.name
            d["expr"] = self.expr
        return d

    @staticmethod
    def from_dict(d: dict) -> TermSpec:
        return TermSpec(d["key"], tuple(d.get("channels") or ()), d.get("name"), d.get("expr"))


_NAME_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_.\-]*$")


def split_terms(text: str) -> list[str]:
    """Split a comma-separated term list, respecting parentheses and brackets."""
    out, depth, cur = [], 0, []
    for ch in text:
        if ch in "([":
            depth += 1
        elif ch in ")]":
            depth -= 1
        if ch == "," and depth == 0:
            out.append("".join(cur).strip())
            cur = []
        else:
            cur.append(ch)
    out.append("".join(cur).strip())
    return [p for p in out if p]


def parse_term(text: str) -> list[TermSpec]:
    """Parse one term text into specs (a group like ``H`` gives three). Channels stay
    unresolved (empty) when not given; :func:`resolve_terms` fills them in."""
    s = text.strip()
    if not s:
        raise InputError("empty term")
    # custom: name:expr (but not e.g. "T(a:b)")
    m = re.match(r"^([A-Za-z_][A-Za-z0-9_]*)\s*:(.+)$", s)
    if m and "(" not in m.group(1):
        name, expr = m.group(1), m.group(2).strip()
        if name in EFFECTS or name in ALIASES or name in GROUPS:
            raise InputError(f"custom term {name!r}: the name is a built-in term; choose another")
        parse_expression(expr)
        return [TermSpec("custom", (), name, expr)]
    m = re.match(r"^([A-Za-z][A-Za-z0-9_/\-]*)\s*(?:\((.*)\))?$", s)
    if not m:
        raise InputError(f"term {s!r}: not understood; use e.g. T, T2(T_coil), dTdt, "
                         f"dGdt(T_a,T_b), Hx, V, warmup, or name:expression")
    key, args = m.group(1), m.group(2)
    key = ALIASES.get(key, key)
    chans = tuple(a.strip() for a in args.split(",") if a.strip()) if args else ()
    if key in GROUPS:
        if chans:
            raise InputError(f"term {s!r}: {key} is a group; give channels per term")
        return [TermSpec(k) for k in GROUPS[key]]
    if key not in EFFECTS or key == "custom":
        known = ", ".join(k for k in EFFECTS if k != "custom")
        raise InputError(f"term {s!r}: unknown term {key!r} (known: {known}, or "
                         "name:expression)")
    need = {"temperature2": 2, "table+temp": 1, "field2": 2, "any2": 2,
            "fieldall": 0, "earth": 0, "fieldlist": 3}.get(EFFECTS[key].needs, 1)
    if EFFECTS[key].needs in ("none", "fieldall", "earth") and chans:
        raise InputError(f"term {s!r}: {key} takes no channel")
    if len(chans) > need:
        raise InputError(f"term {s!r}: {key} takes at most {need} channel(s)")
    return [TermSpec(key, chans)]


def parse_terms(texts: list[str] | str | None) -> list[TermSpec]:
    """Parse term texts (a comma-separated string or a list of strings) into specs."""
    if texts is None:
        return []
    if isinstance(texts, str):
        texts = [texts]
    out: list[TermSpec] = []
    for t in texts:
        if isinstance(t, TermSpec):
            out.append(t)
            continue
        parts = [t] if re.match(r"^[A-Za-z_][A-Za-z0-9_]*\s*:", t.strip()) else split_terms(t)
        for p in parts:
            out.extend(parse_term(p))
    return out


_G_PATTERN = re.compile(r"^(acc|accel|a|g)(_?[xyz])?(_.*)?$|_g$", re.I)  # not gyro_y_dps


def resolve_terms(specs: list[TermSpec], frame: EnvFrame) -> list[TermSpec]:
    """Fill in default channels and check that every channel exists and is usable.

    Defaults: temperature terms use the first temperature channel, dGdt the first two, Hx/Hy/Hz
    the X/Y/Z field channels, g/g2 an extra channel named like acc*/g*/*_g. Raises
    InputError naming the term and the channel (missing, constant, not finite).
    """
    out: list[TermSpec] = []
    src = frame.source
    for sp in specs:
        e = sp.effect
        label = sp.label
        if sp.key == "custom":
            expr = parse_expression(sp.expr or "")
            for ref in expr.channels:
                try:
                    v = frame.channel_values(ref.group, ref.name)
                except InputError as err:
                    raise InputError(f"term {sp.name!r}: {err}") from None
                _check_channel(v, f"term {sp.name!r}", str(ref), src,
                               constant_ok=ref.group in ("t", "t_h"))
            out.append(sp)
            continue
        chans = list(sp.channels)
        if e.needs in ("temperature", "temperature2", "table+temp"):
            have = list(frame.temperature)
            need = 2 if e.needs == "temperature2" else 1
            if not have:
                raise InputError(f"term {label!r}: {src} has no temperature channel; name one "
                                 "with --temp-col")
            if not chans:
                if len(have) < need:
                    raise InputError(f"term {label!r}: needs two temperature channels; {src} "
                                     f"has only {', '.join(have)}")
                chans = have[:need]
            for c in chans:
                if c not in frame.temperature:
                    raise InputError(f"term {label!r}: {src} has no temperature channel {c!r} "
                                     f"(temperature channels: {', '.join(have)})")
            if e.needs == "temperature2" and chans[0] == chans[1]:
                raise InputError(f"term {label!r}: needs two different temperature channels")
            for c in chans:
                _check_channel(frame.temperature[c], f"term {label!r}", c, src,
                               constant_ok=sp.key in ("dTdt", "dGdt", "hyst", "Tlag"))
            if e.needs == "table+temp":
                if frame.table_rate is None:
                    raise InputError(f"term {label!r}: {src} has no rate-table channel; name it "
                                     "with --table-col")
                _check_channel(frame.table_rate, f"term {label!r}", "table rate", src)
            if e.needs == "temperature2":
                _check_channel(frame.temperature[chans[0]] - frame.temperature[chans[1]],
                               f"term {label!r}", f"{chans[0]}−{chans[1]}", src)
            elif sp.key in ("dTdt", "hyst", "Tlag"):
                _check_channel(frame.temperature[chans[0]], f"term {label!r}", chans[0], src)
        elif e.needs == "field":
            have = list(frame.field_uT)
            if not chans:
                if len(have) < e.default_channel + 1:
                    raise InputError(f"term {label!r}: {src} has no magnetic-field channels; "
                                     "name them with --field-col X,Y,Z")
                chans = [have[e.default_channel]]
            if chans[0] not in frame.field_uT:
                raise InputError(f"term {label!r}: {src} has no field channel {chans[0]!r} "
                                 f"(field channels: {', '.join(have) or 'none'})")
            _check_channel(frame.field_uT[chans[0]], f"term {label!r}", chans[0], src)
        elif e.needs in ("field2", "fieldall"):
            have = list(frame.field_uT)
            if e.needs == "fieldall":
                if not have:
                    raise InputError(f"term {label!r}: {src} has no magnetic-field channels; "
                                     "name them with --field-col X,Y,Z")
                chans = []
            elif len(chans) != 2 or chans[0] == chans[1]:
                raise InputError(f"term {label!r}: name two different field channels, e.g. "
                                 f"{sp.key}({','.join(have[:2]) or 'Hx_uT,Hy_uT'})")
            for c in chans:
                if c not in frame.field_uT:
                    raise InputError(f"term {label!r}: {src} has no field channel {c!r} "
                                     f"(field channels: {', '.join(have) or 'none'})")
            if chans:
                _check_channel(frame.field_uT[chans[0]] * frame.field_uT[chans[1]],
                               f"term {label!r}", f"{chans[0]}·{chans[1]}", src)
        elif e.needs == "fieldlist":
            have = list(frame.field_uT)
            if not have:
                raise InputError(f"term {label!r}: {src} has no magnetic-field channels; "
                                 "name them with --field-col X,Y,Z")
            chans = list(chans) or have[:3]
            if len(set(chans)) != len(chans):
                raise InputError(f"term {label!r}: a field channel is named twice")
            for c in chans:
                if c not in frame.field_uT:
                    raise InputError(f"term {label!r}: {src} has no field channel {c!r} "
                                     f"(field channels: {', '.join(have)})")
                _check_channel(frame.field_uT[c], f"term {label!r}", c, src)
        elif e.needs in ("any", "any2"):
            from .frame import find_channel

            n_need = 2 if e.needs == "any2" else 1
            if len(chans) != n_need:
                raise InputError(f"term {label!r}: name {'two channels' if n_need == 2 else 'the channel'}"
                                 f", e.g. {sp.key}({'a,b' if n_need == 2 else 'RH_pct'})")
            try:
                vals = [find_channel(frame, c)[1] for c in chans]
            except InputError as err:
                raise InputError(f"term {label!r}: {err}") from None
            for c, v in zip(chans, vals):
                _check_channel(v, f"term {label!r}", c, src,
                               constant_ok=sp.key in ("dchan", "dchanlag"))
            if n_need == 2:
                _check_channel(vals[0] * vals[1], f"term {label!r}", "·".join(chans), src)
        elif e.needs == "earth":
            if frame.earth_dph is None:
                raise InputError(f"term {label!r}: {src} has no position or IA-attitude channel "
                                 "with a site latitude; name them with --position-col (or "
                                 "ia_elevation_deg/ia_azimuth_deg columns) and --latitude")
            _check_channel(frame.earth_dph, f"term {label!r}", "earth-rate projection", src)
        elif e.needs == "supply":
            if frame.supply is None:
                raise InputError(f"term {label!r}: {src} has no supply-voltage channel; name it "
                                 "with --supply-col")
            _check_channel(frame.supply, f"term {label!r}", "supply", src)
        elif e.needs == "table_rate":
            if frame.table_rate is None:
                raise InputError(f"term {label!r}: {src} has no rate-table channel; name it "
                                 "with --table-col")
            _check_channel(frame.table_rate, f"term {label!r}", "table rate", src)
        elif e.needs == "extra":
            if not chans:
                hits = [k for k in frame.extra if _G_PATTERN.search(k)]
                if not hits:
                    raise InputError(f"term {label!r}: no acceleration channel found in {src}; "
                                     f"name it, e.g. {sp.key}(acc_g)")
                chans = hits[:1]
            if chans[0] not in frame.extra:
                raise InputError(f"term {label!r}: {src} has no channel {chans[0]!r} "
                                 f"(extra channels: {', '.join(frame.extra) or 'none'})")
            _check_channel(frame.extra[chans[0]], f"term {label!r}", chans[0], src)
        out.append(TermSpec(sp.key, tuple(chans), sp.name, sp.expr))
    labels = [s.label for s in out]
    dup = {x for x in labels if labels.count(x) > 1}
    if dup:
        raise InputError(f"term {sorted(dup)[0]!r} given twice")
    return out


def _check_channel(v: np.ndarray, who: str, chan: str, src: str, *,
                   constant_ok: bool = False) -> None:
    v = np.asarray(v, dtype=np.float64)
    good = np.isfinite(v)
    if not good.any():
        raise InputError(f"{who}: channel {chan!r} in {src} has no finite values (all NaN)")
    if not good.all():
        raise InputError(f"{who}: channel {chan!r} in {src} has {int((~good).sum())} NaN/inf "
                         "values; read the log with --nan interpolate or --nan gap")
    if constant_ok:
        return
    span = float(np.max(v) - np.min(v))
    if span <= 1e-12 * max(1.0, float(np.max(np.abs(v)))):
        raise InputError(f"{who}: channel {chan!r} in {src} is constant ({float(v[0]):g}); its "
                         "coefficient cannot be estimated from this log")


# ============================================================================ building
@dataclass
class Refs:
    """Reference values a model is expressed about (stored with the model)."""

    t_ref_c: dict[str, float] = field(default_factory=dict)
    v_ref: float | None = None
    h0_ut: float = H0_UT
    t_on_s: float = 0.0
    smoothing_s: float = 120.0
    hyst_threshold_c_per_h: dict[str, float] = field(default_factory=dict)
    hyst_min_width_c: dict[str, float] = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {"T_ref_degC": dict(self.t_ref_c), "V_ref_V": self.v_ref, "H0_uT": self.h0_ut,
                "t_power_on_s": self.t_on_s, "smoothing_window_s": self.smoothing_s,
                "hysteresis_threshold_degC_per_h": dict(self.hyst_threshold_c_per_h),
                "hysteresis_min_width_degC": dict(self.hyst_min_width_c)}

    @staticmethod
    def from_dict(d: dict) -> Refs:
        return Refs(t_ref_c={k: float(v) for k, v in (d.get("T_ref_degC") or {}).items()},
                    v_ref=d.get("V_ref_V"), h0_ut=float(d.get("H0_uT", H0_UT)),
                    t_on_s=float(d.get("t_power_on_s", 0.0)),
                    smoothing_s=float(d.get("smoothing_window_s", 120.0)),
                    hyst_threshold_c_per_h={k: float(v) for k, v in
                                            (d.get("hysteresis_threshold_degC_per_h") or {}).items()},
                    hyst_min_width_c={k: float(v) for k, v in
                                      (d.get("hysteresis_min_width_degC") or {}).items()})


def default_refs(frame: EnvFrame, *, t_ref: float | None = None, v_ref: float | None = None,
                 smoothing_s: float | None = None, t_on_s: float = 0.0,
                 resolution_s: float | None = None) -> Refs:
    """Reference values from the fitting data: T_ref = ``t_ref`` or the mean temperature
    rounded to 0.1 degC (per sensor), V_ref = ``v_ref`` or the mean supply rounded to 0.01 V,
    smoothing window W = ``smoothing_s`` or max(60 s, 2·resolution), hysteresis threshold =
    max(0.1 degC/h, 0.2 × the 95th percentile of |dT/dt|); the narrowest resolvable hysteresis
    half-width = max(5·σ_T (sensor noise from second differences), half the temperature change
    within W at the 95th-percentile rate)."""
    if smoothing_s is None:
        smoothing_s = max(60.0, 2.0 * (resolution_s or 0.0), 4.0 * frame.dt)
    r = Refs(smoothing_s=float(smoothing_s), t_on_s=float(t_on_s))
    for k, v in frame.temperature.items():
        v = np.asarray(v, float)
        fin = v[np.isfinite(v)]
        r.t_ref_c[k] = float(t_ref) if t_ref is not None else (
            round(float(np.mean(fin)), 1) if len(fin) else 0.0)
        if len(fin) == len(v) and len(v) > 2:
            rate = temperature_rate(v, frame.dt, smoothing_s, frame.bounds)
            r.hyst_threshold_c_per_h[k] = max(0.1, 0.2 * float(np.percentile(np.abs(rate), 95)))
            d2 = np.diff(v, 2)
            sig = 1.4826 * float(np.median(np.abs(d2 - np.median(d2)))) / math.sqrt(6.0)
            r.hyst_min_width_c[k] = max(5.0 * sig, 0.5 * float(np.percentile(np.abs(rate), 95))
                                        * smoothing_s / SEC_PER_HOUR)
        else:
            r.hyst_threshold_c_per_h[k] = 0.1
    if frame.supply is not None:
        r.v_ref = float(v_ref) if v_ref is not None else round(float(np.nanmean(frame.supply)), 2)
    return r


def build_term(frame: EnvFrame, spec: TermSpec, theta: dict[str, float], refs: Refs, *,
               to_be_smoothed: bool = False) -> np.ndarray:
    """The regressor column(s) of one term on ``frame``: shape (n, n_coef).
    ``to_be_smoothed``: the caller applies the working smoother afterwards (the fit's design
    matrix), so a custom expression's ``ddt`` is not smoothed a second time."""
    k = spec.key
    ch = spec.channels
    W = refs.smoothing_s
    if spec.effect.build is not None:
        return spec.effect.build(frame, spec, theta, refs)
    if k == "bias":
        x = bias(frame.n)
    elif k in ("T", "T2", "T3"):
        p = {"T": 1, "T2": 2, "T3": 3}[k]
        x = temperature_offset(frame.temperature[ch[0]], refs.t_ref_c.get(ch[0], 0.0), p)
    elif k == "dTdt":
        x = temperature_rate(frame.temperature[ch[0]], frame.dt, W, frame.bounds)
    elif k == "dGdt":
        x = gradient_rate(frame.temperature[ch[0]], frame.temperature[ch[1]], frame.dt, W,
                          frame.bounds)
    elif k == "Tlag":
        x = lagged_temperature(frame.temperature[ch[0]], frame.t, theta["tau_s"],
                               refs.t_ref_c.get(ch[0], 0.0), frame.bounds)
    elif k == "Tlag2":
        x = lagged_temperature_square(frame.temperature[ch[0]], frame.t, theta["tau_s"],
                                      refs.t_ref_c.get(ch[0], 0.0), frame.bounds)
    elif k in ("Hx", "Hy", "Hz"):
        x = magnetic_field(frame.field_uT[ch[0]], refs.h0_ut)
    elif k == "V":
        x = supply_voltage(frame.supply, refs.v_ref if refs.v_ref is not None else 0.0)
    elif k in ("g", "g2"):
        x = acceleration_power(frame.extra[ch[0]], 1 if k == "g" else 2)
    elif k == "ramp":
        x = time_ramp(frame.t)
    elif k == "warmup":
        x = warmup_transient(frame.t, theta["tau_w_s"], refs.t_on_s)
    elif k == "sin":
        return sinusoid(frame.t, theta["f_Hz"])
    elif k == "hyst":
        x = thermal_branch(frame.temperature[ch[0]], theta["width_c"], frame.bounds)
    elif k == "earth":
        x = earth_rate_projection(frame.earth_dph)
    elif k == "rate":
        x = input_rate(frame.table_rate)
    elif k == "rateT":
        x = input_rate_temperature(frame.table_rate, frame.temperature[ch[0]],
                                   refs.t_ref_c.get(ch[0], 0.0))
    elif k == "custom":
        x = compiled(spec.expr or "").evaluate(frame, smoothing_s=W, raw_ddt=to_be_smoothed)
        from ..io.health import MAX_ABS

        if not np.all(np.isfinite(x)) or np.max(np.abs(x), initial=0.0) > MAX_ABS:
            raise InputError(f"term {spec.name!r}: expression {str(spec.expr)[:60]!r} gives "
                             f"NaN/inf values, or values beyond ±{MAX_ABS:g} where the fit "
                             "overflows, on this log (log or sqrt of a negative number, a huge "
                             "constant); rescale the expression")
    else:  # pragma: no cover
        raise InputError(f"unknown term {k!r}")
    return np.asarray(x, dtype=np.float64).reshape(-1, 1)


_COMPILED: dict[str, SafeExpression] = {}


def compiled(expr: str) -> SafeExpression:
    if expr not in _COMPILED:
        _COMPILED[expr] = parse_expression(expr)
    return _COMPILED[expr]


#: a free sinusoid is searched from two cycles per record up (fewer look like a slow trend);
#: one the user's model holds (not a candidate the diagnosis proposes) is also searched
#: down to SIN_MIN_CYCLES, and the longer period is kept when it leaves at most
#: SIN_EXTEND_RSS of the residual sum of squares of the search from two cycles up
#: (:meth:`gyrotest.envmodel.varpro._Fitter._opt_one`). Campaign seed 51196: a 71-min HVAC
#: cycle in a 2.3 h log (1.9 cycles) held at the bound left the user's model 25 x the floor
#: (RSS ratio 0.0013 below it); searched down to one cycle for every sinusoid, the user's
#: `sin` of seed 27119 took 1.8 cycles of a slow thermal effect (RSS ratio 0.58, held-out
#: worse) and a candidate sinusoid partnered the wrong sensor in the pair search (23183)
SIN_SEARCH_CYCLES = 2.0
SIN_MIN_CYCLES = 1.0
SIN_EXTEND_RSS = 0.25


def nonlinear_bounds(spec: TermSpec, duration_s: float, resolution_s: float,
                     refs: Refs | None = None) -> dict[str, tuple[float, float]]:
    """Search ranges of a term's nonlinear parameters for a record of ``duration_s`` fitted at
    ``resolution_s``: time constants from max(2·resolution, 10 s) to half the record (lags: up
    to the record); frequency from :data:`SIN_SEARCH_CYCLES`/duration (a model's own sinusoid
    is also searched down to :data:`SIN_MIN_CYCLES`) to 1/(4·resolution); hysteresis
    half-width from the larger of 0.02 degC and the sensor's resolvable width
    (``refs.hyst_min_width_c``: a branch narrower than the sensor noise or than the
    temperature change within the smoother window only imitates sign(dT/dt)) to 5 degC."""
    lo_tau = max(2.0 * resolution_s, 10.0)
    if spec.key == "hyst":
        lo_w = 0.02
        if refs is not None and spec.channels:
            lo_w = max(lo_w, refs.hyst_min_width_c.get(spec.channels[0], 0.0))
        return {"width_c": (lo_w, max(5.0, 2.0 * lo_w))}
    if spec.key in ("Tlag", "Tlag2", "dTlagdt", "chanlag", "dchanlag"):
        return {"tau_s": (lo_tau, max(lo_tau * 2, duration_s))}
    if spec.key == "warmup":
        return {"tau_w_s": (lo_tau, max(lo_tau * 2, duration_s / 2))}
    if spec.key == "sin":
        return {"f_Hz": (SIN_SEARCH_CYCLES / duration_s, 1.0 / (4.0 * resolution_s))}
    return {}


def describe(spec: TermSpec) -> str:
    """One-line description of a term in physical words, e.g. 'temperature-rate sensitivity
    (thermal transient) of T_case'."""
    e = spec.effect
    if spec.key == "custom":
        return f"user term {spec.expr}"
    if spec.channels:
        return f"{e.title} [{', '.join(spec.channels)}]"
    return e.title


def effect_table() -> list[dict]:
    """The registry as rows (key, effect, formula, coefficient unit, source) for docs/--help."""
    return [{"term": e.key, "effect": e.title, "formula": e.formula, "unit": e.coef_unit,
             "nonlinear": [p.name for p in e.nonlinear], "source": e.source}
            for e in EFFECTS.values() if e.key != "custom"]

