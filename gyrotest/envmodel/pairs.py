"""Two missing effects that each hide the other (the pair search of
:mod:`gyrotest.envmodel.diagnose`, see :data:`gyrotest.envmodel.rules.PAIR_TOP`).

Far above the floor, when no single candidate qualifies, pairs from a pool of the best
candidates are fitted together; a pair that cuts the held-out RMS well below either member
alone, consistently across the folds, names its more useful member first and the next step
of the forward path tests the other. A single term chosen far above the floor that leaves the
model there may also give way to such a pair (:func:`redirect`).
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import AnalysisError, InputError
from .candidate import (
    Candidate,
    abs_corr,
    equivalents,
    held_out_gain,
    own_contribution,
    significance,
    spectral_z,
)
from .fit import FitResult, WorkData, fit_model
from .rules import (
    BIG_GAIN,
    DECISIVE_GAIN,
    FAR_GAIN,
    FAR_RATIO,
    FAR_T,
    FAR_T_NUISANCE,
    FAR_Z,
    HIDDEN_TOP,
    HYST_PAIR_Z,
    HYST_STRONG_CV_T,
    LOOKAHEAD_MORE,
    LOOKAHEAD_TOP,
    PAIR_EXEMPT_SPECTRAL_Z,
    PAIR_FIT_GAIN,
    PAIR_MARGIN,
    PAIR_MIN_GAIN,
    PAIR_MORE,
    PAIR_POOL,
    PAIR_TOP,
    PRODUCT_LEVEL_R,
    REDIRECT_RATIO,
    SINGLE_EXEMPT_GAIN,
    SINGLE_EXEMPT_T,
    SPECTRAL_EXEMPT_T,
    SPECTRAL_REJECT,
    SPECTRAL_Z,
    TIE,
    TIME_TERMS,
    UNLAGGED,
    WARMUP_SPECTRAL_Z,
    red_floor_for,
    spectral_exempt,
)
from .terms import TermSpec, nonlinear_bounds


def pair_step(wd: WorkData, base: FitResult, base_specs, out: list[Candidate], thetas0,
              folds: int, follows=None) -> Candidate | None:
    """Two effects that each hide the other (see :data:`PAIR_TOP`): the best qualifying
    pair's more useful member (the better one alone), marked significant with the route
    "together with OTHER"; None when no pair qualifies. ``follows(lead, other)``, when
    given, must accept the pair (the next step takes the other member: see
    :func:`gyrotest.envmodel.diagnose._partner_follows`)."""
    found = _find_pair(wd, base, base_specs, out, thetas0, folds)
    if found is None or (follows is not None and not follows(found[0], found[1])):
        return None
    return mark_pair(found)


def _find_pair(wd: WorkData, base: FitResult, base_specs, out: list[Candidate], thetas0,
               folds: int, exclude: set[int] | None = None, below: float = math.inf
               ) -> tuple[Candidate, Candidate, float, float] | None:
    """The best qualifying pair (see :func:`pair_step`), candidates whose ``id`` is in
    ``exclude`` left out, held-out RMS below ``below``: (more useful member, the other, the
    pair's held-out RMS, its fold consistency), or None."""
    skip = exclude or set()
    pool = [c for c in pair_pool(base, out) if id(c) not in skip]
    pairs = [(pool[i], pool[j]) for i in range(len(pool)) for j in range(i + 1, len(pool))]
    seen = {frozenset((id(a), id(b))) for a, b in pairs}
    pairs += [(a, b) for a, b in _polynomial_pairs(out)
              if id(a) not in skip and id(b) not in skip
              and frozenset((id(a), id(b))) not in seen]
    hl = [(a, b) for a, b in _hyst_level_pairs(out) if id(a) not in skip and id(b) not in skip]
    seen |= {frozenset((id(a), id(b))) for a, b in pairs + hl}
    hp = [(a, b) for a, b in _hidden_pairs(out, pool)
          if id(a) not in skip and id(b) not in skip and frozenset((id(a), id(b))) not in seen]
    hidden = {frozenset((id(a), id(b))) for a, b in hp}
    seen |= hidden
    tp = [(a, b) for a, b in _trend_pairs(out, pool)
          if id(a) not in skip and id(b) not in skip and frozenset((id(a), id(b))) not in seen]
    seen |= {frozenset((id(a), id(b))) for a, b in tp}
    pp = [(a, b) for a, b in _partner_pairs(out, pool)
          if id(a) not in skip and id(b) not in skip and frozenset((id(a), id(b))) not in seen]
    seen |= {frozenset((id(a), id(b))) for a, b in pp}
    cp, start = [], {}
    for a, b, th in _channel_pairs(wd, base, base_specs, out, thetas0, folds):
        if id(a) in skip or id(b) in skip:
            continue
        # the block's start holds also for a pair another route proposed (seed 27119: a
        # partner pair of the same two forms of T_gyro, started cold, missed the lag)
        start[frozenset((id(a), id(b)))] = th
        if frozenset((id(a), id(b))) not in seen:
            cp.append((a, b))
    # pairs tested jointly (_joint_z_ok)
    joint = {frozenset((id(a), id(b))) for a, b in hl + tp + pp + cp} | hidden
    pairs += hl + hp + tp + pp + cp
    # the best qualifying pair for each member it would name first, and the member the
    # lowest pair (qualifying or failing its HAC guard) would name
    best_by: dict[int, tuple[Candidate, Candidate, FitResult, float]] = {}
    lowest, lowest_named = math.inf, None
    for a, b in pairs:
        r = fit_pair(wd, base_specs, a, b, thetas0, folds,
                     start=start.get(frozenset((id(a), id(b)))))
        if r is None:
            continue
        impr, _, t_cv = held_out_gain(base, r, folds)
        # the joint HAC test -- or decisive evidence (:func:`_decisive_over_members`, once
        # the spectral z is known): a tilt sequence of few positions leaves a member few
        # effective degrees of freedom (seed 79011: g of acc_ay and an ageing ramp, each
        # hidden by the other, −91 % together at consistency 31 and spectral z 60, the ramp
        # at HAC z 3.8 < 4; the loop had ended at 11.2 x the true model)
        joint_fail = (frozenset((id(a), id(b))) in joint
                      and not _joint_z_ok(r, a, b, wd, t_cv))
        if joint_fail and not impr >= min(SINGLE_EXEMPT_GAIN, DECISIVE_GAIN):
            continue
        if not r.rms_holdout <= min(PAIR_MARGIN * min(a.rms_holdout, b.rms_holdout),
                                    below):
            continue
        # a free frequency or width in the pair: the flexible-term thresholds
        nuisance = a.klass == "nuisance" or b.klass == "nuisance"
        # a warm-up lives in the first chunks: fold consistency understates it, and the
        # spectral test stands in (below FAR_T_NUISANCE no gain is exempt from it, so the
        # bar is SPECTRAL_Z, the WARMUP_SPECTRAL_Z of single warm-ups)
        warm = "warmup" in (a.spec.key, b.spec.key)
        if not (impr >= BIG_GAIN and t_cv >= (FAR_T if warm else FAR_T_NUISANCE)
                if nuisance else impr >= FAR_GAIN and t_cv >= FAR_T):
            continue
        # a member that failed a test alone: the gain that needs no spectral test
        if frozenset((id(a), id(b))) in hidden and not spectral_exempt(impr, t_cv):
            continue
        # far: ratio >= 2; an exempt gain still needs a pair's own bar, and a member the
        # spectral test rejected alone gets no exemption: the pair must pass that test
        # (null seed 31680: a ramp and a channel lag, both rejected alone, fitted together
        # to real-gyro wander at −58 %, spectral z 6.2)
        spec_rej = _spectral_rejected(a) or _spectral_rejected(b)
        bar = (PAIR_EXEMPT_SPECTRAL_Z if spectral_exempt(impr, t_cv) and not spec_rej
               else SPECTRAL_Z)
        red = red_floor_for([a.spec.key, b.spec.key])
        zs = spectral_z(r, [a.term, b.term], wd, red=red)
        if not zs >= bar:
            continue
        if joint_fail and not _decisive_over_members(r, a, b, impr, t_cv, zs, folds):
            continue
        key = frozenset((id(a), id(b)))
        # neither member's coefficient stood out alone, where the other effect inflated its
        # error: both must stand out in the pair's own fit
        late = key not in joint and not any(math.isfinite(c.z) and abs(c.z) >= FAR_Z
                                            for c in (a, b))
        named = _named(a, b, key in joint or late)
        if r.rms_holdout < lowest:
            lowest, lowest_named = r.rms_holdout, named
        prev = best_by.get(id(named))
        if prev is not None and r.rms_holdout >= prev[2].rms_holdout:
            continue
        if late:
            if not (_joint_z_ok(r, a, b, wd, t_cv) or _decisive(impr, t_cv, zs)):
                continue
            joint.add(key)
        best_by[id(named)] = (a, b, r, t_cv)
    # the best pair decides: one that failed its HAC guard does not hand over to the next
    # -- unless the next one names the same member now: then the failed guard concerned the
    # partner's form only (seed 41065, real noise: a warm-up with the lag of the chamber
    # air, −94 %, failed the joint test; the warm-up with the rate of the lagging sensor,
    # −94 %, passed it; the next step names that rate)
    if lowest_named is None or id(lowest_named) not in best_by:
        return None
    a, b, r, t_cv = best_by[id(lowest_named)]
    if frozenset((id(a), id(b))) in hidden and "hyst" in (a.spec.key, b.spec.key):
        h, m = (a, b) if a.spec.key == "hyst" else (b, a)
        found = _plain_level(wd, base_specs, out, h, m, r, thetas0, folds)
        if found is not None:  # the simpler form of the same pair
            lv, r2 = found
            return (m, lv, r2.rms_holdout, t_cv) if m.rms_holdout <= lv.rms_holdout \
                else (lv, m, r2.rms_holdout, t_cv)
    other = b if lowest_named is a else a
    return lowest_named, other, r.rms_holdout, t_cv


def _named(a: Candidate, b: Candidate, joint: bool) -> Candidate:
    """The member of a qualifying pair named first: the better one alone -- unless the pair
    was not tested jointly (``joint`` False: a member's coefficient stood out alone) and that
    one's did not, nor did it qualify alone (a warm-up far above the floor on its spectral
    z, its HAC error inflated: seed 26125): then the other."""
    first, other = (a, b) if a.rms_holdout <= b.rms_holdout else (b, a)
    if joint or first.significant or (math.isfinite(first.z) and abs(first.z) >= FAR_Z):
        return first
    return other


def fit_pair(wd: WorkData, base_specs, a: Candidate, b: Candidate, thetas0, folds: int,
             start: dict | None = None) -> FitResult | None:
    """The base model with candidates ``a`` and ``b`` added, started from the base's and both
    candidates' nonlinear parameters (or from ``start``); None when it cannot be fitted."""
    th = dict(thetas0)
    for c in (a, b):
        th.update(getattr(c._fit, "_thetas", {}) or {})
    if start is not None:
        th = dict(start)
    try:
        return fit_model(wd, list(base_specs) + [a.spec, b.spec], folds=folds, thetas0=th,
                         light=True)
    except (InputError, AnalysisError, np.linalg.LinAlgError, ValueError):
        return None


def fit_from_starts(wd: WorkData, specs, thetas0, own, folds: int) -> FitResult | None:
    """The model ``specs`` fitted from the base model's nonlinear parameters ``thetas0`` and,
    when they differ, from the members' own ``own`` (a lag's τ or a warm-up's fitted beside
    another effect may be trapped far from the truth): the fit that holds out better, or
    None when neither can be fitted."""
    r = None
    for th in [dict(thetas0)] + ([own] if own != thetas0 else []):
        try:
            f = fit_model(wd, specs, folds=folds, thetas0=th, light=True)
        except (InputError, AnalysisError, np.linalg.LinAlgError, ValueError):
            continue
        if r is None or f.rms_holdout < r.rms_holdout:
            r = f
    return r


def mark_pair(found: tuple[Candidate, Candidate, float, float]) -> Candidate:
    """The pair's more useful member, marked significant with the route "together with
    OTHER" (see :func:`_find_pair`)."""
    first, other, rms, t_cv = found
    if first.rejected:  # alone, the other effect hid it (:func:`_hidden`)
        first.note = (f"alone its coefficient did not stand out of the residual's slow noise "
                      f"(spectral z {first.spectral_z:.1f}), which {other.term} dominates")
        first.rejected = None
    first.significant = True
    first.route = f"together with {other.term}"
    first.pair = (other.term, rms, t_cv)
    return first


def redirect(wd: WorkData, base: FitResult, base_specs, out: list[Candidate],
             chosen: Candidate, thetas0, folds: int, fl: float,
             follows=None) -> Candidate | None:
    """Far above the floor, a single term that leaves the model there may have been chosen
    because two larger effects hide each other (see :data:`REDIRECT_RATIO`): the qualifying
    pair of two *other* effects -- neither the chosen term nor one this log cannot tell
    from it -- whose more useful member then leads; None to keep ``chosen``."""
    if (not math.isfinite(fl) or fl <= 0
            or chosen.rms_holdout < FAR_RATIO * fl):
        return None
    same = {id(chosen)} | {id(c) for c in out if c.term in chosen.equivalents}
    found = _find_pair(wd, base, base_specs, out, thetas0, folds, exclude=same,
                       below=REDIRECT_RATIO * chosen.rms_holdout)
    if found is None:
        return None
    # ... unless the chosen term with a partner does about as well: the next step finds it
    # (the lookahead's best partner too: seed 41127, the rate of a lagged node chosen there
    # with T² at 0.087 deg/h gave way to a hysteresis with T² at 0.23)
    if chosen.lookahead is not None and chosen.lookahead[0] * PAIR_MARGIN <= found[2]:
        return None
    # (the found pair's own members too: seed 69070, the level of a humidity channel chosen
    # beside a missing vibration level that a pair found by other routes had named with the
    # humidity's lagged rate, 1.22 x the true model)
    tried: set[int] = set()
    for m in pair_pool(base, out) + [o for ab in _polynomial_pairs(out) for o in ab
                                      if chosen in ab] + [found[0], found[1]]:
        if m is chosen or m.spec is None or chosen.spec is None or id(m) in tried:
            continue
        tried.add(id(m))  # a member found by two routes is fitted once
        r = fit_pair(wd, base_specs, chosen, m, thetas0, folds)
        if r is None:
            continue
        if r.rms_holdout * PAIR_MARGIN <= found[2]:
            return None
    if follows is not None and not follows(found[0], found[1]):
        return None
    pair = mark_pair(found)
    pair.displaced = (chosen.term, chosen.rms_holdout)
    return pair


def lookahead(wd: WorkData, base: FitResult, base_specs, out: list[Candidate],
              tied: list[Candidate], chosen: Candidate, thetas0, folds: int,
              close: list[Candidate] | None = None) -> Candidate:
    """Far above the floor, candidates tied on held-out evidence (``tied``: within
    :data:`TIE`; ``close``: also those the evidence cannot tell apart,
    :data:`gyrotest.envmodel.rules.LOOKAHEAD_T`) are told apart by the step after them: each
    of up to :data:`LOOKAHEAD_TOP` is fitted with every member of the pair pool, the
    second-order forms of the channels the model uses and the cross terms of any channels
    (not another tied one), and the one whose best partner brings the held-out RMS at least
    :data:`PAIR_MARGIN` below what the others reach with theirs leads; otherwise the usual
    order (``chosen``) stands. Each one's best partner is recorded in its ``lookahead``.

    An ageing ramp and the lag of a slowly drifting pressure channel fit a record equally
    (seed 23141, both −41 %); only with the ramp does the missing g cross term then come
    out (−78 %, to the floor), while beside the lag it stays hidden."""
    same = set(chosen.equivalents or equivalents(chosen, out, base))
    alts = [chosen] + [c for c in (close or tied) if c is not chosen
                       and c.term not in same][:LOOKAHEAD_TOP - 1]
    if len(alts) < 2:  # exact equivalents: the usual order names one of them
        return chosen
    skip = {id(c) for c in tied} | {id(c) for c in alts}
    skip |= {id(o) for c in alts for o in out if o.term in c.equivalents}
    partners = [m for m in pair_pool(base, out) if id(m) not in skip]
    partners += [b for c in alts for a, b in _polynomial_pairs(out)
                 if a is c and id(b) not in skip and b not in partners]
    # second-order forms of the channels the model already uses: a hidden partner need not
    # help alone at all (the g cross term of seed 23141 gains nothing beside the ramp's gap)
    used = {ch for s in base_specs for ch in s.channels}
    partners += [m for m in _pairable(out) if id(m) not in skip and m not in partners
                 and m.spec.key in HIGHER_ORDER and m.spec.channels
                 and set(m.spec.channels) <= used][:LOOKAHEAD_MORE]
    # ... and the cross terms of any channels (seed 41060: beside a ramp an anisoelastic
    # g cross term comes out at −57 %; alone, or beside the case temperature, it gains nothing)
    partners += [m for m in _pairable(out) if id(m) not in skip and m not in partners
                 and m.spec.key in CROSS_TERMS][:LOOKAHEAD_MORE]
    best = _best_partners(wd, base_specs, alts, partners, thetas0, folds)
    for c in alts:
        c.lookahead = best.get(id(c))
    if id(chosen) not in best:
        return chosen
    lead = min(alts, key=lambda c: best.get(id(c), (math.inf, ""))[0])
    if lead is chosen or not best[id(lead)][0] <= PAIR_MARGIN * best[id(chosen)][0]:
        return chosen
    how = "tied with" if any(lead is c for c in tied) else "not told apart from"
    lead.note = (f"{how} {chosen.term} on held-out evidence; with {best[id(lead)][1]} it "
                 f"reaches {best[id(lead)][0]:.4g} deg/h, {chosen.term} at best "
                 f"{best[id(chosen)][0]:.4g} deg/h (with {best[id(chosen)][1]})")
    return lead


def _best_partners(wd: WorkData, base_specs, alts: list[Candidate],
                   partners: list[Candidate], thetas0, folds: int
                   ) -> dict[int, tuple[float, str]]:
    """For each candidate of ``alts`` (by ``id``): the lowest held-out RMS it reaches with
    one of ``partners`` and that partner's term."""
    best: dict[int, tuple[float, str]] = {}
    for c in alts:
        if c.spec is None or c._fit is None:
            continue
        for m in partners:
            if m.spec is None or m is c:
                continue
            r = fit_pair(wd, base_specs, c, m, thetas0, folds)
            if r is not None and r.rms_holdout < best.get(id(c), (math.inf, ""))[0]:
                best[id(c)] = (r.rms_holdout, m.term)
    return best


def lag_resolved(spec: TermSpec, tau_s: float, wd: WorkData) -> bool:
    """Whether a lag's fitted time constant ``tau_s`` (s) is resolved by the log: above 1.05 ×
    the bottom of its range and above the smoother window (a shorter lag is the plain term)."""
    lo = nonlinear_bounds(spec, wd.duration_s, wd.resolution_s, wd.refs).get(
        "tau_s", (0.0, 0.0))[0]
    return tau_s > max(1.05 * lo, wd.refs.smoothing_s)


def lag_or_plain(wd: WorkData, base: FitResult, base_specs, out: list[Candidate],
                 chosen: Candidate, thetas0, folds: int) -> Candidate:
    """Far above the floor, a lag form and the plain form of one channel (``Tlag(c)`` and
    ``T(c)``, ``chanlag(c)`` and ``chan(c)``) both missing effects: the step after them tells
    which one leads. The other form leads when its best partner brings the held-out RMS
    at least :data:`PAIR_MARGIN` below the chosen form's best.

    A lag chosen (a lag is the level minus τ times its rate): its time constant may stand in
    for a rate term that is also missing. Each is fitted with the pair pool and the rate
    forms (:data:`RATE_FORMS`); the rate forms of the lag's own channel are not
    the plain form's partners here -- T(c) with the rate of c is the lag's own first-order
    expansion, not a second effect. Seed 23183: Tlag(tc2) −66 %, T(tc2) −39 %; with the
    missing rate of a lagged node of another sensor, T(tc2) reaches 0.168 deg/h, Tlag(tc2)
    at best 0.225.

    The plain form chosen: a lagged node and the rate of its sensor hide each other, and
    alone the lag can hold out worse than the level. Both forms are then fitted with the
    rate forms only, the channel's own first: the level with its own rate is the lag's
    first-order expansion, so a lag that beats it by the margin has a time constant the log
    resolves. The level alone counts as its own best when no rate helps it, and the lagged
    rate of the lag's own channel is not the lag's partner (two time constants of one sensor
    fit its level). Seed 59030 (a node 438 s behind T_case with dT/dt of T_case, both
    missing): T −89.9 %, Tlag −89.4 %; with dT/dt, Tlag reaches 0.110 deg/h (the true
    model's), T 0.155, and the loop had ended 1.48 × the true model."""
    key = chosen.spec.key if chosen.spec else ""
    if chosen._fit is None:
        return chosen
    if key in ("Tlag", "chanlag"):
        other_key, lag_chosen = UNLAGGED[key], True
    elif key in ("T", "chan"):
        other_key, lag_chosen = next(k for k, v in UNLAGGED.items() if v == key), False
    else:
        return chosen
    label = TermSpec(other_key, chosen.spec.channels).label
    other = next((c for c in out if c.term == label and c.significant and c._fit is not None
                  and c.rejected is None and math.isfinite(c.rms_holdout)), None)
    if other is None:
        return chosen
    lag, plain = (chosen, other) if lag_chosen else (other, chosen)
    own = set(chosen.spec.channels)
    if lag_chosen:
        lags = ("Tlag", "chanlag", "T", "chan")
        partners = [m for m in pair_pool(base, out) if m is not lag and m is not plain
                    and not (m.spec.key in lags and set(m.spec.channels) == own)]
        partners += sorted((m for m in _pairable(out) if m.spec.key in RATE_FORMS
                            and m not in partners and m.improvement_pct > 0),
                           key=lambda m: -m.improvement_pct)[:LOOKAHEAD_MORE]
        plain_partners = [m for m in partners
                          if not (m.spec.key in RATE_FORMS and set(m.spec.channels) & own)]
    else:
        # only the rate forms, the channel's own first: the lag's other half (another
        # partner beside which a lag does better is no evidence on this question)
        rates = sorted((m for m in _pairable(out) if m.spec.key in RATE_FORMS),
                       key=lambda m: -m.improvement_pct)
        mine = [m for m in rates if set(m.spec.channels) == own]
        plain_partners = mine + [m for m in rates if m not in mine][:LOOKAHEAD_MORE]
        # not the lagged rate of the lag's own channel: two time constants of one sensor fit
        # its level (seed 44056: a true T(T_case), −99.2 % alone; Tlag with dTlagdt of
        # T_case held out 10 % better and named neither)
        partners = [m for m in plain_partners
                    if not (m.spec.key in LAGGED_RATES and set(m.spec.channels) == own)]
    best = _best_partners(wd, base_specs, [lag], partners, thetas0, folds)
    best.update(_best_partners(wd, base_specs, [plain], plain_partners, thetas0, folds))
    if id(lag) not in best or id(plain) not in best:
        return chosen
    if not lag_chosen and plain.rms_holdout < best[id(plain)][0]:
        # the level needs no partner: the lag must beat it alone
        best[id(plain)] = (plain.rms_holdout, "")
    if best[id(other)][0] > PAIR_MARGIN * best[id(chosen)][0]:
        return chosen
    if not lag_chosen:
        # the lag beside its partner: a time constant the log resolves there, or the level
        partner = next((m for m in partners if m.term == best[id(lag)][1]), None)
        r = (fit_pair(wd, base_specs, lag, partner, thetas0, folds)
             if partner is not None else None)
        tau = ((getattr(r, "_thetas", None) or {}).get(lag.term) or {}).get("tau_s")
        if tau is None or not lag_resolved(lag.spec, tau, wd):
            return chosen
        lag.pair_tau_s = float(tau)
        lag.lookahead = best[id(lag)]
    if lag_chosen:
        plain.note = (f"{lag.term} fits better alone, but with {best[id(plain)][1]} "
                      f"{plain.term} reaches {best[id(plain)][0]:.4g} deg/h and {lag.term} "
                      f"{best[id(lag)][0]:.4g} deg/h (with {best[id(lag)][1]}): the lag's "
                      "time constant stood in for a missing rate term")
    else:
        lag.note = (f"{plain.term} fits better alone, but with {best[id(lag)][1]} "
                    f"{lag.term} reaches {best[id(lag)][0]:.4g} deg/h and {plain.term} at "
                    f"best {best[id(plain)][0]:.4g} deg/h "
                    f"({'with ' + best[id(plain)][1] if best[id(plain)][1] else 'alone'}): the "
                    "lag and a rate term hid each other")
    return other


#: product terms and the first-order (main-effect) forms of their factors
#: (:func:`marginal`)
PRODUCTS = {"chanprod": ("chan",), "gprod": ("g",), "Hprod": ("Hx", "Hy", "Hz")}


def marginal(wd: WorkData, base: FitResult, base_specs, out: list[Candidate],
             chosen: Candidate, thetas0, folds: int, fl: float = math.nan) -> Candidate:
    """A product of two channels chosen while the first-order terms of its factors are not
    in the model: the product of two stepped stimuli fits much of their two separate level
    effects (it is nonzero only where both are on), so it can win alone where the two
    levels are the truth (seed 24177: humidity and a vibration level both missing;
    chanprod(RH_lab,pump_vib) −96 % alone, held-out 0.119 deg/h; chan(RH_lab) with
    chan(pump_vib) 0.039 deg/h, at the floor). The hierarchy principle of regression --
    no interaction without its main effects -- is applied as a test: the missing main
    effects are fitted together, and when they do clearly better than the product (held-out
    RMS at most :data:`PAIR_MARGIN` of its; seed 21091: a tilt level times a decoy humidity,
    0.360 deg/h, against the two levels, 0.357, keeps the product's course) and pass the far-route consistency (:data:`FAR_GAIN`, :data:`FAR_T`),
    the more useful of them leads and the next step tests the other. A true cross term
    (anisoelastic g_x·g_y) is not a sum of levels and keeps the product."""
    mains_of = PRODUCTS.get(chosen.spec.key if chosen.spec else "")
    if not mains_of or chosen._fit is None or not math.isfinite(chosen.rms_holdout):
        return chosen
    level = _product_level(chosen, out, mains_of, fl)
    if level is not None:
        return level
    have = {(s.key, s.channels) for s in base_specs}
    mains = []
    for ch in chosen.spec.channels:
        if any(k in mains_of and chs == (ch,) for k, chs in have):
            continue
        m = next((c for c in out if c.spec is not None and c.spec.key in mains_of
                  and c.spec.channels == (ch,) and not c.replaces and c._fit is not None
                  and math.isfinite(c.rms_holdout)), None)
        if m is None:
            return chosen
        mains.append(m)
    if not mains:
        return chosen
    if len(mains) == 1:
        r = mains[0]._fit
    else:
        r = fit_pair(wd, base_specs, mains[0], mains[1], thetas0, folds)
    if r is None or not r.rms_holdout <= PAIR_MARGIN * chosen.rms_holdout:
        return chosen
    impr, _, t_cv = held_out_gain(base, r, folds)
    if not (impr >= FAR_GAIN and t_cv >= FAR_T):
        return chosen
    first = min(mains, key=lambda c: c.rms_holdout)
    note = (f"{chosen.term} would be a product without its main effects: the first-order "
            f"terms of its factors reach {r.rms_holdout:.4g} deg/h, it {chosen.rms_holdout:.4g}")
    if len(mains) == 1:
        first.significant = True
        first.rejected = None
        first.route = first.route or "main effect of a product"
        first.note = note
        return first
    other = mains[1] if first is mains[0] else mains[0]
    lead = mark_pair((first, other, r.rms_holdout, t_cv))
    lead.displaced = (chosen.term, chosen.rms_holdout)
    lead.note = "a product without its main effects"
    return lead

def _product_level(chosen: Candidate, out: list[Candidate], mains_of,
                   fl: float) -> Candidate | None:
    """The level of a factor of the product ``chosen`` that is a missing effect itself and
    that the product only imitates over this log (fitted contributions alike to |r| ≥
    :data:`PRODUCT_LEVEL_R`: the other factor is nearly constant wherever this one varies),
    marked to lead; None when there is none. The hierarchy principle -- no interaction
    without its main effect -- where the log cannot tell the two apart: the next step tests
    the product beside the level, so the level must leave the model at least
    :data:`FAR_RATIO` × the floor ``fl`` (seed 34109: Hx·Hz, r 0.990 with Hx, took the model
    below the floor, Hx alone to 1.05 × it, where the next step stopped)."""
    if not (math.isfinite(fl) and fl > 0):
        return None
    xp = own_contribution(chosen)
    if xp is None:
        return None
    best, best_r = None, 0.0
    for m in out:
        if (m.spec is None or m.spec.key not in mains_of or len(m.spec.channels) != 1
                or m.spec.channels[0] not in chosen.spec.channels or m.replaces
                or not m.significant or m._fit is None
                or not m.rms_holdout >= FAR_RATIO * fl):
            continue
        r = abs_corr(xp, own_contribution(m))
        if r >= PRODUCT_LEVEL_R and r > best_r:
            best, best_r = m, r
    if best is None:
        return None
    best.note = (f"{chosen.term} holds out {chosen.rms_holdout:.4g} deg/h, {best.term} "
                 f"{best.rms_holdout:.4g}; over this log the product is the level to "
                 f"r = {best_r:.3f} (its other factor is nearly constant wherever "
                 f"{best.spec.channels[0]} varies): the level leads, and the next step tests "
                 "the product beside it")
    return best


#: rate forms :func:`lag_or_plain` tries beside a lag and its plain form
RATE_FORMS = ("dTdt", "dTlagdt", "dGdt", "dchan", "dchanlag")
#: ... the rate forms through a lag of their own
LAGGED_RATES = ("dTlagdt", "dchanlag")


#: second-order forms a lookahead tries beside a tied candidate (:func:`lookahead`)
HIGHER_ORDER = ("chan2", "chanprod", "T2", "g2", "gprod", "Hsq", "Hprod", "Hmag2", "Hquad")
#: products of two channels (lookahead partners on any channels, :func:`lookahead`)
CROSS_TERMS = ("chanprod", "gprod", "Hprod")


#: the level and the square of one channel: a second-order sensitivity whose two terms
#: nearly cancel over the stimulus range explains nothing term by term
LEVEL_SQUARE = {"g": "g2", "T": "T2", "chan": "chan2", "Hx": "Hsq", "Hy": "Hsq", "Hz": "Hsq"}


def _spectral_rejected(c: Candidate) -> bool:
    """Whether ``c`` alone was set aside by the spectral test (its coefficient did not stand
    out of the residual's slow noise)."""
    return bool(c.rejected) and c.rejected.startswith(SPECTRAL_REJECT)


def _pairable(out: list[Candidate]) -> list[Candidate]:
    """Candidates the pair search may use: fitted, not replacing a term, not a hysteresis
    branch (:data:`HYST_WEAK_CV_T`), not rejected -- except by the spectral test (its
    coefficient did not stand out of the residual's slow noise): a second missing effect
    lowers that z too, and the pair must pass the spectral test itself (seed 23141: an
    ageing ramp alone −41 % at spectral z 6.6, the anisoelastic product beside it hidden;
    together −87 % at z 45)."""
    return [c for c in out if c.spec is not None and not c.replaces
            and (c.rejected is None or _spectral_rejected(c))
            and c._fit is not None and math.isfinite(c.rms_holdout) and c.spec.key != "hyst"]


def _polynomial_pairs(out: list[Candidate]) -> list[tuple[Candidate, Candidate]]:
    """(level, square) candidate pairs of one channel (:data:`LEVEL_SQUARE`)."""
    ok = _pairable(out)
    pairs = []
    for a in ok:
        sq = LEVEL_SQUARE.get(a.spec.key)
        b = next((o for o in ok if sq and o.spec.key == sq
                  and o.spec.channels == a.spec.channels), None)
        if b is not None:
            pairs.append((a, b))
    return pairs


def _hyst_level_pairs(out: list[Candidate]) -> list[tuple[Candidate, Candidate]]:
    """(hysteresis, level) candidate pairs of one temperature channel: hyst(c) with T(c),
    and with T2(c) (seed 35077: a hysteresis and a T² of tc1 both missing, with T(tc1) in
    the model; hyst alone −77 %, T² alone nothing, together −92 %, to 1.2 × the true
    model).

    A hysteresis branch is a heating/cooling offset *on top of* the linear sensitivity of
    the same sensor; when both are missing, each alone fits the other's part with the
    wrong sign pattern (seed 22154: hyst alone −19 % held-out at HAC z 0.5, T alone +3 %,
    the two together −59 % at z 9.2 and 8.0). Hysteresis is kept out of the general pool
    (it fits slow wander), so this pair is tried on its own and must pass a joint HAC
    test (:data:`HYST_PAIR_Z`)."""
    ok = [c for c in out if c.spec is not None and not c.replaces and c.rejected is None
          and c._fit is not None and math.isfinite(c.rms_holdout)]
    pairs = []
    for h in ok:
        if h.spec.key != "hyst":
            continue
        pairs += [(h, o) for o in ok if o.spec.key in ("T", "T2")
                  and o.spec.channels == h.spec.channels]
    return pairs


def _hidden(c: Candidate) -> bool:
    """A candidate kept out of the general pair pool that may be one of two effects hiding
    each other: a hysteresis branch, or a term rejected only because its coefficient did not
    stand out of the residual's slow noise (another missing effect's)."""
    if c.spec is None or c.replaces or c._fit is None or not math.isfinite(c.rms_holdout):
        return False
    if c.spec.key == "hyst":
        return c.rejected is None
    return bool(c.rejected and c.rejected.startswith(SPECTRAL_REJECT))


def _hidden_pairs(out: list[Candidate], pool: list[Candidate]
                  ) -> list[tuple[Candidate, Candidate]]:
    """Pairs of one hidden candidate (:func:`_hidden`; the :data:`HIDDEN_TOP` best by
    held-out gain) with a member of the pool or another hidden candidate.

    A warm-up far above the floor beside a missing hysteresis (seed 23147: warm-up −44 %
    held-out, spectral z 3.4 -- the hysteresis is the residual's slow noise; hysteresis
    −15 % at HAC z 2.3; the two together −90 %, at the floor). Such a pair must pass the
    joint HAC test of :func:`_joint_z_ok` (both members at :data:`HYST_PAIR_Z`) and cut
    the held-out RMS by the gain that needs no spectral test
    (:func:`gyrotest.envmodel.rules.spectral_exempt`): a hysteresis and a sinusoid fitted
    together to a real gyro's wander reached −26 % at fold consistency 7 (seed 23019)."""
    hid = [c for c in out if _hidden(c) and c.improvement_pct >= 100 * PAIR_MIN_GAIN]
    hid = sorted(hid, key=lambda c: -c.improvement_pct)[:HIDDEN_TOP]
    partners = [c for c in pool if c.spec.key != "hyst"] + hid
    pairs = []
    for h in hid:
        for m in partners:
            if m is h or (m.spec.key == "hyst" and h.spec.key == "hyst"):
                continue
            if m in hid and (m, h) in pairs:
                continue
            pairs.append((h, m))
    return pairs


#: trend terms paired with every pool member (:func:`_trend_pairs`)
TRENDS = ("ramp",)
#: the best pool members paired with every candidate outside the pool (:func:`_partner_pairs`)
PARTNER_TOP = 2


def _trend_pairs(out: list[Candidate], pool: list[Candidate]
                 ) -> list[tuple[Candidate, Candidate]]:
    """A trend (:data:`TRENDS`) with each member of the pool, whatever the trend's own gain.

    An ageing ramp beside a missing lagged-coil term can gain nothing alone, not even in
    sample (seed 24170: ramp +14 % held-out, 0.0 % fit; the coil lag alone −21 % at a
    trapped τ of 176 s; the two together −84 %, 1.2× the floor), so neither the gain nor
    the fit-gain rule brings it into the pool. Such a pair must pass the joint HAC test of
    :func:`_joint_z_ok` (a ramp fits a gyro's random walk as well as any drift), or carry
    decisive held-out and spectral evidence (:func:`_decisive_over_members`)."""
    trends = [c for c in _pairable(out) if c.spec.key in TRENDS and c not in pool]
    return [(m, t) for t in trends for m in pool if m.spec.key not in TRENDS]


def _partner_pairs(out: list[Candidate], pool: list[Candidate]
                   ) -> list[tuple[Candidate, Candidate]]:
    """Each of the :data:`PARTNER_TOP` best members of the pool (and a warm-up of the pool,
    wherever it ranks) with every other fittable candidate outside the pool, whatever that
    candidate's own gain.

    The generalisation of :func:`_trend_pairs`: an effect hidden by a larger one can make
    the held-out prediction *worse* alone, and then neither the gain nor the fit-gain rule
    brings it into the pool (seed 28086: a sensor lagging its node by 313 s, i.e. a term in
    the rate of the case temperature, beside a warm-up: dT/dt alone +7 % held-out, the
    warm-up alone −27 % at HAC z 0.3; the two together −92 %, 1.1× the true model, at z 8.1
    and 8.9). Such a pair must pass the joint HAC test of :func:`_joint_z_ok` like the
    other pairs that no single-term evidence backs, or carry decisive evidence
    (:func:`_decisive_over_members`)."""
    # a trend leads too (seed 23141: the ramp and a g cross term hidden behind it); so does
    # a warm-up of the pool wherever it ranks: only the first folds see it, so its own gain
    # understates it (seed 41065, real noise: a ramp and a sinusoid ranked above a warm-up
    # whose partner, the rate term of a lagging sensor, was +0.6 % alone; the two together
    # −94 %, at the true model's held-out RMS)
    lead = list(pool[:PARTNER_TOP])
    lead += [c for c in pool[PARTNER_TOP:] if c.spec.key == "warmup"]
    in_pool = {id(c) for c in pool}
    rest = [c for c in _pairable(out) if id(c) not in in_pool and c.spec.key not in TRENDS]
    return [(a, m) for a in lead for m in rest]


#: the forms of one channel fitted together as a block (:func:`_channel_pairs`): level,
#: square, rate and the rate of a lagged node (a level with a lag rate spans the lag itself)
CHANNEL_BLOCK = {"T": ("T", "T2", "dTdt", "dTlagdt"),
                 "chan": ("chan", "chan2", "dchan", "dchanlag")}


def _channel_pairs(wd: WorkData, base: FitResult, base_specs, out: list[Candidate],
                   thetas0, folds: int) -> list[tuple[Candidate, Candidate, dict]]:
    """Pairs of two forms of one channel (:data:`CHANNEL_BLOCK`), for the channels whose
    forms fitted together as one block cut the held-out RMS by the far-route gain
    (:data:`FAR_GAIN`, :data:`FAR_T`) and at least :data:`PAIR_MARGIN` below the best of
    them alone.

    Two effects of one sensor can hide each other so well that neither helps alone, not
    even enough to enter the pair pool (seed 27119: the rate of a lagged node of T_gyro
    −10 % held-out, T² of the same sensor −97 %; the two together −96 %, at the floor).
    Such a pair must pass the joint HAC test of :func:`_joint_z_ok`. The block is fitted
    from the base model's nonlinear parameters and from the members' own (a lag's τ fitted
    alone beside the other effect may be trapped far from the truth: 1611 s against 866 s
    for 27119); its pairs start from the better block's. Returns (a, b, start) triples."""
    ok = [c for c in out if c.spec is not None and not c.replaces and c._fit is not None
          and math.isfinite(c.rms_holdout)
          and (c.rejected is None or c.rejected.startswith(SPECTRAL_REJECT))]
    have = {(s.key, s.channels) for s in base_specs}
    pairs: list[tuple[Candidate, Candidate, dict]] = []
    # a channel's block is keyed on its level candidate (not tried when the model has it)
    chans = {c.spec.channels: CHANNEL_BLOCK[c.spec.key] for c in ok
             if c.spec.key in CHANNEL_BLOCK}
    for ch, forms in chans.items():
        members = [c for k in forms for c in ok
                   if c.spec.key == k and c.spec.channels == ch and (k, ch) not in have]
        if len(members) < 2:
            continue
        own = dict(thetas0)
        for c in members:
            own.update(getattr(c._fit, "_thetas", {}) or {})
        r = fit_from_starts(wd, list(base_specs) + [c.spec for c in members], thetas0, own,
                            folds)
        if r is None or not r.rms_holdout <= PAIR_MARGIN * min(c.rms_holdout for c in members):
            continue
        impr, _, t_cv = held_out_gain(base, r, folds)
        if not (impr >= FAR_GAIN and t_cv >= FAR_T):
            continue
        th = dict(getattr(r, "_thetas", {}) or {})
        pairs += [(members[i], members[j], th) for i in range(len(members))
                  for j in range(i + 1, len(members))]
    return pairs


def _plain_level(wd: WorkData, base_specs, out: list[Candidate], h: Candidate,
                 m: Candidate, r: FitResult, thetas0, folds: int
                 ) -> tuple[Candidate, FitResult] | None:
    """For a qualifying pair of a hysteresis ``h`` and ``m`` (fit ``r``): the level T(c) of
    the same temperature when T(c) with ``m`` does as well (held-out RMS within
    :data:`TIE`): a branch offset as wide as the excursions is that level (seed 22078: the
    ramp with hyst(T_gyro) or with T(T_gyro), 0.0218 deg/h both; T alone helps nothing)."""
    lv = next((o for o in out if o.spec is not None and o.spec.key == "T"
               and o.spec.channels == h.spec.channels and not o.replaces
               and o._fit is not None and math.isfinite(o.rms_holdout)), None)
    if lv is None:
        return None
    r2 = fit_pair(wd, base_specs, lv, m, thetas0, folds)
    if r2 is None or r2.rms_holdout > (1 + TIE) * r.rms_holdout:
        return None
    return lv, r2


def _joint_z_ok(r: FitResult, a: Candidate, b: Candidate, wd: WorkData,
                t_cv: float = math.nan) -> bool:
    """Both members' coefficients stand out in the pair's own fit: HAC z of each at least
    :data:`HYST_PAIR_Z` (the test of :func:`gyrotest.envmodel.candidate.significance`).

    The HAC z is taken against a t reference with the regressor's effective degrees of
    freedom, and some regressors have almost none whatever their size:
    - a warm-up is one transient at the start of the record (seed 35075: a −322 deg/h
      warm-up beside a missing temperature term, HAC t 83 in the pair's fit, z 2.7). It
      passes on the test single warm-ups take far above the floor: spectral z ≥
      :data:`WARMUP_SPECTRAL_Z` in the pair's fit;
    - a hysteresis branch in a chamber run of few heating/cooling cycles (seed 35077: with
      the missing T² of the same sensor, HAC t 153, z 3.1). At a pair fold consistency
      ``t_cv`` ≥ :data:`HYST_STRONG_CV_T`, where no wander fit was seen, a hysteresis member
      passes at spectral z ≥ :data:`SPECTRAL_Z` instead (the red-residual floor as for
      singles). Not any member: a channel lag's rate at HAC z 0.2 took that route beside
      the rate of a lagged node (seed 21091) and displaced the true temperature term."""
    for c in (a, b):
        try:
            z, _ = significance(r, c.spec, None, wd)
        except (ValueError, np.linalg.LinAlgError, IndexError):
            return False
        if math.isfinite(z) and abs(z) >= HYST_PAIR_Z:
            continue
        if c.spec.key in TIME_TERMS and spectral_z(r, [c.term], wd, red=False) \
                >= WARMUP_SPECTRAL_Z:
            continue
        if c.spec.key == "hyst" and t_cv >= HYST_STRONG_CV_T and spectral_z(
                r, [c.term], wd, red=red_floor_for([c.spec.key], z)) >= SPECTRAL_Z:
            continue
        return False
    return True


def _decisive(gain: float, t_cv: float, z_spec: float) -> bool:
    """A pair whose evidence needs no joint HAC test (:data:`HIDDEN_TOP`; and, with
    :func:`_decisive_over_members`, a pair tested jointly that fails that test): held-out
    ``gain`` ≥ :data:`SINGLE_EXEMPT_GAIN` at fold consistency ``t_cv`` ≥
    :data:`SINGLE_EXEMPT_T` (the bar a single term needs to skip the spectral test), or
    ≥ :data:`DECISIVE_GAIN` at ≥ :data:`SPECTRAL_EXEMPT_T`, and spectral z ``z_spec`` ≥
    :data:`SPECTRAL_Z` (the far bar) in the pair's fit."""
    return (((gain >= SINGLE_EXEMPT_GAIN and t_cv >= SINGLE_EXEMPT_T)
             or (gain >= DECISIVE_GAIN and t_cv >= SPECTRAL_EXEMPT_T))
            and math.isfinite(z_spec) and z_spec >= SPECTRAL_Z)


def _decisive_over_members(r: FitResult, a: Candidate, b: Candidate, gain: float,
                           t_cv: float, z_spec: float, folds: int) -> bool:
    """A pair tested jointly that fails the joint HAC test (:func:`_joint_z_ok`) still
    qualifies when its evidence is decisive (:func:`_decisive`) both against the model
    (``gain``, ``t_cv``) and against its better member alone: the pair's own fit ``r`` holds
    out decisively better than that member's, so neither member carries the pair. Seed
    79011: g of acc_ay with an ageing ramp, −91 % against the model and −88 % against g
    alone; seed 24177: a product of two channels with a warm-up, −96 % against the model
    but only −17 % against the product alone (a warm-up riding on the product)."""
    if not _decisive(gain, t_cv, z_spec):
        return False
    m = a if a.rms_holdout <= b.rms_holdout else b
    if m._fit is None:
        return False
    g_m, _, t_m = held_out_gain(m._fit, r, folds)
    return _decisive(g_m, t_m, z_spec)


def pair_pool(base: FitResult, out: list[Candidate]) -> list[Candidate]:
    """The candidates :func:`pair_step` pairs (see :data:`PAIR_TOP`, :data:`PAIR_MORE`)."""
    ok = _pairable(out)

    def group(c: Candidate):
        return tuple(sorted(c.spec.channels)) or (c.spec.key,)

    pool = [c for c in ok if c.improvement_pct >= 100 * PAIR_MIN_GAIN][:PAIR_TOP]
    seen = {group(c) for c in pool}
    more = 0
    for c in ok:  # ranked best first
        if more >= PAIR_MORE:
            break
        if c.improvement_pct >= 100 * PAIR_MIN_GAIN and group(c) not in seen:
            pool.append(c)
            seen.add(group(c))
            more += 1
            # a lag fitted beside a larger hidden effect may take a poor τ: the plain form
            # of the same channel too
            plain = UNLAGGED.get(c.spec.key)
            sib = next((o for o in ok if plain and o.spec.key == plain
                        and o.spec.channels == c.spec.channels
                        and o.improvement_pct >= 100 * PAIR_MIN_GAIN), None)
            if sib is not None and sib not in pool:
                pool.append(sib)
    fit_gain = sorted((c for c in ok if c not in pool and math.isfinite(c.rms_fit)
                       and base.rms_fit > 0
                       and 1 - c.rms_fit / base.rms_fit >= PAIR_FIT_GAIN),
                      key=lambda c: c.rms_fit)
    pool += fit_gain[:max(0, PAIR_POOL - len(pool))]
    return pool
