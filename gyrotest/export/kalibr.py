"""Kalibr ``imu.yaml``: the IMU noise parameters of the Kalibr camera–IMU calibration.

Keys and units (ethz-asl/kalibr wiki, "IMU Noise Model" and "YAML formats"):

* ``gyroscope_noise_density`` — white rate noise, continuous time, rad/s/√Hz = N (deg/√h)
  × (π/180)/60 (:func:`~gyrotest.export.common.arw_rad_s_rt_hz`);
* ``gyroscope_random_walk`` — bias random walk, rad/s²/√Hz = K (deg/h/√h) × (π/180)/216000
  (:func:`~gyrotest.export.common.rrw_rad_s2_rt_hz`);
* ``accelerometer_noise_density`` (m/s²/√Hz) = VRW (m/s/√h) / 60, ``accelerometer_random_walk``
  (m/s³/√Hz) = acceleration random walk K (m/s/h/√h) / 216000 — from the accelerometer axes
  of the Allan document (IEEE Std 1293 terms; :mod:`gyrotest.io.accel`), or the options (which
  win); only when the log had no accelerometer and no option gives them, a marked
  placeholder;
* ``update_rate`` — Hz, the log's sample rate (Kalibr derives the discrete σ = density·√rate
  from it), ``rostopic``.

Kalibr uses one value for the three axes: with several axes the largest is written (each axis
is listed in a comment). Upper-bound coefficients are written at their 95 % bound. Kalibr's
authors advise inflating the Allan values for unmodelled effects (``inflate``).
The YAML is written by hand (flat keys, plain numbers): no YAML library needed at run time.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..core.errors import InputError
from .common import (
    AllanAxis,
    acrw_m_s3_rt_hz,
    arw_rad_s_rt_hz,
    banner,
    fnum,
    rrw_rad_s2_rt_hz,
    vrw_m_s2_rt_hz,
)

#: placeholder accelerometer values (rounded from the example in Kalibr's "YAML formats" wiki
#: page); written only with a PLACEHOLDER comment and a warning on stderr
ACCEL_PLACEHOLDER = {"accelerometer_noise_density": 2.0e-3, "accelerometer_random_walk": 4.0e-4}


@dataclass
class KalibrParams:
    gyroscope_noise_density: float
    gyroscope_random_walk: float
    accelerometer_noise_density: float
    accelerometer_random_walk: float
    update_rate: float
    rostopic: str


def kalibr_yaml(axes: list[AllanAxis], *, rostopic: str = "/imu0",
                update_rate: float | None = None, inflate: float = 1.0,
                accel_noise_density: float | None = None,
                accel_random_walk: float | None = None) -> tuple[str, KalibrParams, list[str]]:
    """The imu.yaml text, the values written and the warnings (placeholders, missing K).

    Raises InputError when no axis has an N coefficient (nothing to export)."""
    if not inflate > 0:
        raise InputError(f"--inflate must be > 0, got {inflate}")
    warnings: list[str] = []
    lines_ax = []
    nd = rw = 0.0
    have_n = have_k = False
    acc_axes = [a for a in axes if a.is_accel]
    axes = [a for a in axes if not a.is_accel]
    if not axes:
        raise InputError(f"{acc_axes[0].source}: no gyro axis among {', '.join(a.axis for a in acc_axes)}; "
                         "Kalibr's imu.yaml needs the gyro noise too")
    for a in axes:
        n, k = a.term("N"), a.term("K")
        parts = []
        if n is not None:
            have_n = True
            nd = max(nd, arw_rad_s_rt_hz(n.value))
            parts.append(f"{n.describe()} -> {arw_rad_s_rt_hz(n.value):.6g} rad/s/sqrt(Hz)")
        if k is not None:
            have_k = True
            rw = max(rw, rrw_rad_s2_rt_hz(k.value))
            parts.append(f"{k.describe()} -> {rrw_rad_s2_rt_hz(k.value):.6g} rad/s^2/sqrt(Hz)")
        lines_ax.append(f"#   {a.label}: " + ("; ".join(parts) or "no N or K in the model"))
    if not have_n:
        raise InputError(f"{axes[0].source}: the noise model has no N (angle random walk) term; "
                         "re-run 'gyrotest allan' with N in --terms")
    if not have_k:
        warnings.append("the noise model has no K (rate random walk) term: "
                        "gyroscope_random_walk written as 0 (Kalibr then trusts the bias "
                        "completely); add K to 'gyrotest allan --terms'")
    rate = update_rate if update_rate is not None else 1.0 / axes[0].tau0_s
    if not rate > 0:
        raise InputError(f"--update-rate must be > 0 Hz, got {rate}")
    rates = {round(1.0 / a.tau0_s, 9) for a in axes}
    if update_rate is None and len(rates) > 1:
        raise InputError("the axes were logged at different rates "
                         f"({', '.join(f'{r:g}' for r in sorted(rates))} Hz); choose one with "
                         "--axis or give --update-rate")
    acc_nd, acc_rw = accel_noise_density, accel_random_walk
    lines_acc = []
    meas_nd = meas_rw = None
    for a in acc_axes:
        n, k = a.term("N"), a.term("K")
        parts = []
        if n is not None:
            meas_nd = max(meas_nd or 0.0, vrw_m_s2_rt_hz(n.value))
            parts.append(f"VRW {n.describe()} -> {vrw_m_s2_rt_hz(n.value):.6g} m/s^2/sqrt(Hz)")
        if k is not None:
            meas_rw = max(meas_rw or 0.0, acrw_m_s3_rt_hz(k.value))
            parts.append(f"acceleration RW {k.describe()} -> "
                         f"{acrw_m_s3_rt_hz(k.value):.6g} m/s^3/sqrt(Hz)")
        lines_acc.append(f"#   {a.label}: " + ("; ".join(parts) or "no N or K in the model"))
    src_nd = src_rw = "option"
    if acc_nd is None and meas_nd is not None:
        acc_nd, src_nd = meas_nd, "measured"
    if acc_rw is None and meas_rw is not None:
        acc_rw, src_rw = meas_rw, "measured"
    if acc_axes and meas_rw is None and accel_random_walk is None:
        acc_rw, src_rw = 0.0, "measured"
        warnings.append("the accelerometer model has no K (acceleration random walk) term: "
                        "accelerometer_random_walk written as 0; add K to 'gyrotest allan "
                        "--terms'")
    ph = []
    if acc_nd is None:
        acc_nd = ACCEL_PLACEHOLDER["accelerometer_noise_density"]
        ph.append("accelerometer_noise_density")
    if acc_rw is None:
        acc_rw = ACCEL_PLACEHOLDER["accelerometer_random_walk"]
        ph.append("accelerometer_random_walk")
    if ph:
        warnings.append(f"{' and '.join(ph)} are PLACEHOLDERS (the log has no accelerometer "
                        "columns: ax/ay/az, acc_x ... with a unit); give "
                        "--accel-noise-density / --accel-random-walk")
    # --inflate applies to what was measured (gyros, and accelerometers measured here)
    p = KalibrParams(nd * inflate, rw * inflate,
                     acc_nd * (inflate if src_nd == "measured" and "accelerometer_noise_density"
                               not in ph else 1.0),
                     acc_rw * (inflate if src_rw == "measured" and "accelerometer_random_walk"
                               not in ph else 1.0), rate, rostopic)

    def tag(key):
        if key in ph:
            return "; PLACEHOLDER, not measured: replace"
        src = src_nd if key == "accelerometer_noise_density" else src_rw
        return "; measured (Allan)" if src == "measured" else "; given as an option"

    head = [
        "# " + banner("Kalibr IMU noise parameters (imu.yaml)", sorted({a.source for a in axes})),
        "# Continuous-time noise densities of Kalibr's IMU noise model (ethz-asl/kalibr wiki",
        "# 'IMU Noise Model'); Kalibr discretises them with update_rate.",
        "#   gyroscope_noise_density = N [deg/sqrt(h)] * (pi/180) / 60        [rad/s/sqrt(Hz)]",
        "#   gyroscope_random_walk   = K [deg/h/sqrt(h)] * (pi/180) / 216000   [rad/s^2/sqrt(Hz)]",
        "# from the Allan noise model of gyrotest (largest over the axes below):",
        *lines_ax,
    ]
    if lines_acc:
        head += ["#   accelerometer_noise_density = VRW [m/s/sqrt(h)] / 60     [m/s^2/sqrt(Hz)]",
                 "#   accelerometer_random_walk   = K [m/s/h/sqrt(h)] / 216000 [m/s^3/sqrt(Hz)]",
                 "# (IEEE Std 1293 terms of the accelerometer axes; options win):",
                 *lines_acc]
    if inflate != 1.0:
        head.append(f"# measured values multiplied by --inflate {inflate:g} (unmodelled effects)")
    body = [
        "",
        "#Accelerometers",
        f"accelerometer_noise_density: {fnum(p.accelerometer_noise_density)}"
        f"   # m/s^2/sqrt(Hz){tag('accelerometer_noise_density')}",
        f"accelerometer_random_walk: {fnum(p.accelerometer_random_walk)}"
        f"   # m/s^3/sqrt(Hz){tag('accelerometer_random_walk')}",
        "",
        "#Gyroscopes",
        f"gyroscope_noise_density: {fnum(p.gyroscope_noise_density)}   # rad/s/sqrt(Hz)",
        f"gyroscope_random_walk: {fnum(p.gyroscope_random_walk)}   # rad/s^2/sqrt(Hz)",
        "",
        f"rostopic: {_yaml_str(rostopic)}   # the IMU ROS topic",
        f"update_rate: {_float(rate)}   # Hz (for the discretisation of the values above)",
    ]
    return "\n".join(head + body) + "\n", p, warnings


def _float(x: float) -> str:
    """A YAML float that stays a float (``10.0``, not ``10``)."""
    t = fnum(x)
    return t if any(c in t for c in ".en") else t + ".0"


def _yaml_str(s: str) -> str:
    """A YAML scalar for a topic name: plain when safe, else double-quoted JSON-style."""
    import json
    import re

    if re.fullmatch(r"/?[A-Za-z_][A-Za-z0-9_/]*", s):
        return s
    return json.dumps(s)
