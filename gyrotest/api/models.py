"""The model workbench and the environmental fits: :class:`Model` (``fit``, ``diagnose``),
:func:`thermal_fit`, :func:`mag_fit`, :func:`compensate` (re-exported at the top level).

These are thin wrappers of the workbench engine (:mod:`gyrotest.envmodel`: ``fit_log``,
``diagnose_log``, ``analyse_thermal``, ``analyse_mag``, ``compensate``): the options are
translated once here, the results wrapped in :mod:`gyrotest.api.results`, so the engine behind
them can change without changing this API.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence

from ..core.errors import InputError, OptionError
from ..io.inputs import as_profile, is_log, read_log_from, split_read_options
from .analyses import _env_model, _read_for
from .modelresults import CompensationResult, MagResult, ModelDiagnosis, ModelFit, ThermalResult

__all__ = ["Model", "compensate", "mag_fit", "read_reference", "thermal_fit"]

_AUX = ("temperature", "field", "supply", "table_rate", "position", "extra")


def read_reference(reference, profile=None, opts: dict | None = None):
    """The static reference run of ``reference=`` (a path read with the log's ingest options
    and profile, without the auxiliary channels a static run need not have; or a log already
    read). Errors name the option."""
    if reference is None or (isinstance(reference, str) and not reference):
        return None
    if is_log(reference):
        return reference
    import dataclasses

    from ..io.inputs import ingest_overrides

    try:
        prof = as_profile(profile)
        if prof is not None:
            prof = dataclasses.replace(prof, columns={k: v for k, v in prof.columns.items()
                                                      if k not in _AUX})
        o = {k: v for k, v in (opts or {}).items()
             if k not in ("temp_col", "field_cols", "supply_col", "table_col", "position_col")}
        if isinstance(reference, (str, os.PathLike)):
            from ..io.ingest import read_log

            ov = ingest_overrides(o)
            return read_log(os.fspath(reference), profile=prof, overrides=ov,
                            nan_policy=o.get("nan_policy") or "error", dead="error")
        return read_log_from(reference, profile=prof, opts=o)
    except InputError as e:
        raise InputError(f"--reference: {e}") from None


def _path_of(data) -> str | None:
    """The file a log came from, for the model's provenance (None for frames and arrays)."""
    if isinstance(data, (str, os.PathLike)):
        return os.fspath(data)
    if is_log(data):
        src = data.source
        return "-" if src == "<stdin>" else (src if os.path.isfile(src) else None)
    return None


def _one(data, where: str):
    if isinstance(data, (list, tuple)):
        raise OptionError(f"{where}: one log, got {len(data)}")
    return data


def thermal_fit(data=None, *, setpoints=None, t0: float = 21.0, sensor: str | None = None,
                gradient: str | Sequence[str] | None = None, weighted: bool = False,
                axis: str | None = None, skip: float | str = 0,
                resolution: float | str = "auto", smooth: float | str = "auto",
                folds: int = 5, reference=None, profile=None,
                **read_options) -> ThermalResult:
    r"""Thermal drift model of a chamber run or a set-point table (``gyrotest thermal-fit``).

    The model of Antonova & Matveev, "Model of error of a fiber-optic gyro exposed to
    thermal and magnetic fields" (Herald of the Bauman Moscow State Technical University,
    Instrument Engineering, 2014):

    .. math::

        \Delta\omega = w_0 + w_1\,\Delta T + w_2\,\Delta T^2 + w_{\Delta V}\,\frac{dT}{dt},
        \qquad \Delta T = T - t_0,

    (w0 deg/h, w1 (deg/h)/degC, w2 (deg/h)/degC², w_ΔV (deg/h)/(degC/h)), with the IEEE Std
    952-1997 §8.3 E terms D_T, D_Ṫ and, with two temperature channels, the gradient-rate
    term D_∇Ṫ. Fitted on block means at the working resolution; 1σ are generalised least squares under the gyro's noise model,
    honest for autocorrelated residuals; the held-out RMS comes from blocked
    cross-validation; a heating-vs-cooling hysteresis check follows. From a set-point table
    dT/dt = 0, so w_ΔV needs a chamber run.

    Parameters
    ----------
    data : path, DataFrame, Simulation or GyroLog, optional
        A continuous chamber run with at least one temperature channel.
    setpoints : str, optional
        A CSV table of steady set-points: temperature, dw[, sigma][, dTdt].
    t0 : float, default 21.0
        Reference temperature t0, degC.
    sensor : str, optional
        Temperature channel of the model (default: the one that fits held-out data best).
    gradient : str or sequence of str, optional
        Two temperature channels ``"A,B"`` for D_∇Ṫ = d(T_A − T_B)/dt.
    weighted : bool, default False
        Weight set-points by 1/σ².
    axis : str, optional
        Gyro axis (default the first).
    skip : float or str, default 0
        Drop the start of the log, s or ``"10min"``.
    resolution, smooth : float or str, default "auto"
        Working resolution (block length) and dT/dt smoother window, s or ``"auto"``.
    folds : int, default 5
        Folds of the blocked cross-validation.
    reference : path or GyroLog, optional
        A static reference run of the same gyro: its noise gives the floor.
    profile, **read_options
        How to read ``data``: see :func:`gyrotest.read`.

    Returns
    -------
    ThermalResult
        ``to_dict()`` is the ``gyrotest thermal-fit --json`` document; ``coef("D_T")`` a
        coefficient (``value``, ``stderr``, ``unit``); ``to_frame()`` every coefficient;
        ``model`` the fitted model for :func:`compensate` (``.save(path)``).

    Raises
    ------
    gyrotest.InputError
        No temperature channel, a log too short, a bad set-point table or option.

    Examples
    --------
    The set-point table of the paper's thermostat test (31…55 °C):

    >>> import gyrotest
    >>> res = gyrotest.thermal_fit(setpoints="sample_data/thermostat.csv", t0=21)
    >>> print(res.to_frame()[["name", "value", "unit"]].round(4).to_string(index=False))
    name   value           unit
      w0  1.3055          deg/h
      w1 -0.1173   deg/(h·degC)
      w2  0.0036 deg/(h·degC^2)
    """
    opts = split_read_options(dict(read_options), "thermal_fit")
    from ..envmodel.domain import (
        analyse_thermal,
        check_thermal_input,
        parse_gradient,
        thermal_terms,
    )

    check_thermal_input(data is not None, setpoints)
    parse_gradient(gradient)
    g = ref = None
    if data is not None:
        g = _read_for(_one(data, "thermal_fit"), "thermal_fit", profile, opts,
                      thermal_terms())[0]
        ref = read_reference(reference, profile, opts)
    elif reference is not None:
        raise OptionError("reference needs a chamber log (it sets the noise floor of the "
                          "chamber-run fit)")
    return ThermalResult(analyse_thermal(
        g, path=_path_of(data), setpoints=setpoints, t0_c=t0, sensor=sensor, gradient=gradient,
        weighted=weighted, axis=axis, skip=skip, resolution=resolution, smooth=smooth,
        folds=folds, reference=ref))


def mag_fit(data, *, with_terms: str | None = None, settle: float | str = "10s",
            min_dwell: float | str = "30s", axis: str | None = None, skip: float | str = 0,
            resolution: float | str = "auto", smooth: float | str = "auto", folds: int = 5,
            reference=None, profile=None, **read_options) -> MagResult:
    r"""Magnetic sensitivities from a Helmholtz-coil run (``gyrotest mag-fit``).

    .. math::

        \Delta\omega = w_0 + w_x \frac{H_x}{H_0} + w_y \frac{H_y}{H_0} + w_z \frac{H_z}{H_0},
        \qquad H_0 = 100\ \mu T,

    (IEEE Std 952-1997 §5.3.3.2; Antonova & Matveev 2014), coefficients in deg/h per
    100 µT with 1σ, from a sequence of field levels stepped one axis at a time (plateaus
    and axes detected) or a continuous magnetometer log. Cross-checks: the paper's reversal
    estimate K = \|Δω(+max) − Δω(−max)\| / (2·max/100 µT) (K = Δω/6 for ±300 µT) and the
    up/down sweep hysteresis.

    Parameters
    ----------
    data : path, DataFrame, Simulation or GyroLog
        A log with three magnetic-field channels (µT).
    with_terms : str, optional
        Extra terms for drift between levels, e.g. ``"T"`` or ``"ramp"`` (``--with``).
    settle : float or str, default "10s"
        Time dropped after every field step when averaging a plateau.
    min_dwell : float or str, default "30s"
        Shortest constant-field stretch that counts as a plateau.
    axis, skip, resolution, smooth, folds, reference
        As in :func:`thermal_fit`.
    profile, **read_options
        How to read ``data``: see :func:`gyrotest.read` (``field_cols="Hx,Hy,Hz"``).

    Returns
    -------
    MagResult
        ``to_dict()`` is the ``gyrotest mag-fit --json`` document; ``to_frame()`` one row
        per axis (value, sigma, reversal K, up − down); ``model`` the fitted model.

    Raises
    ------
    gyrotest.InputError
        Fewer than three field channels, no plateau, a bad option.

    Examples
    --------
    >>> import gyrotest
    >>> res = gyrotest.mag_fit("sample_data/magnetic.parquet",
    ...                        profile="sample_data/magnetic.profile.toml")
    >>> print(res.to_frame()[["name", "value", "sigma"]].round(2).to_string(index=False))
    name  value  sigma
      wx  -0.05   0.01
      wy  -0.59   0.01
      wz  -0.26   0.01
    """
    opts = split_read_options(dict(read_options), "mag_fit")
    from ..envmodel.domain import analyse_mag, mag_terms
    from ..io.inputs import seconds

    _, specs = mag_terms(with_terms)
    settle_s, dwell_s = seconds(settle, "settle"), seconds(min_dwell, "min_dwell")
    g = _read_for(_one(data, "mag_fit"), "mag_fit", profile, opts, specs)[0]
    ref = read_reference(reference, profile, opts)
    return MagResult(analyse_mag(g, path=_path_of(data), with_terms=with_terms,
                                 settle_s=settle_s, min_dwell_s=dwell_s, axis=axis, skip=skip,
                                 resolution=resolution, smooth=smooth, folds=folds,
                                 reference=ref))


class Model:
    r"""A drift model of physical effects: fit it to a log, find what it lacks.

    The gyro rate (minus the rate-table rate, if any) is modelled as a bias plus the terms,
    each one physical effect in its own units (IEEE Std 952-1997 §8.3 E terms: D_T
    (deg/h)/degC, D_Ṫ (deg/h)/(degC/h), w_x deg/h per 100 µT, ...; the library:
    ``gyrotest model terms``):

    .. math::

        \omega(t) = D_F + \sum_k c_k\, x_k(t) + \varepsilon(t),

    fitted on block means at a working resolution chosen from the noise level, under the
    gyro's own noise model ε: white, flicker and rate random-walk noise (IEEE 952 N, B, K)
    fitted by maximum likelihood with the model (or fixed from a static ``reference`` run);
    the coefficients are generalised least squares with its 1σ, the held-out RMS is from
    blocked cross-validation.

    Parameters
    ----------
    terms : str or sequence of str, optional
        Model terms, comma-separated or a list: T, T2, T3, dTdt, dGdt, Tlag, dTlagdt, Hx,
        Hy, Hz, Hvec, V, g, g2, ramp, warmup, sin, hyst, rate, rateT, chan(...); a channel
        in parentheses, e.g. ``"T(T_case_C)"`` or ``"dGdt(T_a,T_b)"``.
    custom : sequence of str, optional
        Custom terms ``"NAME:EXPRESSION"`` from any channel, e.g. ``"vib:extra.vib_g**2"``
        (parsed safely, never evaluated as Python).
    axis : str, optional
        Gyro axis to model (default the first).
    skip : float or str, default 0
        Drop the start of the log; the warm-up term then counts from the true power-on.
    t_ref, v_ref : float, optional
        Reference temperature (degC) and supply voltage (V); default the means.
    resolution, smooth : float or str, default "auto"
        Working resolution and smoother window, s or ``"auto"``.
    folds : int, default 5
        Folds of the blocked cross-validation.
    reference : path or GyroLog, optional
        A static reference run of the same gyro whose noise model is fixed for the fit.
    power_on : bool, optional
        The log starts at the gyro's power-on (a warm-up transient is then a candidate of
        :meth:`diagnose`); default the profile's ``[gyro] power_on_at_start``, else no.

    Raises
    ------
    gyrotest.InputError
        A term text that cannot be parsed (the message names it).

    Examples
    --------
    >>> import gyrotest
    >>> m = gyrotest.Model("T(T_coil_a_C),dTdt(T_coil_a_C)")
    >>> m.terms
    ['T(T_coil_a_C)', 'dTdt(T_coil_a_C)']
    >>> fit = m.fit("sample_data/thermal.parquet", profile="sample_data/thermal.profile.toml")
    >>> fit.to_frame()["name"].tolist()
    ['bias', 'T(T_coil_a_C)', 'dTdt(T_coil_a_C)']
    """

    def __init__(self, terms: str | Sequence[str] = (), *, custom: Sequence[str] = (),
                 axis: str | None = None, skip: float | str = 0, t_ref: float | None = None,
                 v_ref: float | None = None, resolution: float | str = "auto",
                 smooth: float | str = "auto", folds: int = 5, reference=None,
                 power_on: bool | None = None) -> None:
        from ..envmodel.pipeline import collect_terms

        texts = [terms] if isinstance(terms, str) else list(terms)
        custom = [custom] if isinstance(custom, str) else list(custom)
        self.specs = collect_terms(texts, custom)
        self.options = dict(axis=axis, skip=skip, t_ref=t_ref, v_ref=v_ref,
                            resolution=resolution, smooth=smooth, folds=folds)
        self.reference = reference
        self.power_on = power_on

    @property
    def terms(self) -> list[str]:
        """The terms as text, one per term."""
        return [s.label for s in self.specs]

    def __repr__(self) -> str:
        return f"Model({self.terms!r})"

    def _log(self, data, profile, read_options: dict, where: str):
        opts = split_read_options(dict(read_options), where)
        g = _read_for(_one(data, where), where, profile, opts, self.specs)[0]
        return g, read_reference(self.reference, profile, opts)

    def fit(self, data, *, k: float = 4.0, profile=None, **read_options) -> ModelFit:
        """Fit the model to a log and show where it fails (``gyrotest model fit``).

        Parameters
        ----------
        data : path, DataFrame, Simulation or GyroLog
            The log, as :func:`gyrotest.read` takes it.
        k : float, default 4.0
            Excursion threshold: \\|smoothed residual\\| > k·σ marks where the model fails.
        profile, **read_options
            How to read ``data``: see :func:`gyrotest.read`.

        Returns
        -------
        ModelFit
            ``to_dict()`` is the ``gyrotest model fit --json`` document; ``to_frame()`` the
            coefficients (1σ, GLS under the noise model); ``rms_fit``, ``rms_holdout``,
            ``noise`` (the noise model), ``floor`` (its RMS at the working resolution),
            ``loglik``, ``excursions``; ``save(path)`` writes the model for
            :func:`compensate`.

        Raises
        ------
        gyrotest.InputError
            A channel a term needs is missing (the message names the term), a log too
            short for the model.

        Examples
        --------
        >>> import gyrotest
        >>> fit = gyrotest.Model("T").fit("sample_data/thermal.parquet",
        ...                              profile="sample_data/thermal.profile.toml")
        >>> fit.noise.params.N > 0                   # the gyro's white noise, deg/√h
        True
        """
        from ..envmodel.pipeline import fit_log

        g, ref = self._log(data, profile, read_options, "Model.fit")
        return ModelFit(fit_log(g, self.specs, path=_path_of(data), k_sigma=k, reference=ref,
                                **self.options))

    def diagnose(self, data, *, candidates: str | Sequence[str] | None = None,
                 alpha: float = 0.01, path: int = 3,
                 progress: Callable[[int, int, str], None] | None = None, profile=None,
                 **read_options) -> ModelDiagnosis:
        """Which physical effect does the model lack? (``gyrotest model diagnose``)

        Every candidate the log's channels allow (the library and a screen of every logged
        channel) is added in turn and tested by its likelihood ratio under the gyro's fitted
        noise model; a searched time constant, frequency or width is corrected by Davies'
        bound and the step's candidates by a min-P parametric bootstrap. A candidate is a
        missing effect when its family-wise p-value is at most ``alpha``; the verdict names
        it, the complete ``--terms`` to add it and the forward path; with nothing missing it
        tests the residual against the noise model (``gyrotest model diagnose --rules``
        states every rule).

        Parameters
        ----------
        data : path, DataFrame, Simulation or GyroLog
            The log, as :func:`gyrotest.read` takes it.
        candidates : str or sequence of str, optional
            Only try these terms (default every term the channels allow).
        alpha : float, default 0.01
            Family-wise probability of naming a missing effect that does not exist, per
            step.
        path : int, default 3
            Steps of the forward path after the missing effect.
        progress : callable, optional
            ``progress(i, n, label)`` before each candidate is tried.
        profile, **read_options
            How to read ``data``: see :func:`gyrotest.read`.

        Returns
        -------
        ModelDiagnosis
            ``to_dict()`` is the ``gyrotest model diagnose --json`` document; ``verdict``;
            ``missing`` (the term text, or None); ``to_frame()`` the candidates, best first.

        Raises
        ------
        gyrotest.InputError
            A channel a term needs is missing, a bad candidate text.

        Examples
        --------
        >>> import gyrotest
        >>> d = gyrotest.Model("T(T_coil_a_C)").diagnose(
        ...     "sample_data/thermal.parquet", profile="sample_data/thermal.profile.toml",
        ...     candidates="dTdt(T_coil_a_C),ramp")    # doctest: +SKIP
        >>> d.missing                                   # doctest: +SKIP
        'dTdt(T_coil_a_C)'
        """
        from ..envmodel.terms import split_terms
        from ..envmodel.workbench import diagnose_log

        cand = None
        if candidates:
            cand = split_terms(candidates if isinstance(candidates, str)
                               else ",".join(candidates))
        g, ref = self._log(data, profile, read_options, "Model.diagnose")
        return ModelDiagnosis(diagnose_log(g, self.specs, cand, path=_path_of(data),
                                           alpha=alpha, reference=ref, path_steps=path,
                                           progress=progress, power_on=self.power_on,
                                           **self.options))


def compensate(data, model, *, keep_bias: bool = False, profile=None,
               **read_options) -> CompensationResult:
    r"""Apply a drift model to another run: drift before and after (``gyrotest compensate``).

    The transfer test a lab does before trusting a compensation: the model's predicted
    drift (without its constant bias unless ``keep_bias``) is subtracted,

    .. math::

        \omega_c(t) = \omega(t) - \sum_k c_k\, x_k(t),

    and the drift RMS and peak-to-peak at the model's working resolution are compared with
    the reduction the model predicts (its held-out RMS on the fitting run); the Allan
    deviation before and after shows what changed at every τ. The terms are the E terms of the
    IEEE Std 952-1997 §8.3 model equation.

    Parameters
    ----------
    data : path, DataFrame, Simulation or GyroLog
        The run to compensate.
    model : str, EnvModel or a fit result
        A model file (``gyrotest model fit -o``, ``thermal-fit -o``, ``mag-fit -o``), or
        the result of :meth:`Model.fit`, :func:`thermal_fit`, :func:`mag_fit`.
    keep_bias : bool, default False
        Do not subtract the model's constant bias.
    profile, **read_options
        How to read ``data``: see :func:`gyrotest.read`.

    Returns
    -------
    CompensationResult
        ``to_dict()`` is the ``gyrotest compensate --json`` document; ``rms_before_dph``,
        ``rms_after_dph``, ``factor``, ``predicted_factor``; ``log`` the compensated log;
        ``to_frame()`` the Allan deviation before and after.

    Raises
    ------
    gyrotest.InputError
        A channel the model needs is missing, an unreadable model file.

    Examples
    --------
    >>> import gyrotest
    >>> m = gyrotest.thermal_fit("sample_data/thermal.parquet",
    ...                          profile="sample_data/thermal.profile.toml")
    >>> cp = gyrotest.compensate("sample_data/thermal.parquet", m,
    ...                          profile="sample_data/thermal.profile.toml")
    >>> cp.factor > 10          # the drift falls by more than 10x
    True
    """
    opts = split_read_options(dict(read_options), "compensate")
    from ..envmodel.compensation import compensate as engine

    env = _env_model(model)
    g = _read_for(_one(data, "compensate"), "compensate", profile, opts, env.specs)[0]
    model_file = os.fspath(model) if isinstance(model, (str, os.PathLike)) else None
    return CompensationResult(engine(g, env, keep_bias=keep_bias), model_file=model_file)


