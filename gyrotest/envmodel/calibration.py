"""Limited by the sensors: a candidate that only reads the model's nodes better.

Two tests hold such a candidate back (:func:`gyrotest.envmodel.selection.judge_step`):
:func:`sensor_limit`, a bound on what a noise-free reading of the model's own sensors would
gain, and :class:`Calibrated`, the candidate tested again on the model read through its
sensors' reconstructed nodes (regression calibration).

A term built from a noisy or coarsely quantised sensor reads its node badly, and least squares
attenuates its coefficient (:mod:`gyrotest.envmodel.sensors`). Under a noise model dominated
by random walk the attenuation can be severe: the whitened band the fit listens to is where a
rate read through a 0.0625-degC thermocouple is mostly rounding, the coefficient collapses,
and the effect the term should carry stays in the residual. Any smoother reading of the same
node — a lag or a smoothed rate of the same sensor, a second sensor — then "explains" it: a
better reading, not a new effect, and no bound on the sensors' noise sees it, because what
that reading gains is the model's own unexplained signal.

Regression calibration (Carroll, Ruppert, Stefanski & Crainiceanu, *Measurement Error in
Nonlinear Models*, 2nd ed., Chapman & Hall/CRC 2006, ch. 4) replaces each error-prone
covariate by an estimate of its true value given the reading. Here that estimate is the
Whittaker smoother of the reading at the sensor's own error variance
(:func:`gyrotest.envmodel.sensors.reading_path`). A candidate that reads a channel of the same
kind (temperature or extra) as a noisy channel of the model is a missing effect only if it
also passes on top of the model fitted to the calibrated channels, its likelihood ratio taken
with the noise re-estimated under both models and the same look-elsewhere correction
(Davies) and Bonferroni share as the step's own test; otherwise it is limited by the sensors.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from ..core.errors import AnalysisError, InputError
from .candidate import Candidate
from .lookelsewhere import davies_log_p
from .modelfit import FitResult, WorkData, fit_model
from .sensors import node_path, term_channels


def noisy_model_channels(wd: WorkData, base: FitResult, spec) -> list[str]:
    """The noisy channels (with a measured sensor noise) that the model's terms read and that
    are of the same kind (temperature or extra) as a channel ``spec`` reads: the channels of
    which ``spec`` could be a better reading."""
    noise = getattr(wd, "sensor_noise", None) or {}
    if not noise or spec is None:
        return []
    fr = wd.frame
    mine = term_channels(spec)
    used = set()
    for s in base.specs:
        if s.key != "bias":
            used |= term_channels(s)
    out = []
    for ch, sn in noise.items():
        if ch not in used or not sn.variance > 0:
            continue
        group = set(fr.temperature) if ch in fr.temperature else set(fr.extra)
        if mine & group:
            out.append(ch)
    return out


def calibrated_workdata(wd: WorkData) -> WorkData:
    """``wd`` with every channel that has a measured sensor noise replaced by its reconstructed
    node (:func:`gyrotest.envmodel.sensors.reading_path`; cached on ``wd``) and no sensor noise
    left; the gyro's data, blocks and noise caches are shared."""
    fr = wd.frame
    new = {"temperature": dict(fr.temperature), "extra": dict(fr.extra)}
    for ch, sn in (wd.sensor_noise or {}).items():
        group = "temperature" if ch in fr.temperature else "extra" if ch in fr.extra else None
        if group is None or not sn.variance > 0:
            continue
        new[group][ch] = node_path(wd, ch, sn, new[group][ch])
    out = dataclasses.replace(wd, frame=dataclasses.replace(fr, **new), sensor_noise={})
    out.white_n2 = wd.white_n2
    out.acov_cache = wd.acov_cache
    return out


class Calibrated:
    """The step's model refitted on the calibrated channels (built on first use), and the
    test of a candidate on top of it."""

    def __init__(self, wd: WorkData, base: FitResult):
        self.wd, self.base = wd, base
        self._wd: WorkData | None = None
        self._fit: FitResult | None = None
        self.failed = False

    def fit(self) -> FitResult | None:
        if self._fit is None and not self.failed:
            try:
                self._wd = calibrated_workdata(self.wd)
                self._fit = fit_model(self._wd, [s for s in self.base.specs if s.key != "bias"],
                                      thetas0=dict(self.base.thetas), light=True,
                                      noise_start=self.base.noise)
            except (AnalysisError, InputError, ValueError, np.linalg.LinAlgError):
                self.failed = True
        return self._fit

    def lr(self, c) -> float:
        """Λ of candidate ``c`` (its replaced term out) on top of the calibrated model, noise
        re-estimated under both; NaN when either fit fails."""
        base = self.fit()
        if base is None:
            return math.nan
        gone = set((c.replaces or "").split("; ")) - {""}
        specs = [s for s in base.specs if s.key != "bias" and s.label not in gone] + [c.spec]
        th0 = {k: v for k, v in base.thetas.items() if k not in gone}
        if c.theta:
            th0[c.term] = dict(c.theta)
        try:
            r = fit_model(self._wd, specs, thetas0=th0, new_terms=[c.spec], light=True,
                          noise_start=base.noise)
        except (AnalysisError, InputError, ValueError, np.linalg.LinAlgError):
            return math.nan
        return max(0.0, 2.0 * (r.loglik - base.loglik))

    def p_family(self, c, n_c: int, k_tests: int) -> tuple[float, float]:
        """(Λ on the calibrated model, its family-wise p: Davies over the candidate's
        searched parameter, Bonferroni over the step's ``n_c`` candidates and its
        ``k_tests`` tests)."""
        lam = self.lr(c)
        if not math.isfinite(lam):
            return lam, math.nan
        p = min(1.0, k_tests * n_c * math.exp(davies_log_p(lam, max(c.df, 1), c.tv)))
        return lam, p


def sensor_limit(sc: Any, c: Candidate, alpha: float) -> tuple[float, float] | None:
    """Errors in variables: the model's terms carry their sensors' noise (the noise model's
    ``extra_parts``, :func:`gyrotest.envmodel.sensors.eiv_acov`). A candidate reading a
    channel of the same group (temperature or extra) as a noisy channel of the model could be
    a better reading of the same nodes rather than a new effect; taking the realised noise u
    out of the residual would give a likelihood ratio of about uᵀΣ⁻¹u, whose mean is
    tr(Σ⁻¹E). Its spread is that of the simulated realisations (``extra_series``): a
    quantised sensor's sawtooth is far from Gaussian, and the whole error of a dwell moves
    with the quantiser's offset, so the Gaussian variance 2·tr((Σ⁻¹E)²) (used when no
    realisations are kept) understates it. The candidate is sensor-limited when its Λ is
    within the one-sided 1 − α quantile of that (normal approximation). Returns (expected Λ,
    its sd) then, else None. ``sc`` is the step's :class:`gyrotest.envmodel.selection.Screen`."""
    parts = getattr(sc.base.noise, "extra_parts", None) or {}
    if not parts or c.spec is None:
        return None
    fr = sc.wd.frame
    group = {"temperature": set(fr.temperature), "extra": set(fr.extra)}
    mine = term_channels(c.spec)
    E = None
    chans = []
    for ch, acov in parts.items():
        g = "temperature" if ch in fr.temperature else "extra"
        if mine & group[g]:
            E = acov if E is None else E + acov
            chans.append(ch)
    if E is None or not E[0] > 0:
        return None
    from scipy import stats as sps

    lk = sc.lik
    series = getattr(sc.base.noise, "extra_series", None) or {}
    k = min((len(series.get(ch, ())) for ch in chans), default=0)
    if k >= 2:
        gains = [float(np.sum(lk.whiten(sum(series[ch][i] for ch in chans)) ** 2))
                 for i in range(k)]
        tr1, sd = float(np.mean(gains)), float(np.std(gains, ddof=1))
    else:
        tr1, sd = _gaussian_gain(lk, E)
    if not tr1 > 0:
        return None
    lam = c.lr_fixed if math.isfinite(c.lr_fixed) else c.lr
    z = float(sps.norm.isf(alpha))
    return (tr1, sd) if lam <= tr1 + z * sd else None


def _gaussian_gain(lk, E: np.ndarray) -> tuple[float, float]:
    """Mean and sd of uᵀΣ⁻¹u for Gaussian u of autocovariance E (per run of differenced
    samples): tr(Σ⁻¹E) and √(2·tr((Σ⁻¹E)²))."""
    from scipy.linalg import cho_solve, toeplitz

    tr1 = tr2 = 0.0
    for a, b in lk.grid.runs:
        n = b - a - 1
        if n < 1:
            continue
        A = cho_solve((lk._factor(n), True), toeplitz(E[:n]))
        tr1 += float(np.trace(A))
        tr2 += float(np.sum(A * A.T))
    return tr1, math.sqrt(2.0 * max(tr2, 0.0))


__all__ = ["Calibrated", "calibrated_workdata", "noisy_model_channels", "sensor_limit"]
