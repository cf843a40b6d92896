"""Bench profiles: which column is what, and the gyro and site constants.

A lab writes one TOML profile per bench and passes it with ``--profile FILE``; command-line
options override it key by key. Example::

    [columns]
    time = "t_s"                   # seconds (any origin) or ISO-8601 timestamps
    counts = "pulses"              # or: rate = "..." (or a list of axes) / voltage = "..." /
                                   #     up = "...", down = "..." / counter = "..." /
                                   #     delta_angle = "..." (per sample) / angle = "..." (cumulative)
    temperature = ["T_case_C", "T_coil_C"]
    field = ["Hx_uT", "Hy_uT", "Hz_uT"]
    supply = "vsupply"
    table_rate = "table_dps"       # commanded rate-table rate
    position = "pos"               # multi-position label column (up/down/north/...)
    extra = ["vib_g"]              # free channels
    topic = "/imu/data"            # ROS bag topic, HDF5 group or MATLAB struct of the columns

    [units]                        # per-column units where not the role default
    "table_dps" = "deg/s"

    [gyro]
    scale_factor = 0.2             # arcsec/pulse for counts, (deg/h)/V for voltage
    offset_v = 2.5
    rate_unit = "deg/h"            # for a rate column
    angle_unit = "rad"             # for delta_angle / angle columns: rad, deg, arcsec, mrad, urad
    # output_kind = "delta-angle"  # read the (auto-detected) gyro columns as rate, delta-angle or angle
    counter_bits = 32
    sample_rate_hz = 10.0          # when there is no time column (else checked against it)
    time_unit = "ns"               # unit of a numeric time column: s, ms, us, ns (else guessed)
    model = "FOG-X"
    serial = "0001"

    [site]
    latitude_deg = 48.137
    ia = "up"                      # up/down/north/south/east/west, or ia_azimuth_deg + ia_elevation_deg

    [display]
    unit = "deg/s"                 # tables, plots, sheet: deg/h (IEEE, default), deg/s, rad/s, mdps

Role default units: time s, rate deg/h, temperature degC, field uT, supply V, table_rate deg/s.
Unknown sections or keys are an error (a misspelt key would otherwise be silently ignored).
"""

from __future__ import annotations

import copy
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .errors import InputError

SCHEMA: dict[str, dict[str, type | tuple]] = {
    "columns": {
        "time": str,
        "rate": (str, list),
        "counts": (str, list),
        "up": str,
        "down": str,
        "counter": (str, list),
        "voltage": (str, list),
        "delta_angle": (str, list),
        "angle": (str, list),
        "temperature": (str, list),
        "field": (str, list),
        "supply": str,
        "table_rate": str,
        "position": str,
        "extra": (str, list),
        "topic": str,  # ROS topic / HDF5 group / MATLAB struct holding the columns
    },
    "units": {},  # free keys: column name -> unit string
    "gyro": {
        "rate_unit": str,
        "angle_unit": str,
        "output_kind": str,
        "scale_factor": (float, int),
        "offset_v": (float, int),
        "counter_bits": int,
        "sample_rate_hz": (float, int),
        "time_unit": str,
        "model": str,
        "serial": str,
        "type": str,
        "power_on_at_start": bool,  # the log starts at the gyro's power-on (warm-up)
    },
    "site": {
        "latitude_deg": (float, int),
        "ia": str,
        "ia_azimuth_deg": (float, int),
        "ia_elevation_deg": (float, int),
    },
    "display": {
        "unit": str,  # display unit of tables, plots and the sheet (gyrotest.display)
    },
}

LIST_KEYS = {"rate", "counts", "counter", "voltage", "delta_angle", "angle", "temperature",
             "field", "extra"}
OUTPUT_KINDS = ("rate", "counts", "updown", "counter", "voltage", "delta-angle", "angle")
#: output kinds whose columns are angles (unit: [gyro] angle_unit / --angle-unit)
ANGLE_KINDS = ("delta-angle", "angle")
#: [gyro] output_kind: how the auto-detected (or --rate-col) columns are read
READ_AS_KINDS = ("rate", "delta-angle", "angle")


@dataclass
class Profile:
    """A bench profile (possibly empty) after validation. Lists are always lists."""

    columns: dict[str, Any] = field(default_factory=dict)
    units: dict[str, str] = field(default_factory=dict)
    gyro: dict[str, Any] = field(default_factory=dict)
    site: dict[str, Any] = field(default_factory=dict)
    source: str | None = None
    display: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {"columns": self.columns, "units": self.units, "gyro": self.gyro,
                "site": self.site, "source": self.source}

    def output_kind(self) -> str | None:
        """Which gyro output kind the columns name, or None when not given."""
        c = self.columns
        kinds = [k.replace("_", "-") for k in
                 ("rate", "counts", "counter", "voltage", "delta_angle", "angle") if c.get(k)]
        if c.get("up") or c.get("down"):
            kinds.append("updown")
        if len(kinds) > 1:
            raise InputError(
                f"{self.source or 'options'}: more than one gyro output given ({', '.join(kinds)}); "
                "name exactly one of rate, counts, up+down, counter, voltage, delta_angle, angle"
            )
        return kinds[0] if kinds else None


def _check(section: str, key: str, value: Any, src: str) -> Any:
    spec = SCHEMA[section]
    if section == "units":
        if not isinstance(value, str):
            raise InputError(f"{src}: [units] {key!r} must be a unit string like \"deg/s\"")
        return value
    if key not in spec:
        raise InputError(
            f"{src}: unknown key {key!r} in [{section}]; known keys: {', '.join(spec)}"
        )
    typ = spec[key]
    types = typ if isinstance(typ, tuple) else (typ,)
    if float in types and isinstance(value, bool):
        raise InputError(f"{src}: [{section}] {key} must be a number, got {value!r}")
    if not isinstance(value, types):
        want = " or ".join("list of strings" if t is list else t.__name__ for t in types)
        raise InputError(f"{src}: [{section}] {key} must be {want}, got {value!r}")
    if isinstance(value, list):
        if not all(isinstance(v, str) for v in value):
            raise InputError(f"{src}: [{section}] {key} must be a list of column names (strings)")
    if key in LIST_KEYS and isinstance(value, str):
        value = [value]
    return value


def profile_from_dict(data: dict, source: str = "profile") -> Profile:
    """Validate a parsed TOML profile (unknown sections/keys and wrong types are errors)."""
    prof = Profile(source=source)
    for section, body in data.items():
        if section not in SCHEMA:
            raise InputError(
                f"{source}: unknown section [{section}]; known sections: "
                + ", ".join(f"[{s}]" for s in SCHEMA)
            )
        if not isinstance(body, dict):
            raise InputError(f"{source}: [{section}] must be a table of key = value lines")
        target = getattr(prof, section)
        for key, value in body.items():
            target[key] = _check(section, key, value, source)
    prof.output_kind()  # validates that at most one output kind is named
    if prof.gyro.get("output_kind") not in (None, *READ_AS_KINDS):
        raise InputError(f"{source}: [gyro] output_kind must be one of "
                         f"{', '.join(READ_AS_KINDS)}, got {prof.gyro['output_kind']!r}")
    if "unit" in prof.display:
        from .display import parse_display_unit

        parse_display_unit(prof.display["unit"], what=f"{source}: [display] unit")
    if "field" in prof.columns and len(prof.columns["field"]) not in (1, 2, 3):
        raise InputError(f"{source}: [columns] field must list 1 to 3 columns (X, Y, Z)")
    if prof.columns.get("up") and not prof.columns.get("down") or (
        prof.columns.get("down") and not prof.columns.get("up")
    ):
        raise InputError(f"{source}: up/down pulse pairs need both 'up' and 'down' columns")
    return prof


def read_toml(path: str | Path, *, not_found: str, expected: str, kind: str
              ) -> tuple[dict[str, Any], bytes]:
    """Parse a TOML file; returns (data, raw bytes). InputErrors start with the path:
    ``<not_found>``, ``is a directory, expected <expected>``, ``not a text file; <kind> is
    TOML text``, ``invalid TOML: ...``."""
    p = Path(path)
    try:
        raw = p.read_bytes()
    except FileNotFoundError:
        raise InputError(f"{p}: {not_found}") from None
    except IsADirectoryError:
        raise InputError(f"{p}: is a directory, expected {expected}") from None
    try:
        data = tomllib.loads(raw.decode("utf-8"))
    except UnicodeDecodeError:
        raise InputError(f"{p}: not a text file; {kind} is TOML text") from None
    except tomllib.TOMLDecodeError as e:
        raise InputError(f"{p}: invalid TOML: {e}") from None
    return data, raw


def load_profile(path: str | Path) -> Profile:
    """Read and validate a bench profile TOML file."""
    data, _ = read_toml(path, not_found="profile not found; check the --profile path",
                        expected="a TOML profile file", kind="a profile")
    return profile_from_dict(data, source=str(Path(path)))


def merge(base: Profile | None, overrides: dict[str, dict[str, Any]]) -> Profile:
    """Return ``base`` with ``overrides`` (same shape as a profile; None values skipped)
    applied key by key. Naming a different gyro output kind on the command line replaces
    the profile's output kind."""
    prof = copy.deepcopy(base) if base is not None else Profile()
    out_keys = {"rate", "counts", "up", "down", "counter", "voltage", "delta_angle", "angle"}
    for section, body in overrides.items():
        target = getattr(prof, section)
        given = {k: v for k, v in body.items() if v is not None and v != [] and v != ()}
        if section == "columns" and out_keys & set(given):
            for k in out_keys:
                target.pop(k, None)
        for key, value in given.items():
            if key in LIST_KEYS and isinstance(value, str):
                value = [value]
            target[key] = list(value) if isinstance(value, tuple) else value
    prof.output_kind()
    return prof
