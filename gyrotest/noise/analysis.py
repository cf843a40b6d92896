"""The whole Allan noise analysis of a bench log, as one pure function.

:func:`analyse_allan` is what ``gyrotest allan`` and the spec-sheet report both call: it takes a
:class:`~gyrotest.core.data.GyroLog` and returns an :class:`AllanAnalysis` (dataclass, ``to_dict()``
for JSON) without printing anything. Per rate axis it computes

1. the deviation table (default overlapping Allan deviation, IEEE 952 Annex C; NIST SP1065
   eq. 11) with noise identification, EDF and χ² confidence interval per τ
   (:mod:`gyrotest.noise.deviations`), gap-aware over the log's contiguous segments;
2. the joint noise-model fit (:mod:`gyrotest.noise.noisefit`), the classic slope-line read-offs
   and Krobka's bounds, and unit conversions for other tools;
3. model vs measurement and the diagnosis of missing terms (:mod:`gyrotest.noise.diagnose`),
   helped by the Welch PSD lines and the autocorrelation (:mod:`gyrotest.noise.spectral`);
4. Krobka's warnings (:mod:`gyrotest.noise.warnings`), with the Allan–Krobka deviation at
   long τ for the trend check (from the OADEV table's sums: no pass over θ) and the Hadamard
   deviation there when the Allan–Krobka one falls below the Allan deviation's interval (the
   trend warning's evidence; otherwise ``ohdev`` is None);
5. the platform vs strapdown attitude-error prediction (:mod:`gyrotest.noise.impact`);

and, for multi-axis logs, the cross-correlation of the axes.

Input kind (never a silent default): rate outputs (``rate``, ``voltage``) are analysed as rate
samples; pulse outputs (``counts``, ``updown``, ``counter``) as angle increments ΔΘ = N·S0 per
sample (arcsec), the form in which the quantization noise Q = S0/√12 is white angle noise.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from ..core.angle import angle_series
from ..core.data import GyroLog
from ..core.errors import AnalysisError, InputError
from ..core.units import format_duration, parse_duration
from . import kinds as _kinds
from .allanresult import CI_TEXT, AllanAnalysis, AxisAnalysis, allan_document
from .devcore import DeviationResult
from .deviations import DEVIATION_KINDS, compute_deviation
from .diagnose import diagnose
from .impact import attitude_impact
from .noisefit import (
    MIN_EDF,
    conversions,
    fit_alpha,
    fit_deviation,
    parse_terms,
    robust_edf_rules,
    slope_readoffs,
    table_quantity,
)
from .quantity import ACCEL
from .spectral import (
    SpectralLine,
    autocorrelation,
    cross_correlation,
    find_lines,
    welch_psd,
)
from .spikeguard import (
    _clean_dev,
    _clean_dev_streamed,
    _outliers,
    _outliers_flag,
    _outliers_streamed,
    _spike_guard,
    _stitch_recorded,
)
from .warnings import krobka_checks, trend_needs_hadamard

if TYPE_CHECKING:
    from ..io.stream import StreamedLog

#: samples of a streamed log's rate rebuilt for the axis cross-correlation
STREAM_PREFIX = 1 << 24
#: deviations a streamed log (θ only) supports: those computed from θ here
STREAM_DEVS = _kinds.STREAM_DEVS

__all__ = ["AllanAnalysis", "AxisAnalysis", "allan_document", "analyse_allan", "input_kind_of",
           "parse_taus"]

PULSE_KINDS = ("counts", "updown", "counter")
#: deviations whose expectation is the Allan variance, so the IEEE closed forms fit them
ALLAN_TYPE = ("oadev", "adev", "totdev", "akdev")
#: sample-interval jitter (std/τ0) above which the Allan analysis refuses uniform-τ0 results
MAX_JITTER = 0.1
#: from this many samples the spike check (``--outliers flag``, which leaves the rate as
#: recorded) runs on a thread beside the deviations, PSD and fit of the same axis: on records
#: this long it screens (:func:`gyrotest.noise.outliers.detect_outliers`: mostly numpy work
#: that releases the GIL, ≈ 0.2 s of CPU per 10⁷ samples). A streamed log's spike check (the
#: running median everywhere, which holds the GIL) runs in a forked child instead
#: (:mod:`gyrotest._runtime`; benchmarks/README.md, bench_speed, sixth and eighth passes)
SPIKE_BESIDE_MIN = 1 << 20
_PER_DECADE = re.compile(r"^\s*(\d+)\s*/\s*decade\s*$")


def parse_taus(spec: str | Sequence[float] | None) -> str | list[float]:
    """τ grid spec: ``octave``, ``decade``, ``10/decade`` (default; any ``N/decade``), ``all``,
    or an explicit list ``"0.1,1,10"`` (seconds). Returns what
    :func:`gyrotest.noise.taus.tau_grid` accepts."""
    if spec is None:
        return "decade10"
    if not isinstance(spec, str):
        return [float(v) for v in spec]
    s = spec.strip().lower()
    m = _PER_DECADE.match(s)
    if m:
        return f"decade{int(m.group(1))}"
    if s in ("octave", "decade", "all") or re.fullmatch(r"decade\d+", s):
        return s
    try:
        vals = [float(v) for v in re.split(r"[,\s]+", s) if v]
    except ValueError:
        raise InputError(f"bad --taus {spec!r}; use octave, decade, 10/decade, all or a list of "
                         "τ in seconds like 0.1,1,10,100") from None
    if not vals:
        raise InputError("empty --taus list")
    return vals


def input_kind_of(log: GyroLog) -> tuple[str, str]:
    """(input kind for :mod:`deviations`, explanation) from the log's output kind."""
    kind = log.gyro.output_kind
    if kind in PULSE_KINDS:
        q = log.gyro.angle_quantum_arcsec
        return "increment", (f"pulse output ({kind}, S0 = {q:g} arcsec/pulse): analysed as angle "
                             "increments per sample; σ in arcsec/s = deg/h")
    if kind in ("delta-angle", "angle"):
        return "increment", (f"{kind} output ({log.gyro.rate_unit}): analysed as angle increments "
                             "per sample; σ in arcsec/s = deg/h")
    if kind in ("rate", "voltage"):
        return "rate", f"{kind} output: analysed as rate samples (average rate per interval), deg/h"
    raise InputError(f"{log.source}: output kind {kind!r} cannot be analysed (rate, voltage, "
                     "counts, updown or counter)")


def _accelerometers(log: GyroLog, notes: list[str]):
    """The log's accelerometer axes in m/s² (:func:`gyrotest.io.accel.accel_channels`), their
    notes added to ``notes``."""
    from ..io.accel import accel_channels

    acc = accel_channels(log)
    notes.extend(acc.notes)
    if acc:
        notes.append("accelerometer axes " + ", ".join(
            f"{k} ({acc.units[k]}, {acc.how[k]})" for k in acc.data)
            + ": analysed in m/s² with the IEEE Std 1293 terms (velocity random walk, bias "
            "instability, acceleration random walk)")
    return acc


def parse_detrend(spec: str | None) -> tuple[str, float | None]:
    """``none``, ``linear``, ``quadratic`` or ``sine:PERIOD`` (e.g. ``sine:24h``) →
    (method, period s or None)."""
    if spec is None:
        return "none", None
    s = str(spec).strip().lower()
    if s in ("none", "linear", "quadratic"):
        return s, None
    if s.startswith("sine:"):
        period = parse_duration(s[5:], what="--detrend sine:PERIOD")
        if period <= 0:
            raise InputError(f"--detrend {spec}: the period must be > 0, e.g. sine:24h")
        return "sine", float(period)
    raise InputError(f"unknown --detrend {spec!r}; use none, linear, quadratic or sine:PERIOD "
                     "(e.g. sine:24h)")


def _detrend(rate: np.ndarray, t: np.ndarray, segs, spec: str) -> tuple[np.ndarray, dict]:
    """Remove a least-squares trend (:func:`parse_detrend`) over all gap-free samples; the
    mean is kept."""
    method, period = parse_detrend(spec)
    if method == "linear":
        return _detrend_linear(rate, t, segs)
    idx = np.concatenate([np.arange(a, b) for a, b in segs])
    tt = t[idx]
    tm = float(tt.mean())
    half = max(float(tt.max() - tt.min()) / 2.0, 1e-12)
    u = (t - tm) / half
    if method == "quadratic":
        cols = [u, u * u]
        names = ["linear", "quadratic"]
        note = ("a least-squares quadratic a + b·t + c·t² was removed from the rate before the "
                "analysis (it also removes part of any rate random walk at the longest τ)")
    else:
        w = 2 * np.pi / period
        cols = [np.cos(w * (t - tm)), np.sin(w * (t - tm))]
        names = ["cos", "sin"]
        note = (f"a least-squares sinusoid of period {format_duration(period)} was removed from "
                "the rate before the analysis")
    X = np.column_stack([np.ones(t.size)] + cols)
    coef, *_ = np.linalg.lstsq(X[idx], rate[idx], rcond=None)
    trend = X[:, 1:] @ coef[1:]
    info: dict[str, Any] = {"method": method, "note": note,
                            "coefficients_dph": dict(zip(names, map(float, coef[1:])))}
    if method == "sine":
        info["period_s"] = period
        info["amplitude_dph"] = float(np.hypot(coef[1], coef[2]))
    else:
        info["slope_dph_per_s"] = float(coef[1] / half)
        info["R_removed_deg_h_per_h"] = float(coef[1] / half * 3600.0)
    return rate - trend, info


def _detrend_linear(rate: np.ndarray, t: np.ndarray, segs) -> tuple[np.ndarray, dict[str, Any]]:
    """Remove the least-squares line a + b·t (over all gap-free samples; the mean is kept)."""
    idx = np.concatenate([np.arange(a, b) for a, b in segs])
    tt = t[idx]
    x = rate[idx]
    tm = float(tt.mean())
    dt = tt - tm
    b = float(np.dot(dt, x - x.mean()) / np.dot(dt, dt))
    out = rate - b * (t - tm)
    return out, {"method": "linear", "slope_dph_per_s": b, "R_removed_deg_h_per_h": b * 3600.0,
                 "note": "a least-squares straight line was removed from the rate before the "
                         "analysis (it also removes part of any rate random walk at the "
                         "longest τ)"}


def _cross_streamed(log, names, notes: list[str]):
    """Axis cross-correlation of a streamed log from the first samples of its segments."""
    from .streamed import rate_prefixes

    rates, segs, left = {}, None, 0
    for a in names:
        rates[a], segs, left = rate_prefixes(log.series[a], log.means[a],
                                             per_segment=STREAM_PREFIX, total=STREAM_PREFIX)
    if left:
        notes.append(f"axis cross-correlation from the first {log.n - left} samples (streamed "
                     "log)")
    return cross_correlation(rates, log.tau0, segments=segs)


def _fold_filters(fit, diag, warns, tau0):
    """Markov terms with T_c < τ0 are the sensor's output filter: fold them into N (N_eq, see
    :mod:`gyrotest.noise.filtered`) in the requested and the diagnosed model, and drop the
    warnings about a hump screening the white noise (KROBKA-M1, -M5), which the filter note
    replaces. Returns (fit, diagnosis, warnings, info or None)."""
    from .filtered import fold_filter

    final_is_fit = diag is not None and diag.final is fit
    fit, info = fold_filter(fit, tau0)
    if diag is not None:
        if final_is_fit:
            diag.final = fit
        else:
            diag.final, info_d = fold_filter(diag.final, tau0)
            info = info_d or info
    if info is not None:
        warns = [w for w in warns if w.code not in ("KROBKA-M1", "KROBKA-M5")]
    return fit, diag, warns, info


#: the table's (Stable32's) EDF is called out when it exceeds the fit's by this factor
EDF_NOTE_RATIO = 2.0


def _undecided_alpha_note(dev: DeviationResult, edf_table: np.ndarray,
                          edf_fit: np.ndarray) -> list[str]:
    """A note when Stable32's noise type at some τ (its lag-1 ACF from 30 points, or B1 from a
    few averages) makes the printed EDF more than twice the conservative one of the fit: that
    interval is then far too narrow to read."""
    with np.errstate(invalid="ignore", divide="ignore"):
        big = np.flatnonzero(np.asarray(edf_table, float)
                             > EDF_NOTE_RATIO * np.asarray(edf_fit, float))
    if big.size == 0:
        return []
    taus = ", ".join(f"{dev.tau[i]:.4g}" for i in big[:6]) + (" …" if big.size > 6 else "")
    worst = int(big[np.argmax(np.asarray(edf_table)[big] / np.asarray(edf_fit)[big])])
    return [f"α at τ = {taus} s is Stable32's identification from too few averages to be "
            f"decisive (e.g. α = {int(dev.alpha[worst])}, EDF {edf_table[worst]:.3g} at τ = "
            f"{dev.tau[worst]:.4g} s, against {edf_fit[worst]:.3g} for white rate noise): its "
            "interval there is too narrow to read; the fit, N_upper and the warnings use the "
            "conservative EDF (shown with --ci conservative)"]


def _plain_readoffs(dev: DeviationResult, edf: np.ndarray) -> dict[str, Any]:
    """Slope-line read-offs of a table without a model fit ({} when the grid is too sparse)."""
    try:
        return slope_readoffs(dev.tau, dev.sigma, edf, quantity=table_quantity(dev))
    except (ValueError, IndexError, AnalysisError):
        return {}


def _long_taus(tau: np.ndarray, count: int = 8) -> list[float]:
    t = np.asarray(tau, float)
    sel = t[t >= t.max() / 30.0]
    return sel[-count:].tolist()


def _skip_seconds(skip: float | str) -> float:
    return parse_duration(skip, what="--skip") if isinstance(skip, str) else float(skip)


def _skip_warmup(log: GyroLog, skip: float | str) -> GyroLog:
    """``log`` without its first ``skip`` (seconds or duration text); InputError when that is
    the whole record."""
    if isinstance(skip, str):
        text, skip_s = skip, parse_duration(skip, what="--skip")
    else:
        text, skip_s = f"{skip:g}s", float(skip)
    if skip_s <= 0:
        return log
    if skip_s >= log.duration_s:
        raise InputError(f"{log.source}: --skip {text} removes the whole record "
                         f"({format_duration(log.duration_s)})")
    return log.skip(skip_s)


def analyse_allan(
    log: GyroLog,
    *,
    skip_s: float | str = 0.0,
    dev: str = "oadev",
    taus: str | Sequence[float] | None = "10/decade",
    terms: str | Sequence[str] | None = None,
    vehicle_rates: Sequence[float] = (),
    axes: Sequence[str] | None = None,
    confidence: float = 0.683,
    stop_ratio: float | None = None,
    min_edf: float = MIN_EDF,
    detrend: str | None = None,
    run_diagnosis: bool = True,
    spectral: bool = True,
    trend_check: bool = True,
    impact_horizon_s: float = 3600.0,
    bi_cutoff_hz: float | None = None,
    max_steps: int = 3,
    allow_irregular: bool = False,
    fit_model: bool = True,
    ci: str = "stable32",
    outliers: str = "flag",
    env_model=None,
    fill: int = 1,
    accelerometers: bool = True,
) -> AllanAnalysis:
    """Run the whole Allan analysis of ``log`` (module docstring) and return it. Pure: no
    printing, no files.

    Parameters
    ----------
    skip_s : warm-up trim at the start of the log, seconds, or a duration text such as
        ``"30min"`` (read by :func:`gyrotest.core.units.parse_duration`; quoted as written when it
        removes the whole record).
    dev : deviation for the table: oadev (default), adev, mdev, tdev, hdev, ohdev, totdev,
        mtotdev, akdev, hkdev. The noise model is fitted to it when it is Allan-type (oadev,
        adev, totdev, akdev), otherwise to an OADEV computed on the same τ (noted).
    taus : ``octave``, ``decade``, ``N/decade`` (default 10/decade), ``all`` or a list of τ (s).
    terms : noise terms to fit (default Q,N,B,K,R; see :func:`gyrotest.noise.noisefit.parse_terms`).
    vehicle_rates : strapdown vehicle rates in rad/s for the impact prediction.
    axes : rate axes to analyse (default all).
    confidence : of the χ² intervals (0.683 as Stable32).
    stop_ratio : max τ = T/stop_ratio for generated grids (default Stable32's per deviation).
    min_edf : fit floor (τ with fewer EDF are shown, not fitted).
    detrend : None/"none", "linear", "quadratic" or "sine:PERIOD" (remove a least-squares
        trend or sinusoid first; :func:`parse_detrend`).
    env_model : a :class:`gyrotest.envmodel.model.EnvModel` (from ``gyrotest model fit -o``):
        its drift (without the constant bias) is subtracted from its axis before everything
        else, as ``gyrotest compensate`` does, so the noise fit sees noise only.
    run_diagnosis, spectral, trend_check : switch the diagnosis, the PSD/ACF and the
        Allan–Krobka/Hadamard trend comparison.
    impact_horizon_s : time at which σ_att is reported (default 1 h).
    bi_cutoff_hz : fit the full bias-instability template with this cut-off.
    max_steps : at most this many terms added by the diagnosis ladder.
    allow_irregular : analyse on the nominal τ0 even when the sample interval jitters by more
        than 10 % (otherwise an InputError).
    ci : "stable32" (default: the interval of the identified α's EDF, as Stable32 prints it)
        or "conservative" (adds alpha_ci/edf_ci/sigma_lo_ci/sigma_hi_ci columns).
    outliers : spike handling (:mod:`gyrotest.noise.outliers`): "flag" (default: detect and
        warn with the times, analyse unchanged), "remove" (Hampel filter: each spike replaced by
        its running median) or "robust" (each spike clipped to the threshold). Never silent.
    accelerometers : also analyse the log's accelerometer axes (extra channels named ax/ay/az,
        acc_x ... with an acceleration unit: :func:`gyrotest.io.accel.accel_channels`), σ in
        m/s², the terms in IEEE Std 1293 units (VRW m/s/√h, B µg, acceleration random walk
        m/s/h/√h); ``axes`` may name them.
    fill : bridge gaps of at most this many missed samples before the analysis (default 1:
        single missed samples; 0 never bridges; :func:`gyrotest.io.gapfill.fill_gaps`, whose
        effect on σ is stated in the notes). Gaps left split the record into segments.
    fit_model : False gives the plain deviation table (no noise model, diagnosis, warnings or
        impact). With True the model is still skipped, with a note, when the τ grid has too
        few usable points for the requested terms (e.g. ``taus=[1, 10, 100]``).

    Raises :class:`InputError`/:class:`AnalysisError` for bad settings or data the analysis
    cannot support (too short, constant, NaN, irregular timing), with a one-line reason.
    """
    streamed = getattr(log, "series", None) is not None  # gyrotest.io.stream.StreamedLog: θ only
    if streamed and (_skip_seconds(skip_s) > 0 or detrend not in (None, "none")
                     or env_model is not None or outliers != "flag"
                     or dev not in STREAM_DEVS):
        raise InputError(f"{log.source}: a streamed log supports no --skip, --detrend, --model, "
                         f"--outliers {outliers} or --dev {dev}; read it whole")
    log = _skip_warmup(log, skip_s) if not streamed else log
    fill_rep = None
    if not streamed and log.timing.gaps:
        from ..io.gapfill import fill_gaps

        log, fill_rep = fill_gaps(log, int(fill))
    if dev not in DEVIATION_KINDS:
        raise InputError(f"unknown deviation {dev!r}; choose one of {', '.join(DEVIATION_KINDS)}")
    tau_spec = parse_taus(taus)
    keys = parse_terms(terms)
    parse_detrend(detrend)
    if not 0.0 < confidence < 1.0:
        raise InputError(f"confidence must be between 0 and 1 (e.g. 0.683), got {confidence!r}")
    if ci not in CI_TEXT:
        raise InputError(f"unknown --ci {ci!r}; use stable32 or conservative")
    from .outliers import OUTLIER_MODES

    if outliers not in OUTLIER_MODES:
        raise InputError(f"unknown --outliers {outliers!r}; use flag, remove or robust")
    notes: list[str] = []
    tim = log.timing
    if tim.irregular:
        if tim.jitter_rel > MAX_JITTER and not allow_irregular:
            raise InputError(
                f"{log.source}: the sample interval varies by {100 * tim.jitter_rel:.3g} % of "
                f"τ0 = {log.tau0:g} s; the Allan deviation needs uniform sampling. Resample the "
                "log to a fixed interval (average into bins), or pass --allow-irregular to "
                "analyse on the sample index with the nominal τ0")
        notes.append(f"irregular timestamps (interval jitter {100 * tim.jitter_rel:.2g} % of τ0): "
                     f"analysed on the sample index with the nominal τ0 = {log.tau0:g} s")
    segs = log.segments
    if streamed and fill > 0 and any(0 < g.missing <= fill for g in tim.gaps):
        notes.append(f"streamed log: its gaps of ≤ {fill} missed sample(s) are not bridged "
                     "(filling needs the samples in memory); they split the record")
    if fill_rep is not None and (fill_rep.filled or fill_rep.skipped):
        notes.append(fill_rep.note())
    # the recorded samples and their gap-free segments: the τ these support are computed
    # from them alone, the bridged record only adds the longer τ
    raw = (None if fill_rep is None or fill_rep.present is None
           else (fill_rep.present, fill_rep.segments_before))
    if len(segs) > 1:
        notes.append(f"{len(segs)} gap-free segments ({len(tim.gaps)} gap(s)): deviations pooled "
                     "over segments (sums of squares and term counts; no difference spans a gap)"
                     + (f"; the longest is {format_duration(max(b - a for a, b in segs) * log.tau0)}"
                        f" of {format_duration(log.duration_s)}, which ends the τ range"))
    in_kind, in_note = input_kind_of(log)
    quantum = log.gyro.angle_quantum_arcsec
    acc = _accelerometers(log, notes) if accelerometers and not streamed else None
    acc_axes = list(acc.data) if acc else []
    names = list(axes) if axes else log.axes + acc_axes
    for a in names:
        if a not in log.axes and a not in acc_axes:
            raise InputError(f"{log.source}: no axis {a!r}; axes are "
                             f"{', '.join(log.axes + acc_axes)}")
    results: list[AxisAnalysis] = []
    rates_used: dict[str, np.ndarray] = {}
    model_info = model_pred = None
    if env_model is not None:
        model_pred = np.asarray(env_model.predict(log, include_bias=False), float)
        m_axis = env_model.axis if env_model.axis in log.rates else log.axes[0]
        labels = [sp.label for sp in env_model.specs if sp.key != "bias"]
        model_info = {"axis": m_axis, "terms": labels,
                      "drift_rms_dph": float(np.sqrt(np.mean((model_pred - model_pred.mean())
                                                             ** 2))),
                      "drift_p2p_dph": float(np.ptp(model_pred))}
        notes.append(f"deterministic model removed from axis {m_axis} before the analysis "
                     f"({', '.join(labels) or 'bias only'}; drift RMS "
                     f"{model_info['drift_rms_dph']:.4g} deg/h, peak-to-peak "
                     f"{model_info['drift_p2p_dph']:.4g} deg/h)")
    common = dict(dev=dev, tau_spec=tau_spec, keys=keys, vehicle_rates=vehicle_rates,
                  confidence=confidence, stop_ratio=stop_ratio, min_edf=min_edf,
                  run_diagnosis=run_diagnosis, spectral=spectral, trend_check=trend_check,
                  horizon=impact_horizon_s, bi_cutoff_hz=bi_cutoff_hz, max_steps=max_steps,
                  record_s=log.duration_s, source=log.source, fit_model=fit_model, ci=ci)
    for name in names:
        from .._runtime import run_beside, run_on_thread

        spike = None  # the spike check beside the analysis (its report comes back at the end)
        if streamed:
            slog = cast("StreamedLog", log)
            spike = run_beside(_outliers_streamed, log, name)
            rep = None
            try:
                res = _analyse_axis(name, None, log.tau0, segs, in_kind, in_note, quantum,
                                    det_info=None, series=slog.series[name],
                                    means=slog.means[name], **common)
            finally:  # its error first, as in the serial order
                out_info, out_warn, rep = spike.result()
            if outliers == "flag" and rep is not None and rep.found and res.fit is not None:
                _spike_guard(res, rep, _clean_dev_streamed(
                    res, slog.series[name], slog.means[name], segs, rep, confidence,
                    stop_ratio))
        else:
            is_acc = name in acc_axes and name not in log.rates
            rate = np.asarray(acc.data[name] if is_acc else log.rates[name], dtype=np.float64)
            unit = ACCEL.sigma_unit if is_acc else "deg/h"
            det_info = None
            if outliers == "flag" and rate.size >= SPIKE_BESIDE_MIN:  # rate stays as recorded
                spike = run_on_thread(_outliers_flag, rate, log.tau0,
                                      float(log.t[0]) if log.n else 0.0, segs, name, unit,
                                      name="gyrotest-spikes")
            else:
                out_info, out_warn, rate, rep = _outliers(rate, log, segs, name, outliers, unit)
            try:
                if model_info is not None and name == model_info["axis"]:
                    rate = rate - model_pred
                if detrend not in (None, "none"):
                    rate, det_info = _detrend(rate, log.t, segs, detrend)
                rates_used[name] = rate
                if is_acc:
                    try:
                        res = _analyse_axis(
                            name, rate, log.tau0, segs, "rate",
                            f"accelerometer output ({acc.units[name]}, read as m/s²): "
                            "analysed as acceleration samples (average per interval), σ in "
                            "m/s²; IEEE Std 1293 terms (N = velocity random walk)", None,
                            det_info=det_info, raw=raw, unit=unit, **common)
                    except (InputError, AnalysisError) as e:
                        if axes:  # asked for by name: its error is the command's
                            raise
                        # found among the extra channels: a degenerate one is a note
                        notes.append(f"accelerometer axis {name} not analysed: {e}")
                        rates_used.pop(name, None)
                        continue
                else:
                    res = _analyse_axis(name, rate, log.tau0, segs, in_kind, in_note, quantum,
                                        det_info=det_info, raw=raw, **common)
            finally:
                if spike is not None:  # its error first, as in the serial order
                    out_info, out_warn, rep = spike.result()
            if outliers == "flag" and rep is not None and rep.found and res.fit is not None:
                _spike_guard(res, rep, _clean_dev(res, rate, rep, segs, log.tau0, confidence,
                                                  stop_ratio))
        results.append(res)
        results[-1].outliers = out_info
        if out_warn is not None:
            results[-1].warnings.insert(0, out_warn)
    cross = None
    if len(names) > 1 and streamed:
        cross = _cross_streamed(log, names, notes)
    elif len(names) > 1:
        cross = cross_correlation(rates_used, log.tau0, segments=segs)
    settings = {
        "deviation": dev, "taus": tau_spec if isinstance(tau_spec, str) else list(tau_spec),
        "terms": keys, "confidence": confidence, "stop_ratio": stop_ratio, "min_edf": min_edf,
        "detrend": detrend or "none", "model": model_info, "vehicle_rates_rad_s": [float(w) for w in vehicle_rates],
        "impact_horizon_s": impact_horizon_s, "bi_cutoff_hz": bi_cutoff_hz,
        "diagnosis": run_diagnosis, "fit": fit_model, "ci": ci, "outliers": outliers,
        "fill": int(fill), "gap_fill": None if fill_rep is None else fill_rep.to_dict(),
    }
    return AllanAnalysis(source=log.source, tau0=log.tau0, n_samples=log.n,
                         duration_s=log.duration_s, settings=settings, axes=results, cross=cross,
                         notes=notes)


def _analyse_axis(name, rate, tau0, segs, in_kind, in_note, quantum, *, dev, tau_spec, keys,
                  vehicle_rates, confidence, stop_ratio, min_edf, run_diagnosis, spectral,
                  trend_check, horizon, bi_cutoff_hz, max_steps, record_s, det_info,
                  source, fit_model=True, ci="stable32", series=None,
                  means=None, raw=None, unit: str = "deg/h") -> AxisAnalysis:
    notes: list[str] = []
    if series is not None:  # a streamed log: θ is all there is (the rate rebuilt from it)
        data = series
    else:
        data = rate * tau0 if in_kind == "increment" else rate

    def deviation(kind: str, grid, **kw) -> DeviationResult:
        src = data if kind not in STREAM_DEVS else theta
        d = compute_deviation(src, tau0, input_kind=in_kind, kind=kind, taus=grid,
                              confidence=confidence, stop_ratio=stop_ratio, segments=segs,
                              unit=unit, **kw)
        if raw is None or kind == "gapadev":
            return d
        return _stitch_recorded(d, data[raw[0]], raw[1], stop_ratio, kw)

    try:
        # θ once for the table, the OADEV of the fit and the trend check (same numbers)
        theta = data if series is not None else angle_series(data, tau0, input_kind=in_kind,
                                                              segments=segs)
        table_dev = deviation(dev, tau_spec)
    except AnalysisError as e:
        raise AnalysisError(f"{source} [{name}]: {e}") from None
    if dev in ALLAN_TYPE:
        fit_dev = table_dev
    else:
        span = max(b - a for a, b in segs) * tau0  # Thêo1/ThêoH reach 0.75·T, OADEV T/4
        fit_dev = deviation("oadev", [float(t) for t in table_dev.tau
                                      if dev not in ("theo1", "theoh") or t <= span / 4])
        notes.append(f"the IEEE 952 noise model is the Allan variance: fitted to an OADEV on the "
                     f"same τ; the table shows {dev.upper()}")
    edf = np.asarray(table_dev.edf, float).copy()
    lo, hi = np.asarray(table_dev.sigma_lo, float).copy(), np.asarray(table_dev.sigma_hi,
                                                                      float).copy()
    ci_cols = None
    if ci == "conservative":
        edf_c, rules, edf_notes = robust_edf_rules(table_dev)
        lo_c, hi_c = lo.copy(), hi.copy()
        changed = np.flatnonzero(edf_c != edf)
        if changed.size:
            from .edf import chi2_interval

            lo_c[changed], hi_c[changed] = chi2_interval(table_dev.sigma[changed],
                                                         edf_c[changed], confidence)
            notes.extend(edf_notes)
        alpha_c = np.where(np.array([r == "white-rate cap" for r in rules]), 0,
                           fit_alpha(table_dev)[0])
        ci_cols = {"alpha_ci": alpha_c, "edf_ci": edf_c, "edf_ci_rule": rules,
                   "sigma_lo_ci": lo_c, "sigma_hi_ci": hi_c}
    psd = None
    lines: list[SpectralLine] = []
    acf = None
    if spectral:
        f_min = 1.0 / max(float(fit_dev.tau.max()), tau0)
        try:
            if series is not None:
                from .streamed import welch_psd_series

                psd = welch_psd_series(series, means, tau0, f_min=f_min)
            else:
                psd = welch_psd(rate, tau0, segments=segs, f_min=f_min)
            lines = find_lines(psd)
        except ValueError:
            psd = None
        longest = max(segs, key=lambda s: s[1] - s[0])
        n_long = longest[1] - longest[0]
        if series is not None:
            from .streamed import rate_segment

            j = segs.index(longest)
            x_acf = rate_segment(series, means, j, 0, min(n_long, 1 << 20))
        else:
            x_acf = rate[longest[0]:longest[1]]
        acf = autocorrelation(x_acf, tau0, max_samples=1 << 20,
                              max_lag=min(100_000, n_long // 10))
    hints = [ln.f_hz for ln in lines]
    fit = None
    if fit_model:
        try:
            fit = fit_deviation(fit_dev, terms=keys, min_edf=min_edf, bi_cutoff_hz=bi_cutoff_hz,
                                line_hints=hints)
        except AnalysisError as e:
            notes.append(f"noise model not fitted: {e}; the deviation table is complete")
    if fit is None:
        return AxisAnalysis(
            axis=name, input_kind=in_kind, input_note=in_note, dev=table_dev, fit_dev=fit_dev,
            edf=edf, sigma_lo=lo, sigma_hi=hi, fit=None,
            readoffs=_plain_readoffs(fit_dev, edf if fit_dev is table_dev
                                     else np.asarray(fit_dev.edf, float)),
            quantity=table_quantity(table_dev),
            conversions={}, diagnosis=None, warnings=[], impact=None, psd=psd, lines=lines,
            acf=acf, detrend=det_info, notes=notes, ci_conservative=ci_cols)
    readoffs = slope_readoffs(fit_dev.tau, fit_dev.sigma, fit.edf, quantity=fit.quantity)
    if fit_dev is table_dev:
        notes.extend(_undecided_alpha_note(table_dev, edf, fit.edf))
    diag = diagnose(fit, line_hints=hints, max_steps=max_steps) if run_diagnosis else None
    ak = oh = None
    if trend_check:
        long_t = _long_taus(fit_dev.tau)
        if len(long_t) >= 2:
            # AKDEV from the OADEV's sums when the fit's table is one (no pass over θ); OHDEV
            # only as the evidence of a trend warning
            try:
                ak = deviation("akdev", long_t, noise_id=False,
                               reuse=fit_dev if fit_dev.kind == "oadev" else None)
                if trend_needs_hadamard(fit, ak):
                    oh = deviation("ohdev", long_t, noise_id=False)
            except (InputError, AnalysisError) as e:
                notes.append(f"trend check skipped: {e}")
    check_inputs = dict(akdev=ak, ohdev=oh, quantum_arcsec=quantum, diagnosis=diag,
                        record_s=record_s)
    warns = krobka_checks(fit, readoffs, **check_inputs)
    fit, diag, warns, filt = _fold_filters(fit, diag, warns, tau0)
    if filt is not None:
        notes.append(filt["note"])
    best = diag.final if diag is not None else fit
    impact = None
    if fit.quantity == "rate":  # the attitude error of three gyros; not for accelerometers
        impact = attitude_impact(best, horizon_s=horizon, vehicle_rates_rad_s=vehicle_rates,
                                 record_s=record_s)
        impact.model_terms = list(best.requested)
        if best is not fit:
            notes.append(f"the impact prediction uses the diagnosed model --terms "
                         f"{','.join(best.requested)} (the requested terms misfit)")
    return AxisAnalysis(quantity=fit.quantity,
        axis=name, input_kind=in_kind, input_note=in_note, dev=table_dev, fit_dev=fit_dev,
        edf=edf, sigma_lo=lo, sigma_hi=hi, fit=fit, readoffs=readoffs,
        conversions=conversions(best), diagnosis=diag, warnings=warns, impact=impact, psd=psd,
        lines=lines, acf=acf, akdev=ak, ohdev=oh, detrend=det_info,
        notes=notes + [f"{n} (fit weights only)" if n.startswith("EDF ") else n
                       for n in fit.notes], ci_conservative=ci_cols, check_inputs=check_inputs)
