"""Display units: the one conversion layer between gyrotest's internal (IEEE 952) units and
the unit family a reader asks for with ``--unit`` or ``[display] unit`` in the profile.

Everything the core computes stays in the internal units (rate deg/h, angle arcsec, N in
deg/√h, K in deg/h/√h, R in deg/h/h, Q in arcsec) and every JSON key keeps its explicit unit
(``..._dph``); only tables, plot axes and the spec sheet are shown in the display unit.

A family is named by its rate unit. With the rate factor ``f`` (display rate per deg/h:
1 for deg/h, 1/3600 for deg/s, π/(180·3600) for rad/s, 1/3.6 for mdps) the noise terms
convert as (derivations: 1 h = 3600 s, so √h = 60 √s, and a rate noise density per √Hz is a
rate times √s):

========================= ===================== ============================================
quantity (internal unit)  shown as              value
========================= ===================== ============================================
rate, σ(τ), B (deg/h)     <rate>                x · f
N, ARW (deg/√h)           <rate>/√Hz            x · 60 · f  (1 deg/√h = 60 deg/h/√Hz
                                                = 1/60 deg/s/√Hz)
K, RRW (deg/h/√h)         <rate>/√s             x · f / 60  (1 deg/h/√h = 1/60 deg/h/√s
                                                = 1/216000 deg/s/√s)
R, rate ramp (deg/h/h)    <rate>/s              x · f / 3600
Q, angle (arcsec)         <angle>               x · f  (1 deg/h = 1 arcsec/s, so the rate
                                                factor is also arcsec → deg, rad, mdeg)
PSD ((deg/h)²/Hz)         (<rate>)²/Hz          x · f²
========================= ===================== ============================================

The deg/h family keeps the IEEE 952 reporting units unchanged (N deg/√h, K deg/h/√h,
R deg/h/h, Q arcsec). Sources: IEEE Std 952-1997 Annex C (the units of N, K, R, Q); the
Kalibr IMU noise model (ethz-asl/kalibr wiki "IMU-Noise-Model": noise density in rad/s/√Hz,
random walk in rad/s²/√Hz = rad/s/√s), as in :func:`gyrotest.noise.noisefit.conversions`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .errors import InputError

#: unit strings of the internal quantities → the quantity they are (as in the fit's units)
_INTERNAL = {
    "deg/h": "rate",
    "deg/sqrt(h)": "N",
    "deg/√h": "N",
    "deg/h/sqrt(h)": "K",
    "deg/h/√h": "K",
    "deg/h/h": "R",
    "arcsec": "angle",
    "(deg/h)^2/Hz": "psd",
}


@dataclass(frozen=True)
class DisplayUnit:
    """A display-unit family: ``name`` (the rate unit), the rate factor ``f`` (display rate
    per deg/h) and the labels of each quantity."""

    name: str
    f: float
    rate: str
    n: str
    k: str
    r: str
    angle: str
    psd: str

    @property
    def is_internal(self) -> bool:
        """True for the IEEE deg/h family (values unchanged)."""
        return self.f == 1.0

    # --- conversions from internal units -------------------------------------------------
    def rate_value(self, x_dph):
        """Rate, σ(τ), B: deg/h → display rate."""
        return x_dph * self.f

    def n_value(self, n_deg_rt_h):
        """ARW N: deg/√h → display (deg/√h in the deg/h family, else rate/√Hz)."""
        return n_deg_rt_h if self.is_internal else n_deg_rt_h * 60.0 * self.f

    def k_value(self, k_dph_rt_h):
        """RRW K: deg/h/√h → display (unchanged in the deg/h family, else rate/√s)."""
        return k_dph_rt_h if self.is_internal else k_dph_rt_h * self.f / 60.0

    def r_value(self, r_dph_h):
        """Rate ramp R: deg/h/h → display (unchanged in the deg/h family, else rate/s)."""
        return r_dph_h if self.is_internal else r_dph_h * self.f / 3600.0

    def angle_value(self, q_arcsec):
        """Angle (Q): arcsec → display angle (arcsec, deg, rad or mdeg)."""
        return q_arcsec * self.f

    def psd_value(self, s_dph2_hz):
        """Rate PSD: (deg/h)²/Hz → (display rate)²/Hz."""
        return s_dph2_hz * self.f * self.f

    def convert(self, value, unit: str):
        """``(value, label)`` of a value in the internal ``unit`` string (as the noise fit
        names them: ``deg/h``, ``deg/sqrt(h)``, ``deg/h/sqrt(h)``, ``deg/h/h``, ``arcsec``,
        ``(deg/h)^2/Hz``). Other units (s, Hz, degC ...) pass through unchanged; None and
        NaN stay as they are. The deg/h family returns value and unit string unchanged."""
        if self.is_internal:
            return value, unit
        q = _INTERNAL.get(unit)
        if q is None or value is None:
            return value, (self.label(q) if q else unit)
        fn = {"rate": self.rate_value, "N": self.n_value, "K": self.k_value,
              "R": self.r_value, "angle": self.angle_value, "psd": self.psd_value}[q]
        return fn(value), self.label(q)

    def label(self, quantity: str) -> str:
        """Label of ``quantity`` (rate, N, B, K, R, Q, angle, psd) in this family."""
        return {"rate": self.rate, "B": self.rate, "N": self.n, "K": self.k, "R": self.r,
                "Q": self.angle, "angle": self.angle, "psd": self.psd}[quantity]

    def to_dict(self) -> dict:
        return {"unit": self.name, "rate_factor_per_dph": self.f, "labels": {
            "rate": self.rate, "N": self.n, "K": self.k, "R": self.r, "Q": self.angle,
            "psd": self.psd}}


_DEG_S = 1.0 / 3600.0
UNITS: dict[str, DisplayUnit] = {
    "deg/h": DisplayUnit("deg/h", 1.0, "deg/h", "deg/√h", "deg/h/√h", "deg/h/h", "arcsec",
                         "(deg/h)²/Hz"),
    "deg/s": DisplayUnit("deg/s", _DEG_S, "deg/s", "deg/s/√Hz", "deg/s/√s", "deg/s²", "deg",
                         "(deg/s)²/Hz"),
    "rad/s": DisplayUnit("rad/s", _DEG_S * math.pi / 180.0, "rad/s", "rad/s/√Hz", "rad/s/√s",
                         "rad/s²", "rad", "(rad/s)²/Hz"),
    "mdps": DisplayUnit("mdps", 1e3 * _DEG_S, "mdps", "mdps/√Hz", "mdps/√s", "mdps/s", "mdeg",
                        "mdps²/Hz"),
}
DEFAULT = UNITS["deg/h"]
#: an accelerometer axis (IEEE Std 1293): σ in m/s², the terms in their own units (VRW m/s/√h,
#: acceleration random walk m/s/h/√h, ramp m/s/h/h, Q m/s); values are shown unchanged
ACCEL_DISPLAY = DisplayUnit("m/s^2", 1.0, "m/s²", "m/s/√h", "m/s/h/√h", "m/s/h/h", "m/s",
                            "(m/s²)²/Hz")

_ALIASES = {
    "deg/h": "deg/h", "deg/hr": "deg/h", "°/h": "deg/h", "dph": "deg/h",
    "deg/s": "deg/s", "°/s": "deg/s", "dps": "deg/s",
    "rad/s": "rad/s", "rps": "rad/s",
    "mdps": "mdps", "mdeg/s": "mdps", "m°/s": "mdps",
}
CHOICES = tuple(UNITS)


def parse_display_unit(text: str | None, *, what: str = "--unit") -> DisplayUnit:
    """The :class:`DisplayUnit` named by ``text`` (deg/h, deg/s, rad/s, mdps or a common
    spelling: dph, dps, °/s, mdeg/s); None → deg/h. InputError naming the choices."""
    if text is None:
        return DEFAULT
    key = str(text).strip().replace(" ", "")
    name = _ALIASES.get(key) or _ALIASES.get(key.lower())
    if name is None:
        raise InputError(f"unknown display unit {text!r} for {what}; use one of: "
                         f"{', '.join(CHOICES)}")
    return UNITS[name]


def term_text(term, unit: DisplayUnit = DEFAULT, digits: int = 3, k: float = 1.0) -> str:
    """A fitted noise term (:class:`gyrotest.noise.fitresult.FitTerm`-like: ``main``, ``params``,
    ``sigma``, ``upper``, ``units``, ``status``, ``value``) as text in ``unit``, e.g.
    ``N = 0.0501 ± 0.0003 deg/s/√Hz`` or ``R ≤ 2.1e-10 deg/s²``; the deg/h family gives the
    term's own text. ``k``: the ± is k·1σ (the expanded uncertainty U of a sheet whose tables
    give U, k = 2), to be said where the text is shown."""
    if unit.is_internal and hasattr(term, "text") and k == 1.0:
        return term.text(digits)
    from .units import format_number as fmt

    main_unit = term.units[term.main]
    lab = unit.convert(1.0, main_unit)[1]
    if term.status == "not tested":
        return f"{term.main} ≈ {fmt(unit.convert(term.value, main_unit)[0], digits)} {lab} (not tested)"
    if term.status != "identified":
        if term.upper is None:
            return f"{term.main} not identified (bound not computed) {lab}"
        return f"{term.main} ≤ {fmt(unit.convert(term.upper, main_unit)[0], digits)} {lab}"
    parts = []
    for key in [term.main, *[p for p in term.params if p != term.main]]:
        v, lk = unit.convert(term.params[key], term.units[key])
        s = term.sigma.get(key)
        s = unit.convert(s, term.units[key])[0] if s is not None else None
        txt = f"{key} = {fmt(v, digits + 1)}"
        if s is not None and math.isfinite(s):
            txt += f" ± {fmt(k * s, 2)}"
        parts.append(f"{txt} {lk}")
    return ", ".join(parts)
