"""MATLAB ``gyroparams`` and ``accelparams`` (Navigation / Sensor Fusion and Tracking Toolbox,
for ``imuSensor``).

Property names and units as MathWorks documents them for ``gyroparams``:

* ``NoiseDensity`` (rad/s)/√Hz = N·(π/180)/60 (NoiseType "double-sided", the default and the
  IEEE 952 two-sided PSD convention of N);
* ``BiasInstability`` rad/s = B·(π/180)/3600 (IEEE B: the flat Allan level / 0.664);
* ``RandomWalk`` (rad/s)·√Hz = K·(π/180)/216000;
* ``ConstantBias`` rad/s (``--constant-bias``, deg/h);
* ``TemperatureBias`` (rad/s)/°C: the slope d(drift)/dT at 25 °C (the temperature imuSensor
  takes as reference) of a drift model's temperature polynomial (``--thermal``);
* ``TemperatureScaleFactor`` %/°C: −ε_T·1e-4 from ``gyrotest scale-factor`` (ε_T is ppm/°C
  of the input-per-output scale factor; imuSensor scales the output, hence the sign);
* ``MeasurementRange`` rad/s: the scale-factor full scale or ``--range``.

``accelparams`` (the accelerometer axes of the Allan document, IEEE Std 1293 terms):
``NoiseDensity`` (m/s²)/√Hz = VRW/60 (VRW in m/s/√h), ``BiasInstability`` m/s² = B·9.80665e-6
(B in µg), ``RandomWalk`` (m/s²)·√Hz = K/216000 (acceleration random walk in m/s/h/√h),
``ConstantBias`` and ``MeasurementRange`` m/s² from the options.

One axis gives scalars, three axes 1×3 row vectors (gyroparams takes either). Upper-bound
noise terms are written at their 95 % bound (flagged in the comments of the .m file).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..core.errors import InputError
from .common import (
    DEG,
    AllanAxis,
    Document,
    acrw_m_s3_rt_hz,
    arw_rad_s_rt_hz,
    banner,
    dph_rad_s,
    need,
    number,
    rrw_rad_s2_rt_hz,
    ug_m_s2,
    vrw_m_s2_rt_hz,
)

UNITS = {
    "MeasurementRange": "rad/s",
    "ConstantBias": "rad/s",
    "NoiseDensity": "(rad/s)/sqrt(Hz)",
    "BiasInstability": "rad/s",
    "RandomWalk": "(rad/s)*sqrt(Hz)",
    "TemperatureBias": "(rad/s)/degC",
    "TemperatureScaleFactor": "%/degC",
}
#: imuSensor's reference temperature, degC
MATLAB_T_REF_C = 25.0


#: MATLAB accelparams units (the accelerometer twin of gyroparams)
ACC_UNITS = {
    "MeasurementRange": "m/s^2",
    "ConstantBias": "m/s^2",
    "NoiseDensity": "(m/s^2)/sqrt(Hz)",
    "BiasInstability": "m/s^2",
    "RandomWalk": "(m/s^2)*sqrt(Hz)",
}


@dataclass
class GyroParams:
    """The properties written (name → list of per-axis values) and the comment per property;
    ``kind`` is the MATLAB object: "gyroparams" or "accelparams"."""

    axes: list[str]
    values: dict[str, list[float]] = field(default_factory=dict)
    notes: dict[str, str] = field(default_factory=dict)
    sources: list[str] = field(default_factory=list)
    kind: str = "gyroparams"

    @property
    def units(self) -> dict[str, str]:
        return ACC_UNITS if self.kind == "accelparams" else UNITS

    def value(self, name: str) -> float | np.ndarray:
        v = self.values[name]
        return v[0] if len(v) == 1 else np.asarray(v, float)


def thermal_slope_dph_per_c(model: Document, at_c: float = MATLAB_T_REF_C) -> tuple[float, str]:
    """d(drift)/dT (deg/h/°C) at ``at_c`` of the T, T2, T3 terms of a saved drift model on its
    first temperature channel; the channel name. InputError if the model has no such term."""
    src = model.source
    refs = (model.data.get("references") or {}).get("T_ref_degC") or {}
    slope, chan = 0.0, None
    for t in need(model.data, "terms", src):
        key = t.get("key")
        if key not in ("T", "T2", "T3"):
            continue
        ch = (t.get("channels") or [None])[0]
        if chan is None:
            chan = ch
        if ch != chan:
            continue
        p = {"T": 1, "T2": 2, "T3": 3}[key]
        c = number(need(t, "coefficients", src, f"term {t.get('label')}")[0].get("value"), src,
                   f"coefficient of {t.get('label')}")
        t_ref = float(refs.get(ch, 0.0))
        slope += p * c * (at_c - t_ref) ** (p - 1)
    if chan is None:
        raise InputError(f"{src}: the model has no temperature term (T, T2, T3); --thermal needs "
                         "a thermal model (gyrotest thermal-fit -o model.json)")
    return slope, str(chan)


def _noise_values(gp: GyroParams, axes: list[AllanAxis], table) -> None:
    """The noise properties of ``table`` [(property, term key, conversion)] from the axes'
    models (0 where an axis has no such term), with a note per property."""
    for name, key, conv in table:
        terms = [a.term(key) for a in axes]
        if all(t is None for t in terms):
            continue
        gp.values[name] = [0.0 if t is None else conv(t.value) for t in terms]
        gp.notes[name] = "; ".join(f"{a.axis}: " + (t.describe() if t else f"no {key} term")
                                   for a, t in zip(axes, terms))


def _one_or_three(axes: list[AllanAxis], what: str) -> None:
    if len(axes) not in (1, 3):
        raise InputError(f"{what} holds one value or three (x, y, z); the input has "
                         f"{len(axes)} such axes ({', '.join(a.label for a in axes)}): choose "
                         "with --axis")


def build_accelparams(axes: list[AllanAxis], *, constant_bias_m_s2: float | None = None,
                      range_m_s2: float | None = None) -> GyroParams:
    """MATLAB ``accelparams`` of the accelerometer axes of an Allan document (IEEE Std 1293
    terms): NoiseDensity = VRW/60 (m/s²)/√Hz, BiasInstability = B·9.80665e-6 m/s² (B in µg),
    RandomWalk = K/216000 (m/s²)·√Hz (K in m/s/h/√h); upper bounds at their bound."""
    acc = [a for a in axes if a.is_accel]
    if not acc:
        raise InputError(f"{axes[0].source}: no accelerometer axis (ax/ay/az, acc_x ... with "
                         "a unit) in the Allan analysis; accelparams needs one")
    _one_or_three(acc, "accelparams")
    gp = GyroParams([a.axis for a in acc], sources=sorted({a.source for a in acc}),
                    kind="accelparams")
    _noise_values(gp, acc, (("NoiseDensity", "N", vrw_m_s2_rt_hz),
                            ("BiasInstability", "B", ug_m_s2),
                            ("RandomWalk", "K", acrw_m_s3_rt_hz)))
    if "NoiseDensity" not in gp.values:
        raise InputError(f"{acc[0].source}: the accelerometer model has no N (velocity random "
                         "walk) term; re-run 'gyrotest allan' with N in --terms")
    if constant_bias_m_s2 is not None:
        gp.values["ConstantBias"] = [float(constant_bias_m_s2)]
        gp.notes["ConstantBias"] = f"{constant_bias_m_s2:g} m/s^2 (--constant-bias)"
    if range_m_s2 is not None:
        if not range_m_s2 > 0:
            raise InputError(f"--range must be > 0 m/s^2, got {range_m_s2:g}")
        gp.values["MeasurementRange"] = [float(range_m_s2)]
        gp.notes["MeasurementRange"] = f"{range_m_s2:g} m/s^2"
    return gp


def build_gyroparams(axes: list[AllanAxis], *, constant_bias_dph: float | None = None,
                     thermal: Document | None = None, scale_factor: Document | None = None,
                     range_dps: float | None = None) -> GyroParams:
    gyros = [a for a in axes if not a.is_accel]
    if not gyros:
        raise InputError(f"{axes[0].source}: no gyro axis in the Allan analysis; for the "
                         "accelerometers use 'gyrotest export accelparams'")
    axes = gyros
    if len(axes) not in (1, 3):
        raise InputError(f"gyroparams holds one value or three (x, y, z); the input has "
                         f"{len(axes)} axes ({', '.join(a.label for a in axes)}): choose with "
                         "--axis")
    gp = GyroParams([a.axis for a in axes], sources=sorted({a.source for a in axes}))
    _noise_values(gp, axes, (("NoiseDensity", "N", arw_rad_s_rt_hz),
                             ("BiasInstability", "B", dph_rad_s),
                             ("RandomWalk", "K", rrw_rad_s2_rt_hz)))
    if "NoiseDensity" not in gp.values:
        raise InputError(f"{axes[0].source}: the noise model has no N term; re-run "
                         "'gyrotest allan' with N in --terms")
    if constant_bias_dph is not None:
        gp.values["ConstantBias"] = [dph_rad_s(constant_bias_dph)]
        gp.notes["ConstantBias"] = f"{constant_bias_dph:g} deg/h (--constant-bias)"
    if thermal is not None:
        s, ch = thermal_slope_dph_per_c(thermal)
        gp.values["TemperatureBias"] = [dph_rad_s(s)]
        gp.notes["TemperatureBias"] = (f"d(drift)/dT at {MATLAB_T_REF_C:g} degC on {ch} = "
                                       f"{s:.6g} deg/h/degC from {thermal.source}")
        gp.sources.append(thermal.source)
    if scale_factor is not None:
        src = scale_factor.source
        ek = need(scale_factor.data, "epsilon_k", src)
        et = ek.get("epsilon_T_ppm_per_degC")
        if et is not None and math.isfinite(float(et)):
            gp.values["TemperatureScaleFactor"] = [-float(et) * 1e-4]
            gp.notes["TemperatureScaleFactor"] = (
                f"-epsilon_T * 1e-4, epsilon_T = {float(et):.6g} ppm/degC of the input-per-output "
                f"scale factor from {src}")
        fs = scale_factor.data.get("full_scale_dps")
        if range_dps is None and fs:
            range_dps = float(fs)
        gp.sources.append(src)
    if range_dps is not None:
        if not range_dps > 0:
            raise InputError(f"--range must be > 0 deg/s, got {range_dps:g}")
        gp.values["MeasurementRange"] = [range_dps * DEG]
        gp.notes["MeasurementRange"] = f"{range_dps:g} deg/s"
    return gp


def _mat_value(v: float | np.ndarray) -> str:
    if isinstance(v, np.ndarray):
        return "[" + " ".join(f"{x:.10g}" for x in v) + "]"
    return f"{v:.10g}"


def m_script(gp: GyroParams, var: str = "params") -> str:
    """A MATLAB script that builds the gyroparams (or accelparams) object ``var``."""
    acc = gp.kind == "accelparams"
    lines = [f"% {banner('MATLAB ' + gp.kind, gp.sources)}",
             "% Navigation / Sensor Fusion and Tracking Toolbox; use with imuSensor:",
             f"%   imu = imuSensor('SampleRate', fs, '{'Accelerometer' if acc else 'Gyroscope'}'"
             f", {var});",
             f"% Axes: {', '.join(gp.axes)}. Noise terms: continuous-time, NoiseType double-sided.",
             ]
    if acc:
        lines += ["% Conversions (IEEE Std 1293 terms): NoiseDensity = VRW/60,",
                  "%   BiasInstability = B*9.80665e-6, RandomWalk = K/216000",
                  "%   (VRW m/s/sqrt(h), B ug, K m/s/h/sqrt(h))."]
    else:
        lines += ["% Conversions: NoiseDensity = N*(pi/180)/60, BiasInstability = B*(pi/180)/3600,",
                  "%              RandomWalk = K*(pi/180)/216000 (N deg/sqrt(h), B deg/h, K deg/h/sqrt(h))."]
    names = list(gp.values)
    lines.append(f"{var} = {gp.kind}( ...")
    for i, name in enumerate(names):
        end = ");" if i == len(names) - 1 else ", ..."
        lines.append(f"    '{name}', {_mat_value(gp.value(name))}{end}"
                     f"  % {gp.units[name]}: {gp.notes.get(name, '')}")
    return "\n".join(lines) + "\n"


def mat_dict(gp: GyroParams) -> dict:
    """The variables of the .mat file: struct ``gyroparams`` (property → value), struct
    ``units``, char ``notes`` and ``usage``."""
    k = gp.kind
    return {
        k: {n: gp.value(n) for n in gp.values},
        "units": {n: gp.units[n] for n in gp.values},
        "axes": np.array(gp.axes, dtype=object),
        "notes": "\n".join(f"{n}: {v}" for n, v in gp.notes.items()),
        "usage": f"s = load(file); c = namedargs2cell(s.{k}); p = {k}(c{{:}});",
        "source": banner(f"MATLAB {k}", gp.sources),
    }


def write_mat(path, gp: GyroParams) -> None:
    from scipy.io import savemat

    savemat(str(path), mat_dict(gp), appendmat=False, oned_as="row")
