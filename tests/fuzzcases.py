"""Damaged-input cases for every command and every kind of file (issue 62): the families a lab
produces, built from one generator that two drivers share.

A case is a set of files and a command line. :func:`build_case` takes a ``draw`` object with
``choice(seq)``, ``integer(lo, hi)`` and ``uniform(lo, hi)``: the hypothesis tests
(``tests/test_fuzz_families.py``) back it with strategies, the long campaign
(``benchmarks/fuzz_campaign.py --families``) with a numpy generator. :func:`run_case` runs a
case in-process in a fresh directory and returns what went wrong (an exit code other than 0
or 2, a traceback, a changed input, a leftover temporary file, an output after an error, a
run past its time limit), or None.

Families (the issue's table): value families of a log column (all-zero, constant, tiny,
huge, overflow codes, mixed extremes, NaN/inf sprinkled, one column in two roles), document
families of profiles, campaigns, scenarios, model and history files and set-point tables
(deep nesting, wrong types, missing keys, unknown keys, bad units, bad dates, huge numbers,
hex overflow, gzip, binary, empty), options with wild values, an output that is an input, and
FIFOs, devices and directories in place of a file.
"""

from __future__ import annotations

import gzip
import hashlib
import json
import math
import os
import signal
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

from cliutil import run_cli

FIFO = object()  # a file entry that is a named pipe with no writer

# ----------------------------------------------------------------------------- log values
EXTREMES = [0.0, 1e-300, -1e-300, 5e-324, 1e300, -1e308, 1.7976931348623157e308, 9.9e37,
            1e39, 1e41, 3.4e38, float("nan"), float("inf"), float("-inf"), 1e-20, 123456789.0]
VALUE_FAMILIES = ["normal", "zeros", "constant", "tiny", "huge", "overflow_code", "mixed",
                  "nan_inf", "quantised", "two_roles", "short"]


def _fmt(x: float) -> str:
    return repr(float(x))


def log_text(draw, n: int | None = None) -> tuple[str, str, str]:
    """(CSV text, family, damaged column) of a small bench log: t, rate (deg/h), temp (degC),
    Hx/Hy/Hz (uT, a coil sequence), table_dps (a rate-table sequence)."""
    n = n or draw.integer(60, 240)
    family = draw.choice(VALUE_FAMILIES)
    col = draw.choice(["rate", "rate", "temp", "Hx", "table_dps"])
    seed = draw.integer(0, 2**31 - 1)
    import numpy as np

    rng = np.random.default_rng(seed)
    t = np.arange(n) * 5.0
    cols = {
        "t": t,
        "rate": rng.normal(0.0, 1.0, n) + 0.05 * np.sin(t / 200),
        "temp": 20 + 5 * np.sin(t / 400) + rng.normal(0, 0.01, n),
        "Hx": np.repeat([-100.0, 0.0, 100.0, 0.0], -(-n // 4))[:n],
        "Hy": np.zeros(n) + rng.normal(0, 0.1, n),
        "Hz": np.zeros(n) + rng.normal(0, 0.1, n),
        "table_dps": np.repeat([-20.0, -10.0, 10.0, 20.0], -(-n // 4))[:n],
    }
    v = cols[col]
    if family == "zeros":
        v[:] = 0.0
    elif family == "constant":
        v[:] = draw.choice([3.25, -1.0, 1e6, 25.0])
    elif family == "tiny":
        v[:] = rng.normal(0, 1, n) * draw.choice([1e-300, 1e-200, 1e-45, 5e-324])
    elif family == "huge":
        v[:] = rng.normal(0, 1, n) * draw.choice([1e300, 1e307, 1e39, 1e45])
    elif family == "overflow_code":
        k = draw.integer(1, max(1, n // 10))
        v[rng.integers(0, n, k)] = draw.choice([9.9e37, 1e308, -1e308, 3.4e38, 1.7e308])
    elif family == "mixed":
        k = draw.integer(1, n)
        v[rng.integers(0, n, k)] = [draw.choice(EXTREMES) for _ in range(k)]
    elif family == "nan_inf":
        k = draw.integer(1, max(1, n // 5))
        v[rng.integers(0, n, k)] = draw.choice([float("nan"), float("inf"), float("-inf")])
    elif family == "quantised":
        v[:] = np.round(v / 0.5) * 0.5
    elif family == "short":
        k = draw.integer(1, 12)
        cols = {c: x[:k] for c, x in cols.items()}
    lines = [",".join(cols)]
    m = len(cols["t"])
    lines += [",".join(_fmt(cols[c][i]) for c in cols) for i in range(m)]
    return "\n".join(lines) + "\n", family, col


# ----------------------------------------------------------------------------- documents
PROFILE = {"columns": {"time": "t", "rate": "rate", "temperature": ["temp"],
                       "field": ["Hx", "Hy", "Hz"], "table_rate": "table_dps"},
           "gyro": {"rate_unit": "deg/h"}, "site": {"latitude_deg": 48.1, "ia": "up"}}
WILD = [0, -1, 1e300, -1e308, "1e400", True, [], {}, "x", "", None, "😀", 2**70, [1, [2]],
        {"a": {"b": 1}}, "deg/fortnight", "2024-02-30", "nan", "0x" + "f" * 80]


def toml_value(v) -> str:
    if v is None:
        return '"null"'
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        if isinstance(v, float) and not math.isfinite(v):
            return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf")
        return repr(v)
    if isinstance(v, str):
        if v.startswith("0x"):
            return v  # a hex integer literal, overflowing
        return json.dumps(v, ensure_ascii=False)
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{k} = {toml_value(x)}" for k, x in v.items()) + "}"
    raise TypeError(v)


def toml_text(doc: dict) -> str:
    out = []
    for sec, body in doc.items():
        if isinstance(body, dict):
            out.append(f"[{sec}]")
            out += [f"{json.dumps(k)} = {toml_value(v)}" for k, v in body.items()]
        else:
            out.insert(0, f"{json.dumps(sec)} = {toml_value(body)}")
    return "\n".join(out) + "\n"


def _mutate_tree(draw, doc: dict) -> dict:
    """A copy of a two-level document with one to three damaged keys."""
    doc = json.loads(json.dumps(doc))
    for _ in range(draw.integer(1, 3)):
        op = draw.choice(["wrong_type", "delete", "unknown_key", "unknown_section", "bad_unit",
                          "dup_role", "deep_value", "bad_date", "empty_section"])
        sec = draw.choice(sorted(doc))
        body = doc[sec] if isinstance(doc[sec], dict) else {}
        keys = sorted(body) or ["x"]
        key = draw.choice(keys)
        if op == "wrong_type" and isinstance(doc[sec], dict):
            doc[sec][key] = draw.choice(WILD)
        elif op == "delete" and isinstance(doc[sec], dict):
            doc[sec].pop(key, None)
        elif op == "unknown_key" and isinstance(doc[sec], dict):
            doc[sec][draw.choice(["scale_factr", "rtae", "bogus", "Rate_Unit"])] = 1
        elif op == "unknown_section":
            doc[draw.choice(["nonsense", "colums", "gyros"])] = {"a": 1}
        elif op == "bad_unit" and isinstance(doc[sec], dict):
            doc[sec][key] = draw.choice(["furlong/fortnight", "deg/hh", "", "K/s", "°"])
        elif op == "dup_role" and isinstance(doc.get("columns"), dict):
            doc["columns"]["temperature"] = [doc["columns"].get("rate", "rate"), "temp"]
        elif op == "deep_value" and isinstance(doc[sec], dict):
            d = draw.integer(5, 40)
            doc[sec][key] = _nest(d, draw.choice(["list", "table"]))
        elif op == "bad_date" and isinstance(doc[sec], dict):
            doc[sec][key] = draw.choice(["2024-02-30", "2024-13-01", "yesterday", "0000-00-00"])
        elif op == "empty_section":
            doc[sec] = {}
    return doc


def _nest(depth: int, kind: str):
    v: object = 1
    for _ in range(depth):
        v = [v] if kind == "list" else {"a": v}
    return v


def deep_text(draw, fmt: str) -> str:
    """Nesting past the parsers' recursion limit (or just past gyrotest's bound)."""
    d = draw.choice([14, 200, 3000, 20000])
    if fmt == "json":
        return '{"a": ' + "[" * d + "1" + "]" * d + "}"
    kind = draw.choice(["array", "inline", "dotted"])
    if kind == "array":
        return "a = " + "[" * d + "1" + "]" * d + "\n"
    if kind == "inline":
        return "a = " + "{b = " * d + "1" + "}" * d + "\n"
    return "[" + ".".join(["s"] * min(d, 2000)) + "]\nx = 1\n"


def raw_variant(draw, text: str) -> bytes:
    """The text as a lab may save it: unchanged mostly, or gzip'd, cut, binary, empty,
    latin-1, with a BOM or CRLF."""
    kind = draw.choice(["plain"] * 6 + ["gzip", "cut", "binary", "empty", "bom", "crlf",
                                        "latin1"])
    b = text.encode("utf-8")
    if kind == "gzip":
        return gzip.compress(b)
    if kind == "cut":
        return b[: draw.integer(0, max(0, len(b) - 1))]
    if kind == "binary":
        return bytes(draw.integer(0, 255) for _ in range(64)) + b"\x00"
    if kind == "empty":
        return b""
    if kind == "bom":
        return b"\xef\xbb\xbf" + b
    if kind == "crlf":
        return b.replace(b"\n", b"\r\n")
    if kind == "latin1":
        return text.replace("deg", "°").encode("latin-1", errors="replace")
    return b


CAMPAIGN = {"campaign": {"title": "T", "operator": "A", "date": "2024-05-12"},
            "gyro": {"model": "M", "serial": "1"}}
SCENARIO = {"record": {"sample_rate_hz": 10.0, "duration_s": "60s"},
            "gyro": {"output": "rate", "bias_dph": 0.5},
            "site": {"latitude_deg": 48.0, "ia": "up"}}


# ----------------------------------------------------------------------------- cases
@dataclass
class Case:
    family: str
    argv: list[str]
    files: dict[str, object] = field(default_factory=dict)  # name -> bytes | FIFO
    outputs: list[str] = field(default_factory=list)  # files the command may write
    links: dict[str, str] = field(default_factory=dict)  # name -> target (symlinks)

    def __repr__(self) -> str:  # hypothesis prints a failing case
        return f"<{self.family}: gyrotest {' '.join(self.argv)}>"


RATE = ["--rate-unit", "deg/h"]
TERMS = ["T", "T,T2", "dTdt", "T,Hx", "ramp", "H"]


def _analysis_argv(draw, log: str) -> tuple[list[str], list[str]]:
    """A command that reads ``log`` (and the options it needs)."""
    cmd = draw.choice(["info", "bias", "allan", "scale-factor", "model fit", "model diagnose",
                       "thermal-fit", "mag-fit", "compensate", "ingest", "export stable32",
                       "columns"])
    if cmd == "info":
        return ["info", log, *RATE], []
    if cmd == "columns":
        return ["columns", log], []
    if cmd == "bias":
        return ["bias", log, *RATE], []
    if cmd == "allan":
        return ["allan", log, *RATE, *draw.choice([[], ["--no-diagnose"], ["--no-fit"]])], []
    if cmd == "scale-factor":
        return ["scale-factor", log, *RATE, "--table-col", "table_dps"], []
    if cmd == "model fit":
        return ["model", "fit", log, *RATE, "--terms", draw.choice(TERMS)], []
    if cmd == "model diagnose":
        return ["model", "diagnose", log, *RATE, "--terms", "T", "--candidates",
                draw.choice(["T2", "dTdt", "ramp"]), "--path", "1"], []
    if cmd == "thermal-fit":
        return ["thermal-fit", log, *RATE], []
    if cmd == "mag-fit":
        return ["mag-fit", log, *RATE, "--field-cols", "Hx,Hy,Hz"], []
    if cmd == "compensate":
        return ["compensate", log, *RATE, "--model", "model.json"], []
    if cmd == "ingest":
        return ["ingest", log, *RATE, "-o", "out.parquet"], ["out.parquet"]
    return ["export", "stable32", log, *RATE, "-o", "out.txt"], ["out.txt"]


def build_case(draw, good_model: bytes) -> Case:
    """One damaged-input case (see the module docstring). ``good_model``: a valid model file
    (JSON) that the model-file families start from."""
    family = draw.choice(["log_values", "log_values", "log_values", "profile", "campaign",
                          "scenario", "model", "history", "setpoints", "options",
                          "output_is_input", "special_path"])
    base_log, _, _ = log_text(_Fixed(draw), n=120)
    files: dict[str, object] = {"model.json": good_model}
    if family == "log_values":
        text, vfam, col = log_text(draw)
        files["log.csv"] = text.encode()
        argv, outs = _analysis_argv(draw, "log.csv")
        if vfam == "two_roles":
            argv += draw.choice([["--rate-col", "rate", "--temp-col", "rate"],
                                 ["--time-col", "temp", "--temp-col", "temp"],
                                 ["--field-cols", "Hx,Hx,Hz"]])
        if draw.choice([False, False, True]):
            argv += ["--nan", draw.choice(["gap", "interpolate"])]
        return Case(f"log:{vfam}:{col}", argv, files, outs)
    files["log.csv"] = base_log.encode()
    if family == "profile":
        doc = _mutate_tree(draw, PROFILE) if draw.choice([True, True, False]) else PROFILE
        text = deep_text(draw, "toml") if draw.choice([False] * 5 + [True]) else toml_text(doc)
        files["bench.toml"] = raw_variant(draw, text)
        argv, outs = _analysis_argv(draw, "log.csv")
        argv = [a for a in argv if a not in RATE] + ["--profile", "bench.toml"]
        return Case("profile", argv, files, outs)
    if family == "campaign":
        doc = json.loads(json.dumps(CAMPAIGN))
        test = draw.choice(["bias", "allan", "thermal", "nonsense"])
        doc[f"tests.{test}"] = {"logs": ["log.csv"], "profile": "bench.toml"}
        files["bench.toml"] = toml_text({"gyro": {"rate_unit": "deg/h"}}).encode()
        doc = _mutate_tree(draw, doc) if draw.choice([True, True, False]) else doc
        text = deep_text(draw, "toml") if draw.choice([False] * 6 + [True]) else toml_text(doc)
        text = text.replace('["tests.', "[tests.").replace('"tests.', "tests.")
        files["campaign.toml"] = raw_variant(draw, text)
        out = draw.choice(["spec.md", "spec.html", "-"])
        argv = ["report", "campaign.toml"] + ({"spec.md": ["--md", out],
                                               "spec.html": ["--html", out]}.get(out) or [])
        if draw.choice([True, False, False]):
            argv = ["fleet", "campaign.toml", "--jobs", "1", "--no-figures"]
        return Case("campaign", argv, files, [] if out == "-" else [out])
    if family == "scenario":
        doc = json.loads(json.dumps(SCENARIO))
        doc["record"]["duration_s"] = draw.choice(["60s", "1e999h", "1e400s", 1e300, -5,
                                                   "3000000h", "nan", 0, "1min"])
        doc["record"]["sample_rate_hz"] = draw.choice([10.0, 1e9, 1e-300, 0, -1, 1e308])
        doc = _mutate_tree(draw, doc) if draw.choice([True, False]) else doc
        text = deep_text(draw, "toml") if draw.choice([False] * 6 + [True]) else toml_text(doc)
        files["s.toml"] = raw_variant(draw, text)
        return Case("scenario", ["simulate", "s.toml", "-o", "sim.csv"], files,
                    ["sim.csv", "sim.truth.json", "sim.profile.toml"])
    if family == "model":
        d = json.loads(good_model)
        op = draw.choice(["drop_coef", "custom_number", "custom_list", "custom_null",
                          "hex", "huge", "unknown_term", "missing_channel", "wrong_types",
                          "deep", "not_json", "format", "extra_coef", "custom_bad_expr"])
        t = d["terms"][-1]
        if op == "drop_coef":
            t["coefficients"] = []
        elif op == "extra_coef":
            t["coefficients"] = t["coefficients"] * 2
        elif op.startswith("custom"):
            d["terms"].append({"key": "custom", "label": "x", "name": "x",
                               "expr": {"custom_number": 5, "custom_list": [1, 2],
                                        "custom_null": None,
                                        "custom_bad_expr": "__import__('os')"}[op],
                               "coefficients": [{"name": "x", "value": 1.0}]})
        elif op == "huge":
            t["coefficients"][0]["value"] = 10**400
        elif op == "unknown_term":
            t["key"] = "T9"
        elif op == "missing_channel":
            t["channels"] = ["no_such_sensor"]
        elif op == "wrong_types":
            d["resolution_s"] = draw.choice(["x", None, -1, [], 0])
        elif op == "format":
            d["format"] = "something-else"
        fmt = draw.choice(["json", "toml"])
        if op == "hex":
            fmt = "toml"
        if fmt == "json":
            try:
                text = json.dumps(d) if op != "deep" else deep_text(draw, "json")
            except ValueError:
                text = "{}"
            name = "m.json"
        else:
            from gyrotest.envmodel.model import to_toml

            text = to_toml(d) if op != "deep" else deep_text(draw, "toml")
            if op == "hex":
                text = text.replace("value = ", "value = 0x" + "f" * 300 + " # ", 1)
            name = "m.toml"
        if op == "not_json":
            text = text[: len(text) // 2]
        files[name] = raw_variant(draw, text)
        cmd = draw.choice(["compensate", "allan", "export env-model"])
        if cmd == "compensate":
            argv = ["compensate", "log.csv", *RATE, "--model", name]
        elif cmd == "allan":
            argv = ["allan", "log.csv", *RATE, "--model", name, "--no-diagnose"]
        else:
            argv = ["export", "env-model", name, "-o", "lut.csv"]
        return Case(f"model:{op}", argv, files, ["lut.csv"])
    if family == "history":
        steps = draw.choice([[1, 2], [], "x", [{}], [{"step": "one", "log": 5, "terms": 3}],
                             [{"step": 1, "log": "l", "terms": ["T"]}], None])
        d = {"format": draw.choice(["gyrotest-envmodel-history", "x"]), "version": 1,
             "steps": steps}
        files["model.history.json"] = raw_variant(draw, json.dumps(d))
        return Case("history", ["model", "history", "model.json"], files, [])
    if family == "setpoints":
        rows = ["temperature,dw,sigma"] + [
            f"{20 + 5 * i},{draw.choice(['0.1', '0.2', 'inf', 'nan', '1e308', 'x', ''])},0.01"
            for i in range(draw.integer(0, 7))]
        sep = draw.choice([",", ",", ";", "\t", "X", " "])
        text = "\n".join(r.replace(",", sep) for r in rows) + "\n"
        files["sp.csv"] = raw_variant(draw, text)
        return Case("setpoints", ["thermal-fit", "--setpoints", "sp.csv"], files, [])
    if family == "options":
        wild = draw.choice(["1e-300s", "1e999h", "-5s", "nan", "", "0", "1e308", "inf",
                            "abc", "1e-300", "1h", "10/decade", "0/decade", "1e9/decade"])
        opt = draw.choice([
            ("allan", "--horizon"), ("allan", "--skip"), ("allan", "--taus"),
            ("allan", "--vehicle-rate"), ("allan", "--terms"), ("allan", "--detrend"),
            ("allan", "--confidence"), ("allan", "--bi-cutoff"), ("bias", "--settle"),
            ("bias", "--skip"), ("scale-factor", "--min-dwell"), ("scale-factor", "--settle"),
            ("scale-factor", "--trim-end"), ("model fit", "--resolution"),
            ("model fit", "--smooth"), ("model fit", "--terms"), ("model fit", "--term"),
            ("model fit", "--skip"), ("mag-fit", "--settle"), ("mag-fit", "--min-dwell"),
            ("thermal-fit", "--t0"), ("info", "--sample-rate"), ("ingest", "--scale-factor"),
            ("allan", "--csv"), ("ingest", "-o")])
        if opt[1] == "--term":
            wild = draw.choice(["x:t*" + "9" * 290, "x:t*0x" + "f" * 250, "x:1e308*t*t",
                                "x:temp.temp**1e3", "x:", ":t", "x:t" + "*t" * 400])
        if opt[1] in ("--csv", "-o"):
            wild = draw.choice(["x.jpg", "x.txt", "x", "out.parquet", "x.csv"])
        argv, outs = _analysis_argv(draw, "log.csv")
        argv = (["model", "fit"] if opt[0] == "model fit" else [opt[0]]) + ["log.csv", *RATE]
        if opt[0] == "scale-factor":
            argv += ["--table-col", "table_dps"]
        if opt[0] == "mag-fit":
            argv += ["--field-cols", "Hx,Hy,Hz"]
        if opt[0] == "model fit" and opt[1] != "--terms":
            argv += ["--terms", "T"]
        if opt[0] == "ingest" and opt[1] != "-o":
            argv += ["-o", "out.parquet"]
        return Case(f"option:{opt[0]} {opt[1]}", [*argv, opt[1], wild], files,
                    ["out.parquet"] + ([wild] if opt[1] in ("--csv", "-o") and wild else []))
    if family == "output_is_input":
        files["bench.toml"] = toml_text({"gyro": {"rate_unit": "deg/h"}}).encode()
        victim = draw.choice(["log.csv", "bench.toml"])
        how = draw.choice(["same", "symlink"])
        links = {}
        target = victim
        if how == "symlink":
            links["alias_" + victim] = victim
            target = "alias_" + victim
        cmd = draw.choice([
            ["allan", "log.csv", "--profile", "bench.toml", "--csv", target],
            ["allan", "log.csv", "--profile", "bench.toml", "--plot", target],
            ["scale-factor", "log.csv", "--profile", "bench.toml", "--table-col", "table_dps",
             "--points", target],
            ["model", "fit", "log.csv", "--profile", "bench.toml", "--terms", "T", "-o",
             target],
            ["thermal-fit", "log.csv", "--profile", "bench.toml", "-o", target],
            ["mag-fit", "log.csv", "--profile", "bench.toml", "--field-cols", "Hx,Hy,Hz",
             "-o", target],
            ["compensate", "log.csv", "--profile", "bench.toml", "--model", "model.json",
             "-o", target],
            ["ingest", "log.csv", "--profile", "bench.toml", "-o", target],
            ["compensate", "log.csv", "--profile", "bench.toml", "--model", "model.json",
             "--plot", "model.json"],
        ])
        return Case(f"output_is_input:{cmd[0]}", cmd, files, [], links)
    # special paths: a FIFO with no writer, a device, a directory in place of a file
    kind = draw.choice(["fifo", "fifo", "dev_null", "dev_zero", "dir"])
    slot = draw.choice(["log", "profile", "model", "setpoints", "scenario", "campaign",
                        "history", "table"])
    name = {"log": "x.csv", "profile": "x.toml", "model": "x.json", "setpoints": "x.csv",
            "scenario": "x.toml", "campaign": "x.toml", "history": "x.history.json",
            "table": "x.csv"}[slot]
    path = {"dev_null": "/dev/null", "dev_zero": "/dev/zero"}.get(kind, name)
    if kind == "fifo":
        files[name] = FIFO
    elif kind == "dir":
        files[name] = "DIR"
    argv = {"log": [draw.choice(["info", "allan", "bias", "ingest"]), path, *RATE],
            "profile": ["info", "log.csv", "--profile", path],
            "model": ["compensate", "log.csv", *RATE, "--model", path],
            "setpoints": ["thermal-fit", "--setpoints", path],
            "scenario": ["simulate", path, "-o", "sim.csv"],
            "campaign": ["report", path],
            "history": ["model", "history", path],
            "table": ["scale-factor", "--table", path]}[slot]
    if argv[0] == "ingest":
        argv += ["-o", "out.parquet"]
    return Case(f"special:{kind}:{slot}", argv, files, ["out.parquet", "sim.csv"])


class _Fixed:
    """A draw that always takes the first choice (the good base log of every case)."""

    def __init__(self, draw) -> None:
        self._draw = draw

    def choice(self, seq):
        return seq[0]

    def integer(self, lo, hi):
        return lo

    def uniform(self, lo, hi):
        return lo


class RngDraw:
    """``draw`` backed by a numpy Generator (the benchmark campaign)."""

    def __init__(self, rng) -> None:
        self.rng = rng

    def choice(self, seq):
        return seq[int(self.rng.integers(len(seq)))]

    def integer(self, lo, hi):
        return int(self.rng.integers(lo, hi + 1))

    def uniform(self, lo, hi):
        return float(self.rng.uniform(lo, hi))


class HypDraw:
    """``draw`` backed by hypothesis strategies (the test suite)."""

    def __init__(self, draw) -> None:
        from hypothesis import strategies as st

        self._draw, self._st = draw, st

    def choice(self, seq):
        return self._draw(self._st.sampled_from(list(seq)))

    def integer(self, lo, hi):
        return self._draw(self._st.integers(lo, hi))

    def uniform(self, lo, hi):
        return self._draw(self._st.floats(lo, hi))


# ----------------------------------------------------------------------------- running
class Hang(Exception):
    pass


@contextmanager
def _time_limit(seconds: float):
    def fire(signum, frame):
        raise Hang(f"no answer within {seconds:g} s")

    old = signal.signal(signal.SIGALRM, fire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


def _digest(p: Path) -> str:
    return hashlib.sha256(p.read_bytes()).hexdigest()


@dataclass
class Outcome:
    code: int | None
    problem: str | None
    seconds: float
    err: str


def run_case(case: Case, directory: Path, *, limit_s: float = 60.0) -> Outcome:
    """Run ``case`` in ``directory`` (created, left for the caller to remove)."""
    directory.mkdir(parents=True, exist_ok=True)
    for name, content in case.files.items():
        p = directory / name
        if content is FIFO:
            os.mkfifo(p)
        elif content == "DIR":
            p.mkdir()
        else:
            p.write_bytes(content)  # type: ignore[arg-type]
    for name, target in case.links.items():
        os.symlink(target, directory / name)
    named = set(case.argv) | {case.links.get(a) for a in case.argv}
    if case.argv[0] in ("report", "fleet"):  # the campaign names its files
        named |= set(case.files)
    regular = {n: _digest(directory / n) for n, c in case.files.items()
               if isinstance(c, bytes) and n in named}
    existed = {o for o in case.outputs if (directory / o).exists()}
    old = os.getcwd()
    os.chdir(directory)
    t0 = time.perf_counter()
    problem = None
    r = None
    # C libraries (LAPACK's "On entry to DLASCL parameter number 4 had an illegal value": a
    # NaN reached it) write to file descriptor 1 directly: catch that too
    import sys
    import tempfile

    sys.stdout.flush()
    saved = os.dup(1)
    cout = tempfile.TemporaryFile()
    os.dup2(cout.fileno(), 1)
    try:
        with _time_limit(limit_s):
            r = run_cli(case.argv)
    except Hang as e:
        problem = f"hang: {e}"
    finally:
        os.dup2(saved, 1)
        os.close(saved)
        os.chdir(old)
    cout.seek(0)
    c_text = cout.read().decode("utf-8", "replace")
    cout.close()
    if "On entry to" in c_text or "illegal value" in c_text:
        problem = f"a NaN/inf reached LAPACK: {c_text.strip()[:120]}"
    dt = time.perf_counter() - t0
    if r is None:
        return Outcome(None, problem, dt, "")
    if r.code not in (0, 2):
        problem = f"exit {r.code}"
    elif "Traceback" in r.err:
        problem = "traceback"
    elif r.code == 2 and not any(ln.startswith("gyrotest: error:") for ln in r.err_lines):
        problem = "exit 2 without an error line"
    for n, d in regular.items():
        p = directory / n
        if not p.is_file() or _digest(p) != d:
            problem = problem or f"input {n} changed"
    left = [p.name for p in directory.iterdir() if p.name.startswith(".") and
            p.name.endswith(tuple(f".tmp{Path(o).suffix}" for o in [*case.outputs, "x.png"]))]
    if left:
        problem = problem or f"temporary file left: {left}"
    if r.code != 0:
        made = [o for o in case.outputs if o not in existed and o not in regular
                and (directory / o).is_file()]
        if made:
            problem = problem or f"output written although the command failed: {made}"
    return Outcome(r.code, problem, dt, r.err)
