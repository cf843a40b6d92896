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
        "unit": str,  # display unit of tables, plots and the sheet (gyrotest.core.display)
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


#: the profile as a document schema (gyrotest.core.documents): types and closed key sets
DOC_SCHEMA = {
    "columns": {k: ("str|strs" if k in ("rate", "counts", "counter", "voltage", "delta_angle",
                                        "angle", "temperature", "field", "extra") else "str")
                for k in SCHEMA["columns"]},
    "units": {"*": "str"},
    "gyro": {"rate_unit": "str", "angle_unit": "str", "output_kind": "str",
             "scale_factor": "num", "offset_v": "num", "counter_bits": "int",
             "sample_rate_hz": "pos", "time_unit": "str", "model": "str", "serial": "str",
             "type": "str"},
    "site": {"latitude_deg": "num", "ia": "str", "ia_azimuth_deg": "num",
             "ia_elevation_deg": "num"},
    "display": {"unit": "str"},
}
#: the quantity of each column role (for the [units] of a column named in [columns])
_ROLE_QUANTITY = {"time": "time", "rate": "rate", "delta_angle": "angle", "angle": "angle",
                  "temperature": "temperature", "field": "field", "supply": "voltage",
                  "table_rate": "rate"}


def _unit_problem(unit: str, quantity: str) -> str | None:
    from .units import factor, to_internal

    try:
        if quantity == "temperature":
            to_internal(0.0, unit, "temperature")
        else:
            factor(unit, quantity)
    except InputError as e:
        return str(e)
    return None


def profile_problems(data: dict) -> list[str]:
    """Every problem of a parsed profile, one line each naming its key path
    (``[columns].temperature[1]``): types, unknown sections and keys, units that do not parse,
    a column named in two roles, values out of range."""
    from .documents import check_schema, keypath

    problems = check_schema(data, DOC_SCHEMA, toml=True)
    if problems:
        return problems
    cols, gyro = data.get("columns", {}), data.get("gyro", {})
    for key, quantity in (("rate_unit", "rate"), ("angle_unit", "angle"), ("time_unit", "time")):
        if key in gyro:
            bad = _unit_problem(gyro[key], quantity)
            if bad:
                problems.append(f"[gyro].{key}: {bad}")
    roles: dict[str, tuple[str, str]] = {}  # column -> (key path, role)
    for role, value in cols.items():
        if role == "topic":
            continue
        items = [(keypath(("columns", role)), value)] if isinstance(value, str) else [
            (keypath(("columns", role, i)), c) for i, c in enumerate(value)]
        for where, col in items:
            if not col.strip():
                problems.append(f"{where}: an empty column name")
            elif col in roles:
                problems.append(f"{where}: column {col!r} is also {roles[col][0]}; a column has "
                                "one role")
            else:
                roles[col] = (where, role)
    for col, unit in data.get("units", {}).items():
        role = roles.get(col, (None, None))[1]
        quantities = ([_ROLE_QUANTITY[role]] if role in _ROLE_QUANTITY else
                      ["rate", "angle", "time", "temperature", "field", "voltage"])
        if all(_unit_problem(unit, q) for q in quantities):
            want = quantities[0] if len(quantities) == 1 else "any quantity"
            problems.append(f"{keypath(('units', col))}: {unit!r} is not a {want} unit"
                            + (f" ({_unit_problem(unit, quantities[0])})"
                               if len(quantities) == 1 else ""))
    if gyro.get("output_kind") not in (None, *READ_AS_KINDS):
        problems.append(f"[gyro].output_kind: must be one of {', '.join(READ_AS_KINDS)}, got "
                        f"{gyro['output_kind']!r}")
    if "counter_bits" in gyro and not 1 <= gyro["counter_bits"] <= 64:
        problems.append(f"[gyro].counter_bits: must be 1 to 64 bits, got {gyro['counter_bits']}")
    if gyro.get("scale_factor") == 0:
        problems.append("[gyro].scale_factor: must be non-zero")
    site = data.get("site", {})
    if "latitude_deg" in site and not -90 <= site["latitude_deg"] <= 90:
        problems.append(f"[site].latitude_deg: must be within -90...90, got "
                        f"{site['latitude_deg']}")
    field_cols = cols.get("field")
    if field_cols is not None and len([field_cols] if isinstance(field_cols, str)
                                      else field_cols) not in (1, 2, 3):
        problems.append("[columns].field: must list 1 to 3 columns (X, Y, Z)")
    if bool(cols.get("up")) != bool(cols.get("down")):
        problems.append("[columns].up: up/down pulse pairs need both 'up' and 'down' columns")
    return problems


def profile_from_dict(data: dict, source: str = "profile") -> Profile:
    """Validate a parsed TOML profile: every problem (unknown sections/keys, wrong types,
    units that do not parse, a column in two roles) is reported, one line each
    (:class:`gyrotest.core.documents.DocumentError`)."""
    from .documents import DocumentError

    problems = profile_problems(data)
    if problems:
        raise DocumentError(source, problems)
    prof = Profile(source=source)
    for section, body in data.items():
        target = getattr(prof, section)
        for key, value in body.items():
            target[key] = [value] if key in LIST_KEYS and isinstance(value, str) else value
    prof.output_kind()  # validates that at most one output kind is named
    if "unit" in prof.display:
        from .display import parse_display_unit

        parse_display_unit(prof.display["unit"], what=f"{source}: [display] unit")
    return prof


def read_toml(path: str | Path, *, not_found: str, expected: str, kind: str
              ) -> tuple[dict[str, Any], bytes]:
    """Parse a TOML file; returns (data, raw bytes). InputErrors start with the path:
    ``<not_found>``, ``is a directory, expected <expected>``, ``not a text file; <kind> is
    TOML text``, ``invalid TOML: ...``."""
    from .documents import load_document

    data, raw = load_document(Path(path), fmt="toml", what=kind, not_found=not_found)
    if not isinstance(data, dict):  # pragma: no cover - a TOML document is a table
        raise InputError(f"{path}: not a table of keys; {kind} is TOML text")
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
