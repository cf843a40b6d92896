"""The look-elsewhere surrogate test of a nuisance term chosen by the workbench diagnosis
(:mod:`gyrotest.envmodel.diagnose`): a ramp, warm-up or hysteresis
(:data:`gyrotest.envmodel.rules.CHANCE_KEYS`).

A ramp, warm-up or hysteresis branch has a shape free enough to fit
a gyro's own slow noise (bias instability, rate random walk), and the diagnosis picks the
best of many candidates, so the chosen term's held-out gain is the *maximum* of many chance
gains when nothing is missing. The test asks whether that gain is larger than the best gain
any candidate of the step reaches on noise with the same spectrum as the model's residual:

1. **Surrogate noise** (Theiler et al., "Testing for nonlinearity in time series: the method
   of surrogate data", Physica D 58, 1992): the base model's residual e (block means, deg/h)
   is Fourier transformed, its phases are replaced by independent uniform phases and it is
   transformed back, K times (:func:`phase_surrogates`). Each surrogate has e's periodogram
   -- the slow noise at the lowest frequencies included -- and no alignment with any logged
   channel or with time.
2. **The best chance gain** of each surrogate s_k: for every candidate c of the step (its
   regressor at the fitted nonlinear parameters and on a log-spaced grid over the
   parameter's range), the held-out gain 1 − RMS_ho([X_b, x_c]; s_k)/RMS_ho(X_b; s_k) over
   the same blocked folds and fold fits as the diagnosis (least squares free only along the
   directions each fold's training blocks support, :func:`holdout_rms`), maximised over
   the candidates: M_k. Because the candidate model contains the base model, the gain on
   y − X_b·β equals the gain on s_k; the base model's own regressors X_b stay in both fits.
3. **p = (1 + #{M_k ≥ g}) / (K + 1)**, g the chosen term's held-out gain in the diagnosis
   (Westfall & Young, "Resampling-Based Multiple Testing", Wiley 1993: the max statistic
   over the candidates controls the family-wise error of the look-elsewhere search). Above
   :data:`gyrotest.envmodel.rules.CHANCE_P` the term is not named: its gain is one the best
   of the candidates reaches on the residual's own noise.

A true effect the base model misses is itself part of e, so its surrogates carry its power
with random phases; the test is conservative there, which is why it alone decides only for
these three nuisance terms (the campaign's true slow channel effects of a chamber profile
with few cycles reach p 0.1-0.25, benchmarks/README.md), and not for a free sinusoid, whose
own spectral line every surrogate keeps (its sine and cosine coefficients fit any phase).
A channel term chosen below ten times the floor is set aside only when, besides, the
circular shifts and reversals of the residual the term itself leaves reach its gain
(:func:`shift_surrogates`: the term's own power removed, the gyro's own excursions kept);
a pair is tested against the best pair of the step's best candidates
(:func:`pair_chance_test`). Both are applied by
:func:`gyrotest.envmodel.gates.channel_chance_gate`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .fit import cv_layout, fold_coefficients, holdout_folds
from .stats import lstsq_coef
from .terms import nonlinear_bounds


@dataclass
class ChanceTest:
    """Result of :func:`chance_test`: the chosen held-out gain (fraction) and the
    surrogates' best chance gains M_k (fractions; -inf where none could be fitted), from
    which p, the count that reached the gain and their 90 % quantile follow."""

    gain: float
    best: np.ndarray
    #: "phase" (phase-randomised surrogates of the residual, single candidates), "shifts"
    #: (circular shifts and reversals, :func:`shift_surrogates`) or "pairs" (phase
    #: surrogates, pairs of candidates: :func:`pair_chance_test`)
    kind: str = "phase"

    @property
    def k(self) -> int:
        return len(self.best)

    def p_of(self, gain: float) -> float:
        """p of a held-out ``gain`` (fraction) against these surrogates."""
        return (1 + int(np.sum(self.best >= gain))) / (self.k + 1)

    @property
    def p(self) -> float:
        return self.p_of(self.gain)

    @property
    def exceed(self) -> int:
        return int(np.sum(self.best >= self.gain))

    @property
    def q90(self) -> float:
        return float(np.quantile(self.best[np.isfinite(self.best)], 0.9))

    def text(self) -> str:
        what = ("pair of candidates" if self.kind == "pairs" else "candidate")
        return (f"its held-out gain ({100 * self.gain:.1f} %) is within what the best "
                f"{what} reaches on noise with the residual's own spectrum: "
                f"{self.exceed} of {self.k} phase-randomised surrogates of the residual reach "
                f"it (90th percentile {100 * self.q90:.1f} %), so it may be a fit to the "
                "gyro's own slow noise")

    def to_dict(self) -> dict:
        return {"kind": self.kind, "gain_pct": 100 * self.gain, "surrogates": self.k,
                "exceed": self.exceed,
                "q90_pct": 100 * self.q90,
                "max_pct": 100 * float(np.max(self.best[np.isfinite(self.best)])), "p": self.p}


def phase_surrogates(e: np.ndarray, k: int, rng: np.random.Generator) -> np.ndarray:
    """K phase-randomised surrogates of the series ``e`` (columns of an n x K array, mean
    removed): the amplitudes of e's discrete Fourier transform with independent uniform
    phases (zero at frequency 0 and, for even n, at the Nyquist frequency).

    The transform treats the record as periodic, so a random walk's jump from its last value
    back to its first leaks into every frequency: the surrogates of a random walk carry less
    of its power at the lowest frequencies than the record, and their chance gains are
    smaller. The test is lenient there (on random-walk noise with nothing to find, p ≤ 0.1 in
    43 % of records instead of 10 %; on flicker noise 14 %). End-matched surrogates
    (Schreiber & Schmitz, "Surrogate time series", Physica D 142, 2000), which keep the
    line from the first to the last value, hold the size (8 %) but put a warm-up's own
    decay into every surrogate: three of the first ten true warm-ups of the campaign then
    failed the test (p 0.13-0.5). A nuisance term the lenient test rejects is beaten by
    the chance gains of noise that understates the slow wander."""
    e = np.asarray(e, float)
    n = len(e)
    F = np.fft.rfft(e - e.mean())
    ph = rng.uniform(0.0, 2.0 * np.pi, (k, len(F)))
    ph[:, 0] = 0.0
    if n % 2 == 0:
        ph[:, -1] = 0.0
    return np.fft.irfft(np.abs(F)[None, :] * np.exp(1j * ph), n=n, axis=1).T


def holdout_rms(X: np.ndarray, Y: np.ndarray, fold: np.ndarray, masks: list[np.ndarray]
                ) -> np.ndarray:
    """Held-out RMS of each column of ``Y`` under the blocked folds (``fold`` id per block,
    training ``masks``): least squares on the training blocks by the rule of the diagnosis
    (:func:`gyrotest.envmodel.fit.fold_coefficients`: free only along the directions the
    training blocks support, the full-record coefficients along the others), residual on
    the held-out ones, pooled over the folds.

    The rule matters here as much as in the diagnosis: a Helmholtz sequence whose one
    sweep that moves two axes together lies in one chunk leaves that fold's plain
    least-squares fit near-singular (condition 3·10⁴ in seed 58071), its noise-fitted
    coefficients extrapolate to 36 × the residual's RMS, and any candidate correlated with
    that direction "gained" up to 95 % on the surrogates -- a chance gain the diagnosis
    itself can never see."""
    H = np.full(Y.shape, np.nan)
    B_full = lstsq_coef(X, Y)
    for f, m in enumerate(masks):
        held = fold == f
        if not held.any() or m.sum() <= X.shape[1]:
            continue
        B = fold_coefficients(X, Y, m, B_full)
        H[held] = Y[held] - X[held] @ B
    with np.errstate(invalid="ignore"):
        return np.sqrt(np.nanmean(H ** 2, axis=0))


def regressors(design, cand, wd, grid: int) -> list[np.ndarray]:
    """The block regressors of candidate ``cand`` (a judged
    :class:`~gyrotest.envmodel.candidate.Candidate`): at its fitted nonlinear parameters and,
    for a time constant or width, at ``grid`` log-spaced values over its range (a searched
    frequency only at its fitted value)."""
    spec = cand.spec
    if not spec.effect.nonlinear:
        return [design.block(spec, None)]
    fit = cand._fit
    th = dict((getattr(fit, "_thetas", {}) or {}).get(cand.term, {})) if fit else {}
    out = [design.block(spec, th)] if th else []
    b = nonlinear_bounds(spec, wd.duration_s, wd.resolution_s, wd.refs)
    if len(b) == 1 and spec.effect.nonlinear[0].kind != "freq":
        (name, (lo, hi)), = b.items()
        if 0 < lo < hi:
            for v in np.geomspace(lo, hi, grid):
                out.append(design.block(spec, {**th, name: float(v)}))
    return out


def shift_surrogates(e: np.ndarray, k: int) -> np.ndarray:
    """K circular shifts of the series ``e`` and of ``e`` reversed in time (columns of an
    n x K array, mean removed): the first K//2 shift e by 10 %-90 % of its length, the others
    shift the reversed series by 0 %-90 %.

    Unlike a phase-randomised surrogate, a shift keeps the series itself -- its amplitude
    distribution and its few large, non-stationary excursions (the hump and the drop of a
    real MEMS gyro's wander, ADIS16405 record) -- and only moves it against the logged
    channels; reversal adds shapes a causal lag of a channel cannot reach by delay alone.
    Under the hypothesis that the series is independent of the channels a shift is as likely
    as the record itself (the torus-translation test: R. Harms, K. E. Condit, S. P. Hubbell
    and R. B. Foster, "Habitat associations of trees and shrubs in a 50-ha neotropical forest
    plot", Journal of Ecology 89, 2001, 947-959)."""
    e = np.asarray(e, float) - float(np.mean(e))
    n = len(e)
    h = k // 2
    cols = [np.roll(e, int(f * n)) for f in np.linspace(0.1, 0.9, h)]
    cols += [np.roll(e[::-1], int(f * n)) for f in np.linspace(0.0, 0.9, k - h)]
    return np.column_stack(cols)


def best_chance_gains(Xb: np.ndarray, e: np.ndarray, regs: list[np.ndarray],
                      fold: np.ndarray, masks: list[np.ndarray], k: int,
                      rng: np.random.Generator | None, S: np.ndarray | None = None
                      ) -> np.ndarray:
    """M_k of the module docstring: for each of ``k`` phase-randomised surrogates of the
    residual ``e`` (or each column of ``S`` when given), the largest held-out gain
    (fraction) any regressor block of ``regs`` gives beside the base design ``Xb`` (-inf
    where none could be fitted)."""
    if S is None:
        S = phase_surrogates(e, k, rng)
    r0 = holdout_rms(Xb, S, fold, masks)
    best = np.full(S.shape[1], -np.inf)
    for xb in regs:
        if not np.all(np.isfinite(xb)):
            continue
        g = 1.0 - holdout_rms(np.column_stack([Xb, xb]), S, fold, masks) / r0
        best = np.fmax(best, g)
    return best


def candidate_regressors(wd, base, cands, grid: int) -> list[np.ndarray]:
    """The block regressors (:func:`regressors`) of every single candidate of ``cands`` that
    adds a term to the fitted ``base`` model (no swap, no pair, no failed fit): the
    candidates :func:`chance_test` maximises over."""
    fitter = base._fitter  # type: ignore[attr-defined]
    regs: list[np.ndarray] = []
    for c in cands:
        if c.spec is None or c.replaces or c.pair is not None or c.error:
            continue
        try:
            regs += regressors(fitter.d, c, wd, grid)
        except (ValueError, KeyError, FloatingPointError, np.linalg.LinAlgError):
            continue
    return regs


def chance_test(wd, base, cands, gain: float, *, folds: int, k: int, grid: int,
                seed: int, resid: np.ndarray | None = None, shifts: bool = False,
                regs: list[np.ndarray] | None = None) -> ChanceTest | None:
    """The look-elsewhere surrogate test (module docstring) of a held-out ``gain`` (fraction)
    chosen among the judged candidates ``cands`` of a step on the fitted ``base`` model;
    None when no candidate regressor could be built. ``resid``: the series whose surrogates
    are drawn (default the base model's residual); ``shifts``: circular shifts and reversals
    (:func:`shift_surrogates`) instead of phase randomisation; ``regs``: the candidates'
    regressors when already built (:func:`candidate_regressors` of ``cands``)."""
    chunk, buf, _ = cv_layout(wd, folds)
    fold, masks = holdout_folds(wd.nb, folds, chunk_blocks=chunk, buffer_blocks=buf)
    fitter = base._fitter  # type: ignore[attr-defined]
    if regs is None:
        regs = candidate_regressors(wd, base, cands, grid)
    e = base.resid if resid is None else resid  # type: ignore[attr-defined]
    S = shift_surrogates(e, k) if shifts else None
    best = best_chance_gains(fitter.X(base._thetas), e,  # type: ignore[attr-defined]
                             regs, fold, masks, k, np.random.default_rng(seed), S=S)
    if not np.isfinite(best).any():
        return None
    return ChanceTest(gain=gain, best=best, kind="shifts" if shifts else "phase")


def pair_chance_test(wd, base, cands, a, b, gain: float, *, folds: int, k: int, top: int,
                     seed: int) -> ChanceTest | None:
    """The look-elsewhere surrogate test of a pair (``a``, ``b``) chosen together with a
    held-out ``gain`` (fraction): M_k is the best held-out gain any pair of the ``top``
    single candidates of the step (best held-out RMS first, the two members included, each
    at its fitted nonlinear parameters) reaches on the k-th phase-randomised surrogate of
    the base model's residual. None when fewer than two regressors could be built."""
    chunk, buf, _ = cv_layout(wd, folds)
    fold, masks = holdout_folds(wd.nb, folds, chunk_blocks=chunk, buffer_blocks=buf)
    fitter = base._fitter  # type: ignore[attr-defined]
    singles = sorted((c for c in cands if c.spec is not None and not c.replaces
                      and c.pair is None and not c.error and np.isfinite(c.rms_holdout)),
                     key=lambda c: c.rms_holdout)[:top]
    for m in (a, b):
        if m is not None and m.spec is not None and all(m is not c for c in singles):
            singles.append(m)
    blocks = []
    for c in singles:
        try:
            blocks.append(regressors(fitter.d, c, wd, 0)[0])
        except (ValueError, KeyError, FloatingPointError, np.linalg.LinAlgError, IndexError):
            continue
    regs = [np.column_stack([blocks[i], blocks[j]])
            for i in range(len(blocks)) for j in range(i + 1, len(blocks))]
    if not regs:
        return None
    best = best_chance_gains(fitter.X(base._thetas), base.resid,  # type: ignore[attr-defined]
                             regs, fold, masks, k, np.random.default_rng(seed))
    if not np.isfinite(best).any():
        return None
    return ChanceTest(gain=gain, best=best, kind="pairs")


__all__ = ["ChanceTest", "best_chance_gains", "candidate_regressors", "chance_test",
           "holdout_rms", "pair_chance_test",
           "phase_surrogates", "regressors", "shift_surrogates"]

