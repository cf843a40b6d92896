"""The forked child beside the analysis (:mod:`gyrotest._runtime`): value, error and fall-back
behave as a direct call, and the spike check run beside the deviations gives exactly the
analysis of the serial order (issue #13)."""

from __future__ import annotations

import json
import os
import sys

import numpy as np
import pytest

from gyrotest import _runtime as beside
from gyrotest.core.data import GyroConstants, GyroLog, Timing
from gyrotest.core.errors import InputError
from gyrotest.noise import analysis


def _square_sum(x: np.ndarray, k: int) -> tuple[float, int]:
    return float(np.sum(x ** 2)), os.getpid() + k


def _fails(msg: str):
    raise InputError(msg)


def test_value_comes_back_from_another_process():
    x = np.arange(10.0)
    h = beside.run_beside(_square_sum, x, 0)
    s, pid = h.result()
    assert s == 285.0
    if sys.platform.startswith("linux"):
        assert pid != os.getpid()  # computed in the child


def test_error_is_raised_as_by_a_direct_call():
    h = beside.run_beside(_fails, "column 'x' is text")
    with pytest.raises(InputError, match="column 'x' is text"):
        h.result()


def test_falls_back_to_a_direct_call_off_linux(monkeypatch):
    monkeypatch.setattr(beside.sys, "platform", "win32")
    h = beside.run_beside(_square_sum, np.ones(3), 0)
    assert isinstance(h, beside._Inline)
    assert h.result() == (3.0, os.getpid())


def test_large_results_pass_the_pipe():
    big = beside.run_beside(np.arange, 3_000_000)  # 24 MB: many pipe buffers
    assert np.array_equal(big.result(), np.arange(3_000_000))


def _log(n: int) -> GyroLog:
    rng = np.random.default_rng(7)
    rate = rng.normal(0.0, 1.0, n) + 0.3 * np.cumsum(rng.normal(0.0, 1e-3, n))
    rate[[1000, 400_000, n - 5]] += [40.0, -55.0, 60.0]  # three spikes
    return GyroLog(source="beside.csv", rates={"gyro": rate}, tau0=0.01,
                   timing=Timing(n=n, tau0=0.01, duration_s=n * 0.01, source="test"),
                   gyro=GyroConstants(output_kind="rate"))


def test_spike_check_beside_equals_the_serial_analysis(monkeypatch):
    log = _log((1 << 20) + 17)
    beside_res = analysis.analyse_allan(log, outliers="flag").to_dict()
    monkeypatch.setattr(analysis, "SPIKE_BESIDE_MIN", 1 << 40)  # serial: in this process
    serial = analysis.analyse_allan(log, outliers="flag").to_dict()
    a, b = json.dumps(beside_res, sort_keys=True), json.dumps(serial, sort_keys=True)
    assert a == b
    assert beside_res["axes"][0]["outliers"]["n_outliers"] == 3
