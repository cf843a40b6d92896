"""Dead, stuck and overflowing channels (issue 62, item 1): one line naming the column (and the
row for an overflow), exit 2, before any analysis — on every command that analyses a log;
``info`` and ``ingest`` describe and convert, so a dead channel is a warning there."""

from __future__ import annotations

import numpy as np
import pytest

from gyrotest.core.errors import InputError
from gyrotest.io.health import MAX_ABS, is_constant
from gyrotest.io.ingest import read_log

from cliutil import run_cli

N = 1200


def _write(path, gyro, temp=None, *, table=None):
    t = np.arange(N) * 0.5
    temp = 20 + 5 * np.sin(t / 60) if temp is None else temp
    table = np.repeat([-20.0, -10.0, 10.0, 20.0], N // 4) if table is None else table
    hx = np.repeat([-100.0, 0.0, 100.0, 0.0], N // 4)
    with open(path, "w") as f:
        f.write("t,rate,temp,Hx,Hy,Hz,table_dps\n")
        for i in range(N):
            row = (t[i], gyro[i], temp[i], hx[i], 0.0, 0.0, table[i])
            f.write(",".join(repr(float(v)) for v in row) + "\n")
    return path


@pytest.fixture(scope="module")
def model_file(tmp_path_factory):
    d = tmp_path_factory.mktemp("model")
    rng = np.random.default_rng(5)
    log = _write(d / "good.csv", rng.normal(0, 1, N))
    r = run_cli(["model", "fit", log, "--rate-unit", "deg/h", "--terms", "T", "-o",
                 d / "m.json", "-q"])
    assert r.code == 0, r.err
    return d / "m.json"


def _commands(model_file):
    u = ["--rate-unit", "deg/h"]
    return {
        "bias": ["bias", *u],
        "allan": ["allan", *u],
        "scale-factor": ["scale-factor", *u, "--table-col", "table_dps"],
        "model fit": ["model", "fit", *u, "--terms", "T"],
        "model diagnose": ["model", "diagnose", *u, "--terms", "T"],
        "thermal-fit": ["thermal-fit", *u],
        "mag-fit": ["mag-fit", *u, "--field-cols", "Hx,Hy,Hz"],
        "compensate": ["compensate", *u, "--model", str(model_file)],
        "export stable32": ["export", "stable32", *u, "-o", str(model_file.parent / "x.txt")],
    }


DEAD = {
    "zeros": np.zeros(N),
    "constant": np.full(N, 3.25),
    "tiny": np.random.default_rng(1).normal(0, 1, N) * 1e-300,
}


@pytest.mark.parametrize("family", sorted(DEAD))
def test_dead_gyro_channel_every_command(tmp_path, model_file, family):
    log = _write(tmp_path / f"{family}.csv", DEAD[family])
    for cmd in _commands(model_file).values():
        argv = cmd[:1] + ([cmd[1]] if cmd[0] in ("model", "export") else [])
        rest = cmd[len(argv):]
        r = run_cli([*argv, log, *rest])
        r.assert_clean_error("gyro output 'rate' is constant", "whole run", "connected")
    r = run_cli(["info", log, "--rate-unit", "deg/h"])  # a finding, not a failure, here
    assert r.code == 0, r.err
    assert "constant" in r.err and "connected" in r.err


@pytest.mark.parametrize("column", ["rate", "temp"])
@pytest.mark.parametrize("value", [1e308, -9.9e307, 1.7976931348623157e308, 1e41])
def test_overflowing_values_name_column_and_row(tmp_path, model_file, column, value):
    rng = np.random.default_rng(2)
    gyro, temp = rng.normal(0, 1, N), 20 + rng.normal(0, 0.1, N)
    (gyro if column == "rate" else temp)[[100, 101, 700]] = value
    log = _write(tmp_path / "big.csv", gyro, temp)
    label = "gyro output 'rate'" if column == "rate" else "temperature 'temp'"
    for cmd in _commands(model_file).values():  # every channel read is checked, used or not
        argv = cmd[:1] + ([cmd[1]] if cmd[0] in ("model", "export") else [])
        r = run_cli([*argv, log, *cmd[len(argv):]])
        r.assert_clean_error(label, "row 101 (line 102)", "overflow", "--nan gap")
    # dropped as gaps on request: the rest of the log is analysed
    r = run_cli(["bias", log, "--rate-unit", "deg/h", "--nan", "gap", "--json"])
    assert r.code == 0, r.err


def test_scale_factor_that_overflows_after_conversion(tmp_path):
    p = tmp_path / "c.csv"
    p.write_text("t,counts\n" + "".join(f"{i * 0.1:.1f},{i % 7}\n" for i in range(300)))
    r = run_cli(["bias", p, "--counts-col", "counts", "--scale-factor", "1e300"])
    r.assert_clean_error("gyro output", "after the unit conversion", "scale factor")


def test_thresholds_are_the_arithmetic_ones():
    # |x|^6 * 1e9 samples stays finite at the bound, with room for a unit factor of 2e5
    assert (MAX_ABS * 2.1e5) ** 6 * 1e9 < np.finfo(float).max
    assert is_constant(np.full(10, 1e6)) and is_constant(np.array([1e6, 1e6 + 3e-10]))  # 3 ulp
    assert not is_constant(np.array([1e6, 1e6 + 1e-6]))  # a real quantisation step
    assert not is_constant(np.array([0.0, 1e-30]))
    assert is_constant(np.array([0.0, 1e-300, -1e-300]))


def test_python_api_reports_the_dead_channel(tmp_path):
    log = _write(tmp_path / "z.csv", np.zeros(N))
    with pytest.raises(InputError, match="constant"):
        read_log(log, overrides={"gyro": {"rate_unit": "deg/h"}}, dead="error")
    g = read_log(log, overrides={"gyro": {"rate_unit": "deg/h"}})
    assert any("constant" in n for n in g.notes)


def test_saturated_gyro_output_is_a_finding(tmp_path, model_file):
    rng = np.random.default_rng(7)
    clipped = np.clip(rng.normal(0, 1, N), -5.0, 1.5)  # a rail at +1.5 deg/h
    log = _write(tmp_path / "sat.csv", clipped)
    for cmd in _commands(model_file).values():
        argv = cmd[:1] + ([cmd[1]] if cmd[0] in ("model", "export") else [])
        r = run_cli([*argv, log, *cmd[len(argv):]])
        r.assert_clean_error("gyro output 'rate'", "sits at 1.5 deg/h", "saturated")
    r = run_cli(["info", log, "--rate-unit", "deg/h"])
    assert r.code == 0 and "saturated" in r.err, r.err


def test_no_saturation_on_noise_quantised_or_not():
    from gyrotest.io.health import saturation

    rng = np.random.default_rng(8)
    for seed in range(20):  # a continuous record and a coarsely quantised one: never flagged
        x = np.random.default_rng(seed).normal(0, 1, 20000)
        assert saturation(x) is None
        assert saturation(np.round(x / 0.5) * 0.5) is None
        assert saturation(np.round(x * 3)) is None
    # a quantised record whose top level is held far longer than its repeats allow
    q = np.round(rng.normal(0, 1, 20000) / 0.5) * 0.5
    q[5000:5400] = q.max()
    assert saturation(q)[1:] == (5000, 400)
