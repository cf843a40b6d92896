"""Units: parsing and conversion to gyrotest's internal units.

Internal units (everything in the core uses these):

=============== ============= ==========================================================
quantity        internal      note
=============== ============= ==========================================================
angular rate    deg/h         1 deg/h = 1 arcsec/s, so counts x S0[arcsec] / dt[s] is deg/h
angle           arcsec
time            s
temperature     degC
magnetic field  uT            H0 = 100 uT normalises magnetic coefficients (Antonova & Matveev)
voltage         V
acceleration    m/s²          g = 9.80665 m/s² (accelerometer columns: ``gyrotest.io.accel``)
=============== ============= ==========================================================

Unit strings are case-sensitive where it matters (``G`` is gauss, ``g`` standard gravity;
``mG`` milligauss, ``mg`` milli-g); common spellings (``°/h``, ``dph``, ``dps``, ``µT``, ``degC``) are accepted.
"""

from __future__ import annotations

import math
import re

from .errors import InputError

DEG = math.pi / 180.0

# angular rate -> deg/h
_RATE = {
    "deg/h": 1.0,
    "deg/hr": 1.0,
    "°/h": 1.0,
    "dph": 1.0,
    "arcsec/s": 1.0,
    "deg/min": 60.0,
    "°/min": 60.0,
    "deg/s": 3600.0,
    "°/s": 3600.0,
    "dps": 3600.0,
    "mdeg/s": 3.6,
    "rad/s": 3600.0 / DEG,
    "mrad/s": 3.6 / DEG,
    "urad/s": 3.6e-3 / DEG,
    "µrad/s": 3.6e-3 / DEG,
    "rad/h": 1.0 / DEG,
    "rpm": 360.0 * 60.0,
    "arcsec/h": 1.0 / 3600.0,
}

# angle -> arcsec
_ANGLE = {
    "arcsec": 1.0,
    '"': 1.0,
    "deg": 3600.0,
    "°": 3600.0,
    "arcmin": 60.0,
    "rad": 3600.0 / DEG,
    "mrad": 3.6 / DEG,
    "urad": 3.6e-3 / DEG,
    "µrad": 3.6e-3 / DEG,
}

# time -> s
_TIME = {
    "s": 1.0,
    "sec": 1.0,
    "ms": 1e-3,
    "us": 1e-6,
    "µs": 1e-6,
    "ns": 1e-9,
    "min": 60.0,
    "h": 3600.0,
    "hr": 3600.0,
    "d": 86400.0,
}

# magnetic field -> uT
_FIELD = {
    "uT": 1.0,
    "µT": 1.0,
    "nT": 1e-3,
    "mT": 1e3,
    "T": 1e6,
    "G": 100.0,
    "mG": 0.1,
    "Oe": 100.0,  # in air 1 Oe <-> 1 G <-> 100 uT
}

# voltage -> V
_VOLT = {"V": 1.0, "mV": 1e-3, "uV": 1e-6, "µV": 1e-6}

#: standard gravity, m/s² (CGPM 1901; the g of accelerometer data sheets and IEEE Std 1293)
G0 = 9.80665
# acceleration -> m/s²
_ACCEL = {
    "m/s^2": 1.0,
    "m/s2": 1.0,
    "m/s²": 1.0,
    "mps2": 1.0,
    "ms2": 1.0,
    "m/s/s": 1.0,
    "mm/s^2": 1e-3,
    "mm/s2": 1e-3,
    "cm/s^2": 1e-2,
    "gal": 1e-2,
    "ft/s^2": 0.3048,
    "g": G0,
    "g0": G0,
    "mg": G0 * 1e-3,
    "ug": G0 * 1e-6,
    "µg": G0 * 1e-6,
}

_TEMP = {"degC", "C", "°C", "celsius", "K", "degF", "F", "°F"}

QUANTITIES = {
    "rate": _RATE,
    "angle": _ANGLE,
    "time": _TIME,
    "field": _FIELD,
    "voltage": _VOLT,
    "acceleration": _ACCEL,
}
INTERNAL = {
    "rate": "deg/h",
    "angle": "arcsec",
    "time": "s",
    "field": "uT",
    "voltage": "V",
    "temperature": "degC",
    "acceleration": "m/s^2",
}


def _norm(unit: str) -> str:
    u = unit.strip().replace(" ", "")
    u = u.replace("deg/hr", "deg/h").replace("degree", "deg").replace("degs", "deg")
    u = u.replace("/sec", "/s").replace("per", "/")
    return u


def known_units(quantity: str) -> list[str]:
    if quantity == "temperature":
        return sorted(_TEMP)
    return list(QUANTITIES[quantity])


def factor(unit: str, quantity: str, *, what: str = "") -> float:
    """Multiplicative factor converting ``unit`` of ``quantity`` to the internal unit.

    Raises InputError naming the accepted spellings when the unit is unknown.
    """
    table = QUANTITIES[quantity]
    u = _norm(unit)
    if u in table:
        return table[u]
    low = {k.lower(): v for k, v in table.items()}
    if u.lower() in low and quantity not in ("field", "acceleration"):
        return low[u.lower()]
    where = f" for {what}" if what else ""
    raise InputError(
        f"unknown {quantity} unit {unit!r}{where}; use one of: {', '.join(table)}"
    )


def to_internal(values, unit: str, quantity: str, *, what: str = ""):
    """Convert an array (or scalar) in ``unit`` to gyrotest's internal unit for ``quantity``."""
    if quantity == "temperature":
        u = _norm(unit)
        if u in ("degC", "C", "°C", "celsius", "degc"):
            return values
        if u == "K":
            return values - 273.15
        if u in ("degF", "F", "°F"):
            return (values - 32.0) * (5.0 / 9.0)
        raise InputError(
            f"unknown temperature unit {unit!r}{' for ' + what if what else ''}; "
            "use one of: degC, K, degF"
        )
    f = factor(unit, quantity, what=what)
    return values * f if f != 1.0 else values


def rate_factor(unit: str) -> float:
    """deg/h per ``unit`` of angular rate (e.g. 3600 for deg/s)."""
    return factor(unit, "rate")


_RATE_TOKEN = re.compile(r"^\s*((?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*([^\s]*)\s*$")


def parse_rate_dph(text: str | float | int, *, what: str = "rate") -> float:
    """Parse a positive angular rate such as ``"0.05deg/h"``, ``"1e-5 deg/s"`` or a bare number
    (deg/h) into deg/h."""
    if isinstance(text, bool):
        raise InputError(f"{what} must be a rate like 0.05deg/h, got {text!r}")
    if isinstance(text, (int, float)):
        v = float(text)
    else:
        m = _RATE_TOKEN.match(str(text))
        if not m:
            raise InputError(f"cannot read {what} {text!r}; write e.g. 0.05deg/h or 1e-5deg/s")
        v = float(m.group(1)) * (factor(m.group(2), "rate", what=what) if m.group(2) else 1.0)
    if not v > 0 or not math.isfinite(v):
        raise InputError(f"{what} must be a positive rate, got {text!r}")
    return v


_DUR_TOKEN = re.compile(r"\s*((?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*([a-zµ]*)\s*")
_DUR_UNITS = {
    "": 1.0,
    "s": 1.0,
    "sec": 1.0,
    "second": 1.0,
    "seconds": 1.0,
    "ms": 1e-3,
    "m": 60.0,
    "min": 60.0,
    "mins": 60.0,
    "minute": 60.0,
    "minutes": 60.0,
    "h": 3600.0,
    "hr": 3600.0,
    "hrs": 3600.0,
    "hour": 3600.0,
    "hours": 3600.0,
    "d": 86400.0,
    "day": 86400.0,
    "days": 86400.0,
}


#: longest duration accepted anywhere: 1000 years, a finite bound beyond any bench record or
#: option (a larger one is a typo or an overflow, e.g. 1e999h)
MAX_DURATION_S = 1000 * 365.25 * 86400.0


def parse_duration(text: str | float | int, *, what: str = "duration") -> float:
    """Parse a duration such as ``"40min"``, ``"2h"``, ``"90 s"``, ``"1.5h"`` or a number of
    seconds into seconds."""
    if isinstance(text, (int, float)):
        if not text >= 0:  # NaN too
            raise InputError(f"{what} must not be negative, got {text}")
        if not math.isfinite(text) or text > MAX_DURATION_S:
            raise InputError(f"{what} {text!r} s is longer than any record (more than "
                             f"{MAX_DURATION_S:.3g} s, 1000 years)")
        return float(text)
    s = str(text).strip().lower()
    bad = InputError(f"cannot read {what} {text!r}; write e.g. 40min, 2h, 90s or 1h30min")
    if not s:
        raise bad
    total, pos = 0.0, 0
    while pos < len(s):
        m = _DUR_TOKEN.match(s, pos)
        if not m or m.end() == pos or m.group(2) not in _DUR_UNITS:
            raise bad
        if m.group(2) == "" and m.end() != len(s):
            raise bad
        total += float(m.group(1)) * _DUR_UNITS[m.group(2)]
        pos = m.end()
    if total < 0:
        raise InputError(f"{what} must not be negative, got {text!r}")
    if not math.isfinite(total) or total > MAX_DURATION_S:
        raise InputError(f"{what} {text!r} is longer than any record (more than "
                         f"{MAX_DURATION_S:.3g} s, 1000 years); write e.g. 40min, 2h, 30d")
    return total


def format_duration(seconds: float) -> str:
    """Human duration: ``3725 -> '1 h 2 min 5 s'``."""
    if not math.isfinite(seconds):
        return str(seconds)
    if seconds < 120:
        return f"{seconds:.4g} s"
    h, rem = divmod(round(seconds), 3600)
    m, s = divmod(rem, 60)
    out = []
    if h:
        out.append(f"{int(h)} h")
    if m:
        out.append(f"{int(m)} min")
    if s and h < 10:
        out.append(f"{s:.0f} s")
    return " ".join(out)


def format_number(x: float | None, digits: int = 4) -> str:
    """Compact number for tables and messages: ``digits`` significant digits, scientific
    outside 1e-3 … 1e5, ``—`` for None, NaN and infinities."""
    if x is None or not math.isfinite(x):
        return "—"
    if x == 0:
        return "0"
    ax = abs(x)
    if 1e-3 <= ax < 1e5:
        return f"{x:.{digits}g}"
    return f"{x:.{max(digits - 1, 1)}e}"
