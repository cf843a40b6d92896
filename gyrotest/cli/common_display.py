"""The ``--unit`` display option shared by the commands that print rates and noise terms.

Tables, plot axes and the sheet are shown in the display unit (:mod:`gyrotest.core.display`);
JSON keeps its explicit internal units. Precedence: ``--unit``, then the profile's
``[display] unit``, then deg/h (IEEE 952).
"""

from __future__ import annotations

import click

from ..core.display import CHOICES, DisplayUnit, parse_display_unit


def unit_option(f):
    """Add ``--unit`` (display unit of tables and plots) to a command."""
    return click.option(
        "--unit", "display_unit", default=None, metavar="|".join(CHOICES),
        help="Display unit of tables and plots: deg/h (IEEE, default), deg/s, rad/s or mdps; "
             "noise terms follow (N per √Hz, K per √s, R per s, Q as angle). JSON keeps its "
             "explicit units. Default: the profile's [display] unit, else deg/h.")(f)


def resolve_display_unit(unit: str | None, ingest_opts: dict | None = None) -> DisplayUnit:
    """``--unit`` if given, else the ``--profile``'s ``[display] unit``, else deg/h."""
    if unit is not None:
        return parse_display_unit(unit)
    path = (ingest_opts or {}).get("profile")
    if path:
        from ..core.profile import load_profile

        prof = load_profile(path)
        if prof.display.get("unit"):
            return parse_display_unit(prof.display["unit"], what=f"{path}: [display] unit")
    return parse_display_unit(None)
