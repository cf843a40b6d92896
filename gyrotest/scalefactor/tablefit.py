"""Least-squares fits of rate-table points (IEEE 952 §12.9.4.1, §12.9.4.2, §8.3 ε_K).

Notation (all rates in deg/h; 1 deg/h = 1 arcsec/s):

* I — inertial input along the IA = table rate + earth-rate component Ω_IA;
* y — plateau mean of the log's rate = S0 × native output (S0·ΔN/Δt or S0·V, §8.3);
* FS — full-scale input (largest |I| tested unless given); u = I/FS.

The IEEE 952 model equation ``S0·out = (I + D)·(1 + 1e-6 ε_K)⁻¹`` with
``ε_K = ε_0 + f(I)`` gives, to first order in ε,

    y = b + k·I − k·I·1e-6·Σ_j e_j g_j(I)

with k = 1/(1 + 1e-6 ε_0) the output-per-input slope, b = k·D the output at zero input, and
the rate-dependent scale-factor error ``f(I) = Σ_j e_j g_j(I)`` in ppm. The shapes g_j are
the model terms (:data:`TERMS`); each coefficient e_j is in ppm of scale factor (for the power
terms: at full scale). Several runs share the nonlinearity terms and have their own b_r, k_r
(run-to-run scale-factor and bias changes). The scale factor in the log's own units is
``SF = S0/k`` (arcsec/pulse, (deg/h)/V; S0 = 1 for rate output): input per unit output, the
convention of the model equation.

Fits are weighted least squares with weights 1/SE² from the plateau standard errors (or
unweighted, the IEEE default, with the uncertainty from the residual scatter). Model terms
are chosen by forward selection: at each step the candidate with the lowest AICc is added if
its F-test p-value, Bonferroni-corrected over the candidates of the step (and over the trial
periods for the periodic term), is below ``alpha`` and it lowers AICc.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy import stats

from ..core.errors import AnalysisError

DPS = 3600.0


@dataclass(frozen=True)
class Term:
    """A scale-factor error shape g(I) of the model equation's f(I) (ppm)."""

    name: str
    formula: str  # f(I) contribution, e.g. "e·(I/FS)"
    output_form: str  # what it adds to the output, e.g. "∝ I²"
    parity: str  # of the output term: "even" or "odd"
    g: Callable[[np.ndarray], np.ndarray] | None  # of u = I/FS; None for periodic
    min_points: int  # distinct inputs needed


def _lockin_g(u: np.ndarray) -> np.ndarray:
    out = np.zeros_like(u)
    nz = u != 0
    out[nz] = 1.0 / (u[nz] * u[nz])
    return out


#: Candidate nonlinearity terms of f(I), in the order they are offered (and listed). Each
#: power term is named once, by its power k of u = I/FS in f(I) (the scale-factor error
#: ε_K): ``u1`` … ``u4``, coefficient c_k (ppm at full scale); its effect on the output
#: I·f(I) is ∝ I^(k+1) (u1 "quadratic", u2 "cubic" in the output: said once, in
#: ``output_form``). The coefficient names follow the simulator and GYRO_REFERENCE §1:
#: asymmetry A, c_k for (I/FS)^k, periodic amplitude p, Adler lock-in coefficient
#: e_L = ½(Ω_L/FS)²·1e6.
TERMS: dict[str, Term] = {
    "asymmetry": Term("asymmetry", "(A/2)·sgn(I)", "∝ |I| (SF+ ≠ SF−)", "even",
                      lambda u: 0.5 * np.sign(u), 3),
    "u1": Term("u1", "c1·u", "∝ I²", "even", lambda u: u, 4),
    "u2": Term("u2", "c2·u²", "∝ I³", "odd", lambda u: u * u, 5),
    "u3": Term("u3", "c3·u³", "∝ I⁴", "even", lambda u: u ** 3, 6),
    "u4": Term("u4", "c4·u⁴", "∝ I⁵", "odd", lambda u: u ** 4, 7),
    "lockin": Term("lockin", "e_L·(FS/I)² (Adler: Ω_L = FS·√(2e_L·1e-6))",
                   "I·√(1 − Ω_L²/I²) − I", "odd", _lockin_g, 4),
    "periodic": Term("periodic", "p·sin(2πI/P + φ)", "∝ I·sin(2πI/P + φ)",
                     "mixed", None, 8),
}


#: The earlier names of the power terms (by the output power), accepted as input
#: (``--terms``, campaign files, older ``scale-factor --json`` documents) and mapped to the
#: one name; never printed.
TERM_ALIASES = {"quadratic": "u1", "cubic": "u2", "quartic": "u3", "quintic": "u4"}

#: The same names typeset (sheet tables, figure legends): u¹ … u⁴ for u1 … u4.
TERM_LABELS = {"u1": "u¹", "u2": "u²", "u3": "u³", "u4": "u⁴",
               "asymmetry": "asymmetry A", "periodic": "periodic", "lockin": "lock-in"}
#: the same, short (figure legends and bar labels)
TERM_SHORT = {**TERM_LABELS, "asymmetry": "A"}
#: once, beside a list of the terms: what a power term does to the output
OUTPUT_POWER_NOTE = ("u = I/FS; the term c_k·u^k of f(I) adds ∝ I^(k+1) to the output error "
                     "I·f(I): u1 quadratic, u2 cubic")


def canonical_terms(names) -> list[str]:
    """Term names as given (``u2``, or an earlier name such as ``cubic``) → the one name."""
    return [TERM_ALIASES.get(str(n).strip().lower(), str(n).strip()) for n in names]


def term_order(name: str) -> int:
    """Position of a term in :data:`TERMS` (the order every list of terms is shown in)."""
    return list(TERMS).index(name) if name in TERMS else len(TERMS)


#: A higher power term is only offered together with the lower one of the same parity.
HIERARCHY = {"u3": "u1", "u4": "u2"}


# ----------------------------------------------------------------------------- data
@dataclass
class Points:
    """Rate-table points as arrays (one entry per plateau, all runs)."""

    I: np.ndarray  # input rate, deg/h (table + earth)
    y: np.ndarray  # mean output, deg/h (S0 × native)
    se: np.ndarray  # standard error of y, deg/h (NaN: unknown)
    run: np.ndarray  # run index 0..R-1
    runs: list[str]
    table: np.ndarray | None = None  # table rate, deg/h
    sweep: np.ndarray | None = None
    t: np.ndarray | None = None  # window mid-time, s
    temp: np.ndarray | None = None  # degC

    @property
    def n(self) -> int:
        return len(self.I)

    def subset(self, mask: np.ndarray) -> Points:
        def cut(a):
            return None if a is None else a[mask]

        return Points(self.I[mask], self.y[mask], self.se[mask], self.run[mask], self.runs,
                      cut(self.table), cut(self.sweep), cut(self.t), cut(self.temp))

    @property
    def weighted(self) -> bool:
        return bool(np.all(np.isfinite(self.se)) and np.all(self.se > 0))


# ----------------------------------------------------------------------------- WLS
@dataclass
class WLS:
    coef: np.ndarray
    cov: np.ndarray  # covariance of coef (from the SEs; scaled by χ²/dof when unweighted)
    resid: np.ndarray  # y − X·coef
    chi2: float  # Σ (resid/SE)² (unweighted: Σ resid²)
    dof: int
    weighted: bool

    @property
    def chi2_per_dof(self) -> float:
        return self.chi2 / self.dof if self.dof > 0 else math.nan


def wls(X: np.ndarray, y: np.ndarray, se: np.ndarray | None = None) -> WLS:
    """Weighted least squares ``min Σ ((y − Xβ)/SE)²`` by QR on column-scaled, whitened data.

    Returns β, its covariance (XᵀWX)⁻¹ — or, without SEs, s²(XᵀX)⁻¹ with s² = RSS/dof —,
    the residuals, χ² and dof. Raises :class:`AnalysisError` when X is rank deficient.
    """
    n, p = X.shape
    if n < p:
        raise AnalysisError(f"{n} points cannot determine {p} parameters; use more input rates "
                            "or fewer terms")
    weighted = se is not None
    w = 1.0 / se if weighted else np.ones(n)
    A = X * w[:, None]
    b = y * w
    s = np.sqrt(np.sum(A * A, axis=0))
    s[s == 0] = 1.0
    Q, R = np.linalg.qr(A / s)
    d = np.abs(np.diag(R))
    if p and (d.min() <= 1e-10 * d.max()):
        raise AnalysisError("the points cannot separate the model terms (rank-deficient fit); "
                            "use more distinct input rates or fewer terms")
    Rinv = np.linalg.inv(R)  # p is small (a few runs + terms)
    coef_s = Rinv @ (Q.T @ b)
    cov = (Rinv @ Rinv.T) / np.outer(s, s)
    coef = coef_s / s
    resid = y - X @ coef
    chi2 = float(np.sum((resid * w) ** 2))
    dof = n - p
    if not weighted:
        cov = cov * (chi2 / dof if dof > 0 else math.nan)
    return WLS(coef, cov, resid, chi2, dof, weighted)


def aicc(chi2: float, n: int, p: int) -> float:
    """Corrected Akaike criterion for a least-squares fit with known errors:
    ``AICc = χ² + 2p + 2p(p+1)/(n−p−1)`` (∞ when n ≤ p+1)."""
    if n - p - 1 <= 0:
        return math.inf
    return chi2 + 2 * p + 2 * p * (p + 1) / (n - p - 1)


def f_test(chi2_0: float, dof_0: int, chi2_1: float, dof_1: int) -> float:
    """p-value of the extra-sum-of-squares F-test of a nested model (1) against (0):
    ``F = ((χ²₀ − χ²₁)/(ν₀ − ν₁)) / (χ²₁/ν₁)``; robust to a common error in the SE scale."""
    dp = dof_0 - dof_1
    if dp <= 0 or dof_1 <= 0 or chi2_1 <= 0:
        return math.nan
    F = ((chi2_0 - chi2_1) / dp) / (chi2_1 / dof_1)
    return float(stats.f.sf(F, dp, dof_1)) if F > 0 else 1.0


# ----------------------------------------------------------------------------- model
def adler(I: np.ndarray, lock_dph: float | None) -> np.ndarray:
    """Ring-laser lock-in (Adler): ``sgn(I)·√(I² − Ω_L²)`` for |I| > Ω_L, else 0 (deg/h)."""
    I = np.asarray(I, dtype=float)
    if not lock_dph:
        return I
    return np.sign(I) * np.sqrt(np.maximum(I * I - lock_dph * lock_dph, 0.0))


#: Terms that add no column but a nonlinear parameter (scanned): the lock-in rate Ω_L
#: transforms the input, the periodic term's period P.
NONLINEAR_PARAMS = {"lockin": 1, "periodic": 1}


@dataclass
class ModelFit:
    """A fit of y = b_r + k_r·I' − k̄·I'·1e-6·Σ e_j g_j(I') over all runs, with
    I' = I, or the Adler transform of I when a lock-in rate is fitted."""

    terms: list[str]
    period_dps: float | None
    fs_dph: float
    kref: float
    wls: WLS
    n_runs: int
    n: int
    rms_ppm_fs: float  # unweighted RMS of the residuals, ppm of full-scale output
    lockin_dph: float | None = None
    lockin_sigma_dph: float = math.nan

    @property
    def p(self) -> int:
        """Number of fitted parameters, the scanned nonlinear ones included."""
        return len(self.wls.coef) + sum(NONLINEAR_PARAMS.get(t, 0) for t in self.terms)

    @property
    def aicc(self) -> float:
        return aicc(self.wls.chi2, self.n, self.p)

    @property
    def dof(self) -> int:
        return self.n - self.p

    def bias(self, r: int) -> tuple[float, float]:
        return float(self.wls.coef[r]), float(math.sqrt(self.wls.cov[r, r]))

    def slope(self, r: int) -> tuple[float, float]:
        j = self.n_runs + r
        return float(self.wls.coef[j]), float(math.sqrt(self.wls.cov[j, j]))

    def term_index(self) -> dict[str, list[int]]:
        out: dict[str, list[int]] = {}
        j = 2 * self.n_runs
        for t in self.terms:
            if t == "lockin":
                continue
            w = 2 if t == "periodic" else 1
            out[t] = list(range(j, j + w))
            j += w
        return out

    def term_coef(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        if name == "lockin":
            L = self.lockin_dph or 0.0
            e = 0.5 * (L / self.fs_dph) ** 2 * 1e6
            se = (L / self.fs_dph ** 2) * self.lockin_sigma_dph * 1e6
            return np.array([e]), np.array([[se * se]])
        idx = self.term_index()[name]
        return self.wls.coef[idx], self.wls.cov[np.ix_(idx, idx)]

    def _f_cols(self, Ie: np.ndarray) -> np.ndarray:
        u = Ie / self.fs_dph
        f = np.zeros_like(u)
        for t, idx in self.term_index().items():
            c = self.wls.coef[idx]
            if t == "periodic":
                ph = 2 * math.pi * Ie / DPS / self.period_dps
                f = f + c[0] * np.sin(ph) + c[1] * np.cos(ph)
            else:
                f = f + c[0] * TERMS[t].g(u)
        return f

    def nonlinear_output(self, I_dph: np.ndarray) -> np.ndarray:
        """Model output minus its linear part k̄·I, deg/h (for k̄ = the reference slope)."""
        I_dph = np.asarray(I_dph, dtype=float)
        Ie = adler(I_dph, self.lockin_dph)
        return self.kref * (Ie * (1.0 - 1e-6 * self._f_cols(Ie)) - I_dph)

    def f_ppm(self, I_dph: np.ndarray) -> np.ndarray:
        """Rate-dependent scale-factor error f(I) of the fitted terms, ppm (IEEE 952 §8.3):
        output = k·I/(1 + 1e-6 f(I)) ⇒ f = (I/(output/k) − 1)·1e6 (NaN inside a dead band)."""
        I_dph = np.asarray(I_dph, dtype=float)
        if not self.lockin_dph:
            return self._f_cols(I_dph)
        out = I_dph + self.nonlinear_output(I_dph) / self.kref
        with np.errstate(divide="ignore", invalid="ignore"):
            f = (I_dph / out - 1.0) * 1e6
        return np.where(np.abs(I_dph) > self.lockin_dph, f, np.nan)


def design(P: Points, terms: list[str], fs: float, kref: float,
           period_dps: float | None = None, lockin_dph: float | None = None) -> np.ndarray:
    """Design matrix: run intercepts, run slopes (of I'), then −k̄·I'·1e-6·g_j(I') per term;
    I' = the Adler transform of I when ``lockin_dph`` is given."""
    R = len(P.runs)
    Ie = adler(P.I, lockin_dph)
    cols = [(P.run == r).astype(float) for r in range(R)]
    cols += [np.where(P.run == r, Ie, 0.0) for r in range(R)]
    u = Ie / fs
    for t in terms:
        if t == "lockin":
            continue
        if t == "periodic":
            ph = 2 * math.pi * Ie / DPS / period_dps
            cols += [-kref * Ie * 1e-6 * np.sin(ph), -kref * Ie * 1e-6 * np.cos(ph)]
        else:
            cols.append(-kref * Ie * 1e-6 * TERMS[t].g(u))
    return np.column_stack(cols)


def fit_model(P: Points, terms: list[str], fs: float, kref: float, *,
              period_dps: float | None = None, lockin_dph: float | None = None,
              weighted: bool = True) -> ModelFit:
    """Least-squares fit of the model with the given nonlinearity ``terms`` (see module doc);
    ``period_dps`` / ``lockin_dph`` fix the nonlinear parameters of those terms."""
    if "lockin" in terms and not lockin_dph:
        raise AnalysisError("the lock-in term needs a lock-in rate")
    X = design(P, terms, fs, kref, period_dps, lockin_dph if "lockin" in terms else None)
    se = P.se if (weighted and P.weighted) else None
    res = wls(X, P.y, se)
    k = np.array([res.coef[len(P.runs) + r] for r in range(len(P.runs))])
    rms = float(np.sqrt(np.mean((res.resid / (k[P.run] * fs)) ** 2))) * 1e6
    return ModelFit(list(terms), period_dps if "periodic" in terms else None, fs, kref, res,
                    len(P.runs), P.n, rms, lockin_dph if "lockin" in terms else None)


def scan_lockin(P: Points, base: ModelFit, fs: float, kref: float, *,
                weighted: bool = True) -> ModelFit | None:
    """Fit the lock-in rate Ω_L of the Adler transform (ring-laser dead band) added to
    ``base``: χ²(Ω_L) on a log grid below the smallest non-zero |I|, refined by bounded
    minimisation; σ(Ω_L) from the curvature of χ² (Δχ² = 1, × χ²/dof when that exceeds 1).
    Returns None when there are no low rates to constrain it."""
    from scipy.optimize import minimize_scalar

    nz = np.abs(P.I[np.abs(P.table if P.table is not None else P.I) > 0])
    if len(nz) < 3:
        return None
    imin = float(nz.min())
    terms = [t for t in base.terms if t != "lockin"] + ["lockin"]

    def chi(L: float) -> float:
        try:
            return fit_model(P, terms, fs, kref, period_dps=base.period_dps, lockin_dph=L,
                             weighted=weighted).wls.chi2
        except AnalysisError:
            return math.inf

    grid = imin * np.geomspace(1e-6, 0.999, 50)
    vals = np.array([chi(L) for L in grid])
    j = int(np.argmin(vals))
    lo, hi = grid[max(j - 1, 0)], grid[min(j + 1, len(grid) - 1)]
    if hi > lo:
        r = minimize_scalar(chi, bounds=(lo, hi), method="bounded",
                            options={"xatol": 1e-6 * imin})
        L = float(r.x) if r.fun <= vals[j] else float(grid[j])
    else:
        L = float(grid[j])
    fit = fit_model(P, terms, fs, kref, period_dps=base.period_dps, lockin_dph=L,
                    weighted=weighted)
    h = max(1e-4 * L, 1e-9)
    c0, cp, cm = fit.wls.chi2, chi(L + h), chi(max(L - h, 0.0))
    curv = (cp - 2 * c0 + cm) / (h * h)
    if curv > 0 and math.isfinite(curv):
        s = math.sqrt(2.0 / curv)
        if fit.wls.dof > 0:
            s *= math.sqrt(max(1.0, c0 / (fit.wls.dof - 1) if fit.wls.dof > 1 else 1.0))
        fit.lockin_sigma_dph = s
    return fit


def line_fit(I: np.ndarray, y: np.ndarray, se: np.ndarray | None) -> WLS:
    """Straight line y = b + k·I by (weighted) least squares (IEEE 952 §12.9.4.1)."""
    X = np.column_stack([np.ones_like(I), I])
    return wls(X, y, se)


def ieee_line(I: np.ndarray, y: np.ndarray, se: np.ndarray | None, *,
              weighted: bool = False) -> WLS:
    """The IEEE 952 §12.9.4.1 least-squares straight line y = b + k·I of output vs input.

    Unweighted by default (the standard's method; weighting is an "alternate method"): the
    line is then a fixed linear estimator β = (XᵀX)⁻¹Xᵀy and its covariance is the plateau
    SEs propagated through it, ``(XᵀX)⁻¹ Xᵀ diag(SE²) X (XᵀX)⁻¹`` — the deviation of the
    points from the line (nonlinearity) is part of the definition, not noise. Without SEs,
    s²(XᵀX)⁻¹. ``weighted=True``: 1/SE² weights, covariance × max(1, χ²/dof).
    """
    X = np.column_stack([np.ones_like(I), I])
    have = se is not None and np.all(np.isfinite(se)) and np.all(se > 0)
    if weighted and have:
        f = wls(X, y, se)
        f.cov = f.cov * max(1.0, f.chi2_per_dof if f.dof > 0 else 1.0)
        return f
    f = wls(X, y, None)
    if have:
        xs = I.std() or 1.0
        Xs = np.column_stack([np.ones_like(I), (I - I.mean()) / xs])
        A = np.linalg.inv(Xs.T @ Xs) @ Xs.T  # β_s = A·y
        cov_s = (A * se ** 2) @ A.T
        T = np.array([[1.0, -I.mean() / xs], [0.0, 1.0 / xs]])  # β = T·β_s
        f.cov = T @ cov_s @ T.T
    return f


# ----------------------------------------------------------------------------- periodic
def scan_periodic(P: Points, terms: list[str], fs: float, kref: float, *, weighted: bool = True,
                  base: ModelFit | None = None, max_trials: int = 4000
                  ) -> tuple[ModelFit | None, float, int]:
    """Search the period P (deg/s) of a rate-periodic scale-factor error
    ``a·sin(2πI/P) + c·cos(2πI/P)`` (ppm; optical feedback, IEEE 952 §5.3.2.1 a) added to
    ``terms``. Frequencies 1/P from 1/span to 1/(2·smallest spacing of the distinct inputs),
    oversampled ×5. Returns (best fit, raw F-test p-value, number of independent trials
    M = (f_max − f_min)·span for the look-elsewhere correction p·M)."""
    x = np.unique(np.round(P.I / DPS, 9))
    if len(x) < 4:
        return None, math.nan, 0
    span = float(x[-1] - x[0])
    dx = np.diff(x)
    dmin = float(np.min(dx[dx > 0])) if np.any(dx > 0) else span
    fmin, fmax = 1.0 / span, 1.0 / (2.0 * dmin)
    if fmax <= fmin:
        return None, math.nan, 0
    m_eff = max(1, int(math.ceil((fmax - fmin) * span)))
    nf = min(max_trials, 5 * m_eff + 1)
    freqs = np.linspace(fmin, fmax, nf)
    base = base or fit_model(P, terms, fs, kref, weighted=weighted)
    L = base.lockin_dph
    X0 = design(P, terms, fs, kref, None, L)
    Ie = adler(P.I, L)
    se = P.se if (weighted and P.weighted) else None
    w = 1.0 / se if se is not None else np.ones(P.n)
    # all trial frequencies at once: project the sin/cos columns off the base model's column
    # space and get each frequency's χ² reduction from a 2×2 least-squares problem
    A0 = X0 * w[:, None]
    sc0 = np.sqrt(np.sum(A0 * A0, axis=0))
    sc0[sc0 == 0] = 1.0
    Q0, _ = np.linalg.qr(A0 / sc0)
    r0 = P.y * w
    r0 = r0 - Q0 @ (Q0.T @ r0)
    amp = (-kref * Ie * 1e-6 * w)[:, None]
    ph = 2 * math.pi * np.outer(Ie / DPS, freqs)
    S = amp * np.sin(ph)
    C = amp * np.cos(ph)
    S -= Q0 @ (Q0.T @ S)
    C -= Q0 @ (Q0.T @ C)
    ss, cc, sc = np.sum(S * S, 0), np.sum(C * C, 0), np.sum(S * C, 0)
    sr, cr = S.T @ r0, C.T @ r0
    det = ss * cc - sc * sc
    with np.errstate(divide="ignore", invalid="ignore"):
        gain = (cc * sr * sr - 2 * sc * sr * cr + ss * cr * cr) / det
    gain[~np.isfinite(gain) | (det <= 1e-12 * np.maximum(ss * cc, 1e-300))] = -np.inf
    best = (None, float(freqs[int(np.argmax(gain))]))
    try:
        fit = fit_model(P, terms + ["periodic"], fs, kref, period_dps=1.0 / best[1],
                        lockin_dph=L, weighted=weighted)
        fit.lockin_sigma_dph = base.lockin_sigma_dph
    except AnalysisError:
        return None, math.nan, m_eff
    p = f_test(base.wls.chi2, base.dof, fit.wls.chi2, fit.dof)
    return fit, p, m_eff


# ----------------------------------------------------------------------------- selection
@dataclass
class ModelStep:
    """One row of the model history: what adding a term does to the misfit."""

    terms: list[str]
    added: str
    n_params: int
    chi2: float
    dof: int
    rms_ppm_fs: float
    aicc: float
    delta_aicc: float
    p_value: float  # F-test against the previous accepted model (corrected)
    accepted: bool
    note: str = ""

    @property
    def chi2_per_dof(self) -> float:
        return self.chi2 / self.dof if self.dof > 0 else math.nan

    def to_dict(self) -> dict:
        return {"terms": self.terms, "added": self.added, "n_params": self.n_params,
                "chi2": self.chi2, "dof": self.dof, "chi2_per_dof": self.chi2_per_dof,
                "residual_rms_ppm_fs": self.rms_ppm_fs, "aicc": self.aicc,
                "delta_aicc": self.delta_aicc, "f_test_p": self.p_value,
                "accepted": self.accepted, "note": self.note}


def applicable_terms(P: Points, candidates: list[str]) -> tuple[list[str], list[str]]:
    """Terms the points can support at all (asymmetry needs inputs of both signs; a term of
    :data:`TERMS` needs at least its ``min_points`` distinct inputs), and notes for the others."""
    notes = []
    distinct = len(np.unique(np.round(P.I, 6)))
    have_neg = bool(np.any(P.I < 0) and np.any(P.I > 0))
    out = []
    for t in candidates:
        if t == "asymmetry" and not have_neg:
            notes.append("asymmetry term not tried: no negative input rates")
            continue
        if distinct < TERMS[t].min_points:
            notes.append(f"{t} term not tried: {distinct} distinct input rates "
                         f"(needs ≥ {TERMS[t].min_points})")
            continue
        out.append(t)
    return out, notes


def select_model(P: Points, fs: float, kref: float, *, candidates: list[str],
                 forced: list[str] | None = None, alpha: float = 0.05,
                 weighted: bool = True) -> tuple[ModelFit, list[ModelStep], list[str]]:
    """Choose the nonlinearity terms the data support ("add a term, watch the residual fall").

    Start from per-run straight lines (the IEEE §12.9.4.1 fit). With ``forced`` the terms
    are added in that order and all kept. Otherwise:

    0. lock-in (ring-laser dead band, exact Adler transform, Ω_L scanned by
       :func:`scan_lockin`) is kept when its F-test p × (number of candidates) < ``alpha``
       and AICc falls;
    1. every subset of the polynomial/asymmetry candidates that respects the hierarchy
       (u3 only with u1, u4 only with u2) is fitted and the one with the
       lowest AICc kept; then, backwards, a term whose removal F-test has p × (number of
       candidates) ≥ ``alpha`` is dropped, least significant first (an exhaustive search:
       single terms are correlated over a sparse rate set and a greedy path can pick the
       wrong first term);
    2. the periodic term (period scanned, :func:`scan_periodic`) is tried on top and kept when
       its F-test p × trial periods × candidates < ``alpha`` and AICc falls.

    Scanned parameters (Ω_L, P) count as parameters in AICc and in the F-test degrees of
    freedom. The history lists the path to the chosen model (each step adds the chosen term
    that lowers AICc most), then every rejected candidate added to the final model. Returns
    (final fit, history, notes).
    """
    notes: list[str] = []
    base = fit_model(P, [], fs, kref, weighted=weighted)
    hist = [ModelStep([], "straight line", base.p, base.wls.chi2, base.dof, base.rms_ppm_fs,
                      base.aicc, math.nan, math.nan, True, "IEEE 952 §12.9.4.1 least-squares line")]
    ncand = max(1, len(candidates))

    def fit_or_none(terms: list[str], like: ModelFit) -> ModelFit | None:
        try:
            f = fit_model(P, terms, fs, kref, period_dps=like.period_dps,
                          lockin_dph=like.lockin_dph, weighted=weighted)
        except AnalysisError:
            return None
        f.lockin_sigma_dph = like.lockin_sigma_dph
        return f

    def ftest(prev: ModelFit, fit: ModelFit, mult: float = 1.0) -> float:
        p = f_test(prev.wls.chi2, prev.dof, fit.wls.chi2, fit.dof)
        return min(1.0, p * mult) if math.isfinite(p) else p

    def step(prev: ModelFit, fit: ModelFit, added: str, p: float, ok: bool,
             note: str = "") -> ModelStep:
        return ModelStep(list(fit.terms), added, fit.p, fit.wls.chi2, fit.dof, fit.rms_ppm_fs,
                         fit.aicc, fit.aicc - prev.aicc, p, ok, note)

    def lock_note(f: ModelFit) -> str:
        return f"Ω_L = {f.lockin_dph / DPS:.4g} deg/s"

    if forced is not None:
        cur = base
        for t in forced:
            if t == "periodic":
                fit, p, m = scan_periodic(P, cur.terms, fs, kref, weighted=weighted, base=cur)
                if fit is None:
                    raise AnalysisError("the periodic term cannot be fitted: too few distinct rates")
                hist.append(step(cur, fit, t, min(1.0, p * m), True,
                                 f"P = {fit.period_dps:.4g} deg/s ({m} trial periods)"))
            elif t == "lockin":
                fit = scan_lockin(P, cur, fs, kref, weighted=weighted)
                if fit is None:
                    raise AnalysisError("the lock-in term needs at least three non-zero rates")
                hist.append(step(cur, fit, t, ftest(cur, fit), True, lock_note(fit)))
            else:
                fit = fit_or_none(cur.terms + [t], cur)
                if fit is None:
                    raise AnalysisError(f"the {t} term cannot be fitted to these points "
                                        "(too few distinct rates or not separable)")
                hist.append(step(cur, fit, t, ftest(cur, fit), True))
            cur = fit
        return cur, hist, notes

    rejected: list[ModelStep] = []
    # 0. lock-in
    start = base
    lock_rejected = False
    if "lockin" in candidates:
        fit = scan_lockin(P, base, fs, kref, weighted=weighted)
        if fit is not None:
            p = ftest(base, fit, ncand)
            st = step(base, fit, "lockin", p, False, lock_note(fit))
            if math.isfinite(p) and p < alpha and st.delta_aicc < 0:
                st.accepted = True
                hist.append(st)
                start = fit
            else:
                lock_rejected = True
    # 1. exhaustive subset search over polynomial/asymmetry terms
    from itertools import combinations

    poly = [t for t in candidates if t not in ("periodic", "lockin")]
    pre = list(start.terms)
    best = start
    for k in range(1, len(poly) + 1):
        for sub in combinations(poly, k):
            if any(HIERARCHY.get(t) and HIERARCHY[t] not in sub for t in sub):
                continue
            fit = fit_or_none(pre + list(sub), start)
            if fit is not None and fit.aicc < best.aicc:
                best = fit
    chosen = [t for t in best.terms if t not in pre]
    while chosen:
        worst, worst_p = None, -1.0
        for t in chosen:
            if any(HIERARCHY.get(c) == t for c in chosen):
                continue  # keep a lower order while its higher order stays
            red = fit_or_none(pre + [c for c in chosen if c != t], start)
            if red is None:
                continue
            p = ftest(red, best, ncand)
            p = p if math.isfinite(p) else 1.0
            if p > worst_p:
                worst, worst_p = t, p
        if worst is None or worst_p < alpha:
            break
        chosen.remove(worst)
        best = fit_or_none(pre + chosen, start) or start
    # the path to the chosen subset (a lower order before its higher order)
    cur = start
    todo = [t for t in poly if t in chosen]
    while todo:
        ready = [t for t in todo if HIERARCHY.get(t) not in todo]
        opts = [(t, fit_or_none(cur.terms + [t], start)) for t in ready]
        opts = [(t, f) for t, f in opts if f is not None]
        if not opts:
            break
        t, fit = min(opts, key=lambda z: z[1].aicc)
        p = ftest(cur, fit, ncand)
        st = step(cur, fit, t, p, True)
        dep = next((h for h, lo in HIERARCHY.items() if lo == t and h in chosen), None)
        if dep and not (math.isfinite(p) and p < alpha and st.delta_aicc < 0):
            st.note = f"kept as the lower order of {dep}"
        hist.append(st)
        cur = fit
        todo.remove(t)
    for t in poly:
        if t in cur.terms or (HIERARCHY.get(t) and HIERARCHY[t] not in cur.terms):
            continue
        fit = fit_or_none(cur.terms + [t], cur)
        if fit is not None:
            rejected.append(step(cur, fit, t, ftest(cur, fit, ncand), False,
                                 "not supported by the data"))
    # 2. periodic on top
    if "periodic" in candidates:
        fit, p, m = scan_periodic(P, cur.terms, fs, kref, weighted=weighted, base=cur)
        if fit is not None:
            pc = min(1.0, p * m * ncand) if math.isfinite(p) else math.nan
            st = step(cur, fit, "periodic", pc, False,
                      f"P = {fit.period_dps:.4g} deg/s ({m} trial periods)")
            if math.isfinite(pc) and pc < alpha and st.delta_aicc < 0:
                st.accepted = True
                hist.append(st)
                cur = fit
            else:
                st.note += "; not supported by the data"
                rejected.append(st)
    if lock_rejected:  # show what lock-in would do on top of the final model
        fit = scan_lockin(P, cur, fs, kref, weighted=weighted)
        if fit is not None:
            rejected.append(step(cur, fit, "lockin", ftest(cur, fit, ncand), False,
                                 lock_note(fit) + "; not supported by the data"))
    hist.extend(sorted(rejected, key=lambda h: h.aicc))
    return cur, hist, notes


