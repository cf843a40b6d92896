"""Domain fits on top of the model workbench: the Antonova–Matveev thermal model (continuous
chamber runs or a table of steady-state set-points) and the magnetic sensitivities w_x, w_y, w_z
(Helmholtz-coil sequences or a continuous magnetometer log).

Source: M.V. Antonova, V.A. Matveev, "Model of error of a fiber-optic gyro exposed to thermal
and magnetic fields" :

* thermal: Δω(t) = w0 + w1·ΔT + w2·ΔT² + w_ΔV·dT/dt, ΔT = T − t0 (t0 = 21 °C in their lab),
  dT/dt in °C/h; w0 deg/h, w1 deg/(h·°C), w2 deg/(h·°C²), w_ΔV deg/°C = (deg/h)/(°C/h);
  IEEE 952 §8.3 names the same terms D_T and D_Ṫ and adds D_∇Ṫ·d(T_a − T_b)/dt;
* magnetic: Δω(H) = w0 + w_x·Hx/H0 + w_y·Hy/H0 + w_z·Hz/H0, H0 = 100 µT, coefficients in
  deg/h per 100 µT; Helmholtz test 0 → +300 → −300 → 0 µT in 50 µT steps, 180 s per level,
  one axis at a time; quick reversal estimate K = |Δω(+300) − Δω(−300)|/6.

:func:`analyse_thermal` and :func:`analyse_mag` are the whole analyses of ``gyrotest
thermal-fit`` and ``gyrotest mag-fit`` (and of the spec-sheet report's thermal and magnetic
sections): a loaded log and the command's options in, the result out.
"""

from __future__ import annotations

import csv
import io
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..core.errors import AnalysisError, InputError
from . import stats as st
from .modelfit import FitResult, WorkData, fit_model, predict_blocks
from .pipeline import prepare_log
from .terms import H0_UT, TermSpec, parse_terms, split_terms, temperature_rate

#: the paper's published coefficients for its FOG sample (GYRO_REFERENCE §6)
ANTONOVA_MATVEEV_PAPER = {"w0": 1.197, "w1": -0.108, "w2": 0.004, "w_dV": 1.997, "t0_c": 21.0}
#: the paper's steady-state set-point table (thermostat °C, Δω deg/h, σ deg/h)
ANTONOVA_MATVEEV_SETPOINTS = [(31, 0.489, 0.081), (35, 0.346, 0.051), (40, 0.498, 0.051),
                              (45, 0.540, 0.043), (50, 0.919, 0.043), (55, 1.564, 0.019)]

AM_UNITS = {"w0": "deg/h", "w1": "deg/(h·degC)", "w2": "deg/(h·degC^2)",
            "w_dV": "deg/degC = (deg/h)/(degC/h)"}


@dataclass
class Coef:
    """A named coefficient with unit and 1σ."""

    name: str
    value: float
    stderr: float
    unit: str

    def to_dict(self) -> dict:
        return {"name": self.name, "value": self.value, "stderr": self.stderr, "unit": self.unit}


# ============================================================================ thermal
@dataclass
class ThermalResult:
    """Antonova–Matveev and IEEE E-term fits of a continuous chamber run."""

    t0_c: float
    sensor: str
    am: FitResult
    ieee: FitResult | None
    coefficients: list[Coef]
    ieee_coefficients: list[Coef]
    hysteresis: dict[str, Any]
    notes: list[str] = field(default_factory=list)

    def coef(self, name: str) -> Coef:
        for c in self.coefficients + self.ieee_coefficients:
            if c.name == name:
                return c
        raise KeyError(name)

    def to_dict(self) -> dict:
        return {"model": "Antonova-Matveev: dw = w0 + w1*dT + w2*dT^2 + w_dV*dT/dt",
                "t0_degC": self.t0_c, "sensor": self.sensor,
                "coefficients": [c.to_dict() for c in self.coefficients],
                "ieee_E_terms": [c.to_dict() for c in self.ieee_coefficients],
                "hysteresis": self.hysteresis, "notes": self.notes,
                "fit": {"rms_fit_dph": self.am.rms_fit, "rms_holdout_dph": self.am.rms_holdout,
                        "noise_floor_dph": self.am.floor.rms_dph if self.am.floor else None,
                        "resolution_s": self.am.resolution_s,
                        "resolution_note": self.am.resolution_note},
                "am_fit": self.am.to_dict(),
                "ieee_fit": self.ieee.to_dict() if self.ieee else None}


def _c(res: FitResult, label: str, name: str, unit: str) -> Coef:
    c = res.coef(label)
    return Coef(name, c.value, c.stderr, unit)


def thermal_fit(wd: WorkData, *, sensor: str | None = None,
                gradient: tuple[str, str] | None = None, folds: int = 5) -> ThermalResult:
    """Fit Δω = w0 + w1·ΔT + w2·ΔT² + w_ΔV·dT/dt (ΔT from the reference temperature of
    ``wd``, i.e. t0) to a continuous chamber run, and the IEEE E terms D_T, D_Ṫ (the same
    numbers) plus D_∇Ṫ when a second temperature channel exists. Without ``sensor``, the
    temperature channel whose model predicts held-out data best is used (the paper's model is
    in the ambient temperature; a lagging coil sensor fits worse).

    Returns coefficients in the paper's units with 1σ (GLS under the noise model), the fits, and a heating/cooling
    hysteresis check of the residual (mean residual on heating minus cooling branches).
    Source: Antonova & Matveev eq. (3); IEEE 952 §8.3.
    """
    temps = list(wd.frame.temperature)
    if not temps:
        raise InputError(f"{wd.info.get('source')}: thermal-fit needs a temperature channel; "
                         "name it with --temp-col")
    notes = []
    if sensor is None:
        if len(temps) == 1:
            sensor = temps[0]
        else:  # the sensor that sees the temperature driving the drift fits best
            scores = {}
            for c in temps:
                try:
                    r = fit_model(wd, [f"T({c})", f"T2({c})", f"dTdt({c})"], folds=folds,
                                  light=True)
                    scores[c] = r.rms_holdout
                except (InputError, AnalysisError):
                    continue
            if not scores:
                raise InputError(f"{wd.info.get('source')}: no usable temperature channel")
            sensor = min(scores, key=scores.get)
            notes.append("sensor chosen by held-out RMS: " + ", ".join(
                f"{c} {v:.4g} deg/h" for c, v in sorted(scores.items(), key=lambda x: x[1])))
    if sensor not in temps:
        raise InputError(f"{wd.info.get('source')}: no temperature channel {sensor!r} "
                         f"(temperature channels: {', '.join(temps)})")
    t0 = wd.refs.t_ref_c.get(sensor, 21.0)
    s = f"({sensor})"
    am = fit_model(wd, [f"T{s}", f"T2{s}", f"dTdt{s}"], folds=folds)
    coefs = [_c(am, "bias", "w0", AM_UNITS["w0"]), _c(am, f"T{s}", "w1", AM_UNITS["w1"]),
             _c(am, f"T2{s}", "w2", AM_UNITS["w2"]), _c(am, f"dTdt{s}", "w_dV", AM_UNITS["w_dV"])]
    ieee = None
    ieee_c = [Coef("D_T", coefs[1].value, coefs[1].stderr, "(deg/h)/degC"),
              Coef("D_Tdot", coefs[3].value, coefs[3].stderr, "(deg/h)/(degC/h)")]
    if gradient is None and len(temps) >= 2:
        other = next((c for c in temps if c != sensor and np.ptp(
            wd.frame.temperature[c] - wd.frame.temperature[sensor]) > 1e-6), None)
        gradient = (sensor, other) if other else None
    if gradient is not None:
        a, b = gradient
        for c in (a, b):
            if c not in temps:
                raise InputError(f"--gradient: no temperature channel {c!r} (temperature "
                                 f"channels: {', '.join(temps)})")
        g = f"dGdt({a},{b})"
        try:
            ieee = fit_model(wd, [f"T{s}", f"T2{s}", f"dTdt{s}", g], folds=folds)
            ieee_c = [_c(ieee, f"T{s}", "D_T", "(deg/h)/degC"),
                      _c(ieee, f"dTdt{s}", "D_Tdot", "(deg/h)/(degC/h)"),
                      _c(ieee, g, "D_gradTdot", "(deg/h)/(degC/h)")]
        except (InputError, AnalysisError) as e:
            notes.append(f"D_gradTdot not fitted: {e}")
    else:
        notes.append("one temperature channel: D_gradTdot (gradient rate) needs two")
    hyst = hysteresis_check(am, sensor)
    return ThermalResult(t0, sensor, am, ieee, coefs, ieee_c, hyst, notes)


def hysteresis_check(res: FitResult, sensor: str) -> dict:
    """Heating-vs-cooling offset of a fit's residual: mean residual on blocks where the
    smoothed dT/dt > +θ minus where it is < −θ (θ = the model's hysteresis threshold), with a
    1σ from the residual's integrated autocorrelation time (independent-equivalent counts).
    """
    wd = res.wd
    rate = wd.bmean(temperature_rate(wd.frame.temperature[sensor], wd.frame.dt,
                                     wd.refs.smoothing_s, wd.frame.bounds))
    thr = max(0.5, wd.refs.hyst_threshold_c_per_h.get(sensor, 0.5))
    r = res.resid
    heat, cool = rate > thr, rate < -thr
    out: dict[str, Any] = {"threshold_degC_per_h": thr, "heating_blocks": int(heat.sum()),
                           "cooling_blocks": int(cool.sum())}
    if heat.sum() < 3 or cool.sum() < 3:
        out["note"] = "needs both heating and cooling stretches"
        return out
    tau = st.integrated_time(r)
    d = float(r[heat].mean() - r[cool].mean())
    se = float(np.std(r) * math.sqrt(tau / heat.sum() + tau / cool.sum()))
    out.update({"heating_minus_cooling_dph": d, "stderr_dph": se,
                "z": d / se if se > 0 else float("nan"),
                "verdict": ("heating and cooling branches differ: thermal hysteresis or a "
                            "missing rate/lag term" if abs(d) > 3 * se else
                            "no significant heating/cooling difference")})
    return out


@dataclass
class SetpointResult:
    """Quadratic fit of a steady-state set-point table (the paper's thermal test)."""

    t0_c: float
    coefficients: list[Coef]
    points: list[dict]
    rms_dph: float
    dof: int
    weighted: bool
    notes: list[str]

    def coef(self, name: str) -> Coef:
        for c in self.coefficients:
            if c.name == name:
                return c
        raise KeyError(name)

    def to_dict(self) -> dict:
        return {"model": "dw = w0 + w1*dT + w2*dT^2 (+ w_dV*dT/dt)", "t0_degC": self.t0_c,
                "coefficients": [c.to_dict() for c in self.coefficients],
                "points": self.points, "rms_residual_dph": self.rms_dph, "dof": self.dof,
                "weighted": self.weighted, "notes": self.notes,
                "paper": ANTONOVA_MATVEEV_PAPER}


_TEMP_COL = re.compile(r"^(t|temp|temperature|thermostat|setpoint|set_point|t_c|t_degc)"
                       r"(_?c|_?degc)?$", re.I)
_DRIFT_COL = re.compile(r"^(dw|d_w|domega|delta_?omega|drift|rate|omega|dw_dph|drift_dph|"
                        r"delta|dw_deg_h)$", re.I)
_SIGMA_COL = re.compile(r"^(sigma|std|rms|err|error|sigma_dph|u)$", re.I)
_RATE_COL = re.compile(r"^(dtdt|dt_dt|tdot|rate_c_per_h|dtdt_c_per_h)$", re.I)


def read_setpoints(path: str | Path) -> dict[str, np.ndarray]:
    """Read a set-point table (CSV/TSV with a header): temperature °C, drift deviation deg/h,
    optional σ deg/h and dT/dt °C/h. Columns are recognised by name (temperature / thermostat
    / setpoint; dw / drift / delta_omega; sigma / std / rms; dTdt)."""
    from ..core.documents import read_table_text

    p = Path(path)
    text = read_table_text(p, "the set-point table")  # FIFO, device, gzip, encoding: one line
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    if len(lines) < 2:
        raise InputError(f"{p}: set-point table needs a header and at least one row")
    try:
        dialect = csv.Sniffer().sniff(lines[0], delimiters=",;\t ")
    except csv.Error:
        raise InputError(f"{p}: no delimiter found in the header {lines[0][:60]!r}; separate the "
                         "columns with commas, e.g. temperature,dw,sigma") from None
    rows = list(csv.reader(io.StringIO("\n".join(lines)), dialect))
    header = [h.strip() for h in rows[0]]
    cols: dict[str, int] = {}
    for i, h in enumerate(header):
        key = h.replace(" ", "_")
        if "temp" not in cols and _TEMP_COL.match(key):
            cols["temp"] = i
        elif "drift" not in cols and _DRIFT_COL.match(key):
            cols["drift"] = i
        elif "sigma" not in cols and _SIGMA_COL.match(key):
            cols["sigma"] = i
        elif "dtdt" not in cols and _RATE_COL.match(key):
            cols["dtdt"] = i
    for need, hint in (("temp", "temperature"), ("drift", "dw")):
        if need not in cols:
            raise InputError(f"{p}: no {hint} column among {', '.join(header)}; name the columns "
                             "e.g. temperature,dw,sigma")
    out: dict[str, list[float]] = {k: [] for k in cols}
    for n, row in enumerate(rows[1:], 2):
        for k, i in cols.items():
            try:
                x = float(row[i])
            except (ValueError, IndexError):
                raise InputError(f"{p}: row {n}, column {header[i]!r}: not a number "
                                 f"({row[i] if i < len(row) else ''!r})") from None
            if not math.isfinite(x) or abs(x) > 1e40:  # gyrotest.io.health.MAX_ABS
                raise InputError(f"{p}: row {n}, column {header[i]!r}: {row[i].strip()!r} is not "
                                 "a finite measured value; fix or remove the row")
            out[k].append(x)
    return {k: np.asarray(v) for k, v in out.items()}


def thermal_fit_setpoints(temp_c, drift_dph, sigma_dph=None, dtdt=None, *, t0_c: float = 21.0,
                          weighted: bool = False) -> SetpointResult:
    """Fit Δω = w0 + w1·ΔT + w2·ΔT² (+ w_ΔV·dT/dt when a rate column is given) to steady-state
    set-points, ΔT = T − t0.

    Least squares (weighted by 1/σ² when ``weighted``; the paper's σ is the RMS of the output
    over the averaging interval, so by default it only labels the points); 1σ from the scatter,
    s²·(XᵀWX)⁻¹ with s² = χ²/(n − p). At steady state dT/dt = 0, so w_ΔV is not identifiable
    without a rate column. Source: Antonova & Matveev (GYRO_REFERENCE §6 table).
    """
    T = np.asarray(temp_c, float)
    y = np.asarray(drift_dph, float)
    n = len(T)
    cols = [np.ones(n), T - t0_c, (T - t0_c) ** 2]
    names = ["w0", "w1", "w2"]
    notes = []
    if dtdt is not None and np.ptp(np.asarray(dtdt, float)) > 0:
        cols.append(np.asarray(dtdt, float))
        names.append("w_dV")
    else:
        notes.append("w_dV (temperature-rate term) is not identifiable from steady-state "
                     "set-points (dT/dt = 0): fit a continuous chamber run for it")
    X = np.column_stack(cols)
    p = X.shape[1]
    if n < p:
        raise AnalysisError(f"{n} set-points cannot determine {p} coefficients "
                            f"({', '.join(names)})")
    w = np.ones(n)
    if weighted:
        if sigma_dph is None:
            raise InputError("weighted set-point fit needs a sigma column")
        s = np.asarray(sigma_dph, float)
        if np.any(s <= 0):
            raise InputError("sigma column must be > 0 for a weighted fit")
        w = 1.0 / s ** 2
    sw = np.sqrt(w)
    beta, *_ = np.linalg.lstsq(X * sw[:, None], y * sw, rcond=None)
    r = y - X @ beta
    dof = n - p
    chi2 = float(np.sum(w * r * r))
    cov = (np.linalg.pinv((X * w[:, None]).T @ X) * (chi2 / dof) if dof > 0
           else np.full((p, p), np.nan))
    se = np.sqrt(np.clip(np.diag(cov), 0, None))
    coefs = [Coef(nm, float(b), float(e), AM_UNITS[nm]) for nm, b, e in zip(names, beta, se)]
    pts = [{"temperature_degC": float(T[i]), "dT_degC": float(T[i] - t0_c),
            "dw_dph": float(y[i]), "model_dph": float(X[i] @ beta), "residual_dph": float(r[i]),
            **({"sigma_dph": float(sigma_dph[i])} if sigma_dph is not None else {})}
           for i in range(n)]
    if dof == 0:
        notes.append("as many coefficients as points: exact fit, no uncertainty")
    return SetpointResult(t0_c, coefs, pts, float(np.sqrt(np.mean(r * r))), dof, weighted,
                          notes)


# ============================================================================ magnetic
@dataclass
class Plateau:
    """One constant-field level of a Helmholtz sequence."""

    index: int
    t_start_s: float
    t_end_s: float
    field_uT: list[float]
    axis: str | None  # x/y/z of the sequence (background levels inside it too), else None
    level_uT: float  # applied level along that axis (field − background)
    direction: str  # up / down (how the level was approached) or start
    rate_dph: float  # mean rate (minus the non-magnetic model part), deg/h
    rate_std_dph: float
    n: int

    def to_dict(self) -> dict:
        return dict(self.__dict__)


@dataclass
class MagResult:
    """Magnetic sensitivities with reversal and sweep-hysteresis cross-checks."""

    fit: FitResult
    coefficients: list[Coef]
    plateaus: list[Plateau]
    reversal: dict[str, dict]
    hysteresis: dict[str, dict]
    notes: list[str] = field(default_factory=list)

    def coef(self, name: str) -> Coef:
        for c in self.coefficients:
            if c.name == name:
                return c
        raise KeyError(name)

    def to_dict(self) -> dict:
        return {"model": "dw = w0 + wx*Hx/H0 + wy*Hy/H0 + wz*Hz/H0, H0 = 100 uT",
                "coefficients": [c.to_dict() for c in self.coefficients],
                "reversal_K": self.reversal, "sweep_hysteresis": self.hysteresis,
                "plateaus": [p.to_dict() for p in self.plateaus], "notes": self.notes,
                "fit": self.fit.to_dict()}


def detect_plateaus(t: np.ndarray, H: np.ndarray, *, settle_s: float = 10.0,
                    min_dwell_s: float = 30.0, step_uT: float | None = None
                    ) -> list[tuple[int, int]]:
    """Constant-field stretches of a field record (3 × n on a uniform grid): split where any
    axis jumps by more than max(2 µT, 8 × its sample-to-sample noise) (or ``step_uT``/4), drop
    ``settle_s`` after each jump, keep stretches of at least ``min_dwell_s``. Returns (start,
    stop) index pairs."""
    n = H.shape[1]
    if n < 4:
        return []
    dH = np.abs(np.diff(H, axis=1))
    noise = 1.4826 * np.median(np.abs(dH - np.median(dH, axis=1, keepdims=True)), axis=1)
    thr = np.maximum(2.0, 8.0 * noise)
    if step_uT:
        thr = np.maximum(thr, step_uT / 4.0)
    jump = np.any(dH > thr[:, None], axis=0)
    idx = np.where(jump)[0] + 1
    dt = float(np.median(np.diff(t))) if n > 1 else 1.0
    cuts = [0] + list(idx) + [n]
    out = []
    settle = int(math.ceil(settle_s / dt))
    for a, b in zip(cuts[:-1], cuts[1:]):
        a2 = a + (settle if a > 0 else 0)
        b2 = b - 1 if b < n else b
        if (b2 - a2) * dt >= min_dwell_s:
            out.append((a2, b2))
    return out


def mag_fit(wd: WorkData, *, extra_terms: list[str] | None = None, settle_s: float = 10.0,
            min_dwell_s: float = 30.0, folds: int = 5) -> MagResult:
    """Fit w_x, w_y, w_z (deg/h per 100 µT) from a Helmholtz sequence or a continuous
    magnetometer log, with the paper's reversal estimate K and up/down sweep hysteresis.

    The coefficients come from the model fit of the block data with terms Hx, Hy, Hz (plus
    ``extra_terms`` such as T or ramp for drift between levels; 1σ from GLS under the noise model). Plateaus are detected
    on the 1-s grid (:func:`detect_plateaus`); each plateau's mean rate, corrected for the
    non-magnetic fitted terms, gives K_i = (Δω(+max) − Δω(−max))/(2·max/H0) per axis and the
    mean up-minus-down difference at levels visited in both sweep directions.
    Source: Antonova & Matveev eq. (2) and its Helmholtz test.
    """
    fr = wd.frame
    chans = list(fr.field_uT)
    if len(chans) < 3:
        raise InputError(f"{wd.info.get('source')}: mag-fit needs three field channels "
                         f"(X, Y, Z, µT; found {len(chans)}); name them with --field-col")
    terms = [f"H{a}({c})" for a, c in zip("xyz", chans)]
    active = [tm for tm, c in zip(terms, chans) if np.ptp(fr.field_uT[c]) > 1e-9]
    if not active:
        raise AnalysisError(f"{wd.info.get('source')}: the field never changes; no magnetic "
                            "sensitivity can be fitted")
    notes = []
    if len(active) < 3:
        notes.append("constant field axes not fitted: " + ", ".join(
            c for tm, c in zip(terms, chans) if tm not in active))
    res = fit_model(wd, active + list(extra_terms or []), folds=folds)
    coefs = []
    for a, tm in zip("xyz", terms):
        if tm in active:
            c = res.coef(tm)
            coefs.append(Coef(f"w{a}", c.value, c.stderr, "deg/h per 100 uT"))
    # ---- plateaus on the fine grid
    H = np.vstack([fr.field_uT[c] for c in chans[:3]])
    pl_idx = detect_plateaus(fr.t, H, settle_s=settle_s, min_dwell_s=min_dwell_s)
    # non-magnetic part of the model, on the fine grid through the block times
    other = [s for s in res.specs if s.key not in ("Hx", "Hy", "Hz", "bias")]
    corr_b = predict_blocks(res, other) if other else np.zeros(res.n_blocks)
    corr_f = np.interp(fr.t, res.t, corr_b)
    rate = fr.rate - corr_f
    plateaus: list[Plateau] = []
    if len(pl_idx) >= 3:
        means = np.array([H[:, a:b].mean(axis=1) for a, b in pl_idx])
        bg = np.median(means, axis=0)
        prev_level: dict[str, float] = {}
        last_ax: str | None = None
        for i, (a, b) in enumerate(pl_idx):
            dev = means[i] - bg
            k = int(np.argmax(np.abs(dev)))
            if abs(dev[k]) > 5.0:
                ax, level = "xyz"[k], float(dev[k])
                p0 = prev_level.get(ax, 0.0)
                direction = "up" if level > p0 else "down"
                prev_level[ax] = level
                last_ax = ax
            else:
                # background level: inside an axis sequence it is that axis' zero level
                ax, level = last_ax, 0.0
                if ax is None:
                    direction = "start"
                else:
                    p0 = prev_level.get(ax, 0.0)
                    direction = "up" if p0 < 0 else ("down" if p0 > 0 else "start")
                    prev_level[ax] = 0.0
                last_ax = None
            plateaus.append(Plateau(i, float(fr.t[a]), float(fr.t[b - 1]),
                                    [float(v) for v in means[i]], ax, level, direction,
                                    float(rate[a:b].mean()), float(rate[a:b].std()), b - a))
    else:
        notes.append("no Helmholtz plateaus found: coefficients from the continuous record only")
    reversal: dict[str, dict] = {}
    hyst: dict[str, dict] = {}
    for ax in "xyz":
        pa = [p for p in plateaus if p.axis == ax]
        if len(pa) < 2:
            continue
        top = max(pa, key=lambda p: p.level_uT)
        bot = min(pa, key=lambda p: p.level_uT)
        if top.level_uT > 0 > bot.level_uT:
            span = (top.level_uT - bot.level_uT) / H0_UT
            d = top.rate_dph - bot.rate_dph
            reversal[ax] = {"K_dph_per_100uT": abs(d) / span, "signed_dph_per_100uT": d / span,
                            "levels_uT": [top.level_uT, bot.level_uT],
                            "paper_formula": "K = |dw(+max) - dw(-max)| / (2 max / 100 uT)"}
        # up/down at equal levels
        diffs = []
        for p_up in (p for p in pa if p.direction == "up"):
            for p_dn in (p for p in pa if p.direction == "down"):
                if abs(p_up.level_uT - p_dn.level_uT) < 5.0:
                    diffs.append(p_up.rate_dph - p_dn.rate_dph)
        if diffs:
            # a plateau mean's 1σ from the residual noise model: white N over the dwell plus
            # the flicker plateau B
            fl = res.floor
            dwell = float(np.median([p.n for p in pa])) * fr.dt
            se_one = (math.sqrt(fl.white_N ** 2 / dwell + fl.flicker_B ** 2)
                      if fl is not None and math.isfinite(fl.white_N) else
                      float(np.median([p.rate_std_dph for p in pa])))
            m = float(np.mean(diffs))
            se = se_one * math.sqrt(2.0 / len(diffs))
            hyst[ax] = {"up_minus_down_dph": m, "stderr_dph": se, "pairs": len(diffs),
                        "max_abs_dph": float(np.max(np.abs(diffs))),
                        "verdict": ("up and down sweeps differ (magnetic hysteresis or drift "
                                    "between levels)" if abs(m) > 3 * se else
                                    "no significant up/down difference")}
    return MagResult(res, coefs, plateaus, reversal, hyst, notes)



# ============================================================================ the commands
#: terms named when ingest rejects a channel ``thermal-fit`` needs
THERMAL_TERMS = ("T", "dTdt")


def thermal_terms() -> list[TermSpec]:
    """The term specs of :data:`THERMAL_TERMS` (for
    :func:`gyrotest.envmodel.pipeline.naming_terms`)."""
    return parse_terms(list(THERMAL_TERMS))


def parse_gradient(value: str | list[str] | tuple[str, ...] | None) -> tuple[str, str] | None:
    """``--gradient A,B`` (or a list of two names) → ("A", "B"); None when not given."""
    if not value:
        return None
    parts = ([p.strip() for p in value.split(",") if p.strip()] if isinstance(value, str)
             else [str(p).strip() for p in value])
    if len(parts) != 2:
        raise InputError(f"--gradient {value!r}: give two channels, e.g. T_case,T_coil")
    return parts[0], parts[1]


def check_thermal_input(has_log: bool, setpoints) -> None:
    """thermal-fit needs a chamber log, a set-point table, or both."""
    if not has_log and setpoints is None:
        raise InputError("give a chamber log, --setpoints TABLE, or both")


@dataclass
class ThermalAnalysis:
    """``gyrotest thermal-fit``: the chamber-run fit and/or the set-point table fit."""

    chamber: ThermalResult | None
    setpoints: SetpointResult | None

    def to_dict(self, model_file: str | None = None) -> dict:
        """The JSON document of ``gyrotest thermal-fit --json`` (``model_file``: the model
        written with ``-o``, if any)."""
        return {"chamber": self.chamber.to_dict() if self.chamber else None,
                "setpoints": self.setpoints.to_dict() if self.setpoints else None,
                "model_file": model_file}


def analyse_thermal(log=None, *, path: str | None = None, setpoints: str | Path | None = None,
                    t0_c: float = 21.0, sensor: str | None = None,
                    gradient: str | list[str] | tuple[str, ...] | None = None,
                    weighted: bool = False, axis: str | None = None, skip: str | float = "0",
                    resolution: str | None = "auto", smooth: str | None = "auto",
                    folds: int = 5, reference=None) -> ThermalAnalysis:
    """The analysis of ``gyrotest thermal-fit``: the set-point table ``setpoints``
    (:func:`read_setpoints`, :func:`thermal_fit_setpoints`) and/or the chamber run ``log``
    (a :class:`~gyrotest.core.data.GyroLog` read from ``path``): prepared with ΔT from ``t0_c``
    (:func:`gyrotest.envmodel.pipeline.prepare_log` with the ``axis``/``skip``/``resolution``/
    ``smooth`` options as typed), then :func:`thermal_fit`. ``reference``: a static reference
    log of the same gyro whose noise model is fixed for the fit
    (:func:`gyrotest.envmodel.likelihood.reference_noise`)."""
    check_thermal_input(log is not None, setpoints)
    grad = parse_gradient(gradient)
    sp = th = None
    if setpoints is not None:
        tab = read_setpoints(setpoints)
        sp = thermal_fit_setpoints(tab["temp"], tab["drift"], tab.get("sigma"), tab.get("dtdt"),
                                   t0_c=t0_c, weighted=weighted)
    if log is not None:
        if not log.temperature:
            raise InputError(f"{log.source}: thermal-fit needs a temperature channel; name it "
                             "with --temp-col")
        wd = prepare_log(log, path, axis=axis, skip=skip, t_ref=t0_c, resolution=resolution,
                         smooth=smooth, reference=reference)
        th = thermal_fit(wd, sensor=sensor, gradient=grad, folds=folds)
    return ThermalAnalysis(th, sp)


def mag_terms(with_terms: str | None = None) -> tuple[list[str], list[TermSpec]]:
    """(the ``--with`` terms, the term specs ``mag-fit`` needs: Hx, Hy, Hz and those)."""
    extra = split_terms(with_terms) if with_terms else []
    return extra, parse_terms(["Hx", "Hy", "Hz"] + extra)


def mag_document(result: MagResult, *, model_file: str | None = None) -> dict:
    """The JSON document of ``gyrotest mag-fit --json`` (``model_file``: written with ``-o``)."""
    d = result.to_dict()
    d["model_file"] = model_file
    return d


def analyse_mag(log, *, path: str | None = None, with_terms: str | None = None,
                settle_s: float = 10.0, min_dwell_s: float = 30.0, axis: str | None = None,
                skip: str | float = "0", resolution: str | None = "auto",
                smooth: str | None = "auto", folds: int = 5, reference=None) -> MagResult:
    """The analysis of ``gyrotest mag-fit``: ``log`` (read from ``path``) needs three field
    channels; prepared (:func:`gyrotest.envmodel.pipeline.prepare_log`), then :func:`mag_fit`
    with the ``--with`` terms ``with_terms`` (comma-separated); ``reference`` as in
    :func:`analyse_thermal`."""
    extra, _ = mag_terms(with_terms)
    if len(log.field_uT) < 3:
        raise InputError(f"terms Hx, Hy, Hz: {log.source} has {len(log.field_uT)} magnetic-field "
                         "channel(s); name X, Y, Z with --field-col")
    wd = prepare_log(log, path, axis=axis, skip=skip, resolution=resolution, smooth=smooth,
                     reference=reference)
    return mag_fit(wd, extra_terms=extra, settle_s=settle_s, min_dwell_s=min_dwell_s,
                   folds=folds)
