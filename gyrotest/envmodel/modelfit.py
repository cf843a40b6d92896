"""Fitting an environmental drift model to a bench log.

The log is first reduced to smoothed block means (:mod:`.workdata`: the working resolution,
the smoother S_W and the block length T_b, re-exported here).

Estimation
----------
Under the gyro's own noise model (:mod:`.likelihood`): white, flicker and random-walk rate
noise seen through the smoother and the block averaging, its two shape parameters and level
fitted by maximum likelihood with the model (or fixed from a static reference run). The
linear coefficients are generalised least squares (GLS) under that noise model, with its
covariance (Xᵀ Σ⁻¹ X)⁻¹ σ̂². Terms with a time constant or frequency by variable projection:
first on the ordinary residual sum of squares (the nonlinear parameter is searched on a log
grid / from the four highest peaks of the residual periodogram and refined by bounded Brent
minimisation, the linear coefficients solved exactly at each step; two or more time
constants polished jointly by a Nelder–Mead search over their logarithms), then refined
locally on the GLS objective once the noise model is known, and the noise model refitted. A
model fitted from the nonlinear parameters of a smaller one (``thetas0``: a candidate the
diagnosis adds) re-checks them beside the new terms (:mod:`.varpro`). Uncertainties: GLS on
the Gauss–Newton Jacobian (linear columns plus ∂ŷ/∂θ), so nonlinear-parameter uncertainty
propagates; the bias D_F's from the noise model's Allan variance at the record length. A
degenerate design (a variance inflation factor ≥ VIF_MAX) is refused. Held-out validation
(:func:`cv_layout`): the blocks are cut into contiguous chunks of max(6·W, duration/500) (at
least 2·folds chunks); chunk c belongs to fold c mod folds; each fold is predicted from a GLS
fit on the other folds (the same noise shape; a searched frequency searched afresh on the
training folds, time constants kept at the full-data value, which a fold without the
start-up could not pin down, and so are the coefficients along directions that barely vary
outside the held-out chunk), leaving out 2·W on either side of each held-out chunk so that
neither the smoother nor short-memory noise carries held-out data into the training set.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..core.errors import AnalysisError
from . import stats as st
from .excursions import Excursion
from .likelihood import (
    NoiseFit,
    NoiseParams,
    fit_noise,
    fixed_noise,
    gls,
    lik_grid,
    white_level,
)
from .model import EnvModel, ModelTerm
from .terms import (
    TermSpec,
    describe,
    parse_terms,
    resolve_terms,
)
from .varpro import TAU_GRID, Design, _Fitter, _rss  # noqa: F401  (re-exported)
from .workbench_rules import MIN_RELIABILITY, VIF_MAX
from .workdata import (  # noqa: F401  (re-exported)
    MAX_BLOCKS,
    MAX_RES_S,
    MIN_BLOCKS_RES,
    NICE_STEPS,
    WorkData,
    _nice_floor,
    channel_ranges,
    choose_resolution,
    choose_smoothing,
    effective_averaging_time,
    file_provenance,
    prepare,
)


# ============================================================================ design matrix
# ============================================================================ results
@dataclass
class Coefficient:
    """A fitted coefficient with its unit and autocorrelation-robust uncertainty."""

    name: str
    symbol: str
    term: str
    value: float
    stderr: float  # 1σ, GLS under the gyro's noise model
    stderr_ols: float  # naive OLS on block means (independent-residual assumption)
    unit: str
    kind: str = "linear"

    @property
    def z(self) -> float:
        return self.value / self.stderr if self.stderr and self.stderr > 0 else float("nan")

    @property
    def p(self) -> float:
        from scipy import stats as sps

        z = self.z
        return float(2 * sps.norm.sf(abs(z))) if math.isfinite(z) else float("nan")

    @property
    def significance(self) -> str:
        z = abs(self.z)
        if not math.isfinite(z):
            return "n/a"
        if z >= 5:
            return "strong"
        if z >= 3:
            return "significant"
        if z >= 2:
            return "marginal"
        return "not significant"

    def to_dict(self) -> dict:
        return {"name": self.name, "symbol": self.symbol, "term": self.term, "value": self.value,
                "stderr": self.stderr, "stderr_ols_naive": self.stderr_ols, "unit": self.unit,
                "z": self.z, "p": self.p, "significance": self.significance, "kind": self.kind}


@dataclass
class FitResult:
    """Everything a model fit produced (``to_dict`` for JSON; arrays kept for plots)."""

    model: EnvModel
    specs: list[TermSpec]
    coefficients: list[Coefficient]
    n_blocks: int
    n_params: int
    resolution_s: float
    resolution_note: str
    rms_fit: float
    rms_holdout: float
    holdout_fold_rms: list[float]
    holdout_scheme: str
    aic: float
    bic: float
    condition_number: float
    vif: dict[str, float]
    warnings: list[str]
    noise: NoiseFit  # the gyro's noise model under which the coefficients were fitted
    loglik: float  # Gaussian log-likelihood of the differenced likelihood samples
    rms_raw: float  # RMS of the mean-removed block means (no model)
    floor: st.NoiseFloor | None = None
    adev_tau: np.ndarray | None = None
    adev_sigma: np.ndarray | None = None
    excursions: list[Excursion] = field(default_factory=list)
    data: dict[str, Any] = field(default_factory=dict)
    # arrays (not serialised)
    t: np.ndarray | None = None
    y: np.ndarray | None = None
    yhat: np.ndarray | None = None
    resid: np.ndarray | None = None
    holdout_resid: np.ndarray | None = None
    fold_of_block: np.ndarray | None = None
    cov: np.ndarray | None = None
    param_names: list[str] = field(default_factory=list)
    wd: WorkData | None = None
    #: the nonlinear parameters {term label: {name: value}} and the fitter that built the
    #: design (for predictions and warm starts)
    thetas: dict = field(default_factory=dict)
    fitter: Any = None

    @property
    def _thetas(self) -> dict:
        return self.thetas

    @property
    def _fitter(self):
        return self.fitter

    @property
    def terms(self) -> list[str]:
        return [s.label for s in self.specs]

    def coef(self, name: str) -> Coefficient:
        for c in self.coefficients:
            if c.name == name or c.term == name or c.symbol == name:
                return c
        raise KeyError(name)

    def to_dict(self) -> dict:
        d = {
            "terms": self.terms,
            "term_descriptions": {s.label: describe(s) for s in self.specs},
            "coefficients": [c.to_dict() for c in self.coefficients],
            "rms_raw_dph": self.rms_raw,
            "rms_fit_dph": self.rms_fit,
            "rms_holdout_dph": self.rms_holdout,
            "holdout_fold_rms_dph": self.holdout_fold_rms,
            "holdout_scheme": self.holdout_scheme,
            "aic": self.aic, "bic": self.bic,
            "n_blocks": self.n_blocks, "n_params": self.n_params,
            "resolution_s": self.resolution_s, "resolution_note": self.resolution_note,
            "smoothing_window_s": self.model.refs.smoothing_s,
            "condition_number": self.condition_number, "vif": self.vif,
            "uncertainty": {"method": UNCERTAINTY},
            "noise_model": self.noise.params.to_dict(),
            "loglik": self.loglik,
            "noise_floor": self.floor.to_dict() if self.floor else None,
            "residual_allan": ({"tau_s": self.adev_tau, "sigma_dph": self.adev_sigma}
                               if self.adev_tau is not None else None),
            "excursions": [e.to_dict() for e in self.excursions],
            "warnings": self.warnings,
            "data": self.data,
            "model": self.model.to_dict(),
        }
        return d


# ============================================================================ core fitting
def holdout_folds(nb: int, folds: int = 5, *, chunk_blocks: int | None = None,
                  buffer_blocks: int = 0) -> tuple[np.ndarray, list[np.ndarray]]:
    """Blocked cross-validation: fold id per block, and the training mask of each fold.

    The nb blocks are cut into contiguous chunks of ``chunk_blocks`` (default nb/(4·folds));
    chunk c is in fold c mod folds; the training mask of a fold leaves out its chunks plus
    ``buffer_blocks`` on both sides of each (so that the smoother and autocorrelated noise do
    not carry held-out data into the training set).
    """
    if chunk_blocks is None:
        chunk_blocks = max(1, nb // (4 * folds))
    n_chunks = max(folds, int(round(nb / chunk_blocks)))
    edges = np.linspace(0, nb, n_chunks + 1).astype(int)
    fold = np.empty(nb, dtype=int)
    for c in range(n_chunks):
        fold[edges[c]:edges[c + 1]] = c % folds
    masks = []
    for f in range(folds):
        excl = fold == f
        if buffer_blocks > 0:
            excl = excl.copy()
            for c in range(f, n_chunks, folds):
                a, b = edges[c], edges[c + 1]
                excl[max(0, a - buffer_blocks):a] = True
                excl[b:min(nb, b + buffer_blocks)] = True
        masks.append(~excl)
    return fold, masks


def cv_layout(wd: WorkData, folds: int = 5) -> tuple[int, int, str]:
    """Chunk and buffer sizes (blocks) for :func:`holdout_folds` on this data.

    Chunks last max(6·W, duration/500, 2·T_b) so a start-up transient is predicted from data
    close to it rather than extrapolated over a long stretch, with at least 2·folds chunks;
    the buffer spans the smoother's full width 2·W on each side (at most a quarter chunk).
    """
    W = wd.refs.smoothing_s
    tb = wd.resolution_s
    chunk_s = max(6.0 * W, wd.duration_s / 500.0, 2.0 * tb)
    chunk = max(1, int(round(chunk_s / tb)))
    chunk = min(chunk, max(1, wd.nb // (2 * folds)))
    buf = min(int(math.ceil(2.0 * W / tb)), chunk // 4)
    n_chunks = max(folds, int(round(wd.nb / chunk)))
    desc = (f"{folds}-fold blocked cross-validation: {n_chunks} contiguous chunks of "
            f"{chunk * tb:g} s (chunk c in fold c mod {folds}), {buf * tb:g} s left out of "
            "the training set on each side of a held-out chunk")
    return chunk, buf, desc


def fit_model(wd: WorkData, terms: list[TermSpec] | list[str] | str, *, bias: bool = True,
              folds: int = 5, thetas0: dict | None = None,
              light: bool = False, k_sigma: float = 4.0,
              new_terms: list[TermSpec] | None = None,
              noise_start: NoiseFit | None = None) -> FitResult:
    """Fit ``terms`` (plus a bias) to prepared data under the gyro's own noise model; see the
    module docstring.

    Returns a :class:`FitResult` with coefficients in physical units ± 1σ (GLS under the
    fitted noise model, nonlinear parameters by Gauss–Newton), the noise model (N, B, K)
    with the log-likelihood, residual RMS (deg/h) on the fit and on held-out blocks,
    AIC/BIC from the likelihood, collinearity diagnostics, the residual Allan deviation,
    excursions (|residual| > k·σ) and the portable :class:`EnvModel`. ``light`` skips the
    Allan/excursion work. ``thetas0``/``new_terms``: the nonlinear parameters of a smaller
    model and the terms added to it (warm start, see :mod:`.varpro`); ``noise_start``: the
    noise fit of a related model (warm start of the noise shape). A design whose terms are
    degenerate (a variance inflation factor ≥ :data:`VIF_MAX`) raises AnalysisError naming
    the collinear terms.
    """
    specs = parse_terms(terms)  # texts and TermSpecs, mixed freely
    specs = [s for s in specs if s.key != "bias"]
    specs = resolve_terms(specs, wd.frame)
    if bias:
        specs = [TermSpec("bias")] + specs
    n_params = sum(s.n_coef + len(s.effect.nonlinear) for s in specs)
    if wd.nb < n_params + 2:
        names = ", ".join(s.label for s in specs)
        raise AnalysisError(f"terms {names} need {n_params} parameters but {wd.info['source']} "
                            f"gives only {wd.nb} blocks of {wd.resolution_s:g} s; use a longer "
                            "log, fewer terms or a finer --resolution")
    design = Design(wd)
    fitter = _Fitter(design, specs, {c.label for c in new_terms or []})
    # ---- the nonlinear parameters: least squares first (a start), then under the noise model
    thetas = fitter.optimise(thetas0, None, local=True)
    if thetas0:
        thetas = fitter.recheck_taus(thetas, set(thetas0))
        thetas = fitter.rescan(thetas, set(thetas0))
        if new_terms:
            thetas = fitter.repolish(thetas, set(thetas0), new_terms)
    elif len(fitter.nl) > 1:
        alt = fitter.incremental()
        if fitter.solve(alt, None)[1] < fitter.solve(thetas, None)[1]:
            thetas = alt
        thetas = fitter.polish_joint(thetas)
    grid = lik_grid(wd)
    nf = model_noise(wd, grid, fitter, thetas, start=noise_start)
    if fitter.nl:
        fitter.lik = nf.lik
        thetas = fitter.optimise(thetas, None, local=True)
        if nf.n_free:
            nf = model_noise(wd, grid, fitter, thetas, start=nf)
    fitter.lik = nf.lik
    X = fitter.X(thetas)
    draws: dict = {}
    if nf.n_free and getattr(wd, "sensor_noise", None):
        # the noise the terms carry from their sensors joins the noise model (errors in
        # variables): a model whose residual holds a noisy thermometer's noise times a large
        # coefficient is not then "missing" whatever averages that noise out
        from .sensors import eiv_acov, eiv_draws, eiv_series

        draws = eiv_draws(wd, specs, thetas)
        if draws:
            b0, _, _ = gls(nf.lik.whiten(X), nf.lik.whiten(wd.y))
            offs0 = fitter._offsets()
            beta_by = {s.label: b0[offs0[s.label][0]:offs0[s.label][1]] for s in specs}
            E, E_parts = eiv_acov(draws, grid, beta_by, len(nf.acov["white"]))
            if np.any(E > 0):
                nf = model_noise(wd, grid, fitter, thetas, start=nf, extra=E)
                # the sensors' noise enters the residual times the true coefficient, which
                # the GLS one understates by the reliability ratio λ (attenuation, Fuller
                # 1987 §1.1); a second pass takes E at the moment-corrected coefficients
                Xw1, yw1 = nf.lik.whiten(X), nf.lik.whiten(wd.y)
                b1 = gls(Xw1, yw1)[0]
                b1, _ = eiv_corrected(draws, nf.lik, offs0, Xw1, yw1, b1, specs,
                                      min_reliability=0.0)
                beta1 = {s.label: b1[offs0[s.label][0]:offs0[s.label][1]] for s in specs}
                E1, E_parts1 = eiv_acov(draws, grid, beta1, len(nf.acov["white"]))
                if E1[0] > E[0]:
                    E, E_parts, beta_by = E1, E_parts1, beta1
                    nf = model_noise(wd, grid, fitter, thetas, start=nf, extra=E)
                nf.extra_parts = E_parts
                nf.extra_series = eiv_series(draws, beta_by, wd.nb)
                fitter.lik = nf.lik
    lik = nf.lik
    Xw = lik.whiten(X)
    yw = lik.whiten(wd.y)
    beta, rss_w, _ = gls(Xw, yw)
    eiv_note = None
    if draws:
        beta, eiv_note = eiv_corrected(draws, lik, fitter._offsets(), Xw, yw, beta, specs)
        r_w = yw - Xw @ beta
        rss_w = float(r_w @ r_w)
    ib = [i for i, s in enumerate(specs) if s.key == "bias"]
    if ib:
        beta[ib[0]] = float(np.mean(wd.y - X @ beta))
    yhat = X @ beta
    resid = wd.y - yhat
    nb = wd.nb
    # the noise level of the noise model (profiled, or set by the white noise measured on
    # the full band, or by the reference run)
    s2 = nf.scale
    loglik = lik.loglik(rss_w, s2)
    # ---- uncertainties: GLS on the Gauss–Newton Jacobian (linear columns plus ∂ŷ/∂θ)
    Jn, nl_names = fitter.jacobian(thetas, beta)
    J = np.column_stack([X, Jn]) if Jn.shape[1] else X
    _, _, cinv = gls(lik.whiten(J), yw)
    cov = s2 * cinv
    if ib:
        cov[ib[0], ib[0]] = bias_variance(nf.params, wd.duration_s)
    cov_ols = st.ols_covariance(J, resid)
    se = np.sqrt(np.clip(np.diag(cov), 0, None))
    se_ols = np.sqrt(np.clip(np.diag(cov_ols), 0, None))
    coefs: list[Coefficient] = []
    mterms: list[ModelTerm] = []
    offs = fitter._offsets()
    for s in specs:
        a, b = offs[s.label]
        e = s.effect
        unit = e.coef_unit if s.key != "custom" else "deg/h per unit of expression"
        for j, (nm, sym) in enumerate(zip(s.coef_labels(), s.coef_symbols)):
            coefs.append(Coefficient(nm, sym, s.label, float(beta[a + j]), float(se[a + j]),
                                     float(se_ols[a + j]), unit))
        mt = ModelTerm(s, dict(thetas.get(s.label, {})), {}, [float(v) for v in beta[a:b]],
                       [float(v) for v in se[a:b]])
        mterms.append(mt)
    p_lin = X.shape[1]
    for i, (s, pname) in enumerate(nl_names):
        val = thetas[s.label][pname]
        unit = s.effect.nonlinear[0].unit
        coefs.append(Coefficient(f"{s.label}.{pname}", pname, s.label, float(val),
                                 float(se[p_lin + i]), float(se_ols[p_lin + i]), unit,
                                 kind="nonlinear"))
        for mt in mterms:
            if mt.spec.label == s.label:
                mt.theta_stderr[pname] = float(se[p_lin + i])
    names = [c.name for c in coefs]
    # collinearity of the whitened design (what the GLS coefficients see); the bias is not
    # in it (whitening takes differences), so it is left out of the condition number
    live = [j for j in range(p_lin) if j not in ib]
    cond, vif_l, corr_l = st.collinearity(Xw[:, live], [names[j] for j in live])
    vif = vif_l
    corr = np.full((p_lin, p_lin), np.nan)
    corr[np.ix_(live, live)] = corr_l
    degenerate(vif, corr, names[:p_lin], wd)
    # ---- held-out validation (the same noise shape, each fold's coefficients by GLS)
    chunk, buf, cv_desc = cv_layout(wd, folds)
    fold, masks = holdout_folds(nb, folds, chunk_blocks=chunk, buffer_blocks=buf)
    hres = np.full(nb, np.nan)
    fold_rms = []
    for f, m in enumerate(masks):
        if m.sum() < n_params + 2:
            continue
        th_f = fitter.optimise(thetas, m, local=True, kinds=("freq",), fresh=("freq",))
        Xf = fitter.X(th_f)
        lk_f = fitter.lik_for(m)
        if lk_f is None or lk_f.m < 2:
            continue
        bf = fold_coefficients_gls(lk_f, lik, Xf, wd.y, m, beta, ib)
        held = fold == f
        hres[held] = wd.y[held] - Xf[held] @ bf
        fold_rms.append(float(np.sqrt(np.mean(hres[held] ** 2))))
    ok = np.isfinite(hres)
    rms_hold = float(np.sqrt(np.mean(hres[ok] ** 2))) if ok.any() else float("nan")
    rms_fit = float(np.sqrt(np.mean(resid ** 2)))
    k_all = n_params + nf.n_free + 1  # + the noise level σ²
    aic = -2.0 * loglik + 2.0 * k_all
    bic = -2.0 * loglik + k_all * math.log(max(lik.m, 2))
    warnings = _warnings(specs, coefs, vif, corr, names[:p_lin], thetas, fitter, rms_fit,
                         rms_hold, nb, n_params)
    if eiv_note:
        warnings.append(eiv_note)
    rms_raw = float(np.std(wd.y))
    noise = nf.params
    model = EnvModel(terms=mterms, refs=wd.refs, axis=wd.axis, resolution_s=wd.resolution_s,
                     fine_dt_s=wd.frame.dt,
                     fit={"rms_fit_dph": rms_fit, "rms_holdout_dph": rms_hold, "aic": aic,
                          "bic": bic, "n_blocks": nb, "n_params": n_params,
                          "rms_raw_dph": rms_raw, "loglik": loglik,
                          "noise_model": noise.to_dict(),
                          "uncertainty": UNCERTAINTY},
                     data={k: v for k, v in wd.info.items()})
    res = FitResult(model=model, specs=specs, coefficients=coefs, n_blocks=nb,
                    n_params=n_params, resolution_s=wd.resolution_s,
                    resolution_note=wd.resolution_note, rms_fit=rms_fit, rms_holdout=rms_hold,
                    holdout_fold_rms=fold_rms,
                    holdout_scheme=cv_desc,
                    aic=aic, bic=bic, condition_number=cond, vif=vif, warnings=warnings,
                    noise=nf, loglik=loglik, rms_raw=rms_raw, data=dict(wd.info), t=wd.t,
                    y=wd.y, yhat=yhat, resid=resid, holdout_resid=hres, fold_of_block=fold,
                    cov=cov, param_names=names, wd=wd, thetas=thetas, fitter=fitter)
    if not light:
        finish(res, k_sigma=k_sigma)
    return res


#: uncertainty method of every coefficient
UNCERTAINTY = ("GLS under the gyro's noise model (white, flicker and random-walk rate noise "
               "fitted by maximum likelihood on this log, or fixed from a reference run); "
               "nonlinear parameters by Gauss-Newton")


def eiv_corrected(draws, lik, offsets: dict, Xw: np.ndarray, yw: np.ndarray,
                  beta: np.ndarray, specs, min_reliability: float = MIN_RELIABILITY
                  ) -> tuple[np.ndarray, str | None]:
    """The errors-in-variables corrected GLS coefficients (X̃ᵀX̃ − M)⁻¹X̃ᵀỹ with M what the
    sensors' noise adds to X̃ᵀX̃ (:func:`gyrotest.envmodel.sensors.eiv_moment`): a noisy
    regressor's coefficient is otherwise attenuated by its reliability ratio λ. Columns with
    λ < ``min_reliability`` (default :data:`MIN_RELIABILITY`) keep their uncorrected value;
    a note names those below :data:`MIN_RELIABILITY` (the model is limited by that sensor).
    Returns (β, note or None)."""
    from .sensors import eiv_moment

    p = Xw.shape[1]
    M = eiv_moment(draws, lik, offsets, p)
    G = Xw.T @ Xw
    d = np.diag(G)
    live = np.flatnonzero(d > 1e-12 * max(float(d.max()), 1e-300))
    if not np.any(np.diag(M)[live] > 0):
        return beta, None
    rel = 1.0 - np.diag(M)[live] / d[live]
    ok = live[(rel >= min_reliability) & (rel > 0)]
    weak = live[rel < MIN_RELIABILITY]
    note = None
    if len(weak):
        labels = {}
        for s in specs:
            a, b = offsets[s.label]
            for j in range(a, b):
                labels[j] = s.label
        names = sorted({labels.get(int(j), "?") for j in weak})
        note = (f"{', '.join(names)}: limited by the sensor's own noise (reliability "
                f"{float(np.min(rel[rel < MIN_RELIABILITY])):.2f} < {MIN_RELIABILITY:g}): the "
                "coefficient is attenuated; a quieter sensor or a longer --smooth would "
                "read it better")
    Mc = np.zeros_like(M)
    Mc[np.ix_(ok, ok)] = M[np.ix_(ok, ok)]
    A = (G - Mc)[np.ix_(live, live)]
    try:
        b = np.linalg.solve(A, (Xw.T @ yw)[live])
    except np.linalg.LinAlgError:
        return beta, note
    out = np.array(beta, float)
    out[live] = b
    return out, note


def model_noise(wd: WorkData, grid, fitter, thetas: dict, start: NoiseFit | None = None,
                extra: np.ndarray | None = None) -> NoiseFit:
    """The noise model of a term set at fixed nonlinear parameters: fixed from a reference run
    (``wd.noise_ref``), else maximum likelihood with β by GLS inside
    (:func:`gyrotest.envmodel.likelihood.fit_noise`)."""
    ref = getattr(wd, "noise_ref", None)
    if ref is not None:
        return fixed_noise(wd, grid, ref)
    X = fitter.X(thetas)
    # differences of the sample means of [X, y], taken once: each trial shape only solves
    dxy = grid.diffs(grid.means(np.column_stack([X, wd.y])))

    def rss(lk) -> float:
        A = lk.whiten_diffs(dxy, (X.shape[1] + 1,))
        return gls(A[:, :-1], A[:, -1])[1]

    if wd.white_n2 is None:
        wd.white_n2 = white_level(wd)
    return fit_noise(wd, grid, rss, start=start.logits if start is not None else None,
                     white=wd.white_n2 or None, extra=extra)


def bias_variance(p: NoiseParams, duration_s: float) -> float:
    """Variance (deg/h)² of the bias D_F of a record of ``duration_s``: the Allan variance of
    the fitted noise at τ = the record length, N²/T + (2 ln 2/π)·B² + K²·T/3 (IEEE 952
    Annex C): the scatter of the mean rate from one record to the next; a Gauss–Markov term
    of variance σ_m² and correlation time T_c adds
    (2σ_m²T_c/T)·[1 − (T_c/2T)·(3 − 4e^(−T/T_c) + e^(−2T/T_c))] (IEEE 952 Table C.1)."""
    T = max(duration_s, 1.0)
    N = p.N * 60.0
    K = p.K / 60.0
    v = N * N / T + (2 * math.log(2) / math.pi) * p.B ** 2 + K * K * T / 3.0
    if p.markov:
        tc = float(p.gm_tau_s)
        x = T / tc
        v += (2 * p.gm_sigma ** 2 * tc / T) * (1 - (3 - 4 * math.exp(-x) + math.exp(-2 * x))
                                              / (2 * x))
    return v


def degenerate(vif: dict[str, float], corr: np.ndarray, names: list[str], wd: WorkData) -> None:
    """AnalysisError when a term is degenerate with the others (VIF ≥ :data:`VIF_MAX`),
    naming it and its most correlated partner."""
    bad = [(v, nm) for nm, v in vif.items() if not v < VIF_MAX]
    if not bad:
        return
    v, nm = max(bad)
    i = names.index(nm)
    row = np.abs(np.nan_to_num(corr[i].copy()))
    row[i] = 0
    j = int(np.argmax(row))
    other = names[j] if row[j] > 0 else "the other terms"
    raise AnalysisError(f"terms {nm} and {other} are degenerate in "
                        f"{wd.info.get('source', 'this log')} (VIF {v:.3g}): their "
                        "coefficients are not determined by the data; remove one of them")


#: a column whose training-fold variation is below this fraction of its full variation keeps
#: its full-data coefficient in that fold
MIN_FOLD_SUPPORT = 0.02


def fold_coefficients(X: np.ndarray, y: np.ndarray, train: np.ndarray,
                      beta_full: np.ndarray) -> np.ndarray:
    """Least-squares coefficients on the training blocks of a fold, free only along the
    directions the training blocks support (``y`` one series, or an n x K array of series
    with ``beta_full`` p x K: the same rule for each column).

    A direction v of coefficient space is supported when the training blocks carry at least
    :data:`MIN_FOLD_SUPPORT` of the variation the whole record carries along it:
    vᵀ·A_train·v ≥ MIN_FOLD_SUPPORT·vᵀ·A·v, with A = X_cᵀX_c the (column-centred) design's
    information. The supported directions are the generalised eigenvectors of (A_train, A)
    with eigenvalue ≥ MIN_FOLD_SUPPORT; along the others the coefficients keep their
    full-data values, as the time constants do. A regressor (or a combination of them) that
    lives almost only in the held-out chunk -- a warm-up transient shorter than a chunk, the
    one Helmholtz sweep that moves two field axes together -- cannot be estimated without it
    and would otherwise be extrapolated from what is left; with one such column this is the
    plain rule "variation over the training blocks below 2 % of the record's". The
    intercept (a constant column) is always free.
    """
    full = X - X.mean(axis=0)
    v_all = np.sum(full * full, axis=0)
    const = v_all <= 0
    cols = np.flatnonzero(~const)
    if len(cols) == 0:
        return st.lstsq_coef(X[train], y[train])
    xt = X[train][:, cols] - X[train][:, cols].mean(axis=0)
    scale = np.sqrt(v_all[cols])
    F = full[:, cols] / scale
    T = xt / scale
    A = F.T @ F
    At = T.T @ T
    s, Q = np.linalg.eigh(A)
    keep = s > 1e-10 * max(float(s.max()), 1e-300)
    W = Q[:, keep] / np.sqrt(s[keep])           # A-whitening: Wᵀ A W = I
    lam, U = np.linalg.eigh(W.T @ At @ W)
    V = W @ U[:, lam >= MIN_FOLD_SUPPORT]       # supported directions (scaled coefficients)
    if V.shape[1] == len(cols) and keep.all():
        return st.lstsq_coef(X[train], y[train])
    base = np.array(beta_full, dtype=float)
    Xtr = X[train]
    yt = y[train] - Xtr @ base
    D = [Xtr[:, cols] @ (V / scale[:, None])] if V.shape[1] else []
    D += [Xtr[:, np.flatnonzero(const)]]
    Dm = np.column_stack(D)
    c = st.lstsq_coef(Dm, yt)
    b = base
    k = V.shape[1]
    if k:
        b[cols] += (V / scale[:, None]) @ c[:k]
    b[np.flatnonzero(const)] += c[k:]
    return b


def fold_coefficients_gls(lik_tr, lik, X: np.ndarray, y: np.ndarray, train: np.ndarray,
                          beta_full: np.ndarray, bias_idx: list[int]) -> np.ndarray:
    """GLS coefficients on the training blocks of a fold (``lik_tr``: the likelihood on them),
    free only along the directions the training blocks support -- the rule of
    :func:`fold_coefficients` in the whitened coordinates of the whole record (``lik``):
    a direction v is supported when vᵀ·A_train·v ≥ :data:`MIN_FOLD_SUPPORT`·vᵀ·A·v with
    A = X̃ᵀX̃ the whitened design's information. The bias is the training blocks' mean
    residual."""
    b = np.array(beta_full, dtype=float)
    live = [j for j in range(X.shape[1]) if j not in bias_idx]
    if live:
        Xw = lik.whiten(X[:, live])
        Xt = lik_tr.whiten(X[:, live])
        yt = lik_tr.whiten(y) - Xt @ b[live]
        scale = np.sqrt(np.sum(Xw * Xw, axis=0))
        ok = scale > 0
        F = Xw[:, ok] / scale[ok]
        T = Xt[:, ok] / scale[ok]
        A = F.T @ F
        At = T.T @ T
        sv, Q = np.linalg.eigh(A)
        keep = sv > 1e-10 * max(float(sv.max()), 1e-300)
        Wm = Q[:, keep] / np.sqrt(sv[keep])
        lam, U = np.linalg.eigh(Wm.T @ At @ Wm)
        V = Wm @ U[:, lam >= MIN_FOLD_SUPPORT]
        if V.shape[1]:
            D = T @ V
            c, *_ = np.linalg.lstsq(D, yt, rcond=None)
            idx = np.array(live)[ok]
            b[idx] += (V @ c) / scale[ok]
    if bias_idx:
        b[bias_idx[0]] = 0.0
        b[bias_idx[0]] = float(np.mean((y - X @ b)[train]))
    return b


def fine_residual(res: FitResult) -> np.ndarray:
    """Residual on the fine grid (rate − model), deg/h."""
    wd = res.wd
    fitter = res.fitter
    pred = np.zeros(wd.frame.n)
    offs = fitter._offsets()
    beta = np.array([c.value for c in res.coefficients if c.kind == "linear"])
    for s in res.specs:
        a, b = offs[s.label]
        pred += fitter.d.fine(s, res.thetas.get(s.label)) @ beta[a:b]
    return wd.frame.rate - pred


def noise_floor(p: NoiseParams, wd: WorkData) -> st.NoiseFloor:
    """The RMS of the block-mean residual that the noise model ``p`` alone leaves at the
    working resolution over the record (:func:`gyrotest.envmodel.floor.floor_rms`: white,
    flicker and random-walk noise), with the parameters it came from."""
    from .floor import floor_rms

    N = p.N * 60.0
    plateau = p.B * math.sqrt(2 * math.log(2) / math.pi)
    K = p.K / 60.0
    t_eff = wd.t_eff if wd.t_eff is not None else wd.resolution_s
    rms = floor_rms(N, plateau, K, t_eff, wd.duration_s)
    basis = ((p.basis or ("the noise model fitted by maximum likelihood with this model "
                          "(white, flicker and random-walk rate noise)"))
             + f"; its RMS at T_eff = {t_eff:.3g} s over {wd.duration_s:.0f} s")
    return st.NoiseFloor(rms, N, plateau, t_eff, wd.duration_s, basis, random_walk_K=K)


def finish(res: FitResult, k_sigma: float = 4.0) -> None:
    """Residual Allan deviation, noise floor and excursions (the slower diagnostics)."""
    from .excursions import find_excursions

    wd = res.wd
    r = fine_residual(res)
    tau, sig = st.oadev(r, wd.frame.dt, segments=wd.frame.bounds)
    res.adev_tau, res.adev_sigma = tau, sig
    res.floor = noise_floor(res.noise.params, wd)
    res.excursions = find_excursions(res, k_sigma=k_sigma)
    res.model.fit["noise_floor_dph"] = res.floor.rms_dph


def fit_document(res: FitResult, *, written: dict | None = None) -> dict:
    """The JSON document of ``gyrotest model fit --json`` (``written``: the model and history
    files written, if any)."""
    d = res.to_dict()
    d["written"] = written or {}
    return d


_ADVICE = {
    frozenset({"T", "ramp"}): "temperature and time rise together (a monotone ramp): run a "
    "thermal cycle (up and down) or hold the temperature while time passes",
    frozenset({"T", "warmup"}): "self-heating and warm-up coincide: log a warm-up at constant "
    "chamber temperature, or a temperature change well after warm-up",
    frozenset({"warmup", "ramp"}): "log longer after warm-up so the transient and the ramp "
    "separate",
    frozenset({"T", "T2"}): "widen the temperature range or centre T_ref in it",
    frozenset({"T2", "T3"}): "widen the temperature range",
    frozenset({"T", "T3"}): "widen the temperature range",
    frozenset({"dTdt", "dGdt"}): "change the ramp rate or heat one side so that the gradient "
    "rate and the temperature rate vary independently",
    frozenset({"T", "Tlag"}): "use temperature steps or faster ramps so the core lag shows",
    frozenset({"dTdt", "Tlag"}): "use temperature steps so a lag (exponential) and a rate "
    "term (follows dT/dt) look different",
    frozenset({"dTdt", "hyst"}): "add dwells between heating and cooling so the branch and the "
    "rate decouple",
    frozenset({"T", "dTdt"}): "hold set-points long enough for dT/dt to return to zero",
    frozenset({"Tlag", "dTlagdt"}): "none needed beside T of the same sensor: a lagged node's "
    "level and its rate are then the same model (T_node = T − τ·dT_node/dt); keep the one "
    "whose coefficient you want to read (Tlag: the node's own D_T)",
    frozenset({"chanlag", "dchanlag"}): "none needed beside the channel's own level: a lagged "
    "node's level and its rate are then the same model; keep the one you want to read",
}


def _advice(ka: str, kb: str) -> str:
    if ka == kb:
        return "use sensors that differ, or keep one of them"
    a = _ADVICE.get(frozenset({ka, kb}))
    if a:
        return a
    if {ka, kb} <= {"Hx", "Hy", "Hz"}:
        return "step one coil axis at a time (Helmholtz sequence per axis)"
    return "vary the two channels independently in a dedicated test"


def _warnings(specs, coefs, vif, corr, names, thetas, fitter, rms_fit, rms_hold, nb,
              n_params) -> list[str]:
    out: list[str] = []
    key_of = {}
    for s in specs:
        for nm in s.coef_labels():
            key_of[nm] = s.key
    done = set()
    for i, nm in enumerate(names):
        v = vif.get(nm)
        if v is None or not (v > 10):
            continue
        row = np.abs(np.nan_to_num(corr[i].copy()))
        row[i] = 0
        j = int(np.argmax(row))
        pair = frozenset({nm, names[j]})
        if pair in done:
            continue
        done.add(pair)
        out.append(f"{nm} and {names[j]} are nearly collinear in this log "
                   f"(r = {corr[i, j]:+.3f}, VIF {v:.3g}): their coefficients trade off and "
                   f"cannot be told apart here; to separate them, "
                   f"{_advice(key_of.get(nm, ''), key_of.get(names[j], ''))}")
    for c in coefs:
        if c.symbol == "D_F" or c.kind != "linear":
            continue
        if abs(c.z) < 2:
            out.append(f"{c.name}: not significant (|z| = {abs(c.z):.2g} under the noise model); "
                       "the data do not support this term")
    for s in fitter.nl:
        (pname, val), = thetas[s.label].items()
        lo, hi = fitter.bounds[s.label][pname]
        unit = s.effect.nonlinear[0].unit
        if s.effect.nonlinear[0].kind == "tau" and (val < lo * 1.05 or val > hi / 1.05):
            out.append(f"{s.label}: {pname} = {val:.4g} {unit} is at the edge of its search "
                       f"range [{lo:.4g}, {hi:.4g}] {unit}: not resolved by this log")
    if math.isfinite(rms_hold) and rms_hold > 1.5 * rms_fit:
        out.append(f"held-out RMS {rms_hold:.3g} deg/h is {rms_hold / rms_fit:.2g}x the fit RMS: "
                   "the model over-fits or does not extrapolate between the time chunks")
    if nb < 10 * n_params:
        out.append(f"only {nb} blocks for {n_params} parameters: uncertainties are rough")
    return out


def predict_blocks(res: FitResult, specs: list[TermSpec] | None = None) -> np.ndarray:
    """Block-level prediction of a subset of a fit's terms (for partial-residual plots)."""
    fitter = res.fitter
    offs = fitter._offsets()
    beta = np.array([c.value for c in res.coefficients if c.kind == "linear"])
    out = np.zeros(res.n_blocks)
    for s in specs or res.specs:
        a, b = offs[s.label]
        out += fitter.d.block(s, res.thetas.get(s.label)) @ beta[a:b]
    return out
