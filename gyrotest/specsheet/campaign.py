"""The campaign file: which logs make up a gyro test campaign, how to read them, which options
each analysis gets, the spec limits (IEEE 952's "shall not exceed ___" blanks) and the
laboratory parts of the report (``[lab]``, ``[approval]``, ``[decision]``, ``[[equipment]]``,
``[[revisions]]``, per-test ``environment``). User reference: docs/campaign.md and
``gyrotest report --template``.

A campaign is TOML; paths are relative to the campaign file; unknown sections and keys are
errors. The whole file is validated -- every path exists, every bench profile parses, every
option has the right type and parses (durations, noise terms, vehicle rates, model terms) --
before any analysis runs, so a typo costs a one-line error, not a half-finished report::

    [campaign]
    title = "Acceptance test"          # optional
    operator = "J. Doe"
    date = "2024-05-12"
    organisation = "Gyro lab"          # optional
    notes = "..."                      # optional, printed under the title block

    [gyro]
    model = "GT-FOG-100"
    serial = "0427"
    type = "FOG"                       # optional
    nominal_scale_factor = 0.5         # S0
    scale_factor_unit = "arcsec/pulse" # arcsec/pulse | (deg/h)/V | 1

    [site]
    latitude_deg = 48.137              # passed to every analysis as --latitude
    name = "Munich, bench 2"           # optional

    [tests.bias]                       # static runs: D_F and run-to-run repeatability
    logs = ["static.parquet", "bias_run1.parquet"]
    profile = "static.profile.toml"    # bench profile for these logs (--profile)
    skip = "30min"                     # warm-up trim (--skip)
    conditions = "power-off between runs"   # free text: what separates the runs
    limits = { bias_dph = 3.0, repeatability_1sigma_dph = 0.05 }

    [tests.allan]                      # one static log: random drift N, B, K, R, Q
    log = "static.parquet"
    profile = "static.profile.toml"
    skip = "30min"
    terms = "Q,N,B,K,R"                # --terms
    vehicle_rates = ["10deg/s", "100deg/s"]   # application note (--vehicle-rate)
    horizon = "1h"                     # --horizon
    limits = { N = 0.015, B = 0.05 }

    [tests.scale_factor]               # rate-table runs, one log per run
    logs = ["rt1.parquet", "rt2.parquet"]
    profile = "rt.profile.toml"
    settle = "10s"
    limits = { linearity_max_ppm_fs = 20, asymmetry_ppm = 50 }

    [tests.thermal]                    # chamber run: Antonova-Matveev model and IEEE E terms
    log = "thermal.parquet"
    profile = "thermal.profile.toml"
    t0 = 21.0
    gradient = ["T_coil_a_C", "T_coil_b_C"]
    model_steps = ["T", "T,T2", "T,T2,dTdt"]   # model history: one 'model fit' per step
    limits = { D_T = 0.5 }

    [tests.magnetic]                   # Helmholtz-coil run: w_x, w_y, w_z
    log = "magnetic.parquet"
    profile = "magnetic.profile.toml"

    [tests.multiposition]              # IA alignment (positions in a label column)
    log = "multipos.csv"
    profile = "multipos.profile.toml"
    settle = "30s"

    [tests.supply]                     # supply-voltage sensitivity ('model fit --terms V')
    log = "supply.csv"
    profile = "supply.profile.toml"

Every test also takes ``ingest = { ... }`` with the shared ingest options (``time_col``,
``temp_col``, ``rate_unit`` ... as in ``gyrotest info --help``). A test that is absent is
reported as "not tested". :data:`TESTS` lists every key of every test with its meaning and
the command-line option it becomes.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..core.errors import InputError

# ----------------------------------------------------------------------------- schema
#: per test: key -> (type, CLI option or None, help). Types: "path", "paths", "str", "float",
#: "int", "bool", "duration", "rate" (e.g. "0.05deg/h"; a number is deg/h), "strs", "limits",
#: "ingest".
COMMON_KEYS: dict[str, tuple[str, str | None, str]] = {
    "profile": ("path", "--profile", "bench profile TOML for the logs of this test"),
    "ingest": ("ingest", None, "shared ingest options (time_col, rate_col, temp_col ...)"),
    "limits": ("limits", None, "spec limits of this test's items"),
    "conditions": ("str", None, "free text: the test conditions IEEE 952 asks to state"),
    "axis": ("str", "--axis", "gyro axis (rate column) to analyse"),
    "environment": ("environment", None, "ambient conditions during this test (temperature, "
                    "humidity, pressure, vibration, notes)"),
}

#: keys of a test's ``environment = { ... }`` table (free text, units written out)
ENVIRONMENT_KEYS = {"temperature": "ambient temperature, e.g. \"22 ± 1 °C\"",
                    "humidity": "relative humidity, e.g. \"40 … 50 % RH\"",
                    "pressure": "air pressure, e.g. \"960 hPa\"",
                    "vibration": "seismic/vibration condition, e.g. \"isolated pier\"",
                    "notes": "anything else a reader needs to repeat the test"}

TESTS: dict[str, dict[str, tuple[str, str | None, str]]] = {
    "bias": {
        "logs": ("paths", None, "static runs (one log per run)"),
        "skip": ("duration", "--skip", "warm-up trim at the start of each run"),
        "no_earth_rate": ("bool", "--no-earth-rate", "do not subtract the earth rate"),
        "warmup_band": ("rate", "--warmup-band", "warm-up time: band around the final bias, "
                        "e.g. \"0.05deg/h\" (a number is deg/h); each log starts at power-on"),
        "warmup_block": ("duration", "--warmup-block", "warm-up time: block length (its "
                         "resolution), default 60s"),
    },
    "allan": {
        "log": ("path", None, "static log for the Allan analysis"),
        "skip": ("duration", "--skip", "warm-up trim"),
        "terms": ("str", "--terms", "noise terms to fit, e.g. Q,N,B,K,R"),
        "vehicle_rates": ("strs", "--vehicle-rate", "vehicle rates for the application note"),
        "horizon": ("duration", "--horizon", "time of the attitude-error prediction"),
        "taus": ("str", "--taus", "tau grid: octave, decade, N/decade, all or a list"),
        "detrend": ("str", "--detrend", "none, linear, quadratic or sine:PERIOD"),
        "model": ("path", "--model", "drift model (gyrotest model fit -o) removed first"),
        "bi_cutoff_hz": ("float", "--bi-cutoff", "bias-instability cut-off f0, Hz"),
        "no_diagnose": ("bool", "--no-diagnose", "skip the search for missing terms"),
    },
    "scale_factor": {
        "logs": ("paths", None, "rate-table runs (one log per run)"),
        "settle": ("duration", "--settle", "minimum settling time after each rate change "
                   "(each plateau's settling is found from its data)"),
        "fixed_settle": ("bool", "--fixed-settle", "use settle exactly (no settling from the data)"),
        "trim_end": ("duration", "--trim-end", "time excluded before the end of a plateau"),
        "min_dwell": ("duration", "--min-dwell", "shortest plateau"),
        "detect": ("str", "--detect", "auto, table or output"),
        "rates": ("str", "--rates", "commanded rates, deg/s, for detected plateaus"),
        "full_scale_dps": ("float", "--full-scale", "full-scale input rate, deg/s"),
        "terms": ("str", "--terms", "nonlinearity terms: auto, linear or a list"),
        "alpha": ("float", "--alpha", "significance level for adding a term"),
        "common_rates": ("bool", "--common-rates", "keep only the rates all runs share"),
        "no_asymmetry": ("bool", "--no-asymmetry", "reduce runs without negative rates"),
    },
    "thermal": {
        "log": ("path", None, "thermal-chamber log"),
        "t_ref": ("float", "--t-ref", "reference temperature T_ref, degC (ΔT = T − T_ref)"),
        "t0": ("float", "--t-ref", "old name of t_ref"),
        "sensor": ("str", "--sensor", "temperature channel of the model"),
        "gradient": ("strs", "--gradient", "two channels A, B for D_gradTdot"),
        "skip": ("duration", "--skip", "drop the start of the log"),
        "resolution": ("str", "--resolution", "working resolution or auto"),
        "smooth": ("str", "--smooth", "smoother window or auto"),
        "setpoints": ("path", "--setpoints", "table of steady-state set-points (CSV)"),
        "model_steps": ("strs", None, "model history: terms of each 'model fit' step"),
    },
    "magnetic": {
        "log": ("path", None, "Helmholtz-coil (or magnetometer) log"),
        "settle": ("duration", "--settle", "time dropped after every field step"),
        "min_dwell": ("duration", "--min-dwell", "shortest field plateau"),
        "with": ("str", "--with", "extra terms for drift between levels, e.g. T"),
        "skip": ("duration", "--skip", "drop the start of the log"),
    },
    "multiposition": {
        "log": ("path", None, "multi-position log with a position label column"),
        "skip": ("duration", "--skip", "trim at the start"),
        "settle": ("duration", "--settle", "time dropped after every position change"),
    },
    "supply": {
        "log": ("path", None, "log with a supply-voltage channel"),
        "terms": ("str", "--terms", "model terms (default V)"),
        "skip": ("duration", "--skip", "drop the start of the log"),
    },
    "accel": {
        "log": ("path", None, "static log with accelerometer columns (ax/ay/az, acc_x ... with "
                "a unit): their noise per IEEE Std 1293"),
        "skip": ("duration", "--skip", "warm-up trim"),
        "terms": ("str", "--terms", "noise terms to fit, e.g. Q,N,B,K,R"),
        "taus": ("str", "--taus", "tau grid: octave, decade, N/decade, all or a list"),
        "detrend": ("str", "--detrend", "none, linear, quadratic or sine:PERIOD"),
    },
}

#: limit keys per test: key -> (label, unit, what it limits)
LIMITS: dict[str, dict[str, tuple[str, str]]] = {
    "bias": {"bias_dph": ("|D_F|", "°/h"),
             "repeatability_1sigma_dph": ("bias repeatability (1σ)", "°/h"),
             "repeatability_max_spread_dph": ("bias repeatability (max spread)", "°/h"),
             "warmup_time_s": ("warm-up time (worst run)", "s")},
    "allan": {"N": ("angle random walk N", "°/√h"), "B": ("bias instability B", "°/h"),
              "K": ("rate random walk K", "(°/h)/√h"), "R": ("rate ramp R", "(°/h)/h"),
              "Q": ("quantization Q", "arcsec")},
    "scale_factor": {
        "scale_factor_error_ppm": ("|SF/S0 − 1|", "ppm"),
        "linearity_max_ppm_fs": ("linearity error (max)", "ppm of FS"),
        "linearity_1sigma_ppm_fs": ("linearity error (1σ)", "ppm of FS"),
        "asymmetry_ppm": ("|asymmetry|", "ppm"),
        "repeatability_1sigma_ppm": ("SF repeatability (1σ)", "ppm"),
        "repeatability_max_spread_ppm": ("SF repeatability (max spread)", "ppm"),
        "stability_1sigma_ppm": ("SF stability (1σ, every run)", "ppm"),
        "temperature_ppm_per_degC": ("|SF temperature sensitivity|", "ppm/°C")},
    "thermal": {"D_T": ("|D_T|", "(°/h)/°C"), "D_Tdot": ("|D_Ṫ|", "(°/h)/(°C/h)"),
                "D_gradTdot": ("|D_∇Ṫ|", "(°/h)/(°C/h)")},
    "magnetic": {"wx": ("|w_x|", "°/h per 100 µT"), "wy": ("|w_y|", "°/h per 100 µT"),
                 "wz": ("|w_z|", "°/h per 100 µT")},
    "multiposition": {"azimuth_misalignment_deg": ("|IA azimuth misalignment|", "°")},
    "accel": {"N": ("velocity random walk VRW", "m/s/√h"), "B": ("bias instability B", "µg"),
              "K": ("acceleration random walk K", "m/s/h/√h"),
              "R": ("acceleration ramp R", "m/s/h/h"), "Q": ("velocity quantization Q", "m/s")},
    "supply": {"supply_dph_per_v": ("|supply sensitivity|", "(°/h)/V")},
}

SECTION_KEYS = {
    "campaign": {"title": "str", "operator": "str", "date": "date", "organisation": "str",
                 "notes": "str", "report_id": "str", "customer": "str", "revision": "str"},
    "lab": {"name": "str", "address": "str", "accreditation": "str", "logo": "path",
            "contact": "str"},
    "approval": {"prepared_by": "str", "reviewed_by": "str", "approved_by": "str",
                 "approved_title": "str", "approval_date": "date"},
    "decision": {"rule": "str", "coverage_factor": "float"},
    "gyro": {"model": "str", "serial": "str", "type": "str", "nominal_scale_factor": "float",
             "scale_factor_unit": "str"},
    "site": {"latitude_deg": "float", "name": "str"},
}
REQUIRED = {"campaign": ("operator", "date"), "gyro": ("model", "serial")}
#: decision rules (ILAC-G8:09/2019): guard-banded acceptance with w = U, or simple acceptance
DECISION_RULES = ("guard-band", "simple")
#: ``[[equipment]]`` entries: key -> type
EQUIPMENT_KEYS = {"name": "str", "model": "str", "serial": "str", "asset_id": "str",
                  "calibrated": "date", "calibration_due": "date", "certificate": "str",
                  "tests": "strs"}
#: ``[[revisions]]`` entries: key -> type
REVISION_KEYS = {"revision": "str", "date": "date", "description": "str", "author": "str"}
SF_UNITS = ("arcsec/pulse", "(deg/h)/V", "1")
INGEST_KEYS = ("time_col", "rate_col", "rate_unit", "counts_col", "up_col", "down_col",
               "counter_col", "counter_bits", "voltage_col", "scale_factor", "offset",
               "sample_rate", "temp_col", "field_cols", "supply_col", "table_col",
               "position_col", "ia", "nan_policy")


# ----------------------------------------------------------------------------- model
@dataclass
class Test:
    """One test of the campaign after validation: absolute log paths, profile, options."""

    name: str
    logs: list[Path]
    profile: Path | None
    options: dict[str, Any]
    ingest: dict[str, Any]
    limits: dict[str, float]
    conditions: str | None = None
    files: dict[str, str] = field(default_factory=dict)  # relative name -> sha256
    environment: dict[str, str] = field(default_factory=dict)

    def opt(self, key: str, default: Any = None) -> Any:
        """An option value, or ``default`` when the campaign does not give it."""
        return self.options.get(key, default)


@dataclass
class Campaign:
    """A validated campaign file."""

    path: Path
    sha256: str
    meta: dict[str, Any]
    gyro: dict[str, Any]
    site: dict[str, Any]
    tests: dict[str, Test]
    raw: dict[str, Any]
    lab: dict[str, Any] = field(default_factory=dict)
    approval: dict[str, Any] = field(default_factory=dict)
    decision: dict[str, Any] = field(default_factory=dict)
    equipment: list[dict[str, Any]] = field(default_factory=list)
    revisions: list[dict[str, Any]] = field(default_factory=list)

    @property
    def root(self) -> Path:
        """The directory paths in the campaign are relative to."""
        return self.path.parent

    def rel(self, p: Path) -> str:
        """``p`` relative to the campaign directory (as written in the campaign)."""
        try:
            return p.relative_to(self.root).as_posix()
        except ValueError:
            return str(p)

    def to_dict(self) -> dict[str, Any]:
        """JSON form (paths relative to the campaign directory)."""
        return {"file": str(self.path), "sha256": self.sha256, "campaign": self.meta,
                "gyro": self.gyro, "site": self.site,
                "tests": {k: {"logs": [self.rel(p) for p in t.logs],
                              "profile": self.rel(t.profile) if t.profile else None,
                              "options": t.options, "ingest": t.ingest, "limits": t.limits,
                              "conditions": t.conditions, "environment": t.environment}
                          for k, t in self.tests.items()},
                "lab": {k: (self.rel(v) if isinstance(v, Path) else v)
                        for k, v in self.lab.items()},
                "approval": self.approval, "decision": self.decision,
                "equipment": self.equipment, "revisions": self.revisions}


# ----------------------------------------------------------------------------- parsing
def sha256_file(path: Path) -> str:
    """SHA-256 (hex) of a file's bytes."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


class _Err:
    def __init__(self, src: str):
        self.src = src

    def __call__(self, where: str, msg: str) -> InputError:
        return InputError(f"{self.src}: {where}: {msg}")


def _scalar(err: _Err, where: str, value: Any, typ: str) -> Any:
    if typ in ("str", "date"):
        if typ == "date" and isinstance(value, (_dt.date, _dt.datetime)):
            return value.isoformat()
        if not isinstance(value, str):
            raise err(where, f"must be a string, got {value!r}")
        if typ == "date":  # a date that exists: 2024-02-30 is not one
            try:
                _dt.date.fromisoformat(value)
            except ValueError:
                try:
                    _dt.datetime.fromisoformat(value)
                except ValueError:
                    raise err(where, f"must be a real date like 2025-03-31, got {value!r}"
                              ) from None
        return value
    if typ == "float":
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise err(where, f"must be a number, got {value!r}")
        if not math.isfinite(float(value)):
            raise err(where, f"must be finite, got {value!r}")
        return float(value)
    if typ == "int":
        if isinstance(value, bool) or not isinstance(value, int):
            raise err(where, f"must be an integer, got {value!r}")
        return value
    if typ == "bool":
        if not isinstance(value, bool):
            raise err(where, f"must be true or false, got {value!r}")
        return value
    raise AssertionError(typ)


def _check_file(err: _Err, root: Path, where: str, value: Any) -> Path:
    if not isinstance(value, str) or not value:
        raise err(where, f"must be a file path (string), got {value!r}")
    p = (root / value).resolve() if not Path(value).is_absolute() else Path(value)
    if not p.exists():
        raise err(where, f"file {value!r} not found (paths are relative to the campaign file, "
                         f"{root})")
    if p.is_dir():
        raise err(where, f"{value!r} is a directory, expected a file")
    from ..core.guard import declare_input

    declare_input(p, f"the file {where} of the campaign")
    return p


def _check_option(err: _Err, where: str, test: str, key: str, typ: str, value: Any) -> Any:
    """Type-check and pre-parse one option so that a bad value fails before any work."""
    from ..core.units import parse_duration, parse_rate_dph

    if typ == "rate":
        try:
            v = parse_rate_dph(value, what=key)
        except InputError as e:
            raise err(where, str(e)) from None
        return value if isinstance(value, str) else f"{v:g}deg/h"
    if typ == "duration":
        if isinstance(value, bool) or not isinstance(value, (str, int, float)):
            raise err(where, f"must be a duration like \"30min\" or seconds, got {value!r}")
        try:
            v = parse_duration(value, what=key)
        except InputError as e:
            raise err(where, str(e)) from None
        if v < 0:
            raise err(where, "must not be negative")
        return str(value) if isinstance(value, str) else f"{float(value):g}s"
    if typ == "strs":
        if isinstance(value, str):
            value = [value]
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            raise err(where, f"must be a list of strings, got {value!r}")
        if key == "vehicle_rates":
            from ..noise.impact import parse_vehicle_rate

            for v in value:
                try:
                    parse_vehicle_rate(v)
                except InputError as e:
                    raise err(where, str(e)) from None
        if key == "gradient" and len(value) != 2:
            raise err(where, f"give two temperature channels, got {value!r}")
        if key == "model_steps":
            from ..envmodel.terms import parse_terms

            if not value:
                raise err(where, "list at least one step, e.g. [\"T\", \"T,T2\"]")
            for v in value:
                try:
                    parse_terms([v])
                except InputError as e:
                    raise err(where, f"step {v!r}: {e}") from None
        return list(value)
    v = _scalar(err, where, value, typ)
    if test in ("allan", "accel") and key == "terms":
        from ..noise.noisefit import parse_terms

        try:
            parse_terms(v)
        except InputError as e:
            raise err(where, str(e)) from None
    if test in ("allan", "accel") and key == "taus":
        from ..noise.analysis import parse_taus

        try:
            parse_taus(v)
        except InputError as e:
            raise err(where, str(e)) from None
    if test in ("allan", "accel") and key == "detrend":
        from ..noise.analysis import parse_detrend

        try:
            parse_detrend(v)
        except InputError as e:
            raise err(where, str(e)) from None
    if test == "scale_factor" and key == "detect" and v not in ("auto", "table", "output"):
        raise err(where, f"must be auto, table or output, got {v!r}")
    if test in ("supply", "magnetic") and key in ("terms", "with"):
        from ..envmodel.terms import parse_terms, split_terms

        try:
            parse_terms(split_terms(v))
        except InputError as e:
            raise err(where, str(e)) from None
    return v


def _known(keys) -> str:
    return ", ".join(sorted(keys))


def parse_campaign(data: dict[str, Any], path: Path, sha: str = "") -> Campaign:
    """Validate a parsed campaign (see the module docstring); raises :class:`InputError`
    naming the campaign file and the offending key."""
    err = _Err(str(path))
    root = path.parent
    known_top = set(SECTION_KEYS) | {"tests", "equipment", "revisions"}
    for k in data:
        if k not in known_top:
            raise err(f"[{k}]", f"unknown section; known sections: {_known(known_top)}")
    out: dict[str, dict[str, Any]] = {}
    for sec, keys in SECTION_KEYS.items():
        body = data.get(sec, {})
        if not isinstance(body, dict):
            raise err(f"[{sec}]", "must be a table")
        vals = {}
        for k, v in body.items():
            if k not in keys:
                raise err(f"[{sec}] {k}", f"unknown key; known keys: {_known(keys)}")
            if keys[k] == "path":
                vals[k] = _check_file(err, root, f"[{sec}] {k}", v)
                if k == "logo" and vals[k].suffix.lower() not in (".png", ".jpg", ".jpeg"):
                    raise err(f"[{sec}] {k}", f"{v!r}: the logo must be a PNG or JPEG image")
            else:
                vals[k] = _scalar(err, f"[{sec}] {k}", v, keys[k])
        for k in REQUIRED.get(sec, ()):
            if k not in vals:
                raise err(f"[{sec}] {k}", "missing (required)")
        out[sec] = vals
    unit = out["gyro"].get("scale_factor_unit")
    if unit is not None and unit not in SF_UNITS:
        raise err("[gyro] scale_factor_unit", f"must be one of {', '.join(SF_UNITS)}")
    rule = out["decision"].get("rule", "guard-band")
    if rule not in DECISION_RULES:
        raise err("[decision] rule", f"must be one of {', '.join(DECISION_RULES)}, got {rule!r}")
    k_cov = out["decision"].get("coverage_factor", 2.0)
    if not 1.0 <= k_cov <= 3.0:
        raise err("[decision] coverage_factor", f"must be within 1 … 3 (2 for about 95 %), "
                  f"got {k_cov:g}")
    out["decision"] = {"rule": rule, "coverage_factor": k_cov}
    equipment = _entries(err, data, "equipment", EQUIPMENT_KEYS, ("name", "calibration_due"))
    for i, e in enumerate(equipment):
        for t in e.get("tests", []):
            if t not in TESTS:
                raise err(f"[[equipment]] #{i + 1} tests", f"unknown test {t!r}; known tests: "
                          f"{_known(TESTS)}")
    revisions = _entries(err, data, "revisions", REVISION_KEYS, ("revision", "date",
                                                                 "description"))
    if "latitude_deg" in out["site"] and not -90 <= out["site"]["latitude_deg"] <= 90:
        raise err("[site] latitude_deg", "must be within -90...90")
    tests_raw = data.get("tests", {})
    if not isinstance(tests_raw, dict):
        raise err("[tests]", "must be a table of [tests.NAME] sections")
    tests: dict[str, Test] = {}
    for name, body in tests_raw.items():
        if name not in TESTS:
            raise err(f"[tests.{name}]", f"unknown test; known tests: {_known(TESTS)}")
        if not isinstance(body, dict):
            raise err(f"[tests.{name}]", "must be a table")
        spec = {**COMMON_KEYS, **TESTS[name]}
        sec = f"[tests.{name}]"
        logs: list[Path] = []
        opts: dict[str, Any] = {}
        ingest: dict[str, Any] = {}
        limits: dict[str, float] = {}
        profile = None
        conditions = None
        env: dict[str, str] = {}
        for k, v in body.items():
            if k not in spec:
                raise err(f"{sec} {k}", f"unknown key; known keys: {_known(spec)}")
            typ = spec[k][0]
            where = f"{sec} {k}"
            if k == "logs":
                if isinstance(v, str):
                    v = [v]
                if not isinstance(v, list) or not v:
                    raise err(where, "must be a list of log files")
                logs = [_check_file(err, root, f"{where}[{i}]", p) for i, p in enumerate(v)]
            elif k == "log":
                logs = [_check_file(err, root, where, v)]
            elif typ == "path":
                p = _check_file(err, root, where, v)
                if k == "profile":
                    profile = p
                else:
                    opts[k] = p
            elif typ == "limits":
                if not isinstance(v, dict):
                    raise err(where, "must be a table, e.g. limits = { N = 0.015 }")
                for lk, lv in v.items():
                    if lk not in LIMITS.get(name, {}):
                        raise err(f"{where}.{lk}", "unknown limit; known limits: "
                                  + _known(LIMITS.get(name, {})))
                    x = _scalar(err, f"{where}.{lk}", lv, "float")
                    if x < 0:
                        raise err(f"{where}.{lk}", "a limit is a maximum of |value|; give a "
                                  "non-negative number")
                    limits[lk] = x
            elif typ == "ingest":
                if not isinstance(v, dict):
                    raise err(where, "must be a table, e.g. ingest = { temp_col = \"T1\" }")
                for ik, iv in v.items():
                    if ik not in INGEST_KEYS:
                        raise err(f"{where}.{ik}", f"unknown ingest option; known: "
                                  f"{_known(INGEST_KEYS)}")
                    if ik == "temp_col" and isinstance(iv, list):
                        if not all(isinstance(x, str) for x in iv):
                            raise err(f"{where}.{ik}", "must be a list of column names")
                    elif ik in ("scale_factor", "offset", "sample_rate"):
                        iv = _scalar(err, f"{where}.{ik}", iv, "float")
                    elif ik == "counter_bits":
                        iv = _scalar(err, f"{where}.{ik}", iv, "int")
                    elif not isinstance(iv, str):
                        raise err(f"{where}.{ik}", f"must be a string, got {iv!r}")
                    ingest[ik] = iv
            elif k == "conditions":
                conditions = _scalar(err, where, v, "str")
            elif typ == "environment":
                if not isinstance(v, dict):
                    raise err(where, "must be a table, e.g. environment = { temperature = "
                                     "\"22 ± 1 °C\" }")
                for ek, ev in v.items():
                    if ek not in ENVIRONMENT_KEYS:
                        raise err(f"{where}.{ek}", f"unknown key; known keys: "
                                  f"{_known(ENVIRONMENT_KEYS)}")
                    env[ek] = _scalar(err, f"{where}.{ek}", ev, "str")
            else:
                opts[k] = _check_option(err, where, name, k, typ, v)
        if not logs and not (name == "thermal" and "setpoints" in opts):
            key = "logs" if "logs" in TESTS[name] else "log"
            raise err(f"{sec} {key}", "missing: name the log file(s) of this test")
        if profile is not None:
            from ..core.profile import load_profile

            try:
                load_profile(profile)
            except InputError as e:
                raise err(f"{sec} profile", str(e)) from None
        files = {}
        for p in logs + ([profile] if profile else []) + [v for v in opts.values()
                                                           if isinstance(v, Path)]:
            files[_rel(root, p)] = sha256_file(p)
        tests[name] = Test(name, logs, profile, opts, ingest, limits, conditions, files, env)
    # keep IEEE order regardless of the file's order
    ordered = {k: tests[k] for k in TESTS if k in tests}
    return Campaign(path=path, sha256=sha, meta=out["campaign"], gyro=out["gyro"],
                    site=out["site"], tests=ordered, raw=data, lab=out["lab"],
                    approval=out["approval"], decision=out["decision"], equipment=equipment,
                    revisions=revisions)


def _entries(err: _Err, data: dict[str, Any], name: str, keys: dict[str, str],
             required: tuple[str, ...]) -> list[dict[str, Any]]:
    """Validate an array of tables (``[[equipment]]``, ``[[revisions]]``)."""
    body = data.get(name, [])
    if not isinstance(body, list) or not all(isinstance(e, dict) for e in body):
        raise err(f"[[{name}]]", f"must be an array of tables: write each entry under its own "
                                 f"[[{name}]] line")
    out = []
    for i, e in enumerate(body):
        where = f"[[{name}]] #{i + 1}"
        vals: dict[str, Any] = {}
        for k, v in e.items():
            if k not in keys:
                raise err(f"{where} {k}", f"unknown key; known keys: {_known(keys)}")
            if keys[k] == "strs":
                if isinstance(v, str):
                    v = [v]
                if not isinstance(v, list) or not all(isinstance(x, str) for x in v):
                    raise err(f"{where} {k}", f"must be a list of strings, got {v!r}")
                vals[k] = list(v)
            else:
                vals[k] = _scalar(err, f"{where} {k}", v, keys[k])
            if keys[k] == "date":
                try:
                    _dt.date.fromisoformat(str(vals[k])[:10])
                except ValueError:
                    raise err(f"{where} {k}", f"must be a date like 2025-03-31, got {v!r}"
                              ) from None
        for k in required:
            if k not in vals:
                raise err(f"{where} {k}", "missing (required)")
        out.append(vals)
    return out


def _rel(root: Path, p: Path) -> str:
    try:
        return p.relative_to(root.resolve()).as_posix()
    except ValueError:
        try:
            return p.relative_to(root).as_posix()
        except ValueError:
            return str(p)


def load_campaign(path: str | Path) -> Campaign:
    """Read and validate a campaign file (see the module docstring)."""
    from ..core.profile import read_toml

    data, raw = read_toml(path, not_found="campaign file not found",
                          expected="a campaign TOML file", kind="a campaign")
    return parse_campaign(data, Path(path).resolve(), hashlib.sha256(raw).hexdigest())
