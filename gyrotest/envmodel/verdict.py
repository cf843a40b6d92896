"""The verdict of a diagnosis step in words (:func:`verdict_text`) and the rule that reads a
qualifying sinusoid at a logged stimulus's period as an effect of that channel
(:func:`period_rule`); both are used by :mod:`gyrotest.envmodel.diagnose`."""

from __future__ import annotations

import math

from .candidate import Candidate, uses_channel
from .fit import FitResult
from .rules import (
    AT_FLOOR,
    CHANCE_P,
    FAR_T_NUISANCE,
    FAR_Z,
    MIN_IMPROVEMENT,
    PERIOD_SHARE,
    WARMUP_SPECTRAL_Z,
)


def period_rule(out: list[Candidate], frame) -> None:
    """A qualifying sinusoid whose period is that of logged stimuli
    (:func:`gyrotest.envmodel.screen.period_matches`) is a stimulus acting through its
    channel -- when a term of one of those channels explains it: the best candidate using
    any of them (a channel-less nuisance term does not count; a hysteresis of a temperature
    does) gets at least :data:`PERIOD_SHARE` of the sinusoid's held-out gain. Then the
    sinusoid is rejected; otherwise no such channel carries the disturbance (an HVAC cycle
    seen in a temperature and in the rate by another path) and the sinusoid stands, with a
    note."""
    for c in out:
        ms = c.period_match
        if not ms or not c.significant:
            continue
        chans = list(dict.fromkeys(name.rstrip("²") for name, _ in ms))
        per = 1.0 / float((c._fit._thetas.get(c.term) or {})["f_Hz"])  # type: ignore[union-attr]
        users = [o for o in out if o is not c and o.spec is not None and o.spec.key != "sin"
                 and math.isfinite(o.improvement_pct)
                 and any(uses_channel(o.spec, ch, frame) for ch in chans)]
        best = max(users, key=lambda o: o.improvement_pct, default=None)
        share = (best.improvement_pct / c.improvement_pct
                 if best is not None and c.improvement_pct > 0 else 0.0)
        names = ", ".join(f"{n} (R² {r2:.2f})" for n, r2 in ms[:3])
        if share >= PERIOD_SHARE:
            c.rejected = (f"its period {per:.4g} s is that of the logged stimulus {names} and "
                          f"{best.term} explains it too ({-best.improvement_pct:+.1f} % vs "
                          f"{-c.improvement_pct:+.1f} %): an effect of that channel, not a "
                          "periodic disturbance")
            c.significant = False
            c.route = None
        else:
            c.note = (f"its period {per:.4g} s is also that of the logged stimulus {names}, "
                      f"but no term of {', '.join(chans[:3])} explains it"
                      + (f" (best: {best.term}, {-best.improvement_pct:+.1f} %)" if best
                         else ""))


def paste_hint(specs, c: Candidate) -> str:
    """The options that fit the model of ``specs`` with the candidate ``c`` in it, complete, to
    paste: ``--terms`` with every library term of the model (less those ``c`` replaces) and
    ``c``; the model's custom terms as their ``--term`` options. ``--terms 'dTlagdt(T)'``
    alone would fit a model without the terms it already has."""
    gone = set((c.replaces or "").split("; "))
    lib = [s.label for s in specs if s.key not in ("custom", "bias") and s.label not in gone]
    own = [f" --term '{s.name}:{s.expr}'" for s in specs
           if s.key == "custom" and s.label not in gone]

    def terms(extra: list[str]) -> str:
        return f"--terms '{','.join(lib + extra)}'" if lib or extra else ""

    if c.spec is not None and c.spec.key == "custom":
        return (terms([]) + "".join(own) + f" --term '{c.spec.name}:{c.spec.expr}'").strip()
    hint = terms([c.term]) + "".join(own)
    if c.custom:
        alt = terms([]) + "".join(own) + f" --term '{c.custom}'"
        hint += f" (or {alt.strip()})"
    return hint


def verdict_text(base: FitResult, cands: list[Candidate], chosen: Candidate | None,
                 path: list[dict], floor: float, ratio: float
                 ) -> tuple[str, Candidate | None]:
    """The verdict line of a diagnosis step: the chosen missing effect with its evidence, the
    route that qualified it, its pair or note, the hint that adds it and the forward path; or,
    when nothing was chosen, "at the noise floor", the best "possible" effect (a gain larger
    than the fold scatter, not significant), or "no missing effect" with the first rejected
    candidate's reason. The second value is the "possible" candidate, if any."""
    fl_txt = (f"the noise floor ({floor:.3g} deg/h)" if math.isfinite(floor)
              else "the noise floor (not estimated)")
    if chosen is not None:
        top = chosen
        v = (f"missing effect: {top.term} — {top.effect}; held-out RMS "
             f"{base.rms_holdout:.4g} → {top.rms_holdout:.4g} deg/h "
             f"({-top.improvement_pct:+.1f} %), {top.evidence.split(', ', 1)[1]}")
        if top.route == "far above the floor":
            v += (f"; the model is {ratio:.1f}x the noise floor, so the consistent held-out "
                  f"gain (gain/(fold scatter/sqrt(folds)) = {top.cv_t:.1f}) decides, not the "
                  "HAC test")
            if not (math.isfinite(top.z) and abs(top.z) >= FAR_Z):
                v += (f" (z = {top.z:.1f}: other missing effects inflate its error), with the "
                      f"coefficient standing out of the residual's spectrum (spectral z "
                      f"{top.spectral_z:.1f})")
            if (top.spec is not None and top.spec.key == "warmup"
                    and top.cv_t < FAR_T_NUISANCE):
                v += ("; a warm-up lives in the first chunks of the record, which most folds "
                      "cannot see, so a low consistency is accepted when its coefficient "
                      "stands out of the residual's slow noise (spectral z "
                      f"{top.spectral_z:.1f} >= {WARMUP_SPECTRAL_Z:g})")
        if top.route == "field axes":
            v += ("; no new effect qualifies, but the field effect the model has fits better "
                  "in the gyro's own axes: "
                  + (f"{top.term} replaces {top.replaces} (the z tests what it adds beyond "
                     "them" if top.replaces else f"{top.term} completes its field vector "
                     "(the z tests its coefficient")
                  + f"; gain/(fold scatter/sqrt(folds)) = {top.cv_t:.1f})")
        pair = top.pair
        if pair is not None:
            disp = top.displaced
            why = (f"{disp[0]} alone would leave {disp[1]:.4g} deg/h, while" if disp
                   else "no single term explains it:")
            many = ", " in pair[0]  # a group (:mod:`.groups`): three or more members
            # a field block in place of the model's field terms (:func:`.axes.block_pair`)
            other = pair[0] + (" in place of " + top.route.split(" in place of ", 1)[1]
                               if top.route and top.route.startswith("together with")
                               and " in place of " in top.route else "")
            v += (f"; the model is {ratio:.1f}x the noise floor and {why} "
                  f"{top.term}{', ' if many else ' and '}{other} together bring the "
                  f"held-out RMS to {pair[1]:.4g} deg/h, consistently across the folds "
                  f"(gain/(fold scatter/sqrt(folds)) = {pair[2]:.1f}); "
                  + (f"each alone or in pairs holds out far worse: they hide one another, so "
                     f"the next steps test {pair[0]}" if many else
                     f"each hides the other, so the next step tests {other}"))
        if top.note:
            v += f"; {top.note}"
        if top.klass == "channel" and math.isfinite(top.r_residual):
            ch = ", ".join(top.spec.channels) if top.spec else ""
            v += f"; the residual follows {ch} (r = {top.r_residual:+.2f})"
        v += (f"; add it with {paste_hint(base.specs, top)}"
              + (f" (in place of {top.replaces})" if top.replaces else ""))
        if top.equivalents:
            v += ("; indistinguishable in this log from " + ", ".join(top.equivalents[:3])
                  + " (same fitted contribution)")
        if len(path) > 1:
            v += "; then " + ", then ".join(
                f"{p['term']} (→ {p['rms_holdout_after_dph']:.3g} deg/h)" for p in path[1:])
            last = path[-1]["ratio_to_floor_after"]
            if math.isfinite(last):
                v += f"; held-out/floor after the path {last:.2f}"
        return v, None
    if math.isfinite(ratio) and ratio <= AT_FLOOR:
        return (f"no missing effect found: the held-out residual ({base.rms_holdout:.3g} "
                f"deg/h) is at {fl_txt}, ratio {ratio:.2f}"), None
    ok = [c for c in cands if math.isfinite(c.improvement_pct) and c.rejected is None]
    best = max(ok, key=lambda c: c.improvement_pct) if ok else None
    # a term a look-elsewhere test set aside (gates.chance_gate, gates.channel_chance_gate)
    aside = next((c for c in cands if c.chance is not None and c.note and not c.significant
                  and c.chance.p > CHANCE_P), None)
    if (best is not None and math.isfinite(best.gain_scatter_pct)
            and best.improvement_pct > max(best.gain_scatter_pct, 100 * MIN_IMPROVEMENT)):
        return (f"possible missing effect: {best.term} — {best.effect}; held-out RMS "
                f"{base.rms_holdout:.4g} → {best.rms_holdout:.4g} deg/h "
                f"({-best.improvement_pct:+.1f} %, more than the fold-to-fold scatter "
                f"{best.gain_scatter_pct:.1f} %) but not significant ({best.evidence}"
                + (f"; {best.note}" if best.chance is not None and best.note else "") + "); "
                f"held-out/floor {ratio:.2f}; try it with {paste_hint(base.specs, best)} on a "
                "second log"
                + (f"; {aside.term} was set aside: {aside.note}"
                   if aside is not None and aside is not best else "")), best
    rej = [c for c in cands if c.rejected]
    v = ("no missing effect found among the candidates"
         + (f"; the held-out residual is {ratio:.2g}x {fl_txt}: an effect outside the "
            "library and the channel screen, or noise slower than white/flicker (random "
            "walk, Markov); see the excursions" if math.isfinite(ratio) else ""))
    if aside is not None:
        v += f"; {aside.term} was set aside: {aside.note}"
    if rej:
        v += f"; {rej[0].term} was rejected: {rej[0].rejected}"
    return v, None
