"""A simulated production lot: one acceptance-test campaign per serial number.

:func:`write_lot` draws each serial's true parameters around a nominal design (bias D_F,
angle random walk N, bias instability B, scale-factor error, asymmetry) from its own seed,
simulates a static run (bias and Allan analysis) and a rate-table run (scale factor) per
serial and writes, per serial, the logs with their truth and profile files and a campaign
``campaign_<serial>.toml`` ready for ``gyrotest report`` and ``gyrotest fleet``. Optionally one
serial is made an outlier (its bias far outside the lot) and some serials get an earlier
acceptance test (a campaign dated before, with its own logs) to chart against.

The lot exercises the fleet summary with a known truth: ``lot.json`` lists every serial's true
parameters.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from datetime import date, timedelta
from pathlib import Path
from typing import Any

import numpy as np

from .writer import _toml_key, _toml_value

MODEL = "GT-FOG-100"
#: spec limits written into every lot campaign (keys of docs/campaign.md)
LIMITS: dict[str, dict[str, float]] = {
    "bias": {"bias_dph": 3.0},
    "allan": {"N": 0.012, "B": 0.1},
    "scale_factor": {"scale_factor_error_ppm": 300, "linearity_max_ppm_fs": 20,
                     "asymmetry_ppm": 50},
}


@dataclass
class LotSize:
    """Lengths of the simulated runs: static run (duration, s; rate, Hz), rate-table dwell (s)."""

    static_s: float = 2 * 3600.0
    static_hz: float = 2.0
    dwell_s: float = 30.0
    table_hz: float = 10.0


SMALL = LotSize(static_s=1800.0, static_hz=1.0, dwell_s=20.0, table_hz=10.0)


@dataclass
class LotMember:
    """One simulated campaign: serial, date, campaign file and the true parameters."""

    serial: str
    date: str
    campaign: Path
    truth: dict[str, float]
    earlier: bool = False

    def to_dict(self) -> dict[str, Any]:
        """JSON form."""
        return {"serial": self.serial, "date": self.date, "campaign": self.campaign.name,
                "earlier_test": self.earlier, "truth": self.truth}


@dataclass
class Lot:
    """What :func:`write_lot` wrote."""

    directory: Path
    members: list[LotMember] = field(default_factory=list)

    @property
    def campaigns(self) -> list[Path]:
        """Campaign files, earlier tests first (the order ``gyrotest fleet`` is given them)."""
        return [m.campaign for m in sorted(self.members, key=lambda m: (m.date, m.serial))]


def _params(rng: np.random.Generator, outlier: bool) -> dict[str, float]:
    """One serial's true parameters: a normal spread around the nominal design."""
    p = {"bias_dph": 0.42 + 0.15 * rng.standard_normal(),
         "N": 0.008 * (1 + 0.08 * rng.standard_normal()),
         "B": 0.04 * (1 + 0.15 * rng.standard_normal()),
         "offset_ppm": 85.0 + 25.0 * rng.standard_normal(),
         "asymmetry_ppm": 24.0 + 5.0 * rng.standard_normal()}
    if outlier:
        p["bias_dph"] = 2.4  # within the 3 °/h limit, far outside the lot
    return p


def _scenario(kind: str, serial: str, seed: int, p: dict[str, float], size: LotSize,
              start: str) -> dict[str, Any]:
    sc: dict[str, Any] = {
        "scenario": {"name": f"lot-{serial}-{kind}", "seed": seed},
        "record": {"sample_rate_hz": size.static_hz if kind == "static" else size.table_hz},
        "gyro": {"output": "counts", "scale_factor": 0.2, "bias_dph": p["bias_dph"],
                 "model": MODEL, "serial": serial, "type": "FOG",
                 "noise": {"N": p["N"], "B": p["B"], "B_f0_hz": 0.25}},
        "site": {"latitude_deg": 48.137, "ia": "up"},
        "file": {"start_iso": start},
    }
    if kind == "static":
        sc["record"]["duration_s"] = size.static_s
    else:
        rates = [0, 10, -10, 50, -50, 100, -100, 200, -200, 500, -500, 0]
        sc["rate_table"] = {"rates_dps": rates, "dwell_s": size.dwell_s, "settle_tau_s": 0.5,
                            "exclude_s": 10, "column": "table_dps"}
        sc["effects"] = {"scale_factor": {"offset_ppm": p["offset_ppm"],
                                          "asymmetry_ppm": p["asymmetry_ppm"],
                                          "nonlinearity_ppm": [4.0, -8.0],
                                          "full_scale_dps": 500.0}}
    return sc


def _campaign_toml(serial: str, day: str, report_id: str, static: str, table: str) -> str:
    lines = ["# Simulated acceptance-test campaign of one serial of a lot "
             "(gyrotest.simulation.lot.write_lot).",
             "[campaign]", 'title = "Acceptance test, single-axis FOG (simulated lot)"',
             'operator = "A. Tester"', f"date = {day}", f'report_id = "{report_id}"', "",
             "[gyro]", f'model = "{MODEL}"', f'serial = "{serial}"',
             "nominal_scale_factor = 0.2", 'scale_factor_unit = "arcsec/pulse"', "",
             "[site]", "latitude_deg = 48.137", ""]
    tests: dict[str, dict[str, Any]] = {
        "bias": {"logs": [static], "profile": static.rsplit(".", 1)[0] + ".profile.toml",
                 "skip": "5min"},
        "allan": {"log": static, "profile": static.rsplit(".", 1)[0] + ".profile.toml",
                  "skip": "5min", "terms": "Q,N,B"},
        "scale_factor": {"logs": [table], "profile": table.rsplit(".", 1)[0] + ".profile.toml",
                         "settle": "10s"},
    }
    for name, body in tests.items():
        lines.append(f"[tests.{name}]")
        for k, v in body.items():
            lines.append(f"{_toml_key(k)} = {_toml_value(v)}")
        lim = ", ".join(f"{_toml_key(k)} = {_toml_value(v)}" for k, v in LIMITS[name].items())
        lines += [f"limits = {{ {lim} }}", ""]
    return "\n".join(lines)


def write_lot(directory: str | Path, n: int = 6, *, seed: int = 20240, size: LotSize | None = None,
              outlier: int | None = 3, earlier: int = 2, first_serial: int = 1101) -> Lot:
    """Simulate a lot of ``n`` serials into ``directory``; returns the :class:`Lot`.

    Serial i (0-based) is ``first_serial + i`` with seed ``seed + 10·i``; serial ``outlier``
    (None: none) has a bias far outside the lot; the first ``earlier`` serials also get an
    earlier acceptance test (90 days before, bias shifted by its yearly drift). The logs are
    Parquet, the runs as long as ``size`` (default :class:`LotSize`; :data:`SMALL` for tests).
    """
    from .core import simulate
    from .writer import write_log

    size = size or LotSize()
    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    lot = Lot(d)
    day0 = date(2024, 6, 3)
    for i in range(n):
        serial = str(first_serial + i)
        rng = np.random.default_rng(seed + 10 * i)
        p = _params(rng, outlier is not None and i == outlier)
        tests = [(day0 + timedelta(days=i), p, False)]
        if i < earlier:
            q = dict(p, bias_dph=p["bias_dph"] - 0.1 - 0.05 * rng.standard_normal())
            tests.insert(0, (day0 - timedelta(days=90 - i), q, True))
        for j, (day, par, early) in enumerate(tests):
            tag = f"{serial}{'_early' if early else ''}"
            start = f"{day.isoformat()}T08:00:00"
            sfx = {}
            for k, kind in enumerate(("static", "table")):
                sc = _scenario(kind, serial, seed + 10 * i + 2 * j + k + 1, par, size, start)
                out = d / f"{tag}_{kind}.parquet"
                write_log(simulate(sc), out)
                sfx[kind] = out.name
            camp = d / f"campaign_{tag}.toml"
            camp.write_text(_campaign_toml(serial, day.isoformat(), f"LOT-{tag}", sfx["static"],
                                           sfx["table"]), encoding="utf-8")
            truth = {k: float(v) for k, v in par.items()}
            lot.members.append(LotMember(serial, day.isoformat(), camp, truth, early))
    (d / "lot.json").write_text(json.dumps({"model": MODEL, "seed": seed, "members": [
        m.to_dict() for m in lot.members]}, indent=1) + "\n", encoding="utf-8")
    return lot
