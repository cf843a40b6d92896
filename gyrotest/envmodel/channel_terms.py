"""More physical effects for the drift model: lagged-node temperature rate, magnetic
sensitivity of second order (m = 2), anisoelastic g cross terms, and generic forms of *any*
logged channel (humidity, pressure, vibration, ...).

Each effect is one documented function (arrays in, array out) plus a registry entry in
:data:`gyrotest.envmodel.terms.EFFECTS`, as in :mod:`gyrotest.envmodel.terms`. Terms are
written ``dTlagdt(T_case)``, ``Hsq(Hx_uT)``, ``Hprod(Hx_uT,Hy_uT)``, ``Hmag2``,
``gprod(gx,gy)``, and for any channel ``chan(RH_pct)``, ``chan2(x)``, ``chanabs(x)``,
``dchan(x)``, ``chanlag(x)``, ``dchanlag(x)``, ``chanprod(a,b)``. A channel name is looked up
among the temperature, field and extra channels, and ``supply`` / ``table_rate``.

Conventions as in :mod:`gyrotest.envmodel.terms`: time s, rates per hour, field in units of
H0 = 100 uT, output deg/h.
"""

from __future__ import annotations

import numpy as np

from ..core.errors import InputError
from .frame import find_channel
from .terms import (
    EFFECTS,
    H0_UT,
    Effect,
    EnvFrame,
    NLParam,
    Refs,
    TermSpec,
    first_order_lag,
    smoothed_rate,
)


def numeric_channels(frame: EnvFrame) -> dict[str, tuple[str, np.ndarray]]:
    """Every logged auxiliary channel by name: (group, values)."""
    out: dict[str, tuple[str, np.ndarray]] = {}
    for group, chans in (("temperature", frame.temperature), ("field", frame.field_uT),
                         ("extra", frame.extra)):
        for k, v in chans.items():
            out[k] = (group, np.asarray(v, dtype=np.float64))
    if frame.supply is not None:
        out["supply"] = ("supply", np.asarray(frame.supply, dtype=np.float64))
    return out


# ============================================================================ effect functions
def lagged_node_rate(temp_c: np.ndarray, t: np.ndarray, tau_s: float, dt: float,
                     window_s: float, bounds: list[tuple[int, int]] | None = None
                     ) -> np.ndarray:
    """Temperature rate of a body that lags the sensor (an unlogged coil or core).

    Formula: d T_node/dt in degC/h, τ·dT_node/dt = T − T_node (first-order lag,
    :func:`gyrotest.envmodel.terms.first_order_lag`), differentiated after the working
    smoother as in :func:`gyrotest.envmodel.terms.smoothed_rate`. Units: degC/h; coefficient
    (deg/h)/(degC/h) (IEEE D_Ṫ acting on the lagging node); τ in s, fitted. Source: IEEE Std
    952-1997 §8.3 E-term D_Ṫ·dT/dt; Antonova & Matveev, "Model of error of a
    fiber-optic gyro exposed to thermal and magnetic fields", w_ΔV term on the node
    temperature; first-order lumped thermal model.
    """
    return smoothed_rate(first_order_lag(temp_c, t, tau_s, bounds), dt, window_s, bounds)


def field_square(field_ut: np.ndarray, h0_ut: float = H0_UT) -> np.ndarray:
    """Second-order magnetic sensitivity to one field component.

    Formula: x = (H_i/H0)², H0 = 100 uT. Units: dimensionless; coefficient deg/h per
    (100 uT)². Source: Antonova & Matveev eq. (2), Δω(H) = Σ_{m} w_m·(H/H0)^m with
    m = 2 allowed; IEEE Std 952-1997 §8.3 (magnetic field among the E-terms).
    """
    return (np.asarray(field_ut, float) / h0_ut) ** 2


def field_product(field_a_ut: np.ndarray, field_b_ut: np.ndarray,
                  h0_ut: float = H0_UT) -> np.ndarray:
    """Mixed second-order magnetic term.

    Formula: x = H_i·H_j/H0². Units: dimensionless; coefficient deg/h per (100 uT)².
    Source: Antonova & Matveev eq. (2) at m = 2 (cross products of the components).
    """
    return np.asarray(field_a_ut, float) * np.asarray(field_b_ut, float) / h0_ut ** 2


def field_magnitude_square(components_ut: list[np.ndarray], h0_ut: float = H0_UT
                           ) -> np.ndarray:
    """Second-order sensitivity to the field magnitude.

    Formula: x = |H|²/H0² = Σ_i H_i²/H0². Units: dimensionless; coefficient deg/h per
    (100 uT)². Source: Antonova & Matveev eq. (2), m = 2 in |H|.
    """
    return sum((np.asarray(c, float) / h0_ut) ** 2 for c in components_ut)


def field_vector(components_ut: list[np.ndarray], h0_ut: float = H0_UT) -> np.ndarray:
    """First-order magnetic sensitivity along every axis at once: a gyro whose axes are not
    the coils' (or a field not fixed in the gyro frame) sees each coil through a rotation, so
    one fitted sensitivity per component is needed.

    Formula: columns H_x/H0, H_y/H0, H_z/H0 (H0 = 100 uT); Δω = Σ_i w_i·H_i/H0. Units:
    dimensionless; coefficients deg/h per 100 uT. Source: Antonova & Matveev eq. (2), m = 1,
    with the sensitivity vector w = R·w_gyro of a rotated frame.
    """
    return np.column_stack([np.asarray(c, float) / h0_ut for c in components_ut])


def field_quadratic(components_ut: list[np.ndarray], h0_ut: float = H0_UT) -> np.ndarray:
    """Full second-order magnetic sensitivity: every square and cross product of the
    components, which a rotated frame mixes (H_a·H_b of the gyro's own axes is a combination
    of all H_i·H_j of the coil axes).

    Formula: columns H_i·H_j/H0² for i ≤ j (xx, yy, zz, xy, xz, yz for three components);
    Δω = Σ_{i≤j} w_ij·H_i·H_j/H0². Units: dimensionless; coefficients deg/h per (100 uT)².
    Source: Antonova & Matveev eq. (2), m = 2, for a symmetric second-order tensor in a
    rotated frame.
    """
    c = [np.asarray(x, float) / h0_ut for x in components_ut]
    cols = [x * x for x in c]
    cols += [c[i] * c[j] for i in range(len(c)) for j in range(i + 1, len(c))]
    return np.column_stack(cols)


def acceleration_product(g_a: np.ndarray, g_b: np.ndarray) -> np.ndarray:
    """Anisoelastic (g·g) sensitivity between two acceleration components.

    Formula: x = g_i·g_j (g in units of standard gravity). Units: g²; coefficient deg/h/g².
    Source: IEEE Std 952-1997 §8.3 (acceleration-squared E-terms); anisoelastic drift of
    mechanical and vibratory gyros, Antonova & Matveev eq. (1) at m = 2.
    """
    return np.asarray(g_a, float) * np.asarray(g_b, float)


def channel_level(x: np.ndarray) -> np.ndarray:
    """A logged channel of any kind (humidity, pressure, vibration, ...), linearly.

    Formula: x (the bias term absorbs its mean). Units: those of the channel; coefficient
    deg/h per unit. Source: IEEE Std 952-1997 §8.3 ("other environmental sensitivities
    pertinent to the application").
    """
    return np.asarray(x, float)


def channel_square(x: np.ndarray) -> np.ndarray:
    """Square of a logged channel. Formula: x². Units: unit²; coefficient deg/h per unit².
    Source: second-order term of a sensitivity polynomial (IEEE Std 952-1997 §8.3)."""
    return np.asarray(x, float) ** 2


def channel_abs(x: np.ndarray) -> np.ndarray:
    """Magnitude of a logged channel (an even effect that is not quadratic). Formula: |x|.
    Units: those of x; coefficient deg/h per unit. Source: gyrotest (channel screen)."""
    return np.abs(np.asarray(x, float))


def channel_rate(x: np.ndarray, dt: float, window_s: float,
                 bounds: list[tuple[int, int]] | None = None) -> np.ndarray:
    """Rate of change of a logged channel, per hour, through the working smoother.

    Formula: dx/dt ≈ d(S_W x)/dt · 3600 (:func:`gyrotest.envmodel.terms.smoothed_rate`).
    Units: unit/h; coefficient
    (deg/h)/(unit/h). Source: IEEE Std 952-1997 §8.3 (rate E-terms)."""
    return smoothed_rate(x, dt, window_s, bounds)


def channel_lag(x: np.ndarray, t: np.ndarray, tau_s: float,
                bounds: list[tuple[int, int]] | None = None) -> np.ndarray:
    """A logged channel seen through a first-order lag of time constant τ (fitted): what a
    body or a slow sensor follows. Formula: τ·dy/dt = x − y. Units: those of x; coefficient
    deg/h per unit. Source: first-order lumped model
    (:func:`gyrotest.envmodel.terms.first_order_lag`)."""
    return first_order_lag(x, t, tau_s, bounds)


def channel_lag_rate(x: np.ndarray, t: np.ndarray, tau_s: float, dt: float, window_s: float,
                     bounds: list[tuple[int, int]] | None = None) -> np.ndarray:
    """Rate of change of a lagged channel (per hour). Formula: d/dt of y, τ·dy/dt = x − y.
    Units: unit/h; coefficient (deg/h)/(unit/h). Source: as :func:`lagged_node_rate` for any
    channel."""
    return smoothed_rate(first_order_lag(x, t, tau_s, bounds), dt, window_s, bounds)


def channel_product(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Product of two logged channels. Formula: a·b. Units: unit_a·unit_b; coefficient deg/h
    per unit_a·unit_b. Source: cross term of a second-order sensitivity polynomial."""
    return np.asarray(a, float) * np.asarray(b, float)


# ============================================================================ builders
def _vals(frame: EnvFrame, spec: TermSpec, i: int) -> np.ndarray:
    return find_channel(frame, spec.channels[i])[1]


def _build(frame: EnvFrame, spec: TermSpec, theta: dict, refs: Refs) -> np.ndarray:
    k = spec.key
    W = refs.smoothing_s
    if k == "dTlagdt":
        x = lagged_node_rate(frame.temperature[spec.channels[0]], frame.t, theta["tau_s"],
                             frame.dt, W, frame.bounds)
    elif k == "Hsq":
        x = field_square(frame.field_uT[spec.channels[0]], refs.h0_ut)
    elif k == "Hprod":
        x = field_product(frame.field_uT[spec.channels[0]], frame.field_uT[spec.channels[1]],
                          refs.h0_ut)
    elif k == "Hmag2":
        x = field_magnitude_square(list(frame.field_uT.values()), refs.h0_ut)
    elif k == "Hvec":
        return field_vector([frame.field_uT[c] for c in spec.channels], refs.h0_ut)
    elif k == "Hquad":
        return field_quadratic([frame.field_uT[c] for c in spec.channels], refs.h0_ut)
    elif k == "gprod":
        x = acceleration_product(_vals(frame, spec, 0), _vals(frame, spec, 1))
    elif k == "chan":
        x = channel_level(_vals(frame, spec, 0))
    elif k == "chan2":
        x = channel_square(_vals(frame, spec, 0))
    elif k == "chanabs":
        x = channel_abs(_vals(frame, spec, 0))
    elif k == "dchan":
        x = channel_rate(_vals(frame, spec, 0), frame.dt, W, frame.bounds)
    elif k == "chanlag":
        x = channel_lag(_vals(frame, spec, 0), frame.t, theta["tau_s"], frame.bounds)
    elif k == "dchanlag":
        x = channel_lag_rate(_vals(frame, spec, 0), frame.t, theta["tau_s"], frame.dt, W,
                             frame.bounds)
    elif k == "chanprod":
        x = channel_product(_vals(frame, spec, 0), _vals(frame, spec, 1))
    else:  # pragma: no cover
        raise InputError(f"unknown term {k!r}")
    return np.asarray(x, dtype=np.float64).reshape(-1, 1)


#: the custom-expression equivalent of each effect (printed as the ``--term`` that adds it)
EXPRESSIONS = {
    "dTlagdt": "ddt(lag(temp.{0}, {tau}))",
    "Hsq": "(field.{0}/100)**2",
    "Hprod": "field.{0}*field.{1}/10000",
    "gprod": "{ref0}*{ref1}",
    "chan": "{ref0}",
    "chan2": "{ref0}**2",
    "chanabs": "abs({ref0})",
    "dchan": "ddt({ref0})",
    "chanlag": "lag({ref0}, {tau})",
    "dchanlag": "ddt(lag({ref0}, {tau}))",
    "chanprod": "{ref0}*{ref1}",
}


def _reg(e: Effect) -> None:
    EFFECTS[e.key] = e


_TAU = (NLParam("tau_s", "s", "tau"),)
_reg(Effect("dTlagdt", "temperature rate of a lagging node (first-order lag τ)",
            "d T_node/dt [degC/h], τ·dT_node/dt = T − T_node", ("D_Tdot_node",),
            "(deg/h)/(degC/h)", "IEEE 952 §8.3 D_Ṫ on a lagging node; Antonova–Matveev w_ΔV",
            "temperature", lagged_node_rate, nonlinear=_TAU, smooth=True, prefiltered=True,
            build=_build))
_reg(Effect("Hsq", "magnetic field squared (second order)", "(H_i/H0)²", ("w_H2",),
            "deg/h per (100 uT)^2", "Antonova–Matveev eq.(2), m = 2", "field", field_square,
            build=_build))
_reg(Effect("Hprod", "magnetic cross term (second order)", "H_i·H_j/H0²", ("w_Hij",),
            "deg/h per (100 uT)^2", "Antonova–Matveev eq.(2), m = 2", "field2", field_product,
            build=_build))
_reg(Effect("Hmag2", "field magnitude squared (second order)", "|H|²/H0²", ("w_Hmag2",),
            "deg/h per (100 uT)^2", "Antonova–Matveev eq.(2), m = 2 in |H|", "fieldall",
            field_magnitude_square, build=_build))
def _vec_names(chans: tuple[str, ...]) -> tuple[str, ...]:
    return tuple(f"w[{c}]" for c in chans)


def _quad_names(chans: tuple[str, ...]) -> tuple[str, ...]:
    sq = [f"w[{c}^2]" for c in chans]
    return tuple(sq + [f"w[{chans[i]}*{chans[j]}]" for i in range(len(chans))
                       for j in range(i + 1, len(chans))])


_reg(Effect("Hvec", "magnetic sensitivity along every field axis (gyro axes not the coils')",
            "H_i/H0 for each listed field channel", ("w_H",), "deg/h per 100 uT",
            "Antonova–Matveev eq.(2), m = 1, in a rotated frame", "fieldlist", field_vector,
            build=_build, coef_names_fn=_vec_names))
_reg(Effect("Hquad", "full second-order magnetic sensitivity (rotated axes)",
            "H_i·H_j/H0², i ≤ j, of the listed field channels", ("w_HH",),
            "deg/h per (100 uT)^2", "Antonova–Matveev eq.(2), m = 2, in a rotated frame",
            "fieldlist", field_quadratic, build=_build, coef_names_fn=_quad_names))
_reg(Effect("gprod", "anisoelastic g·g sensitivity", "g_i·g_j", ("w_gg",), "deg/h/g^2",
            "IEEE 952 §8.3; Antonova–Matveev eq.(1), m = 2", "any2", acceleration_product,
            build=_build))
_reg(Effect("chan", "sensitivity to a logged channel", "x", ("c_x",), "deg/h per unit",
            "IEEE 952 §8.3 (other environmental sensitivities)", "any", channel_level,
            build=_build))
_reg(Effect("chan2", "quadratic sensitivity to a logged channel", "x²", ("c_x2",),
            "deg/h per unit^2", "second-order sensitivity polynomial", "any", channel_square,
            build=_build))
_reg(Effect("chanabs", "sensitivity to the magnitude of a logged channel", "|x|",
            ("c_absx",), "deg/h per unit", "channel screen", "any", channel_abs,
            build=_build))
_reg(Effect("dchan", "sensitivity to the rate of change of a logged channel", "dx/dt [1/h]",
            ("c_dx",), "(deg/h)/(unit/h)", "IEEE 952 §8.3 (rate E-terms)", "any",
            channel_rate, smooth=True, prefiltered=True, build=_build))
_reg(Effect("chanlag", "a logged channel through a first-order lag τ", "lag(x, τ)",
            ("c_lagx",), "deg/h per unit", "first-order lumped model", "any", channel_lag,
            nonlinear=_TAU, smooth=True, build=_build))
_reg(Effect("dchanlag", "rate of change of a lagged logged channel", "d lag(x, τ)/dt [1/h]",
            ("c_dlagx",), "(deg/h)/(unit/h)", "first-order lumped model", "any",
            channel_lag_rate, nonlinear=_TAU, smooth=True, prefiltered=True, build=_build))
_reg(Effect("chanprod", "product of two logged channels", "a·b", ("c_ab",),
            "deg/h per unit_a·unit_b", "cross term of a sensitivity polynomial", "any2",
            channel_product, build=_build))


def channel_ref(frame: EnvFrame, name: str) -> str:
    """How a custom expression names the channel ``name`` (``temp.X``, ``field.X``,
    ``extra.X``, ``extra["odd name"]``, ``supply``)."""
    group = find_channel(frame, name)[0]
    if group in ("supply", "table_rate"):
        return group
    ns = {"temperature": "temp", "field": "field", "extra": "extra"}[group]
    if name.isidentifier():
        return f"{ns}.{name}"
    return f'{ns}["{name}"]'


def custom_text(spec: TermSpec, theta: dict | None, frame: EnvFrame) -> str | None:
    """The ``--term NAME:EXPRESSION`` equivalent of a fitted term of this module (time
    constants at their fitted values), or None for terms without one."""
    tmpl = EXPRESSIONS.get(spec.key)
    if tmpl is None:
        return None
    tau = (theta or {}).get("tau_s")
    refs = {f"ref{i}": channel_ref(frame, c) for i, c in enumerate(spec.channels)}
    expr = tmpl.format(*spec.channels, tau=f"{tau:.4g}" if tau else "TAU_S", **refs)
    base = "_".join([spec.key] + [c for c in spec.channels])
    name = "".join(ch if ch.isalnum() or ch == "_" else "_" for ch in base)
    if not name[0].isalpha():
        name = "x_" + name
    return f"{name}:{expr}"
