"""Scale-factor repeatability per test condition (IEEE 952 §12.9.4.2.3 and §5.3.2.1 c) kept
apart from the temperature sensitivity ε_T (§12.9.4.3.1, §5.3.2.2 a).

Repeatability is the run-to-run change of the scale factor *under the same conditions* (power
off/on between runs, same temperature). Runs at different temperatures differ by ε_T·ΔT as
well, so pooling them mixes two specifications (0.8 ppm/°C × 23 °C is 18 ppm, twice a typical
power-cycle repeatability). :func:`repeatability_by_condition`:

* groups the runs by their mean temperature (single linkage: a run within ``tol_degC`` of the
  next joins its group) and, when the logs carry a power-on label (a constant ``power_on``
  column, see :func:`power_on_label`), tells power-cycle groups from runs within one power-on;
* in each group of ≥ 2 runs: 1σ (ddof = 1) and max spread of the run SFs, ppm of the group
  mean, and the uncertainty of that 1σ from the runs' own SF uncertainties,
  σ(s) = √(Σ (∂s/∂x_i)² σ_i²), ∂s/∂x_i = (x_i − x̄)/((n − 1)·s) (floored at the RMS of σ_i
  when s is no larger than the noise);
* the repeatability is the pooled within-group 1σ, √(Σ (n_g − 1)·s_g² / Σ (n_g − 1)), and the
  largest within-group spread; None when no two runs share a condition (the spread of all
  runs is then reported with a note, never as the repeatability).

Units: ppm of scale factor, temperatures degC.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

POWER_ON_COLUMNS = ("power_on", "power_cycle", "power_on_id", "session")


def power_on_label(log) -> str | None:
    """Power-on label of a run: the value of a ``power_on``/``power_cycle``/``session``
    column of the log (constant over the run; its first value), or ``log.meta["power_on"]``.
    None when the log says nothing."""
    meta = getattr(log, "meta", {}) or {}
    if meta.get("power_on") is not None:
        return str(meta["power_on"])
    extra = getattr(log, "extra", {}) or {}
    for k, v in extra.items():
        if k.lower() in POWER_ON_COLUMNS and len(v):
            return str(v[0])
    return None


def group_by_temperature(temps_degC, tol_degC: float = 2.0) -> list[int]:
    """Group index of each run: sorted mean temperatures, a new group where the gap to the
    previous run exceeds ``tol_degC``; runs without a temperature form one group of their own."""
    t = np.asarray(temps_degC, float)
    grp = [-1] * len(t)
    order = [i for i in np.argsort(t) if np.isfinite(t[i])]
    g, prev = -1, math.nan
    for i in order:
        if not math.isfinite(prev) or t[i] - prev > tol_degC:
            g += 1
        grp[i] = g
        prev = t[i]
    if any(x == -1 for x in grp):
        g += 1
        grp = [g if x == -1 else x for x in grp]
    return grp


def spread_stats(x_ppm, s_ppm) -> tuple[float, float, float]:
    """(1σ ddof = 1, its uncertainty from the per-run σ, max spread), ppm, of values x_ppm
    with 1σ uncertainties s_ppm; NaNs for fewer than two values."""
    x = np.asarray(x_ppm, float)
    s = np.asarray(s_ppm, float)
    n = len(x)
    if n < 2:
        return math.nan, math.nan, math.nan
    sd = float(np.std(x, ddof=1))
    rms = float(np.sqrt(np.mean(s ** 2))) if np.all(np.isfinite(s)) else math.nan
    if sd > 0 and math.isfinite(rms):
        g = (x - x.mean()) / ((n - 1) * sd)
        unc = float(np.sqrt(np.sum((g * s) ** 2)))
        if sd <= rms:
            unc = max(unc, rms)
    else:
        unc = rms
    return sd, unc, float(np.ptp(x))


@dataclass
class RepeatGroup:
    """Runs under one condition (temperature, and power-on when the logs say)."""

    temperature_degC: float
    runs: list[str]
    kind: str  # "power cycles", "within one power-on", "power cycles (assumed)", "single run"
    sigma_ppm: float = math.nan
    sigma_uncertainty_ppm: float = math.nan
    max_spread_ppm: float = math.nan
    run_sf_ppm: list[float] = field(default_factory=list)  # SF − group mean, ppm

    def to_dict(self) -> dict:
        return {"temperature_degC": self.temperature_degC, "runs": self.runs,
                "n_runs": len(self.runs), "kind": self.kind,
                "repeatability_1sigma_ppm": self.sigma_ppm,
                "repeatability_1sigma_uncertainty_ppm": self.sigma_uncertainty_ppm,
                "repeatability_max_spread_ppm": self.max_spread_ppm,
                "run_sf_change_ppm": self.run_sf_ppm}


def repeatability_by_condition(names: list[str], sf, sf_sigma, temps_degC,
                               power_on: list[str | None] | None = None, *,
                               tol_degC: float = 2.0
                               ) -> tuple[list[RepeatGroup], float, float, float, list[str]]:
    """Group the runs (see module doc) and return (groups, pooled within-group 1σ, its
    uncertainty, largest within-group spread, notes), ppm. ``sf``/``sf_sigma``: the runs'
    scale factors and 1σ (any unit, same for all)."""
    sf = np.asarray(sf, float)
    ss = np.asarray(sf_sigma, float)
    temps = np.asarray(temps_degC, float)
    po = list(power_on) if power_on is not None else [None] * len(sf)
    tg = group_by_temperature(temps, tol_degC)
    groups: list[RepeatGroup] = []
    notes: list[str] = []
    for g in sorted(set(tg)):
        idx = [i for i in range(len(sf)) if tg[i] == g]
        # within a temperature: one sub-group per power-on label when the logs give them and
        # some runs share one; otherwise every run is its own power-on
        labels = [po[i] for i in idx]
        subsets = [idx]
        kind = "power cycles (assumed)"
        if all(lb is not None for lb in labels):
            if len(set(labels)) == len(labels):
                kind = "power cycles"
            else:
                kind = "within one power-on"
                subsets = [[i for i in idx if po[i] == lb] for lb in dict.fromkeys(labels)]
                if len(set(labels)) > 1:
                    notes.append(f"runs {', '.join(names[i] for i in idx)} at one temperature "
                                 "span several power-ons: repeatability within each power-on; "
                                 "reduce one run per power-on for the power-cycle figure")
        for sub in subsets:
            t_mean = (float(np.nanmean(temps[sub])) if np.any(np.isfinite(temps[sub]))
                      else math.nan)
            x = (sf[sub] / np.mean(sf[sub]) - 1) * 1e6
            s = ss[sub] / np.mean(sf[sub]) * 1e6
            sd, unc, sp = spread_stats(x, s)
            groups.append(RepeatGroup(t_mean, [names[i] for i in sub],
                                      kind if len(sub) > 1 else "single run", sd, unc, sp,
                                      x.tolist()))
    multi = [g for g in groups if len(g.runs) > 1]
    if multi:
        dof = np.array([len(g.runs) - 1 for g in multi], float)
        pooled = float(math.sqrt(np.sum(dof * np.array([g.sigma_ppm for g in multi]) ** 2)
                                 / dof.sum()))
        # d pooled / d s_g = dof_g s_g / (Σ dof · pooled)
        unc = (float(math.sqrt(np.sum((dof * np.array([g.sigma_ppm for g in multi])
                                       * np.array([g.sigma_uncertainty_ppm for g in multi])
                                       / (dof.sum() * pooled)) ** 2)))
               if pooled > 0 else float(np.nanmax([g.sigma_uncertainty_ppm for g in multi])))
        spread = float(max(g.max_spread_ppm for g in multi))
    else:
        pooled = unc = spread = math.nan
    ok_t = temps[np.isfinite(temps)]
    if len(ok_t) >= 2 and np.ptp(ok_t) > tol_degC:
        if multi:
            notes.append(f"runs at {len({round(g.temperature_degC, 1) for g in groups})} "
                         f"temperatures ({np.min(ok_t):.3g}…{np.max(ok_t):.3g} °C): "
                         "repeatability within each temperature; the change across "
                         "temperatures is ε_T (temperature sensitivity), not repeatability")
        else:
            notes.append(f"every run at a different temperature ({np.min(ok_t):.3g}…"
                         f"{np.max(ok_t):.3g} °C): repeatability not measured (no two runs "
                         "share a condition); the spread of all runs is mostly ε_T·ΔT")
    return groups, pooled, unc, spread, notes


@dataclass
class Repeatability:
    """Run-to-run scale factor (IEEE 952 §12.9.4.2.3, §5.3.2.1 c) per condition
    (:mod:`.repeatability`): the repeatability is the pooled 1σ (ddof=1) and the largest
    spread *within* groups of runs at one temperature (NaN when no two runs share one); the
    spread of all runs is kept beside it (``all_runs_*``), labelled as such."""

    n_runs: int
    sigma_ppm: float  # within-condition (pooled over temperature groups)
    max_spread_ppm: float
    run_sf_ppm: list[float]  # each run's SF − mean of all runs, ppm
    sigma_model_ppm: float  # all runs, model SF
    sigma_uncertainty_ppm: float = math.nan  # measurement uncertainty of sigma_ppm
    all_runs_sigma_ppm: float = math.nan
    all_runs_max_spread_ppm: float = math.nan
    groups: list[RepeatGroup] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    def to_dict(self) -> dict:
        return {"n_runs": self.n_runs, "repeatability_1sigma_ppm": self.sigma_ppm,
                "repeatability_1sigma_uncertainty_ppm": self.sigma_uncertainty_ppm,
                "repeatability_max_spread_ppm": self.max_spread_ppm,
                "definition": "pooled 1 sigma (ddof=1) and largest max-min spread of the run "
                              "scale factors within groups of runs at one temperature (power "
                              "cycles between them); null when no two runs share a temperature",
                "groups": [g.to_dict() for g in self.groups],
                "all_runs_1sigma_ppm": self.all_runs_sigma_ppm,
                "all_runs_max_spread_ppm": self.all_runs_max_spread_ppm,
                "run_sf_change_ppm": self.run_sf_ppm,
                "repeatability_model_1sigma_ppm": self.sigma_model_ppm,
                "notes": self.notes}
