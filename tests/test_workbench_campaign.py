"""The fast subset of the randomized workbench campaign (``benchmarks/bench_workbench.py
--quick``): 20 short cases from the independent simulator ``benchmarks/workbench_sim.py``
(every run kind, nulls, several effects at once, odd channel names, lagging sensors, fields
not fixed in the gyro frame, real noise when ``../shared`` is present) through the plain user
loop. The full campaign and its figures are in ``benchmarks/README.md``; these bounds only
catch a regression of the verdict rules.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"


def _bench():
    """The campaign runner and the independent simulator from ``benchmarks/``."""
    sys.path.insert(0, str(BENCH))
    try:
        import bench_workbench as bw
        import workbench_sim as ws
    finally:
        sys.path.remove(str(BENCH))
    return bw, ws


def _loop(seed: int) -> tuple[dict, list[str]]:
    """The campaign's plain user loop on case ``seed``: its row and the labels it added."""
    bw, ws = _bench()
    row = bw.run_case(ws.make_case(seed))
    return row, [a["label"] for a in row["added"]]


def _assert_real_null_quiet(seed: int) -> dict:
    """A null case on real ADIS16405 noise (skipped without ``../shared``): no alarm.
    Returns the campaign row."""
    bw, ws = _bench()
    if not ws.real_noise_available():
        pytest.skip("real ADIS16405 log not found (../shared beside the repo)")
    row = bw.run_case(ws.make_case(seed, null=True))
    assert row["noise"]["type"] == "real"
    assert not row["alarm"], row["added"]
    return row


def _diagnose_base(seed: int, extra: tuple[str, ...] = ()):
    """Seed ``seed`` of the simulator read through ingest and prepared, and the diagnosis of
    its base model (with the terms ``extra`` added, as the loop adds them): (case, work data,
    diagnosis)."""
    from gyrotest.envmodel import diagnose, prepare
    from gyrotest.envmodel.terms import parse_terms, resolve_terms
    from gyrotest.ingest import read_log

    _, ws = _bench()
    case = ws.make_case(seed)
    with tempfile.TemporaryDirectory() as td:
        log = read_log(ws.write_case(case, td), overrides=case.profile)
    wd = prepare(log)
    terms = list(case.base_terms) + list(extra)
    return case, wd, diagnose(wd, resolve_terms(parse_terms(terms), wd.frame))


@pytest.fixture(scope="module")
def quick():
    bw, _ = _bench()
    rows = bw.run_quick(jobs=1)
    return rows, bw.summarise(rows)["overall"]


def test_quick_campaign_runs_every_case(quick):
    rows, s = quick
    assert s["crashed"] == 0, [r.get("error") for r in rows if r.get("status") == "crash"]
    assert s["completed"] >= 15


def test_quick_campaign_verdicts(quick):
    _, s = quick
    # strong effects are found, nulls stay quiet, the loop ends near the true model
    assert s["recall_strong"]["frac"] >= 0.45, s["recall_strong"]
    assert s["false_alarms_spurious"]["k"] == 0, s["false_alarms_spurious"]
    assert s["final_ok"]["frac"] >= 0.6, s["final_ok"]
    assert s["floor_ok"]["frac"] >= 0.7, s["floor_ok"]


def test_stored_rows_are_pooled_by_summarise(tmp_path, capsys):
    """``--summarise`` re-reads the rows of earlier ``--json`` runs and pools them: two copies
    of a small run count every case twice, with the same fractions, and the spurious alarms
    are split by noise type."""
    import json

    bw, _ = _bench()
    start = bw.QUICK_SEEDS.start
    rows = (bw.run_campaign([start, start + 1], kinds=["helmholtz"], max_hours=1.0)
            + bw.run_campaign([start + 2], kinds=["helmholtz"], max_hours=1.0, nulls=True))
    rows = json.loads(json.dumps(rows, default=bw._json_default))
    s = bw.summarise(rows)["overall"]
    paths = []
    for k in range(2):
        p = tmp_path / f"run{k}.json"
        p.write_text(json.dumps({"rows": rows}))
        paths.append(str(p))
    assert bw.main(["--summarise", *paths]) == 0
    out = capsys.readouterr().out
    assert "| 6 (6 / 0 / 0) |" in out
    assert f"({2 * s['recall']['k']}/{2 * s['recall']['n']})" in out
    assert "spurious, synthetic noise / real ADIS16405 noise" in out
    pooled = bw.summarise(rows + rows)["overall"]
    assert pooled["false_alarms_spurious"]["n"] == 2 * s["false_alarms_spurious"]["n"] >= 2
    assert (pooled["false_alarms_spurious_synthetic"]["n"]
            + pooled["false_alarms_spurious_real"]["n"]
            == pooled["false_alarms_spurious"]["n"])


@pytest.mark.parametrize("seed", [10588, 10655])
def test_real_gyro_wander_is_not_named_as_a_channel(seed):
    """Null cases on real ADIS16405 noise: its slow wander (≈ 6-20x the short-τ floor) had
    been fitted by a smooth logged channel (a humidity rate, a lagged humidity) and named as
    the missing effect via the far route; the spectral (Whittle) z of that coefficient is
    1-2, so the verdict stays quiet (seeds from the tuning set of the Whittle gate)."""
    _assert_real_null_quiet(seed)


@pytest.mark.parametrize("seed, follow_up", [(15000, "dTdt(Tcase)"),
                                             (15082, "Hz(field_z)")])
def test_follow_up_effect_near_the_floor_is_added(seed, follow_up):
    """Near the floor the spectral gate's bar is z >= 4: with the bar at 8 the loop stopped
    1.2-1.7x above the floor and left a smaller true effect out (a temperature rate whose
    spectral z was 5.8; the z part of a field term misaligned with the coil axes, 5.5),
    ending 1.15-1.3x the true model's held-out RMS (seeds of the unseen set 15000-15199 of
    the gate's first report, then used to tune this bar)."""
    bw, ws = _bench()
    row = bw.run_case(ws.make_case(seed))
    labels = [a["label"] for a in row["added"]]
    assert follow_up in labels, labels
    assert row["final_over_true"] <= 1.1, (labels, row["final_over_true"])


@pytest.mark.parametrize("seed", [16635, 16648, 16661])
def test_real_gyro_wander_is_not_named_as_hysteresis(seed):
    """Null cases on real ADIS16405 noise where a heating/cooling branch state (a near-step
    regressor with a searched width) had been fitted to the gyro's wander and named as the
    missing effect: gain/(scatter/√folds) 3.2-6.4, against 10-1000 for true hysteresis. The
    branch now needs ≥ 4 on the strict route and ≥ 10 (with p × trials < 0.01) on the weak
    ones (seeds from the tuning set 16500-16699 of that rule)."""
    _assert_real_null_quiet(seed)


def test_true_hysteresis_near_threshold_is_still_named():
    """Thermal hysteresis at 3.2x the floor (synthetic noise) keeps its strict-route verdict
    under the hysteresis rule above (gain/(scatter/√folds) ≈ 115)."""
    bw, ws = _bench()
    row = bw.run_case(ws.make_case(16188))
    assert [a["label"] for a in row["added"]] == ["hyst(T_gyro)"], row["added"]
    assert row["final_over_true"] <= 1.1


def test_three_large_effects_at_once_are_all_found():
    """A tilt run missing a warm-up (100x the floor), a temperature term (21x) and an
    anisoelastic product (30x) at once: the warm-up cut the held-out RMS by 68 %, consistently
    across the folds, but the other two inflated its HAC error (z = 0.7 < 1) and the verdict
    stayed "possible". Far above the floor its spectral z (10.4 >= 8) now stands in for the
    HAC guard, and the loop adds all three (seed of the unseen set 21000-21199, then used to
    tune the rule)."""
    row, labels = _loop(21125)
    assert labels[0] == "warmup", labels
    assert {"gprod(ax_g,ay_g)", "T(tc1)"} <= set(labels), labels
    assert row["final_over_true"] <= 1.1, (labels, row["final_over_true"])


def test_hac_backed_term_wins_over_a_spectral_only_one():
    """A term that qualifies only by its spectral z (HAC z 0.2) comes after the terms with a
    HAC test behind them: the temperature term of temp_case is named, not the lagged-node
    rate that held out 3 % better and left the loop 1.27x the true model (seed 21091)."""
    row, labels = _loop(21091)
    assert "dTlagdt(temp_case)" not in labels, labels
    # the first step names the tilt level, not its product with the decoy humidity (the
    # product is that level to r 0.99: rules.PRODUCT_LEVEL_R); beside the level the
    # temperature effect comes out as hyst(temp_case) with a half-width (1.9 degC) wider
    # than the whole excursion (1.3 degC) -- a branch that never switches, i.e. T(temp_case)
    # with an offset per record segment, 3 % better held out. Either names the effect on
    # the true sensor; telling them apart is left for a later pass
    assert labels[0] == "chan(incl_x)", labels
    assert {"T(temp_case)", "hyst(temp_case)"} & set(labels), labels
    assert row["final_over_true"] <= 1.1, (labels, row["final_over_true"])


def test_real_wander_fit_without_hac_support_stays_quiet():
    """Real ADIS16405 noise with a lagged-node rate fitted to its wander: 80 % held-out gain,
    consistent across the folds (7.3), HAC z 0.3 and spectral z 5.9 -- below the bar of 8 that
    replaces the HAC guard, so no alarm (null seed 20561 of an earlier unseen set)."""
    _assert_real_null_quiet(20561)


def test_hysteresis_and_its_temperature_level_are_found_as_a_pair():
    """Hysteresis (4x the floor) and the linear sensitivity of the same thermocouple (3x),
    both missing: each alone fits the other's part (hyst -19 % held-out at HAC z 0.5, T
    alone worse than nothing); together -59 % at z 9.2 and 8.0. The first step names the
    hysteresis together with T(Tcase) and the loop ends at the true model (seed 22154: it
    said "possible missing effect" and stopped at 2.4x)."""
    row, labels = _loop(22154)
    assert labels[:2] == ["hyst(Tcase)", "T(Tcase)"], labels
    assert row["final_over_true"] <= 1.1, (labels, row["final_over_true"])


def test_a_term_the_model_does_better_without_is_removed():
    """A Helmholtz run whose starting model carries a field component the gyro does not
    have: once the missing square term is added, the model without Hz(mag_B3) holds out
    better, the diagnosis says to remove it and the loop ends at the true model (seed 23025:
    1.18x the true model without the removal)."""
    bw, ws = _bench()
    row = bw.run_case(ws.make_case(23025))
    removed = [s["removed"]["term"] for s in row["steps"] if s.get("removed")]
    assert removed == ["Hz(mag_B3)"], removed
    assert "Hz(mag_B3)" not in row["final_terms"], row["final_terms"]
    assert row["final_over_true"] <= 1.1, row["final_over_true"]


def test_a_hysteresis_as_wide_as_the_excursions_is_named_as_the_level():
    """A ramp and T(T_gyro), both missing, hide each other (T alone worse than nothing). The
    ramp with hyst(T_gyro) or with T(T_gyro) reach the floor alike (0.0218 deg/h): the pair
    is named with the plain level, ramp first, and the loop ends at the true model (seed
    22078: a warm-up was named first, and in a first version of the hidden pairs the
    hysteresis)."""
    row, labels = _loop(22078)
    assert labels == ["ramp", "T(T_gyro)"], labels
    assert row["final_over_true"] <= 1.1, row["final_over_true"]


def test_a_term_hidden_by_another_effect_is_found_as_a_pair():
    """A warm-up (9x the floor) beside a missing heating/cooling hysteresis (6x): alone the
    warm-up cuts the held-out RMS by 44 % but its coefficient does not stand out of the
    residual's slow noise (the hysteresis), and the hysteresis alone gains 15 % at HAC z 2.3;
    together they reach the floor. The first step names the warm-up together with the
    hysteresis (seed 23147: "possible missing effect: sin" and 10x the true model before)."""
    row, labels = _loop(23147)
    assert labels[:2] == ["warmup", "hyst(tc1)"], labels
    assert "which hyst(tc1) dominates" in row["steps"][0]["verdict"]
    assert row["final_over_true"] <= 1.1, (labels, row["final_over_true"])


def test_tied_candidates_are_told_apart_by_the_next_step():
    """An ageing ramp and the lag of a drifting pressure channel (a decoy) cut the held-out
    RMS equally (-41 %); only beside the ramp does the missing g cross term come out (seed
    23141: the decoy's lag was named and the loop stopped at 4.7x the true model). Until the
    fourteenth pass the lookahead named the ramp, then the product. Since a single term needs
    ≥ 55 % (or ≥ 40 % at fold consistency ≥ 10) to skip the spectral test, neither tied
    candidate (41 % at 5.8-6.8, spectral z 6.6-7.5) qualifies at the first step. Since the
    eighteenth pass a candidate the spectral test rejected alone may join a pair (which must
    then pass that test itself), and a trend may lead the partner pairs: the ramp and the
    product are found together (-87 %, pair spectral z 45), the ramp named first, then the
    product; the decoy is never named and the loop ends at the true model."""
    row, labels = _loop(23141)
    assert "ramp" in labels and "chanprod(incl_x,incl_y)" in labels, labels
    assert not any(lab.startswith("chanlag(P_lab") for lab in labels), labels
    assert row["final_over_true"] <= 1.1, (labels, row["final_over_true"])


def test_a_lag_that_stood_in_for_a_rate_term_gives_way_to_the_plain_temperature():
    """T(tc2) and the rate of a lagged node of another sensor, both missing: alone the lag
    Tlag(tc2) wins (-66 % against -39 %), its time constant absorbing part of the rate term;
    beside that rate term the plain T(tc2) reaches 0.168 deg/h and the lag 0.225. The first
    step names T(tc2) (seed 23183: Tlag(tc2) before, the true T never named). Since the
    eighteenth pass the pair search finds T(tc2) with the rate term directly (a candidate
    the spectral test rejected alone may join a pair), and the verdict says what the lag
    alone would leave."""
    row, labels = _loop(23183)
    assert labels[0] == "T(tc2)", labels
    verdict = row["steps"][0]["verdict"]
    assert ("stood in for a missing rate term" in verdict
            or ("Tlag(tc2) alone would leave" in verdict and "dTlagdt(tc0)" in verdict)), verdict
    assert row["final_over_true"] <= 1.1, (labels, row["final_over_true"])


def test_a_warm_started_time_constant_trap_is_left():
    """A warm-up fitted without the missing lagged coil takes τ 268 s; with the coil's lag
    added beside it, one-parameter moves stay in the trap (held-out 0.42 deg/h, fold
    consistency 1.7: "no missing effect"). The rescan from scratch finds τ 1035 s and
    1972 s (true 1309 s, 2029 s) and the lag is named (seed 24077: 10.5x the true model
    before)."""
    row, labels = _loop(24077)
    assert labels[0] == "Tlag(tc1)", labels
    assert row["final_over_true"] <= 1.1, (labels, row["final_over_true"])


def test_a_product_gives_way_to_the_levels_of_its_factors():
    """A humidity level and a vibration level, both missing: their product alone cuts the
    held-out RMS by 96 % (0.119 deg/h), the two levels together reach 0.039 deg/h (the
    floor). No interaction without its main effects: the levels are named (seed 24177: the
    product was added and the loop stopped at 3.0x the true model)."""
    row, labels = _loop(24177)
    assert sorted(labels) == ["chan(RH_lab)", "chan(pump_vib)"], labels
    # over this log the product is the vibration level to r 0.998 (rules.PRODUCT_LEVEL_R),
    # which decides before the fit of the two levels together (pairs.marginal)
    verdict = row["steps"][0]["verdict"]
    assert ("a product without its main effects" in verdict
            or "the product is the level" in verdict), verdict
    assert row["final_over_true"] <= 1.1, (labels, row["final_over_true"])


def test_a_ramp_that_gains_nothing_alone_is_paired():
    """An ageing ramp beside a missing lagged coil gains nothing alone, not even in sample;
    the coil's lag alone takes a poor τ. Paired with the pool (jointly tested) the two reach
    1.2x the floor (seed 24170: a warm-up and T(T_air) were added, 1.5x the true model)."""
    row, labels = _loop(24170)
    assert labels[:2] == ["Tlag(T_air)", "ramp"], labels
    assert row["final_over_true"] <= 1.1, (labels, row["final_over_true"])



def test_a_rotated_gyros_field_term_is_refitted_in_its_own_axes():
    """A gyro 2.2° off the coils, sensitive along its own y axis: Hy is named first, and what
    its cross-axis parts leave (1.1x the true model) is below what a new effect must show
    near the floor. The block over every field axis replaces Hy (seed 25199)."""
    bw, ws = _bench()
    row = bw.run_case(ws.make_case(25199))
    added = row["added"]
    assert [a["label"] for a in added] == ["Hy(mag_B2)", "Hvec(mag_B1,mag_B2,mag_B3)"], added
    assert added[1]["replaces"] == "Hy(mag_B2)"
    assert row["final_over_true"] <= 1.1, row["final_over_true"]


def test_a_strict_consistent_gain_passes_a_floor_estimate_that_is_too_high():
    """After the warm-up the model is at 1.08x the short-τ floor, but the floor estimate is
    8 % above the true model's residual: a rotated field term cuts the held-out RMS by 16 %
    (z 4.9, fold consistency 4.2), which a model at its true floor cannot give (seed
    25002: left out before, 1.17x the true model)."""
    row, labels = _loop(25002)
    assert labels == ["warmup", "Hx(Bx)"], labels
    assert row["final_over_true"] <= 1.1, row["final_over_true"]


def test_a_slow_true_effect_the_hac_test_sees_is_not_judged_against_the_red_floor():
    """A gyro-temperature lag on real-noise wander, 2.1x the floor (seed 33105): Tlag(T_gyro)
    -54 % held-out at HAC z 4.1. With the red-residual floor its spectral z fell to 1.7 and
    nothing was added (2.2x the true model); a coefficient the HAC test already sees at
    |z| >= 3.5 is judged without the floor."""
    row, labels = _loop(33105)
    assert labels == ["Tlag(T_gyro)"], labels
    assert row["final_over_true"] <= 1.1, row["final_over_true"]


def test_a_short_warm_up_seen_by_one_fold_is_named_far_above_the_floor():
    """A 560 s warm-up beside two channel effects, the model 25x the floor: the warm-up cuts
    the held-out RMS by 55 %, but it lives in the first chunks, so its fold consistency (2.9)
    stays under the bar of a flexible term; its coefficient stands out of the residual's slow
    noise (spectral z 14). Before, nothing was added and the loop ended 23x the true model
    (seed 26125)."""
    row, labels = _loop(26125)
    assert labels[:2] == ["warmup", "chan(rh)"], labels
    assert all(t["named"] for t in row["truth"] if t["missing"]), row["truth"]
    assert row["final_over_true"] <= 1.1, row["final_over_true"]


@pytest.mark.parametrize("seed", [26568, 26622])
def test_real_wander_fit_below_the_single_term_exemption_stays_quiet(seed):
    """Null cases on real ADIS16405 noise, 7-19x the short-τ floor: a warm-up (26568, -42 %
    held-out at fold consistency 5.1) and T² of a chamber sensor (26622, -43 % at 8.6), both at
    spectral z < 6, had passed the spectral gate through its exemption (≥ 40 % at ≥ 5); a
    single term now needs ≥ 55 % (or ≥ 40 % at ≥ 10) to skip it."""
    _assert_real_null_quiet(seed)


def test_two_effects_whose_single_z_the_other_inflates_are_named_as_a_pair():
    """A humidity channel (212x the floor) and the rate of a 1677 s lagged node (207x) hide
    each other: alone each cuts the held-out RMS by 8-16 % at HAC z 0.1-0.6; together they
    reach the floor, each coefficient at HAC z ≥ 4 in the pair's own fit. Before, the pair
    was dropped on its members' single z and the loop ended 132x the true model (seed
    27086)."""
    row, labels = _loop(27086)
    assert labels[:2] == ["chan(RH_pct)", "dTlagdt(T_case_C)"], labels
    assert all(t["named"] for t in row["truth"] if t["missing"]), row["truth"]
    assert row["final_over_true"] <= 1.1, row["final_over_true"]


def test_two_forms_of_one_sensor_that_hide_each_other_are_found_as_a_block():
    """The rate of a lagged node of T_gyro and T² of the same sensor: alone the rate gains
    -10 % held-out and T² -97 % (neither enters the pair pool); the four forms of T_gyro
    fitted as one block reach the floor, and the pair of two of them passes the joint HAC
    test. Before, nothing was added and the loop ended 24x the true model (seed 27119)."""
    row, labels = _loop(27119)
    assert labels[0] == "dTlagdt(T_gyro)", labels
    assert "T2(T_gyro)" in labels, labels
    assert row["final_over_true"] <= 1.1, row["final_over_true"]


def test_an_effect_that_hurts_alone_is_found_as_the_partner_of_the_best_candidate():
    """A sensor lagging its node by 313 s (a term in the case temperature's rate) beside a
    warm-up: dT/dt alone makes the held-out prediction worse (it enters no pair pool), the
    warm-up alone gains -27 % at HAC z 0.3; the warm-up with dT/dt as its partner gains
    -92 % at z 8 and 9. Before, the loop took a spurious ramp first and ended 13x the true
    model (seed 28086)."""
    row, labels = _loop(28086)
    assert labels[0] == "warmup", labels
    assert "ramp" not in labels, labels
    assert row["final_over_true"] <= 1.1, row["final_over_true"]


@pytest.mark.parametrize("seed", [30582, 30690, 30697])
def test_real_wander_fitted_by_a_pair_or_a_slow_channel_stays_quiet(seed):
    """Null cases on real ADIS16405 noise, 3-8x the short-τ floor. 30582 and 30690: two terms
    fitted together to the wander (a sinusoid with the lag of a humidity channel; a humidity
    lag with a humidity x vibration product) gained 43 % held-out at fold consistency 6-13,
    which exempted them from the spectral test; their spectral z is 2.0-3.7, and a pair on
    that route now needs 6. 30697: the case temperature fitted to the wander, -46 % at
    spectral z 10.6 against the residual's own spectrum; with the low-frequency floor of a red
    residual (:func:`gyrotest.envmodel.stats.red_floor`) 3.2."""
    _assert_real_null_quiet(seed)


def test_real_wander_fitted_by_a_ramp_and_a_channel_the_spectral_test_rejected_stays_quiet():
    """Null case on real ADIS16405 noise, 3.1x the short-τ floor (seed 31680). A ramp and the
    lag of a pump-vibration channel, each rejected alone by the spectral test (z 6.2, 5.6),
    fitted together to the wander: -58 % held-out at fold consistency above 5, pair spectral
    z 6.2. Such members may join a pair (a second missing effect lowers a true term's z), but
    the pair must then pass the spectral test itself (8), not the exempt-gain bar (6)."""
    _assert_real_null_quiet(31680)


def _fit_case(seed: int, terms, *, null: bool = False):
    """Prepare a campaign case's log and fit ``terms`` (default: the case's base model);
    returns (held-out RMS of that fit, held-out RMS of the true model), deg/h."""
    import tempfile

    from gyrotest.envmodel import fit_model, prepare
    from gyrotest.ingest import read_log

    _, ws = _bench()
    case = ws.make_case(seed, null=null)
    with tempfile.TemporaryDirectory() as td:
        log = read_log(ws.write_case(case, td), overrides=case.profile)
    wd = prepare(log)
    terms = case.base_terms if terms is None else terms(case)
    return fit_model(wd, terms).rms_holdout, fit_model(wd, case.true_terms).rms_holdout


def test_a_free_sinusoid_is_not_refitted_on_a_harmonic_in_the_held_out_folds():
    """The base model of null seed 34064 holds a free-frequency sinusoid (an HVAC cycle of
    3662 s in a 2.1 h run). Searched afresh on each training mask, the highest periodogram
    peak was a harmonic in three of five folds (training RSS 17-70 against 0.03-0.05 at the
    true frequency), and the model's held-out RMS came out 82x the true model's. The search
    now refines the strongest peaks and keeps the best fit."""
    hold, true = _fit_case(34064, None, null=True)
    assert hold <= 1.1 * true, (hold, true)


def test_two_time_constants_in_a_curved_valley_are_fitted_jointly():
    """A warm-up beside the lag of the case temperature, with the supply term added (seed
    34102): one-parameter moves stopped at τ 778 s and 648 s (held-out 0.38 deg/h, 3.6x the
    true model, and hysteresis then looked like the next missing effect). The joint search
    over both time constants reaches the true model's held-out RMS."""
    hold, true = _fit_case(34102, lambda case: case.base_terms + ["V"])
    assert hold <= 1.1 * true, (hold, true)


def test_a_huge_warm_up_hidden_by_a_missing_temperature_term_is_found_as_a_pair():
    """A −316 deg/h warm-up (τ 384 s) and a 44 deg/h/degC temperature term, both missing
    beside a field model (seed 35075): each alone gains little, the pair reaches the true
    model, but the warm-up's HAC z in the pair's fit is 2.7 at HAC t 83 (one transient has
    about one effective degree of freedom). A warm-up member passes the pair's joint test on
    its spectral z, as single warm-ups do (before: "no missing effect", 31x the true model)."""
    bw, ws = _bench()
    if not ws.real_noise_available():
        pytest.skip("real ADIS16405 log not found (../shared beside the repo)")
    row = bw.run_case(ws.make_case(35075))
    labels = [a["label"] for a in row["added"]]
    assert sorted(labels) == ["T(T_case_C)", "warmup"], labels
    assert row["final_over_true"] <= 1.1, (labels, row["final_over_true"])


def test_a_hysteresis_far_above_the_floor_with_few_cycles_is_named():
    """A chamber run's hysteresis of 99x the floor (seed 35027): −95 % held-out at fold
    consistency 745, but few heating/cooling cycles leave its HAC p x trials at 0.011, just
    above the weak routes' guard (0.01), and the verdict said "possible" (14.6x the true
    model). At consistency >= 100 the guard is 0.05. (One step: the next ones, far above
    the floor with a hysteresis in the model, cost a minute of pair fits.)"""
    bw, ws = _bench()
    row = bw.run_case(ws.make_case(35027), max_steps=1)
    labels = [a["label"] for a in row["added"]]
    assert labels[:1] == ["hyst(T_case_C)"], labels
    assert row["final_over_true"] <= 1.1, (labels, row["final_over_true"])


def test_a_hysteresis_and_the_square_of_its_temperature_are_found_together():
    """A hysteresis and a T^2 of one sensor, both missing (seed 35077): hysteresis alone
    -77 to -79 %, T^2 alone nothing; the (hysteresis, level) pairs now include T^2, and the
    joint test accepts the branch's spectral z at the pair's high fold consistency (HAC z
    3.1 at HAC t 153). Before: two "possible" hysteresis verdicts, 10.4x the true model."""
    bw, ws = _bench()
    row = bw.run_case(ws.make_case(35077), max_steps=2)
    labels = [a["label"] for a in row["added"]]
    assert any(k.startswith("hyst(") for k in labels) and "T2(tc1)" in labels, labels
    assert row["final_over_true"] <= 1.25, (labels, row["final_over_true"])


def test_a_model_term_that_stands_in_for_the_missing_effect_is_replaced():
    """A static run whose case temperature drifts with the missing ageing ramp (seed 36096):
    the user's T(Tcase) is not in the true model; beside it the ramp cuts the in-sample RMS
    by 25 % but the held-out RMS by 3 % (the two are collinear and the held-out blocks
    extrapolate them). In place of T(Tcase) it gains 28 % held out, the true model's RMS.
    Before: "no missing effect" at 1.4x the true model."""
    bw, ws = _bench()
    row = bw.run_case(ws.make_case(36096), max_steps=2)
    assert [(a["label"], a["replaces"]) for a in row["added"]] == [("ramp", "T(Tcase)")]
    assert "T(Tcase)" not in row["final_terms"], row["final_terms"]
    assert row["final_over_true"] <= 1.1, row["final_over_true"]


def test_a_free_form_of_the_users_own_term_fitted_to_real_wander_is_not_a_swap():
    """Null case on real ADIS16405 noise, 6x the short-τ floor (seed 36616): the user's model
    holds the true effect as a custom fixed-τ lag rate; the library's rate of a lagged node,
    its τ free, took its place at HAC z 4.5 by fitting the wander (-41 % held-out at fold
    consistency 1.6). Beside the user's term its coefficient has z 1.5: a swap's own z also
    carries what the replaced term explained, so the candidate must stand beside it too."""
    _assert_real_null_quiet(36616)


def test_a_sinusoid_fitted_to_real_wander_does_not_take_a_true_terms_place():
    """Null case on real ADIS16405 noise, 11x the short-τ floor (seed 38603): a free
    sinusoid took the place of the user's true vibration-squared term on the strict route
    (z 5.5 in its place), fitting the wander; beside the term its p x trials was 0.006, above
    the clear-gain guard of a nuisance term (0.001). A swap's candidate must pass that guard
    of its class beside the term."""
    _assert_real_null_quiet(38603)


def test_a_pair_whose_lead_alone_worsens_the_model_needs_a_next_step():
    """Null case on real ADIS16405 noise, 22x the short-τ floor (seed 38688): a humidity
    rate and a lagged pressure fitted together to the wander held out 0.31 deg/h, so the
    rate was named first -- but alone it took the held-out RMS from 0.74 to 9.3 deg/h, the
    next step found nothing to add (the pressure lag had spectral z 5.7 beside it), the
    backward check removed the rate, and the user loop cycled, ending at 15x the true model.
    A pair whose lead alone makes the model worse needs a next step that names an effect.
    Without the pair, the humidity lagged by the record length (τ 9709 s of 9720 s, HAC z
    0.7) came next; a lag at the top of its range is a slow trend and is not named off the
    strict test (rules.LAG_TOP). The case is quiet."""
    bw, ws = _bench()
    if not ws.real_noise_available():
        pytest.skip("real ADIS16405 log not found (../shared beside the repo)")
    row = bw.run_case(ws.make_case(38688, null=True))
    labels = [a["label"] for a in row["added"]]
    assert len(labels) == len(set(labels)), labels
    assert not row["alarm"], labels


def test_a_lag_as_long_as_the_record_is_not_a_missing_effect():
    """Real ADIS16405 noise, 9x the short-τ floor (seed 36190, the missing effect a lagged
    node's rate that the user's T and Tlag terms absorb): the supply channel lagged by
    9709 s in a 9720 s record fitted the wander (-33 % held out, HAC z 0.0, spectral z 9.3)
    and was named. Lagged that long a channel is a slow trend: not named off the strict
    test (rules.LAG_TOP)."""
    bw, ws = _bench()
    if not ws.real_noise_available():
        pytest.skip("real ADIS16405 log not found (../shared beside the repo)")
    row = bw.run_case(ws.make_case(36190))
    assert row["noise"]["type"] == "real"
    labels = [a["label"] for a in row["added"]]
    assert "chanlag(supply)" not in labels, labels
    assert row["final_over_true"] <= 1.1, row["final_over_true"]


def test_a_warm_up_near_the_floor_takes_the_clear_gain_route_on_its_hac_test():
    """A warm-up beside field terms the user has, the model 1.8x the floor (seed 39181):
    the warm-up cuts the held-out RMS by 45 %, but only the first fold sees it (consistency
    5.0, under the 6 of a flexible term) and its HAC test gives p x trials 0.0014. Before,
    the loop stopped at "possible" and ended 1.9x the true model (rules.WARMUP_CLEAR_P)."""
    row, labels = _loop(39181)
    assert labels[:1] == ["warmup"], labels
    assert row["final_over_true"] <= 1.1, row["final_over_true"]


def test_a_product_that_only_imitates_a_level_gives_way_to_the_level():
    """A tilt table (seed 39018): tilt_z is nearly constant wherever tilt_y varies, so
    tilt_y*tilt_z is the level of tilt_y to r = 0.991 and held out 12 % better than it; the
    truth was tilt_y with tilt_x^2 and tilt_x*tilt_y, which hide each other. From the
    product the loop stalled at 13x the true model; the level leads now
    (rules.PRODUCT_LEVEL_R)."""
    bw, ws = _bench()
    if not ws.real_noise_available():
        pytest.skip("real ADIS16405 log not found (../shared beside the repo)")
    row = bw.run_case(ws.make_case(39018))
    labels = [a["label"] for a in row["added"]]
    assert labels[0] == "chan(tilt_y)", labels
    assert "chanprod(tilt_y,tilt_z)" not in labels, labels
    assert "chanprod(tilt_x,tilt_y)" in labels and "chan2(tilt_x)" in labels, labels
    assert row["final_over_true"] <= 1.25, row["final_over_true"]


def test_a_warm_up_and_a_sinusoid_that_hide_each_other_are_named_as_a_pair():
    """Real ADIS16405 noise, 23x the short-τ floor (seed 37133): a warm-up (τ 459 s) and an
    HVAC sinusoid are both missing. Alone each gains little (-20 % and -6 % held out), fitted
    together -49 % at spectral z 10.7, but the warm-up lives in the first fold and the pair's
    fold consistency (3.1) stayed under the 3.75 of flexible terms: nothing was named and the
    loop ended 5.3x the true model. A pair with a warm-up now takes consistency >= 2.13 with
    spectral z >= 8."""
    bw, ws = _bench()
    if not ws.real_noise_available():
        pytest.skip("real ADIS16405 log not found (../shared beside the repo)")
    row = bw.run_case(ws.make_case(37133))
    labels = [a["label"] for a in row["added"]]
    assert set(labels[:2]) == {"warmup", "sin"}, labels
    assert row["final_over_true"] < 3.0, row["final_over_true"]


def test_a_rotated_gyro_with_a_large_field_product_takes_the_quadratic_block():
    """A gyro 2.7 deg off the coils (seed 39015) with a field product By*Bz 92x the floor:
    the product's cross-axis parts (4 % of it) each qualified as a new effect, and the loop
    spent its five steps naming Hprod(Bx,By), Hsq(Bz), Hsq(By), Hsq(Bx) and ended 1.5x the
    true model. The full quadratic block in place of Hprod(By,Bz) holds out 2.70 -> 0.25 deg/h
    against 1.99 for the best new term, and is now chosen first (rules.AXES_FIRST)."""
    row, labels = _loop(39015)
    assert labels[:2] == ["Hprod(By,Bz)", "Hquad(Bx,By,Bz)"], labels
    assert len(labels) <= 3, labels
    assert row["final_over_true"] <= 1.1, (labels, row["final_over_true"])


def test_the_quadratic_block_does_not_go_before_a_missing_linear_field_term():
    """Seed 39199: Hsq(Hy) named, then a linear Hz 38x the floor still missing. The quadratic
    block in place of Hsq(Hy) absorbs most of it over the stepped sequences (-96 % against
    Hz's -93 %), but it is not the same effect in rotated axes: the block goes first only
    before a new field term of its own order, and Hz is named (rules.AXES_FIRST). Since the
    lookahead also takes candidates the held-out evidence cannot tell apart (LOOKAHEAD_T),
    Hz comes first here (with its partner Hprod 1.76 deg/h against 2.21 for Hsq), and the
    loop goes on to the rotated field's Hy and Hx and the warm-up."""
    row, labels = _loop(39199)
    assert set(labels[:2]) == {"Hsq(Hy_uT)", "Hz(Hz_uT)"}, labels
    assert not any(lb.startswith("Hquad") for lb in labels), labels
    assert row["final_over_true"] <= 1.1, (labels, row["final_over_true"])


def test_a_users_free_sinusoid_is_searched_again_beside_a_new_warm_up():
    """Seed 41032: the user's model holds a free sinusoid (an HVAC cycle of 2852 s) and a
    warm-up of 305 s is missing. Fitted without the warm-up, the sinusoid locks onto the
    transient; when the warm-up was tried, the frequency was searched only near that value
    and stayed there: the warm-up held out 0.35 instead of 0.09 deg/h at HAC z 1.0, and the
    loop ended 13x the true model. The warm frequency is now searched from scratch beside a
    new term (varpro recheck_taus)."""
    row, labels = _loop(41032)
    assert labels[:1] == ["warmup"], labels
    assert row["final_over_true"] <= 1.1, (labels, row["final_over_true"])


def test_a_pair_with_the_same_lead_stands_in_for_a_best_pair_that_fails_its_joint_test():
    """Real ADIS16405 noise (seed 41065): a warm-up and the rate term of a sensor lagging its
    node are missing, and each hides the other. The best pair, the warm-up with a lag of the
    chamber air, failed the joint HAC test, and that blocked the next pair, the warm-up with
    dT/dt of the lagging sensor, which passes it: nothing was named and the loop ended 15x
    the true model. A pair with the same leading member is now accepted."""
    bw, ws = _bench()
    if not ws.real_noise_available():
        pytest.skip("real ADIS16405 log not found (../shared beside the repo)")
    row = bw.run_case(ws.make_case(41065))
    labels = [a["label"] for a in row["added"]]
    assert labels[:2] == ["warmup", "dTdt(T_gyro)"], labels
    assert row["final_over_true"] <= 1.1, (labels, row["final_over_true"])


def test_candidates_the_held_out_evidence_cannot_tell_apart_go_to_the_lookahead():
    """Seed 41060 (tilt table): after the warm-up, T of a drifting case temperature held out
    9 % better than the true ageing ramp, but ± 30 % from fold to fold (consistency 0.7).
    Beside T the missing anisoelastic g cross term stays hidden (0.111 deg/h); beside the
    ramp it comes out at −57 % (0.054). Only candidates within 2 % went to the lookahead, and
    the loop ended 1.4x the true model (rules.LOOKAHEAD_T)."""
    row, labels = _loop(41060)
    assert labels == ["warmup", "ramp", "gprod(acc_ax,acc_ay)"], labels
    assert row["final_over_true"] <= 1.1, (labels, row["final_over_true"])


def test_a_term_the_lookahead_chose_with_its_partner_is_not_redirected():
    """Seed 41127: far above the floor the rate of a lagged node, T and a hysteresis tie;
    the lookahead picks the rate, whose partner T² takes the model to the floor. The
    redirect then gave way to a pair of two other candidates (the hysteresis with T²,
    0.23 deg/h against 0.099) because it compared only partners from the pool: the loop
    ended 2.3x the true model."""
    _, _, d = _diagnose_base(41127)
    assert d.found[0].term == "dTlagdt(T_case_C)", d.verdict
    assert d.path[-1]["ratio_to_floor_after"] < 1.3, d.path


def test_a_warm_up_near_the_floor_takes_the_clear_route_from_a_ten_percent_gain():
    """Seed 41166: beside the ramp the user added, a warm-up (τ 3427 s) cuts the held-out RMS
    by 17.5 % at fold consistency 2.15, p x trials 0.0063 (rules.WARMUP_CLEAR_P), with the
    model 1.25x the floor; the route needed a 20 % gain and the loop ended 1.2x the true
    model."""
    row, labels = _loop(41166)
    assert labels == ["ramp", "warmup"], labels
    assert row["final_over_true"] <= 1.1, (labels, row["final_over_true"])


def test_warm_time_constants_of_a_new_terms_sensor_are_searched_jointly():
    """Seed 40110: the loop has added a warm-up and the rate of a lagged node of T_gyro
    (τ 3689 s and 2041 s, fitted without the node's level). Beside T(T_gyro) they belong at
    2749 s and 909 s; neither reaches its value alone, so warm-started T(T_gyro) held out
    +0.1 % and the loop ended 1.28x the true model. Searched jointly (varpro repolish), T
    holds out -22 % at HAC z 6.3, at the true model's held-out RMS."""
    from gyrotest.envmodel import diagnose, fit_model, prepare
    from gyrotest.envmodel.terms import parse_terms, resolve_terms
    from gyrotest.ingest import read_log

    _, ws = _bench()
    case = ws.make_case(40110)
    with tempfile.TemporaryDirectory() as td:
        log = read_log(ws.write_case(case, td), overrides=case.profile)
    wd = prepare(log)
    d = diagnose(wd, resolve_terms(parse_terms(["warmup", "dTlagdt(T_gyro)"]), wd.frame))
    assert d.found and d.found[0].term in ("T(T_gyro)", "Tlag(T_gyro)"), d.verdict
    true = fit_model(wd, case.true_terms)
    assert d.found[0].rms_holdout <= 1.05 * true.rms_holdout, (d.found[0].rms_holdout,
                                                                true.rms_holdout)


def test_a_warm_up_and_a_free_sinusoid_of_the_users_model_are_searched_jointly():
    """Null seed 40685: the user's model holds a warm-up (true τ 1645 s) and a free HVAC
    sinusoid (period 4486 s) in a record of about two cycles; the transient and the first
    half-cycle trade off. Searched one at a time from scratch the fit stopped at τ 970 s,
    period 4388 s (RSS 45x the joint optimum) and the residual alarmed as a missing effect;
    the free frequency now joins the joint time-constant search (varpro polish_joint)."""
    bw, ws = _bench()
    row = bw.run_case(ws.make_case(40685, null=True))
    assert not row["alarm"], row["added"]


def test_three_effects_that_hide_one_another_are_found_as_a_group():
    """Seed 44140 (tilt table, read after it served as an unseen set): g(gy), the anisoelastic
    gx·gy and T(temp_case) all missing at 100-200x the floor beside the user's g2(gy). Alone
    they hold out -18 %, +32 % and -1 %, any two at best +58 % at fold consistency 4.7, so
    neither a single nor a pair qualified: "no missing effect", 64x the true model. All three
    together hold out +98 %; backward elimination from the saturated model (envmodel.groups)
    names the best of them alone first, and the forward path reaches the true model."""
    from gyrotest.envmodel import fit_model

    case, wd, d = _diagnose_base(44140)
    assert d.found, d.verdict
    top = d.found[0]
    assert top.route.startswith("together with"), top.route
    group = {top.term} | set(top.pair[0].split(", "))
    assert {g.replace("gx,gy", "gy,gx") for g in group} == {
        "gprod(gy,gx)", "g(gy)", "T(temp_case)"}, group
    assert "hide one another" in d.verdict, d.verdict
    true = fit_model(wd, case.true_terms)
    assert len(d.path) == 3, d.path
    assert d.path[-1]["rms_holdout_after_dph"] <= 1.1 * true.rms_holdout, d.path


def test_a_hac_z_against_a_gain_the_folds_do_not_repeat_stays_quiet():
    """Null 43578n (real ADIS16405 noise): the rate of a lagged humidity channel held out
    -8.6 % at fold consistency 0.75 with HAC z 5.0 and passed the strict test; every route
    now needs the held-out gain more often a gain than not (rules.MIN_CV_T)."""
    _assert_real_null_quiet(43578)


@pytest.mark.parametrize("seed", [47529, 47605])
def test_real_wander_fitted_by_a_nuisance_term_fails_the_surrogate_test(seed):
    """Null cases on real ADIS16405 noise, 3.4-3.9x the short-τ floor: a warm-up (−37 %
    held out, far route) and a hysteresis branch (−52 %, strict route) fitted to the gyro's
    wander had been named. The best candidate reaches those gains on phase-randomised
    surrogates of the residual in 11-17 of 39 (surrogate p 0.30-0.45 > 0.1), so the verdict
    stays "possible" (seeds from the tuning set of the surrogate gate,
    :mod:`gyrotest.envmodel.chance`)."""
    _assert_real_null_quiet(seed)


def test_a_true_warm_up_passes_the_surrogate_test():
    """A true warm-up (synthetic noise, −46 % held out on the far route) beats every one of
    the 39 surrogates' best chance gains (90 % of them below 9 %): surrogate p 0.025, and
    the loop names it."""
    row, labels = _loop(45000)
    assert "warmup" in labels, labels
    d = row["steps"][0]
    assert d["verdict"].startswith("missing effect: warmup"), d["verdict"]


def test_a_short_warm_up_that_brings_the_model_to_the_floor_is_named():
    """Seed 49097 (synthetic noise, static bench): after the supply term, a warm-up of τ 310 s
    (2 × the floor) held out −57 % and left the model 0.87 × the floor, but its coefficient's
    spectral z (6.3) was judged against the far bar of 8 (the base was 2.04 × the floor), so
    the loop stopped at 2.3 × the true model. A candidate whose own model comes within
    :data:`gyrotest.envmodel.rules.SPECTRAL_NEAR_POST` × the floor is judged against the
    near bar: its residual, on which the z is taken, is white/flicker noise."""
    row, labels = _loop(49097)
    assert labels[:2] == ["V", "warmup"], labels
    assert row["final_over_true"] <= 1.1, row["final_over_true"]


def test_a_misaligned_field_product_is_named_without_the_quadratic_block():
    """Seed 53181 (Helmholtz sequences, gyro 4.8° off the coils): |H|² and a product of the
    gyro's y and z field components. After Hmag2 the quadratic block (six coefficients) held
    out 2.07 × the floor against 2.58 for Hprod(field_y, field_z) and was named; its cross
    products of coil axes, fitted from the other folds' field settings, extrapolated badly and
    the loop ended 2.1 × the true model. Hprod with one more second-order field term holds out
    better than the block (:func:`gyrotest.envmodel.axes.sparse_follow`), and the block then
    gives way to Hsq(field_y) together with Hsq(field_z)
    (:func:`gyrotest.envmodel.axes.sparse_pair`)."""
    row, labels = _loop(53181)
    assert labels[:2] == ["Hmag2", "Hprod(field_y,field_z)"], labels
    assert not any(lab.startswith("Hquad") for lab in labels), labels
    assert row["final_over_true"] <= 1.1, row["final_over_true"]


def test_a_field_sensitivity_hidden_by_the_field_squared_is_named():
    """Seed 54092 (Helmholtz single-axis sequences, gyro 2.3° off the coils): a linear
    field sensitivity (mostly z) and |H|², 4.6× and 3.7× the floor, each hidden by the
    other. Together Hz and its square cut the held-out RMS by 75 % at fold consistency 18.7
    and spectral z 27, but the coil sequence's few steps left Hz at joint HAC z 3.8 (< 4):
    "no missing effect" at 5× the floor, 4.5× the true model. A decisive pair
    (:func:`gyrotest.envmodel.pairs._decisive`) needs no joint HAC test."""
    row, labels = _loop(54092)
    assert labels[:1] == ["Hz(Hz_uT)"], labels
    assert row["final_over_true"] <= 1.2, row["final_over_true"]


def test_a_hidden_g_sensitivity_pair_with_a_large_gain_is_named():
    """Seed 55189 (tilt table, base model with the anisoelastic term acc_ax·acc_ay): a
    g-sensitivity along acc_ay and its square, 6.4× and 2.8× the floor, hide each other.
    Together they cut the held-out RMS by 80 % at fold consistency 7.2 and spectral z 9.1,
    joint HAC z 3.93 and 3.98: "no missing effect" at 5× the floor, 4.9× the true model,
    until a larger gain needed less consistency (:data:`gyrotest.envmodel.rules.DECISIVE_GAIN`)."""
    row, labels = _loop(55189)
    assert labels[:2] == ["g(acc_ay)", "g2(acc_ay)"], labels
    assert row["final_over_true"] <= 1.1, row["final_over_true"]


def test_three_hidden_g_effects_below_twenty_times_the_floor_are_named():
    """Seed 56107 (tilt table, base model g(ay_g) and a ramp): g(ax_g), g²(ay_g) and the
    anisoelastic ax_g·ay_g, 2.6×, 10.8× and 6.8× the floor, hide one another: at 8× the
    floor the best single term held out −13.6 %, all three together −87 %. The group search
    ran only from 20× the floor ("no missing effect", 7.6× the true model); it now runs from
    the far ratio (:data:`gyrotest.envmodel.rules.GROUP_RATIO`)."""
    row, labels = _loop(56107)
    assert row["steps"][0]["top"]["route"].startswith("together with"), row["steps"][0]["top"]
    assert {"g(ax_g)", "gprod(ax_g,ay_g)"} <= set(labels), labels
    assert row["final_over_true"] <= 1.1, row["final_over_true"]


def test_a_warm_up_beside_a_coil_sequence_beats_its_surrogates():
    """Seed 58071 (Helmholtz; the user's model has Hx, Hy, Hz and a product x·z of 54× the
    floor): a warm-up of 1.3× the floor is missing. It held out −38.9 % at HAC z 6.9, but
    the surrogate test held its surrogates out with plain least squares per fold; the one
    fold whose training blocks barely moved x and z together was near-singular and 34 of 39
    surrogates "reached" the gain (p 0.88, "possible", 1.64× the true model). With the
    diagnosis's own fold fits (:func:`gyrotest.envmodel.fit.fold_coefficients`) none does."""
    row, labels = _loop(58071)
    assert labels[:1] == ["warmup"], labels
    assert "surrogate p = 0.03" in row["steps"][0]["verdict"], row["steps"][0]["verdict"]
    assert row["final_over_true"] <= 1.1, row["final_over_true"]


def test_a_level_gives_way_to_its_lag_when_the_lag_and_a_rate_hide_each_other():
    """Seed 59030 (static run): a node 438 s behind T_case and dT/dt of T_case are both
    missing beside a warm-up. Alone, T(T_case) holds out better than Tlag(T_case) (−89.9 %
    against −89.4 %; the lone lag's τ sits at 42 s, below the smoother), but with dT/dt the
    lag reaches the true model's 0.110 deg/h and the level only 0.156: the lag leads, with
    its τ resolved beside the rate (the loop had named T and ended 1.48× the true model)."""
    _, _, d = _diagnose_base(59030, ("warmup",))
    top = d.found[0]
    assert top.term == "Tlag(T_case)", d.verdict
    assert top.pair_tau_s > 300, top.pair_tau_s
    assert "the lag and a rate term hid each other" in d.verdict
    assert "then dTdt(T_case)" in d.verdict


def test_a_decisive_pair_passes_where_a_member_has_few_degrees_of_freedom():
    """Fresh seed 79011 of the thirty-sixth pass (tilt table, synthetic noise): beside the
    anisoelastic product the model has, the g sensitivity of acc_ay (12.5 x the floor) and
    an ageing ramp (9 x) are both missing, and each hides the other (alone −27 % and +14 %
    held out). Together they take the held-out RMS −91 % at fold consistency 31 and spectral
    z 60, but on a table of few positions the ramp's HAC z in the pair's fit was 3.8, below
    the joint test's 4, and the loop ended at 11.2 x the true model. Held-out and spectral
    evidence decisive against the model and against g alone (−88 %) passes the pair
    (pairs._decisive_over_members)."""
    from gyrotest.envmodel import fit_model

    case, wd, d = _diagnose_base(79011, ("gprod(acc_ax,acc_ay)",))
    top = d.found[0]
    assert top.term == "g(acc_ay)" and top.pair is not None and top.pair[0] == "ramp", d.verdict
    assert top.pair[1] <= 1.1 * fit_model(wd, case.true_terms).rms_holdout, top.pair


def test_a_redirect_keeps_the_single_that_does_as_well_with_a_member_of_the_pair():
    """Seed 69070 (climate run, synthetic noise): the humidity and vibration levels are both
    missing. chan(RH_lab) is chosen (−49 %); the pair search also finds the humidity's
    lagged rate with chan(vib_level), which passes on decisive evidence (−84 % at fold
    consistency 37). chan(RH_lab) with that same vibration level does as well, so the chosen
    level stays and the next step names the vibration (the redirect had ended the loop at
    1.22 x the true model with the lagged rate)."""
    _, _, d = _diagnose_base(69070)
    top = d.found[0]
    assert top.term == "chan(RH_lab)" and top.displaced is None, d.verdict


def test_a_single_the_chance_gate_sets_aside_gives_way_to_a_pair_that_beats_chance():
    """Fresh seed 69199 of the thirty-fifth pass (static run, synthetic noise): the supply
    voltage (2.9 x the floor) and the rate of a case sensor that lags its node by 235 s
    (4.6 x) are both missing. V alone held out −31 % at HAC z 2.9, but the phase surrogates
    of the base residual -- every one carrying the missed rate -- reached that gain (p 0.15)
    and so did the shifts of the residual V leaves: the gate set V aside and the loop ended
    at 4.3 x the true model. Together the two take the held-out RMS to the true model's, and
    no pair of the step's best candidates does that on the surrogates (p 0.025): the step
    names V with dT/dt(T_case) next, and says why V alone was set aside."""
    from gyrotest.envmodel import fit_model

    case, wd, d = _diagnose_base(69199)
    top = d.found[0]
    assert top.term == "V" and top.pair is not None and top.pair[0] == "dTdt(T_case)", d.verdict
    assert top.chance is not None and top.chance.kind == "pairs" and top.chance.p <= 0.1
    assert "V alone was set aside" in d.verdict, d.verdict
    assert top.pair[1] <= 1.1 * fit_model(wd, case.true_terms).rms_holdout, top.pair


@pytest.mark.parametrize("seed, why", [(70962, "pair of candidates")])
def test_a_channel_fit_to_real_wander_that_chance_reaches_is_left_possible(seed, why):
    """A real-noise null of the thirty-third pass's tuning set (seeds 70001-71399 drawn with
    real ADIS16405 noise): a pair of field squares (70962, −12 % together at 6.5 x the floor)
    fitted to the gyro's own slow excursions had been named. Its gain is within what chance
    reaches -- the best pair of the step's candidates reaches it on the phase surrogates of
    the residual (p 0.73) -- so the step names nothing and says which term it set aside,
    why. (The single-term test is checked on arrays in test_envmodel_chance; its real-noise
    nulls take 50 s.)"""
    v = _assert_real_null_quiet(seed)["steps"][0]["verdict"]
    assert not v.startswith("missing effect") and why in v and "set aside" in v, v


def test_a_new_effect_hidden_behind_a_rotated_field_is_paired_with_the_block():
    """Fresh seed 83007 of the thirty-seventh pass: a gyro 4.4° off the coils, Hz(mag_B3) in
    the model, T(T_gyro) missing at 5.9 x the floor. T alone gains 6 % (the cross-axis parts
    of the field effect hide it), and Hvec in place of Hz alone holds out 3 % worse; the
    loop had ended at 2.95 x the true model. Together they gain 43 % at fold consistency
    7.6: the step names T together with the block in place of Hz (the physical effect before
    the ageing ramp, which ties with the block at 44 %), and the next step names the block."""
    from gyrotest.envmodel import fit_model

    case, wd, d = _diagnose_base(83007, ("Hz(mag_B3)",))
    top = d.found[0]
    assert top.term == "T(T_gyro)", d.verdict
    assert top.route == "together with Hvec(mag_B1,mag_B2,mag_B3) in place of Hz(mag_B3)"
    assert top.pair is not None and top.pair[1] <= 0.6 * d.base.rms_holdout, top.pair
    assert ("the next step tests Hvec(mag_B1,mag_B2,mag_B3) in place of Hz(mag_B3)"
            in d.verdict), d.verdict
    # the next step, with T added: the block in place of Hz
    _, _, d2 = _diagnose_base(83007, ("Hz(mag_B3)", "T(T_gyro)"))
    top2 = d2.found[0]
    assert top2.term == "Hvec(mag_B1,mag_B2,mag_B3)" and top2.replaces == "Hz(mag_B3)", \
        d2.verdict
    assert top2.rms_holdout <= 2.0 * fit_model(wd, case.true_terms).rms_holdout
