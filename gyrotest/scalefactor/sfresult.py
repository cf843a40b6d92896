"""The results of a scale-factor analysis (:func:`gyrotest.scalefactor.analysis.analyse`): per
run (:class:`RunResult`), the nonlinearity model and its terms, the periodic check, the
temperature sensitivity, the lock-in, the stability, and the whole
:class:`ScaleFactorResult` with its JSON form."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .characteristics import (
    AsymmetryResult,
    LinearityStats,
)
from .lowrate import InputRange, StepResponse
from .plateaus import Plateau, RunPlateaus
from .repeatability import Repeatability
from .tablefit import (
    DPS,
    ModelFit,
    ModelStep,
)


# ----------------------------------------------------------------------------- results
@dataclass
class StabilityResult:
    """Scale-factor stability within a run (IEEE 952 §12.9.4.2.4): SF of each sweep (ppm from
    the run's SF), its 1σ and maximum spread, last − first sweep, and the drift (ppm/h) of a
    straight line through the sweep SFs vs time. The fitted nonlinearity is removed before
    each sweep's line, so sweeps over different rates compare."""

    run: str
    n_sweeps: int
    sweep_sf_ppm: list[float]
    sweep_sf_sigma_ppm: list[float]
    sweep_time_h: list[float]
    sigma_ppm: float
    max_spread_ppm: float
    last_minus_first_ppm: float
    drift_ppm_per_h: float
    drift_sigma_ppm_per_h: float

    def to_dict(self) -> dict:
        return {"run": self.run, "n_sweeps": self.n_sweeps,
                "sweep_sf_change_ppm": self.sweep_sf_ppm,
                "sweep_sf_sigma_ppm": self.sweep_sf_sigma_ppm,
                "sweep_mid_time_h": self.sweep_time_h,
                "stability_1sigma_ppm": self.sigma_ppm,
                "stability_max_spread_ppm": self.max_spread_ppm,
                "last_minus_first_sweep_ppm": self.last_minus_first_ppm,
                "drift_ppm_per_h": self.drift_ppm_per_h,
                "drift_sigma_ppm_per_h": self.drift_sigma_ppm_per_h}


@dataclass
class RunResult:
    """One run: the IEEE straight line (§12.9.4.1) and the model's linear coefficient."""

    run: str
    source: str
    method: str
    n_plateaus: int
    n_used: int
    n_sweeps: int
    earth_rate_dph: float
    temperature_mean_degC: float
    slope: float  # output per input, dimensionless (deg/h of S0·output per deg/h input)
    slope_sigma: float
    scale_factor: float
    scale_factor_sigma: float
    scale_factor_error_ppm: float  # (SF/S0 − 1)·1e6 = ε_0 of the model equation
    bias_dph: float  # input-referred b/k of the straight line (absorbs even nonlinearity)
    bias_sigma_dph: float
    chi2_per_dof: float  # of the straight line
    scale_factor_model: float
    scale_factor_model_sigma: float
    bias_model_dph: float
    bias_model_sigma_dph: float
    linearity: LinearityStats
    stability: StabilityResult | None
    sf_key: str = "dimensionless"
    bias_zero_rate_dph: float = math.nan  # IEEE §12.11.4.1.1 at the zero-rate plateaus
    bias_zero_rate_sigma_dph: float = math.nan

    def to_dict(self) -> dict:
        k = self.sf_key
        return {
            "run": self.run, "source": self.source, "plateau_method": self.method,
            "n_plateaus": self.n_plateaus, "n_points_used": self.n_used,
            "n_sweeps": self.n_sweeps, "earth_rate_ia_dph": self.earth_rate_dph,
            "temperature_mean_degC": self.temperature_mean_degC,
            f"scale_factor_{k}": self.scale_factor,
            f"scale_factor_sigma_{k}": self.scale_factor_sigma,
            "scale_factor_error_ppm": self.scale_factor_error_ppm,
            "slope_output_per_input": self.slope, "slope_sigma": self.slope_sigma,
            "slope_error_ppm": (self.slope - 1.0) * 1e6,
            "bias_dph": self.bias_model_dph, "bias_sigma_dph": self.bias_model_sigma_dph,
            "bias_line_dph": self.bias_dph, "bias_line_sigma_dph": self.bias_sigma_dph,
            "bias_zero_rate_dph": self.bias_zero_rate_dph,
            "bias_zero_rate_sigma_dph": self.bias_zero_rate_sigma_dph,
            "line_chi2_per_dof": self.chi2_per_dof,
            f"scale_factor_model_{k}": self.scale_factor_model,
            f"scale_factor_model_sigma_{k}": self.scale_factor_model_sigma,
            "linearity": self.linearity.to_dict(),
            "stability": self.stability.to_dict() if self.stability else None,
        }


@dataclass
class TermCoefficient:
    name: str
    formula: str
    output_form: str
    coef_ppm: float  # e (or amplitude for periodic)
    sigma_ppm: float
    supported: bool
    extra: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {"term": self.name, "f_of_I": self.formula, "output_term": self.output_form,
                "coefficient_ppm": self.coef_ppm, "sigma_ppm": self.sigma_ppm,
                "supported_by_data": self.supported, **self.extra}


@dataclass
class NonlinearityModel:
    """ε_K rate-dependent part f(I) (IEEE 952 §8.3): selected terms, coefficients (ppm; power
    terms at full scale), the selection history, and the residual after the model."""

    terms: list[str]
    coefficients: list[TermCoefficient]
    history: list[ModelStep]
    full_scale_dph: float
    period_dps: float | None
    chi2_per_dof: float
    residual_rms_ppm_fs: float
    statement: str
    alpha: float
    fit: ModelFit | None = None

    def f_ppm(self, I_dph) -> np.ndarray:
        """f(I) in ppm of scale factor for inputs in deg/h (0 for a straight-line model)."""
        if self.fit is None:
            return np.zeros_like(np.asarray(I_dph, float))
        return self.fit.f_ppm(I_dph)

    def to_dict(self) -> dict:
        return {"terms": self.terms, "coefficients": [c.to_dict() for c in self.coefficients],
                "full_scale_dps": self.full_scale_dph / DPS, "period_dps": self.period_dps,
                "chi2_per_dof": self.chi2_per_dof,
                "residual_rms_ppm_fs": self.residual_rms_ppm_fs,
                "selection": "lock-in (scanned) if it lowers AICc with F-test p < alpha; then the "
                             "lowest-AICc subset of asymmetry/power terms (hierarchical), terms "
                             "dropped while their F-test p (Bonferroni) >= alpha; then the "
                             "periodic term (period scanned, look-elsewhere corrected); "
                             f"alpha = {self.alpha:g}",
                "statement": self.statement,
                "history": [h.to_dict() for h in self.history],
                "f_of_I": "epsilon_K(I) = epsilon_T dT + sum(coefficient_ppm * shape), "
                          "u = I/full_scale"}


@dataclass
class PeriodicCheck:
    """Rate-periodic scale-factor error (optical feedback; IEEE 952 §5.3.2.1 a)."""

    status: str
    supported: bool = False
    period_dps: float = math.nan
    amplitude_ppm: float = math.nan
    amplitude_sigma_ppm: float = math.nan
    phase_deg: float = math.nan
    p_value: float = math.nan  # corrected for trial periods and candidates

    def to_dict(self) -> dict:
        return {"status": self.status, "supported_by_data": self.supported,
                "period_dps": self.period_dps, "amplitude_ppm": self.amplitude_ppm,
                "amplitude_sigma_ppm": self.amplitude_sigma_ppm, "phase_deg": self.phase_deg,
                "p_value_corrected": self.p_value,
                "form": "f(I) += A sin(2 pi I/P + phase), ppm of scale factor"}


@dataclass
class TemperatureSensitivity:
    """SF temperature sensitivity across runs at different temperatures (IEEE 952 §12.9.4.3.1):
    ``max change/range`` and the slope of a weighted line through (T_r, SF_r), ppm/°C of SF."""

    status: str
    t_min_degC: float = math.nan
    t_max_degC: float = math.nan
    slope_ppm_per_degC: float = math.nan
    slope_sigma_ppm_per_degC: float = math.nan
    max_change_per_range_ppm_per_degC: float = math.nan

    def to_dict(self) -> dict:
        return {"status": self.status, "t_min_degC": self.t_min_degC,
                "t_max_degC": self.t_max_degC,
                "sensitivity_ppm_per_degC": self.slope_ppm_per_degC,
                "sensitivity_sigma_ppm_per_degC": self.slope_sigma_ppm_per_degC,
                "max_change_over_range_ppm_per_degC": self.max_change_per_range_ppm_per_degC}


@dataclass
class LockIn:
    """Low-rate dead band (ring-laser lock-in): the points whose output collapsed (excluded
    from the fits) and, when the model keeps the Adler term, the fitted lock-in rate."""

    checked: bool
    detected: bool = False
    locked_rates_dps: list[float] = field(default_factory=list)
    dead_band_below_dps: float = math.nan  # largest |rate| locked
    dead_band_above_dps: float = math.nan  # smallest |rate| above it that was not locked
    fitted_dps: float = math.nan  # Ω_L of the Adler term when the model keeps it
    fitted_sigma_dps: float = math.nan

    def to_dict(self) -> dict:
        return {"checked": self.checked, "detected": self.detected,
                "locked_rates_dps": self.locked_rates_dps,
                "dead_band_at_least_dps": self.dead_band_below_dps,
                "dead_band_below_dps": self.dead_band_above_dps,
                "lock_in_rate_fitted_dps": self.fitted_dps,
                "lock_in_rate_fitted_sigma_dps": self.fitted_sigma_dps,
                "model": "Adler: output = k sgn(I) sqrt(I^2 - L^2) for |I| > L, else 0"}


@dataclass
class ScaleFactorResult:
    """Everything ``gyrotest scale-factor`` computes. ``to_dict()`` has units in key names."""

    output_kind: str
    nominal_scale_factor: float
    sf_unit: str
    sf_key: str
    full_scale_dph: float
    weighted: bool
    settings: dict
    runs: list[RunResult]
    scale_factor: float  # mean over runs (straight line)
    scale_factor_sigma: float
    scale_factor_model: float
    scale_factor_model_sigma: float
    scale_factor_error_ppm: float
    bias_dph: float
    bias_sigma_dph: float
    bias_zero_rate_dph: float
    bias_zero_rate_sigma_dph: float
    linearity: LinearityStats
    linearity_after_model: LinearityStats
    model: NonlinearityModel
    asymmetry: AsymmetryResult
    periodic: PeriodicCheck
    repeatability: Repeatability | None
    temperature: TemperatureSensitivity
    lock_in: LockIn
    points: list[Plateau]
    point_table: dict[str, np.ndarray]
    run_plateaus: list[RunPlateaus]
    notes: list[str] = field(default_factory=list)
    threshold: StepResponse | None = None
    resolution: StepResponse | None = None
    input_range: InputRange | None = None

    def to_dict(self) -> dict:
        k = self.sf_key
        pts = []
        for i, p in enumerate(self.points):
            d = p.to_dict()
            for name in ("linearity_ppm_fs", "linearity_ppm_output", "stderr_ppm_fs",
                         "model_residual_ppm_fs", "f_model_ppm"):
                d[name] = float(self.point_table[name][i])
            pts.append(d)
        return {
            "output_kind": self.output_kind,
            "scale_factor_unit": self.sf_unit,
            "scale_factor_definition": "input per unit output, S·output = input (IEEE 952 "
                                       "§8.3); fitted as S0/slope of output vs input "
                                       "(§12.9.4.1)",
            f"nominal_scale_factor_{k}": self.nominal_scale_factor,
            f"scale_factor_{k}": self.scale_factor,
            f"scale_factor_sigma_{k}": self.scale_factor_sigma,
            f"scale_factor_model_{k}": self.scale_factor_model,
            f"scale_factor_model_sigma_{k}": self.scale_factor_model_sigma,
            "scale_factor_error_ppm": self.scale_factor_error_ppm,
            "scale_factor_error_definition": "(SF/S0 - 1) * 1e6 = epsilon_0 of the model "
                                             "equation (input per output); the output-per-input "
                                             "slope error slope_error_ppm = (k - 1) * 1e6 has "
                                             "the opposite sign",
            "slope_error_ppm": float(np.mean([(r.slope - 1.0) * 1e6 for r in self.runs])),
            "bias_dph": self.bias_dph,
            "bias_sigma_dph": self.bias_sigma_dph,
            "bias_definition": "D_F = b/k from the nonlinearity model (zero-rate output, "
                               "input-referred, earth rate removed), mean over runs",
            "bias_zero_rate_dph": self.bias_zero_rate_dph,
            "bias_zero_rate_sigma_dph": self.bias_zero_rate_sigma_dph,
            "bias_zero_rate_definition": "IEEE 952 §12.11.4.1.1 at the zero-rate plateaus: "
                                         "mean of output/k - earth rate (model-free; null "
                                         "without zero-rate plateaus)",
            "full_scale_dps": self.full_scale_dph / DPS,
            "weighted_fit": self.weighted,
            "settings": self.settings,
            "runs": [r.to_dict() for r in self.runs],
            "linearity": self.linearity.to_dict(),
            "linearity_after_model": self.linearity_after_model.to_dict(),
            "nonlinearity_model": self.model.to_dict(),
            "asymmetry": self.asymmetry.to_dict(),
            "periodic": self.periodic.to_dict(),
            "repeatability": self.repeatability.to_dict() if self.repeatability else None,
            "temperature_sensitivity": self.temperature.to_dict(),
            "lock_in": self.lock_in.to_dict(),
            "epsilon_k": self.epsilon_k(),
            "plateau_extraction": [rp.to_dict() for rp in self.run_plateaus],
            "points": pts,
            "threshold": self.threshold.to_dict() if self.threshold else None,
            "resolution": self.resolution.to_dict() if self.resolution else None,
            "input_range": self.input_range.to_dict() if self.input_range else None,
            "notes": self.notes,
        }

    def epsilon_k(self) -> dict:
        """The scale-factor error terms of the IEEE 952 model equation, for the spec sheet:
        ε_K = ε_0 + ε_T·ΔT + f(I), ppm."""
        return {
            "epsilon_0_ppm": self.scale_factor_error_ppm,
            "epsilon_T_ppm_per_degC": self.temperature.slope_ppm_per_degC,
            "f_terms": [c.to_dict() for c in self.model.coefficients if c.supported],
            "full_scale_dps": self.full_scale_dph / DPS,
        }
