"""The pair search's decision rule (:func:`gyrotest.envmodel.pairs._find_pair`), with the
fits replaced by fixed numbers: the pair with the lowest held-out RMS decides; when it
fails the joint HAC test, only a qualifying pair naming the same member first stands in."""

from __future__ import annotations

import math
from types import SimpleNamespace

import pytest

from gyrotest.envmodel import pairs
from gyrotest.envmodel.candidate import Candidate
from gyrotest.envmodel.terms import TermSpec


def _cand(label: str, rms: float) -> Candidate:
    c = Candidate(label, label, None, rms, rms, 10.0, 0.5, 0.6, 1.0, 1, False,
                  spec=TermSpec("T", (label,)), klass="library")
    c._fit = SimpleNamespace(_thetas={})
    return c


@pytest.fixture
def rigged(monkeypatch):
    """Pairs from a fixed list with fixed held-out RMS; ``fail`` names the pairs whose
    joint HAC test fails; every pair's held-out ``gain`` (fraction) is the same, at fold
    consistency 50 and spectral z 100 (decisive, :func:`gyrotest.envmodel.pairs._decisive`,
    from a gain of 55 %)."""
    def rig(cands, table, fail, gain=0.5):
        monkeypatch.setattr(pairs, "pair_pool", lambda base, out: [])
        monkeypatch.setattr(pairs, "_polynomial_pairs",
                            lambda out: [(cands[a], cands[b]) for a, b in table])
        for name in ("_hyst_level_pairs", "_hidden_pairs", "_trend_pairs", "_partner_pairs"):
            monkeypatch.setattr(pairs, name, lambda *a, **k: [])
        monkeypatch.setattr(pairs, "_channel_pairs", lambda *a, **k: [])

        def fit(wd, base_specs, a, b, thetas0, folds, start=None):
            return SimpleNamespace(rms_holdout=table[(a.term, b.term)])

        monkeypatch.setattr(pairs, "fit_pair", fit)
        monkeypatch.setattr(pairs, "held_out_gain", lambda base, r, folds: (gain, 0.01, 50.0))
        monkeypatch.setattr(pairs, "spectral_z", lambda *a, **k: 100.0)
        monkeypatch.setattr(pairs, "_joint_z_ok",
                            lambda r, a, b, wd, t: (a.term, b.term) not in fail)
        return pairs._find_pair(None, SimpleNamespace(rms_holdout=10.0), [], list(cands.values()),
                                {}, 5)
    return rig


def test_lowest_qualifying_pair_decides(rigged):
    c = {n: _cand(n, r) for n, r in [("X", 5.0), ("Y", 6.0), ("P", 9.0), ("Q", 9.5)]}
    found = rigged(c, {("X", "P"): 0.5, ("Y", "Q"): 0.4}, fail=set())
    assert found[0].term == "Y" and found[1].term == "Q" and math.isclose(found[2], 0.4)


def test_failed_lowest_pair_blocks_a_pair_naming_another_member(rigged):
    c = {n: _cand(n, r) for n, r in [("X", 5.0), ("Y", 6.0), ("P", 9.0), ("Q", 9.5)]}
    found = rigged(c, {("X", "P"): 0.5, ("Y", "Q"): 0.4}, fail={("Y", "Q")})
    assert found is None


def test_a_decisive_pair_needs_no_joint_hac_test(rigged):
    """Seed 54092: a linear field sensitivity and |H|², each hidden by the other, gained 75 %
    together at consistency 18.7 and spectral z 27, but one member's joint HAC z was 3.8."""
    c = {n: _cand(n, r) for n, r in [("X", 5.0), ("Y", 6.0), ("P", 9.0), ("Q", 9.5)]}
    found = rigged(c, {("X", "P"): 0.5, ("Y", "Q"): 0.4}, fail={("Y", "Q")}, gain=0.75)
    assert found[0].term == "Y" and found[1].term == "Q"
    assert pairs._decisive(0.55, 10.0, 8.0)
    assert not pairs._decisive(0.54, 50.0, 100.0)
    assert not pairs._decisive(0.69, 9.9, 100.0)
    assert not pairs._decisive(0.9, 50.0, 7.9)
    # seed 55189: a larger gain needs less fold consistency
    assert pairs._decisive(0.70, 5.0, 8.0)
    assert pairs._decisive(0.797, 7.18, 9.12)
    assert not pairs._decisive(0.9, 4.9, 100.0)
    assert not pairs._decisive(0.56, 5.19, 9.78)  # the far null's wander pair


@pytest.mark.parametrize("order", [0, 1, 2])
def test_failed_lowest_pair_hands_over_to_a_pair_naming_the_same_member(rigged, order):
    # L = (X, P) fails; G1 = (Y, Q) passes but names Y; G2 = (X, Q) passes and names X
    c = {n: _cand(n, r) for n, r in [("X", 5.0), ("Y", 6.0), ("P", 9.0), ("Q", 9.5)]}
    rows = [(("X", "P"), 0.05), (("Y", "Q"), 0.10), (("X", "Q"), 0.12)]
    rows = rows[order:] + rows[:order]
    found = rigged(c, dict(rows), fail={("X", "P")})
    assert found is not None and found[0].term == "X" and found[1].term == "Q", found
