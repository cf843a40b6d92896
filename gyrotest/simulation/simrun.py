"""The result of a simulation (:func:`gyrotest.simulation.simulate`): one :class:`SimRun` per run
(its columns, truth and profile) in a :class:`SimResult`."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..core.output import jsonable
from .specs import Scenario


@dataclass
class SimRun:
    """One simulated run (one log file).

    Arrays are per sample interval k (n values); ``t`` is the end of each interval in s from
    the start of the run. ``columns`` is the file content in column order after the optional
    faults (the counter kind has one more row: the initial counter value).
    """

    index: int
    tau0: float
    t: np.ndarray
    rate_dph: np.ndarray  # what the file encodes, as deg/h (after pulse/ADC quantization)
    ideal_rate_dph: np.ndarray  # S0 dN/dt before the output quantization
    noise_free_rate_dph: np.ndarray  # all random terms off
    input_dph: np.ndarray  # I = table + earth
    components: dict[str, np.ndarray]
    env: dict[str, Any]
    columns: dict[str, np.ndarray]
    truth: dict[str, Any]
    profile: dict[str, Any]

    @property
    def n(self) -> int:
        return int(self.t.size)

    def to_dict(self, include_data: bool = False) -> dict[str, Any]:
        """JSON-safe summary (truth, profile, column names; the data only on request)."""
        d: dict[str, Any] = {"run": self.index, "samples": self.n, "tau0_s": self.tau0,
                             "columns": list(self.columns), "truth": self.truth,
                             "profile": self.profile}
        if include_data:
            d["data"] = {k: np.asarray(v).tolist() for k, v in self.columns.items()}
        return jsonable(d)


@dataclass
class SimResult:
    """Result of :func:`gyrotest.simulation.simulate`: one :class:`SimRun` per run plus the scenario summary.

    For a single run the convenience properties (``t``, ``rate_dph``, ``columns``, ``truth``,
    ``profile``) refer to it; ``truth`` of a multi-run result is the summary (per-run truths
    under ``truth["runs"]``).
    """

    name: str
    seed: int
    scenario: Scenario
    runs: list[SimRun] = field(default_factory=list)
    summary: dict[str, Any] = field(default_factory=dict)

    @property
    def run(self) -> SimRun:
        return self.runs[0]

    @property
    def t(self) -> np.ndarray:
        return self.runs[0].t

    @property
    def rate_dph(self) -> np.ndarray:
        return self.runs[0].rate_dph

    @property
    def columns(self) -> dict[str, np.ndarray]:
        return self.runs[0].columns

    @property
    def profile(self) -> dict[str, Any]:
        return self.runs[0].profile

    @property
    def truth(self) -> dict[str, Any]:
        return self.runs[0].truth if len(self.runs) == 1 else self.summary

    def to_dict(self, include_data: bool = False) -> dict[str, Any]:
        """JSON-safe: name, seed, multi-run summary and every run's :meth:`SimRun.to_dict`."""
        return jsonable({"name": self.name, "seed": self.seed, "summary": self.summary,
                         "runs": [r.to_dict(include_data) for r in self.runs]})
