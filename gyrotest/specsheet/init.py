"""A campaign file started from a folder of logs (``gyrotest report --init DIR``).

Every log in the folder is read once (with the bench profile beside it, ``NAME.profile.toml``,
when there is one) and put into the test its channels say it belongs to:

* a rate-table column that moves → ``scale_factor`` (every such run);
* three field channels that move by more than :data:`FIELD_STEP_UT` → ``magnetic``;
* a position label column → ``multiposition``;
* temperatures spanning more than :data:`THERMAL_SPAN_C` → ``thermal``;
* a supply voltage that moves by more than :data:`SUPPLY_STEP_V` → ``supply``;
* otherwise a static run → ``bias`` (every static run) and ``allan`` (the longest).

The file says, in a comment beside each log, why it went where it did, lists the files it
could not read with the reason, and marks what only the lab can fill in (operator, date,
gyro, limits) ``FILL IN``; it is a valid campaign as written (``gyrotest report`` runs it).
Keys and their meaning: ``docs/campaign.md`` or ``gyrotest report --template``.
"""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass, field
from pathlib import Path

from ..core.errors import GyrotestError

#: suffixes of the files looked at (a ROS 2 bag is a directory holding metadata.yaml)
LOG_SUFFIXES = (".csv", ".tsv", ".txt", ".dat", ".csv.gz", ".txt.gz", ".parquet", ".feather",
                ".arrow", ".mat", ".h5", ".hdf5", ".bag", ".mcap", ".db3")
#: a thermal run: the temperatures span more than this, degC
THERMAL_SPAN_C = 5.0
#: a Helmholtz-coil run: each field channel moves by more than this, µT
FIELD_STEP_UT = 10.0
#: a supply-voltage test: the supply moves by more than this, V
SUPPLY_STEP_V = 0.1
#: what only the lab can say
FILL = "FILL IN"


@dataclass
class FoundLog:
    """One log of the folder: where it goes and why."""

    path: Path
    profile: Path | None
    test: str | None  # None: not recognised
    why: str
    duration_s: float = 0.0
    temperatures: list[str] = field(default_factory=list)
    start: str | None = None
    gyro: dict = field(default_factory=dict)
    site: dict = field(default_factory=dict)


def _log_files(folder: Path) -> list[Path]:
    out = []
    for p in sorted(folder.iterdir()):
        name = p.name.lower()
        if p.is_dir() and (p / "metadata.yaml").exists():
            out.append(p)  # a ROS 2 bag
        elif p.is_file() and name.endswith(LOG_SUFFIXES) and not name.endswith(
                (".profile.toml", ".truth.json")):
            out.append(p)
    return out


def _stem(p: Path) -> str:
    name = p.name
    for suf in (".csv.gz", ".txt.gz"):
        if name.lower().endswith(suf):
            return name[: -len(suf)]
    return p.stem


def _span(x) -> float:
    import numpy as np

    x = np.asarray(x, dtype=float)
    return float(np.nanmax(x) - np.nanmin(x)) if x.size else 0.0


def classify(path: Path) -> FoundLog:
    """Read one log (with the profile beside it) and say which test it belongs to."""
    from ..core.profile import load_profile
    from ..io.ingest import read_log

    prof_path = path.with_name(f"{_stem(path)}.profile.toml")
    prof_path = prof_path if prof_path.exists() else None
    try:
        prof = load_profile(prof_path) if prof_path else None
        g = read_log(path, profile=prof)
    except GyrotestError as e:
        return FoundLog(path, prof_path, None, f"not read: {e}")
    found = FoundLog(path, prof_path, None, "", g.duration_s, list(g.temperature),
                     g.timing.start, dict(prof.gyro) if prof else {},
                     dict(prof.site) if prof else {})
    temps = {k: _span(v) for k, v in g.temperature.items()}
    if g.table_rate is not None and _span(g.table_rate) > 0:
        import numpy as np

        top = float(np.nanmax(np.abs(g.table_rate))) / 3600.0
        found.test, found.why = "scale_factor", f"rate table up to {top:.4g} deg/s"
    elif len(g.field_uT) == 3 and all(_span(v) > FIELD_STEP_UT for v in g.field_uT.values()):
        found.test, found.why = "magnetic", (
            "three field channels stepping by up to "
            f"{max(_span(v) for v in g.field_uT.values()):.4g} µT: a Helmholtz-coil run")
    elif g.position is not None:
        labels = list(dict.fromkeys(str(x) for x in g.position))
        found.test, found.why = "multiposition", (
            f"position column ({', '.join(labels[:6])}): a multi-position test")
    elif temps and max(temps.values()) > THERMAL_SPAN_C:
        k = max(temps, key=temps.get)
        found.test, found.why = "thermal", (
            f"{k} spans {temps[k]:.3g} °C: a thermal-chamber run")
    elif g.supply is not None and _span(g.supply) > SUPPLY_STEP_V:
        found.test, found.why = "supply", (
            f"supply voltage moves by {_span(g.supply):.3g} V: a supply-voltage test")
    else:
        found.test, found.why = "bias", (
            f"static, {g.duration_s / 3600:.3g} h"
            + (f", temperatures within {max(temps.values()):.2g} °C" if temps else ""))
    return found


def _q(s: str) -> str:
    return '"' + str(s).replace("\\", "\\\\").replace('"', '\\"') + '"'


def _list(items: list[str]) -> str:
    return "[" + ", ".join(_q(x) for x in items) + "]"


def _first(found: list[FoundLog], section: str, key: str):
    return next((getattr(f, section).get(key) for f in found
                 if getattr(f, section).get(key) not in (None, "")), None)


def _profile_line(logs: list[FoundLog]) -> list[str]:
    profs = [f.profile for f in logs]
    if not any(profs):
        return ["# profile = \"bench.profile.toml\"    # FILL IN if the logs need one (columns, "
                "units, S0)"]
    from ..core.profile import load_profile

    first = next(p for p in profs if p)
    line = [f"profile = {_q(first.name)}"]
    seen = set()
    for p in profs:  # what the profiles say, not their comments or names
        d = load_profile(p).to_dict() if p else {}
        d.pop("source", None)
        seen.add(repr(sorted(d.items())))
    if len(seen) > 1:
        line[0] += "    # one profile for every log of the test: check it fits all of them"
    return line


def campaign_text(folder: str | Path, *, today: dt.date | None = None
                  ) -> tuple[str, list[FoundLog]]:
    """The commented campaign for the logs in ``folder`` and what was found (module doc)."""
    folder = Path(folder)
    found = [classify(p) for p in _log_files(folder)]
    by: dict[str, list[FoundLog]] = {}
    for f in found:
        if f.test:
            by.setdefault(f.test, []).append(f)
    starts = sorted(f.start[:10] for f in found if f.start)
    date = starts[0] if starts else (today or dt.date.today()).isoformat()
    model, serial = _first(found, "gyro", "model"), _first(found, "gyro", "serial")
    lat = _first(found, "site", "latitude_deg")
    n_ok = sum(1 for f in found if f.test)
    out = [
        f"# Campaign started by 'gyrotest report --init' from the {len(found)} log(s) in "
        f"{folder.name or folder}/ ({n_ok} recognised).",
        "# Fill in every 'FILL IN', check the test each log went to (the comment says why),",
        "# add the limits of your specification, then:",
        "#   gyrotest report campaign.toml --pdf spec.pdf",
        "# Every key: docs/campaign.md or 'gyrotest report --template'. Paths are relative to "
        "this file.",
        "",
        "[campaign]",
        f"title = {_q(FILL + ': test title')}",
        f"operator = {_q(FILL)}                    # required: who ran the tests",
        f"date = {date}                          # required: "
        + ("the first log's start" if starts else "today (the logs carry no date)"),
        "",
        "[gyro]",
        f"model = {_q(model or FILL)}" + ("" if model else "                       # required"),
        f"serial = {_q(serial or FILL)}" + ("" if serial else "                      # required"),
        "",
    ]
    if lat is not None:
        out += ["[site]", f"latitude_deg = {float(lat):g}                   # from the bench "
                "profile", ""]
    else:
        out += ["# [site]", "# latitude_deg = 48.137                   # FILL IN: every "
                "analysis removes the earth rate at this latitude", ""]
    out += ["[decision]", "rule = \"guard-band\"                      # ILAC-G8: guard band "
            "w = U", "coverage_factor = 2.0", ""]
    order = ("bias", "allan", "scale_factor", "thermal", "magnetic", "multiposition", "supply")
    static = by.get("bias", [])
    if static:
        by["allan"] = [max(static, key=lambda f: f.duration_s)]
    for test in order:
        logs = by.get(test, [])
        if not logs:
            out += [f"# [tests.{test}]                            # no log found for this test "
                    "(absent: \"not tested\")", ""]
            continue
        out.append(f"[tests.{test}]")
        if test == "allan":
            out.append(f"log = {_q(logs[0].path.name)}    # the longest static run")
        elif test in ("bias", "scale_factor"):
            out.append("logs = [")
            out += [f"    {_q(f.path.name)},    # {f.why}" for f in logs]
            out.append("]")
        else:
            out.append(f"log = {_q(logs[0].path.name)}    # {logs[0].why}")
            for extra in logs[1:]:
                out.append(f"# also {extra.path.name}: {extra.why} (one log per test)")
        out += _profile_line(logs)
        if test in ("bias", "allan"):
            out.append("# skip = \"30min\"                        # warm-up trim")
        if test == "thermal":
            t = logs[0].temperatures
            out.append(f"# sensor = {_q(t[0]) if t else FILL}   # the model's temperature "
                       "channel (default: the one that predicts held-out data best)")
            if len(t) >= 2:
                out.append(f"# gradient = {_list(t[:2])}   # two channels for D_gradTdot")
            out.append("# t_ref = 21.0                         # reference temperature, degC")
        out.append("# limits = { }                          # FILL IN: e.g. "
                   + {"bias": "bias_dph = 3.0", "allan": "N = 0.012, B = 0.06",
                      "scale_factor": "linearity_max_ppm_fs = 20",
                      "thermal": "D_T = 0.5", "magnetic": "wx = 0.7, wy = 0.7, wz = 0.7",
                      "multiposition": "azimuth_misalignment_deg = 1.0",
                      "supply": "supply_dph_per_v = 0.05"}[test])
        out.append("")
    skipped = [f for f in found if not f.test]
    if skipped:
        out.append("# files not used (give each a bench profile NAME.profile.toml beside it, "
                   "or add it by hand):")
        out += [f"#   {f.path.name}: {f.why}" for f in skipped]
        out.append("")
    return "\n".join(out), found
