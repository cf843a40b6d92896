"""Model history: the successive fits of one log, so the user watches the error fall.

Every ``gyrotest model fit ... -o model.json`` appends a step to ``model.history.json`` beside
the model (or to ``DIR/history.json`` with ``--session DIR``): which terms, which were added or
removed since the previous step of the same log, residual RMS on the fit and held-out data,
AIC/BIC, the noise floor, and the model file of that step. :func:`load_history` reads it from a
model file, a history file or a session directory.
"""

from __future__ import annotations

import datetime as _dt
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..core.errors import InputError
from ..core.output import write_json
from .schemas import HISTORY_FORMAT


@dataclass
class HistoryStep:
    """One fit in the history."""

    step: int
    time: str
    log: str
    sha256: str | None
    terms: list[str]
    added: list[str]
    removed: list[str]
    n_params: int
    rms_fit_dph: float
    rms_holdout_dph: float
    aic: float
    bic: float
    noise_floor_dph: float | None = None
    resolution_s: float | None = None
    model_file: str | None = None
    extra: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {k: v for k, v in self.__dict__.items()}

    @staticmethod
    def from_dict(d: dict) -> HistoryStep:
        keys = HistoryStep.__dataclass_fields__
        return HistoryStep(**{k: d.get(k) for k in keys if k in d or k not in
                              ("extra", "noise_floor_dph", "resolution_s", "model_file")})


def history_path_for(model_path: str | Path) -> Path:
    """``model.json`` → ``model.history.json`` (beside the model)."""
    p = Path(model_path)
    return p.with_name(p.stem + ".history.json")


def session_paths(directory: str | Path, step: int, suffix: str = ".json") -> tuple[Path, Path]:
    """(model file of step n, history file) inside a session directory."""
    d = Path(directory)
    return d / f"step-{step:02d}{suffix}", d / "history.json"


def resolve_history(path: str | Path) -> Path:
    """The history file for a model file, history file or session directory."""
    p = Path(path)
    if p.is_dir():
        return p / "history.json"
    if p.name.endswith(".history.json") or p.name == "history.json":
        return p
    return history_path_for(p)


def load_history(path: str | Path) -> list[HistoryStep]:
    """Read the steps (oldest first); InputError when there is no readable history."""
    from ..core.documents import DocumentError, load_document, path_kind
    from .schemas import history_problems

    hp = resolve_history(path)
    if path_kind(hp) == "missing":
        raise InputError(f"no model history at {hp} (fit with -o MODEL.json or --session DIR "
                         "first)")
    # not declared an input: 'model fit -o' reads it to append a step (the command line
    # declares it for 'model history', gyrotest.cli.io_roles)
    d, _ = load_document(hp, fmt="json", what="a model history", declare=False)
    problems = history_problems(d)  # every problem, naming its key (gyrotest.envmodel.schemas)
    if problems:
        raise DocumentError(str(hp), problems)
    return [HistoryStep.from_dict(s) for s in d["steps"]]


def _f(x: Any) -> float:
    try:
        return float(x)
    except (TypeError, ValueError):
        return math.nan


def make_step(res, steps: list[HistoryStep], model_file: str | None = None) -> HistoryStep:
    """A history step for a :class:`~gyrotest.envmodel.modelfit.FitResult`, diffed against the
    previous step of the same log (same sha256, or the same file name without one)."""
    data = res.data or {}
    sha = data.get("sha256")
    log = data.get("file") or data.get("source") or "log"
    prev = None
    for s in reversed(steps):
        if (sha and s.sha256 == sha) or (not sha and s.log == log):
            prev = s
            break
    terms = [t for t in res.terms if t != "bias"]
    added = [t for t in terms if prev is None or t not in prev.terms]
    removed = [t for t in (prev.terms if prev else []) if t not in terms]
    return HistoryStep(
        step=len(steps) + 1,
        time=_dt.datetime.now(_dt.UTC).replace(microsecond=0).isoformat(),
        log=str(log), sha256=sha, terms=terms, added=added, removed=removed,
        n_params=res.n_params, rms_fit_dph=res.rms_fit, rms_holdout_dph=res.rms_holdout,
        aic=res.aic, bic=res.bic,
        noise_floor_dph=res.floor.rms_dph if res.floor else None,
        resolution_s=res.resolution_s, model_file=model_file,
        extra={"noise_floor_basis": res.floor.basis} if res.floor else {})


def append_history(path: str | Path, res, model_file: str | None = None) -> HistoryStep:
    """Append a step for ``res`` to the history file at ``path`` (created if missing); written
    atomically. Returns the new step."""
    hp = Path(path)
    steps = load_history(hp) if hp.is_file() else []
    step = make_step(res, steps, model_file)
    steps.append(step)
    write_json(hp, {"format": HISTORY_FORMAT, "version": 1,
                    "steps": [s.to_dict() for s in steps]})
    return step


def steps_for_log(steps: list[HistoryStep], which: str | None = None) -> list[HistoryStep]:
    """The steps of one log (default: the log of the latest step)."""
    if not steps:
        return []
    ref = steps[-1] if which is None else next(
        (s for s in steps if s.log == which or s.sha256 == which), None)
    if ref is None:
        raise InputError(f"no steps for log {which!r} in the history")
    key = ref.sha256 or ref.log
    return [s for s in steps if (s.sha256 or s.log) == key]
