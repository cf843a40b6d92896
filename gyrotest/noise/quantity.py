"""What an Allan analysis is of: gyro rate (IEEE Std 952) or acceleration (IEEE Std 1293).

The noise terms, their closed forms and the fit are the same for both (angle ↔ velocity,
rate ↔ acceleration); only the unit σ(τ) is computed in and the units the coefficients are
reported in differ. The fit works in the σ unit of the table (deg/h for gyros, m/s² for
accelerometers) and reports each coefficient with the formula of the gyro unit
(:func:`gyrotest.noise.noisefit._reported`: N = √c/60, K = 60√c, R = 3600√c, B = √c, Q = √c,
q_c = 60√c/T_c, Ω0 = √c) times the factor of :attr:`Quantity.scale`:

=====================  ======================  =========================  ===================
term (IEEE 1293 name)  accelerometer unit      value, σ in m/s², τ in s    factor on the gyro
                                                                           formula
=====================  ======================  =========================  ===================
Q velocity quantiz.    m/s                     √c                          1
N velocity random walk m/s/√h                  60·√c (√h = 60 √s)          3600
B bias instability     µg                      √c / (9.80665e-6 m/s²)      1/9.80665e-6
K acceleration RW      m/s/h/√h (m/s/h^1.5)    216000·√c                   3600
R acceleration ramp    m/s/h²                  3600²·√c                    3600
markov q_c             m/s/h/√h, T_c s         216000·√c/T_c               3600
sine Ω0                µg                      √c / 9.80665e-6             1/9.80665e-6
blue α                 (m/s²)²/Hz              c                           1
=====================  ======================  =========================  ===================

(IEEE Std 1293-2018, *IEEE Standard Specification Format Guide and Test Procedure for Linear
Single-Axis, Nongyroscopic Accelerometers*, Annex on Allan variance: velocity random walk,
bias instability, acceleration random walk, the analogues of IEEE Std 952's angle random walk,
bias instability and rate random walk; g = 9.80665 m/s².)
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..core.units import G0

__all__ = ["ACCEL", "QUANTITIES", "RATE", "Quantity", "quantity_of"]

_MU_G = G0 * 1e-6  # m/s² per µg


@dataclass(frozen=True)
class Quantity:
    """The measured quantity of an Allan table (module docstring): ``key`` ("rate" or
    "acceleration"), ``sensor`` name, ``sigma_unit`` of σ(τ), per-term parameter ``units``,
    ``scale`` of each reported parameter on top of the gyro formula, term ``titles``, and the
    ``standard`` whose terms these are."""

    key: str
    sensor: str
    sigma_unit: str
    units: dict[str, dict[str, str]]
    scale: dict[str, float] = field(default_factory=dict)
    titles: dict[str, str] = field(default_factory=dict)
    standard: str = ""
    angle: str = "angle"  # what the integral of the quantity is

    def factor(self, param: str) -> float:
        """The factor on the gyro-unit formula of a reported parameter (1 for gyros)."""
        return self.scale.get(param, 1.0)

    def unit(self, key: str, param: str | None = None) -> str:
        """Unit of a term's main (or named) parameter."""
        u = self.units[key]
        return u[param] if param else next(iter(u.values()))


RATE = Quantity(
    key="rate", sensor="gyro", sigma_unit="deg/h",
    units={
        "Q": {"Q": "arcsec"},
        "N": {"N": "deg/sqrt(h)"},
        "B": {"B": "deg/h"},
        "K": {"K": "deg/h/sqrt(h)"},
        "R": {"R": "deg/h/h"},
        "markov": {"q_c": "deg/h/sqrt(h)", "T_c": "s"},
        "sine": {"Omega0": "deg/h", "f0": "Hz"},
        "blue": {"alpha": "(deg/h)^2/Hz", "beta": "Hz"},
    },
    titles={"Q": "quantization", "N": "ARW", "B": "bias instability", "K": "RRW",
            "R": "rate ramp", "markov": "Gauss-Markov", "sine": "sinusoid",
            "blue": "blue, S(0)=0"},
    standard="IEEE Std 952-1997 Annex C", angle="angle")

ACCEL = Quantity(
    key="acceleration", sensor="accelerometer", sigma_unit="m/s^2",
    units={
        "Q": {"Q": "m/s"},
        "N": {"N": "m/s/sqrt(h)"},
        "B": {"B": "ug"},
        "K": {"K": "m/s/h/sqrt(h)"},
        "R": {"R": "m/s/h/h"},
        "markov": {"q_c": "m/s/h/sqrt(h)", "T_c": "s"},
        "sine": {"Omega0": "ug", "f0": "Hz"},
        "blue": {"alpha": "(m/s^2)^2/Hz", "beta": "Hz"},
    },
    scale={"Q": 1.0, "N": 3600.0, "B": 1.0 / _MU_G, "K": 3600.0, "R": 3600.0,
           "q_c": 3600.0, "Omega0": 1.0 / _MU_G},
    titles={"Q": "velocity quantization", "N": "VRW", "B": "bias instability",
            "K": "acceleration RW", "R": "acceleration ramp", "markov": "Gauss-Markov",
            "sine": "sinusoid", "blue": "blue, S(0)=0"},
    standard="IEEE Std 1293-2018", angle="velocity")

QUANTITIES = {RATE.key: RATE, ACCEL.key: ACCEL}


def quantity_of(name: str | None) -> Quantity:
    """The :class:`Quantity` of a key ("rate", "acceleration"; None → rate)."""
    return QUANTITIES[name or "rate"]
