"""The decision rules of the workbench diagnosis (:mod:`gyrotest.envmodel.diagnose`), in
words, with their thresholds: what ``gyrotest model diagnose --rules`` prints and the man page
lists. The thresholds live in :mod:`gyrotest.envmodel.rules`; the text follows them (a change of
rule changes both; ``tests/test_envmodel_cli.py`` checks the main numbers). A plain module outside
:mod:`gyrotest.envmodel`, so that printing it does not load numpy and scipy.
"""

from __future__ import annotations

import textwrap

#: (heading, text) of each rule, in the order the diagnosis applies them
RULES: tuple[tuple[str, str], ...] = (
    ("Routes",
     "A missing effect needs its held-out gain more often a gain than not across the folds "
     "(gain / (fold scatter / sqrt(folds)) >= 1) and either passes the strict test (p x "
     "trials x candidates < alpha, gain >= --min-improvement) or gives a clear gain (>= 5 % "
     "while the model is above 1.2x the noise floor, p x trials < 0.01; a warm-up, which "
     "most folds cannot see, also >= 10 % at fold consistency >= 2.13), or, when the model "
     "is at least 2x the noise floor, cuts the held-out RMS by >= 10 % consistently across "
     "the folds (gain / (fold scatter / sqrt(folds)) >= 2.13, |z| >= 1; ramp, warm-up, "
     "sinusoid and hysteresis >= 20 % at >= 3.75, a warm-up, which most folds cannot see, at "
     ">= 2.13 with spectral z >= 8); there, when no single term qualifies (or a pair of two "
     "others halves the held-out RMS of the one that does), the best candidates, further "
     "channels and the largest in-sample gains are also tried in pairs, and so are the level "
     "and square of each channel and a ramp beside each of them (two effects that hide each "
     "other are named one after the other; a pair with a warm-up at fold consistency >= 2.13 "
     "when its spectral z is >= 8; when the best pair fails the joint HAC test (both members "
     "|z| < 1 alone), a qualifying pair naming the same member first stands in (such a pair "
     "passes without that test at a gain >= 55 % with fold consistency >= 10, or >= 70 % "
     "with >= 5, and spectral z >= 8); a pair whose first member alone makes the model worse "
     "only when the next step then names an effect, so the loop cannot add and remove it in "
     "turn); last of all, a term whose |z| < 1 only because other missing effects inflate "
     "its error, when its coefficient stands out of the residual's spectrum (spectral z >= "
     "8)."),
    ("Sinusoids",
     "A sinusoid on the period of a logged stimulus is rejected when a term of that channel "
     "gets half its gain; otherwise it stands, and the verdict says whose period it shares."),
    ("Slow wander",
     "Off the strict test, the added coefficients must also stand out of the candidate "
     "model's residual spectrum (frequency-domain GLS z >= 8; >= 4 while the model is within "
     "2x the floor, or when the candidate brings it within 1.25x), unless the held-out gain "
     "is >= 55 % with fold consistency >= 5 or >= 40 % at >= 10 (a pair: >= 40 % at >= 5, "
     "then z >= 6; no exemption for a pair with a member that failed the test alone): a "
     "smooth channel fitted to the gyro's own slow wander is not named. Far above the floor "
     "the lowest bins of a red residual's spectrum are raised to the power law of the band "
     "above (not for a warm-up, nor for a coefficient at HAC |z| >= 3.5)."),
    ("Hysteresis and joint tests",
     "A hysteresis branch also needs fold consistency >= 4 (>= 10 with p x trials < 0.01 off "
     "the strict test, or >= 100 with p x trials < 0.05) and is paired only with the level "
     "or square of its own temperature, hyst(c) with T(c) or T2(c), each coefficient at HAC "
     "z >= 4 in the pair's fit (a warm-up, one transient with about one degree of freedom, "
     "at spectral z >= 8 instead; a hysteresis at spectral z >= 8 when the pair's fold "
     "consistency is >= 100); the same joint test (and a gain >= 40 % at fold consistency >= "
     "5) admits a hysteresis or a term set aside by the spectral test beside another "
     "candidate (a warm-up hidden by a missing hysteresis). A pair tested jointly that fails "
     "the joint test still qualifies on decisive evidence (gain >= 55 % at fold consistency "
     ">= 10, or >= 70 % at >= 5, and spectral z >= 8) against the model and against its "
     "better member alone: a tilt table of few positions leaves a member few effective "
     "degrees of freedom."),
    ("Ties and lags",
     "Candidates within 2 % of the best held-out RMS are ranked by class (a library term, "
     "then a second-order form, then a generic channel term, then a ramp, warm-up, sinusoid "
     "or hysteresis), then by the channels they bring into the model (fewest first: the "
     "sensors the model already uses explain more simply), then by form (x before x², a lag "
     "before a rate). At >= 2x the floor, tied candidates (within 2 %, or a gain over them with fold "
     "consistency < 2.13) are told apart by the step after them (each fitted with the pair "
     "pool, second-order forms and channel cross terms), and a lag (Tlag, chanlag) gives way "
     "to its plain form when that does >= 10 % better beside a missing rate term of another "
     "channel (and a level T, chan to its lag when the lag does >= 10 % better beside a rate "
     "term, its channel's own included: a lagged node and its sensor's rate hide each "
     "other); a lag whose time constant reaches the record length is named only on the "
     "strict test (lagged that long, a channel is a slow trend that fits the gyro's own "
     "drift)."),
    ("Look-elsewhere tests",
     "A ramp, warm-up or hysteresis added as the missing effect (not in place of a model "
     "term) must also beat a look-elsewhere surrogate test: the best gain any candidate "
     "reaches on 39 phase-randomised surrogates of the residual (held out fold by fold as "
     "the diagnosis holds out the log) may reach its gain in at most 3 of them (surrogate p "
     "<= 0.1); otherwise the best other qualifying candidate whose own gain passes that test "
     "is named, or none. A channel term is set aside (left \"possible\") when those surrogates "
     "reach its gain and so do 39 circular shifts and reversals of the residual it leaves "
     "(the gyro's own excursions kept); a pair when the best pair of the step's eight best "
     "candidates reaches its gain on the surrogates (at 2-10x the floor). A channel term set "
     "aside with no other single to name may be one of two effects that hide each other (the "
     "missed one is in every surrogate): the step's best qualifying pair is named instead "
     "when it beats that pair test."),
    ("Products, and a model at the floor",
     "A product of two channels gives way to the level terms of its factors when those do >= "
     "10 % better together (no interaction without its main effects), and to the level of a "
     "factor when, over this log, it is that level to |r| >= 0.98 (the other factor nearly "
     "constant: a tilt table's vertical gravity component) and the level qualifies, leaving "
     "the model >= 2x the floor; the next step tests the product beside it. A model within "
     "1.1x the floor takes a new term only at a gain >= 20 %, or >= 10 % on the strict test "
     "with fold consistency >= 4."),
    ("Field terms in the gyro's axes",
     "When no new effect qualifies, the model's own field terms of an order are tried in the "
     "gyro's axes: the block over every moving field axis (Hvec for Hx/Hy/Hz, Hquad for "
     "Hsq/Hprod/Hmag2) replaces them when it cuts the held-out RMS by >= 8 % at fold "
     "consistency >= 2.5 and what it adds beyond them has |z| >= 1, or by >= 5 % when fold "
     "consistency and |z| are each >= 1 and (t + |z|)/sqrt(2) >= 2.5 (a gyro mounted a few "
     "degrees off the coils; a sequence that moves coils together in few blocks shows the "
     "cross-axis parts in few folds); the quadratic block is also chosen before a new "
     "second-order field term (Hsq, Hprod, Hmag2) when it holds out >= 10 % better than that "
     "term (the cross-axis parts of a large second-order effect would each qualify and take "
     "the steps one by one), unless that term with one more second-order field term holds "
     "out as well as the block; a chosen quadratic block gives way to two second-order field "
     "terms added beside the model that hold out as well (>= 10 % gain at fold consistency "
     ">= 2.13), named \"together with\" each other: two coefficients extrapolate to field "
     "settings the held-out folds did not see where the block's six do not; with all but one "
     "field axis in the model, that axis's term (Hx, Hy or Hz) is named instead."),
    ("Model terms that stood in for the effect",
     "When still none qualifies above 1.2x the floor, the three candidates with the largest "
     "in-sample gains (>= 20 %) are judged in place of each model term: a term of your model "
     "that stood in for the missing effect (collinear with it over the record) is named for "
     "replacement (\"replaces X\") when the swap qualifies, fits the record no worse, holds "
     "out better than the candidate beside the term at fold consistency >= 2.13, and the "
     "candidate's p x trials beside the term is < 0.01 (< 0.001 for a ramp, warm-up, "
     "sinusoid or hysteresis)."),
    ("Effects that hide one another",
     "When still none qualifies and the model is >= 2x the floor, three or more effects may "
     "hide one another (each alone and in pairs holds out worse than all together): the ten "
     "channel-driven candidates with the largest in-sample gains (no ramp, warm-up, sinusoid "
     "or hysteresis) are fitted together and eliminated backward (a member goes while "
     "leaving it out costs < 2 % held-out RMS, or while its HAC |z| in the group's fit is < "
     "4); at least three must remain, cut the held-out RMS by >= 50 % at fold consistency >= "
     "5, hold out at most half of the best member alone and stand out of the residual's "
     "spectrum (z >= 8). The member best alone is named first, \"together with\" the others, "
     "which the next steps test."),
    ("A new effect beside the field in the gyro's axes",
     "When still none qualifies and the model is >= 1.2x the floor, each field block (Hvec, "
     "Hquad) in place of the model's field terms of its order is fitted with each candidate "
     "of the pair pool: a gyro off the coils hides a second effect behind the cross-axis "
     "parts of its field sensitivity, and the block alone behind that effect. The pair must "
     "cut the held-out RMS by >= 10 % at fold consistency >= 2.13, to <= 0.9x either member "
     "alone; the candidate's HAC |z| in the pair's fit must reach 4 and its spectral z 8, "
     "what the block adds beyond the replaced terms |z| 1, and the pair's gain must beat the "
     "best pair of the step's candidates on the phase surrogates (p <= 0.1). The candidate "
     "is named \"together with\" the block (a physical effect before a ramp, warm-up, "
     "sinusoid or hysteresis within 2 %); the next step names the block."),
    ("Removal, the floor and the verdict",
     "When no missing effect is found, each term of the model is left out once: one whose "
     "removal lowers the held-out RMS by >= 5 % (fold consistency >= 1) is named for removal "
     "(\"the model does better without X: remove it\"). The noise floor is fixed before any "
     "model is fitted: from the log's short-tau noise (differences across steps of a logged "
     "channel left out), or from --reference. The verdict names the effect, how to add it "
     "(--terms or the equivalent --term), the explanations this log cannot tell apart, and "
     "the forward path (--path) to the floor."),
)


def rules_text(width: int = 88) -> str:
    """The rules as plain text: each heading on its own line, its text wrapped to ``width``."""
    parts = []
    for head, text in RULES:
        parts.append(head + "\n" + textwrap.fill(text, width, initial_indent="  ",
                                                  subsequent_indent="  ",
                                                  break_on_hyphens=False))
    return "\n\n".join(parts)


#: the one-line form the diagnosis prints under its verdict
SUMMARY = ("missing effect = held-out RMS down by >= {min_pct:g} % (fold consistency >= 1) with "
           "HAC p x trials x candidates < {alpha:g}, or a clear gain off that test that also "
           "passes the spectral and look-elsewhere tests (a fit to the gyro's own wander is not "
           "named); every rule with its thresholds: gyrotest model diagnose --rules")


__all__ = ["RULES", "SUMMARY", "rules_text"]
