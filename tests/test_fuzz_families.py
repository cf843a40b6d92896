"""Property-based fuzzing of every command with the damaged-input families of issue 62
(``tests/fuzzcases.py``): value families of a log column, damaged profiles, campaigns,
scenarios, model and history files and set-point tables, wild option values, an output that
is an input, FIFOs with no writer, devices and directories.

Every case ends in exit 0 or 2 (never 1), prints no traceback, changes no input, leaves no
temporary file and no output after an error, and answers within its time limit. The suite's
profile is derandomised and small; ``GYROTEST_FUZZ=long`` runs more, and
``benchmarks/fuzz_campaign.py --families`` is the 10⁵-case campaign.
"""

from __future__ import annotations

import os

import pytest
from fuzzcases import HypDraw, build_case, run_case
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cliutil import run_cli

LONG = os.environ.get("GYROTEST_FUZZ") == "long"


@pytest.fixture(scope="module")
def good_model(tmp_path_factory):
    import numpy as np
    from fuzzcases import RngDraw, log_text

    d = tmp_path_factory.mktemp("model")
    base, _, _ = log_text(RngDraw(np.random.default_rng(0)), n=120)
    (d / "base.csv").write_text(base)
    r = run_cli(["model", "fit", d / "base.csv", "--rate-unit", "deg/h", "--terms", "T", "-o",
                 d / "good.json", "--no-history", "-q"])
    assert r.code == 0, r.err
    return (d / "good.json").read_bytes()


class _Bytes(bytes):
    def __repr__(self) -> str:
        return "<a valid model file>"


@st.composite
def cases(draw, good_model):
    return build_case(HypDraw(draw), good_model)


@settings(derandomize=True, max_examples=2000 if LONG else 120, deadline=None, database=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture,
                                 HealthCheck.data_too_large])
@given(data=st.data())
def test_every_family_exits_0_or_2(tmp_path, monkeypatch, good_model, data):
    monkeypatch.setenv("GYROTEST_FIFO_WAIT", "0.2")
    case = data.draw(cases(_Bytes(good_model)), label="case")
    out = run_case(case, tmp_path / f"c{os.urandom(4).hex()}", limit_s=60)
    assert out.problem is None, f"{case}: {out.problem}\n{out.err[-800:]}"
