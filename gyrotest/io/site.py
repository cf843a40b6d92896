"""The test site (latitude, input-axis direction) from a bench profile."""

from __future__ import annotations

from ..core.earth import Site, check_latitude, parse_ia
from ..core.errors import InputError
from ..core.profile import Profile


def site_from_profile(prof: Profile, source: str = "profile") -> Site | None:
    s = prof.site
    if not s:
        return None
    lat = s.get("latitude_deg")
    if lat is None:
        if any(k in s for k in ("ia", "ia_azimuth_deg", "ia_elevation_deg")):
            raise InputError(f"{source}: the IA direction is given but no latitude; add "
                             "--latitude or [site] latitude_deg")
        return None
    lat = check_latitude(lat)
    if "ia_azimuth_deg" in s or "ia_elevation_deg" in s:
        az = float(s.get("ia_azimuth_deg", 0.0))
        el = float(s.get("ia_elevation_deg", 0.0))
        if not -90 <= el <= 90:
            raise InputError(f"{source}: ia_elevation_deg {el} is outside −90…90")
        label = s.get("ia") or f"az {az:g}°, el {el:g}°"
        if s.get("ia"):
            az, el, label = parse_ia(s["ia"])
        return Site(lat, az % 360.0, el, label)
    az, el, label = parse_ia(s.get("ia", "up"))
    return Site(lat, az, el, label)
