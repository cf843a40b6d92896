"""The lot: per-campaign results, grouping by serial, lot statistics and robust outliers.

Each campaign is analysed exactly as ``gyrotest report`` does (:func:`analyse_campaign`: the
same analyses, the same spec items, limits and decision rule) and reduced to a plain,
picklable record, so that the per-campaign work can run in a process pool or on Dask
workers and the lot summary (:func:`summarise`) is computed once, in the caller, from the
records -- the result does not depend on where the work ran.

Campaigns are grouped by (gyro model, serial). The latest test of each serial (by the
campaign date; on the same date the one given last) is its entry in the lot; earlier ones are
kept as that serial's earlier acceptance tests and charted against.
"""

from __future__ import annotations

import math
import re
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

#: modified z-score threshold of Iglewicz & Hoaglin (1993) for large samples
OUTLIER_Z = 3.5
#: fewest lot members with a value before outliers are flagged
OUTLIER_MIN_N = 5
#: lot-wise false-alarm rate per spec item the thresholds are set for
OUTLIER_ALPHA = 0.01
#: threshold on max |M| such that a lot of n normal values has a flag with probability
#: OUTLIER_ALPHA (Monte Carlo, 200 000 lots per n, seed 1; benchmarks/fleet_outliers.py
#: rebuilds and checks it on other seeds). The MAD of a few values is itself very uncertain,
#: so small lots need a much larger |M| than 3.5 before a value is called an outlier.
OUTLIER_THRESHOLDS = {5: 18.72, 6: 9.94, 7: 10.72, 8: 7.91, 9: 8.19, 10: 6.83, 12: 6.3,
                      15: 5.99, 20: 5.21, 25: 4.99, 30: 4.77, 40: 4.59, 50: 4.48}

#: sheet items that state a setting, not a measurement (left out of the lot summary)
SETTINGS = {"scale_factor.nominal", "scale_factor.full_scale"}

_SHEET_LOCK = threading.Lock()  # the sheet layout keeps per-sheet state in class attributes


def modified_z_scores(x: np.ndarray) -> np.ndarray:
    r"""Robust z-scores of the values ``x`` of one spec item over the lot.

    .. math:: M_i = 0.6745\,(x_i - \tilde{x}) / \mathrm{MAD}, \qquad
              \mathrm{MAD} = \mathrm{median}_i |x_i - \tilde{x}|

    with :math:`\tilde{x}` the median (0.6745 = Φ⁻¹(0.75) makes MAD/0.6745 a consistent
    estimate of σ for normal data). When MAD = 0 (more than half the values equal) the mean
    absolute deviation from the median is used, :math:`M_i = (x_i - \tilde{x}) / (1.253314\,
    \mathrm{MeanAD})`; when that is 0 too, every score is 0. Iglewicz and Hoaglin call a value
    with :math:`|M_i| > 3.5` a potential outlier; for the small lots here the threshold grows
    with 1/n (:func:`outlier_threshold`).

    Units: dimensionless (``x`` in any unit). Source: B. Iglewicz and D. C. Hoaglin, *How to
    Detect and Handle Outliers*, ASQC Basic References in Quality Control vol. 16, ASQC
    Quality Press, 1993, §3.
    """
    x = np.asarray(x, dtype=float)
    if x.size == 0:
        return x
    med = float(np.median(x))
    dev = x - med
    mad = float(np.median(np.abs(dev)))
    if mad > 0:
        return 0.6745 * dev / mad
    mean_ad = float(np.mean(np.abs(dev)))
    if mean_ad > 0:
        return dev / (1.253314 * mean_ad)
    return np.zeros_like(x)


def outlier_threshold(n: int) -> float:
    """The |M| above which a value of a lot of ``n`` is flagged (:data:`OUTLIER_THRESHOLDS`;
    linear in n between tabulated sizes; beyond 50 shifted along the normal quantile
    Φ⁻¹(1 − α/(2n)); never below :data:`OUTLIER_Z`); inf below :data:`OUTLIER_MIN_N`."""
    from scipy.stats import norm

    if n < OUTLIER_MIN_N:
        return math.inf
    ns = sorted(OUTLIER_THRESHOLDS)
    if n in OUTLIER_THRESHOLDS:
        c = OUTLIER_THRESHOLDS[n]
    elif n > ns[-1]:
        q = norm.isf
        c = OUTLIER_THRESHOLDS[ns[-1]] + q(OUTLIER_ALPHA / (2 * n)) - q(OUTLIER_ALPHA
                                                                        / (2 * ns[-1]))
    else:
        lo = max(k for k in ns if k < n)
        hi = min(k for k in ns if k > n)
        w = (n - lo) / (hi - lo)
        c = (1 - w) * OUTLIER_THRESHOLDS[lo] + w * OUTLIER_THRESHOLDS[hi]
    return max(float(c), OUTLIER_Z)


def flag_outliers(x) -> tuple[np.ndarray, np.ndarray]:
    """(modified z-scores, flags) of one spec item over a lot: flagged where
    |M| > :func:`outlier_threshold` (n); nothing is flagged when the robust spread is
    below 1e-9 of the median (values equal up to rounding)."""
    x = np.asarray(x, dtype=float)
    z = modified_z_scores(x)
    rs = robust_sigma(x) if x.size else 0.0
    if not x.size or not rs > 1e-9 * abs(float(np.median(x))):
        return z, np.zeros(x.size, dtype=bool)
    return z, np.abs(z) > outlier_threshold(int(x.size))


def robust_sigma(x: np.ndarray) -> float:
    """MAD/0.6745 (the σ the modified z-score divides by; 1.253314·MeanAD when MAD = 0)."""
    x = np.asarray(x, dtype=float)
    if x.size == 0:
        return float("nan")
    dev = np.abs(x - np.median(x))
    mad = float(np.median(dev))
    return mad / 0.6745 if mad > 0 else 1.253314 * float(np.mean(dev))


# ----------------------------------------------------------------------------- one campaign
def analyse_campaign(path: str) -> dict[str, Any]:
    """Run one campaign as ``gyrotest report`` does (no figures) and return its record: the
    identity (model, serial, date, report id, campaign SHA-256), the overall verdict and every
    spec item (value, 1σ, expanded uncertainty, limit, verdict). A bad campaign or log gives
    ``{"campaign": path, "error": message}`` (the caller raises it, naming the file)."""
    from ..core.errors import GyrotestError
    from ..specsheet.build import build_sheet, run_campaign
    from ..specsheet.campaign import load_campaign

    t0 = time.perf_counter()
    try:
        camp = load_campaign(path)
        an = run_campaign(camp)
        with _SHEET_LOCK:
            sheet = build_sheet(camp, an, figures=False)
    except GyrotestError as e:
        return {"campaign": str(path), "error": str(e)}
    items = []
    for c in sheet.checks:
        m = c.measured
        value = m.value if m is not None else None
        if value is not None and not math.isfinite(value):
            value = None
        items.append({
            "key": c.key, "item": re.sub(r" ± U \(k = [0-9.]+\)", "", c.label),
            "ieee": c.ieee, "unit": c.unit, "limit": c.limit,
            "value": value, "sigma": m.sigma if m is not None else None,
            "expanded_uncertainty": c.expanded_uncertainty,
            "bound": bool(m.bound) if m is not None else False, "verdict": c.verdict})
    return {
        "campaign": str(path), "file": Path(path).name, "sha256": camp.sha256,
        "model": str(camp.gyro.get("model", "")), "serial": str(camp.gyro.get("serial", "")),
        "date": str(camp.meta.get("date", "")), "report_id": str(camp.meta.get("report_id", "")),
        "decision_rule": sheet.checks[0].rule if sheet.checks else "",
        "coverage_factor": sheet.checks[0].k if sheet.checks else 2.0, "overall": sheet.overall(), "items": items,
        "seconds": time.perf_counter() - t0}


# ----------------------------------------------------------------------------- the lot
@dataclass
class ItemStats:
    """One spec item over the lot (the latest test of each serial)."""

    key: str
    item: str
    unit: str
    limit: float | None
    n: int = 0
    n_bounds: int = 0
    mean: float | None = None
    std: float | None = None
    min: float | None = None
    max: float | None = None
    median: float | None = None
    robust_sigma: float | None = None
    verdicts: dict[str, int] = field(default_factory=dict)
    z: dict[str, float] = field(default_factory=dict)  # serial -> modified z-score
    outliers: list[str] = field(default_factory=list)  # serials
    threshold: float = math.inf  # |M| above which a serial is flagged (n-dependent)

    def to_dict(self) -> dict[str, Any]:
        """JSON form (``_`` + unit spelled out in ``unit``)."""
        return {"key": self.key, "item": self.item, "unit": self.unit, "limit": self.limit,
                "n": self.n, "n_upper_bounds": self.n_bounds, "mean": self.mean,
                "std": self.std, "min": self.min, "max": self.max, "median": self.median,
                "robust_sigma": self.robust_sigma, "verdicts": self.verdicts,
                "modified_z": self.z,
                "outlier_threshold": self.threshold if math.isfinite(self.threshold) else None,
                "outliers": self.outliers}


@dataclass
class Fleet:
    """The lot summary: records per campaign, the lot (latest test per serial), earlier
    tests, statistics and outliers per spec item."""

    records: list[dict[str, Any]]
    lot: list[dict[str, Any]]
    earlier: dict[str, list[dict[str, Any]]]  # serial -> earlier records (oldest first)
    stats: list[ItemStats]
    run: dict[str, Any] = field(default_factory=dict)  # how it ran: jobs, scheduler, seconds

    @property
    def model(self) -> str:
        """Gyro model(s) of the lot."""
        return ", ".join(sorted({r["model"] for r in self.lot}))

    def item(self, rec: dict[str, Any], key: str) -> dict[str, Any] | None:
        """The spec item ``key`` of one record."""
        return next((i for i in rec["items"] if i["key"] == key), None)

    def overall(self) -> str:
        """Worst overall verdict over the lot."""
        from ..specsheet.sheet import NO_LIMIT, SEVERITY

        v = {r["overall"] for r in self.lot}
        return next((s for s in SEVERITY if s in v), NO_LIMIT)

    def outliers(self) -> list[dict[str, Any]]:
        """Every flagged (item, serial) with its value, the lot median and the z-score."""
        out = []
        for s in self.stats:
            for serial in s.outliers:
                rec = next(r for r in self.lot if r["serial"] == serial)
                it = self.item(rec, s.key)
                out.append({"key": s.key, "item": s.item, "unit": s.unit, "serial": serial,
                            "value": it["value"] if it else None, "median": s.median,
                            "robust_sigma": s.robust_sigma, "modified_z": s.z[serial],
                            "threshold": s.threshold})
        return out

    def to_dict(self, timing: bool = True) -> dict[str, Any]:
        """JSON form; ``timing=False`` leaves out the run times (for comparing runs)."""
        recs = [dict(r) for r in self.records]
        if not timing:
            for r in recs:
                r.pop("seconds", None)
        d = {"format": "gyrotest-fleet", "version": 1, "model": self.model,
             "serials": [r["serial"] for r in self.lot], "overall_verdict": self.overall(),
             "outlier_rule": {"statistic": "modified z-score (Iglewicz & Hoaglin 1993)",
                              "false_alarm_per_item_and_lot": OUTLIER_ALPHA,
                              "min_serials": OUTLIER_MIN_N},
             "items": [s.to_dict() for s in self.stats], "outliers": self.outliers(),
             "lot": [r["campaign"] for r in self.lot],
             "earlier_tests": {k: [r["campaign"] for r in v] for k, v in self.earlier.items()},
             "campaigns": recs}
        if timing:
            d["run"] = self.run
        return d


def _serial_key(s: str) -> tuple:
    return (0, int(s), s) if s.isdigit() else (1, 0, s)


def summarise(records: list[dict[str, Any]]) -> Fleet:
    """The lot summary from the campaign records (in the order the campaigns were given)."""
    by_serial: dict[tuple[str, str], list[tuple[int, dict]]] = {}
    for i, r in enumerate(records):
        by_serial.setdefault((r["model"], r["serial"]), []).append((i, r))
    lot, earlier = [], {}
    for (_, serial), recs in by_serial.items():
        recs.sort(key=lambda ir: (ir[1]["date"], ir[0]))
        lot.append(recs[-1][1])
        if len(recs) > 1:
            earlier[serial] = [r for _, r in recs[:-1]]
    lot.sort(key=lambda r: (_serial_key(r["serial"]), r["model"]))
    keys: dict[str, dict[str, Any]] = {}
    for r in lot:
        for it in r["items"]:
            if it["key"] in SETTINGS:
                continue
            if it["value"] is not None and it["key"] not in keys:
                keys[it["key"]] = it
    stats = []
    for key, first in keys.items():
        limits = {it["limit"] for r in lot for it in r["items"] if it["key"] == key}
        limits.discard(None)
        s = ItemStats(key, first["item"], first["unit"],
                      limits.pop() if len(limits) == 1 else None)
        vals, serials = [], []
        for r in lot:
            it = next((i for i in r["items"] if i["key"] == key), None)
            if it is None:
                continue
            s.verdicts[it["verdict"]] = s.verdicts.get(it["verdict"], 0) + 1
            if it["value"] is None:
                continue
            vals.append(float(it["value"]))
            serials.append(r["serial"])
            s.n_bounds += bool(it["bound"])
        x = np.asarray(vals)
        s.n = int(x.size)
        s.mean, s.min, s.max = float(x.mean()), float(x.min()), float(x.max())
        s.median = float(np.median(x))
        s.std = float(x.std(ddof=1)) if x.size > 1 else None
        s.robust_sigma = robust_sigma(x)
        z, flag = flag_outliers(x)
        s.z = {sn: float(zz) for sn, zz in zip(serials, z)}
        s.threshold = outlier_threshold(s.n)
        s.outliers = [sn for sn, f in zip(serials, flag) if f]
        stats.append(s)
    return Fleet(records, lot, earlier, stats)
