"""A fitted environmental model as a portable object: terms, coefficients with units and
uncertainties, reference values, nonlinear parameters, and the data it came from.

Saved as JSON (``.json``) or TOML (``.toml``); :meth:`EnvModel.predict` applies it to any log
with the same channels (for ``gyrotest compensate``). Prediction uses the same effect
functions as the fit: pointwise terms at full rate, smooth terms (derivatives, lags,
transients) on a 1-s grid interpolated to full rate.
"""

from __future__ import annotations

import datetime as _dt
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .. import __version__
from ..core.errors import InputError
from ..core.output import jsonable, write_text
from .schemas import FORMAT
from .terms import EFFECTS, Refs, TermSpec, build_term, frame_from_log, resolve_terms

FORMAT_VERSION = 1


@dataclass
class ModelTerm:
    """One fitted term: spec, nonlinear parameters, coefficient values and 1σ (GLS)."""

    spec: TermSpec
    theta: dict[str, float] = field(default_factory=dict)
    theta_stderr: dict[str, float] = field(default_factory=dict)
    coef: list[float] = field(default_factory=list)
    coef_stderr: list[float] = field(default_factory=list)

    def to_dict(self) -> dict:
        e = self.spec.effect
        d = self.spec.to_dict()
        d["effect"] = e.title if self.spec.key != "custom" else f"user term {self.spec.expr}"
        d["formula"] = e.formula if self.spec.key != "custom" else str(self.spec.expr)
        d["source"] = e.source
        d["coefficients"] = [
            {"name": n, "symbol": s, "value": v, "stderr": u, "unit": e.coef_unit}
            for n, s, v, u in zip(self.spec.coef_labels(), self.spec.coef_symbols, self.coef,
                                  self.coef_stderr)
        ]
        if self.theta:
            units = {p.name: p.unit for p in e.nonlinear}
            d["nonlinear"] = [{"name": k, "value": v, "stderr": self.theta_stderr.get(k),
                               "unit": units.get(k, "")} for k, v in self.theta.items()]
        return d

    @staticmethod
    def from_dict(d: dict) -> ModelTerm:
        spec = TermSpec.from_dict(d)
        coefs = d.get("coefficients") or []
        nl = d.get("nonlinear") or []
        return ModelTerm(spec, {x["name"]: float(x["value"]) for x in nl},
                         {x["name"]: _f(x.get("stderr")) for x in nl},
                         [float(c["value"]) for c in coefs], [_f(c.get("stderr")) for c in coefs])


def _f(x) -> float:
    return float("nan") if x is None else float(x)


@dataclass
class EnvModel:
    """A fitted drift model ``ω − Ω_in = Σ coef·regressor`` (deg/h)."""

    terms: list[ModelTerm]
    refs: Refs
    axis: str = "rate"
    resolution_s: float = 1.0
    fine_dt_s: float = 1.0
    fit: dict[str, Any] = field(default_factory=dict)
    data: dict[str, Any] = field(default_factory=dict)
    created: str = field(default_factory=lambda: _dt.datetime.now(_dt.UTC)
                         .replace(microsecond=0).isoformat())

    @property
    def specs(self) -> list[TermSpec]:
        return [t.spec for t in self.terms]

    def coefficient(self, label: str, idx: int = 0) -> float:
        """Value of a term's coefficient by term label (e.g. ``dTdt(T_case)``) or key."""
        for t in self.terms:
            if t.spec.label == label or t.spec.key == label:
                return t.coef[idx]
        raise KeyError(label)

    def to_dict(self) -> dict:
        return {
            "format": FORMAT, "format_version": FORMAT_VERSION,
            "gyrotest_version": __version__, "created": self.created,
            "equation": "rate - input_rate [deg/h] = sum(coefficient * regressor)",
            "axis": self.axis, "resolution_s": self.resolution_s, "fine_dt_s": self.fine_dt_s,
            "references": self.refs.to_dict(),
            "terms": [t.to_dict() for t in self.terms],
            "fit": self.fit, "data": self.data,
        }

    @staticmethod
    def from_dict(d: dict, source: str = "model") -> EnvModel:
        if d.get("format") != FORMAT:
            raise InputError(f"{source}: not a gyrotest model file (format {d.get('format')!r})")
        try:
            terms = [ModelTerm.from_dict(x) for x in d["terms"]]
            for t in terms:
                if t.spec.key not in EFFECTS:
                    raise InputError(f"{source}: unknown term {t.spec.key!r}")
            return EnvModel(terms=terms, refs=Refs.from_dict(d.get("references") or {}),
                            axis=d.get("axis", "rate"), resolution_s=float(d["resolution_s"]),
                            fine_dt_s=float(d.get("fine_dt_s", 1.0)), fit=d.get("fit") or {},
                            data=d.get("data") or {}, created=d.get("created", ""))
        except (KeyError, TypeError, ValueError) as e:
            raise InputError(f"{source}: malformed model file ({type(e).__name__}: {e})") from None

    # ------------------------------------------------------------------ I/O
    def save(self, path: str | Path) -> Path:
        """Write the model atomically as JSON (.json) or TOML (.toml)."""
        p = Path(path)
        suf = p.suffix.lower()
        if suf == ".toml":
            write_text(p, to_toml(jsonable(self.to_dict())))
        elif suf in (".json", ""):
            write_text(p, json.dumps(jsonable(self.to_dict()), indent=2, ensure_ascii=False)
                       + "\n")
        else:
            raise InputError(f"model file {p}: unknown format {p.suffix!r}; use .json or .toml")
        return p

    @staticmethod
    def load(path: str | Path) -> EnvModel:
        from ..core.documents import DocumentError, load_document
        from .schemas import model_problems

        p = Path(path)
        d, _ = load_document(p, what="the model file", not_found="model file not found; give a "
                             "file written by 'gyrotest model fit -o' (or thermal-fit/mag-fit)")
        problems = model_problems(d)  # every problem, naming its key (gyrotest.envmodel.schemas)
        if problems:
            raise DocumentError(str(p), problems)
        return EnvModel.from_dict(d, str(p))

    # ------------------------------------------------------------------ prediction
    def check_log(self, log) -> list[TermSpec]:
        """Check that ``log`` has every channel the model needs (InputError naming the term and
        channel otherwise); returns the specs."""
        frame = frame_from_log(log, axis=self._axis_for(log))
        specs = resolve_terms(self.specs, frame)
        return specs

    def _axis_for(self, log) -> str:
        return self.axis if self.axis in log.rates else log.axes[0]

    def predict(self, log, *, include_bias: bool = True) -> np.ndarray:
        """Model drift (deg/h) at every sample of ``log``.

        Formula: ŷ(t) = Σ_terms coef·x_term(t) with the stored references and nonlinear
        parameters. Pointwise terms are evaluated at full rate; smooth ones (dT/dt, lags,
        warm-up, sinusoid, hysteresis) on a ``fine_dt_s`` grid and linearly interpolated.
        """
        axis = self._axis_for(log)
        full = frame_from_log(log, axis=axis)
        specs = resolve_terms(self.specs, full)
        need_fine = any(s.effect.smooth for s in specs)
        fine = None
        if need_fine:
            dt = self.fine_dt_s if self.fine_dt_s > log.tau0 else None
            fine = frame_from_log(log, axis=axis, dt=dt) if dt else full
        out = np.zeros(full.n)
        for term, spec in zip(self.terms, specs):
            if spec.key == "bias" and not include_bias:
                continue
            coef = np.asarray(term.coef, float)
            if spec.effect.smooth and fine is not full and fine is not None:
                xf = build_term(fine, spec, term.theta, self.refs) @ coef
                out += np.interp(full.t, fine.t, xf)
            else:
                out += build_term(full, spec, term.theta, self.refs) @ coef
        return out

    def domain_warnings(self, log) -> list[str]:
        """Channels of ``log`` outside the range the model was fitted on (extrapolation)."""
        rng = (self.data or {}).get("channel_ranges") or {}
        out = []
        groups = {"temperature": log.temperature, "field": log.field_uT, "extra": log.extra}
        for key, (lo, hi) in rng.items():
            grp, _, name = key.partition(":")
            if grp == "supply":
                v = log.supply
            else:
                v = groups.get(grp, {}).get(name)
            if v is None or lo is None or hi is None:
                continue
            vmin, vmax = float(np.nanmin(v)), float(np.nanmax(v))
            span = max(hi - lo, 1e-9)
            if vmin < lo - 0.05 * span or vmax > hi + 0.05 * span:
                out.append(f"{key} spans {vmin:.4g}…{vmax:.4g} but the model was fitted on "
                           f"{lo:.4g}…{hi:.4g}: extrapolating")
        return out


# ----------------------------------------------------------------------------- TOML writer
def _toml_value(v: Any) -> str:
    if v is None:
        return "nan"
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_toml_key(k)} = {_toml_value(x)}" for k, x in v.items()) + "}"
    return json.dumps(str(v))


def _toml_key(k: str) -> str:
    import re

    return k if re.match(r"^[A-Za-z0-9_\-]+$", k) else json.dumps(k, ensure_ascii=False)


def to_toml(d: dict) -> str:
    """Serialise a JSON-like dict to TOML (tables, arrays of tables, inline values).
    TOML has no null: None table entries are left out, None in a list becomes nan; lists of
    dicts become arrays of tables."""
    lines: list[str] = []

    def emit(table: dict, prefix: str) -> None:
        table = {k: v for k, v in table.items() if v is not None}
        simple = {k: v for k, v in table.items()
                  if not isinstance(v, dict) and not (isinstance(v, list) and v
                                                      and all(isinstance(x, dict) for x in v))}
        for k, v in simple.items():
            lines.append(f"{_toml_key(k)} = {_toml_value(v)}")
        for k, v in table.items():
            if k in simple:
                continue
            name = f"{prefix}.{_toml_key(k)}" if prefix else _toml_key(k)
            if isinstance(v, dict):
                lines.append("")
                lines.append(f"[{name}]")
                emit(v, name)
            else:
                for item in v:
                    lines.append("")
                    lines.append(f"[[{name}]]")
                    emit(item, name)

    emit(d, "")
    return "\n".join(lines) + "\n"
