"""Output quantisation of a sampled channel: its step (LSB) and how much of the noise it is.

A digital sensor's rate (or acceleration) output is a whole number of LSB: the ADIS16405
writes multiples of 0.05 °/s (180 °/h), an MPU-6050 at ±250 °/s multiples of 1/131 °/s
(27.5 °/h). Rounding to the LSB q adds, when the noise spans several LSB, a white noise of
variance q²/12 per sample (Widrow, "A study of rough amplitude quantization by means of
Nyquist sampling theory", IRE Trans. Circuit Theory 3, 1956; the uniform model holds while
the noise σ ≳ q/2): for a rate output a white rate noise N_q = q·√(τ0/12)/60 deg/√h (q in
deg/h, τ0 in s), part of the fitted N. When the noise is below about one LSB the output
sticks on a few levels and that model fails (the rounding error then follows the signal).

:func:`output_resolution` finds q from the values themselves (no datasheet needed): the
smallest spacing between the distinct values, checked to divide every value's offset from
the smallest; σ is the sample-to-sample noise std(Δx)/√2 (drift does not count).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["output_resolution", "MAX_SAMPLES"]

#: at most this many leading samples are inspected (enough to see every level in use)
MAX_SAMPLES = 1 << 18
#: a share of the sample noise variance q²/12/σ² from which the quantisation is "coarse"
COARSE_SHARE = 0.01


def output_resolution(x, *, tau0: float | None = None, unit: str = "deg/h",
                      max_samples: int = MAX_SAMPLES) -> dict[str, Any] | None:
    """The quantisation step of ``x`` and its share of the noise, or None when the values are
    not on a grid (a float output, or no repeated levels).

    Returns ``lsb`` (in the unit of x), ``levels`` (distinct values in the samples looked
    at), ``sigma`` (sample-to-sample noise, std(Δx)/√2), ``lsb_over_sigma``, ``share`` =
    (q²/12)/σ² (the rounding's share of the sample noise variance), ``coarse`` (share ≥ 1 %),
    ``uniform_model`` (σ ≥ q/2: rounding acts as white noise of variance q²/12), and for a
    rate in deg/h with ``tau0`` the white rate noise it adds, ``N_q`` deg/√h."""
    a = np.asarray(x, dtype=np.float64)[:max_samples]
    a = a[np.isfinite(a)]
    if a.size < 16:
        return None
    u = np.unique(a)
    if u.size < 2 or u.size > a.size // 4:
        return None  # a continuous (float) output: nearly every sample is new
    d = np.diff(u)
    span = float(u[-1] - u[0])
    tol = 1e-9 * max(span, float(np.max(np.abs(u))))
    q = float(np.min(d[d > tol])) if np.any(d > tol) else 0.0
    if not q > 0:
        return None
    k = (u - u[0]) / q
    if np.max(np.abs(k - np.round(k))) > 1e-3:
        # not all levels are multiples of the smallest spacing: try the spacing's common
        # divisor over the used levels (a level skipped now and then is still a grid)
        return None
    dx = np.diff(a)
    sigma = float(np.std(dx) / math.sqrt(2.0)) if dx.size > 1 else math.nan
    share = (q * q / 12.0) / (sigma * sigma) if sigma > 0 else math.inf
    out = {"lsb": q, "unit": unit, "levels": int(u.size), "samples_inspected": int(a.size),
           "sigma": sigma, "lsb_over_sigma": q / sigma if sigma > 0 else math.inf,
           "share": share, "coarse": bool(share >= COARSE_SHARE),
           "uniform_model": bool(sigma >= q / 2.0)}
    if unit == "deg/h" and tau0:
        out["N_q_deg_rt_h"] = q * math.sqrt(tau0 / 12.0) / 60.0
    return out


def resolution_text(r: dict[str, Any], scale: float = 1.0, label: str | None = None) -> str:
    """One line for ``info``: the LSB (times ``scale`` in ``label``), levels, the share."""
    lab = label or r["unit"]
    txt = (f"output quantised: LSB {r['lsb'] * scale:.4g} {lab}, {r['levels']} levels used; "
           f"rounding noise q/√12 = {100 * math.sqrt(r['share']):.3g} % of the sample noise σ "
           f"({100 * r['share']:.3g} % of its variance)")
    if not r["uniform_model"]:
        txt += (" — coarse: σ < LSB/2, the output sticks on a few levels and the rounding is "
                "not white noise (the short-τ Allan deviation and N are then unreliable)")
    elif r["coarse"]:
        txt += " — coarse enough to add to N"
    if "N_q_deg_rt_h" in r and r["uniform_model"]:
        txt += f"; as white rate noise N_q = {r['N_q_deg_rt_h']:.3g} deg/√h"
    return txt
