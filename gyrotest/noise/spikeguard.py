"""Spikes inside the Allan analysis (:mod:`.analysis`): the spike check of a record read whole
or streamed (:mod:`.outliers`, :mod:`.streamed`), its report and warning, the record with the
flagged samples removed or bridged, the deviation of that cleaned record, and the guard that
compares it with the deviation of the record as recorded (:func:`_spike_guard`)."""

from __future__ import annotations

import copy
from typing import Any

import numpy as np

from ..core.data import GyroLog
from ..core.errors import AnalysisError, InputError
from .allanresult import AxisAnalysis
from .devcore import DeviationResult
from .deviations import compute_deviation
from .noisefit import (
    conversions,
    fit_deviation,
)
from .warnings import KrobkaWarning, krobka_checks


def _outliers_streamed(log, name: str):
    """The spike check of a streamed log's axis (flag mode: report and warn only)."""
    from .streamed import detect_outliers_series

    rep = detect_outliers_series(log.series[name], log.means[name], log.tau0, channel=name)
    return (_outlier_report(rep, "flag"),
            None if not rep.found else _outlier_warning(rep, "flag"), rep)


def _outlier_report(rep, mode: str) -> dict[str, Any]:
    info = rep.to_dict()
    info["mode"] = mode
    return info


def _outlier_warning(rep, mode: str) -> KrobkaWarning:
    what = {"flag": "analysed as recorded (--outliers remove or robust to treat them)",
            "remove": "each replaced by its running median before the analysis "
                      "(--outliers remove)",
            "robust": "each clipped to the threshold before the analysis "
                      "(--outliers robust)"}[mode]
    info = rep.to_dict()
    return KrobkaWarning(
        code="OUTLIERS", title="spikes in the rate",
        message=f"{rep.summary()}; {what}",
        reason="isolated spikes (data link, ADC, shock) are not gyro noise: one 40σ sample "
               "in 10^6 raises the short-τ Allan deviation and N; detected with a Hampel "
               "filter (running median, robust scale; Pearson, IEEE Trans. Control Syst. "
               "Technol. 10, 2002)",
        evidence={"n_outliers": rep.n_outliers, "n_events": len(rep.events),
                  "threshold_k": rep.k, "excess_kurtosis": info["excess_kurtosis"]})


def _outliers(rate: np.ndarray, log: GyroLog, segs, name: str, mode: str,
              unit: str = "deg/h"):
    """Spike detection on one axis (:mod:`gyrotest.noise.outliers`): (report dict, warning or
    None, the rate after the ``mode`` treatment)."""
    from .outliers import apply_outliers, detect_outliers

    rep = detect_outliers(rate, log.tau0, t0=float(log.t[0]) if log.n else 0.0, channel=name,
                          segments=segs, unit=unit)
    info = _outlier_report(rep, mode)
    warn = None
    if rep.found:
        warn = _outlier_warning(rep, mode)
        rate = apply_outliers(rate, rep, mode, segments=segs)
    return info, warn, rate, rep


def _outliers_flag(rate: np.ndarray, tau0: float, t0: float, segs, name: str,
                   unit: str = "deg/h"):
    """:func:`_outliers` for ``--outliers flag`` (the rate stays as recorded), with plain
    arguments and only the small results, for a thread beside the analysis."""
    from .outliers import detect_outliers

    rep = detect_outliers(rate, tau0, t0=t0, channel=name, segments=segs, unit=unit)
    return (_outlier_report(rep, "flag"), (_outlier_warning(rep, "flag") if rep.found else None),
            rep)


def _stitch_recorded(dev: DeviationResult, data_rec: np.ndarray, segs_rec, stop_ratio,
                     kw: dict[str, Any]) -> DeviationResult:
    """``dev`` (computed across bridged gaps) with the rows at the τ that the recorded
    samples' own gap-free segments support replaced by the deviation of those segments alone
    (pooled, no difference spanning a gap): the filled samples then only serve the longer τ,
    where their effect (:mod:`gyrotest.io.gapfill`) is far inside the confidence interval, and
    leave the short τ, whose intervals are narrow, exactly as recorded."""
    from .taus import max_averaging_factor

    longest = max(b - a for a, b in segs_rec)
    m_max = max_averaging_factor(longest, dev.kind, stop_ratio)
    sel = np.flatnonzero(np.asarray(dev.m) <= m_max)
    if sel.size == 0:
        return dev
    kw = {k: v for k, v in kw.items() if k != "reuse"}
    try:
        rec = compute_deviation(data_rec, dev.tau0, input_kind=dev.input_kind, kind=dev.kind,
                                taus=[float(dev.tau[i]) for i in sel],
                                confidence=dev.confidence, stop_ratio=stop_ratio,
                                segments=segs_rec, unit=dev.unit, **kw)
    except (InputError, AnalysisError):
        return dev
    pos = {int(m): j for j, m in enumerate(rec.m)}
    out = copy.copy(dev)
    for name in ("m", "tau", "n", "alpha", "edf", "sigma", "sigma_lo", "sigma_hi"):
        arr = np.array(getattr(dev, name), copy=True)
        src = getattr(rec, name)
        for i in sel:
            j = pos.get(int(dev.m[i]))
            if j is not None:
                arr[i] = src[j]
        setattr(out, name, arr)
    meth = list(dev.alpha_method)
    for i in sel:
        j = pos.get(int(dev.m[i]))
        if j is not None and j < len(rec.alpha_method):
            meth[i] = rec.alpha_method[j]
    out.alpha_method = meth
    if dev.alpha_fit is not None and rec.alpha_fit is not None:
        af, ef = np.array(dev.alpha_fit, copy=True), np.array(dev.edf_fit, copy=True)
        afm = list(dev.alpha_fit_method or [""] * len(af))
        for i in sel:
            j = pos.get(int(dev.m[i]))
            if j is not None:
                af[i], ef[i] = rec.alpha_fit[j], rec.edf_fit[j]
                afm[i] = (rec.alpha_fit_method or [""] * len(rec.alpha_fit))[j]
        out.alpha_fit, out.edf_fit, out.alpha_fit_method = af, ef, afm
    t_split = float(max(dev.tau[i] for i in sel))
    out.notes = list(dev.notes) + [
        f"τ ≤ {t_split:.4g} s from the recorded samples' gap-free segments alone (pooled); "
        "longer τ across the bridged gaps"]
    return out


def _clean_dev(res: AxisAnalysis, rate: np.ndarray, rep, segs, tau0: float,
               confidence: float, stop_ratio: float | None):
    """The OADEV (the fit's τ) of ``rate`` with the flagged samples replaced by their running
    median (the ``remove`` treatment), or the error text when it cannot be computed."""
    from .outliers import apply_outliers

    clean = apply_outliers(rate, rep, "remove", segments=segs)
    data = clean * tau0 if res.input_kind == "increment" else clean
    try:
        return compute_deviation(data, tau0, input_kind=res.input_kind, kind="oadev",
                                 taus=[float(t) for t in res.fit_dev.tau],
                                 confidence=confidence, stop_ratio=stop_ratio, segments=segs,
                                 unit=res.dev.unit)
    except (InputError, AnalysisError) as e:
        return str(e)


def _clean_dev_streamed(res: AxisAnalysis, series, means, segs, rep, confidence: float,
                        stop_ratio: float | None):
    """:func:`_clean_dev` of a streamed log, from its θ alone: each flagged sample's running
    median is computed from the rate rebuilt around it (the same window as for a record read
    whole), θ is shifted in place by the cumulative corrections, the OADEV computed, and θ
    shifted back (no copy of the record)."""
    from .outliers import _running_median, _seg_window
    from .streamed import rate_segment

    w_half = rep.window
    theta = series.theta
    step = 1.0 if series.input_kind != "increment" else series.tau0  # θ per rate unit
    # per segment: θ indices just after the flagged samples and the running sum of their Δθ
    fixes: list[tuple[int, int, np.ndarray, np.ndarray]] = []
    for j, ((a, b), (p0, p1)) in enumerate(zip(segs, series.bounds)):
        w = _seg_window(a, b, rep.window)
        pos, dth = [], []
        for e in rep.events:
            if not (a <= e.start < b):
                continue
            lo, hi = max(a, e.start - w_half), min(b, e.stop + w_half)
            x = rate_segment(series, means, j, lo - a, hi - a)
            med = _running_median(x, w) if w >= 3 else x
            i = np.arange(e.start, e.stop)
            pos.append(i - a + 1)
            dth.append((x[i - lo] - med[i - lo]) * step)
        if pos:
            q = np.concatenate(pos)
            order = np.argsort(q, kind="stable")
            fixes.append((p0, p1, q[order], np.cumsum(np.concatenate(dth)[order])))
    if not fixes:
        return "no flagged sample inside a segment"

    def shift(sign: float) -> None:
        for p0, p1, q, csum in fixes:  # θ after each flagged sample moves by the Δθ so far
            ends = np.append(q[1:], p1 - p0)
            for start, end, c in zip(q, ends, csum):
                theta[p0 + start:p0 + end] -= sign * c

    shift(1.0)
    try:
        return compute_deviation(series, series.tau0, input_kind=series.input_kind,
                                 kind="oadev", taus=[float(t) for t in res.fit_dev.tau],
                                 confidence=confidence, stop_ratio=stop_ratio,
                                 unit=res.dev.unit)
    except (InputError, AnalysisError) as e:
        return str(e)
    finally:
        shift(-1.0)


def _spike_guard(res: AxisAnalysis, rep, dev_c) -> None:
    """No term is identified from flagged spikes (``--outliers flag``, the rate analysed as
    recorded).

    The fitted models (requested and diagnosed) are refitted, same terms and τ, to the OADEV
    of the rate with the flagged samples replaced by their running median (the ``remove``
    treatment). A term identified on the record as it is but not without the spikes rests on
    them: it becomes an upper bound (the 95 % bound of the refit, the sensor's own), with the
    reason in its notes and ``status_note``; a term identified both ways whose value moves by
    more than twice its 1σ gets the value without the spikes in its notes. The warnings are
    recomputed with the new statuses. Modifies ``res`` in place. ``dev_c`` is the cleaned
    OADEV (:func:`_clean_dev`, :func:`_clean_dev_streamed`) or the reason it is missing."""
    from .outliers import MAX_LISTED

    if isinstance(dev_c, str):
        res.notes.append(f"spike guard not applied: {dev_c}")
        return
    ev = sorted(rep.events, key=lambda e: -abs(e.peak_z))[:MAX_LISTED]
    where = ", ".join(f"t = {e.t_s:.6g} s ({e.peak_z:+.0f}σ)"
                      for e in sorted(ev, key=lambda e: e.t_s))
    models = [res.fit]
    if res.diagnosis is not None and res.diagnosis.final is not res.fit:
        models.append(res.diagnosis.final)
    marked: list[str] = []
    for model in models:
        try:
            ref = fit_deviation(dev_c, terms=model.requested, min_edf=model.min_edf,
                                bi_cutoff_hz=model.bi_f0)
        except AnalysisError:
            continue
        for t in model.terms:
            if not t.identified:
                continue
            tc = ref.term(t.label)
            if tc is None or not tc.identified:
                bound = tc.upper if tc is not None and tc.upper is not None else t.value
                t.notes.append(
                    f"identified only with the {rep.n_outliers} flagged spike sample(s) "
                    f"({where}): with them replaced by their running median the same model "
                    f"gives {t.main} ≤ {bound:.4g} {t.units[t.main]} (not identified); "
                    f"{t.main} = {t.value:.4g} with the spikes is theirs, not the sensor's")
                t.status = "upper bound"
                t.status_note = "spike-driven"
                t.upper = bound
                t.sigma = {k: None for k in t.sigma}
                marked.append(f"{t.label} ({t.main} = {t.value:.4g} → ≤ {bound:.4g})")
            else:
                s_raw = t.sigma.get(t.main) or 0.0
                s_cln = tc.sigma.get(t.main) or 0.0
                if abs(t.value - tc.value) > 2.0 * max(s_raw, s_cln, 1e-300):
                    t.status_note = "spikes move it"
                    t.notes.append(f"without the {rep.n_outliers} flagged spike sample(s): "
                                   f"{tc.text()} (the spikes move it)")
                    marked.append(f"{t.label} moved: {t.value:.4g} with the spikes, "
                                  f"{tc.value:.4g} without")
    if not marked:
        return
    res.notes.append("spike guard (no term identified from flagged spikes): "
                     + "; ".join(dict.fromkeys(marked))
                     + " — --outliers remove analyses the rate without them")
    if res.check_inputs is not None:
        warns = krobka_checks(res.fit, res.readoffs, **res.check_inputs)
        from .filtered import FILTER_STATUS

        if any(t.status == FILTER_STATUS for m in models for t in m.terms):
            warns = [w for w in warns if w.code not in ("KROBKA-M1", "KROBKA-M5")]
        res.warnings = warns
    res.conversions = conversions(res.best_fit)
