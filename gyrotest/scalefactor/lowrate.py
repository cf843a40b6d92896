"""Threshold, resolution and input range from rate-table plateaus (IEEE 952 §5.3.1, §5.3.2;
definitions of IEEE Std 528, "Inertial sensor terminology").

* **Threshold**: the largest absolute value of the minimum input that produces an output of at
  least 50 % of the output expected from the scale factor. From the low-rate plateaus
  (|table rate| ≤ 0.1 % of full scale, or any plateau in a lock-in dead band): a plateau
  *responds* when (y − b)/(k·I) ≥ 0.5 and |y − b| > 2·SE, with b, k the run's line fitted
  without the low and saturated plateaus. The threshold lies between the largest rate that did
  not respond and the smallest rate above it that did (both signs); when every low rate
  responds it is stated as ≤ the smallest rate tested.
* **Resolution**: the largest value of the minimum change in input, above the threshold, that
  produces a change in output of at least 50 % of the expected change. From consecutive
  plateaus of one run at the same sign whose commands differ by at most 10 % (a step sequence
  on a base rate): a step responds when Δy/(k·ΔI) ≥ 0.5 and |Δy| > 2·√(SE₁² + SE₂²).
* **Input range / saturation**: plateaus where the output stops following the table: the
  output falls short of the line through the lower half of the rates by more than
  ``tol`` (1 %) of the expected output. Saturated plateaus are excluded from the fits; the
  input range is the largest |rate| of each sign that still follows.

Units: rates deg/s in the results (deg/h inside, like the points), ratios dimensionless.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .tablefit import DPS, Points, line_fit

NOT_TESTED = "not tested"


@dataclass
class StepResponse:
    """Threshold or resolution (IEEE 528): the steps tried and the bracket found, deg/s."""

    status: str  # "ok" or "not tested (why)"
    value_dps: float = math.nan  # upper bound: the threshold/resolution is at most this
    lower_dps: float = math.nan  # largest input (step) that did not respond
    steps: list[dict] = field(default_factory=list)

    def to_dict(self) -> dict:
        return {"status": self.status, "at_most_dps": self.value_dps,
                "above_dps": self.lower_dps, "steps": self.steps,
                "criterion": "output (change) >= 50 % of the expected from the scale factor "
                             "and > 2 standard errors (IEEE Std 528)"}


@dataclass
class InputRange:
    """Input range (IEEE 952 §5.3.1): the largest |rate| of each sign that the output follows,
    and the plateaus where it saturated (excluded from the fits)."""

    status: str
    positive_dps: float = math.nan
    negative_dps: float = math.nan
    saturated: bool = False
    saturated_rates_dps: list[float] = field(default_factory=list)
    tolerance: float = 0.01

    def to_dict(self) -> dict:
        return {"status": self.status, "input_range_positive_dps": self.positive_dps,
                "input_range_negative_dps": self.negative_dps,
                "saturation_detected": self.saturated,
                "saturated_rates_dps": self.saturated_rates_dps,
                "criterion": f"output short of the low-rate line by more than "
                             f"{self.tolerance:.0%} of the expected output"}


def _ref_line(I: np.ndarray, y: np.ndarray, use: np.ndarray) -> tuple[float, float] | None:
    if len(np.unique(np.round(I[use], 6))) < 2:
        return None
    f = line_fit(I[use], y[use], None)
    return float(f.coef[0]), float(f.coef[1])


def detect_saturation(P: Points, *, tol: float = 0.01) -> tuple[np.ndarray, InputRange]:
    """Saturated plateaus (mask over P) and the input range. Per run, the reference line goes
    through the non-zero plateaus at or below the median |rate| (far from any saturation); a
    plateau above it saturates when 1 − (y − b)/(k·I) > ``tol``."""
    sat = np.zeros(P.n, dtype=bool)
    tab = P.table if P.table is not None else P.I
    for r in range(len(P.runs)):
        sel = np.flatnonzero(P.run == r)
        I, y, tb = P.I[sel], P.y[sel], tab[sel]
        nz = tb != 0
        if nz.sum() < 4:
            continue
        mag = np.abs(tb)
        lo = nz & (mag <= np.median(mag[nz]))
        ref = _ref_line(I, y, lo | ~nz)
        if ref is None:
            continue
        b, k = ref
        with np.errstate(divide="ignore", invalid="ignore"):
            rho = (y - b) / (k * I)
        sat[sel[nz & ~lo & (1 - rho > tol)]] = True
    tested_pos = tab[tab > 0] / DPS
    tested_neg = -tab[tab < 0] / DPS
    if not sat.any():
        return sat, InputRange(
            "ok: no saturation up to the largest rates tested (the range is at least these)",
            float(tested_pos.max()) if len(tested_pos) else math.nan,
            float(tested_neg.max()) if len(tested_neg) else math.nan, tolerance=tol)
    srates = sorted(set(np.round(tab[sat] / DPS, 6).tolist()))
    fol_pos = tab[(tab > 0) & ~sat] / DPS
    fol_neg = -tab[(tab < 0) & ~sat] / DPS
    rng = InputRange("saturation detected", float(fol_pos.max()) if len(fol_pos) else math.nan,
                     float(fol_neg.max()) if len(fol_neg) else math.nan, True, srates, tol)
    return sat, rng


def threshold(P_all: Points, exclude: np.ndarray, fs_dph: float, *,
              low_frac: float = 1e-3, locked: np.ndarray | None = None) -> StepResponse:
    """Threshold from the low-rate plateaus of ``P_all`` (all points, the locked ones
    included); ``exclude``: points kept out of the reference lines (saturated)."""
    tab = P_all.table if P_all.table is not None else P_all.I
    lk = locked if locked is not None else np.zeros(P_all.n, bool)
    low = (tab != 0) & ((np.abs(tab) <= low_frac * fs_dph) | lk)
    if not low.any():
        return StepResponse(f"{NOT_TESTED}: no plateau at or below {low_frac:.1%} of full "
                            f"scale ({low_frac * fs_dph / DPS:.3g} deg/s) nor in a dead band")
    steps = []
    for r in range(len(P_all.runs)):
        sel = np.flatnonzero(P_all.run == r)
        use = ~low[sel] & ~exclude[sel]
        ref = _ref_line(P_all.I[sel], P_all.y[sel], use)
        if ref is None:
            continue
        b, k = ref
        for i in sel[low[sel]]:
            got = P_all.y[i] - b
            exp = k * P_all.I[i]
            se = P_all.se[i]
            ratio = got / exp
            sig = abs(got) > 2 * se if math.isfinite(se) else True
            steps.append({"run": P_all.runs[r], "rate_dps": float(tab[i] / DPS),
                          "output_ratio": float(ratio),
                          "responds": bool(ratio >= 0.5 and sig)})
    if not steps:
        return StepResponse(f"{NOT_TESTED}: too few other rates for a reference line")
    return _bracket(steps, "rate_dps")


def resolution(P_all: Points, exclude: np.ndarray, *, max_rel: float = 0.1,
               above_dps: float = 0.0) -> StepResponse:
    """Resolution from consecutive plateaus of a run whose commands (same sign, above the
    threshold ``above_dps``) differ by at most ``max_rel`` relative."""
    tab = P_all.table if P_all.table is not None else P_all.I
    steps = []
    for r in range(len(P_all.runs)):
        sel = np.flatnonzero(P_all.run == r)
        ref = _ref_line(P_all.I[sel], P_all.y[sel], ~exclude[sel])
        if ref is None:
            continue
        k = ref[1]
        for a, c in zip(sel[:-1], sel[1:]):
            ta, tc = tab[a], tab[c]
            if ta == 0 or tc == 0 or np.sign(ta) != np.sign(tc) or ta == tc:
                continue
            if abs(tc - ta) > max_rel * min(abs(ta), abs(tc)):
                continue
            if min(abs(ta), abs(tc)) / DPS <= above_dps or exclude[a] or exclude[c]:
                continue
            dy = P_all.y[c] - P_all.y[a]
            dI = P_all.I[c] - P_all.I[a]
            se = math.hypot(P_all.se[a], P_all.se[c])
            ratio = dy / (k * dI)
            sig = abs(dy) > 2 * se if math.isfinite(se) else True
            steps.append({"run": P_all.runs[r], "base_rate_dps": float(ta / DPS),
                          "step_dps": float(abs(tc - ta) / DPS), "output_ratio": float(ratio),
                          "responds": bool(ratio >= 0.5 and sig)})
    if not steps:
        return StepResponse(f"{NOT_TESTED}: no step sequence (consecutive plateaus of one sign "
                            f"within {max_rel:.0%} of each other)")
    return _bracket(steps, "step_dps")


def _bracket(steps: list[dict], key: str) -> StepResponse:
    """Smallest input (step) above which every tried one responded, and the largest one that
    did not."""
    mags = sorted({round(abs(s[key]), 12) for s in steps})
    fails = [abs(s[key]) for s in steps if not s["responds"]]
    lower = max(fails) if fails else math.nan
    ok_above = [m for m in mags if not fails or m > lower]
    if not ok_above:
        return StepResponse(f"not reached: no tested {'rate' if key == 'rate_dps' else 'step'} "
                            f"up to {max(mags):g} deg/s produced 50 % of the expected output",
                            math.nan, lower, steps)
    return StepResponse("ok", float(min(ok_above)), lower, steps)
