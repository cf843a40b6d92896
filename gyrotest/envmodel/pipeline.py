"""A log made ready for the model workbench, the same way for every command and the report.

``gyrotest model fit/diagnose``, ``thermal-fit``, ``mag-fit`` and ``compensate`` (and the
spec-sheet report, which runs the same analyses) share these steps:

* :func:`collect_terms` -- the ``--terms`` / ``--term NAME:EXPR`` texts as term specs;
* :func:`naming_terms` -- run a log reader; when ingest rejects a channel a term needs, the
  error names the term(s) as well;
* :func:`prepare_log` -- the ``--skip`` warm-up trim and :func:`gyrotest.envmodel.modelfit.prepare`
  with the working-resolution options as typed (``auto`` or a duration); a log too short for
  the model names the terms;
* :func:`fit_log` -- ``gyrotest model fit``: :func:`prepare_log`, the fit and its slower
  diagnostics (the counterpart of :func:`gyrotest.envmodel.workbench.diagnose_log`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TypeVar

from ..core.errors import AnalysisError, InputError
from ..core.units import format_duration, parse_duration
from .modelfit import FitResult, WorkData, file_provenance, finish, fit_model, prepare
from .terms import TermSpec, parse_terms

__all__ = ["collect_terms", "duration_or_auto", "naming_terms", "prepare_log"]

T = TypeVar("T")


def collect_terms(terms: Sequence[str], custom: Sequence[str] = ()) -> list[TermSpec]:
    """Parse ``--terms`` (each a comma-separated list) and ``--term NAME:EXPRESSION`` into
    term specs (InputError on bad text)."""
    texts = [t for t in terms if t.strip()]
    out = parse_terms(texts) if texts else []
    for c in custom:
        if ":" not in c:
            raise InputError(f"--term {c!r}: write NAME:EXPRESSION, e.g. vib:extra.vib_g**2")
        out += parse_terms([c])
    return out


#: words of an ingest error that point at the channel a term needs (by the term's role)
_ROLE_WORDS = {"temperature": ("temperature",), "temperature2": ("temperature",),
               "table+temp": ("temperature", "table", "rate-table"),
               "field": ("field", "magnetic"), "supply": ("supply",),
               "table_rate": ("table", "rate-table"), "extra": ()}


def naming_terms(load: Callable[[], T], specs: Sequence[TermSpec]) -> T:
    """``load()`` (a log reader); when it raises an InputError about a channel that one of
    ``specs`` needs, the message starts with the term(s): ``terms T, dTdt: ...``."""
    try:
        return load()
    except InputError as e:
        msg = str(e)
        low = msg.lower()
        hit = []
        for s in specs:
            if s.key == "custom":
                if any(ref.name.lower() in low for ref in _expr_refs(s)):
                    hit.append(s.label)
                continue
            words = _ROLE_WORDS.get(s.effect.needs, ())
            if any(w in low for w in words) or any(c.lower() in low for c in s.channels):
                hit.append(s.label)
        if hit:
            raise InputError(f"term{'s' if len(hit) > 1 else ''} {', '.join(hit)}: {msg}") from None
        raise


def _expr_refs(spec: TermSpec):
    from .expr import parse_expression

    try:
        return parse_expression(spec.expr or "").channels
    except InputError:
        return []


def duration_or_auto(text: str | None, what: str) -> float | None:
    """``auto`` (or nothing) → None, else a positive duration in seconds."""
    if text is None or str(text).strip().lower() in ("auto", ""):
        return None
    v = parse_duration(text, what=what)
    if v <= 0:
        raise InputError(f"{what} must be > 0 (got {text!r})")
    return v


def prepare_log(log, path: str | None, *, axis: str | None = None, skip: str | float = "0",
                t_ref: float | None = None, v_ref: float | None = None,
                resolution: str | None = "auto", smooth: str | None = "auto",
                specs: Sequence[TermSpec] | None = None, reference=None,
                power_on: bool | None = None) -> WorkData:
    """Trim the first ``skip`` (duration text; the warm-up term then counts from the true
    power-on), then :func:`~gyrotest.envmodel.modelfit.prepare` at the working resolution
    (``resolution``/``smooth``: ``auto`` or a duration). ``path`` is the log file for the
    model's provenance (``-`` for stdin). When the log is too short, the message names
    ``specs``. ``reference``: a static reference :class:`~gyrotest.core.data.GyroLog` of the same
    gyro whose noise model is fixed for every model of the log
    (:func:`gyrotest.envmodel.likelihood.reference_noise`) instead of fitted on the log. ``power_on``: the log starts at the gyro's
    power-on (before ``skip``), so a warm-up transient is a candidate effect of the
    diagnosis; None: the profile's ``[gyro] power_on_at_start`` (default false)."""
    try:
        wd = _prepare(log, path, axis=axis, skip=skip, t_ref=t_ref, v_ref=v_ref,
                      resolution=resolution, smooth=smooth)
    except AnalysisError as e:
        if specs:
            names = ", ".join(s.label for s in specs)
            raise AnalysisError(f"terms {names}: {e}") from None
        raise
    if power_on is None:
        power_on = bool(getattr(getattr(log, "gyro", None), "power_on_at_start", False))
    wd.power_on = bool(power_on)
    if reference is not None:
        from .floor import check_reference
        from .likelihood import reference_noise

        ax = wd.axis if wd.axis in reference.rates else None
        noise = reference_noise(reference, wd, axis=ax)
        check_reference(reference, log, wd, noise)
        wd.noise_ref = noise
    return wd


def _prepare(log, path, *, axis, skip, t_ref, v_ref, resolution, smooth) -> WorkData:
    skip_s = parse_duration(skip or "0", what="--skip")
    if skip_s > 0:
        if skip_s >= log.duration_s:
            raise InputError(f"--skip {skip} is longer than the log "
                             f"({format_duration(log.duration_s)})")
        log = log.skip(skip_s)
    prov = file_provenance(path) if path != "-" else {"file": "<stdin>"}
    return prepare(log, axis=axis, resolution=duration_or_auto(resolution, "--resolution"),
                   t_ref=t_ref, v_ref=v_ref,
                   smoothing_s=duration_or_auto(smooth, "--smooth"), t_on_s=-skip_s,
                   provenance=prov)


def fit_log(log, specs: list[TermSpec], *, path: str | None = None, axis: str | None = None,
            skip: str | float = "0", t_ref: float | None = None, v_ref: float | None = None,
            resolution: str | None = "auto", smooth: str | None = "auto", folds: int = 5,
            k_sigma: float = 4.0, reference=None) -> FitResult:
    """``gyrotest model fit``: prepare ``log`` with the command's options
    (:func:`prepare_log`; ``path`` for the model's provenance), fit
    ``specs`` (:func:`~gyrotest.envmodel.modelfit.fit_model`) and add the residual Allan deviation, noise floor and
    excursions (:func:`~gyrotest.envmodel.modelfit.finish`). ``reference``: a static reference log
    for the noise floor."""
    wd = prepare_log(log, path, axis=axis, skip=skip, t_ref=t_ref, v_ref=v_ref,
                     resolution=resolution, smooth=smooth, specs=specs, reference=reference)
    res = fit_model(wd, specs, folds=folds, light=True)
    finish(res, k_sigma=k_sigma)
    return res
