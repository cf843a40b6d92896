"""Which physical effect is the model missing? One likelihood decides.

The statistical model (:mod:`.likelihood`): the block-mean rate is Σ β_k·x_k(θ_k) plus the
gyro's own noise -- white, flicker and random-walk rate noise seen through the workbench's
smoother and block averaging -- whose parameters are fitted by maximum likelihood on the same
log (or fixed from a static reference run). Every decision is a likelihood-ratio test or an
information criterion on that model:

1. **Candidates** (:func:`gyrotest.envmodel.screen.candidate_terms`): every library term the
   log's channels allow and the model lacks, a screen of every logged channel (level, square,
   rate; a lagged node's level, square and rate with a fitted τ; products where physics has
   them), the field blocks in the gyro's own axes (``Hvec``, ``Hquad``, in place of the
   model's per-axis field terms), and the nuisance terms (ramp, sinusoid, hysteresis; a
   warm-up only when the log starts at the gyro's power-on).
2. **One test per candidate.** The candidate is added to the model (its design columns
   whitened by the Cholesky factor of the noise covariance) and scored by the likelihood
   ratio Λ = 2(ℓ₁ − ℓ₀), with the noise shape of the model and the noise level re-estimated
   (σ² profiled: Λ = m·ln(RSS₀/RSS₁) on m whitened differences). Under "nothing missing",
   Λ ~ χ² with the candidate's number of coefficients. A time constant, frequency or
   hysteresis width searched over a range exists only under the alternative; its p-value is
   Davies' (1987) bound P(χ²_s > u) + V·u^{(s−1)/2}·e^{−u/2}·2^{−s/2}/Γ(s/2), V the total
   variation of √Λ over the searched range.
3. **One criterion.** "Missing effect" when the smallest p-value, multiplied by the number of
   candidates tried in the step (Bonferroni), is at most the family-wise α (default
   :data:`ALPHA` = 1 %). Moves of two terms at once are not made: on the campaign they
   named a true effect once in 17 steps and raised a third of the false alarms on real
   noise.
4. **Indistinguishable candidates.** Candidates whose models are within ΔBIC ≤
   :data:`BIC_TIE` of the best are not told apart by the data (Kass & Raftery 1995): they
   are named together, with the measurement that would separate them; among them a
   physical library term is preferred to a generic channel form, and that to a nuisance
   term (the prior order of :data:`gyrotest.envmodel.screen.CLASS_ORDER`).
5. **Replace, not stack.** After the chosen term is added, a model term of the same sensor
   or field that the data no longer support beside it (ΔBIC of dropping it < −BIC_TIE) is
   named as the term it replaces ("Tlag in place of T").
6. **Nothing missing.** When no candidate passes, the residual is checked against the noise
   model: the whitened residual should be white (Ljung–Box test over :data:`WHITE_LAGS`
   lags at the same α); the verdict prints the residual's N, B, K. A model term the data do
   not support (ΔBIC of dropping it < −BIC_TIE) is named for removal.
7. **Never degenerate.** A candidate whose design column lies in the span of the model's
   (variance inflation ≥ :data:`gyrotest.envmodel.modelfit.VIF_MAX`) is not proposed.

Sources: S. S. Wilks (1938) (likelihood ratio); R. B. Davies, Biometrika 74 (1987) 33–43;
R. E. Kass, A. E. Raftery, JASA 90 (1995) 773–795 (Bayes factors, ΔBIC); G. M. Ljung,
G. E. P. Box, Biometrika 65 (1978) 297–303.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
from scipy import optimize

from ..core.errors import AnalysisError, InputError
from .calibration import Calibrated, noisy_model_channels, sensor_limit
from .candidate import Candidate, Removal
from .lookelsewhere import (
    Whiteness,
    davies_log_p,
    family_p,
    ljung_box,
    total_variation,
)
from .modelfit import VIF_MAX, FitResult, WorkData, fit_model
from .screen import CLASS_ORDER, block_candidates, candidate_terms, period_matches, term_class
from .terms import TermSpec, describe, nonlinear_bounds, parse_terms, resolve_terms
from .workbench_rules import (  # noqa: E402  (the decision constants, one source)
    ALPHA,
    BIC_TIE,
    TAU_POINTS,
    WHITE_LAGS,
)

#: within a class, simpler forms first at equal evidence (x before x², a lag before a rate)
FORM_ORDER = {"chan": 0, "chanlag": 1, "dchan": 2, "dchanlag": 3, "chan2": 4, "chanabs": 5,
              "chanprod": 6, "Tlag": 0, "dTlagdt": 1, "Tlag2": 2, "Hsq": 2, "Hmag2": 2,
              "Hprod": 3, "T2": 2, "T3": 4, "g2": 2, "gprod": 3}
#: multi-coefficient blocks over every field axis (tried after the single terms)
BLOCK_KEYS = ("Hvec", "Hquad")
#: products of two channels (interactions: tried before their main effects only when no
#: main effect passes)
INTERACTION_KEYS = ("Hprod", "gprod", "chanprod")
#: the plain form of a lagged term (a lag that replaces its plain form is the same sensor)
UNLAGGED = {"Tlag": "T", "Tlag2": "T2", "dTlagdt": "dTdt", "chanlag": "chan",
            "dchanlag": "dchan"}


# ============================================================================ the screen
class Screen:
    """The model of one step, whitened once; candidate columns are scored against it."""

    def __init__(self, wd: WorkData, base: FitResult):
        self.wd = wd
        self.base = base
        self.lik = base.noise.lik
        self.m = self.lik.m
        self.design = base.fitter.d
        self.yw = self.lik.whiten(wd.y)
        X = base.fitter.X(base.thetas)
        self.Xw = self.lik.whiten(X)
        self.offsets = base.fitter._offsets()
        self.Q = _orth(self.Xw)
        self.r0 = self.yw - self.Q @ (self.Q.T @ self.yw)
        self.rss0 = float(self.r0 @ self.r0)
        self.log_m = math.log(max(self.m, 2))
        self._grid: list[tuple] | None = None
        self._theta_grid: list[tuple] | None = None
        #: every direction tested in the step (orthonormal bases outside the model's span,
        #: one group per candidate and searched value) and the candidate each belongs to:
        #: the family of the min-P bootstrap (:func:`family_p`)
        self.groups: list[np.ndarray] = []
        self.owner: list[int] = []
        self.current = -1

    def lr_whitened(self, Zw: np.ndarray) -> tuple[float, bool]:
        """Λ of adding whitened columns ``Zw`` to the model; (0, True) when they lie in its
        span (degenerate). The tested direction joins the step's family."""
        if Zw.ndim == 1:
            Zw = Zw[:, None]
        Zp = Zw - self.Q @ (self.Q.T @ Zw)
        own = np.sum(Zp * Zp, axis=0)
        tot = np.sum(Zw * Zw, axis=0)
        live = own > tot / VIF_MAX
        if not live.any():
            return 0.0, True
        Qz = _orth(Zp[:, live])
        self._record(Qz)
        g = Qz.T @ self.r0
        rss1 = max(self.rss0 - float(g @ g), 1e-300)
        return self.m * math.log(self.rss0 / rss1), bool((~live).any())

    def shapes(self) -> list[tuple]:
        """The noise shapes over which :meth:`lr_full` profiles the likelihood: the model's
        own maximum-likelihood shape and a grid of lower and higher flicker and random-walk
        shares around it, down to none, with the model's Gauss–Markov term (if it has one) as
        fitted or removed (logits of :func:`gyrotest.envmodel.likelihood.fit_noise`).
        Each entry: (likelihood, noise level σ² or None for profiled, whitened model design,
        whitened y, ℓ of the model)."""
        if self._grid is not None:
            return self._grid
        from .likelihood import Likelihood, _shares, shape_gamma

        nf = self.base.noise
        self._grid = []
        if nf.n_free == 0 or nf.logits is None:
            return self._grid
        u0 = np.asarray(nf.logits, float)
        steps = (0.5, 0.0, -2.0, -5.0, -30.0)
        # a Gauss–Markov term (at its fitted T_c) as fitted or none
        gm_steps = (0.0, -30.0) if len(u0) == 4 else (None,)
        white = self.wd.white_n2 or None
        X = self.base.fitter.X(self.base.thetas)
        for a, b, c in itertools.product(steps, steps, gm_steps):
            u = u0.copy()
            u[:2] = np.clip(u0[:2] + [a, b], -18.0, 18.0)
            if c is not None:
                u[2] = np.clip(u0[2] + c, -18.0, 18.0)
            sh = _shares(u)
            s2 = (white * float(nf.acov["white"][0]) / max(sh[0], 1e-300)
                  if white else None)
            if nf.extra is not None and s2 is not None:
                # the sensors' noise through the model's terms stays as the model has it
                g = s2 * shape_gamma(nf.acov, sh)
                k = min(len(g), len(nf.extra))
                g[:k] += nf.extra[:k]
                lk, s2 = Likelihood.build(self.lik.grid, g), 1.0
            else:
                lk = Likelihood.build(self.lik.grid, shape_gamma(nf.acov, sh))
            Xw = lk.whiten(X)
            yw = lk.whiten(self.wd.y)
            Q = _orth(Xw)
            r = yw - Q @ (Q.T @ yw)
            ll = _ll(lk, float(r @ r), s2)
            self._grid.append((lk, s2, Q, r, ll))
        return self._grid

    def lr_full(self, Z: np.ndarray) -> float:
        """Λ of adding block-level columns ``Z`` with the noise shape re-estimated under both
        models (profiled over :meth:`shapes`): 2·(max ℓ with Z − max ℓ without). A missing
        effect that the model's noise model had absorbed (a slow effect as random walk)
        regains its full likelihood; without a shape grid (a noise model fixed from a
        reference run) it is the fixed-shape Λ."""
        grid = self.shapes()
        if not grid:
            return self.lr_blocks(Z)[0]
        Z = np.asarray(Z, float).reshape(self.wd.nb, -1)
        best0 = max(g[4] for g in grid)
        best1 = -math.inf
        cur, self.current = self.current, -1
        for lk, s2, Q, r, _ in grid:
            Zw = lk.whiten(Z)
            Zp = Zw - Q @ (Q.T @ Zw)
            own = np.sum(Zp * Zp, axis=0)
            tot = np.sum(Zw * Zw, axis=0)
            live = own > tot / VIF_MAX
            if not live.any():
                continue
            Qz = _orth(Zp[:, live])
            g = Qz.T @ r
            best1 = max(best1, _ll(lk, float(r @ r) - float(g @ g), s2))
        self.current = cur
        return max(0.0, 2.0 * (best1 - best0)) if math.isfinite(best1) else 0.0

    def theta_profiles(self) -> list[tuple]:
        """The model at other values of its own searched parameters (a time constant, a
        frequency, a width: :data:`TAU_POINTS` values over each term's search range, one term
        at a time, the model's noise shape): (orthonormal whitened design, whitened
        residual). A candidate can change the best value of a model term (a warm-up whose
        τ grew long to imitate an ageing ramp returns to its own once the ramp is in);
        :meth:`lr_theta` profiles over them."""
        if self._theta_grid is not None:
            return self._theta_grid
        self._theta_grid = []
        fitter, thetas = self.base.fitter, self.base.thetas
        X0 = fitter.X(thetas)
        for spec in fitter.nl:
            (pname, (lo, hi)), = fitter.bounds[spec.label].items()
            if not (lo > 0 and hi > lo):
                continue
            a, b = self.offsets[spec.label]
            for v in np.exp(np.linspace(math.log(lo), math.log(hi), TAU_POINTS)):
                try:
                    cols = np.asarray(self.design.block(spec, {pname: float(v)}), float)
                except (InputError, ValueError, KeyError, np.linalg.LinAlgError):
                    continue
                X = X0.copy()
                X[:, a:b] = cols.reshape(self.wd.nb, -1)
                Q = _orth(self.lik.whiten(X))
                self._theta_grid.append((Q, self.yw - Q @ (Q.T @ self.yw)))
        return self._theta_grid

    def lr_theta(self, Z: np.ndarray) -> float:
        """Λ of adding block-level columns ``Z`` with the model's own searched parameters
        profiled under both models (:meth:`theta_profiles`, at the model's noise shape)."""
        grid = self.theta_profiles()
        if not grid:
            return 0.0
        Zw = self.lik.whiten(np.asarray(Z, float).reshape(self.wd.nb, -1))
        rss0 = min([self.rss0] + [float(r @ r) for _, r in grid])
        best = self.rss0
        for Q, r in [(self.Q, self.r0)] + grid:
            Zp = Zw - Q @ (Q.T @ Zw)
            own = np.sum(Zp * Zp, axis=0)
            live = own > np.sum(Zw * Zw, axis=0) / VIF_MAX
            if not live.any():
                continue
            g = _orth(Zp[:, live]).T @ r
            best = min(best, float(r @ r) - float(g @ g))
        return max(0.0, self.m * math.log(rss0 / max(best, 1e-300)))

    def not_recording(self):
        """Context in which tested directions do not join the family (a refinement)."""
        import contextlib

        @contextlib.contextmanager
        def cm():
            cur, self.current = self.current, -1
            try:
                yield
            finally:
                self.current = cur

        return cm()

    def _record(self, Qz: np.ndarray) -> None:
        if self.current >= 0 and Qz.shape[1]:
            self.groups.append(Qz)
            self.owner.append(self.current)

    def lr_blocks(self, Z: np.ndarray) -> tuple[float, bool]:
        return self.lr_whitened(self.lik.whiten(np.asarray(Z, float).reshape(self.wd.nb, -1)))

    def nested_in(self, Z: np.ndarray) -> list[str]:
        """Labels of the model's terms whose columns lie in the span of the block-level
        columns ``Z`` (to 1/VIF_MAX of their whitened variance)."""
        Qz = _orth(self.lik.whiten(np.asarray(Z, float).reshape(self.wd.nb, -1)))
        out = []
        for s in self.base.specs:
            if s.key == "bias":
                continue
            a, b = self.offsets[s.label]
            A = self.Xw[:, a:b]
            tot = float(np.sum(A * A))
            if not tot > 0:
                continue
            R = A - Qz @ (Qz.T @ A)
            if float(np.sum(R * R)) < tot / VIF_MAX:
                out.append(s.label)
        return out

    def lr_swap(self, Z: np.ndarray, replaced: list[str]) -> float:
        """Λ of the model with the terms ``replaced`` taken out and columns ``Z`` put in
        (can be negative: the swap fits worse)."""
        keep = np.ones(self.Xw.shape[1], bool)
        for lab in replaced:
            a, b = self.offsets[lab]
            keep[a:b] = False
        A = np.column_stack([self.Xw[:, keep], self.lik.whiten(Z.reshape(self.wd.nb, -1))])
        Q = _orth(A)
        # the direction the swap adds beyond the model (the block nests the replaced terms)
        D = Q - self.Q @ (self.Q.T @ Q)
        self._record(_orth(D))
        r = self.yw - Q @ (Q.T @ self.yw)
        return self.m * math.log(self.rss0 / max(float(r @ r), 1e-300))

    def lr_drop(self, label: str) -> float:
        """Λ of the model's term ``label`` (the model against the model without it)."""
        a, b = self.offsets[label]
        keep = np.ones(self.Xw.shape[1], bool)
        keep[a:b] = False
        Q = _orth(self.Xw[:, keep])
        r = self.yw - Q @ (Q.T @ self.yw)
        return self.m * math.log(max(float(r @ r), 1e-300) / max(self.rss0, 1e-300))


def _ll(lk, rss: float, s2: float | None) -> float:
    """ℓ of a whitened residual sum of squares at noise level σ² (None: profiled)."""
    if s2 is None:
        return lk.profile(rss)[0]
    return lk.loglik(rss, s2)


def _orth(A: np.ndarray) -> np.ndarray:
    """Orthonormal basis of the column space of A (zero and dependent columns dropped)."""
    if A.ndim == 1:
        A = A[:, None]
    if A.shape[1] == 0:
        return np.zeros((A.shape[0], 0))
    s = np.sqrt(np.sum(A * A, axis=0))
    ok = s > 1e-12 * max(float(s.max()), 1e-300)
    if not ok.any():
        return np.zeros((A.shape[0], 0))
    Q, R = np.linalg.qr(A[:, ok] / s[ok])
    d = np.abs(np.diag(R))
    return Q[:, d > 1e-7 * max(float(d.max()), 1e-300)]


def _n_nonlinear(spec: TermSpec) -> int:
    return len(spec.effect.nonlinear)


def score_candidate(sc: Screen, spec: TermSpec, replaces: list[str] | None = None,
                    index: int = -1) -> Candidate:
    """Λ (profiled over a searched parameter) and ΔBIC of one candidate; every direction it
    tests joins the step's family (``index``: the candidate's place in the step), whose
    bootstrap gives the p-values (:func:`family_p`)."""
    c = Candidate(term=spec.label, effect=describe(spec), spec=spec, klass=term_class(spec),
                  replaces="; ".join(replaces) if replaces else None)
    by_label = {s.label: s for s in sc.base.specs}
    k_rep = sum(by_label[r].n_coef + _n_nonlinear(by_label[r]) for r in (replaces or []))
    c.df = spec.n_coef - (k_rep if replaces else 0)
    c.n_params = spec.n_coef + _n_nonlinear(spec)
    sc.current = index
    try:
        if not spec.effect.nonlinear:
            Z = sc.design.block(spec, None)
            if not replaces and Z.shape[1] > 1:
                # a block that contains a model term (a custom form of one of its
                # components) replaces it: the model with both is degenerate
                replaces = sc.nested_in(Z)
                if replaces:
                    c.replaces = "; ".join(replaces)
                    k_rep = sum(by_label[r].n_coef + _n_nonlinear(by_label[r])
                                for r in replaces)
                    c.df = spec.n_coef - k_rep
            if replaces:
                lr, deg = sc.lr_swap(Z, replaces), False
            else:
                lr, deg = sc.lr_blocks(Z)
            if deg and lr <= 0:
                c.degenerate = "its regressor lies in the span of the model's terms"
                return c
            c.lr = max(lr, 0.0)
        else:
            lr, theta, V, rng = _search(sc, spec, replaces)
            c.theta = theta
            c.tv = V
            c.lr = max(lr, 0.0)
            (pname, (lo, hi)), = rng.items()
            unit = spec.effect.nonlinear[0].unit
            c.searched = f"{pname} over {lo:.3g}–{hi:.3g} {unit}"
            if not math.isfinite(lr):
                c.degenerate = "its regressor lies in the span of the model's terms"
                return c
    except (InputError, ValueError, KeyError, np.linalg.LinAlgError, FloatingPointError) as e:
        c.error = f"could not be evaluated: {e}"
        return c
    c.dbic = -c.lr + (c.n_params - (k_rep if replaces else 0)) * sc.log_m
    return c


def _search(sc: Screen, spec: TermSpec, replaces: list[str] | None
            ) -> tuple[float, dict, float, dict]:
    """Profile Λ over a term's nonlinear parameter: (max Λ, θ at the max, total variation
    of √Λ along the search, the searched range)."""
    wd = sc.wd
    rng = nonlinear_bounds(spec, wd.duration_s, wd.resolution_s, wd.refs)
    (pname, (lo, hi)), = rng.items()
    kind = spec.effect.nonlinear[0].kind

    def lr_at(v: float) -> float:
        Z = sc.design.block(spec, {pname: float(v)})
        if replaces:
            return sc.lr_swap(Z, replaces)
        lr, deg = sc.lr_blocks(Z)
        return lr if not (deg and lr <= 0) else 0.0

    # the grid is the tested family (its directions join the min-P bootstrap and its
    # largest Λ is the statistic); the refinement between grid points only estimates θ
    if kind == "freq":
        hi = min(hi, 0.5 / max(sc.lik.grid.delta_s, wd.resolution_s))
        if not hi > lo:
            raise ValueError("no frequency to search below the likelihood's Nyquist frequency")
        f, vals = _freq_curve(sc, lo, hi)
        i = int(np.argmax(vals))
        T = wd.duration_s
        a, b = max(lo, f[i] - 0.25 / T), min(hi, f[i] + 0.25 / T)
        with sc.not_recording():
            r = optimize.minimize_scalar(lambda v: -lr_at(v), bounds=(a, b),
                                         method="bounded",
                                         options={"xatol": 1e-3 / T, "maxiter": 8})
        best = float(r.x) if -float(r.fun) > vals[i] else float(f[i])
        return (float(vals[i]), {pname: best}, total_variation(list(vals)),
                {pname: (lo, hi)})
    n = TAU_POINTS if spec.key != "hyst" else max(6, TAU_POINTS // 2)
    grid = np.exp(np.linspace(math.log(lo), math.log(hi), n))
    vals = [lr_at(v) for v in grid]
    i = int(np.argmax(vals))
    a = math.log(grid[max(i - 1, 0)])
    b = math.log(grid[min(i + 1, n - 1)])
    with sc.not_recording():
        r = optimize.minimize_scalar(lambda u: -lr_at(math.exp(u)), bounds=(a, b),
                                     method="bounded", options={"xatol": 0.02, "maxiter": 8})
    best = math.exp(float(r.x)) if -float(r.fun) > vals[i] else float(grid[i])
    return float(vals[i]), {pname: float(best)}, total_variation(vals), {pname: (lo, hi)}


def _freq_curve(sc: Screen, lo: float, hi: float) -> tuple[np.ndarray, np.ndarray]:
    """Λ of a sinusoid (cos and sin columns) on a 4×-oversampled Fourier grid over [lo, hi].
    The working smoother and the averaging are symmetric filters, which scale a sinusoid
    without shifting its phase; the columns are therefore cos and sin at the likelihood
    samples' centre times (Λ does not depend on a column's scale)."""
    T = sc.wd.duration_s
    nf = int(max(8, math.ceil((hi - lo) * 4.0 * T)))
    f = np.linspace(lo, hi, nf)
    tt = sc.lik.grid.t - sc.lik.grid.t[0]
    W = 2 * np.pi * np.outer(tt, f)
    S = np.concatenate([np.cos(W), np.sin(W)], axis=1)
    Sw = sc.lik.whiten_samples(S)
    Zp = Sw - sc.Q @ (sc.Q.T @ Sw)
    C, Sn = Zp[:, :nf], Zp[:, nf:]
    g1, g2 = C.T @ sc.r0, Sn.T @ sc.r0
    a11 = np.sum(C * C, axis=0)
    a22 = np.sum(Sn * Sn, axis=0)
    a12 = np.sum(C * Sn, axis=0)
    det = a11 * a22 - a12 * a12
    ok = det > 1e-12 * np.maximum(a11 * a22, 1e-300)
    # orthonormal pairs (Gram–Schmidt per frequency) for the min-P family
    n1 = np.sqrt(np.maximum(a11, 1e-300))
    q1 = C / n1
    s2 = Sn - q1 * np.sum(q1 * Sn, axis=0)
    n2 = np.sqrt(np.maximum(np.sum(s2 * s2, axis=0), 1e-300))
    q2 = s2 / n2
    for j in np.flatnonzero(ok):
        sc._record(np.column_stack([q1[:, j], q2[:, j]]))
    gain = np.zeros(nf)
    gain[ok] = (a22[ok] * g1[ok] ** 2 - 2 * a12[ok] * g1[ok] * g2[ok]
                + a11[ok] * g2[ok] ** 2) / det[ok]
    rss1 = np.maximum(sc.rss0 - gain, 1e-300)
    return f, sc.m * np.log(sc.rss0 / rss1)


def _columns(sc: Screen, c: Candidate) -> np.ndarray | None:
    """The candidate's block-level columns at its best searched value (a swap: its columns
    beside the model, whose span nests the replaced terms); None without a term."""
    if c.spec is None:
        return None
    return sc.design.block(c.spec, c.theta or None)


def _n_replaced(sc: Screen, c: Candidate) -> int:
    by_label = {s.label: s for s in sc.base.specs}
    return sum(by_label[r].n_coef + _n_nonlinear(by_label[r])
               for r in (c.replaces or "").split("; ") if r in by_label)


# ============================================================================ a step
def step_candidates(wd: WorkData, base: FitResult, candidates=None) -> list[tuple[TermSpec,
                                                                                  list[str]]]:
    """The moves of one step: (term, labels of the model terms it replaces)."""
    if candidates is None:
        cands = candidate_terms(wd.frame, base.specs)
        if not getattr(wd, "power_on", False):
            cands = [c for c in cands if c.key != "warmup"]
        moves = [(c, []) for c in cands]
        moves += [(s, rep) for s, rep in block_candidates(wd.frame, base.specs)]
        return moves
    specs = resolve_terms(parse_terms(candidates), wd.frame)
    have = {s.label for s in base.specs}
    return [(s, []) for s in specs if s.label not in have]


def _second_tier(c: Candidate, used: set[str]) -> bool:
    """A move tried after the main effects: a field block, or an interaction of channels
    the model does not use yet."""
    if c.spec is None:
        return False
    if c.spec.key in BLOCK_KEYS:
        return True
    return c.spec.key in INTERACTION_KEYS and not (set(c.spec.channels) & used)


def _prior_key(c: Candidate, used: set[str]):
    new = len(set(c.spec.channels) - used) if c.spec is not None else 0
    return (CLASS_ORDER.get(c.klass, 9), new,
            FORM_ORDER.get(c.spec.key if c.spec else "", 5), c.log_p)


def judge_step(wd: WorkData, base: FitResult, candidates=None, *, alpha: float = ALPHA,
               progress=None) -> tuple[list[Candidate], Candidate | None]:
    """Score every move of the step against ``base``; return them (most significant first)
    and the chosen missing effect (None when no move passes at the family-wise ``alpha``)."""
    sc = Screen(wd, base)
    moves = step_candidates(wd, base, candidates)
    out: list[Candidate] = []
    for i, (spec, rep) in enumerate(moves):
        if progress:
            progress(i, len(moves), spec.label)
        out.append(score_candidate(sc, spec, rep or None, index=i))
    sc.current = -1
    local, p_fw, _ = family_p(sc, len(out))
    tested = []
    for i, c in enumerate(out):
        if c.degenerate is None and c.error is None and math.isfinite(local[i]):
            c.log_p = float(local[i])
            c.p_fw = float(p_fw[i])
            tested.append(c)
        else:
            c.log_p = math.nan
    # the step's tests share its family-wise α (Bonferroni), each at α/k: (a) the min-P
    # bootstrap of the likelihood ratio at the model's own noise shape; (b) the likelihood
    # ratio with the noise shape, or the model's own searched parameters, re-estimated
    # under both models (Wilks; Davies for a searched value; Bonferroni over the step's
    # candidates). (b) regains a missing effect that the model had absorbed — in its noise
    # model (a slow effect taken for random walk) or in another term's time constant (a
    # warm-up τ grown long to imitate a ramp) — which (a), at the absorbing values, cannot
    # see. Without a shape grid (a noise model fixed from a reference run) or a searched
    # parameter in the model, (a) and (b) are one test.
    n_c = max(1, len(tested))
    two = bool(sc.shapes() or sc.theta_profiles())
    k_tests = 2 if two else 1
    if k_tests > 1 and not two:
        for c in tested:
            c.p_fw = min(1.0, k_tests * c.p_fw)
    if two:
        for c in tested:
            lr = c.lr
            try:
                Z = _columns(sc, c)
                if Z is not None:
                    with sc.not_recording():
                        lr = max(sc.lr_full(Z), sc.lr_theta(Z))
            except (InputError, ValueError, KeyError, np.linalg.LinAlgError):
                pass
            p_full = min(1.0, n_c * math.exp(davies_log_p(lr, max(c.df, 1), c.tv)))
            c.p_fw_full = p_full
            c.p_fw = min(1.0, k_tests * min(c.p_fw, p_full))
            c.lr_fixed, c.lr = c.lr, max(c.lr, lr)
            c.dbic = -c.lr + (c.n_params - _n_replaced(sc, c)) * sc.log_m
    for c in out:
        c.trials = n_c
    for c in tested:
        c.significant = c.p_family <= alpha
    out.sort(key=lambda c: (c.log_p if math.isfinite(c.log_p) else math.inf))
    used = {ch for s in base.specs for ch in s.channels}
    sig = [c for c in tested if c.significant]
    # a gain the model's own sensor noise could give (a better reading of the same nodes,
    # by another sensor of the group or a lag or rate of the same one) is not a new effect
    for c in sig:
        lim = sensor_limit(sc, c, alpha)
        if lim is not None:
            c.sensor_limited = lim
            c.significant = False
            c.sensor_reason = (f"reads the model's nodes better, but by no more than a "
                               f"noise-free reading of the model's own sensors would (Λ ≈ "
                               f"{lim[0]:.1f} ± {lim[1]:.1f})")
    sig = [c for c in sig if c.significant]
    # ... nor a gain that the model read through its sensors' reconstructed nodes leaves no
    # room for (regression calibration: an attenuated coefficient leaves the effect in the
    # residual, where any smoother reading of the same node takes it); tested on the moves
    # about to be chosen, in the order they are tried
    cal: list[Calibrated] = []

    def calibration_limited(c: Candidate) -> bool:
        if not noisy_model_channels(wd, base, c.spec):
            return False
        if not cal:
            cal.append(Calibrated(wd, base))
        lam, p_cal = cal[0].p_family(c, n_c, k_tests)
        if not (math.isfinite(p_cal) and p_cal > alpha):
            return False
        c.sensor_limited = (lam, 0.0)
        c.significant = False
        c.sensor_reason = (f"passes on the model as read, but on the model read through its "
                           f"sensors' reconstructed nodes (regression calibration) it gains "
                           f"only Λ = {lam:.1f} (family-wise p = {p_cal:.2g})")
        return True
    # main effects first: a field block (several coefficients at once), or a product of two
    # channels neither of which the model uses yet (weak heredity: Chipman 1996), only when
    # no main effect passes
    singles = [c for c in sig if not _second_tier(c, used)]
    if singles:
        sig = singles
    chosen = None
    while sig and chosen is None:
        best_bic = min(c.dbic for c in sig)
        tied = [c for c in sig if c.dbic <= best_bic + BIC_TIE]
        for c in sorted(tied, key=lambda c: _prior_key(c, used)):
            if calibration_limited(c):
                continue
            try:
                chosen = refit(wd, base, c)
            except AnalysisError as e:  # a degenerate model: not proposed
                c.degenerate = str(e)
                c.significant = False
                chosen = None
                continue
            break
        # every move of the tie degenerate or limited by the sensors: the next passing ones
        sig = [c for c in sig if c.significant and c not in tied]
        if chosen is not None:
            others = [c for c in tied if c is not chosen and c.significant]
            chosen.equivalents = [c.term for c in others]
            if others:
                other = others[0]
                chosen.advice = separation_advice(chosen, other)
    return out, chosen


def refit(wd: WorkData, base: FitResult, c: Candidate) -> Candidate:
    """Fit the model with the candidate (its nonlinear parameters re-optimised from the
    screen's, the noise re-estimated): the held-out gain, the coefficient's z, Λ with the
    noise re-estimated under both models; and the model term it replaces, if the data no
    longer support one beside it."""
    base_specs = [s for s in base.specs if s.key != "bias"]
    gone = set((c.replaces or "").split("; ")) - {""}
    specs = [s for s in base_specs if s.label not in gone] + [c.spec]
    th0 = {k: v for k, v in base.thetas.items() if k not in gone}
    if c.theta:
        th0[c.term] = dict(c.theta)
    r = fit_model(wd, specs, thetas0=th0, new_terms=[c.spec], light=True,
                  noise_start=base.noise)
    if not gone:
        rep = replaced_term(wd, r, c)
        if rep is not None:
            label, _ = rep
            specs2 = [s for s in specs if s.label != label]
            th2 = {k: v for k, v in r.thetas.items() if k != label}
            r = fit_model(wd, specs2, thetas0=th2, light=True, noise_start=r.noise)
            c.replaces = label
    _attach(c, base, r)
    return c


def _attach(c: Candidate, base: FitResult, r: FitResult) -> None:
    c._fit = r
    c.rms_fit = r.rms_fit
    c.rms_holdout = r.rms_holdout
    if math.isfinite(base.rms_holdout) and base.rms_holdout > 0:
        c.improvement_pct = 100.0 * (base.rms_holdout - r.rms_holdout) / base.rms_holdout
    c.lr_refit = 2.0 * (r.loglik - base.loglik)
    own = [cf for cf in r.coefficients if cf.term == c.term and cf.kind == "linear"]
    if own:
        c.z = max((cf.z for cf in own), key=lambda z: abs(z) if math.isfinite(z) else -1)
    c.coefficients = [cf.to_dict() for cf in r.coefficients if cf.term == c.term]


def replaced_term(wd: WorkData, r: FitResult, c: Candidate) -> tuple[str, float] | None:
    """A model term that the data no longer support beside the new one: of the terms that
    act through the same channel (or are its plain form), the one whose removal improves
    the BIC most, if by more than :data:`BIC_TIE`. Returns (label, ΔBIC) or None."""
    if c.spec is None:
        return None
    chans = set(c.spec.channels)
    plain = UNLAGGED.get(c.spec.key)
    sc = Screen(wd, r)
    best = None
    for s in r.specs:
        if s.key == "bias" or s.label == c.term:
            continue
        if not (chans & set(s.channels)) and s.key != plain:
            continue
        lr = sc.lr_drop(s.label)
        k = s.n_coef + _n_nonlinear(s)
        dbic = lr - k * sc.log_m
        if dbic < -BIC_TIE and (best is None or dbic < best[1]):
            best = (s.label, dbic)
    return best


def separation_advice(a: Candidate, b: Candidate) -> str:
    from .modelfit import _advice

    ka = a.spec.key if a.spec else ""
    kb = b.spec.key if b.spec else ""
    return _advice(ka, kb)


def removal(wd: WorkData, base: FitResult) -> Removal | None:
    """The model term whose removal improves the BIC most, if by more than
    :data:`BIC_TIE` (the data favour the model without it)."""
    sc = Screen(wd, base)
    best = None
    for s in base.specs:
        if s.key == "bias":
            continue
        lr = sc.lr_drop(s.label)
        k = s.n_coef + _n_nonlinear(s)
        dbic = lr - k * sc.log_m
        if dbic < -BIC_TIE and (best is None or dbic < best.dbic):
            best = Removal(s.label, lr, k, dbic)
    return best


def residual_whiteness(base: FitResult) -> Whiteness:
    """Ljung–Box test of the model's whitened residual (the standardised innovations under
    its noise model)."""
    sc_lik = base.noise.lik
    X = base.fitter.X(base.thetas)
    e = sc_lik.whiten(base.wd.y - X @ np.array([cf.value for cf in base.coefficients
                                                  if cf.kind == "linear"]))
    return ljung_box(e, WHITE_LAGS, fitted=base.noise.n_free)


def stimulus_note(c: Candidate, frame) -> str | None:
    """A sinusoid whose period is that of a logged stimulus: say so."""
    if c.spec is None or c.spec.key != "sin" or "f_Hz" not in c.theta:
        return None
    ms = period_matches(frame, float(c.theta["f_Hz"]))
    if not ms:
        return None
    names = ", ".join(f"{n} (R² {r2:.2f})" for n, r2 in ms[:3])
    return (f"its period {1.0 / c.theta['f_Hz']:.4g} s is also that of the logged stimulus "
            f"{names}, but no term of that channel explains it as well")


__all__ = ["ALPHA", "BIC_TIE", "Candidate", "Removal", "Screen", "TAU_POINTS",
           "judge_step", "refit", "removal", "residual_whiteness", "score_candidate"]
