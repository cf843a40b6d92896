"""Reading a log and the static analyses: :func:`read`, :func:`allan`, :func:`bias`,
:func:`scale_factor` (re-exported at the top level: ``gyrotest.allan`` ...).

Each function takes what a notebook has (a path, a DataFrame, a numpy array with its sample
interval and unit, a simulation, or a list of them where the command takes several logs),
keyword-only options with the command line's names and units, and returns the result object
the command renders. The command line calls these same functions.
"""

from __future__ import annotations

from collections.abc import Sequence

from ..core.errors import OptionError
from ..io.inputs import as_logs, read_log_from, seconds, split_read_options, text_list
from .results import AllanResult, BiasResult, ScaleFactorResult

__all__ = ["allan", "bias", "read", "scale_factor"]


def read(data, profile=None, *, sample_interval=None, unit: str | None = None,
         name: str | None = None, stream: bool = False, **options):
    """Read a bench log into a :class:`~gyrotest.core.data.GyroLog` (``gyrotest info``/``ingest``).

    The gyro output becomes an angular rate in deg/h (one array per axis), time seconds from
    the first sample, temperatures degC, magnetic field µT, supply voltage V; gaps (intervals
    over 1.5 nominal) split the log into segments. Pulse counts become rate as
    ``counts · S0 / τ0`` (S0 in arcsec/pulse, 1 arcsec/s = 1 deg/h), an analog output as
    ``S0 · (V − offset)`` (IEEE Std 952-1997 §8.3 model equation).

    Parameters
    ----------
    data : str, os.PathLike, pandas.DataFrame, numpy.ndarray, Simulation or GyroLog
        A log file (CSV/TSV/whitespace text, gzip'd text, Parquet, Feather, MATLAB, HDF5, ROS
        bag, ``"-"`` for CSV on stdin), a DataFrame with the same columns (a named or
        datetime index is used as a column), a numpy array of rates (1-D, or samples x axes)
        with ``sample_interval`` and ``unit``, a :func:`gyrotest.simulate` result, or a log
        already read (returned as it is).
    profile : str, os.PathLike, dict or Profile, optional
        Bench profile: a TOML file, or a dict of the same shape (``{"columns": {...},
        "gyro": {...}, "site": {...}}``). The options below override it key by key.
    sample_interval : float or str, optional
        Sample interval τ0 of an array or frame without time column, in s, or a duration such
        as ``"10ms"``.
    unit : str, optional
        Unit of an array's (or frame's) rate values: ``deg/h``, ``deg/s``, ``rad/s``,
        ``mrad/s``, ``urad/s``, ``deg/min``, ``arcsec/s``.
    name : str, optional
        Name of a frame or array in results and messages (default ``"<DataFrame>"``,
        ``"<array>"``).
    stream : bool, default False
        A Parquet log of ≥ 2**24 rows comes back as its integrated angle only (a
        :class:`~gyrotest.io.stream.StreamedLog`, enough for :func:`allan`).
    **options
        Ingest options with the command line's names: ``time_col``, ``rate_col`` (a name, a
        list or comma-separated names for several axes), ``rate_unit``, ``counts_col``,
        ``up_col``, ``down_col``, ``counter_col``, ``counter_bits``, ``voltage_col``,
        ``delta_angle_col``, ``angle_col``, ``angle_unit``, ``output_kind``,
        ``scale_factor`` (S0: arcsec/pulse or (deg/h)/V), ``offset`` (V), ``sample_rate``
        (Hz), ``time_unit``, ``temp_col`` (a name or a list), ``field_cols``,
        ``supply_col``, ``table_col``, ``position_col``, ``latitude`` (deg), ``ia``
        (``up``, ``north`` ... or ``"AZ/EL"``), ``topic``, ``nan`` (``error``, ``gap`` or
        ``interpolate``).

    Returns
    -------
    GyroLog
        The log in internal units: ``rates`` (deg/h by axis), ``tau0`` (s), ``timing``
        (gaps, jitter), ``temperature``, ``field_uT``, ``supply``, ``table_rate``, ``site``,
        ``notes`` (what ingest assumed or left out).

    Raises
    ------
    gyrotest.InputError
        A file that cannot be read, a missing column, a bad unit or value; the message names
        the file, row or column and the fix.
    gyrotest.OptionError
        An option with a wrong value or type (e.g. an array without ``sample_interval``).

    See Also
    --------
    allan, bias : analyses that take the same inputs and options.

    Examples
    --------
    A numpy array of rates with its sample interval and unit:

    >>> import numpy as np, gyrotest
    >>> rate = np.random.default_rng(1).normal(0.0, 0.01, 36000)
    >>> log = gyrotest.read(rate, sample_interval=0.1, unit="deg/s")
    >>> log.tau0, log.n, round(float(log.rate.std()), 1)     # rate in deg/h
    (0.1, 36000, 35.7)
    """
    opts = split_read_options(dict(options), "read")
    return read_log_from(data, profile=profile, opts=opts, sample_interval=sample_interval,
                         unit=unit, name=name, stream=stream)


def _empty(data) -> bool:
    return data is None or (isinstance(data, (list, tuple)) and not data)


def _env_model(model):
    """A drift model given as a file, an EnvModel or a result holding one."""
    if model is None:
        return None
    from ..envmodel.model import EnvModel

    if isinstance(model, EnvModel):
        return model
    inner = getattr(model, "model", None)
    if isinstance(inner, EnvModel):
        return inner
    import os

    if isinstance(model, (str, os.PathLike)):
        return EnvModel.load(os.fspath(model))
    raise OptionError(f"model: expected a model file, an EnvModel or a fit result, got "
                      f"{type(model).__name__}")


def _read_for(data, where: str, profile, opts, specs=None, **kw) -> list:
    """Read the logs of an analysis; with model ``specs``, an ingest error about a channel a
    term needs names the term (as the commands do)."""
    if not specs:
        return as_logs(data, where, profile=profile, opts=opts, **kw)
    from ..envmodel.pipeline import naming_terms

    return naming_terms(lambda: as_logs(data, where, profile=profile, opts=opts, **kw),
                          specs)


def allan_settings(*, dev="oadev", taus="10/decade", stop_ratio=None, terms="Q,N,B,K,R",
                   axis=None, confidence=0.683, ci="stable32", min_edf=None, detrend="none",
                   skip=0, outliers="flag", vehicle_rate=(), horizon="1h", bi_cutoff=None,
                   diagnose=True, fit=True, allow_irregular=False, fill=1) -> dict:
    """:func:`allan`'s options as :func:`gyrotest.noise.analysis.analyse_allan` takes them
    (checked: an InputError names the option)."""
    from ..noise.analysis import parse_detrend, parse_taus
    from ..noise.impact import parse_horizon, parse_vehicle_rate
    from ..noise.kinds import DEVIATION_KINDS, MIN_EDF
    from ..noise.noisefit import parse_terms

    if dev not in DEVIATION_KINDS:
        raise OptionError(f"dev: unknown deviation {dev!r}", fix="use one of "
                          + ", ".join(DEVIATION_KINDS))
    if ci not in ("stable32", "conservative"):
        raise OptionError(f"ci: {ci!r}", fix="use stable32 or conservative")
    if outliers not in ("flag", "remove", "robust"):
        raise OptionError(f"outliers: {outliers!r}", fix="use flag, remove or robust")
    if not 0.0 < float(confidence) < 1.0:
        raise OptionError(f"confidence must be between 0 and 1, got {confidence}")
    seconds(skip, "skip")
    rates = [vehicle_rate] if isinstance(vehicle_rate, (str, int, float)) else vehicle_rate
    parse_detrend(detrend)
    if isinstance(axis, str):
        axis = [a.strip() for a in axis.split(",") if a.strip()] or None
    return dict(skip_s=skip, dev=dev, taus=parse_taus(taus), terms=parse_terms(text_list(terms)),
                vehicle_rates=[parse_vehicle_rate(v) for v in rates or ()],
                axes=list(axis) if axis else None, confidence=float(confidence),
                stop_ratio=stop_ratio, min_edf=MIN_EDF if min_edf is None else min_edf,
                detrend=detrend, run_diagnosis=bool(diagnose),
                impact_horizon_s=parse_horizon(horizon), bi_cutoff_hz=bi_cutoff,
                allow_irregular=allow_irregular, fit_model=bool(fit), ci=ci,
                outliers=outliers, fill=int(fill))


def allan(data, *, dev: str = "oadev", taus: str | Sequence[float] = "10/decade",
          stop_ratio: float | None = None, terms: str | Sequence[str] = "Q,N,B,K,R",
          axis: str | Sequence[str] | None = None, confidence: float = 0.683,
          ci: str = "stable32", min_edf: float | None = None, detrend: str = "none",
          model=None, skip: float | str = 0, outliers: str = "flag",
          vehicle_rate: str | float | Sequence = (), horizon: float | str = "1h",
          bi_cutoff: float | None = None, diagnose: bool = True, fit: bool = True,
          allow_irregular: bool = False, fill: int = 1, profile=None, sample_interval=None,
          unit: str | None = None, **read_options) -> AllanResult:
    r"""Allan noise analysis that explains itself (``gyrotest allan``).

    The deviation table of the requested kind with χ² confidence intervals from the
    equivalent degrees of freedom of the identified noise type, a joint fit of the IEEE
    noise terms to the Allan variance, each coefficient *identified* or an upper bound, the
    residuals in CI units, the search for missing terms, Krobka's warnings and the
    platform vs strapdown attitude-error growth.

    The overlapping Allan variance of rate samples y_k at τ = m·τ0 (IEEE Std 952-1997
    Annex C; NIST SP 1065 eq. 14) is

    .. math::

        \sigma^2(\tau) = \frac{1}{2 m^2 (M - 2m + 1)} \sum_{j=1}^{M-2m+1}
        \Big[\sum_{i=j}^{j+m-1} (y_{i+m} - y_i)\Big]^2,

    and the noise model adds the terms' Allan variances in quadrature (IEEE Std 952-1997
    Annex C, eq. C.11):

    .. math::

        \sigma^2(\tau) = \frac{3Q^2}{\tau^2} + \frac{N^2}{\tau} + \frac{2\ln 2}{\pi}B^2
        + \frac{K^2\tau}{3} + \frac{R^2\tau^2}{2},

    fitted by maximum likelihood with each estimate's χ² distribution (not slope lines).
    Intervals: EDF of Greenhall & Riley, "Uncertainty of stability variances based on
    finite differences" (PTTI 2003/2004), noise type by Riley & Greenhall's lag-1
    autocorrelation; misreadings of the Allan graph after Krobka, "On the topology of the
    Allan variance graphs and typical misconceptions in the interpretations of the gyro
    noise structure" (ICINS, 2015).

    Parameters
    ----------
    data : path, DataFrame, numpy array, Simulation, GyroLog, or a list of them
        The log(s), as :func:`read` takes them; several logs give one result with one entry
        per log (``res.logs``).
    dev : str, default "oadev"
        Deviation of the table: oadev, adev, mdev, tdev, hdev, ohdev, totdev, mtotdev,
        akdev, hkdev, ... The noise model is always fitted to an Allan-type one.
    taus : str or sequence of float, default "10/decade"
        τ grid: ``octave``, ``decade``, ``N/decade``, ``all``, or the τ values in s.
    stop_ratio : float, optional
        Longest τ = T/ratio for generated grids (default Stable32's, 4 for OADEV).
    terms : str or sequence of str, default "Q,N,B,K,R"
        Noise terms to fit: Q (arcsec), N (deg/√h), B (deg/h), K (deg/h/√h), R (deg/h/h),
        markov, sine, blue; ``"+markov"`` adds to the default.
    axis : str or sequence of str, optional
        Rate axes to analyse (default every axis).
    confidence : float, default 0.683
        Confidence of the χ² intervals.
    ci : {"stable32", "conservative"}
        Interval columns: Stable32's, or also a conservative one in its own columns.
    min_edf : float, optional
        τ with fewer equivalent degrees of freedom are shown, not fitted.
    detrend : str, default "none"
        Remove a least-squares trend first: ``none``, ``linear``, ``quadratic`` or
        ``sine:PERIOD`` (e.g. ``sine:24h``).
    model : str, EnvModel or fit result, optional
        A drift model (file of ``gyrotest model fit -o``, or :meth:`Model.fit`'s result):
        its deterministic drift is removed before the noise analysis.
    skip : float or str, default 0
        Warm-up trim at the start, s or a duration such as ``"30min"``.
    outliers : {"flag", "remove", "robust"}
        Spikes (Hampel filter): warn with their times; replace each by its running median;
        or clip each to the threshold.
    vehicle_rate : str, float or sequence, optional
        Strapdown vehicle rate(s) for the impact prediction, e.g. ``"10deg/s"`` (a bare
        number is deg/s).
    horizon : float or str, default "1h"
        Time at which the attitude error is reported.
    bi_cutoff : float, optional
        Fit the full bias-instability template with this cut-off f0, Hz.
    diagnose : bool, default True
        Search for missing terms (``--no-diagnose`` is ``diagnose=False``).
    fit : bool, default True
        Fit the noise model (``--no-fit`` is ``fit=False``: the plain table).
    allow_irregular : bool, default False
        Analyse on the nominal τ0 even if the sample interval jitters by more than 10 %.
    fill : int, default 1
        Bridge gaps of at most this many missed samples before the analysis (0 never
        bridges); the bridged samples serve only the longer τ (``--fill``).
    profile, sample_interval, unit, **read_options
        How to read ``data``: see :func:`read`.

    Returns
    -------
    AllanResult
        ``to_dict()`` is the ``gyrotest allan --json`` document; ``to_frame()`` the
        deviation table (``tau_s``, ``sigma_dph`` ...); ``terms()`` every fitted term;
        ``term("N")`` one term (``.value``, ``.sigma``, ``.upper``, ``.status``);
        ``plot()`` σ(τ) with the fit, components and residuals.

    Raises
    ------
    gyrotest.InputError
        A log or option the analysis cannot use (too short for the τ grid, irregular
        sampling, an unknown term ...), with the fix.
    gyrotest.OptionError
        An option with a wrong value (unknown ``dev``, ``confidence`` outside (0, 1) ...).

    See Also
    --------
    read : the inputs and ingest options.

    Examples
    --------
    White rate noise of N = 0.01 deg/√h and bias instability B = 0.02 deg/h, 2 h at 10 Hz:

    >>> import gyrotest
    >>> sim = gyrotest.simulate({"record": {"sample_rate_hz": 10, "duration_s": "2h"},
    ...                          "gyro": {"noise": {"N": 0.01, "B": 0.02}}}, seed=1)
    >>> res = gyrotest.allan(sim, terms="N,B")
    >>> print(res.term("N").text())
    N = 0.009997 ± 3.2e-05 deg/sqrt(h)
    >>> res.to_frame()[["tau_s", "sigma_dph"]].head(3).round(3)  # N·60/√τ = 1.897 at 0.1 s
       tau_s  sigma_dph
    0    0.1      1.897
    1    0.2      1.344
    2    0.3      1.098

    A numpy array (as AllanTools takes it), rates in deg/s sampled at 100 Hz:

    >>> import numpy as np
    >>> x = np.random.default_rng(2).normal(0.0, 0.005, 60000)
    >>> res = gyrotest.allan(x, sample_interval=0.01, unit="deg/s", terms="N", taus="decade")
    >>> print(res.term("N").text())   # 0.005 deg/s = 18 deg/h; 18 · √0.01 s / 60 = 0.03 deg/√h
    N = 0.02993 ± 8.9e-05 deg/sqrt(h)
    """
    opts = split_read_options(dict(read_options), "allan")
    kw = allan_settings(dev=dev, taus=taus, stop_ratio=stop_ratio, terms=terms, axis=axis,
                        confidence=confidence, ci=ci, min_edf=min_edf, detrend=detrend,
                        skip=skip, outliers=outliers, vehicle_rate=vehicle_rate,
                        horizon=horizon, bi_cutoff=bi_cutoff, diagnose=diagnose, fit=fit,
                        allow_irregular=allow_irregular, fill=fill)
    from ..noise.analysis import analyse_allan

    env = _env_model(model)
    logs = _read_for(data, "allan", profile, opts, env.specs if env else None,
                     sample_interval=sample_interval, unit=unit)
    return AllanResult([analyse_allan(g, env_model=env, **kw) for g in logs])


def bias(data, *, skip: float | str = 0, axis: str | None = None,
         positions: str | Sequence[str] | None = None, settle: float | str = 0,
         earth_rate: bool = True, outliers: str = "flag",
         warmup_band: str | float | None = None, warmup_block: float | str = "60s",
         profile=None, sample_interval=None, unit: str | None = None,
         **read_options) -> BiasResult:
    r"""Bias D_F with an uncertainty honest for correlated noise (``gyrotest bias``).

    D_F is the mean rate after the warm-up trim minus the earth-rate component along the
    input axis (IEEE Std 952-1997 §12.11.4.1.1):

    .. math::

        D_F = \bar\omega - \Omega_E(\cos\varphi\cos e\cos A + \sin\varphi\sin e),

    Ω_E = 15.041067 deg/h, latitude φ, IA azimuth A and elevation e. Its 1σ is the Allan
    deviation at the record length from a fitted noise model (σ/√n is several times too
    small under flicker and random-walk noise; it is given for comparison). Several runs
    with one IA give the run-to-run repeatability (§5.3.3.1.1); several IA directions a
    multi-position fit of D_F and the earth-rate components with the latitude check and the
    IA azimuth misalignment (§5.3.4).

    Parameters
    ----------
    data : path, DataFrame, numpy array, Simulation, GyroLog, or a list of them
        One static run, or several (repeatability; multi-position with ``positions``).
    skip : float or str, default 0
        Warm-up trim at the start of each run, s or ``"30min"``.
    axis : str, optional
        Gyro axis (or comma-separated axes) to analyse; default every axis (with several
        axes the earth rate is not removed: one IA cannot hold for orthogonal axes).
    positions : str or sequence of str, optional
        IA direction of each run in order, e.g. ``"up,down,north,south"``.
    settle : float or str, default 0
        Time dropped after every position change in a log with a position column.
    earth_rate : bool, default True
        Subtract the earth-rate component (``--no-earth-rate`` is ``earth_rate=False``).
    outliers : {"flag", "remove", "robust"}
        Spikes: warn, replace by the running median, or clip.
    warmup_band : str or float, optional
        Report the warm-up time (IEEE Std 952-1997 §5.3.3): the time until the bias stays
        within ± this rate of its final value, e.g. ``"0.05deg/h"`` (a number is deg/h).
    warmup_block : float or str, default "60s"
        Block length of the warm-up time (its resolution).
    profile, sample_interval, unit, **read_options
        How to read ``data``: see :func:`read`. ``latitude`` (deg) and ``ia`` give the
        earth rate.

    Returns
    -------
    BiasResult
        ``to_dict()`` is the ``gyrotest bias --json`` document; ``bias_dph`` the D_F of the
        first axis; ``to_frame()`` one row per axis and run (``bias_dph``, ``sigma_dph`` ...);
        ``per_axis`` the full analysis per axis (runs, repeatability, multi-position fit).

    Raises
    ------
    gyrotest.InputError
        A run too short after the trim, positions that do not match the runs, a bad option.

    Examples
    --------
    A static run with IA up at 48.137° N: D_F = 0.5 deg/h besides the earth rate:

    >>> import gyrotest
    >>> sim = gyrotest.simulate({"record": {"sample_rate_hz": 10, "duration_s": "1h"},
    ...                          "gyro": {"bias_dph": 0.5, "noise": {"N": 0.01}},
    ...                          "site": {"latitude_deg": 48.137, "ia": "up"}}, seed=3)
    >>> res = gyrotest.bias(sim)
    >>> row = res.to_frame().iloc[0]
    >>> print(f"{row.earth_rate_ia_dph:.4f} {row.bias_dph:.2f} ± {row.sigma_dph:.3f} deg/h")
    11.2017 0.50 ± 0.011 deg/h
    """
    opts = split_read_options(dict(read_options), "bias")
    from ..core.units import parse_rate_dph
    from ..staticbias.analysis import parse_positions
    from ..staticbias.multiaxis import analyse_bias_axes

    if outliers not in ("flag", "remove", "robust"):
        raise OptionError(f"outliers: {outliers!r}", fix="use flag, remove or robust")
    skip_s = seconds(skip, "skip")
    settle_s = seconds(settle, "settle")
    band = parse_rate_dph(warmup_band, what="warmup_band") if warmup_band is not None else None
    wblock = seconds(warmup_block, "warmup_block")
    if wblock <= 0:
        raise OptionError(f"warmup_block must be > 0, got {warmup_block!r}")
    n = len(data) if isinstance(data, (list, tuple)) else 1
    pos_list = parse_positions(text_list(positions), n)  # before reading: a count error is cheap
    logs = as_logs(data, "bias", profile=profile, opts=opts, sample_interval=sample_interval,
                   unit=unit)
    return BiasResult(analyse_bias_axes(logs, skip_s=skip_s, settle_s=settle_s, axis=axis,
                                        positions=pos_list, earth_rate=bool(earth_rate),
                                        outliers=outliers, warmup_band_dph=band,
                                        warmup_block_s=wblock))


def scale_factor(data=None, *, table=None, settle: float | str = "0s",
                 fixed_settle: bool = False, trim_end: float | str = "0s",
                 min_dwell: float | str = "2s", detect: str = "auto",
                 rates: str | Sequence[float] | None = None, stderr: str = "allan",
                 snap_tol: float = 3e-3, full_scale: float | None = None,
                 terms: str | Sequence[str] = "auto", alpha: float = 0.05,
                 weighted_line: bool = False, weighted: bool = True, lock_in: bool = True,
                 periodic: bool = True, asymmetry: bool = True, common_rates: bool = False,
                 on_note=None, profile=None, **read_options) -> ScaleFactorResult:
    r"""Scale factor, linearity, asymmetry and nonlinearity from rate-table runs
    (``gyrotest scale-factor``; IEEE Std 952-1997 §12.9.4, §5.3.2).

    Each run's plateaus (from the commanded-rate column or detected in the output; the
    settling of each from its own data) give the output per input rate I = table rate +
    earth rate along the IA. The scale factor is the least-squares straight line through
    the plateau means (§12.9.4.1, input per output: arcsec/pulse, (deg/h)/V, or 1 for a rate
    output), the linearity error its largest residual in ppm of full scale, the asymmetry
    (SF+ − SF−)/SF̄ from separate lines (§12.9.4.2.2), and the nonlinearity model f(I) of the
    IEEE 952 §8.3 scale-factor error

    .. math::

        \varepsilon_K(I) = \varepsilon_0 + \varepsilon_T \Delta T + f(I),

    grown term by term (asymmetry, quadratic, cubic, ..., lock-in, periodic) while an F-test
    at ``alpha`` (Bonferroni-corrected) supports the next term. Several runs at one
    temperature give the repeatability (§12.9.4.2.3), runs at different temperatures the
    temperature sensitivity ε_T (§12.9.4.3.1).

    Parameters
    ----------
    data : path, DataFrame, GyroLog, or a list of them, optional
        One continuous rate-table log per run.
    table : str, optional
        A ready plateau table (CSV: ``table_rate_dps``, ``output_dph|output_pps|output_v``
        [, ``stderr_*``, ``temperature_degC``, ``run``]) instead of logs.
    settle : float or str, default "0s"
        Minimum settling time after each rate change; each plateau's own settling, found
        from its data, can only be longer.
    fixed_settle : bool, default False
        Use ``settle`` exactly after every rate change.
    trim_end : float or str, default "0s"
        Time excluded before the end of each plateau.
    min_dwell : float or str, default "2s"
        Constant stretches shorter than this are transitions.
    detect : {"auto", "table", "output"}
        Plateaus from the commanded-rate column or from steps in the output.
    rates : str or sequence of float, optional
        Commanded rates, deg/s (± implied), for plateaus detected in the output.
    stderr : {"allan", "batch"}
        Plateau standard error: Allan deviation at the plateau length, or batch means.
    snap_tol : float, default 3e-3
        Relative tolerance when matching detected levels to rates.
    full_scale : float, optional
        Full-scale input rate, deg/s (default: the largest \|rate\| tested).
    terms : str or sequence of str, default "auto"
        Nonlinearity terms: ``auto`` (chosen by the data), ``linear``, or a list of
        asymmetry, quadratic, cubic, quartic, quintic, lockin, periodic.
    alpha : float, default 0.05
        Significance level for adding a term.
    weighted_line : bool, default False
        Weight the IEEE straight line by 1/SE² (§12.9.4.1 is unweighted).
    weighted : bool, default True
        Weight the nonlinearity fit (``--unweighted`` is ``weighted=False``).
    lock_in, periodic : bool, default True
        Look for a low-rate dead band, a rate-periodic error.
    asymmetry : bool, default True
        Require negative rates for the asymmetry (``--no-asymmetry`` is ``False``).
    common_rates : bool, default False
        Keep only the rates all runs share.
    on_note : callable, optional
        Called with each note about a plateau table.
    profile, **read_options
        How to read ``data``: see :func:`read`. ``scale_factor`` (S0), ``latitude`` and
        ``ia`` apply to a ``table`` too.

    Returns
    -------
    ScaleFactorResult
        ``to_dict()`` is the ``gyrotest scale-factor --json`` document; ``to_frame()`` the
        plateau table; ``plot()`` residuals vs input rate and output vs time.

    Raises
    ------
    gyrotest.InputError
        No plateau, a plateau still settling at its end, no negative rates (without
        ``asymmetry=False``), runs that do not match, a bad option.

    Examples
    --------
    >>> import gyrotest
    >>> sim = gyrotest.simulate({
    ...     "record": {"sample_rate_hz": 20},
    ...     "gyro": {"noise": {"N": 0.01}},
    ...     "effects": {"scale_factor": {"nonlinearity_ppm": [0.0, 20.0]}},
    ...     "rate_table": {"rates_dps": [0, 10, -10, 50, -50, 100, -100], "dwell_s": 30}},
    ...     seed=4)
    >>> res = gyrotest.scale_factor(sim)
    >>> d = res.to_dict()
    >>> len(res.to_frame()), d["scale_factor_unit"], round(d["scale_factor_dimensionless"], 4)
    (7, '1', 1.0)
    """
    from .. import scalefactor as sfm

    opts = split_read_options(dict(read_options), "scale_factor")
    settle_s, trim_s, dwell_s = (seconds(settle, "settle"), seconds(trim_end, "trim_end"),
                                 seconds(min_dwell, "min_dwell"))
    sfm.check_settings(settle_s=settle_s, trim_end_s=trim_s, min_dwell_s=dwell_s, alpha=alpha,
                       snap_tol=snap_tol, full_scale_dps=full_scale)
    rate_list = sfm.parse_rates(text_list(rates))
    kw = dict(full_scale_dps=full_scale, terms=sfm.parse_term_choice(text_list(terms)),
              alpha=alpha, weighted=bool(weighted), weighted_line=bool(weighted_line),
              lock_in=bool(lock_in), periodic=bool(periodic), common_rates=bool(common_rates),
              require_asymmetry=bool(asymmetry))
    if table is not None:
        if not _empty(data):
            raise OptionError("give either rate-table logs or table=FILE, not both")
        res = sfm.reduce_table(table, latitude_deg=opts.get("latitude"), ia=opts.get("ia"),
                               scale_factor=opts.get("scale_factor"),
                               on_note=on_note or (lambda _m: None), **kw)
        return ScaleFactorResult(res)
    if _empty(data):
        raise OptionError("no input", fix="give one rate-table log per run, or table=FILE")
    logs = as_logs(data, "scale_factor", profile=profile, opts=opts)
    res = sfm.reduce_logs(logs, settle_s=settle_s, auto_settle=not fixed_settle,
                          trim_end_s=trim_s, min_dwell_s=dwell_s, detect=detect,
                          rates_dps=rate_list, snap_tol=snap_tol, stderr=stderr, **kw)
    return ScaleFactorResult(res, logs=logs)
