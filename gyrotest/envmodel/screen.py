"""The candidate terms a diagnosis tries: the library terms the log's channels allow, and a
screen of every logged channel in the forms physics gives an effect.

For each numeric channel the screen proposes, beside the library terms of its kind
(temperature: T, T2, T3, dT/dt, lagged core, lagged-node rate, hysteresis; field: H_i, H_i²,
H_i·H_j, |H|²; supply: V; acceleration: g, g², g_i·g_j; a moving IA: the earth-rate
projection), the generic forms of
:mod:`gyrotest.envmodel.channel_terms` for channels the library has no term for (humidity,
pressure, vibration, tilt, ... and the supply's square, rate and lag): level, square,
magnitude, rate of change, first-order lag (fitted τ), the rate of that lag, and the products
of pairs of such channels (the first six). Nuisance terms that are
tied to no channel (time ramp, warm-up, free-frequency sinusoid) close the list.

Each candidate has a *class* used to break ties in the ranking: a channel-based explanation
is preferred to a nuisance term when the evidence is equal.
"""

from __future__ import annotations

import numpy as np

from .channel_terms import numeric_channels
from .terms import _G_PATTERN, EnvFrame, TermSpec

#: tie-break order (lower is preferred at equal evidence)
CLASS_ORDER = {"library": 0, "second-order": 1, "channel": 2, "nuisance": 3}
NUISANCE = ("ramp", "warmup", "sin", "hyst")
#: products are screened between at most this many generic channels (pairs grow as n²)
MAX_PRODUCT_CHANNELS = 6
SECOND_ORDER = ("T2", "T3", "Hsq", "Hprod", "Hmag2", "Hquad", "g2", "gprod", "Tlag",
                "dTlagdt")


def term_class(spec: TermSpec) -> str:
    """library | second-order | channel | nuisance (see :data:`CLASS_ORDER`)."""
    if spec.key in NUISANCE:
        return "nuisance"
    if spec.key in ("chan", "chan2", "chanabs", "dchan", "chanlag", "dchanlag", "chanprod",
                    "custom"):
        return "channel"
    if spec.key in SECOND_ORDER:
        return "second-order"
    return "library"


def _varies(v: np.ndarray) -> bool:
    v = np.asarray(v, float)
    return bool(np.all(np.isfinite(v)) and np.ptp(v) > 1e-9 * max(1.0, float(np.max(np.abs(v)))))


def _curved(v: np.ndarray) -> bool:
    """Whether x² differs from a straight line in x over the logged range (|r(x, x²)| <
    0.999): a channel far from zero (supply 15 V, pressure 1013 hPa) makes x² a copy of x,
    a tie the screen should not offer."""
    x = np.asarray(v, float)
    x2 = x * x
    if np.std(x) == 0 or np.std(x2) == 0:
        return False
    return abs(float(np.corrcoef(x, x2)[0, 1])) < 0.999


def candidate_terms(frame: EnvFrame, present: list[TermSpec]) -> list[TermSpec]:
    """Every term this log's channels allow and the model ``present`` lacks (see the module
    docstring). Terms the model already has, and nuisance terms of a kind it has, are left
    out."""
    have = {s.label for s in present}
    keys_present = {s.key for s in present}
    cands: list[TermSpec] = []
    temps = [k for k, v in frame.temperature.items() if _varies(v)]
    for tc in temps:
        for k in ("T", "T2", "T3", "dTdt", "Tlag", "dTlagdt", "hyst"):
            if k == "T3" and TermSpec("T2", (tc,)).label not in have:
                continue
            cands.append(TermSpec(k, (tc,)))
    for i, a in enumerate(temps):
        for b in temps[i + 1:]:
            if _varies(frame.temperature[a] - frame.temperature[b]):
                cands.append(TermSpec("dGdt", (a, b)))
    fields = [(i, n) for i, (n, v) in enumerate(frame.field_uT.items()) if i < 3 and _varies(v)]
    for i, name in fields:
        cands.append(TermSpec(f"H{'xyz'[i]}", (name,)))
    for _i, name in fields:
        cands.append(TermSpec("Hsq", (name,)))
    for j, (_i, a) in enumerate(fields):
        for _k, b in fields[j + 1:]:
            cands.append(TermSpec("Hprod", (a, b)))
    if len(fields) >= 2:
        cands.append(TermSpec("Hmag2"))
    if frame.supply is not None and _varies(frame.supply):
        cands.append(TermSpec("V"))
        cands += [TermSpec(k, ("supply",)) for k in ("dchan", "chanlag")]
        if _curved(frame.supply):
            cands.append(TermSpec("chan2", ("supply",)))
    if frame.table_rate is not None and _varies(frame.table_rate):
        cands.append(TermSpec("rate"))
        for ch in temps:
            cands.append(TermSpec("rateT", (ch,)))
    accel, plain = [], []
    for name, v in frame.extra.items():
        if not _varies(v):
            continue
        if _G_PATTERN.search(name):
            accel.append(name)
            cands += [TermSpec("g", (name,)), TermSpec("g2", (name,))]
            continue
        plain.append(name)
        cands.append(TermSpec("chan", (name,)))
        if _curved(v):
            cands.append(TermSpec("chan2", (name,)))
        v = np.asarray(v, float)
        if np.min(v) < 0 < np.max(v):
            cands.append(TermSpec("chanabs", (name,)))
        cands += [TermSpec("dchan", (name,)), TermSpec("chanlag", (name,)),
                  TermSpec("dchanlag", (name,))]
    for j, a in enumerate(accel):
        for b in accel[j + 1:]:
            cands.append(TermSpec("gprod", (a, b)))
    # products of other channels (tilt, vibration axes, ...): pairs of the first few
    few = plain[:MAX_PRODUCT_CHANNELS]
    for j, a in enumerate(few):
        for b in few[j + 1:]:
            cands.append(TermSpec("chanprod", (a, b)))
    if frame.earth_dph is not None and _varies(frame.earth_dph):
        cands.append(TermSpec("earth"))
    cands += [TermSpec("ramp"), TermSpec("warmup"), TermSpec("sin")]
    out = []
    for c in cands:
        if c.label in have:
            continue
        if (c.key in ("ramp", "warmup", "sin", "V", "rate", "Hmag2", "earth")
                and c.key in keys_present):
            continue
        out.append(c)
    return out


def block_candidates(frame: EnvFrame, present: list[TermSpec]
                     ) -> list[tuple[TermSpec, list[str]]]:
    """Groups of terms that only explain the data together, tried when no single candidate
    does and the model is far above the floor: the field sensitivity along every axis
    (``Hvec``, when at most one of Hx, Hy, Hz is in the model) and the full second-order
    field sensitivity (``Hquad``), which a gyro not aligned with the coils needs (one
    rotated component mixes every coil axis), over the field components the run moves
    (range ≥ 5 % of the largest). Returns (spec, labels of the model's terms it replaces)
    pairs."""
    fields = {n: np.asarray(v, float) for i, (n, v) in enumerate(frame.field_uT.items())
              if i < 3 and _varies(v)}
    span = {n: float(np.ptp(v)) for n, v in fields.items()}
    # the components the run moves (a held coil shows only the magnetometer's noise)
    moving = tuple(n for n in fields if span[n] >= 0.05 * max(span.values(), default=0.0))
    if len(moving) < 2:
        return []
    keys = {s.key for s in present}
    out: list[tuple[TermSpec, list[str]]] = []
    lin = [s for s in present if s.key in ("Hx", "Hy", "Hz") and s.channels[0] in moving]
    if "Hvec" not in keys and len(lin) < len(moving):
        out.append((TermSpec("Hvec", moving), [s.label for s in lin]))
    if "Hquad" not in keys:
        out.append((TermSpec("Hquad", moving), [
            s.label for s in present if s.key in ("Hsq", "Hprod", "Hmag2")
            and all(c in moving for c in (s.channels or moving))]))
    return out


def stimulus_periods(frame: EnvFrame) -> dict[str, np.ndarray]:
    """Every varying channel (and its square: a symmetric sweep of H shows in H² at twice the
    frequency) as a zero-mean series on the frame's grid, for the period check of a fitted
    sinusoid (:func:`period_matches`)."""
    out = {}
    for name, (_g, v) in numeric_channels(frame).items():
        if not _varies(v):
            continue
        x = v - np.mean(v)
        out[name] = x
        x2 = x * x
        out[f"{name}²"] = x2 - np.mean(x2)
    return out


def period_matches(frame: EnvFrame, f_hz: float, min_r2: float = 0.1
                   ) -> list[tuple[str, float]]:
    """Every logged channel (or square, "name²") whose variation has the period 1/``f_hz``:
    the fraction of its variance a sinusoid at f explains, R² ≥ ``min_r2``; best first. A
    free-frequency sinusoid that matches a stimulus period may be that stimulus acting
    through a channel rather than a periodic disturbance."""
    t = frame.t
    w = 2 * np.pi * f_hz * t
    S = np.column_stack([np.cos(w), np.sin(w)])
    out = []
    for name, x in stimulus_periods(frame).items():
        v = float(x @ x)
        if v <= 0:
            continue
        b, *_ = np.linalg.lstsq(S, x, rcond=None)
        r2 = float(np.sum((S @ b) ** 2)) / v
        if r2 >= min_r2:
            out.append((name, r2))
    return sorted(out, key=lambda m: -m[1])
