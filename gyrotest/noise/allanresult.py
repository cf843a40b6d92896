"""The result of an Allan analysis (:func:`gyrotest.noise.analysis.analyse_allan`): one
:class:`AxisAnalysis` per gyro or accelerometer axis (the deviation table, the noise fit, the
diagnosis, the warnings and notes) and the :class:`AllanAnalysis` of a log, with their JSON
documents (:func:`allan_document`) and units."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .devcore import DeviationResult
from .diagnose import Diagnosis
from .impact import ImpactResult
from .noisefit import (
    NoiseFit,
)
from .quantity import RATE, quantity_of
from .spectral import (
    Autocorrelation,
    CrossCorrelation,
    PsdEstimate,
    SpectralLine,
)
from .warnings import KrobkaWarning


@dataclass
class AxisAnalysis:
    """Everything computed for one rate axis of one log (see :func:`gyrotest.noise.analysis.analyse_allan`)."""

    axis: str
    input_kind: str
    input_note: str
    dev: DeviationResult
    fit_dev: DeviationResult
    edf: np.ndarray
    sigma_lo: np.ndarray
    sigma_hi: np.ndarray
    fit: NoiseFit | None
    readoffs: dict[str, Any]
    conversions: dict[str, Any]
    diagnosis: Diagnosis | None
    warnings: list[KrobkaWarning]
    impact: ImpactResult | None
    psd: PsdEstimate | None
    lines: list[SpectralLine]
    acf: Autocorrelation | None
    akdev: DeviationResult | None = None
    ohdev: DeviationResult | None = None
    detrend: dict[str, Any] | None = None
    notes: list[str] = field(default_factory=list)
    ci_conservative: dict[str, Any] | None = None
    outliers: dict[str, Any] | None = None
    #: what the warnings were computed from (to recompute them when a term's status changes)
    check_inputs: dict[str, Any] | None = field(default=None, repr=False)
    #: "rate" (a gyro axis, IEEE 952) or "acceleration" (an accelerometer axis, IEEE 1293)
    quantity: str = "rate"

    @property
    def best_fit(self) -> NoiseFit | None:
        """The diagnosed model when the diagnosis added terms, else the requested fit (None
        when no model was fitted: --no-fit, or too few τ for the terms)."""
        return self.diagnosis.final if self.diagnosis is not None else self.fit

    def table(self) -> dict[str, np.ndarray]:
        """The Stable32-like table of the requested deviation: tau, m, n, alpha, edf, sigma_lo,
        sigma, sigma_hi (Stable32's interval: the identified α and its EDF), with --ci
        conservative also alpha_ci, edf_ci, edf_ci_rule, sigma_lo_ci, sigma_hi_ci
        (:func:`gyrotest.noise.noisefit.robust_edf_rules`), plus model σ and the residual in CI
        units when the table is the fitted one."""
        d = self.dev
        out = {"tau": np.asarray(d.tau, float), "m": np.asarray(d.m), "n": np.asarray(d.n),
               "alpha": np.asarray(d.alpha), "edf": self.edf, "sigma_lo": self.sigma_lo,
               "sigma": np.asarray(d.sigma, float), "sigma_hi": self.sigma_hi}
        if self.ci_conservative is not None:
            out.update(self.ci_conservative)
        if self.dev is self.fit_dev and self.fit is not None:
            out["model"] = self.fit.model_sigma()
            out["residual_ci"] = self.fit.residuals()
            out["fitted"] = self.fit.used
        return out

    def to_dict(self) -> dict[str, Any]:
        tab = self.table()
        rows = []
        for i in range(len(tab["tau"])):
            row = {"tau": float(tab["tau"][i]), "m": int(tab["m"][i]), "n": int(tab["n"][i]),
                   "alpha": int(tab["alpha"][i]), "edf": _num(tab["edf"][i]),
                   "sigma_lo": _num(tab["sigma_lo"][i]), "sigma": _num(tab["sigma"][i]),
                   "sigma_hi": _num(tab["sigma_hi"][i])}
            if "edf_ci" in tab:
                row.update({"alpha_ci": int(tab["alpha_ci"][i]), "edf_ci": _num(tab["edf_ci"][i]),
                            "edf_ci_rule": tab["edf_ci_rule"][i],
                            "sigma_lo_ci": _num(tab["sigma_lo_ci"][i]),
                            "sigma_hi_ci": _num(tab["sigma_hi_ci"][i])})
            if "model" in tab:
                row["model"] = _num(tab["model"][i])
                row["residual_ci"] = _num(tab["residual_ci"][i])
                row["fitted"] = bool(tab["fitted"][i])
            rows.append(row)
        d = self.dev
        return {
            "axis": self.axis,
            "quantity": self.quantity,
            "sensor": quantity_of(self.quantity).sensor,
            "units": axis_units(self.quantity),
            "input_kind": self.input_kind,
            "input": self.input_note,
            "deviation": {"kind": d.kind, "unit": d.unit, "confidence": d.confidence,
                          "ci_method": d.ci_method,
                          "ci": CI_TEXT["stable32" if self.ci_conservative is None
                                        else "conservative"],
                          "fit_weights": FIT_WEIGHTS, "alpha_method": list(d.alpha_method),
                          "notes": list(d.notes)},
            "table": rows,
            "fit_deviation": self.fit_dev.kind,
            "fit": None if self.fit is None else self.fit.to_dict(),
            "slope_readoffs": self.readoffs,
            "conversions": self.conversions,
            "diagnosis": None if self.diagnosis is None else self.diagnosis.to_dict(),
            "warnings": [w.to_dict() for w in self.warnings],
            "impact": None if self.impact is None else self.impact.to_dict(),
            "psd": None if self.psd is None else self.psd.to_dict(),
            "psd_lines": [ln.to_dict() for ln in self.lines],
            "autocorrelation": None if self.acf is None else self.acf.to_dict(),
            "trend_check": {
                "akdev": None if self.akdev is None else {
                    "tau": self.akdev.tau.tolist(), "sigma": self.akdev.sigma.tolist()},
                "ohdev": None if self.ohdev is None else {
                    "tau": self.ohdev.tau.tolist(), "sigma": self.ohdev.sigma.tolist()},
            },
            "detrend": self.detrend,
            "outliers": self.outliers,
            "notes": list(self.notes),
        }


def _num(v) -> float | None:
    v = float(v)
    return v if math.isfinite(v) else None


def axis_units(quantity: str) -> dict[str, str]:
    """The units of an axis' numbers in JSON (gyro: IEEE 952; accelerometer: IEEE 1293)."""
    q = quantity_of(quantity)
    out = {"sigma": q.sigma_unit, "tau": "s"}
    for params in q.units.values():
        out.update(params)
    if q is RATE:
        out["attitude"] = "deg"
    return out


@dataclass
class AllanAnalysis:
    """The Allan analysis of one log: settings, one :class:`AxisAnalysis` per rate axis, the
    cross-correlation of the axes (multi-axis logs) and notes."""

    source: str
    tau0: float
    n_samples: int
    duration_s: float
    settings: dict[str, Any]
    axes: list[AxisAnalysis]
    cross: CrossCorrelation | None
    notes: list[str] = field(default_factory=list)

    def axis(self, name: str | None = None) -> AxisAnalysis:
        if name is None:
            return self.axes[0]
        for a in self.axes:
            if a.axis == name:
                return a
        raise KeyError(name)

    @property
    def warnings(self) -> list[KrobkaWarning]:
        return [w for a in self.axes for w in a.warnings]

    def to_dict(self) -> dict[str, Any]:
        return {
            "source": self.source,
            "tau0_s": self.tau0,
            "sample_rate_hz": 1.0 / self.tau0,
            "n_samples": self.n_samples,
            "duration_s": self.duration_s,
            "settings": self.settings,
            "units": axis_units("rate"),
            **({"accelerometer_units": axis_units("acceleration")}
               if any(a.quantity == "acceleration" for a in self.axes) else {}),
            "axes": [a.to_dict() for a in self.axes],
            "cross_correlation": None if self.cross is None else self.cross.to_dict(),
            "notes": list(self.notes),
        }


def allan_document(results: Sequence[AllanAnalysis], *, csv: str | None = None,
                   plot: str | None = None, psd: str | None = None) -> dict[str, Any]:
    """The JSON document of ``gyrotest allan --json``: every log's analysis and the files
    written."""
    return {"analysis": "allan", "logs": [r.to_dict() for r in results],
            "files": {"csv": csv, "plot": plot, "psd": psd}}


#: what the interval columns mean (``--ci``)
CI_TEXT = {
    "stable32": "Stable32's: χ² interval from the EDF of the noise type identified at that τ "
                "(the alpha column), no capping",
    "conservative": "Stable32's in sigma_lo/sigma_hi; sigma_lo_ci/sigma_hi_ci from the fit's "
                    "EDF: noise type from the B1 ratio at the number of averages, EDF capped "
                    "at the white-rate value where α > 0 came from few averages and made "
                    "non-increasing in τ (alpha_ci/edf_ci)",
}


#: how the fit weights the τ (always the conservative EDF), stated with every fit
FIT_WEIGHTS = ("the fit weights each σ̂²(τ) by a χ² likelihood with its own conservative EDF: "
               "the noise type from the B1 ratio at the number of averages (Barnes 1969) where "
               "Stable32's rule differs, the EDF capped at the white-rate value where α > 0 "
               "came from few averages, non-increasing in τ; the table's α and interval are "
               "Stable32's")
