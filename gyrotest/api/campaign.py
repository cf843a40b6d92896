"""Whole campaigns and simulated logs: :func:`report`, :func:`simulate` (re-exported at the
top level)."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

from ..core.errors import OptionError
from .results import Report, Simulation

__all__ = ["report", "simulate"]


def report(campaign, *, variant: str = "customer", figures: bool = True,
           progress: Callable[[str], None] | None = None) -> Report:
    """The IEEE-952-style specification sheet of a test campaign (``gyrotest report``).

    Runs every test of the campaign through the same analyses as the individual functions
    (:func:`gyrotest.bias`, :func:`gyrotest.allan`, :func:`gyrotest.scale_factor`,
    :func:`gyrotest.thermal_fit`, :func:`gyrotest.mag_fit`, model fit) and lays out, in IEEE
    Std 952-1997 order (§5.3, §8.3), the model equation with the fitted coefficients, scale
    factor, bias and random drift, environmental sensitivities, IA alignment, test
    conditions with every file's SHA-256, and compliance with the campaign's limits under
    the stated decision rule (guarded acceptance, ILAC-G8:09/2019, with expanded
    uncertainties U = kσ, k = 2, JCGM 100:2008): PASS / CONDITIONAL PASS / CONDITIONAL FAIL
    / FAIL. A test the campaign does not list reads "not tested".

    Parameters
    ----------
    campaign : str or os.PathLike
        A campaign TOML file (format: the manual's "Campaign file" page, or ``gyrotest
        report --template``). It is checked completely before any analysis.
    variant : {"customer", "engineering"}
        customer: results with expanded uncertainties, limits, decision rule, conditions,
        equipment, references and sign-off; engineering: adds the diagnostics, algorithm
        notes, model history, commands and warnings.
    figures : bool, default True
        Draw the figures (needed for HTML/PDF with figures; False is faster).
    progress : callable, optional
        Called with the name of each analysis as it starts.

    Returns
    -------
    Report
        ``to_dict()`` is the ``gyrotest report --json`` document; ``to_frame()`` the
        compliance checks (value, σ, limit, U, verdict); ``to_markdown()``, ``to_html()``,
        ``to_pdf(path)``; ``overall()`` the overall verdict.

    Raises
    ------
    gyrotest.InputError
        A bad key, path, profile or option in the campaign (before any analysis), or an
        analysis the data cannot support.

    Examples
    --------
    >>> import gyrotest
    >>> rep = gyrotest.report("sample_data/campaign.toml", figures=False)  # doctest: +SKIP
    >>> rep.to_frame()[["item", "verdict"]].head(3)                        # doctest: +SKIP
    """
    if variant not in ("customer", "engineering"):
        raise OptionError(f"variant: {variant!r}", fix="use customer or engineering")
    from ..specsheet.build import make_report
    from ..specsheet.campaign import Campaign, load_campaign

    if isinstance(campaign, Campaign):
        camp = campaign
    elif isinstance(campaign, (str, os.PathLike)):
        camp = load_campaign(Path(campaign))
    else:
        raise OptionError(f"campaign: expected a campaign TOML path, got "
                          f"{type(campaign).__name__}")
    return Report(make_report(camp, figures=figures, progress=progress, variant=variant))


def simulate(scenario, *, seed: int | None = None) -> Simulation:
    """Simulate a bench log with known truth (``gyrotest simulate``).

    The IEEE Std 952-1997 §8.3 model equation

    .. math::

        S_0 \\frac{dN}{dt} = \\mathrm{LockIn}(I + E + D)\\,(1 + 10^{-6}\\varepsilon_K)^{-1},

    with the input I (rate table and earth rate along the IA), the environmental terms E
    (temperature, its rate and gradient with lagging sensors, the Antonova–Matveev model,
    magnetic, supply and warm-up effects), the drift D (bias and the IEEE noise terms N, B,
    K, R, Q, Markov, sinusoids, blue noise, each generated with an exact discretisation, so
    the Allan deviation of a simulated record matches the closed forms) and the
    scale-factor error ε_K. Outputs: rate in any unit, pulse counts, up/down pairs, a
    rolling counter, or an analog voltage through an ADC.

    Parameters
    ----------
    scenario : str, os.PathLike or dict
        A scenario TOML file (``sample_data/scenarios/README.md``), or a dict of the same
        shape. Durations are seconds or text such as ``"2h"``.
    seed : int, optional
        Random seed (default the scenario's ``[scenario] seed``, else fresh entropy); the
        seed used is in the truth.

    Returns
    -------
    Simulation
        ``truth`` (every true parameter in reporting units), ``runs``, ``columns``;
        ``to_frame()`` the samples as the log file holds them; ``write(path)`` writes the
        log with its ``.truth.json`` and ``.profile.toml``; ``to_dict()`` the ``gyrotest
        simulate --json`` document. Every analysis function takes it as its log.

    Raises
    ------
    gyrotest.InputError
        An unknown key or a bad value in the scenario.

    Examples
    --------
    >>> import gyrotest
    >>> sim = gyrotest.simulate({"record": {"sample_rate_hz": 10, "duration_s": 600},
    ...                          "gyro": {"bias_dph": 0.5, "noise": {"N": 0.01}}}, seed=1)
    >>> sim.truth["bias"]["D_F_dph"], sim.to_frame().shape
    (0.5, (6000, 2))
    """
    from ..simulation import simulate as engine

    return Simulation(engine(scenario, seed=seed))
