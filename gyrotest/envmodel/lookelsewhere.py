"""Look-elsewhere corrections and the tests of the workbench verdict.

* :func:`family_p` -- each candidate's own p-value, corrected for its own search (Davies'
  bound), and its family-wise p-value over the step's candidates by a min-P parametric
  bootstrap of the noise the model leaves (Westfall & Young 1993);
* :func:`ljung_box` -- the whiteness test of a whitened residual ("nothing missing");
* :func:`chi2_logsf`, :func:`davies_log_p` -- χ² tails in logs, finite far out.

The step's tested directions come from :class:`gyrotest.envmodel.selection.Screen` (its
``groups``, ``owner``, ``Q``, ``r0``, ``rss0`` and ``m``).

Sources: R. B. Davies, Biometrika 74 (1987) 33–43; P. H. Westfall, S. S. Young,
*Resampling-Based Multiple Testing*, Wiley 1993; G. M. Ljung, G. E. P. Box, Biometrika 65
(1978) 297–303; M. Abramowitz, I. A. Stegun, *Handbook of Mathematical Functions* 6.5.32.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import special
from scipy import stats as sps

from .workbench_rules import ALPHA, MC_DRAWS, WHITE_LAGS


@dataclass
class Whiteness:
    """Ljung–Box test of the whitened residual (standardised innovations)."""

    q: float
    lags: int
    dof: int
    p: float

    @property
    def consistent(self) -> bool:
        return not (self.p < ALPHA)

    def to_dict(self) -> dict:
        return {"ljung_box_q": self.q, "lags": self.lags, "dof": self.dof, "p": self.p,
                "consistent": self.consistent}


def chi2_logsf(u, k):
    """ln P(χ²_k > u), finite far into the tail. k = 1: ln 2 + ln Φ(−√u) (the normal tail's
    log, stable); k = 2: −u/2 exactly; otherwise ln Q(k/2, u/2) (the regularised incomplete
    gamma function) and, where that underflows, the leading term of its asymptotic series
    (k/2 − 1)·ln(u/2) − u/2 − ln Γ(k/2) (Abramowitz & Stegun 6.5.32)."""
    u = np.maximum(np.asarray(u, float), 0.0)
    k = np.asarray(k, float)
    u, k = np.broadcast_arrays(u, k)
    out = np.empty(u.shape)
    one = k == 1
    two = k == 2
    rest = ~(one | two)
    out[one] = math.log(2.0) + special.log_ndtr(-np.sqrt(u[one]))
    out[two] = -0.5 * u[two]
    if np.any(rest):
        ur, kr = u[rest], k[rest]
        with np.errstate(divide="ignore"):
            q = np.log(special.gammaincc(kr / 2, ur / 2))
        bad = ~np.isfinite(q)
        q[bad] = ((kr[bad] / 2 - 1) * np.log(ur[bad] / 2) - ur[bad] / 2
                  - special.gammaln(kr[bad] / 2))
        out[rest] = q
    return out if out.ndim else float(out)


def davies_log_p(u: float, s: int, V: float) -> float:
    """ln of Davies' (1987) upper bound on P(sup_θ Λ(θ) > u) for a χ²_s process with total
    variation V of √Λ over the searched range; V = 0: the plain χ²_s tail."""
    u = max(float(u), 0.0)
    s = max(int(s), 1)
    a = float(chi2_logsf(u, s))
    if not V > 0 or u <= 0:
        return a
    b = (math.log(V) + 0.5 * (s - 1) * math.log(u) - 0.5 * u - 0.5 * s * math.log(2.0)
         - float(special.gammaln(0.5 * s)))
    return float(min(0.0, np.logaddexp(a, b)))


def total_variation(vals: list[float]) -> float:
    """Total variation of √Λ along a searched grid (the V of :func:`davies_log_p`)."""
    r = np.sqrt(np.maximum(np.asarray(vals, float), 0.0))
    return float(np.sum(np.abs(np.diff(r)))) if len(r) > 1 else 0.0


def ljung_box(e: np.ndarray, lags: int = WHITE_LAGS, fitted: int = 2) -> Whiteness:
    """Ljung & Box (1978): Q = m(m+2)·Σ_{k≤h} ρ_k²/(m−k) ~ χ²_{h−fitted} for white e."""
    e = np.asarray(e, float)
    m = len(e)
    h = int(max(1, min(lags, m // 5)))
    e = e - e.mean()
    d = float(e @ e)
    if m < 10 or d <= 0:
        return Whiteness(math.nan, h, 0, math.nan)
    rho = np.array([float(e[k:] @ e[:-k]) / d for k in range(1, h + 1)])
    q = float(m * (m + 2) * np.sum(rho ** 2 / (m - np.arange(1, h + 1))))
    dof = max(1, h - fitted)
    return Whiteness(q, h, dof, float(sps.chi2.sf(q, dof)))


#: seed of the min-P bootstrap's draws (the verdict is reproducible)
MC_SEED = 952


def _group_lr(sc, R: np.ndarray, rss0: np.ndarray) -> np.ndarray:
    """Λ of every tested direction (rows) for whitened residuals ``R`` (columns), σ²
    profiled: m·ln(RSS₀/(RSS₀ − ‖Q_gᵀR‖²))."""
    sizes = np.array([g.shape[1] for g in sc.groups])
    starts = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    Q = np.concatenate(sc.groups, axis=1)
    G = Q.T @ R
    gain = np.add.reduceat(G * G, starts, axis=0)
    return sc.m * np.log(rss0 / np.maximum(rss0 - gain, 1e-300 * rss0))


def _candidate_stats(sc, lam: np.ndarray, n_cand: int) -> np.ndarray:
    """Each candidate's search-corrected ln p for each column of ``lam`` (groups × draws):
    Davies' (1987) bound from its largest Λ over its searched values and the total variation
    of √Λ along them (a candidate without a search: its χ² tail). NaN rows: untested."""
    sizes = np.array([g.shape[1] for g in sc.groups])
    owner = np.array(sc.owner)
    out = np.full((n_cand, lam.shape[1]), np.nan)
    for i in range(n_cand):
        rows = np.flatnonzero(owner == i)
        if not len(rows):
            continue
        L = lam[rows]
        k = int(np.max(sizes[rows]))
        top = np.max(L, axis=0)
        if len(rows) > 1:
            V = np.sum(np.abs(np.diff(np.sqrt(np.maximum(L, 0.0)), axis=0)), axis=0)
        else:
            V = np.zeros(L.shape[1])
        out[i] = _davies_vec(top, k, V)
    return out


def _davies_vec(u: np.ndarray, s: int, V: np.ndarray) -> np.ndarray:
    """Vectorised :func:`davies_log_p` (ln of the bound, at most 0)."""
    u = np.maximum(np.asarray(u, float), 0.0)
    a = np.asarray(chi2_logsf(u, s), float)
    with np.errstate(divide="ignore", invalid="ignore"):
        b = (np.log(V) + 0.5 * (s - 1) * np.log(np.maximum(u, 1e-300)) - 0.5 * u
             - 0.5 * s * math.log(2.0) - float(special.gammaln(0.5 * s)))
    b = np.where((V > 0) & (u > 0), b, -np.inf)
    return np.minimum(0.0, np.logaddexp(a, b))


def family_p(sc, n_cand: int, draws: int = MC_DRAWS
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each candidate's own p-value and its family-wise p-value over the step.

    Every direction the step tested (each candidate at each searched value: orthonormal
    columns outside the model's span, :attr:`Screen.groups`) has a likelihood ratio
    Λ_g = m·ln(RSS₀/RSS_g). A candidate's own p-value corrects for its own search: Davies'
    (1987) bound P(χ²_k > u) + V·u^{(k−1)/2}·e^{−u/2}·2^{−k/2}/Γ(k/2) with u its largest Λ
    and V the total variation of √Λ over its searched time constants, frequencies or widths
    (no search: the χ²_k tail). So every candidate carries the same weight, whatever the
    size of its search. The family-wise p-value corrects for the step's candidates with
    their correlations: under "nothing missing" the whitened residual is white noise
    projected off the model's span, so drawing such noise (:data:`MC_DRAWS` draws, fixed
    seed) and computing every candidate's own p on each draw gives the distribution of the
    step's smallest own p; a candidate's family-wise p is the fraction of draws at or below
    its own (Westfall & Young 1993, single-step min-P). Returns (ln own p, family-wise p)
    per candidate (NaN: untested) and the sorted null minima (:func:`family_null`)."""
    local = np.full(n_cand, np.nan)
    p_fw = np.full(n_cand, np.nan)
    if not sc.groups:
        return local, p_fw, np.zeros(0)
    obs = _candidate_stats(sc, _group_lr(sc, sc.r0[:, None], np.array([sc.rss0])), n_cand)
    local = obs[:, 0]
    sim = family_null(sc, n_cand, draws)
    for i in range(n_cand):
        p_fw[i] = p_from_null(sim, local[i])
    return local, p_fw, sim


def family_null(sc, n_cand: int, draws: int = MC_DRAWS) -> np.ndarray:
    """The null distribution (sorted) of the step's smallest candidate ln p (the min-P
    parametric bootstrap of :func:`family_p`)."""
    if not sc.groups:
        return np.zeros(0)
    rng = np.random.default_rng(MC_SEED)
    E = rng.standard_normal((sc.m, draws))
    E -= sc.Q @ (sc.Q.T @ E)
    rss0 = np.sum(E * E, axis=0)
    stats_ = _candidate_stats(sc, _group_lr(sc, E, rss0), n_cand)
    sim = np.nanmin(stats_, axis=0)
    sim.sort()
    return sim


def p_from_null(sim: np.ndarray, log_p: float) -> float:
    """Family-wise p of a candidate ln p against the sorted null minima (:func:`family_null`)."""
    if not len(sim) or not math.isfinite(log_p):
        return math.nan
    n_le = int(np.searchsorted(sim, log_p + 1e-12, side="right"))
    return (1.0 + n_le) / (len(sim) + 1.0)


__all__ = ["MC_SEED", "Whiteness", "chi2_logsf", "davies_log_p", "family_null", "family_p",
           "ljung_box", "p_from_null", "total_variation"]
