"""The scale-factor characteristics of IEEE 952 §5.3.2.1 from the rate-table points and the
fitted line: the linearity error (:func:`linearity_stats`), the asymmetry of the positive
and negative input scale factors (:class:`AsymmetryResult`, with or without a common
intercept, and per rate), and the lock-in (dead band) of a ring-laser gyro
(:func:`detect_lock_in`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .tablefit import DPS, Points, line_fit


# ----------------------------------------------------------------------------- linearity
@dataclass
class LinearityStats:
    """Linearity error summary (IEEE 952 §12.9.4.2.1, §5.3.2.1 a): maximum |error| and 1σ
    (RMS), in ppm of full-scale output and in ppm of output."""

    n: int
    max_ppm_fs: float
    sigma_ppm_fs: float
    max_ppm_output: float
    sigma_ppm_output: float
    max_at_input_dps: float = math.nan

    def to_dict(self) -> dict:
        return {"n_points": self.n, "linearity_max_ppm_fs": self.max_ppm_fs,
                "linearity_1sigma_ppm_fs": self.sigma_ppm_fs,
                "linearity_max_ppm_output": self.max_ppm_output,
                "linearity_1sigma_ppm_output": self.sigma_ppm_output,
                "linearity_max_at_input_dps": self.max_at_input_dps}


def linearity_stats(I: np.ndarray, ppm_fs: np.ndarray, ppm_out: np.ndarray) -> LinearityStats:
    """max |e| and 1σ = RMS(e) of per-point linearity errors (ppm of FS and of output; points
    at zero input have no ppm-of-output value)."""
    if len(ppm_fs) == 0:
        return LinearityStats(0, math.nan, math.nan, math.nan, math.nan)
    j = int(np.argmax(np.abs(ppm_fs)))
    po = ppm_out[np.isfinite(ppm_out)]
    return LinearityStats(
        n=len(ppm_fs), max_ppm_fs=float(np.max(np.abs(ppm_fs))),
        sigma_ppm_fs=float(np.sqrt(np.mean(ppm_fs ** 2))),
        max_ppm_output=float(np.max(np.abs(po))) if len(po) else math.nan,
        sigma_ppm_output=float(np.sqrt(np.mean(po ** 2))) if len(po) else math.nan,
        max_at_input_dps=float(I[j] / DPS))


# ----------------------------------------------------------------------------- asymmetry
ASYM_DEFINITION = ("(SF+ - SF-) / (0.5 (SF+ + SF-)) * 1e6 with SF+ (SF-) the scale factor of "
                   "the positive (negative) inputs in the unit of the scale_factor column, input "
                   "per unit output (arcsec/pulse, (deg/h)/V; IEEE 952 §8.3, §12.9.4.2.2): "
                   "positive when a pulse (volt) is worth more input for positive rates, i.e. "
                   "when the positive inputs give less output per unit input")


@dataclass
class AsymmetryResult:
    """Scale-factor asymmetry (IEEE 952 §12.9.4.2.2, §5.3.2.1 b), ppm.

    ``A = (SF+ − SF−)/(½(SF+ + SF−))`` with SF the scale factor of the SF column (input per
    unit output, IEEE 952 §8.3); with the fitted output-per-input slopes k± this is
    ``A = (|k−| − |k+|)/(½(|k+| + |k−|))`` exactly (the one sign convention of the tool).

    * ``asymmetry_ppm`` (primary; per run, then the mean): SF+ and SF− from separate
      least-squares lines through the positive and the negative inputs, each with the
      zero-rate plateaus (through the common intercept of the §12.9.4.1 line when a side has
      fewer than two distinct inputs); σ from the plateau SEs. An even nonlinearity leaks
      into it, as the standard's definition implies.
    * ``common_intercept``: SF± = Σx(y − b)/Σx² through the intercept b of the full line.
    * ``model``: the asymmetry coefficient A of the nonlinearity model, fitted beside the
      other selected terms (separates a kink at zero from smooth even curvature).
    * ``per_rate``: at each |table rate| present with both signs.
    """

    status: str  # "ok" or why it was skipped
    asymmetry_ppm: float = math.nan
    asymmetry_sigma_ppm: float = math.nan
    per_run_ppm: list[float] = field(default_factory=list)
    method: str = ""
    common_intercept_ppm: float = math.nan
    common_intercept_sigma_ppm: float = math.nan
    model_ppm: float = math.nan
    model_sigma_ppm: float = math.nan
    supported: bool = False  # did the model selection keep the asymmetry term?
    per_rate: list[dict] = field(default_factory=list)

    def to_dict(self) -> dict:
        return {"status": self.status, "asymmetry_ppm": self.asymmetry_ppm,
                "asymmetry_sigma_ppm": self.asymmetry_sigma_ppm,
                "asymmetry_per_run_ppm": self.per_run_ppm,
                "method": self.method,
                "asymmetry_common_intercept_ppm": self.common_intercept_ppm,
                "asymmetry_common_intercept_sigma_ppm": self.common_intercept_sigma_ppm,
                "asymmetry_model_ppm": self.model_ppm,
                "asymmetry_model_sigma_ppm": self.model_sigma_ppm,
                "asymmetry_term_supported_by_data": self.supported,
                "definition": ASYM_DEFINITION,
                "per_rate": self.per_rate}


def _asym_from(sp: float, sm: float, gp: np.ndarray, gm: np.ndarray,
               se: np.ndarray | None) -> tuple[float, float]:
    """A (ppm, SF-column convention: (|k−| − |k+|)/(½(|k+| + |k−|)) for output-per-input
    slopes k± = ``sp``, ``sm``) and σ_A from the SEs through the gradients wrt y."""
    m = 0.5 * (abs(sp) + abs(sm))
    A = (abs(sm) - abs(sp)) / m * 1e6
    if se is None or not np.all(np.isfinite(se)):
        return A, math.nan
    gp, gm = gp * np.sign(sp), gm * np.sign(sm)
    gA = ((gm - gp) / m - (abs(sm) - abs(sp)) / (2 * m * m) * (gp + gm)) * 1e6
    return A, float(np.sqrt(np.sum((gA * se) ** 2)))


def asymmetry_common_intercept(I: np.ndarray, y: np.ndarray, se: np.ndarray | None,
                               b: float, db_dy: np.ndarray) -> tuple[float, float]:
    """Asymmetry of one run through the common intercept, ppm: slopes k± = Σ_{±} I(y − b)/Σ_{±} I²
    with b the intercept of the §12.9.4.1 line (``db_dy`` = ∂b/∂y of that line, for the error
    propagation); A = (|k−| − |k+|)/(½(|k+| + |k−|))·1e6 = (SF+ − SF−)/(½(SF+ + SF−))·1e6
    (SF = S0/k). Returns (A, σ_A)."""
    pos, neg = I > 0, I < 0
    sp_den, sm_den = float(np.sum(I[pos] ** 2)), float(np.sum(I[neg] ** 2))
    sp = float(np.sum(I[pos] * (y[pos] - b))) / sp_den
    sm = float(np.sum(I[neg] * (y[neg] - b))) / sm_den
    gp = np.where(pos, I, 0.0) / sp_den - float(np.sum(I[pos])) / sp_den * db_dy
    gm = np.where(neg, I, 0.0) / sm_den - float(np.sum(I[neg])) / sm_den * db_dy
    return _asym_from(sp, sm, gp, gm, se)


def asymmetry_separate_lines(I: np.ndarray, y: np.ndarray, se: np.ndarray | None,
                             table: np.ndarray | None = None) -> tuple[float, float] | None:
    """IEEE 952 §12.9.4.2.2 asymmetry of one run, ppm, from separate unweighted least-squares
    lines through the positive and the negative inputs, each with the zero-rate plateaus
    (sides by the sign of the table rate). σ from the SEs through both lines (the shared
    zero-rate points included). None when a side has fewer than two distinct inputs."""
    sgn = np.sign(table if table is not None else I)
    grads, slopes = [], []
    for side in (1.0, -1.0):
        m = (sgn == side) | (sgn == 0)
        if len(np.unique(np.round(I[m], 6))) < 2:
            return None
        X = np.column_stack([np.ones(m.sum()), I[m] - I[m].mean()])
        A = np.linalg.inv(X.T @ X) @ X.T
        g = np.zeros(len(I))
        g[m] = A[1]
        grads.append(g)
        slopes.append(float(A[1] @ y[m]))
    return _asym_from(slopes[0], slopes[1], grads[0], grads[1], se)


def per_rate_asymmetry(P: Points, bias: np.ndarray) -> list[dict]:
    """Asymmetry at each |table rate| present with both signs, pooled over runs:
    k± = (ȳ± − b_r)/Ī±, A = (|k−| − |k+|)/(½(|k+| + |k−|))·1e6 (= (SF+ − SF−)/SF̄), with
    σ propagated from the plateau SEs (b_r taken as exact)."""
    tab = P.table if P.table is not None else P.I
    out = []
    mags = np.unique(np.round(np.abs(tab[tab != 0]), 6))
    for mg in mags:
        vals, sig = [], []
        for r in range(len(P.runs)):
            sel = P.run == r
            pos = sel & np.isclose(tab, mg, rtol=1e-9, atol=1e-9)
            neg = sel & np.isclose(tab, -mg, rtol=1e-9, atol=1e-9)
            if not pos.any() or not neg.any():
                continue

            def avg(m):
                se = P.se[m]
                if np.all(np.isfinite(se)) and np.all(se > 0):
                    w = 1 / se ** 2
                    return (float(np.sum(w * P.y[m]) / np.sum(w)), float(1 / math.sqrt(np.sum(w))),
                            float(np.mean(P.I[m])))
                return float(np.mean(P.y[m])), math.nan, float(np.mean(P.I[m]))

            yp, sp, ip = avg(pos)
            yn, sn, in_ = avg(neg)
            kp = (yp - bias[r]) / ip
            kn = (yn - bias[r]) / in_
            a = (abs(kn) - abs(kp)) / (0.5 * (abs(kp) + abs(kn))) * 1e6
            s = math.hypot(sp / (kp * ip), sn / (kn * in_)) * 1e6
            vals.append(a)
            sig.append(s)
        if not vals:
            continue
        vals_a, sig_a = np.array(vals), np.array(sig)
        if np.all(np.isfinite(sig_a)) and np.all(sig_a > 0):
            w = 1 / sig_a ** 2
            a, s = float(np.sum(w * vals_a) / np.sum(w)), float(1 / math.sqrt(np.sum(w)))
        else:
            a = float(np.mean(vals_a))
            s = float(np.std(vals_a, ddof=1) / math.sqrt(len(vals_a))) if len(vals_a) > 1 else math.nan
        out.append({"rate_dps": float(mg / DPS), "asymmetry_ppm": a, "sigma_ppm": s,
                    "n_runs": len(vals)})
    return out


# ----------------------------------------------------------------------------- lock-in
def detect_lock_in(P: Points, *, ratio: float = 0.1) -> tuple[np.ndarray, list[str]]:
    """Low-rate dead band / lock-in (ring-laser gyros): points whose bias-corrected output has
    collapsed below ``ratio`` × the straight line fitted to the upper half of |I| in the same
    run (points just above the lock-in rate are kept: the Adler term describes them). Not an
    IEEE 952 clause: the dead band shows up there as linearity error at low rates
    (§12.9.4.2.1). Returns (mask of locked points, notes)."""
    locked = np.zeros(P.n, dtype=bool)
    notes = []
    for r in range(len(P.runs)):
        sel = np.flatnonzero(P.run == r)
        I, y = P.I[sel], P.y[sel]
        nz = np.abs(P.table[sel] if P.table is not None else I) > 0
        if nz.sum() < 4:
            continue
        mag = np.abs(I)
        hi = nz & (mag >= np.median(mag[nz]))
        if len(np.unique(np.round(I[hi], 6))) < 2:
            continue
        fit = line_fit(I[hi], y[hi], None)
        b, k = fit.coef
        with np.errstate(divide="ignore", invalid="ignore"):
            rho = (y - b) / (k * I)
        lk = nz & ~hi & (rho < ratio)
        locked[sel[lk]] = True
    return locked, notes
