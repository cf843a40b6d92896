"""The decision constants of the workbench diagnosis and its rules in words.

Every constant the verdict depends on lives here, with its statistical meaning;
:mod:`gyrotest.envmodel.selection`, :mod:`gyrotest.envmodel.likelihood` and
:mod:`gyrotest.envmodel.modelfit` import them, and the rules text that ``gyrotest model diagnose
--rules`` prints and the man page lists is generated from them. A plain module outside
:mod:`gyrotest.envmodel`, so that printing the rules loads neither numpy nor scipy.
"""

from __future__ import annotations

import textwrap

#: family-wise probability of a false "missing effect" in one diagnosis step (``--alpha``)
ALPHA = 0.01
#: models within this ΔBIC are not distinguishable by the data (Kass & Raftery 1995: a Bayes
#: factor below e ≈ 2.7 is "not worth more than a bare mention"); also the margin by which
#: the BIC must favour dropping a term before the verdict names it for removal
BIC_TIE = 2.0
#: a design column with R² ≥ 1 − 1/VIF_MAX on the others is degenerate: less than 10⁻⁸ of its
#: variance is its own, so its coefficient is fixed by rounding and the smoother's edges, not
#: by the data (never proposed; ``model fit`` refuses it)
VIF_MAX = 1e8
#: draws of the min-P parametric bootstrap that gives family-wise p-values (Monte Carlo
#: standard error 0.003 at p = 0.01)
MC_DRAWS = 1000
#: lags of the Ljung–Box whiteness test of the whitened residual ("nothing missing")
WHITE_LAGS = 20
#: search budget: points of the log-spaced grid on which a time constant or a hysteresis
#: width is profiled before refinement
TAU_POINTS = 16
#: computing budget: at most this many likelihood samples (Cholesky factors cost O(n³))
NL_MAX = 400
#: draws of each noisy channel's measurement noise simulated for the errors-in-variables
#: noise term and the attenuation correction (a computing budget)
EIV_DRAWS = 32
#: a term whose whitened regressor is more noise than signal (reliability ratio
#: var(signal)/var(signal + noise) below this) is not corrected for attenuation — the
#: correction would divide by a small difference — and is named as sensor-limited
MIN_RELIABILITY = 0.5

#: (heading, text) of each rule, in the order the diagnosis applies them
RULES: tuple[tuple[str, str], ...] = (
    ("Statistical model",
     "The block-mean gyro rate is the model's terms plus the gyro's own noise: white, flicker "
     "and rate random-walk noise (IEEE 952 N, B, K), and a first-order Gauss–Markov rate "
     "when it lowers Akaike's criterion (its share and correlation time T_c searched), seen "
     "through the workbench's smoother and block averaging. Its shape parameters and its "
     "level are fitted by maximum "
     "likelihood on the same log (exact Gaussian likelihood of the first differences of "
     f"at most {NL_MAX} samples, Cholesky factor of their Toeplitz covariance), or fixed from "
     "a static reference run (--reference). Coefficients are generalised least squares under "
     "that noise model, with its standard errors."),
    ("One test per candidate",
     "Each candidate term is added to the model and scored by the likelihood ratio "
     "Λ = 2(ℓ1 − ℓ0) (noise shape of the model, noise level re-estimated), chi-square with "
     "the candidate's number of coefficients when nothing is missing. A time constant, "
     f"frequency or hysteresis width is profiled on a grid ({TAU_POINTS} log-spaced points "
     "for a time constant or width, the Fourier frequencies for a sinusoid) and refined."),
    ("One criterion",
     f"A candidate is a missing effect when its family-wise p-value is at most alpha "
     f"(default {ALPHA:g}, --alpha). The step's tests share alpha (Bonferroni): (a) the "
     f"min-P parametric bootstrap (Westfall & Young 1993) of Λ at the model's noise shape: "
     f"{MC_DRAWS} draws of the noise the model leaves, projected off the model; each draw's "
     "smallest local p over every candidate and every searched value; the fraction of draws "
     "at or below the candidate's own — this corrects for every candidate and every searched "
     "time constant, frequency and width at once; (b) Λ with the noise shape, and the "
     "model's own searched time constants, frequencies and widths, re-estimated under both "
     "models (Wilks; Davies' (1987) bound for the candidate's searched value; Bonferroni over "
     "the step's candidates) — a missing effect the model had absorbed in its random walk or "
     "in another term's time constant regains its weight there. Each test is at alpha/k for "
     "the k tests the step makes (2, or 1 without a shape grid); a candidate's family-wise "
     "p-value is k times the smaller of its (a) and (b). Moves of two terms at once are not "
     "made (on the campaign they named a true effect once in 17 steps)."),
    ("Indistinguishable candidates",
     f"Candidates within ΔBIC {BIC_TIE:g} of the best are not told apart by the data (Kass & "
     "Raftery 1995): the verdict names them together and the measurement that would separate "
     "them; among them a physical library term goes before a second-order term, a generic "
     "channel form and a nuisance term (ramp, warm-up, sinusoid, hysteresis), then the one "
     "bringing fewer new channels, then the simpler form."),
    ("Replace, not stack",
     "A block that contains a model term (the field sensitivity along every axis in place of "
     "per-axis terms, or of a custom form of one of them) replaces it. After the chosen term "
     f"is added, a model term of the same channel that the data no longer support beside it "
     f"(BIC of the model without it lower by more than {BIC_TIE:g}) is named as replaced."),
    ("The sensors' own noise",
     "Each logged temperature and extra channel's own noise is simulated "
     f"({EIV_DRAWS} draws) through every term that reads it: white noise of the σ its second "
     "differences give, or, for a channel quantised in steps of q, the rounding error "
     "Q(path + c + w) − c − path at a random offset c of the quantiser's grid (a sawtooth on "
     "a slow channel, white q²/12 on a fast one) along the node's path (the Whittaker "
     "smoother of the reading whose departures from it have the sensor's own error variance "
     "σ² + q²/12), the white noise w under the rounding matched to how often the reading "
     "toggles. It joins the "
     "noise model at the attenuation-corrected coefficients (the residual carries it times the "
     "true coefficient, not the attenuated one), and the coefficients are corrected for that "
     "attenuation (errors in variables, method of moments; a term with a reliability ratio "
     f"below {MIN_RELIABILITY:g} keeps its uncorrected value and is named as sensor-limited). "
     "A candidate reading a channel of the same kind is 'limited by the sensors', not a "
     "missing effect, when its likelihood ratio is within the one-sided 1 − alpha quantile of "
     "what a noise-free reading of the model's own sensors would give (uᵀΣ⁻¹u of the "
     "simulated realisations u of that noise: mean tr(Σ⁻¹E), spread from the draws). A "
     "candidate that passes both is tested once more on the model refitted to its sensors' "
     "reconstructed nodes (regression calibration: each noisy channel replaced by its "
     "Whittaker path; Carroll, Ruppert, Stefanski & Crainiceanu 2006): where a coefficient "
     "collapses under a noisy reading the effect stays in the residual and any smoother "
     "reading of the same node takes it, so a candidate that no longer passes at alpha there "
     "(the same Davies and Bonferroni corrections) is limited by the sensors too. The "
     "verdict names it as a better reading and how to use it."),
    ("Never degenerate",
     f"A candidate whose design column lies in the span of the model's (variance inflation "
     f"≥ {VIF_MAX:g}) is not proposed; 'model fit' refuses such a model in one line naming "
     "the collinear terms."),
    ("A warm-up",
     "A warm-up transient is a candidate only when the log starts at the gyro's power-on "
     "(--power-on, or [gyro] power_on_at_start in the profile): otherwise a decaying "
     "exponential only absorbs the gyro's own slow noise."),
    ("Nothing missing",
     f"When no candidate passes, the whitened residual is tested for whiteness (Ljung–Box "
     f"over {WHITE_LAGS} lags at alpha): consistent, the verdict is 'no missing effect' with "
     "the residual's N, B, K; not consistent, an effect outside the library or noise the model "
     f"lacks. A model term whose removal lowers the BIC by more than {BIC_TIE:g} is named for "
     "removal."),
)

#: the one-line summary printed under every verdict
SUMMARY = ("a candidate is a missing effect when its likelihood-ratio test under the gyro's "
           "fitted noise model passes at the family-wise alpha = {alpha:g} (min-P parametric "
           "bootstrap over every candidate and searched value); candidates within ΔBIC "
           f"{BIC_TIE:g} are indistinguishable; 'model diagnose --rules' prints every rule")


def rules_text(width: int = 88) -> str:
    """Every rule, wrapped to ``width`` columns (``model diagnose --rules``)."""
    out = ["Workbench verdict rules (gyrotest model diagnose), in the order they apply:", ""]
    for i, (head, text) in enumerate(RULES, 1):
        out.append(f"{i}. {head}")
        out += textwrap.wrap(text, width=width, initial_indent="   ",
                             subsequent_indent="   ")
        out.append("")
    return "\n".join(out).rstrip() + "\n"


__all__ = ["ALPHA", "BIC_TIE", "EIV_DRAWS", "MC_DRAWS", "MIN_RELIABILITY", "NL_MAX",
           "RULES", "SUMMARY", "TAU_POINTS", "VIF_MAX", "WHITE_LAGS", "rules_text"]
