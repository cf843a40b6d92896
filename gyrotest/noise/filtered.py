"""Filtered white noise: a Markov term whose correlation time is shorter than the sample
interval is the sensor's own output filter, not a noise source.

MEMS gyros (e.g. the ADIS16405) low-pass and decimate their output, so consecutive samples are
correlated over a few milliseconds. Fitted with the IEEE terms, this shows up as a first-order
Gauss–Markov term with T_c < τ0 that "screens" the white noise: the joint fit then reports a
tiny N while almost all the white noise sits in the Markov term. For τ ≫ T_c a Markov process
is white rate noise with S(0) = (q_c·T_c)² (IEEE Std 952-1997 Annex C; Krobka, Allan-graph
topology, eq. 5.7), i.e. N_M = q_c·T_c/3600 deg/√h with q_c in deg/h/√h and T_c in s, so the
angle random walk a datasheet quotes is

    N_eq = √(N² + Σ N_M²)   deg/√h

:func:`fold_filter` reports that N_eq as the ARW N and keeps the filter as a note and as a
model component (so the model curve and the residuals are unchanged).
"""

from __future__ import annotations

import copy
import math
from typing import Any

__all__ = ["FILTER_STATUS", "fold_filter"]

#: status of a Markov term folded into N as the sensor's filter
FILTER_STATUS = "sensor filter (in N)"


def fold_filter(fit, tau0: float) -> tuple[Any, dict[str, Any] | None]:
    """(fit', info): ``fit`` with every identified Markov term of T_c < ``tau0`` folded into N.

    ``fit'`` is a copy: its N term reports N_eq (identified, 1σ by first-order propagation
    from the terms' own 1σ, treated as independent) and each folded Markov term gets the status
    :data:`FILTER_STATUS`; the coefficients (hence the model curve, residuals and attitude
    prediction) are unchanged. ``info`` is None when nothing was folded, else a dict with
    ``N_eq``, ``N_eq_sigma``, ``N_white_bound``, ``filters`` [(label, T_c s)] and ``note``.
    """
    if fit is None:
        return fit, None
    mk = [t for t in fit.terms if t.key == "markov" and t.identified and t.shape is not None
          and t.shape < tau0]
    n_term = fit.term("N")
    if not mk or n_term is None:
        return fit, None
    out = copy.copy(fit)
    out.terms = [copy.copy(t) for t in fit.terms]
    n_new = next(t for t in out.terms if t.key == "N")
    c_n = max(n_term.coef, 0.0)
    c_m = sum(max(t.coef, 0.0) for t in mk)
    fN = fit.q.factor("N") if hasattr(fit, "q") else 1.0  # accelerometer units (VRW)
    unit = "m/s/√h" if fN != 1.0 else "deg/√h"
    n_eq = math.sqrt(c_n + c_m) / 60.0
    # var(N_eq²·3600) = var(c_N) + Σ var(c_M); c = (60 N)², c_M = (q_c T_c)² / 3600
    var_c = 0.0
    if n_term.identified and n_term.sigma.get("N"):
        var_c += (2 * 3600.0 * n_term.value * n_term.sigma["N"] / fN**2) ** 2
    for t in mk:
        q, T = t.params["q_c"], t.params["T_c"]
        sq, sT = t.sigma.get("q_c") or 0.0, t.sigma.get("T_c") or 0.0
        rel = math.hypot(sq / q if q else 0.0, sT / T if T else 0.0)
        var_c += (2 * rel * t.coef) ** 2
    sig = math.sqrt(var_c) / (2 * 3600.0 * n_eq) if n_eq > 0 else math.nan
    n_eq, sig = n_eq * fN, sig * fN
    bound = n_term.upper if not n_term.identified else n_term.value
    filters = [(t.label, float(t.shape)) for t in mk]
    note = ("filtered white noise: " + ", ".join(
        f"{lab} T_c = {1000 * tc:.3g} ms" for lab, tc in filters)
        + f" is shorter than the sample interval τ0 = {1000 * tau0:.3g} ms — the sensor's own "
        f"output filter, not a noise source. N is quoted as the angle random walk N_eq = "
        f"√(N² + Σ(q_c·T_c)²) = {n_eq:.4g} {unit} (the ARW of datasheets); the filter lowers "
        "σ at the first τ only")
    if bound is not None:
        note += f" (white noise above the filter band: N ≤ {bound:.3g} {unit})"
    n_new.params = {"N": n_eq}
    n_new.sigma = {"N": sig}
    n_new.status = "identified"
    n_new.upper = None
    if not n_term.dominant_tau:
        doms = [t.dominant_tau for t in mk if t.dominant_tau]
        if doms:
            n_new.dominant_tau = (min(d[0] for d in doms), max(d[1] for d in doms))
    n_new.notes = list(n_term.notes) + ["N_eq: white noise seen through the sensor's filter "
                                        "(the filter's Markov term folded in)"]
    for t in out.terms:
        if t.key == "markov" and any(t.label == lab for lab, _ in filters):
            t.status = FILTER_STATUS
            t.notes = list(t.notes) + ["the sensor's output filter (T_c < τ0): folded into N"]
    info = {"N_eq": n_eq, "N_eq_sigma": sig, "N_white_bound": bound,
            "filters": [{"term": lab, "T_c_s": tc} for lab, tc in filters], "note": note}
    return out, info
