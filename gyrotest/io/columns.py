"""Column roles: which column is time, gyro output, temperature, field ...; and units
taken from the column names."""

from __future__ import annotations

import re
from typing import Any

from ..core.errors import InputError
from ..core.profile import Profile
from .rawtable import _missing_column_msg

# ----------------------------------------------------------------------------- auto-detection
_TIME_NAMES = {"time", "t", "t_s", "time_s", "times", "timestamp", "seconds", "sec", "elapsed",
               "elapsed_s", "datetime", "date_time", "time_ns", "time_us", "time_ms", "t_ns",
               "timestamp_ns", "timestamp_us", "timestamp_ms", "stamp_ns"}
_RATE_NAMES = {"rate", "omega", "gyro", "w", "rate_dph", "omega_dph", "rate_dps", "omega_dps",
               "rate_rads", "gyro_rate"}
#: rate columns: rate/omega/gyro/gyr/angvel with an optional axis and unit suffix
#: (gyro_x_rps, rate_dph), and the short axis names gx/gy/gz, wx/wy/wz
_RATE_RE = re.compile(
    r"^(?:(?:rate|omega|gyro|gyr|ang_?vel|angular_velocity)_?[xyz123]?|[gw]_?[xyz])"
    r"(?:_(?:d?p[hs]|rads?|rad_?s|rps|deg_?[sh]|mrad_?s))?$")


def is_rate_name(name: str) -> bool:
    """A gyro rate column by its name (without a bracketed unit, lower case): the names above,
    and the same words as loggers write them, separated by blanks, hyphens or dots (``Gyro Z``
    of ``Gyro Z (deg/s)``), with ``rate`` after the sensor's name (``gyro_rate_dps``)."""
    if name in _RATE_NAMES or _RATE_RE.match(name):
        return True
    key = re.sub(r"[\s.\-]+", "_", name.strip())
    key = re.sub(r"^(gyro|gyr|omega)_?rate(?=_|$)", r"\1", key)
    return key in _RATE_NAMES or bool(_RATE_RE.match(key))


#: per-sample angle increments (an IMU's Δθ output): dtheta, dtheta_x, delta_angle_y, dang_z
_DELTA_ANGLE_RE = re.compile(r"^(?:d_?theta|delta_?angle|delta_?theta|dang)_?[xyz123]?"
                             r"(?:_(?:rad|deg|mrad|urad|arcsec))?$")
_COUNT_NAMES = {"counts", "count", "pulses", "pulse", "dn", "delta_n", "n_pulses"}
_COUNTER_NAMES = {"counter", "cnt", "cum_counts", "pulse_counter"}
_VOLT_NAMES = {"voltage", "v_out", "vout", "volt", "u_out", "analog"}
_SUPPLY_NAMES = {"supply", "vsupply", "v_supply", "supply_v", "vcc", "vin", "v_in", "vdd"}
_TABLE_NAMES = {"table_rate", "table", "cmd_rate", "table_dps", "commanded_rate", "table_cmd",
                "rate_cmd", "input_rate"}
_POSITION_NAMES = {"position", "pos", "ia_position"}
_FIELD_PATTERNS = [
    (re.compile(r"^(h|b|mag_?|field_?)x", re.I), "x"),
    (re.compile(r"^(h|b|mag_?|field_?)y", re.I), "y"),
    (re.compile(r"^(h|b|mag_?|field_?)z", re.I), "z"),
]
_TEMP_PATTERN = re.compile(r"^(temp|temperature|t_(?!s$)|tc\d|t\d|thermo)", re.I)

# unit hints from a column-name suffix
_SUFFIX_UNITS = [
    (re.compile(r"_(dph|deg_?h|deg_per_h)$", re.I), "deg/h"),
    (re.compile(r"_(dps|deg_?s|deg_per_s)$", re.I), "deg/s"),
    (re.compile(r"_(rads|rad_?s|rad_per_s|rps)$", re.I), "rad/s"),
    (re.compile(r"_(mrads|mrad_?s)$", re.I), "mrad/s"),
    (re.compile(r"_(degc|c)$", re.I), "degC"),
    (re.compile(r"_k$", re.I), "K"),
    (re.compile(r"_(degf|f)$", re.I), "degF"),
    (re.compile(r"_(ut|µt|microtesla)$", re.I), "uT"),
    (re.compile(r"_nt$", re.I), "nT"),
    (re.compile(r"_mt$"), "mT"),
    (re.compile(r"_gauss$", re.I), "G"),
    # ``_g`` is an acceleration in standard gravity (accelerometer columns ax_g, acc_z_g);
    # a magnetic-field column named so is read in gauss (ingest: field_unit)
    (re.compile(r"_g$"), "g"),
    (re.compile(r"_mg$"), "mg"),
    (re.compile(r"_(ug|µg)$"), "ug"),
    (re.compile(r"_(mps2|ms2|m_?s2|mpss)$", re.I), "m/s^2"),
    (re.compile(r"_v$", re.I), "V"),
    (re.compile(r"_mv$", re.I), "mV"),
    (re.compile(r"_ms$", re.I), "ms"),
    (re.compile(r"_us$", re.I), "us"),
    (re.compile(r"_ns$", re.I), "ns"),
]
#: angle units from a name suffix: only for delta-angle / angle columns (``gx_rad``)
_ANGLE_SUFFIX_UNITS = [
    (re.compile(r"_rad$", re.I), "rad"),
    (re.compile(r"_mrad$", re.I), "mrad"),
    (re.compile(r"_urad$", re.I), "urad"),
    (re.compile(r"_deg$", re.I), "deg"),
    (re.compile(r"_arcsec$", re.I), "arcsec"),
]


def angle_unit_from_name(col: str) -> str | None:
    """The angle unit a column header states: bracketed (``dtheta_x [rad]``) or a suffix."""
    return _header_unit(col, _ANGLE_SUFFIX_UNITS)


def _header_unit(col: str, suffixes) -> str | None:
    """A bracketed unit in the header, else the unit of the first matching name suffix."""
    base, unit = split_header_unit(col)
    if unit:
        return unit
    return next((u for pat, u in suffixes if pat.search(base)), None)


# ----------------------------------------------------------------------------- roles
class RoleError(InputError):
    """The columns do not say which one is the gyro output (or its unit): ``gyrotest info``
    still lists the columns and its guesses before reporting it."""


_ROLE_POOLS = [
    ("time", lambda b: b in _TIME_NAMES),
    ("rate", is_rate_name),
    ("delta-angle", lambda b: bool(_DELTA_ANGLE_RE.match(b))),
    ("counts", lambda b: b in _COUNT_NAMES),
    ("counter", lambda b: b in _COUNTER_NAMES),
    ("voltage", lambda b: b in _VOLT_NAMES),
    ("supply voltage", lambda b: b in _SUPPLY_NAMES),
    ("rate-table rate", lambda b: b in _TABLE_NAMES),
    ("position", lambda b: b in _POSITION_NAMES),
    ("temperature", lambda b: bool(_TEMP_PATTERN.match(b))),
    ("magnetic field", lambda b: any(p.match(b) for p, _ in _FIELD_PATTERNS)),
    ("up pulses", lambda b: b == "up"),
    ("down pulses", lambda b: b == "down"),
]


def column_guesses(names: list[str]) -> list[dict[str, str | None]]:
    """Every column with the role its name suggests (or None) and the unit its header states
    (or None): what ``gyrotest info`` lists when it cannot pick the gyro output."""
    out = []
    for n in names:
        b = base_name(n).lower()
        role = next((r for r, test in _ROLE_POOLS if test(b)), None)
        unit = _unit_from_name(n) or (angle_unit_from_name(n) if role == "delta-angle" else None)
        out.append({"column": n, "role": role, "unit": unit})
    return out


def _ci(names: list[str]) -> dict[str, str]:
    return {n.lower(): n for n in names}


_HEADER_UNIT = re.compile(r"^(?P<base>.*?\S)\s*(?:\[(?P<sq>[^\[\]]+)\]|\((?P<par>[^()]+)\))\s*$")


def split_header_unit(col: str) -> tuple[str, str | None]:
    """``"gx [deg/s]"`` → ``("gx", "deg/s")``, ``"temp (degC)"`` → ``("temp", "degC")``;
    a name without a bracketed unit → ``(name, None)``."""
    m = _HEADER_UNIT.match(col.strip())
    if not m:
        return col, None
    unit = (m.group("sq") or m.group("par")).strip()
    return m.group("base"), unit or None


def base_name(col: str) -> str:
    """The column name without a bracketed unit."""
    return split_header_unit(col)[0]


def _unit_from_name(col: str) -> str | None:
    """A unit stated in the header: a bracketed unit (``gx [deg/s]``) or a name suffix
    (``rate_dps``)."""
    return _header_unit(col, _SUFFIX_UNITS)


def resolve_columns(names: list[str], prof: Profile, source: str) -> tuple[dict[str, Any], list[str]]:
    """Map roles to columns: the profile (and overrides) first, then obvious names.

    Returns (roles, notes). ``roles`` keys: time, kind, output (list), temperature (list),
    field (list), supply, table_rate, position, extra (list).
    """
    cols = prof.columns
    lower = _ci(names)
    notes: list[str] = []
    used: set[str] = set()

    def need(col: str, role: str) -> str:
        if col in names:
            used.add(col)
            return col
        if col.lower() in lower:
            real = lower[col.lower()]
            used.add(real)
            return real
        by_base = [n for n in names if base_name(n).lower() == col.lower()]
        if len(by_base) == 1:  # --rate-col gx for a header "gx [deg/s]"
            used.add(by_base[0])
            return by_base[0]
        raise InputError(_missing_column_msg(col, names, source, role))

    roles: dict[str, Any] = {}
    # time
    if cols.get("time"):
        roles["time"] = need(cols["time"], "time")
    else:
        hits = [n for n in names if base_name(n).lower() in _TIME_NAMES]
        roles["time"] = hits[0] if hits else None
        if roles["time"]:
            used.add(roles["time"])
            notes.append(f"time: column {roles['time']!r} (auto-detected)")
    # gyro output
    kind = prof.output_kind()
    if kind == "updown":
        roles["output"] = [need(cols["up"], "up pulses"), need(cols["down"], "down pulses")]
    elif kind is not None:
        roles["output"] = [need(c, kind) for c in cols[kind.replace("-", "_")]]
    else:
        found: dict[str, list[str]] = {}
        for n in names:
            if n in used:
                continue
            ln = base_name(n).lower()
            if is_rate_name(ln):
                found.setdefault("rate", []).append(n)
            elif _DELTA_ANGLE_RE.match(ln):
                found.setdefault("delta-angle", []).append(n)
            elif ln in _COUNT_NAMES:
                found.setdefault("counts", []).append(n)
            elif ln in _COUNTER_NAMES:
                found.setdefault("counter", []).append(n)
            elif ln in _VOLT_NAMES:
                found.setdefault("voltage", []).append(n)
        if "up" in lower and "down" in lower:
            found["updown"] = [lower["up"], lower["down"]]
        if len(found) > 1:
            raise RoleError(
                f"{source}: several gyro outputs look possible ({'; '.join(f'{k}: {v}' for k, v in found.items())}); "
                "name one with --rate-col, --counts-col, --up-col/--down-col, --counter-col or "
                "--voltage-col (or in the profile's [columns])"
            )
        if not found:
            raise RoleError(
                f"{source}: no gyro output column found among {', '.join(names[:12])}; name it "
                "with --rate-col, --counts-col, --up-col/--down-col, --counter-col or --voltage-col "
                "(or in a --profile)"
            )
        kind, cs = next(iter(found.items()))
        roles["output"] = cs
        used.update(cs)
        notes.append(f"gyro output: {kind} from column(s) {', '.join(map(repr, cs))} (auto-detected)")
    read_as = prof.gyro.get("output_kind")
    if read_as and read_as != kind:
        if read_as not in ("rate", "delta-angle", "angle"):
            raise InputError(f"{source}: unknown output kind {read_as!r}; use rate, delta-angle "
                             "or angle")
        if kind not in ("rate", "delta-angle", "angle"):
            raise InputError(f"{source}: --output-kind {read_as} reads rate or angle columns, "
                             f"but the gyro output is {kind} ({', '.join(roles['output'])})")
        notes.append(f"gyro output read as {read_as} (--output-kind)")
        kind = read_as
    roles["kind"] = kind
    # auxiliary channels
    if cols.get("temperature"):
        roles["temperature"] = [need(c, "temperature") for c in cols["temperature"]]
    else:
        roles["temperature"] = [n for n in names
                                if n not in used and _TEMP_PATTERN.match(base_name(n))]
        if roles["temperature"]:
            notes.append("temperature: " + ", ".join(map(repr, roles["temperature"])) + " (auto-detected)")
        used.update(roles["temperature"])
    if cols.get("field"):
        roles["field"] = [need(c, "magnetic field") for c in cols["field"]]
    else:
        fx = []
        for pat, _axis in _FIELD_PATTERNS:
            hit = [n for n in names if n not in used and pat.match(base_name(n))]
            if len(hit) == 1:
                fx.append(hit[0])
        roles["field"] = fx if len(fx) == 3 else []
        if roles["field"]:
            notes.append("magnetic field X, Y, Z: " + ", ".join(map(repr, fx)) + " (auto-detected)")
        used.update(roles["field"])
    for role, pool, label in (("supply", _SUPPLY_NAMES, "supply voltage"),
                              ("table_rate", _TABLE_NAMES, "rate-table rate"),
                              ("position", _POSITION_NAMES, "position")):
        if cols.get(role):
            roles[role] = need(cols[role], label)
        else:
            hit = [n for n in names if n not in used and base_name(n).lower() in pool]
            roles[role] = hit[0] if hit else None
            if roles[role]:
                used.add(roles[role])
                notes.append(f"{label}: column {roles[role]!r} (auto-detected)")
    if cols.get("extra"):
        roles["extra"] = [need(c, "extra channel") for c in cols["extra"]]
    else:
        roles["extra"] = [n for n in names if n not in used and not n.startswith("Unnamed")]
    one_role_per_column(roles, source)
    return roles, notes


def one_role_per_column(roles: dict[str, Any], source: str) -> None:
    """A column named in two roles (``rate = "gx"`` and ``temperature = ["gx"]``, or twice in
    one list) is an error naming both keys: it would be read twice, as two quantities."""
    seen: dict[str, str] = {}
    out_key = {"updown": "up/down"}.get(roles.get("kind") or "", (roles.get("kind") or "rate"))
    for key in ("time", "output", "temperature", "field", "supply", "table_rate", "position",
                "extra"):
        value = roles.get(key)
        if not value:
            continue
        name = out_key.replace("-", "_") if key == "output" else key
        items = [(f"[columns].{name}", value)] if isinstance(value, str) else [
            (f"[columns].{name}[{i}]", c) for i, c in enumerate(value)]
        for where, col in items:
            if col in seen:
                raise InputError(f"{source}: column {col!r} is named in two roles, {seen[col]} "
                                 f"and {where}; a column has one role: fix the profile's "
                                 "[columns] or the column options")
            seen[col] = where


