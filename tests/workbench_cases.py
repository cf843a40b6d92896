"""The workbench cases of issue #9, written with plain numpy (not ``gyrotest.simulation``).

:func:`case` returns a :class:`Case`: the log, the base terms a user starts from, the true
model as term texts (custom expressions where the library has no term), and the term keys
that name each missing effect correctly. :func:`user_loop` runs the plain user loop
(diagnose, add the named effect, repeat).

(No tests here; imported by ``test_envmodel_workbench.py``.)
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from test_envmodel_helpers import make_log

from gyrotest.core.earth import Site, earth_rate_component
from gyrotest.envmodel.terms import first_order_lag, thermal_branch

HOUR = 3600.0


@dataclass
class Case:
    log: object
    base: list[str]
    true_terms: list[str]
    missing: list[set[str]]  # per missing effect: the keys that name it
    extra_ok: set[str] = field(default_factory=set)  # keys that may also be added
    white: float = 0.3  # the white noise N, (deg/h)·√s


def flicker(n: int, rng) -> np.ndarray:
    """Unit-variance 1/f noise by spectral shaping."""
    f = np.fft.rfftfreq(n)
    s = np.zeros_like(f)
    s[1:] = 1.0 / np.sqrt(f[1:])
    x = np.fft.irfft(s * (rng.normal(size=len(f)) + 1j * rng.normal(size=len(f))), n)
    return x / np.std(x)


def noise(n: int, rng, N: float = 0.3, B: float = 0.003) -> np.ndarray:
    """White (N (deg/h)·√s at 1 s) plus flicker noise, deg/h."""
    return N * rng.normal(size=n) + 1.3 * B * flicker(n, rng)


def chamber(t: np.ndarray) -> np.ndarray:
    kt = np.array([0, 0.5, 1.5, 2.0, 3.0, 3.5, 4.2, 5.0, 6.0, 7.0, 8.0]) * HOUR
    kT = np.array([20, 20, 45, 45, 25, 25, 38, 38, 30, 30, 22])
    return np.interp(t, kt, kT)


def helmholtz(n: int, axes=(0, 1, 2), dwell: int = 180) -> np.ndarray:
    """Coil field per axis (uT): one axis at a time steps through −300…+250 uT."""
    H = np.zeros((3, n))
    seq = np.arange(n) // dwell
    for k, ax in enumerate(axes):
        blk = (seq >= 10 + k * 40) & (seq < 10 + k * 40 + 36)
        lev = ((seq - (10 + k * 40)) % 12 - 6) * 50.0
        H[ax][blk] = lev[blk]
    return H


def case(name: str, seed: int = 1) -> Case:
    rng = np.random.default_rng(seed)
    if name == "warmup":  # supply steps + slow temperature term; warm-up missing
        n = int(6 * HOUR)
        t = np.arange(n) * 1.0
        T = 22 + 0.8 * np.sin(2 * np.pi * t / (5 * HOUR)) + 0.01 * rng.normal(size=n)
        V = np.where(t < 2 * HOUR, 15.0, np.where(t < 4 * HOUR, 14.0, 16.0))
        V = V + 0.002 * rng.normal(size=n)
        rate = (1.0 + 0.3 * (T - 22) + 0.2 * (V - 15) + 0.5 * np.exp(-t / 1500)
                + noise(n, rng))
        return Case(make_log(rate, 1.0, temps={"T_case": T}, supply=V), ["T(T_case)", "V"],
                    ["T(T_case)", "V", "warmup"], [{"warmup"}])
    if name == "hyhz":  # two magnetic sensitivities missing at once
        n = int(6 * HOUR)
        t = np.arange(n) * 1.0
        T = 22 + 0.3 * np.sin(2 * np.pi * t / (4 * HOUR))
        H = helmholtz(n) + np.array([20, 0, -45])[:, None] + 0.05 * rng.normal(size=(3, n))
        rate = 0.5 + 0.05 * (T - 22) - 0.47 * H[1] / 100 - 0.19 * H[2] / 100 + noise(n, rng)
        log = make_log(rate, 1.0, temps={"T_case": T},
                       field={"Hx": H[0], "Hy": H[1], "Hz": H[2]})
        return Case(log, ["T(T_case)"], ["T(T_case)", "Hy", "Hz"],
                    [{"Hy", "Hprod"}, {"Hz", "Hprod"}])
    if name == "lagcoil":  # D_T and D_Tdot on an unlogged coil lagging by 1500 s + hysteresis
        n = int(8 * HOUR)
        t = np.arange(n) * 1.0
        Tc = chamber(t) + 0.01 * rng.normal(size=n)
        coil = first_order_lag(chamber(t), t, 1500.0)
        dcoil = np.gradient(coil, 1.0) * HOUR
        rate = (1.0 + 0.1 * (coil - 30) + 0.3 * dcoil + 0.15 * thermal_branch(chamber(t), 3.0)
                + noise(n, rng, B=0.005))
        return Case(make_log(rate, 1.0, temps={"T_case": Tc}), ["T(T_case)"],
                    ["coil:lag(temp.T_case, 1500)", "coilrate:ddt(lag(temp.T_case, 1500))",
                     "hyst(T_case)"],
                    # beside T of the case, the coil's level names its rate exactly: the coil
                    # lags the case, so d(coil)/dt = (T_case − coil)/τ
                    [{"dTlagdt", "dchanlag", "Tlag", "chanlag"}, {"hyst"}],
                    extra_ok={"Tlag", "chanlag"})
    if name == "hmag2":  # effect proportional to |H|²
        n = int(6 * HOUR)
        seq = np.arange(n) // 180
        hx = np.where((seq >= 5) & (seq < 100),
                      (np.abs(((seq - 5) % 26) - 13) - 6.5) * 50.0, 0.0)
        H = np.vstack([hx + 19, np.zeros(n) + 2, np.zeros(n) - 45])
        H = H + 0.05 * rng.normal(size=(3, n))
        T = 22 + 0.3 * np.sin(2 * np.pi * np.arange(n) / (4 * HOUR))
        rate = 0.5 + 0.05 * (T - 22) + 0.2 * np.sum((H / 100) ** 2, axis=0) + noise(n, rng)
        log = make_log(rate, 1.0, temps={"T_case": T},
                       field={"Hx": H[0], "Hy": H[1], "Hz": H[2]})
        return Case(log, ["T(T_case)", "Hx"], ["T(T_case)", "Hx", "Hmag2"],
                    [{"Hsq", "Hmag2", "chan2"}])
    if name == "rh":  # humidity channel outside the library
        n = int(6 * HOUR)
        t = np.arange(n) * 1.0
        T = 22 + 0.5 * np.sin(2 * np.pi * t / (5 * HOUR))
        RH = np.interp(t, [0, 3600, 3700, 7200, 7300, 21600], [40, 40, 70, 70, 30, 30])
        RH = RH + 0.3 * rng.normal(size=n)
        rate = 0.5 + 0.05 * (T - 22) + 0.006 * RH + noise(n, rng)
        return Case(make_log(rate, 1.0, temps={"T_case": T}, extra={"RH_pct": RH}),
                    ["T(T_case)"], ["T(T_case)", "chan(RH_pct)"], [{"chan", "chan2"}])
    if name == "gxgy":  # anisoelastic cross term
        n = int(6 * HOUR)
        t = np.arange(n) * 1.0
        T = 22 + 0.3 * np.sin(2 * np.pi * t / (4 * HOUR))
        pos = np.arange(n) // 600
        a1, a2 = pos * np.pi / 7, pos * np.pi / 3.3
        gx = np.sin(a1) * np.cos(a2) + 0.001 * rng.normal(size=n)
        gy = np.cos(a1) * np.cos(a2) + 0.001 * rng.normal(size=n)
        rate = (0.5 + 0.05 * (T - 22) + 0.08 * gx + 0.03 * gy + 0.05 * gx * gy
                + noise(n, rng, N=0.1, B=0.002))
        log = make_log(rate, 1.0, temps={"T_case": T}, extra={"gx": gx, "gy": gy})
        return Case(log, ["T(T_case)"], ["T(T_case)", "g(gx)", "g(gy)", "gprod(gx,gy)"],
                    [{"g"}, {"g"}, {"gprod", "chanprod"}], white=0.1)
    if name == "tumble":  # IA turned through the meridian: earth rate, not g-sensitivity
        n = int(6 * HOUR)
        t = np.arange(n) * 1.0
        el = np.array([90, 60, 30, 0, -30, -60, -90, 0], float)[(np.arange(n) // 900) % 8]
        lat = 48.1
        T = 22 + 0.3 * np.sin(2 * np.pi * t / (4 * HOUR))
        rate = 0.5 + 0.05 * (T - 22) + earth_rate_component(lat, 0.0, el) + noise(n, rng)
        log = make_log(rate, 1.0, temps={"T_case": T},
                       extra={"acc_ia_g": np.sin(np.radians(el)) + 0.001 * rng.normal(size=n),
                              "ia_elevation_deg": el})
        log.site = Site(lat)
        return Case(log, ["T(T_case)"], ["T(T_case)", "earth"], [{"earth"}])
    if name == "null":  # complete model, an unrelated wandering channel
        n = int(6 * HOUR)
        t = np.arange(n) * 1.0
        Tc = chamber(t) + 0.01 * rng.normal(size=n)
        rate = 1.0 + 0.05 * (Tc - 30) + noise(n, rng, B=0.005)
        RH = 45 + np.cumsum(rng.normal(size=n)) * 0.01
        return Case(make_log(rate, 1.0, temps={"T_case": Tc}, extra={"RH_pct": RH}),
                    ["T(T_case)"], ["T(T_case)"], [])
    raise KeyError(name)


CASES = ["warmup", "hyhz", "lagcoil", "hmag2", "rh", "gxgy", "tumble", "null"]


def user_loop(wd, base: list[str], max_steps: int = 5):
    """diagnose → add the named effect (replacing what it replaces) → repeat. Returns
    (list of (Diagnosis, added TermSpec or None), final term specs)."""
    from gyrotest.envmodel.terms import parse_terms, resolve_terms
    from gyrotest.envmodel.workbench import diagnose

    specs = resolve_terms(parse_terms(base), wd.frame)
    steps = []
    removed: set[str] = set()
    for _ in range(max_steps):
        d = diagnose(wd, specs, path_steps=1)
        if not d.found:
            if d.remove is not None and d.remove.term not in removed:
                # "the data do not support X: remove it" -- the user removes it
                removed.add(d.remove.term)
                specs = [s for s in specs if s.label != d.remove.term]
                steps.append((d, None))
                continue
            steps.append((d, None))
            break
        top = d.found[0]
        gone = set(top.replaces.split("; ")) if top.replaces else set()
        specs = [s for s in specs if s.label not in gone] + [top.spec]
        steps.append((d, top.spec))
    return steps, specs
