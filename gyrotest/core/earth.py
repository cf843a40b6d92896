"""Earth rate along the input axis (IEEE 952 §12.11.4.1.1).

The earth rate vector in the local-level frame (north, east, up) at latitude φ is
``Ω_E · (cos φ, 0, sin φ)``. An input axis (IA) pointing at azimuth A (from north, clockwise
towards east) and elevation e above the horizon has the unit vector
``u = (cos e · cos A, cos e · sin A, sin e)``, so the component sensed along the IA is

    Ω_IA = Ω_E · (cos φ · cos e · cos A + sin φ · sin e)

IA up: +Ω_E sin φ; down: −Ω_E sin φ; north: +Ω_E cos φ; south: −Ω_E cos φ; east/west: 0.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from .errors import InputError

#: Earth's sidereal rotation rate, rad/s (IERS / WGS-84 value).
OMEGA_E_RAD_S = 7.2921150e-5
#: Earth's sidereal rotation rate in deg/h (= arcsec/s): 15.041067 deg/h.
OMEGA_E_DPH = OMEGA_E_RAD_S * 180.0 / math.pi * 3600.0

#: Named input-axis directions: name -> (azimuth_deg, elevation_deg).
IA_DIRECTIONS: dict[str, tuple[float, float]] = {
    "up": (0.0, 90.0),
    "down": (0.0, -90.0),
    "north": (0.0, 0.0),
    "south": (180.0, 0.0),
    "east": (90.0, 0.0),
    "west": (270.0, 0.0),
}
_ALIASES = {"u": "up", "d": "down", "n": "north", "s": "south", "e": "east", "w": "west",
            "zenith": "up", "nadir": "down", "+z": "up", "-z": "down"}


@dataclass(frozen=True)
class Site:
    """Where and how the gyro sits: latitude and input-axis direction."""

    latitude_deg: float
    ia_azimuth_deg: float = 0.0
    ia_elevation_deg: float = 90.0
    ia_label: str = "up"

    def earth_rate_dph(self) -> float:
        """Earth-rate component along the IA, deg/h."""
        return earth_rate_component(self.latitude_deg, self.ia_azimuth_deg, self.ia_elevation_deg)

    def to_dict(self) -> dict:
        return {
            "latitude_deg": self.latitude_deg,
            "ia": self.ia_label,
            "ia_azimuth_deg": self.ia_azimuth_deg,
            "ia_elevation_deg": self.ia_elevation_deg,
            "earth_rate_ia_dph": self.earth_rate_dph(),
        }


def parse_ia(text: str) -> tuple[float, float, str]:
    """Parse an IA direction: ``up``/``down``/``north``/``south``/``east``/``west`` or
    ``AZ/EL`` in degrees (e.g. ``45/30``: azimuth 45° from north towards east, elevation 30°).

    Returns ``(azimuth_deg, elevation_deg, label)``.
    """
    t = str(text).strip().lower()
    t = _ALIASES.get(t, t)
    if t in IA_DIRECTIONS:
        az, el = IA_DIRECTIONS[t]
        return az, el, t
    m = re.fullmatch(r"\s*([-+]?\d+(?:\.\d*)?)\s*[/,]\s*([-+]?\d+(?:\.\d*)?)\s*", t)
    if m:
        az, el = float(m.group(1)), float(m.group(2))
        if not -90.0 <= el <= 90.0:
            raise InputError(f"IA elevation {el}° is outside −90…90°")
        return az % 360.0, el, f"az {az % 360.0:g}°, el {el:g}°"
    raise InputError(
        f"unknown IA direction {text!r}; use up, down, north, south, east, west or AZ/EL in degrees "
        "(e.g. 45/30)"
    )


def check_latitude(lat: float) -> float:
    lat = float(lat)
    if not math.isfinite(lat) or not -90.0 <= lat <= 90.0:
        raise InputError(f"latitude {lat} is outside −90…90°")
    return lat


def cosd(deg):
    """cos of an angle in degrees, exactly 0 at odd multiples of 90° (``np.cos(np.pi/2)`` is
    6e-17: an IA pointing east would sense 6e-16 deg/h of earth rate instead of none)."""
    deg = np.asarray(deg, dtype=float)
    return np.where(np.mod(deg, 180.0) == 90.0, 0.0, np.cos(np.radians(deg)))


def sind(deg):
    """sin of an angle in degrees, exactly 0 at multiples of 180° (:func:`cosd`)."""
    deg = np.asarray(deg, dtype=float)
    return np.where(np.mod(deg, 180.0) == 0.0, 0.0, np.sin(np.radians(deg)))


def earth_rate_component(latitude_deg, azimuth_deg=0.0, elevation_deg=90.0):
    """Earth-rate component along the input axis, deg/h.

    ``Ω_IA = Ω_E (cos φ cos e cos A + sin φ sin e)`` with Ω_E = 15.041067 deg/h, latitude φ,
    IA azimuth A (from north, clockwise) and elevation e (GYRO_REFERENCE §2; IEEE 952
    §12.11.4.1.1). Works element-wise on arrays.
    """
    phi, a, e = latitude_deg, azimuth_deg, elevation_deg
    val = OMEGA_E_DPH * (cosd(phi) * cosd(e) * cosd(a) + sind(phi) * sind(e))
    return float(val) if np.ndim(val) == 0 else val


def ia_unit_vector(azimuth_deg, elevation_deg) -> np.ndarray:
    """Unit vector of the IA in the local-level (north, east, up) frame."""
    a, e = azimuth_deg, elevation_deg
    return np.array([cosd(e) * cosd(a), cosd(e) * sind(a), sind(e)], dtype=float)


def earth_rate_vector(latitude_deg) -> np.ndarray:
    """Earth rate in the local-level (north, east, up) frame, deg/h."""
    return OMEGA_E_DPH * np.array([cosd(latitude_deg), 0.0, sind(latitude_deg)], dtype=float)
