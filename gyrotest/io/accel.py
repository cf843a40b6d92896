"""Accelerometer channels of a bench log: which columns they are, and their unit.

Every IMU lab logs the accelerometers on the same bench as the gyros. Ingest keeps such
columns as extra channels, as written (the environmental models use them in g, e.g.
``extra.acc_z_g``); :func:`accel_channels` picks them out by name and unit and converts a
copy to m/s² for the accelerometer noise analysis (``gyrotest allan``, IEEE Std 1293 terms).

Names: ``ax``/``ay``/``az``, ``a_x``, ``acc_x``, ``accel_y``, ``acceleration_z``, ``lin_acc_x``,
``linear_acceleration_x`` (also with axis 1/2/3), optionally with a unit suffix. Units: as
ingest states them for the channel (the profile's ``[units]``, the file's own — a ROS
``sensor_msgs/Imu`` states m/s² — or the header: ``ax [g]``, suffix ``_g``, ``_mg``, ``_ug``,
``_mps2``/``_ms2``/``_m_s2``), else the norm of the mean of three axes (a static log sees
gravity): within 5 % of 9.80665 reads m/s², within 5 % of 1 reads g, said in a note. Columns
whose unit stays unknown are not analysed (a note names the fix).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..core.errors import InputError
from ..core.units import G0, factor

__all__ = ["AccelChannels", "accel_channels", "is_accel_name", "ACCEL_NAME"]

#: accelerometer column names (base name, lower case, without a bracketed unit)
ACCEL_NAME = re.compile(
    r"^(?:a|acc|accel|acceleration|lin_?acc|lin_?accel|linear_?acc|linear_?acceleration)"
    r"_?([xyz123])(?:_(?:g|mg|ug|µg|mps2|ms2|m_?s2|mpss|m_s\^2))?$")
_SUFFIX = {"g": "g", "mg": "mg", "ug": "ug", "µg": "ug", "mps2": "m/s^2", "ms2": "m/s^2",
           "m_s2": "m/s^2", "ms_2": "m/s^2", "mpss": "m/s^2"}
#: a static accelerometer triad reads |mean| = 1 g: the tolerance of the unit guess
GRAVITY_TOL = 0.05


def is_accel_name(col: str) -> bool:
    """Whether a column name is an accelerometer axis (module docstring)."""
    from .columns import base_name

    return bool(ACCEL_NAME.match(base_name(col).strip().lower()))


def _suffix_unit(col: str) -> str | None:
    from .columns import split_header_unit

    base, unit = split_header_unit(col)
    if unit:
        return unit
    m = re.search(r"_(g|mg|ug|µg|mps2|ms2|m_s2|mpss)$", base.strip().lower())
    return _SUFFIX[m.group(1)] if m else None


@dataclass
class AccelChannels:
    """Accelerometer axes in m/s² (``data``: column → array), the unit each was read in
    (``units``), how (``how``: profile, file, header, gravity), and ``notes``."""

    data: dict[str, np.ndarray] = field(default_factory=dict)
    units: dict[str, str] = field(default_factory=dict)
    how: dict[str, str] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    def __bool__(self) -> bool:
        return bool(self.data)

    def to_dict(self) -> dict[str, Any]:
        return {"axes": list(self.data), "units_read": dict(self.units),
                "unit_source": dict(self.how), "internal_unit": "m/s^2",
                "notes": list(self.notes)}


def accel_channels(log) -> AccelChannels:
    """The accelerometer axes of ``log`` (its extra channels named as accelerometers) in
    m/s², with their units (module docstring). The log is not changed."""
    out = AccelChannels()
    cols = [c for c in log.extra if is_accel_name(c)]
    if not cols:
        return out
    stated = {}
    guess = []
    for c in cols:
        # ingest's unit of an extra channel: the profile's [units], the file's, the header's
        u, how = log.units.get(c) or _suffix_unit(c), "stated"
        if u:
            try:
                f = factor(u, "acceleration", what=f"accelerometer column {c!r}")
            except InputError:
                out.notes.append(f"accelerometer column {c!r}: unit {u!r} is not an "
                                 "acceleration (m/s^2, g, mg, ug): not analysed")
                continue
            stated[c] = (u, f, how)
        else:
            guess.append(c)
    if guess:
        means = [float(np.nanmean(log.extra[c])) for c in guess]
        norm = math.sqrt(sum(m * m for m in means))
        unit = None
        if len(guess) == 3 and abs(norm / G0 - 1.0) <= GRAVITY_TOL:
            unit = "m/s^2"
        elif len(guess) == 3 and abs(norm - 1.0) <= GRAVITY_TOL:
            unit = "g"
        if unit:
            out.notes.append(f"accelerometer columns {', '.join(guess)} carry no unit: read in "
                             f"{unit}, because the mean of the three axes has the norm "
                             f"{norm:.4g} (gravity); name the unit (e.g. {guess[0]}_g, "
                             f"{guess[0]}_mps2, or [units] in the profile) to be sure")
            for c in guess:
                stated[c] = (unit, factor(unit, "acceleration"), "gravity")
        else:
            out.notes.append(f"accelerometer column(s) {', '.join(guess)}: unit unknown (not "
                             "stated, and no static triad reading 1 g); name it (e.g. "
                             f"{guess[0]}_g or {guess[0]}_mps2, or [units] in the profile) to "
                             "analyse them")
    for c in cols:
        if c in stated:
            u, f, how = stated[c]
            out.data[c] = np.asarray(log.extra[c], dtype=np.float64) * f
            out.units[c] = u
            out.how[c] = how
    return out
