"""Scenario files for the simulator: parsing and validation into typed specs.

The format is documented in :mod:`gyrotest.simulation` (module docstring) and in
``sample_data/scenarios/README.md``. Every user mistake raises
:class:`gyrotest.core.errors.InputError` naming the file, the section and key, and the fix.
Unknown sections and keys are errors (a misspelt key would otherwise be silently ignored).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from ..core.earth import IA_DIRECTIONS, check_latitude, parse_ia
from ..core.errors import InputError
from ..core.units import parse_duration
from .specs import (
    BlueSpec,
    EffectsSpec,
    FieldSpec,
    FileSpec,
    GyroSpec,
    HelmholtzSpec,
    MarkovSpec,
    NodeSpec,
    NoiseSpec,
    PositionSpec,
    RateTableSpec,
    RecordSpec,
    RunsSpec,
    Scenario,
    SegmentSpec,
    SensorSpec,
    SineSpec,
    SiteSpec,
    SupplySpec,
    TemperatureSpec,
    ThermalTerm,
)

OUTPUT_KINDS = ("rate", "counts", "updown", "counter", "voltage")
RATE_UNITS = ("deg/h", "deg/s", "rad/s", "mrad/s", "urad/s", "deg/min", "arcsec/s")
BLUE_FAMILIES = ("blue_markov_derivative", "blue_exp", "blue_gauss")
THERMAL_KINDS = ("poly", "rate", "gradient_rate", "hysteresis", "antonova-matveev")
SEGMENT_KINDS = ("hold", "ramp", "step", "staircase", "sine")

#: Antonova & Matveev, "Model of error of a fiber-optic gyro exposed to thermal and magnetic
#: fields": FOG drift vs ambient temperature,
#: Delta-omega = w0 + w1 dT + w2 dT^2 + w_dV dT/dt, dT from t0 = 21 degC, dT/dt in degC/h.
ANTONOVA_MATVEEV = {"w0": 1.197, "w1": 0.108, "w2": 0.004, "w_dV": 1.997, "t0_c": 21.0}
#: Antonova & Matveev Helmholtz-coil test (Antonova & Matveev): 0 -> +300 -> -300 -> 0 uT in 50 uT
#: steps, 180 s per level, one axis at a time.
HELMHOLTZ_DEFAULT = {"step_uT": 50.0, "max_uT": 300.0, "dwell_s": 180.0}

_REQ = object()


class _Sec:
    """One TOML table being read: typed getters, and unknown keys are an error."""

    def __init__(self, data: Any, path: str, src: str):
        if not isinstance(data, dict):
            raise InputError(f"{src}: [{path}] must be a table of key = value lines")
        self.d = data
        self.path = path
        self.src = src
        self.known: list[str] = []

    def err(self, key: str, msg: str) -> InputError:
        return InputError(f"{self.src}: [{self.path}] {key}: {msg}")

    def has(self, key: str) -> bool:
        if key not in self.known:
            self.known.append(key)
        return key in self.d

    def get(self, key: str, kind: str, default: Any = _REQ, *, positive: bool = False,
            nonneg: bool = False, choices: tuple | None = None) -> Any:
        if key not in self.known:
            self.known.append(key)
        if key not in self.d:
            if default is _REQ:
                raise self.err(key, "missing; add it to the scenario")
            return default
        v = self.d[key]
        v = self._convert(key, v, kind)
        if choices is not None and v not in choices:
            raise self.err(key, f"{v!r} is not one of {', '.join(map(str, choices))}")
        vals = v if isinstance(v, list) else [v]
        for x in vals:
            if isinstance(x, float):
                if positive and not x > 0:
                    raise self.err(key, f"must be > 0, got {x}")
                if nonneg and x < 0:
                    raise self.err(key, f"must be >= 0, got {x}")
        return v

    def _convert(self, key: str, v: Any, kind: str) -> Any:
        def num(x: Any) -> float:
            if isinstance(x, bool) or not isinstance(x, (int, float)):
                raise self.err(key, f"must be a number, got {x!r}")
            x = float(x)
            if not math.isfinite(x):
                raise self.err(key, f"must be finite, got {x}")
            return x

        if kind == "float":
            return num(v)
        if kind == "int":
            if isinstance(v, bool) or not isinstance(v, int):
                raise self.err(key, f"must be an integer, got {v!r}")
            return int(v)
        if kind == "str":
            if not isinstance(v, str):
                raise self.err(key, f"must be a string, got {v!r}")
            return v
        if kind == "bool":
            if not isinstance(v, bool):
                raise self.err(key, f"must be true or false, got {v!r}")
            return v
        if kind == "duration":
            if isinstance(v, bool):
                raise self.err(key, f"must be a duration (seconds or e.g. \"40min\"), got {v!r}")
            if isinstance(v, (int, float)):
                return num(v)
            if isinstance(v, str):
                return parse_duration(v, what=f"[{self.path}] {key}")
            raise self.err(key, f"must be a duration (seconds or e.g. \"40min\"), got {v!r}")
        if kind == "floats":
            if isinstance(v, (int, float)) and not isinstance(v, bool):
                return [num(v)]
            if not isinstance(v, list):
                raise self.err(key, f"must be a list of numbers, got {v!r}")
            return [num(x) for x in v]
        if kind == "strs":
            if isinstance(v, str):
                return [v]
            if not isinstance(v, list) or not all(isinstance(x, str) for x in v):
                raise self.err(key, f"must be a list of strings, got {v!r}")
            return list(v)
        if kind == "pairs":
            if not isinstance(v, list) or not all(
                isinstance(p, list) and len(p) == 2 for p in v
            ):
                raise self.err(key, f"must be a list of [a, b] pairs, got {v!r}")
            return [(num(a), num(b)) for a, b in v]
        if kind == "table":
            if not isinstance(v, dict):
                raise self.err(key, f"must be a table {{...}}, got {v!r}")
            return v
        if kind == "tables":
            if isinstance(v, dict):
                return [v]
            if not isinstance(v, list) or not all(isinstance(x, dict) for x in v):
                raise self.err(key, "must be a list of tables ([[...]] or [{...}, ...])")
            return v
        raise AssertionError(kind)

    def sub(self, key: str, index: int | None = None) -> _Sec | None:
        if key not in self.known:
            self.known.append(key)
        if key not in self.d:
            return None
        v = self.d[key]
        path = f"{self.path}.{key}" if self.path else key
        if index is not None:
            path = f"{path}[{index}]"
        return _Sec(v, path, self.src)

    def done(self) -> None:
        unknown = [k for k in self.d if k not in self.known]
        if unknown:
            where = f"[{self.path}]" if self.path else "the top level"
            raise InputError(
                f"{self.src}: unknown key {unknown[0]!r} in {where}; known keys: "
                + ", ".join(self.known)
            )


# The parsed scenario types are in :mod:`.specs`.


# ---------------------------------------------------------------------------------- parsing


def load_scenario(scenario: dict | str | Path | Scenario) -> Scenario:
    """Read and validate a scenario from a TOML path or an already parsed dict."""
    if isinstance(scenario, Scenario):
        return scenario
    if isinstance(scenario, dict):
        return parse_scenario(scenario, source="scenario")
    from ..core.documents import load_document

    p = Path(scenario)
    data, _ = load_document(p, fmt="toml", what="a scenario",
                            not_found="scenario file not found; check the path")
    return parse_scenario(data, source=str(p))


def _position(sec: _Sec, *, need_dwell: bool) -> PositionSpec:
    dwell = sec.get("dwell_s", "duration", _REQ if need_dwell else 0.0, positive=need_dwell)
    label = sec.get("label", "str", None)
    if sec.has("ia_azimuth_deg") or sec.has("ia_elevation_deg"):
        if sec.has("ia"):
            raise sec.err("ia", "give either ia or ia_azimuth_deg + ia_elevation_deg, not both")
        az = sec.get("ia_azimuth_deg", "float", 0.0)
        el = sec.get("ia_elevation_deg", "float", 0.0)
        if not -90.0 <= el <= 90.0:
            raise sec.err("ia_elevation_deg", f"must be within -90...90 deg, got {el}")
        lab = label or f"az{az:g}_el{el:g}"
        return PositionSpec(lab, az % 360.0, el, dwell, False)
    ia = sec.get("ia", "str", "up")
    try:
        az, el, lab = parse_ia(ia)
    except InputError as e:
        raise sec.err("ia", str(e)) from None
    named = lab in IA_DIRECTIONS
    return PositionSpec(label or (lab if named else f"az{az:g}_el{el:g}"), az, el, dwell, named)


def parse_scenario(data: dict, source: str = "scenario") -> Scenario:
    """Validate a parsed scenario dict (see the :mod:`gyrotest.simulation` docstring)."""
    top = _Sec(data, "", source)
    # [scenario]
    name, desc, seed = Path(source).stem if source != "scenario" else "scenario", "", None
    s = top.sub("scenario")
    if s is not None:
        name = s.get("name", "str", name)
        desc = s.get("description", "str", "")
        seed = s.get("seed", "int", None)
        s.done()
    # [record]
    rec = RecordSpec()
    s = top.sub("record")
    if s is not None:
        rec.sample_rate_hz = s.get("sample_rate_hz", "float", 10.0, positive=True)
        rec.duration_s = s.get("duration_s", "duration", None)
        if rec.duration_s is not None and rec.duration_s <= 0:
            raise s.err("duration_s", "must be > 0")
        s.done()
    gyro = _parse_gyro(top.sub("gyro"), source, rec)
    site = _parse_site(top.sub("site"))
    env = top.sub("environment")
    temp = fld = sup = None
    if env is not None:
        temp = _parse_temperature(env.sub("temperature"))
        fld = _parse_field(env.sub("field"))
        sup = _parse_supply(env.sub("supply"))
        env.done()
    effects = _parse_effects(top.sub("effects"))
    table = _parse_table(top.sub("rate_table"))
    runs = _parse_runs(top.sub("runs"))
    fil = _parse_file(top.sub("file"))
    top.done()
    sc = Scenario(name=name, description=desc, seed=seed, record=rec, gyro=gyro, site=site,
                  temperature=temp, field=fld, supply=sup, effects=effects, rate_table=table,
                  runs=runs, file=fil, raw=data, source=source)
    _cross_check(sc)
    return sc


def _parse_gyro(s: _Sec | None, source: str, rec: RecordSpec) -> GyroSpec:
    g = GyroSpec()
    if s is None:
        return g
    g.output = s.get("output", "str", "rate", choices=OUTPUT_KINDS)
    g.rate_unit = s.get("rate_unit", "str", "deg/h", choices=RATE_UNITS)
    g.scale_factor = s.get("scale_factor", "float", None, positive=True)
    if g.output != "rate" and g.scale_factor is None:
        unit = "(deg/h)/V" if g.output == "voltage" else "arcsec/pulse"
        raise s.err("scale_factor", f"missing: output {g.output!r} needs S0 in {unit}")
    g.bias_dph = s.get("bias_dph", "float", 0.0)
    g.counter_bits = s.get("counter_bits", "int", 32)
    if g.counter_bits not in (16, 24, 32, 48, 64):
        raise s.err("counter_bits", "use 16, 24, 32, 48 or 64")
    g.counter_start = s.get("counter_start", "int", None)
    if g.counter_start is not None and not 0 <= g.counter_start < 2**g.counter_bits:
        raise s.err("counter_start", f"must be within 0...2^{g.counter_bits}-1")
    g.dither_counts = s.get("dither_counts", "float", 0.0, nonneg=True)
    g.offset_v = s.get("offset_v", "float", 0.0)
    g.adc_bits = s.get("adc_bits", "int", 0)
    if not 0 <= g.adc_bits <= 32:
        raise s.err("adc_bits", "must be 0 (no ADC) ... 32")
    rng = s.get("adc_range_v", "floats", [0.0, 5.0])
    if len(rng) != 2 or rng[1] <= rng[0]:
        raise s.err("adc_range_v", "must be [low, high] with high > low")
    g.adc_range_v = (rng[0], rng[1])
    g.model = s.get("model", "str", None)
    g.serial = s.get("serial", "str", None)
    g.type = s.get("type", "str", None)
    ns = s.sub("noise")
    if ns is not None:
        g.noise = _parse_noise(ns, rec)
    s.done()
    return g


def _parse_noise(s: _Sec, rec: RecordSpec) -> NoiseSpec:
    n = NoiseSpec()
    n.N = s.get("N", "float", 0.0, nonneg=True)
    n.B = s.get("B", "float", 0.0, nonneg=True)
    n.B_f0_hz = s.get("B_f0_hz", "float", None, positive=True)
    if n.B_f0_hz is not None and n.B_f0_hz > 0.5 * rec.sample_rate_hz * (1 + 1e-12):
        raise s.err("B_f0_hz", f"the cut-off {n.B_f0_hz} Hz is above the Nyquist frequency "
                    f"{0.5 * rec.sample_rate_hz:g} Hz; lower it or raise [record] sample_rate_hz")
    n.K = s.get("K", "float", 0.0, nonneg=True)
    n.R = s.get("R", "float", 0.0)
    n.Q = s.get("Q", "float", 0.0, nonneg=True)
    n.fft_padding = s.get("fft_padding", "int", 4)
    if n.fft_padding < 1:
        raise s.err("fft_padding", "must be >= 1")
    for i, t in enumerate(s.get("markov", "tables", [])):
        m = _Sec(t, f"gyro.noise.markov[{i}]", s.src)
        T_c = m.get("T_c", "float", positive=True)
        if m.has("sigma_dph"):
            if m.has("q_c"):
                raise m.err("sigma_dph", "give either q_c or sigma_dph, not both")
            sig = m.get("sigma_dph", "float", nonneg=True)
            q_c = 60.0 * sig / math.sqrt(T_c / 2.0)  # process std = q_c_int sqrt(T_c/2)
        else:
            q_c = m.get("q_c", "float", nonneg=True)
        m.done()
        n.markov.append(MarkovSpec(q_c, T_c))
    for i, t in enumerate(s.get("sinusoid", "tables", [])):
        m = _Sec(t, f"gyro.noise.sinusoid[{i}]", s.src)
        amp = m.get("amplitude_dph", "float", nonneg=True)
        f0 = m.get("freq_hz", "float", positive=True)
        ph = m.get("phase_deg", "float", None)
        m.done()
        n.sinusoid.append(SineSpec(amp, f0, ph))
    for i, t in enumerate(s.get("blue", "tables", [])):
        m = _Sec(t, f"gyro.noise.blue[{i}]", s.src)
        fam = m.get("family", "str", choices=BLUE_FAMILIES)
        alpha = m.get("alpha", "float", nonneg=True)
        beta = m.get("beta", "float", positive=True)
        nn = m.get("n", "float", None)
        if fam == "blue_markov_derivative":
            if nn is not None:
                raise m.err("n", "the family blue_markov_derivative has no n")
        elif nn is None:
            raise m.err("n", f"missing: the family {fam} needs the power n")
        elif fam == "blue_exp" and nn < 1 or fam == "blue_gauss" and nn <= 1:
            raise m.err("n", "must be >= 1 for blue_exp, > 1 for blue_gauss")
        m.done()
        n.blue.append(BlueSpec(fam, alpha, beta, nn))
    s.done()
    return n


def _parse_site(s: _Sec | None) -> SiteSpec:
    site = SiteSpec()
    if s is None:
        site.ia = PositionSpec("up", 0.0, 90.0, 0.0, True)
        return site
    site.given = True
    lat = s.get("latitude_deg", "float", 0.0)
    try:
        site.latitude_deg = check_latitude(lat)
    except InputError as e:
        raise s.err("latitude_deg", str(e)) from None
    pos = s.get("positions", "tables", [])
    if pos:
        for k in ("ia", "ia_azimuth_deg", "ia_elevation_deg"):
            if s.has(k):
                raise s.err(k, "give the IA per position in [[site.positions]], not both")
        for i, t in enumerate(pos):
            ps = _Sec(t, f"site.positions[{i}]", s.src)
            site.positions.append(_position(ps, need_dwell=True))
            ps.done()
    else:
        site.ia = _position(s, need_dwell=False)
    s.done()
    return site


def _parse_segment(t: dict, i: int, src: str) -> SegmentSpec:
    s = _Sec(t, f"environment.temperature.profile[{i}]", src)
    kind = s.get("kind", "str", choices=SEGMENT_KINDS)
    p: dict[str, Any] = {}
    if kind == "hold":
        p["duration_s"] = s.get("duration_s", "duration", positive=True)
        p["value_c"] = s.get("value_c", "float", None)
    elif kind == "ramp":
        p["to_c"] = s.get("to_c", "float")
        p["rate_c_per_h"] = s.get("rate_c_per_h", "float", None, positive=True)
        p["duration_s"] = s.get("duration_s", "duration", None)
        if (p["rate_c_per_h"] is None) == (p["duration_s"] is None):
            raise s.err("rate_c_per_h", "give exactly one of rate_c_per_h or duration_s")
    elif kind == "step":
        p["to_c"] = s.get("to_c", "float")
    elif kind == "staircase":
        p["levels_c"] = s.get("levels_c", "floats")
        if not p["levels_c"]:
            raise s.err("levels_c", "must list at least one set-point")
        p["dwell_s"] = s.get("dwell_s", "duration", positive=True)
        p["ramp_c_per_h"] = s.get("ramp_c_per_h", "float", 0.0, nonneg=True)
    elif kind == "sine":
        p["amplitude_c"] = s.get("amplitude_c", "float")
        p["period_s"] = s.get("period_s", "duration", positive=True)
        p["cycles"] = s.get("cycles", "float", None, positive=True)
        p["duration_s"] = s.get("duration_s", "duration", None)
        if (p["cycles"] is None) == (p["duration_s"] is None):
            raise s.err("cycles", "give exactly one of cycles or duration_s")
    s.done()
    return SegmentSpec(kind, p)


def _parse_temperature(s: _Sec | None) -> TemperatureSpec | None:
    if s is None:
        return None
    t = TemperatureSpec()
    t.initial_c = s.get("initial_c", "float", 21.0)
    for i, seg in enumerate(s.get("profile", "tables", [])):
        t.segments.append(_parse_segment(seg, i, s.src))
    names = {"ambient"}
    for i, nd in enumerate(s.get("nodes", "tables", [])):
        ns = _Sec(nd, f"environment.temperature.nodes[{i}]", s.src)
        name = ns.get("name", "str")
        if name in names:
            raise ns.err("name", f"node {name!r} is defined twice (or is the reserved 'ambient')")
        node = NodeSpec(name=name, tau_s=ns.get("tau_s", "duration", positive=True),
                        input=ns.get("input", "str", "ambient"),
                        initial_c=ns.get("initial_c", "float", None))
        if node.input not in names:
            raise ns.err("input", f"unknown node {node.input!r}; define it before this node "
                         f"(known: {', '.join(sorted(names))})")
        ns.done()
        names.add(name)
        t.nodes.append(node)
    cols: set[str] = set()
    for i, sn in enumerate(s.get("sensors", "tables", [])):
        ss = _Sec(sn, f"environment.temperature.sensors[{i}]", s.src)
        sen = SensorSpec(
            column=ss.get("column", "str"),
            node=ss.get("node", "str", "ambient"),
            tau_s=ss.get("tau_s", "duration", 0.0),
            noise_c=ss.get("noise_c", "float", 0.0, nonneg=True),
            offset_c=ss.get("offset_c", "float", 0.0),
            resolution_c=ss.get("resolution_c", "float", 0.0, nonneg=True),
        )
        if sen.node not in names:
            raise ss.err("node", f"unknown node {sen.node!r}; known: {', '.join(sorted(names))}")
        if sen.column in cols:
            raise ss.err("column", f"column {sen.column!r} is used twice")
        cols.add(sen.column)
        ss.done()
        t.sensors.append(sen)
    s.done()
    return t


def _axes3(s: _Sec, key: str, default: tuple) -> tuple[float, float, float]:
    v = s.get(key, "floats", list(default))
    if len(v) != 3:
        raise s.err(key, "must list three values [x, y, z]")
    return (v[0], v[1], v[2])


def _parse_field(s: _Sec | None) -> FieldSpec | None:
    if s is None:
        return None
    f = FieldSpec()
    f.background_uT = _axes3(s, "background_uT", (0.0, 0.0, 0.0))
    f.noise_uT = s.get("noise_uT", "float", 0.0, nonneg=True)
    f.random_walk_uT_per_sqrt_h = s.get("random_walk_uT_per_sqrt_h", "float", 0.0, nonneg=True)
    f.sine_amplitude_uT = _axes3(s, "sine_amplitude_uT", (0.0, 0.0, 0.0))
    f.sine_period_s = s.get("sine_period_s", "duration", 3600.0)
    f.columns = s.get("columns", "strs", ["Hx_uT", "Hy_uT", "Hz_uT"])
    if f.columns and len(f.columns) != 3:
        raise s.err("columns", "must name three columns [x, y, z] (or [] for none)")
    h = s.sub("helmholtz")
    if h is not None:
        axes = h.get("axes", "strs", ["x", "y", "z"])
        for a in axes:
            if a not in ("x", "y", "z"):
                raise h.err("axes", f"unknown axis {a!r}; use x, y, z")
        f.helmholtz = HelmholtzSpec(
            axes=axes,
            step_uT=h.get("step_uT", "float", HELMHOLTZ_DEFAULT["step_uT"], positive=True),
            max_uT=h.get("max_uT", "float", HELMHOLTZ_DEFAULT["max_uT"], positive=True),
            dwell_s=h.get("dwell_s", "duration", HELMHOLTZ_DEFAULT["dwell_s"]),
            start_s=h.get("start_s", "duration", 0.0),
            pause_s=h.get("pause_s", "duration", 0.0),
        )
        if f.helmholtz.dwell_s <= 0:
            raise h.err("dwell_s", "must be > 0")
        h.done()
    s.done()
    return f


def _parse_supply(s: _Sec | None) -> SupplySpec | None:
    if s is None:
        return None
    p = SupplySpec()
    p.nominal_v = s.get("nominal_v", "float", 15.0)
    p.steps = s.get("steps", "pairs", [])
    p.drift_v_per_h = s.get("drift_v_per_h", "float", 0.0)
    p.ripple_v = s.get("ripple_v", "float", 0.0, nonneg=True)
    p.ripple_hz = s.get("ripple_hz", "float", 50.0, positive=True)
    p.noise_v = s.get("noise_v", "float", 0.0, nonneg=True)
    p.column = s.get("column", "str", "vsupply")
    s.done()
    return p


def _parse_thermal(t: dict, i: int, src: str) -> ThermalTerm:
    s = _Sec(t, f"effects.thermal[{i}]", src)
    kind = s.get("kind", "str", choices=THERMAL_KINDS)
    term = ThermalTerm(kind=kind)
    term.node = s.get("node", "str", "ambient")
    if kind == "poly":
        term.t_ref_c = s.get("t_ref_c", "float", 21.0)
        term.D_T = s.get("D_T", "float", 0.0)
        term.D_T2 = s.get("D_T2", "float", 0.0)
        term.D_T3 = s.get("D_T3", "float", 0.0)
    elif kind == "rate":
        term.D_Tdot = s.get("D_Tdot", "float")
    elif kind == "gradient_rate":
        nodes = s.get("nodes", "strs")
        if len(nodes) != 2:
            raise s.err("nodes", "must name two temperature nodes [a, b] (gradient a - b)")
        term.nodes = (nodes[0], nodes[1])
        term.D_gradTdot = s.get("D_gradTdot", "float")
    elif kind == "hysteresis":
        term.amplitude_dph = s.get("amplitude_dph", "float")
        term.width_c = s.get("width_c", "float", 0.5, positive=True)
    else:  # antonova-matveev preset
        am = ANTONOVA_MATVEEV
        term.w0 = s.get("w0", "float", am["w0"])
        term.D_T = s.get("w1", "float", am["w1"])
        term.D_T2 = s.get("w2", "float", am["w2"])
        term.D_Tdot = s.get("w_dV", "float", am["w_dV"])
        term.t_ref_c = s.get("t0_c", "float", am["t0_c"])
    s.done()
    return term


def _parse_effects(s: _Sec | None) -> EffectsSpec:
    e = EffectsSpec()
    if s is None:
        return e
    for i, t in enumerate(s.get("thermal", "tables", [])):
        e.thermal.append(_parse_thermal(t, i, s.src))
    m = s.sub("magnetic")
    if m is not None:
        e.magnetic_w = _axes3(m, "w_dph_per_100uT", (0.0, 0.0, 0.0))
        m.done()
    p = s.sub("supply")
    if p is not None:
        e.supply_dph_per_v = p.get("dph_per_v", "float")
        p.done()
    w = s.sub("warmup")
    if w is not None:
        e.warmup_amplitude_dph = w.get("amplitude_dph", "float")
        e.warmup_tau_s = w.get("tau_s", "duration", positive=True)
        w.done()
    f = s.sub("scale_factor")
    if f is not None:
        sf = e.scale_factor
        sf.offset_ppm = f.get("offset_ppm", "float", 0.0)
        sf.asymmetry_ppm = f.get("asymmetry_ppm", "float", 0.0)
        sf.nonlinearity_ppm = f.get("nonlinearity_ppm", "floats", [])
        sf.full_scale_dps = f.get("full_scale_dps", "float", None, positive=True)
        sf.periodic_ppm = f.get("periodic_ppm", "float", 0.0)
        sf.periodic_period_dps = f.get("periodic_period_dps", "float", 10.0, positive=True)
        sf.periodic_phase_deg = f.get("periodic_phase_deg", "float", 0.0)
        sf.temp_ppm_per_c = f.get("temp_ppm_per_c", "float", 0.0)
        sf.node = f.get("node", "str", "ambient")
        sf.t_ref_c = f.get("t_ref_c", "float", 21.0)
        sf.lock_in_dph = f.get("lock_in_dph", "float", 0.0, nonneg=True)
        sf.saturation_dps = f.get("saturation_dps", "float", None, positive=True)
        f.done()
    s.done()
    return e


def _parse_table(s: _Sec | None) -> RateTableSpec | None:
    if s is None:
        return None
    rates = s.get("rates_dps", "floats")
    if not rates:
        raise s.err("rates_dps", "must list at least one plateau rate")
    dwell = s.get("dwell_s", "floats", [60.0])
    if len(dwell) == 1:
        dwell = dwell * len(rates)
    if len(dwell) != len(rates) or any(d <= 0 for d in dwell):
        raise s.err("dwell_s", f"give one positive dwell or one per plateau ({len(rates)})")
    col = s.get("column", "str", "table_dps")
    t = RateTableSpec(
        rates_dps=rates,
        dwell_s=dwell,
        settle_tau_s=s.get("settle_tau_s", "float", 0.5, nonneg=True),
        exclude_s=s.get("exclude_s", "float", 5.0, nonneg=True),
        column=col or None,
    )
    if any(t.exclude_s >= d for d in dwell):
        raise s.err("exclude_s", "the settling window must be shorter than every dwell")
    s.done()
    return t


def _parse_runs(s: _Sec | None) -> RunsSpec:
    r = RunsSpec()
    if s is None:
        return r
    r.count = s.get("count", "int", 1)
    if r.count < 1:
        raise s.err("count", "must be >= 1")
    r.sf_offsets_ppm = s.get("sf_offsets_ppm", "floats", None)
    r.sf_sigma_ppm = s.get("sf_sigma_ppm", "float", 0.0, nonneg=True)
    r.bias_offsets_dph = s.get("bias_offsets_dph", "floats", None)
    r.bias_sigma_dph = s.get("bias_sigma_dph", "float", 0.0, nonneg=True)
    for key in ("sf_offsets_ppm", "bias_offsets_dph"):
        v = getattr(r, key)
        if v is not None and len(v) != r.count:
            raise s.err(key, f"must list one value per run ({r.count})")
    s.done()
    return r


def _parse_file(s: _Sec | None) -> FileSpec:
    f = FileSpec()
    if s is None:
        return f
    f.time = s.get("time", "str", "seconds", choices=("seconds", "iso", "none"))
    f.time_column = s.get("time_column", "str", None)
    f.t0_s = s.get("t0_s", "float", 0.0)
    f.start_iso = s.get("start_iso", "str", f.start_iso)
    try:
        import numpy as np

        np.datetime64(f.start_iso.rstrip("Z"), "us")
    except ValueError:
        raise s.err("start_iso", f"cannot read {f.start_iso!r}; write e.g. "
                    "2024-05-01T08:00:00") from None
    f.output_column = s.get("output_column", "str", None)
    f.up_column = s.get("up_column", "str", "up")
    f.down_column = s.get("down_column", "str", "down")
    f.position_column = s.get("position_column", "str", "pos")
    fs = s.sub("faults")
    if fs is not None:
        f.faults.drop = fs.get("drop", "pairs", [])
        f.faults.drop_random = fs.get("drop_random", "int", 0)
        f.faults.jitter_s = fs.get("jitter_s", "float", 0.0, nonneg=True)
        f.faults.duplicate_rows = fs.get("duplicate_rows", "int", 0)
        if f.faults.drop_random < 0 or f.faults.duplicate_rows < 0:
            raise fs.err("drop_random", "counts must be >= 0")
        fs.done()
    s.done()
    return f


def _cross_check(sc: Scenario) -> None:
    src = sc.source
    nodes = {"ambient"} | {n.name for n in (sc.temperature.nodes if sc.temperature else [])}
    for i, t in enumerate(sc.effects.thermal):
        used = list(t.nodes) if t.nodes else [t.node]
        for n in used:
            if n not in nodes:
                raise InputError(f"{src}: [effects.thermal[{i}]] node {n!r} is not defined; "
                                 f"known temperature nodes: {', '.join(sorted(nodes))} (add "
                                 "[[environment.temperature.nodes]])")
    sf = sc.effects.scale_factor
    if sf.temp_ppm_per_c and sf.node not in nodes:
        raise InputError(f"{src}: [effects.scale_factor] node {sf.node!r} is not defined; known: "
                         f"{', '.join(sorted(nodes))}")
    if sc.effects.magnetic_w is not None and sc.field is None:
        raise InputError(f"{src}: [effects.magnetic] needs a field: add [environment.field]")
    if sc.effects.supply_dph_per_v and sc.supply is None:
        raise InputError(f"{src}: [effects.supply] needs [environment.supply]")
    faults = sc.file.faults
    if sc.file.time == "none" and (faults.drop or faults.drop_random or faults.jitter_s
                                   or faults.duplicate_rows):
        raise InputError(f"{src}: [file.faults] need a time column; set [file] time = "
                         "\"seconds\" or \"iso\"")
    tau0 = 1.0 / sc.record.sample_rate_hz
    if faults.jitter_s > 0.2 * tau0:
        raise InputError(f"{src}: [file.faults] jitter_s {faults.jitter_s} s is too large for the "
                         f"sample interval {tau0:g} s (keep it below 0.2 tau0, timestamps must "
                         "stay increasing)")
