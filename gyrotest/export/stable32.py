"""A Stable32-style deviation table: the layout of the result tables Stable32 prints (W. J.
Riley, *Handbook of Frequency Stability Analysis*, NIST SP 1065, 2008, uses the same columns).

Per analysed axis one block::

    # STATISTICS FOR FILE: <log> (axis <name>)
    # Frequency Data Points 1 thru N of N
    # Data Type: frequency (gyro rate; sigma in deg/h) ...
    # Tau0 = 0.1 s
    # Sigma Type: Overlapping Allan
    # Confidence Factor = 0.683
    # Deadtime T/Tau = 1.000000
    #
    #  AF        Tau        #    Alpha  Min Sigma      Sigma         Max Sigma
        1   1.0000e-01   197999     0   1.8153e+00    1.8185e+00     1.8218e+00

AF is the averaging factor m = τ/τ0, ``#`` the number of terms of the estimator, Alpha the
power-law noise type used for the confidence interval, Min/Max Sigma the interval at the
confidence factor. Numbers with ``digits`` significant digits (Stable32: 5).
"""

from __future__ import annotations

import math

from .. import __version__
from ..core.errors import InputError
from .common import AllanAxis, need, number

SIGMA_TYPES = {
    "adev": "Normal Allan", "oadev": "Overlapping Allan", "mdev": "Modified Allan",
    "tdev": "Time", "hdev": "Hadamard", "ohdev": "Overlapping Hadamard", "totdev": "Total",
    "mtotdev": "Modified Total", "akdev": "Allan-Krobka", "hkdev": "Hadamard-Krobka",
}
COLUMNS = "#  AF        Tau        #    Alpha  Min Sigma      Sigma         Max Sigma"


def _e(x, digits: int) -> str:
    if x is None or not math.isfinite(float(x)):
        return "nan".rjust(digits + 5)
    return f"{float(x):.{digits - 1}e}"


def stable32_block(a: AllanAxis, digits: int = 5) -> str:
    """One Stable32-style table for an analysed axis."""
    src = a.source
    dev = need(a.doc, "deviation", a.file, f"axis {a.axis}")
    rows = need(a.doc, "table", a.file, f"axis {a.axis}")
    kind = str(dev.get("kind", "oadev"))
    n = a.n_samples
    head = [f"# STATISTICS FOR FILE: {src} (axis {a.axis})",
            f"# Frequency Data Points 1 thru {n} of {n}" if n else "# Frequency Data",
            f"# Data Type: frequency ({'acceleration' if a.is_accel else 'gyro rate'}; "
            f"sigma in {dev.get('unit', 'deg/h')}); "
            f"{a.doc.get('input', '')}".rstrip("; "),
            f"# Tau0 = {a.tau0_s:g} s",
            f"# Sigma Type: {SIGMA_TYPES.get(kind, kind.upper())}",
            f"# Confidence Factor = {float(dev.get('confidence', 0.683)):.3f}",
            "# Deadtime T/Tau = 1.000000",
            "#",
            COLUMNS]
    body = []
    for i, r in enumerate(rows):
        where = f"axis {a.axis} table row {i + 1}"
        tau = number(need(r, "tau", a.file, where), a.file, f"tau of {where}")
        m = r.get("m")
        m = int(round(tau / a.tau0_s)) if m is None else int(m)
        cnt = int(number(need(r, "n", a.file, where), a.file, f"n of {where}"))
        alpha = r.get("alpha")
        al = "   -" if alpha is None else f"{int(alpha):4d}"
        body.append(f"{m:5d}   {_e(tau, digits)} {cnt:8d}  {al}   {_e(r.get('sigma_lo'), digits)}"
                    f"    {_e(need(r, 'sigma', a.file, where), digits)}"
                    f"     {_e(r.get('sigma_hi'), digits)}")
    if not body:
        raise InputError(f"{src}: axis {a.axis} has an empty deviation table")
    tail = [f"# gyrotest {__version__}: confidence intervals {dev.get('ci_method', '')}"]
    return "\n".join(head + body + tail) + "\n"


def stable32_tables(axes: list[AllanAxis], digits: int = 5) -> str:
    if not 2 <= digits <= 12:
        raise InputError(f"--digits must be 2…12, got {digits}")
    return "\n".join(stable32_block(a, digits) for a in axes)
