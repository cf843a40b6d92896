"""The gyro's own axes for a field effect the model already has.

A Helmholtz run logs the field in the coils' axes; a gyro mounted a few degrees off them
sees each of its field sensitivities as a mix of every coil axis. The forward selection
names the dominant coil component (``Hy``) or product (``Hprod(Bx,By)``) first; what the
small cross-axis parts leave behind is then below what a *new* effect must show near the
floor, and the model ends 10-20 % above the true one.

When no new effect qualifies and the model has field terms of an order, the block of that
order over every field component the run moves (``Hvec`` for Hx/Hy/Hz, ``Hquad`` for
Hsq/Hprod/Hmag2; :func:`gyrotest.envmodel.screen.block_candidates`) is tried in their
place. It is not a new physical effect but the same one in rotated axes, so it is judged
by a test of exactly what it adds -- the HAC Wald test that the block's coefficients lie
in the span of the terms it replaces (:func:`axes_test`) -- with the held-out gain and its
fold consistency (:data:`gyrotest.envmodel.rules.AXES_GAIN`, ``AXES_T``, ``AXES_Z``).
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import AnalysisError, InputError
from . import stats as st
from .candidate import Candidate, held_out_gain, significance, spectral_z
from .channel_terms import custom_text
from .fit import FitResult, WorkData, fit_model
from .pairs import fit_from_starts, fit_pair, mark_pair, pair_pool
from .rules import (
    AXES_COMBINED_WEAK,
    AXES_GAIN,
    AXES_GAIN_WEAK,
    AXES_SPARSE_TOP,
    AXES_T,
    AXES_T_WEAK,
    AXES_Z,
    AXES_Z_WEAK,
    FAR_GAIN,
    FAR_T,
    HYST_PAIR_Z,
    PAIR_MARGIN,
    SPECTRAL_Z,
    TIE,
)
from .screen import CLASS_ORDER, block_candidates, term_class
from .terms import TermSpec, describe


def axes_test(r: FitResult, spec: TermSpec, replaced: list[TermSpec], wd: WorkData
              ) -> tuple[float, float]:
    """HAC Wald test that the block ``spec``'s coefficients w in the fitted model ``r`` lie in
    the span of the terms it ``replaced`` (what the block adds beyond them).

    Formula: with B the block's columns and R those of the replaced terms, A = B⁺R (R = B·A
    exactly when the replaced terms are members of the block); L spans the left null space
    of A (L·A = 0), and H0 "w = A·γ for some γ" is L·w = 0:
    W = (L·w)ᵀ (L·Σ·Lᵀ)⁻¹ (L·w), Σ the HAC covariance of w, referred to F(q, df) with
    q = rank L and df the block's effective degrees of freedom
    (:func:`gyrotest.envmodel.stats.effective_df`). Returns (z, p); (nan, nan) when the
    block adds nothing; with nothing replaced, the test of every coefficient. Source:
    gyrotest (a linear-restriction Wald test, e.g. Greene, *Econometric Analysis*, §5.3)."""
    d = r._fitter.d  # type: ignore[attr-defined]
    B = d.block(spec, None)
    idx = [i for i, cf in enumerate(r.coefficients) if cf.term == spec.label
           and cf.kind == "linear"]
    if len(idx) != B.shape[1]:
        return math.nan, math.nan
    if replaced:
        R = np.column_stack([d.block(s, None) for s in replaced])
        A, *_ = np.linalg.lstsq(B, R, rcond=None)
        # rows spanning the left null space of A (L·A = 0)
        u, sv, _ = np.linalg.svd(A, full_matrices=True)
        rank = int(np.sum(sv > 1e-9 * max(float(sv.max(initial=0.0)), 1e-300)))
        L = u[:, rank:].T
    else:
        L = np.eye(len(idx))  # nothing replaced: every coefficient is new
    if L.shape[0] == 0:
        return math.nan, math.nan
    beta = np.array([r.coefficients[i].value for i in idx])
    cov = r.cov[np.ix_(idx, idx)]
    X = r._fitter.X(r._thetas)  # type: ignore[attr-defined]
    df = st.effective_df(X, idx, st.integrated_time(r.resid))
    _, p, z = st.wald_t(L @ beta, L @ cov @ L.T, df)
    return z, p


def _simplest(spec: TermSpec, replaced: list[TermSpec], repl: list[str], frame
              ) -> tuple[TermSpec, list[TermSpec], list[str]]:
    """``Hvec`` in place of all but one of the moving components' Hx/Hy/Hz is the model with
    that one component added: name the single term (IEEE 952's w_x, w_y or w_z), which
    replaces nothing."""
    if spec.key != "Hvec" or len(spec.channels) - len(replaced) != 1:
        return spec, replaced, repl
    have = {s.channels[0] for s in replaced}
    (ch,) = [c for c in spec.channels if c not in have]
    axis = list(frame.field_uT).index(ch)
    return TermSpec(("Hx", "Hy", "Hz")[axis], (ch,)), [], []


def block_qualifies(gain: float, t_cv: float, z: float, weak: bool = False) -> bool:
    """Whether a field block with held-out gain ``gain`` (fraction), fold consistency
    ``t_cv`` and Wald z ``z`` of what it adds (:func:`axes_test`) qualifies
    (:func:`axes_step`): the strong test (:data:`AXES_GAIN`, :data:`AXES_T`, :data:`AXES_Z`);
    ``weak``, also a gain ≥ :data:`AXES_GAIN_WEAK` whose two pieces of evidence each reach
    :data:`AXES_T_WEAK` and :data:`AXES_Z_WEAK` and together (Stouffer's sum
    (t_cv + |z|)/√2) reach :data:`AXES_COMBINED_WEAK`."""
    if not (math.isfinite(z) and math.isfinite(gain) and math.isfinite(t_cv)):
        return False
    if gain >= AXES_GAIN and t_cv >= AXES_T and abs(z) >= AXES_Z:
        return True
    return bool(weak and gain >= AXES_GAIN_WEAK and t_cv >= AXES_T_WEAK
                and abs(z) >= AXES_Z_WEAK
                and (t_cv + abs(z)) / math.sqrt(2.0) >= AXES_COMBINED_WEAK)


def axes_step(wd: WorkData, base: FitResult, base_specs: list[TermSpec], thetas0: dict,
              folds: int, weak: bool = False) -> tuple[list[Candidate], Candidate | None]:
    """Try each field block in place of the model's own field terms of its order; return
    the judged blocks and the one that qualifies (the best by held-out RMS), or None.

    A block qualifies when it cuts the held-out RMS by ≥ :data:`AXES_GAIN`, consistently
    across the folds (gain/(scatter/√folds) ≥ :data:`AXES_T`), and what it adds beyond the
    replaced terms exceeds its HAC standard error (:func:`axes_test`, z ≥ :data:`AXES_Z`).
    ``weak`` (no new effect qualifies in the step): also on the weak test of
    :func:`block_qualifies` (a sequence that moves coil pairs together in few blocks shows
    the cross-axis parts in few folds)."""
    out: list[Candidate] = []
    for spec, repl in block_candidates(wd.frame, base.specs):
        replaced = [s for s in base_specs if s.label in repl]
        if not replaced:
            continue  # not a field effect the model has: a new effect, judged elsewhere
        spec, replaced, repl = _simplest(spec, replaced, repl, wd.frame)
        specs = [s for s in base_specs if s.label not in repl] + [spec]
        try:
            r = fit_model(wd, specs, folds=folds, thetas0=thetas0, light=True)
            z, p = axes_test(r, spec, replaced, wd)
        except (InputError, AnalysisError, np.linalg.LinAlgError, ValueError):
            continue
        gain, scatter, t_cv = held_out_gain(base, r, folds)
        ok = block_qualifies(gain, t_cv, z, weak)
        replaces = "; ".join(repl) or None
        try:
            custom = custom_text(spec, {}, wd.frame)
        except InputError:
            custom = None
        effect = describe(spec) + (f" (replaces {replaces})" if replaces else "")
        c = Candidate(spec.label, effect, replaces, r.rms_fit, r.rms_holdout, 100 * gain,
                      z, p, p, 1, ok,
                      [c2.to_dict() for c2 in r.coefficients if c2.term == spec.label],
                      r.n_params, spec=spec, klass=term_class(spec),
                      route="field axes" if ok else None, gain_scatter_pct=100 * scatter,
                      custom=custom)
        c.cv_t = t_cv
        c._fit = r
        out.append(c)
    ok = [c for c in out if c.significant]
    return out, min(ok, key=lambda c: c.rms_holdout, default=None)


def sparse_follow(wd: WorkData, base_specs, chosen: Candidate, out: list[Candidate],
                  block: Candidate, keys, thetas0, folds: int) -> bool:
    """Whether the new effect ``chosen`` of the block's order, with one more term of that
    order (``keys``; any of the :data:`AXES_SPARSE_TOP` best alone by held-out RMS: the one
    that completes it need not help alone), holds out at least as well as the quadratic
    ``block`` (:data:`gyrotest.envmodel.rules.AXES_SPARSE_TOP`): the sparse path then goes
    on from ``chosen``."""
    follow = sorted((c for c in out if c is not chosen and c.spec is not None
                     and c.spec.key in keys and c.pair is None and not c.error
                     and not c.replaces and math.isfinite(c.rms_holdout)),
                    key=lambda c: c.rms_holdout)[:AXES_SPARSE_TOP]
    for c in follow:
        r = fit_pair(wd, base_specs, chosen, c, thetas0, folds)
        if r is not None and r.rms_holdout <= block.rms_holdout:
            return True
    return False


def sparse_pair(wd: WorkData, base: FitResult, base_specs, out: list[Candidate],
                block: Candidate, keys, thetas0, folds: int) -> Candidate | None:
    """Two terms of the block's order (``keys``: Hsq, Hprod, Hmag2) added beside the model
    (the :data:`AXES_SPARSE_TOP` best alone by held-out RMS, two at a time) that hold out at
    least as well as the chosen quadratic ``block`` and qualify as a pair (held-out gain
    ≥ :data:`FAR_GAIN` at fold consistency ≥ :data:`FAR_T`): the better one alone, marked
    "together with" the other (the next step names it), or None. Two coefficients fitted
    from the whole sequence extrapolate to held-out field settings where the block's cross
    products of coil axes do not (:data:`AXES_SPARSE_TOP`)."""
    pool = sorted((c for c in out if c is not block and c.spec is not None
                   and c.spec.key in keys and c.pair is None and not c.replaces
                   and not c.error and math.isfinite(c.rms_holdout)),
                  key=lambda c: c.rms_holdout)[:AXES_SPARSE_TOP]
    best = None
    for i, a in enumerate(pool):
        for b in pool[i + 1:]:
            r = fit_pair(wd, base_specs, a, b, thetas0, folds)
            if r is None or not r.rms_holdout <= block.rms_holdout:
                continue
            gain, _, t_cv = held_out_gain(base, r, folds)
            if (gain >= FAR_GAIN and t_cv >= FAR_T
                    and (best is None or r.rms_holdout < best[2])):
                first, other = (a, b) if a.rms_holdout <= b.rms_holdout else (b, a)
                best = (first, other, r.rms_holdout, t_cv)
    return mark_pair(best) if best is not None else None


#: the field terms each block stands for (a pair member of these keys is part of the block)
BLOCK_KEYS = {"Hvec": ("Hx", "Hy", "Hz"), "Hquad": ("Hsq", "Hprod", "Hmag2")}


def block_pair(wd: WorkData, base: FitResult, base_specs, out: list[Candidate], thetas0,
               folds: int, follows=None) -> Candidate | None:
    """A new effect that only shows beside a field block in place of the model's own field
    terms, each hiding the other: the new effect, marked "together with" the block (the next
    step names the block; :func:`axes_step`), or None.

    Seed 83007: a gyro 4.4° off the coils, Hz(mag_B3) in the model and T(T_gyro) missing at
    5.9× the floor. T alone gains 6 %, the block ``Hvec`` in place of Hz alone holds out 3 %
    worse, together they gain 43 %; neither qualifies alone and the general pair search
    (:func:`gyrotest.envmodel.pairs._find_pair`) keeps blocks out (they replace terms).

    For each field block that replaces model terms
    (:func:`gyrotest.envmodel.screen.block_candidates`; fitted alone unless ``out`` holds it
    judged) and each member of the pair pool (:func:`gyrotest.envmodel.pairs.pair_pool`)
    that is not a field term of the block's order nor a generic term of its channels: the
    model without the replaced terms, with the block and the member. A pair
    qualifies when it cuts the held-out RMS by ≥ :data:`FAR_GAIN` at fold consistency ≥
    :data:`FAR_T`, to at most :data:`PAIR_MARGIN` × either member alone; the member's HAC z
    in the pair's fit reaches :data:`HYST_PAIR_Z` (the joint test of hidden pairs) and its
    spectral z :data:`SPECTRAL_Z`; and what the block adds beyond the replaced terms has
    Wald z ≥ :data:`AXES_Z` (:func:`axes_test`). Of the qualifying pairs within
    :data:`TIE` of the best held-out RMS, the member of the first class
    (:data:`gyrotest.envmodel.screen.CLASS_ORDER`: a library or channel effect before a
    nuisance term) is named; ``follows(member, block)`` must accept it."""
    blocks = []
    for spec, repl in block_candidates(wd.frame, base.specs):
        if not repl:
            continue  # a new effect: the general pair search has it
        fitted = next((c for c in out if c.term == spec.label and c.replaces
                       and c._fit is not None), None)
        if fitted is None:
            try:
                r = fit_model(wd, [s for s in base_specs if s.label not in repl] + [spec],
                              folds=folds, thetas0=thetas0, light=True)
            except (InputError, AnalysisError, np.linalg.LinAlgError, ValueError):
                continue
            fitted = Candidate(spec.label, describe(spec), "; ".join(repl), r.rms_fit,
                               r.rms_holdout, 100 * held_out_gain(base, r, folds)[0],
                               math.nan, math.nan, math.nan, 1, False, spec=spec,
                               klass=term_class(spec))
            fitted._fit = r
        blocks.append((spec, repl, fitted))
    if not blocks:
        return None
    pool = pair_pool(base, out)
    found = []
    for spec, repl, blk in blocks:
        replaced = [s for s in base_specs if s.label in repl]
        keys = BLOCK_KEYS[spec.key]
        for m in pool:
            if m.spec.key in keys or (m.spec.key.startswith("chan")
                                      and set(m.spec.channels) <= set(spec.channels)):
                continue
            specs = [s for s in base_specs if s.label not in repl] + [spec, m.spec]
            # from the base model's nonlinear parameters and from the member's own (fitted
            # beside the replaced terms, a warm-up's τ may be trapped)
            own = {**thetas0, **(getattr(m._fit, "_thetas", {}) or {})}
            r = fit_from_starts(wd, specs, thetas0, own, folds)
            if r is None:
                continue
            if not r.rms_holdout <= PAIR_MARGIN * min(blk.rms_holdout, m.rms_holdout):
                continue
            gain, _, t_cv = held_out_gain(base, r, folds)
            if not (gain >= FAR_GAIN and t_cv >= FAR_T):
                continue
            try:
                z_m, _ = significance(r, m.spec, None, wd)
                z_b, _ = axes_test(r, spec, replaced, wd)
            except (np.linalg.LinAlgError, ValueError, IndexError):
                continue
            if not (math.isfinite(z_m) and abs(z_m) >= HYST_PAIR_Z
                    and math.isfinite(z_b) and abs(z_b) >= AXES_Z):
                continue
            if not spectral_z(r, [m.term], wd) >= SPECTRAL_Z:
                continue
            found.append((m, blk, r.rms_holdout, t_cv))
    if not found:
        return None
    # within TIE of the best, the physical effect before a nuisance term (seed 83007: the
    # ramp −44.3 % with the block, T(T_gyro) −43.4 %)
    low = min(f[2] for f in found)
    best = min((f for f in found if f[2] <= low * (1 + TIE)),
               key=lambda f: (CLASS_ORDER.get(f[0].klass, 9), f[2]))
    if follows is not None and not follows(best[0], best[1]):
        return None
    named = mark_pair(best)
    named.route = f"together with {best[1].term} in place of {best[1].replaces}"
    return named


__all__ = ["BLOCK_KEYS", "axes_step", "axes_test", "block_pair", "block_qualifies",
           "sparse_follow", "sparse_pair"]
