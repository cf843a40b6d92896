"""Regression tests of issue 62, one per family of its table (the overwrite family is in
test_no_overwrite.py, dead/stuck/overflowing channels in test_bad_channels.py): each ends in
exit 2 with one line per problem naming the file, the key or option and the fix — or exit 0
with a sensible result — never exit 1, never a hang."""

from __future__ import annotations

import gzip
import json
import os
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from cliutil import run_cli

SAMPLE = Path(__file__).resolve().parents[1] / "sample_data"
RATE = ["--rate-unit", "deg/h"]


def _log(path: Path, n: int = 240) -> Path:
    rng = np.random.default_rng(3)
    t = np.arange(n) * 5.0
    rows = ["t,rate,temp,Hx,Hy,Hz,table_dps"]
    for i in range(n):
        rows.append(f"{t[i]},{rng.normal():.6f},{20 + 5 * np.sin(t[i] / 400):.4f},"
                    f"{[-100, 0, 100, 0][i * 4 // n]},0.0,0.0,{[-20, -10, 10, 20][i * 4 // n]}")
    path.write_text("\n".join(rows) + "\n")
    return path


@pytest.fixture
def work(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("GYROTEST_FIFO_WAIT", "0.3")
    _log(tmp_path / "log.csv")
    return tmp_path


def _errors(r) -> list[str]:
    assert r.code == 2, f"exit {r.code}: {r.err}"
    assert "Traceback" not in r.err
    errs = [ln for ln in r.err_lines if ln.startswith("gyrotest: error:")]
    assert errs, r.err
    return errs


def _has(r, *fragments) -> None:
    text = " ".join(_errors(r)).lower()
    for f in fragments:
        assert f.lower() in text, f"{f!r} not in {text!r}"


ANALYSES = [["info", "log.csv"], ["ingest", "log.csv", "-o", "o.parquet"], ["bias", "log.csv"],
            ["allan", "log.csv"], ["model", "fit", "log.csv", "--terms", "T"],
            ["model", "diagnose", "log.csv", "--terms", "T"], ["thermal-fit", "log.csv"],
            ["mag-fit", "log.csv"], ["scale-factor", "log.csv"], ["columns", "log.csv"]]
DEEP = {"array": "x = " + "[" * 5000 + "]" * 5000 + "\n",
        "inline": "x = " + "{a = " * 5000 + "1" + "}" * 5000 + "\n",
        "dotted": "[" + ".".join(["a"] * 500) + "]\nx = 1\n",
        "just-past-the-bound": "[gyro]\nx = " + "[" * 14 + "1" + "]" * 14 + "\n"}


@pytest.mark.parametrize("kind", sorted(DEEP))
def test_deeply_nested_profile_and_campaign(work, kind):
    (work / "p.toml").write_text(DEEP[kind])
    for argv in ANALYSES:
        _has(run_cli([*argv, "--profile", "p.toml"]), "p.toml", "nest")
    _has(run_cli(["report", "p.toml"]), "p.toml", "nest")
    _has(run_cli(["simulate", "p.toml", "-o", "s.csv"]), "p.toml", "nest")
    (work / "c.toml").write_text('[campaign]\ntitle = "T"\noperator = "A"\ndate = 2024-05-12\n'
                                 '[gyro]\nmodel = "M"\nserial = "1"\n[tests.bias]\n'
                                 'logs = ["log.csv"]\nprofile = "p.toml"\n')
    _has(run_cli(["report", "c.toml"]), "p.toml", "nest")


def test_profile_problems_each_named_by_key(work):
    (work / "p.toml").write_text(
        '[columns]\nrate = "rate"\ntemperature = ["temp", "rate"]\n'
        '[gyro]\nrate_unit = "furlong/fortnight"\n[units]\ntemp = "parsec"\n')
    for argv in (["info", "log.csv"], ["ingest", "log.csv", "-o", "o.parquet"],
                 ["bias", "log.csv"], ["allan", "log.csv"]):
        errs = _errors(run_cli([*argv, "--profile", "p.toml"]))
        assert len(errs) == 3, errs  # one line per problem, each naming its key
        text = " ".join(errs)
        for key in ("[columns].temperature[1]", "[gyro].rate_unit", "[units].temp"):
            assert key in text, text
    assert not (work / "o.parquet").exists()


def test_one_column_in_two_roles_from_the_options(work):
    for extra in (["--rate-col", "rate", "--temp-col", "rate"],
                  ["--time-col", "temp", "--temp-col", "temp"], ["--field-cols", "Hx,Hx,Hz"]):
        for argv in (["info", "log.csv"], ["bias", "log.csv"], ["allan", "log.csv"]):
            _has(run_cli([*argv, *RATE, *extra]), "two roles")


@pytest.mark.parametrize("date", ['"2024-02-30"', '"2024-13-01"', '"yesterday"'])
def test_campaign_with_a_date_that_does_not_exist(work, date):
    (work / "c.toml").write_text(f'[campaign]\ntitle = "T"\noperator = "A"\ndate = {date}\n'
                                 '[gyro]\nmodel = "M"\nserial = "1"\n')
    _has(run_cli(["report", "c.toml"]), "[campaign] date", "real date")


@pytest.fixture
def model(work):
    r = run_cli(["model", "fit", "log.csv", *RATE, "--terms", "T,T2", "-o", "m.json",
                 "--no-history", "-q"])
    assert r.code == 0, r.err
    return json.loads((work / "m.json").read_text())


def _custom(expr):
    return {"key": "custom", "label": "x", "name": "x", "expr": expr,
            "coefficients": [{"name": "x", "value": 1.0}]}


@pytest.mark.parametrize("damage,fragments", [
    ("missing coefficient", ["terms[1].coefficients", "0 value(s)"]),
    ("coefficient value null", ["terms[1].coefficients[0].value", "must be a number"]),
    ("custom number", ["terms[3].expr", "string"]),
    ("custom list", ["terms[3].expr", "string"]),
    ("custom null", ["terms[3]", "custom term needs"]),
    ("huge integer", ["terms[1].coefficients[0].value", "within"]),
    ("unknown term", ["terms[1].key", "unknown term"]),
    ("no format", ["not a gyrotest"]),
])
def test_damaged_model_file(work, model, damage, fragments):
    d = json.loads(json.dumps(model))
    t = d["terms"][1]
    if damage == "missing coefficient":
        t["coefficients"] = []
    elif damage == "coefficient value null":
        t["coefficients"][0]["value"] = None
    elif damage.startswith("custom"):
        d["terms"].append(_custom({"custom number": 5, "custom list": [1, 2],
                                   "custom null": None}[damage]))
    elif damage == "huge integer":
        t["coefficients"][0]["value"] = 10**400
    elif damage == "unknown term":
        t["key"] = "T9"
    else:
        del d["format"]
    text = json.dumps(d)
    (work / "bad.json").write_text(text)
    for argv in (["compensate", "log.csv", *RATE, "--model", "bad.json"],
                 ["allan", "log.csv", *RATE, "--model", "bad.json", "--no-diagnose"],
                 ["export", "env-model", "bad.json", "-o", "lut.csv"]):
        _has(run_cli(argv), "bad.json", *fragments)


def test_model_toml_with_an_overflowing_hex_literal(work, model):
    from gyrotest.envmodel.model import to_toml

    text = to_toml(model).replace("value = ", "value = 0x" + "f" * 300 + " # ", 1)
    (work / "m.toml").write_text(text)
    _has(run_cli(["compensate", "log.csv", *RATE, "--model", "m.toml"]), "m.toml",
         ".value", "within")


def test_model_channel_the_log_lacks(work, model):
    model["terms"][1]["channels"] = ["T_no_such_sensor"]
    (work / "m.json").write_text(json.dumps(model))
    _has(run_cli(["compensate", "log.csv", *RATE, "--model", "m.json"]), "T_no_such_sensor")


@pytest.mark.parametrize("steps", [[1, 2], [], "x", [{}], [{"step": "one", "log": 5}]])
def test_damaged_history(work, steps):
    (work / "m.history.json").write_text(json.dumps(
        {"format": "gyrotest-model-history", "version": 1, "steps": steps}))
    r = run_cli(["model", "history", "m.json"])
    if steps == []:
        _has(r, "history is empty")
    else:
        _has(r, "m.history.json", "steps")


@pytest.mark.parametrize("kind,fragments", [
    ("gzip", ["gzip", "decompress"]),
    ("no delimiter", ["no delimiter"]),
    ("inf", ["row 3", "not a finite"]),
    ("huge", ["row 3", "not a finite"]),
    ("binary", ["binary"]),
    ("latin-1", ["utf-8"]),
])
def test_damaged_setpoint_table(work, kind, fragments):
    text = "temperature,dw,sigma\n31,0.1,0.01\n37,{},0.01\n43,0.3,0.01\n49,0.5,0.01\n"
    data = text.format("inf" if kind == "inf" else "1e308" if kind == "huge" else "0.2")
    raw = data.encode()
    if kind == "gzip":
        raw = gzip.compress(raw)
    elif kind == "no delimiter":
        raw = data.replace(",", "|").encode()
    elif kind == "binary":
        raw = b"\x00\x01" * 100
    elif kind == "latin-1":
        raw = data.replace("temperature", "température").encode("latin-1")
    (work / "sp.csv").write_bytes(raw)
    _has(run_cli(["thermal-fit", "--setpoints", "sp.csv"]), "sp.csv", *fragments)


@pytest.mark.parametrize("duration,fragments", [
    ('"1e999h"', ["longer than any record"]),
    ("1e300", ["samples", "limit"]),
    ('"100000h"', ["samples", "limit", "GiB available"]),
])
def test_scenario_beyond_memory_is_refused_before_allocation(work, duration, fragments):
    (work / "s.toml").write_text(f'[record]\nsample_rate_hz = 100.0\nduration_s = {duration}\n'
                                 '[gyro]\noutput = "rate"\n')
    t0 = time.perf_counter()
    _has(run_cli(["simulate", "s.toml", "-o", "s.csv"]), *fragments)
    assert time.perf_counter() - t0 < 5  # nothing was allocated
    assert not (work / "s.csv").exists()


def test_a_device_in_place_of_a_file(work):
    (work / "c.toml").write_text('[campaign]\ntitle = "T"\noperator = "A"\ndate = 2024-05-12\n'
                                 '[gyro]\nmodel = "M"\nserial = "1"\n[tests.bias]\n'
                                 'logs = ["log.csv"]\nprofile = "/dev/urandom"\n')
    for argv in (["simulate", "/dev/urandom", "-o", "s.csv"], ["report", "/dev/urandom"],
                 ["info", "log.csv", "--profile", "/dev/urandom"], ["report", "c.toml"],
                 ["compensate", "log.csv", *RATE, "--model", "/dev/zero"],
                 ["thermal-fit", "--setpoints", "/dev/zero"], ["info", "/dev/zero"]):
        _has(run_cli(argv), "device")


@pytest.mark.parametrize("argv,fragments", [
    (["allan", "log.csv", "--horizon", "1e-300s"], ["--horizon", "1 us"]),
    (["allan", "log.csv", "--horizon", "1e999h"], ["--horizon", "longer than any record"]),
    (["allan", "log.csv", "--vehicle-rate", "1e-300deg/s"], ["--vehicle-rate"]),
    (["allan", "log.csv", "--terms", ""], ["term"]),
    (["allan", "log.csv", "--csv", "x.jpg"], ["--csv", ".jpg"]),
    (["scale-factor", "log.csv", "--min-dwell", "1e999h"], ["--min-dwell"]),
    (["scale-factor", "log.csv", "--settle", "1e999h"], ["--settle"]),
    (["scale-factor", "log.csv", "--points", "p.png"], ["points", ".png"]),
    (["bias", "log.csv", "--settle", "1e999h"], ["--settle"]),
    (["mag-fit", "log.csv", "--settle", "1e999h"], ["--settle"]),
    (["model", "fit", "log.csv", "--terms", "T", "--t-ref", "nan"], ["--t-ref"]),
    (["thermal-fit", "log.csv", "--t0", "1e308"], ["--t0"]),
    (["ingest", "log.csv", "-o", "x.txt"], ["x.txt", ".parquet"]),
    (["model", "fit", "log.csv", "--term", "x:t*" + "9" * 290], ["term 'x'", "1e+40"]),
    (["model", "diagnose", "log.csv", "--term", "x:t*" + "9" * 290], ["term 'x'", "1e+40"]),
    (["model", "fit", "log.csv", "--term", "x:t*0x" + "f" * 200], ["term 'x'", "1e+40"]),
])
def test_options_with_wild_values(work, argv, fragments):
    _has(run_cli([*argv, *RATE]), *fragments)


def test_sensible_results_for_odd_options(work):
    # a cut-off beyond Nyquist: the deviation table, and a note why no model was fitted
    r = run_cli(["allan", "log.csv", *RATE, "--bi-cutoff", "1e308"])
    assert r.code == 0 and "Nyquist" in r.err and "noise model not fitted" in r.err, r.err
    # no terms: the bias-only model
    r = run_cli(["model", "fit", "log.csv", *RATE, "--terms", "", "--json"])
    assert r.code == 0, r.err
    assert json.loads(r.out)["terms"] == ["bias"]


SLOTS = {
    "log": ["info", "{p}", *RATE],
    "allan": ["allan", "{p}", *RATE],
    "ingest": ["ingest", "{p}", *RATE, "-o", "o.parquet"],
    "bias": ["bias", "{p}", *RATE],
    "scale-factor": ["scale-factor", "{p}", *RATE],
    "profile": ["info", "log.csv", "--profile", "{p}"],
    "model": ["compensate", "log.csv", *RATE, "--model", "{p}"],
    "setpoints": ["thermal-fit", "--setpoints", "{p}"],
    "scenario": ["simulate", "{p}", "-o", "s.csv"],
    "campaign": ["report", "{p}"],
    "plateau table": ["scale-factor", "--table", "{p}"],
    "columns": ["columns", "{p}"],
}


@pytest.mark.timeout(60)
@pytest.mark.parametrize("slot", sorted(SLOTS))
def test_fifo_with_no_writer_never_hangs(work, slot):
    os.mkfifo(work / "pipe")
    t0 = time.perf_counter()
    r = run_cli([a.format(p="pipe") for a in SLOTS[slot]])
    assert time.perf_counter() - t0 < 10
    _has(r, "pipe", "named pipe", "no data")
    assert "not found" not in r.err


@pytest.mark.timeout(60)
def test_fifo_with_a_slow_writer_is_read_to_its_end(work):
    os.mkfifo(work / "pipe")
    text = (work / "log.csv").read_bytes()

    def writer():
        with open(work / "pipe", "wb") as f:
            f.write(text[:1000])
            f.flush()
            time.sleep(0.15)  # a pause shorter than the wait (0.3 s here)
            f.write(text[1000:])

    th = threading.Thread(target=writer)
    th.start()
    r = run_cli(["info", "pipe", *RATE, "--json"])
    th.join()
    assert r.code == 0, r.err
    assert json.loads(r.out)["timing"]["samples"] == 240
