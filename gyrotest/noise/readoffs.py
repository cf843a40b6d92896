"""Classic read-offs of an Allan deviation and the unit conversions of a noise fit.

* :func:`n_upper_bound`: a one-sided upper bound on N from the deviation alone;
* :func:`slope_readoffs`: the IEEE 952 Annex C slope read-offs (the straight-line values
  at the characteristic τ of each slope), the cross-check of the joint fit
  (:mod:`.noisefit`);
* :func:`conversions`: the fitted terms in the other units data sheets use (deg/√h,
  ppm, m/s/√h ...)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy import special

from .quantity import RATE, quantity_of
from .terms import (
    BIAS_INSTABILITY_PLATEAU,
)

if TYPE_CHECKING:
    from .fitresult import NoiseFit


#: family-wise level of Krobka's white-noise bound N_upper (:func:`slope_readoffs`)
N_UPPER_LEVEL = 0.95


def n_upper_bound(tau, sigma, edf, *, level: float = N_UPPER_LEVEL) -> tuple[float, float, int]:
    """Krobka's bound on white rate noise as a statistical upper limit: (N_upper deg/√h, the τ
    that sets it, the number of τ it was taken over).

    White rate noise N adds N²/τ to the Allan variance of any mixture of independent noises
    (Krobka (Allan-graph topology) eq. 5.9), so σ²(τ) ≥ N²/τ at every τ: the −½ ray through the
    leftmost point, lowered until it touches the graph. Read on the estimates σ̂(τ) this
    construction is biased low (at long τ a few clusters scatter σ̂ far below σ), so each
    σ̂(τ) is replaced by its one-sided upper confidence limit σ_U(τ) = σ̂·√(ν/χ²_ν(α/k)) from
    its EDF ν (σ̂²ν/σ² ~ χ²_ν, NIST SP1065 §5.3), at the Bonferroni level α/k over the k τ
    with an EDF: all k limits hold together with probability ≥ ``level`` = 1 − α, hence

        N_upper = min_τ σ_U(τ)·√τ / 60   deg/√h (σ in deg/h, τ in s)

    is an upper bound of N at that confidence. Without EDF it is the graph reading
    min σ̂√τ/60."""
    t = np.asarray(tau, float)
    s = np.asarray(sigma, float)
    ok = np.isfinite(t) & np.isfinite(s) & (s > 0) & (t > 0)
    if edf is None:
        v = np.where(ok, s * np.sqrt(t), np.inf)
        i = int(np.argmin(v))
        return float(v[i] / 60.0), float(t[i]), int(np.count_nonzero(ok))
    e = np.asarray(edf, float)
    ok &= np.isfinite(e) & (e > 0)
    k = int(np.count_nonzero(ok))
    if k == 0:
        return math.nan, math.nan, 0
    q = (1.0 - level) / k
    with np.errstate(invalid="ignore", divide="ignore"):
        chi = special.chdtri(np.where(ok, e, 1.0), 1.0 - q)  # lower q-quantile of χ²_ν
        s_up = s * np.sqrt(np.where(ok, e, 1.0) / chi)
    v = np.where(ok & np.isfinite(s_up), s_up * np.sqrt(t), np.inf)
    i = int(np.argmin(v))
    return float(v[i] / 60.0), float(t[i]), k


def slope_readoffs(tau, sigma, edf=None, *, min_edf: float = 10.0,
                   quantity: str = "rate") -> dict[str, Any]:
    """The slope-line read-offs other tools report, for comparison (not fits).

    Local log–log slope by central differences (MATLAB "allanvar" example; allan_variance_ros),
    searched only where the EDF ≥ ``min_edf`` (noisy slopes at long τ would otherwise win):

    * ``N_slope`` = σ(τ_i)·√τ_i/60 deg/√h at the point whose slope is closest to −½ (the −½ line
      through it read at τ = 1 s, /60 for deg/√h; IEEE 952 Annex C);
    * ``K_slope`` = 60·σ(τ_i)·√(3/τ_i) deg/h/√h at the slope closest to +½ (line read at τ = 3 s);
    * ``B_slope`` = σ(τ_i)/0.6643 deg/h at the slope closest to 0;
    * ``N_upper``: Krobka's bound on white rate noise, the −½ ray through the leftmost
      point lowered until it touches the graph (Krobka (Allan-graph topology) §5, rule 5),
      taken on the upper 95 % confidence limits of σ̂ (family-wise over the τ, from ``edf``;
      :func:`n_upper_bound`), so that it is an upper bound of N at 95 %; ``N_upper_graph`` =
      min σ̂√τ/60, the same construction on the estimates (biased low where few clusters
      scatter σ̂);
    * ``B_tangent`` = σ_min/0.6643 deg/h: the zero-slope tangent at the minimum with the
      IEEE factor (an upper bound in a mixture; Krobka (Allan-graph topology) M3/M4); ``allan_floor`` = σ_min and
      its τ (what tools that omit 0.664 report as B).

    The formulas are the gyro's (σ in deg/h); an accelerometer table (``quantity``
    "acceleration", σ in m/s²) gets N, K in its units and B in µg
    (:mod:`gyrotest.noise.quantity`).
    """
    q = quantity_of(quantity)
    fN, fK, fB = q.factor("N"), q.factor("K"), q.factor("B")
    t = np.asarray(tau, float)
    s = np.asarray(sigma, float)
    ok = np.isfinite(s) & (s > 0)
    e = np.full(t.shape, np.inf) if edf is None else np.asarray(edf, float)
    t, s, e = t[ok], s[ok], e[ok]
    out: dict[str, Any] = {"method": "slope-line read-offs (MATLAB allanvar example style, slopes "
                           f"only where EDF >= {min_edf:g}) and Krobka bounds; for comparison "
                           "only"}
    if t.size < 3:
        return out
    lt, ls = np.log(t), np.log(s)
    slope = np.gradient(ls, lt)
    rel = e >= min_edf
    if np.count_nonzero(rel) < 3:
        rel = np.ones_like(rel)
    big = np.where(rel, 0.0, np.inf)
    iN = int(np.argmin(np.abs(slope + 0.5) + big))
    iK = int(np.argmin(np.abs(slope - 0.5) + big))
    iB = int(np.argmin(np.abs(slope) + big))
    imin = int(np.argmin(s))
    n_graph, t_graph, _ = n_upper_bound(t, s, None)
    n_up, t_up, k_up = n_upper_bound(t, s, None if edf is None else e)
    out.update({
        "N_slope": float(s[iN] * math.sqrt(t[iN]) / 60.0) * fN, "N_slope_tau_s": float(t[iN]),
        "N_slope_local_slope": float(slope[iN]),
        "K_slope": float(60.0 * s[iK] * math.sqrt(3.0 / t[iK])) * fK,
        "K_slope_tau_s": float(t[iK]),
        "K_slope_local_slope": float(slope[iK]),
        "B_slope": float(s[iB] / BIAS_INSTABILITY_PLATEAU) * fB, "B_slope_tau_s": float(t[iB]),
        "N_upper": n_up * fN, "N_upper_tau_s": t_up,
        "N_upper_rule": (f"min over {k_up} τ of the one-sided upper confidence limit of σ (EDF, "
                         f"χ², Bonferroni) × √τ/60: {100 * N_UPPER_LEVEL:g} % upper bound of N"
                         if edf is not None else "min σ√τ/60 (graph reading, no EDF)"),
        "N_upper_graph": n_graph * fN, "N_upper_graph_tau_s": t_graph,
        "N_leftmost": float(s[0] * math.sqrt(t[0]) / 60.0) * fN, "leftmost_tau_s": float(t[0]),
        "B_tangent": float(s[imin] / BIAS_INSTABILITY_PLATEAU) * fB,
        "allan_floor": float(s[imin]), "allan_floor_tau_s": float(t[imin]),
        "units": {"N": q.unit("N"), "K": q.unit("K"), "B": q.unit("B"),
                  "allan_floor": q.sigma_unit},
    })
    if q is RATE:
        out["allan_floor_dph"] = out["allan_floor"]
    else:
        out["allan_floor_m_s2"] = out["allan_floor"]
    return out


_D2R = math.pi / 180.0


def conversions(fit: NoiseFit) -> dict[str, Any]:
    """Coefficients in the units and names of other tools (continuous-time convention).

    * N: deg/√h → deg/s/√Hz = N/60; rad/s/√Hz = N/60·π/180 (N_int/3600 deg/s·√s). Discrete
      per-sample σ at the log rate: N_c/√τ0 (Kalibr: σ_gd = σ_g/√Δt).
    * K: deg/h/√h → (deg/s)·√Hz = K/(60·3600); rad/s²/√Hz likewise ×π/180. Discrete per-sample
      bias-walk σ: K_c·√τ0 (Kalibr σ_bgd = σ_bg·√Δt).
    * B: deg/h → deg/s = B/3600, rad/s.
    * Kalibr ``gyroscope_noise_density`` = N [rad/s/√Hz], ``gyroscope_random_walk`` = K
      [rad/s²/√Hz] (ethz-asl/kalibr wiki "IMU-Noise-Model"); MATLAB ``gyroparams``
      ``NoiseDensity`` = N [(rad/s)/√Hz], ``BiasInstability`` = B [rad/s] (IEEE B, i.e. the
      floor/0.664), ``RandomWalk`` = K [(rad/s)·√Hz]. All are continuous-time densities of the
      two-sided IEEE PSD (white S = N²); upper-bound terms are exported at their bound.
    """
    def val(key):
        t = fit.term(key)
        if t is None:
            return None, None
        return (t.value if t.identified else t.upper), t.status

    if fit.quantity == "acceleration":
        return _accel_conversions(fit, val)
    N, Ns = val("N")
    K, Ks = val("K")
    B, Bs = val("B")
    tau0 = fit.tau0
    out: dict[str, Any] = {"convention": "continuous-time densities (two-sided IEEE 952 PSD: "
                           "white rate S = N^2); discrete per-sample sigma = density/sqrt(tau0) "
                           "for white noise, density*sqrt(tau0) for the bias random walk",
                           "tau0_s": tau0}
    if N is not None:
        nd = N / 60.0
        out["N"] = {"status": Ns, "deg_per_rt_h": N, "deg_s_per_rt_hz": nd,
                    "rad_s_per_rt_hz": nd * _D2R,
                    "discrete_sigma_deg_s": nd / math.sqrt(tau0),
                    "discrete_sigma_rad_s": nd * _D2R / math.sqrt(tau0)}
    if K is not None:
        kd = K / (60.0 * 3600.0)
        out["K"] = {"status": Ks, "deg_h_per_rt_h": K, "deg_s2_per_rt_hz": kd,
                    "rad_s2_per_rt_hz": kd * _D2R,
                    "discrete_sigma_rad_s": kd * _D2R * math.sqrt(tau0)}
    if B is not None:
        out["B"] = {"status": Bs, "deg_h": B, "deg_s": B / 3600.0, "rad_s": B / 3600.0 * _D2R}
    out["kalibr"] = {
        "gyroscope_noise_density": None if N is None else N / 60.0 * _D2R,
        "gyroscope_random_walk": None if K is None else K / (60.0 * 3600.0) * _D2R,
        "units": {"gyroscope_noise_density": "rad/s/sqrt(Hz)",
                  "gyroscope_random_walk": "rad/s^2/sqrt(Hz)"},
        "note": "Kalibr's update_rate must be the log rate 1/tau0; it derives the discrete "
                "sigma itself. The maintainers suggest inflating these for unmodelled effects.",
    }
    out["matlab_gyroparams"] = {
        "NoiseDensity": None if N is None else N / 60.0 * _D2R,
        "BiasInstability": None if B is None else B / 3600.0 * _D2R,
        "RandomWalk": None if K is None else K / (60.0 * 3600.0) * _D2R,
        "units": {"NoiseDensity": "(rad/s)/sqrt(Hz)", "BiasInstability": "rad/s",
                  "RandomWalk": "(rad/s)*sqrt(Hz)"},
    }
    return out


def _accel_conversions(fit: NoiseFit, val) -> dict[str, Any]:
    """:func:`conversions` of an accelerometer table (IEEE Std 1293 terms; N = VRW in m/s/√h,
    B in µg, K = acceleration random walk in m/s/h/√h):

    * VRW → m/s²/√Hz = N/60 (1 m/s/√h = 1/60 m/s/√s, and m/s/√s = (m/s²)/√Hz), µg/√Hz =
      that / 9.80665e-6; Kalibr ``accelerometer_noise_density`` (m/s²/√Hz), MATLAB
      ``accelparams.NoiseDensity`` ((m/s²)/√Hz); discrete per-sample σ = density/√τ0.
    * K → m/s³/√Hz = K/216000 (1 m/s/h/√h = 1/(3600·60) m/s²/√s); Kalibr
      ``accelerometer_random_walk`` (m/s³/√Hz), MATLAB ``accelparams.RandomWalk``
      ((m/s²)·√Hz); µg/√h = K/3600·60/9.80665e-6… as m/s²/√h: K/3600.
    * B (µg) → m/s² (MATLAB ``accelparams.BiasInstability``, IEEE B, the flat level/0.664).
    """
    from ..core.units import G0

    ug = G0 * 1e-6
    N, Ns = val("N")
    K, Ks = val("K")
    B, Bs = val("B")
    tau0 = fit.tau0
    out: dict[str, Any] = {"quantity": "acceleration",
                           "convention": "continuous-time densities (two-sided PSD: white "
                           "acceleration S = VRW^2); discrete per-sample sigma = "
                           "density/sqrt(tau0) for white noise, density*sqrt(tau0) for the "
                           "bias random walk", "tau0_s": tau0}
    if N is not None:
        nd = N / 60.0
        out["N"] = {"status": Ns, "m_s_per_rt_h": N, "m_s2_per_rt_hz": nd,
                    "ug_per_rt_hz": nd / ug, "discrete_sigma_m_s2": nd / math.sqrt(tau0)}
    if K is not None:
        kd = K / 216000.0
        out["K"] = {"status": Ks, "m_s_per_h_rt_h": K, "m_s3_per_rt_hz": kd,
                    "ug_per_rt_h": K / 3600.0 / ug,
                    "discrete_sigma_m_s2": kd * math.sqrt(tau0)}
    if B is not None:
        out["B"] = {"status": Bs, "ug": B, "m_s2": B * ug}
    out["kalibr"] = {
        "accelerometer_noise_density": None if N is None else N / 60.0,
        "accelerometer_random_walk": None if K is None else K / 216000.0,
        "units": {"accelerometer_noise_density": "m/s^2/sqrt(Hz)",
                  "accelerometer_random_walk": "m/s^3/sqrt(Hz)"},
        "note": "Kalibr's update_rate must be the log rate 1/tau0; it derives the discrete "
                "sigma itself. The maintainers suggest inflating these for unmodelled effects.",
    }
    out["matlab_accelparams"] = {
        "NoiseDensity": None if N is None else N / 60.0,
        "BiasInstability": None if B is None else B * ug,
        "RandomWalk": None if K is None else K / 216000.0,
        "units": {"NoiseDensity": "(m/s^2)/sqrt(Hz)", "BiasInstability": "m/s^2",
                  "RandomWalk": "(m/s^2)*sqrt(Hz)"},
    }
    return out
