"""The look-elsewhere gates of the workbench diagnosis (:mod:`gyrotest.envmodel.diagnose`):
whether the held-out gain of the effect a step chose is one that the best of the step's
candidates reaches on noise like the residual's (:mod:`gyrotest.envmodel.chance` builds the
surrogates and the tests; this module decides what the step names when they fail).

* :func:`chance_gate` -- a chosen ramp, warm-up or hysteresis
  (:data:`~gyrotest.envmodel.rules.CHANCE_KEYS`);
* :func:`channel_chance_gate` -- a channel term or pair chosen on the routes of
  :data:`~gyrotest.envmodel.rules.CHANNEL_CHANCE_ROUTES` between 2 and 10 x the floor;
* :func:`set_aside_pair` -- the pair that may stand in for a single term the gate set aside.
"""

from __future__ import annotations

import math

from .candidate import Candidate, equivalents
from .chance import candidate_regressors, chance_test, pair_chance_test
from .pairs import pair_step
from .rules import (
    CHANCE_GRID,
    CHANCE_K,
    CHANCE_P,
    CHANCE_SEED,
    CHANNEL_CHANCE_OTHERS,
    PAIR_CHANCE_TOP,
)


def chance_gate(wd, base, out: list[Candidate], chosen: Candidate, folds: int
                ) -> Candidate | None:
    """The look-elsewhere surrogate test of a chosen ramp, warm-up or hysteresis
    (:mod:`.chance`, :data:`CHANCE_KEYS`,
    :data:`CHANCE_P`): the term; or, when the best candidate of the step reaches its held-out
    gain on noise with the residual's own spectrum, the best other significant candidate
    that is not a nuisance term and whose own gain the surrogates do not reach, else None
    (the nuisance term stays a "possible" effect)."""
    test = phase_test(wd, base, out, chosen, folds)
    if test is None or test.p <= CHANCE_P:
        return chosen
    chosen.significant = False
    chosen.route = None
    chosen.note = test.text()
    # the same surrogates judge the others: one whose gain they reach is no better
    other = []
    for c in out:
        if not c.significant:
            continue
        if not (math.isfinite(c.improvement_pct)
                and test.p_of(c.improvement_pct / 100.0) <= CHANCE_P):
            c.significant = False
            c.route = None
        elif (c.pair is None and not c.hac_waived and c.klass != "nuisance"
              and math.isfinite(c.rms_holdout)):
            other.append(c)
    if not other:
        for c in out:
            c.significant = False
        return None
    nxt = min(other, key=lambda c: c.rms_holdout)
    nxt.equivalents = equivalents(nxt, out, base)
    return nxt


def channel_chance_gate(wd, base, out: list[Candidate], chosen: Candidate, folds: int,
                        follows=None) -> Candidate | None:
    """The look-elsewhere tests of a chosen channel term or pair
    (:data:`CHANNEL_CHANCE_ROUTES`): the term; or None (every candidate of the step set
    aside, the best left as a "possible" effect) when its held-out gain is one that
    chance reaches on noise like the residual's.

    * A single term must beat the phase-randomised surrogates of the base residual
      (:func:`.chance.chance_test`, surrogate p ≤ :data:`CHANCE_P`) *or* the circular
      shifts and reversals of the residual the term itself leaves
      (:func:`.chance.shift_surrogates`). The first test carries a missed effect's own power
      into every surrogate and alone is conservative for a true slow channel effect; the
      second carries only what the term leaves, with a real gyro's own excursions in place.
      A term both tests reach is set aside, and the next qualifying candidate (best held-out
      first, at most :data:`CHANNEL_CHANCE_OTHERS`) that beats either test is named instead;
      when none does, the step's best qualifying pair that beats the pair test below
      (:func:`set_aside_pair`; ``follows`` as for :func:`.pairs.pair_step`).
    * A pair must beat the best pair of the step's :data:`PAIR_CHANCE_TOP` best single
      candidates on phase-randomised surrogates of the base residual
      (:func:`.chance.pair_chance_test`)."""
    if chosen.pair is not None:
        test = _pair_chance(wd, base, out, chosen, folds)
        if test is None:
            return chosen
        chosen.chance = test
        if test.p <= CHANCE_P:
            return chosen
        note = test.text()
    else:
        # the candidates' regressors once for every test of the step below
        regs = candidate_regressors(wd, base, out, CHANCE_GRID)
        test = phase_test(wd, base, out, chosen, folds, regs)
        if test is None or test.p <= CHANCE_P or beats_shifts(wd, base, out, chosen,
                                                              test.gain, folds, regs):
            return chosen
        note = (f"{test.text()}; and so do the circular shifts and reversals of the "
                "residual it leaves (the gyro's own excursions kept)")
    chosen.significant = False
    chosen.route = None
    chosen.pair = None
    chosen.note = note
    if chosen.chance.kind == "phase":
        # the same surrogates judge the other qualifying candidates, best held-out first:
        # the first whose gain they do not reach, or that beats the shifts of its own
        # residual, is named (seed 63180: a rotated field component set aside beside a
        # temperature level on the strict route)
        others = sorted((c for c in out if c is not chosen and c.significant
                         and c.pair is None and c.replaces is None and c.spec is not None
                         and math.isfinite(c.improvement_pct)
                         and math.isfinite(c.rms_holdout)), key=lambda c: c.rms_holdout)
        for c in others[:CHANNEL_CHANCE_OTHERS]:
            g = c.improvement_pct / 100.0
            if chosen.chance.p_of(g) <= CHANCE_P or (
                    c.klass != "nuisance" and beats_shifts(wd, base, out, c, g, folds,
                                                           regs)):
                c.equivalents = equivalents(c, out, base)
                return c
        # ... nor another single: the set-aside term may be one of two effects that hide
        # each other (the missed one in every surrogate), judged as a pair
        ch = chosen.chance
        pair = set_aside_pair(wd, base, out, folds, follows)
        if pair is not None:
            pair.note = (f"{chosen.term} alone was set aside ({ch.exceed} of {ch.k} "
                         "phase-randomised surrogates of the residual reach its gain, and so "
                         "do the shifts of the residual it leaves: a missed partner is in "
                         f"every one); the pair {pair.term} + {pair.pair[0]} beats the best "
                         "pair of the step's candidates on the phase surrogates "
                         f"(p = {pair.chance.p:.2g})")
            return pair
    for c in out:
        c.significant = False
        c.route = None
    return None


def phase_test(wd, base, out: list[Candidate], chosen: Candidate, folds: int,
               regs: list | None = None):
    """The look-elsewhere test of ``chosen``'s held-out gain on phase-randomised surrogates
    of the base residual (:func:`.chance.chance_test`; ``regs`` the step's candidate
    regressors when built), kept as ``chosen.chance``; None when it cannot be run."""
    gain = chosen.improvement_pct / 100.0
    if not math.isfinite(gain):
        return None
    test = chance_test(wd, base, out, gain, folds=folds, k=CHANCE_K, grid=CHANCE_GRID,
                       seed=CHANCE_SEED, regs=regs)
    if test is not None:
        chosen.chance = test
    return test


def beats_shifts(wd, base, out: list[Candidate], c: Candidate, gain: float, folds: int,
                 regs: list | None = None) -> bool:
    """Whether candidate ``c``'s held-out ``gain`` (fraction) beats the best chance gains on
    the circular shifts and reversals of the residual ``c`` itself leaves
    (:func:`.chance.shift_surrogates`; p ≤ :data:`CHANCE_P`), or cannot be tested."""
    fit = c._fit
    if fit is None or fit.resid is None:
        return True
    shifted = chance_test(wd, base, out, gain, folds=folds, k=CHANCE_K, grid=CHANCE_GRID,
                          seed=CHANCE_SEED, resid=fit.resid, shifts=True, regs=regs)
    return shifted is None or shifted.p <= CHANCE_P


def set_aside_pair(wd, base, out: list[Candidate], folds: int, follows=None
                   ) -> Candidate | None:
    """After :func:`channel_chance_gate` set a single term aside and no other single beat
    its tests: the step's best qualifying pair (:func:`.pairs.pair_step`, the pair route's
    own bars: held-out gain, fold consistency, spectral and joint HAC tests, and the next
    step must name the other member when ``follows`` says so) whose held-out gain beats the
    best pair of the step's :data:`PAIR_CHANCE_TOP` best candidates on phase-randomised
    surrogates of the base residual (:func:`.chance.pair_chance_test`, p ≤ :data:`CHANCE_P`,
    the test every pair chosen on the pair route takes). Its more useful member is returned,
    marked "together with" the other; None when no pair qualifies or beats the test.

    A single term's surrogates carry the power of every effect the base model misses, so a
    term whose partner is missing too is the one the single test is most conservative for
    (seed 69199: the supply voltage, 2.9 x the floor, −31 % held out at HAC z 2.9, surrogate
    p 0.15, beside the missed rate of a lagging case sensor; the two together −77 %, pair
    p 0.025, to the true model; the loop had ended at 4.3 x it). The pair's chance test
    asks the same question of the pair, against the best pair chance finds."""
    base_specs = [s for s in base.specs if s.key != "bias"]
    thetas0 = dict(getattr(base, "_thetas", {}) or {})
    pair = pair_step(wd, base, base_specs, out, thetas0, folds, follows=follows)
    if pair is None:
        return None
    return pair_chance_gate(wd, base, out, pair, folds, untested=False)


def pair_chance_gate(wd, base, out: list[Candidate], pair: Candidate, folds: int,
                     untested: bool = True) -> Candidate | None:
    """``pair`` (a candidate marked "together with" its partner) when its held-out gain
    beats the best pair of the step's candidates on phase-randomised surrogates of the base
    residual (:func:`_pair_chance`, p ≤ :data:`CHANCE_P`), or when the test cannot be run
    and ``untested`` allows it; else None, the candidate unmarked."""
    test = _pair_chance(wd, base, out, pair, folds)
    if (test is None and not untested) or (test is not None and test.p > CHANCE_P):
        pair.significant = False
        pair.route = None
        pair.pair = None
        return None
    if test is not None:
        pair.chance = test
    pair.equivalents = equivalents(pair, out, base)
    return pair


def _pair_chance(wd, base, out: list[Candidate], pair: Candidate, folds: int):
    """The look-elsewhere test of ``pair`` (a candidate marked "together with" its partner,
    ``pair.pair = (partner term, pair held-out RMS)``): its held-out gain over the base
    model against the best pair of the step's :data:`PAIR_CHANCE_TOP` best candidates on
    phase-randomised surrogates of the base residual (:func:`.chance.pair_chance_test`);
    None when the gain is undefined or the test cannot be run."""
    partner = next((c for c in out if c.term == pair.pair[0]), None)
    gain = 1.0 - pair.pair[1] / base.rms_holdout if base.rms_holdout > 0 else math.nan
    if not math.isfinite(gain):
        return None
    return pair_chance_test(wd, base, out, pair, partner, gain, folds=folds, k=CHANCE_K,
                            top=PAIR_CHANCE_TOP, seed=CHANCE_SEED)


__all__ = ["beats_shifts", "chance_gate", "channel_chance_gate", "pair_chance_gate",
           "phase_test",
           "set_aside_pair"]
