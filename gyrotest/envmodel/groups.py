"""Three or more missing effects that hide one another (the group search of
:mod:`gyrotest.envmodel.diagnose`, see :data:`gyrotest.envmodel.rules.GROUP_RATIO`).

Far above the floor, several missing effects of comparable size can each make the model
*worse* when added alone: the coefficient of one absorbs part of the others and extrapolates
badly into the held-out blocks. Pairs (:mod:`gyrotest.envmodel.pairs`) repair two such
effects; a third one still hides them. Seed 44140 of the campaign, a tilt table with
g(gy) (15 deg/h/g), the anisoelastic gx·gy (−43 deg/h/g²) and T (7 deg/h/°C) all missing
at 100–200x the floor: alone they hold out −18 %, +32 % and −1 %; any two of them at most
+58 %; the three together +98 %, at the floor.

The search is backward elimination from the saturated model, the usual remedy when forward
selection stalls on effects that only work together (e.g. Hastie, Tibshirani & Friedman,
*The Elements of Statistical Learning*, 2nd ed., Springer 2009, §3.3.2): the base model plus
every channel-driven candidate (no free-frequency or free-width nuisance term, no time term)
is fitted at once; the member whose removal costs least held-out RMS is dropped, while that
costs less than :data:`GROUP_DROP`, and members whose coefficient does not stand out in the
group's own fit (HAC |z| < :data:`GROUP_Z`) go too. What remains must cut the held-out RMS
by :data:`GROUP_GAIN` consistently across the folds and stand out of the residual's
spectrum, like a pair. The member that holds out best alone is named first; the next step
tests the others.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import AnalysisError, InputError
from .candidate import Candidate, held_out_gain, significance, spectral_z
from .fit import FitResult, WorkData, fit_model
from .rules import (
    GROUP_DROP,
    GROUP_GAIN,
    GROUP_POOL,
    GROUP_T,
    GROUP_Z,
    SPECTRAL_Z,
    red_floor_for,
)


def _pool(base: FitResult, out: list[Candidate]) -> list[Candidate]:
    """The :data:`GROUP_POOL` channel-driven candidates with the largest in-sample gain: no
    nuisance term (:data:`gyrotest.envmodel.screen.NUISANCE`: a ramp or warm-up fits the
    gyro's own drift, a sinusoid or hysteresis has a free frequency or width)."""
    ok = [c for c in out if c.spec is not None and not c.replaces and c.pair is None
          and c.klass != "nuisance"
          and c._fit is not None and math.isfinite(c.rms_fit)
          and math.isfinite(c.rms_holdout) and c.rms_fit < base.rms_fit]
    ok.sort(key=lambda c: c.rms_fit)
    pool, seen = [], set()
    for c in ok:
        if c.term in seen:
            continue
        pool.append(c)
        seen.add(c.term)
        if len(pool) >= GROUP_POOL:
            break
    return pool


def _fit(wd: WorkData, base_specs, members: list[Candidate], thetas0, folds: int
         ) -> FitResult | None:
    th = dict(thetas0)
    for c in members:
        th.update(getattr(c._fit, "_thetas", {}) or {})
    try:
        return fit_model(wd, list(base_specs) + [c.spec for c in members], folds=folds,
                         thetas0=th, light=True)
    except (InputError, AnalysisError, np.linalg.LinAlgError, ValueError):
        return None


def _weakest(r: FitResult, members: list[Candidate], wd: WorkData) -> Candidate | None:
    """The member with the smallest HAC |z| in the group's fit ``r``, when below
    :data:`GROUP_Z`; None when all stand out."""
    worst, zmin = None, math.inf
    for c in members:
        try:
            z, _ = significance(r, c.spec, None, wd)
        except (ValueError, np.linalg.LinAlgError, IndexError):
            z = math.nan
        az = abs(z) if math.isfinite(z) else 0.0
        if az < zmin:
            worst, zmin = c, az
    return worst if zmin < GROUP_Z else None


def group_step(wd: WorkData, base: FitResult, base_specs, out: list[Candidate], thetas0,
               folds: int) -> Candidate | None:
    """The group search (see the module docstring): the group member that holds out best
    alone, marked significant with the route "together with A, B", or None."""
    members = _pool(base, out)
    if len(members) < 3:
        return None
    r = _fit(wd, base_specs, members, thetas0, folds)
    if r is None:
        return None
    impr, _, t_cv = held_out_gain(base, r, folds)
    if not (impr >= GROUP_GAIN and t_cv >= GROUP_T):
        return None  # not even all of them together
    while len(members) > 2:
        # each member left out once: the cheapest goes while it costs < GROUP_DROP, then
        # the one whose coefficient stands out least while it is below GROUP_Z
        drops = {id(c): _fit(wd, base_specs, [m for m in members if m is not c], thetas0,
                             folds) for c in members}
        fits = [(c, drops[id(c)]) for c in members if drops[id(c)] is not None]
        c, rr = min(fits, key=lambda f: f[1].rms_holdout, default=(None, None))
        if rr is None or rr.rms_holdout > (1.0 + GROUP_DROP) * r.rms_holdout:
            c = _weakest(r, members, wd)
            if c is None:
                break  # every member is needed and stands out
            rr = drops[id(c)]
            if rr is None:
                return None
        members, r = [m for m in members if m is not c], rr
    # two members are the pair search's business; a single is the single's
    if len(members) < 3:
        return None
    impr, _, t_cv = held_out_gain(base, r, folds)
    if not (impr >= GROUP_GAIN and t_cv >= GROUP_T):
        return None
    if min(c.rms_holdout for c in members) * (1.0 - GROUP_GAIN) < r.rms_holdout:
        return None  # one of them alone does most of it: the singles decide
    labels = [c.term for c in members]
    red = red_floor_for([c.spec.key for c in members])
    if not spectral_z(r, labels, wd, red=red) >= SPECTRAL_Z:
        return None
    first = min(members, key=lambda c: c.rms_holdout)
    others = [c.term for c in members if c is not first]
    first.significant = True
    first.rejected = None
    first.route = "together with " + ", ".join(others)
    first.pair = (", ".join(others), r.rms_holdout, t_cv)
    return first


__all__ = ["group_step"]
