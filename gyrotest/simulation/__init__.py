'''Bench-log simulator: realistic gyro test logs with known truth.

Python API::

    from gyrotest.simulation import simulate, write_log
    res = simulate("sample_data/scenarios/fog_static.toml", seed=1)   # or a dict
    res.rate_dph, res.truth, res.columns        # arrays (single run) and the truth dict
    write_log(res, "out/fog.csv")               # + out/fog.truth.json, out/fog.profile.toml

CLI: ``gyrotest simulate SCENARIO.toml -o log.csv [--format csv|parquet|feather] [--seed N]``.

Model (IEEE 952 §8.3): ``S0 dN/dt = LockIn(I + E + D) / (1 + 1e-6 eps_K)``, see
:mod:`gyrotest.simulation.core`. Every sample is the average rate over its interval (what a
pulse integrator delivers); the noise generators are exact discretisations
(:mod:`gyrotest.simulation.noise`), so the Allan deviation of a simulated record matches the
closed forms of :mod:`gyrotest.noise.terms`.

Scenario TOML
=============

All sections are optional except what the output needs; unknown keys are an error. Units are
in the key names or listed here; durations accept seconds or strings like ``"40min"``, ``"2h"``.

.. code-block:: toml

    [scenario]
    name = "fog-static"           # default: file stem
    description = "..."
    seed = 1                      # default seed (--seed / seed= wins)

    [record]
    sample_rate_hz = 100.0
    duration_s = "2h"             # default: the longest sequence below (positions, rate table,
                                  # temperature profile, Helmholtz test)

    [gyro]
    output = "rate"               # rate | counts | updown | counter | voltage
    rate_unit = "deg/h"           # rate output: deg/h deg/s rad/s mrad/s urad/s deg/min arcsec/s
    scale_factor = 0.2            # S0: arcsec/pulse (counts, updown, counter), (deg/h)/V (voltage)
    bias_dph = 0.5                # D_F, deg/h
    counter_bits = 32             # counter: 16, 24, 32, 48
    counter_start = 4294967000    # counter: initial value (default: rolls over early)
    dither_counts = 200.0         # updown: mean common dither count in both columns (Poisson)
    offset_v = 2.5                # voltage: V at zero rate
    adc_bits = 16                 # voltage: ADC resolution over adc_range_v (0 = none)
    adc_range_v = [0.0, 5.0]
    model = "FOG-X"               # identity, copied to the profile
    serial = "0001"
    type = "FOG"

    [gyro.noise]                  # IEEE 952 Annex C terms, reporting units
    N = 0.005                     # angle random walk, deg/sqrt(h)
    B = 0.01                      # bias instability, deg/h
    B_f0_hz = 1.0                 # its 1/f cut-off f0, Hz (default fs/2, must be <= fs/2)
    K = 0.002                     # rate random walk, deg/h/sqrt(h)
    R = 0.0                       # rate ramp, deg/h/h (deterministic R*t)
    Q = 0.0                       # white angle noise, arcsec (pulse outputs add S0/sqrt(12))
    fft_padding = 4               # FFT synthesis length factor (bias instability, blue_exp/gauss)
    [[gyro.noise.markov]]         # first-order Markov: q_c deg/h/sqrt(h) (or sigma_dph), T_c s
    q_c = 0.5
    T_c = 20.0
    [[gyro.noise.sinusoid]]
    amplitude_dph = 0.05
    freq_hz = 0.2
    phase_deg = 0.0               # default random
    [[gyro.noise.blue]]           # Krobka's S(0) = 0 families (Krobka (Allan-graph topology) Tables 7.1-7.3)
    family = "blue_markov_derivative"   # alpha f^2/(beta^2+f^2); or blue_exp (alpha f^n e^-beta f),
    alpha = 1e-4                        # blue_gauss (alpha f^n e^-beta f^2) with n = ...
    beta = 0.5

    [site]
    latitude_deg = 48.137
    ia = "up"                     # up/down/north/south/east/west or "AZ/EL", or
                                  # ia_azimuth_deg + ia_elevation_deg
    # [[site.positions]]          # multi-position run instead of ia (one table per position;
    # ia = "north"                # writes a label column, default "pos"; label = "..." optional)
    # dwell_s = 600

    [environment.temperature]
    initial_c = 21.0              # ambient/chamber temperature at t = 0
    profile = [                   # segments in order; the last value holds afterwards
      {kind = "hold", duration_s = 600},
      {kind = "ramp", to_c = 40, rate_c_per_h = 20},          # or duration_s
      {kind = "step", to_c = 30},                              # instantaneous
      {kind = "staircase", levels_c = [31, 35, 40, 45, 50, 55], dwell_s = "40min", ramp_c_per_h = 60},
      {kind = "sine", amplitude_c = 10, period_s = "2h", cycles = 3},
    ]
    nodes = [                     # first-order lags: gyro core, coil layers ... (input default
      {name = "core", tau_s = 900},                    # "ambient"; chains allowed)
      {name = "coil_in", tau_s = 1500, input = "core"},
    ]
    [[environment.temperature.sensors]]   # recorded columns: a lagged, noisy view of a node
    column = "T_case_C"
    node = "ambient"
    tau_s = 5
    noise_c = 0.01
    offset_c = 0.0
    resolution_c = 0.0625

    [environment.field]           # gyro-frame field, uT
    background_uT = [20.0, 0.0, -45.0]
    noise_uT = 0.05               # magnetometer noise (recorded columns only)
    random_walk_uT_per_sqrt_h = 0.0
    sine_amplitude_uT = [0.0, 0.0, 0.0]
    sine_period_s = 3600
    columns = ["Hx_uT", "Hy_uT", "Hz_uT"]   # [] = not recorded
    [environment.field.helmholtz] # 0 -> +300 -> -300 -> 0 uT per axis, one axis at a time
    axes = ["x", "y", "z"]        # (Antonova & Matveev defaults: step 50 uT, max 300 uT, 180 s per level)
    step_uT = 50
    max_uT = 300
    dwell_s = 180
    start_s = 0
    pause_s = 0

    [environment.supply]
    nominal_v = 15.0
    steps = [[600.0, 14.0], [1200.0, 16.0]]   # [time_s, volts] set-points
    drift_v_per_h = 0.0
    ripple_v = 0.0                # averaged exactly over each sample interval
    ripple_hz = 50.0
    noise_v = 0.0                 # recorded column only
    column = "vsupply"

    [[effects.thermal]]           # one table per term; node = which temperature drives it
    kind = "poly"                 # D_T dT + D_T2 dT^2 + D_T3 dT^3, dT = T_node - t_ref_c
    node = "core"
    t_ref_c = 21.0
    D_T = 0.05                    # (deg/h)/degC, D_T2 (deg/h)/degC^2, D_T3 (deg/h)/degC^3
    [[effects.thermal]]
    kind = "rate"                 # D_Tdot * dT/dt, dT/dt in degC/h; (deg/h)/(degC/h) = deg/degC
    node = "ambient"
    D_Tdot = 0.5
    [[effects.thermal]]
    kind = "gradient_rate"        # D_gradTdot * d(T_a - T_b)/dt
    nodes = ["core", "coil_in"]
    D_gradTdot = 0.3
    [[effects.thermal]]
    kind = "hysteresis"           # +-amplitude/2 on heating/cooling branches (play operator,
    node = "core"                 # reversal needs 2*width_c)
    amplitude_dph = 0.05
    width_c = 0.5
    [[effects.thermal]]
    kind = "antonova-matveev"     # w0 + w1 dT + w2 dT^2 + w_dV dT/dt, dT from t0_c = 21 degC;
    node = "ambient"              # defaults: the paper's w0 = 1.197, w1 = 0.108, w2 = 0.004,
                                  # w_dV = 1.997 (overridable: w0, w1, w2, w_dV, t0_c)

    [effects.magnetic]
    w_dph_per_100uT = [-0.037, -0.576, -0.253]   # drift = sum w_i H_i / 100 uT

    [effects.supply]
    dph_per_v = 0.05              # (deg/h)/V around nominal_v

    [effects.warmup]
    amplitude_dph = 2.0           # A exp(-t/tau_w) from power-on
    tau_s = 300

    [effects.scale_factor]        # eps_K in ppm: IEEE 952 §8.3
    offset_ppm = 0.0
    asymmetry_ppm = 0.0           # (SF+ − SF−)/SF̄, SF input per output: +: a pulse is worth more for positive inputs
    nonlinearity_ppm = [0.0, 5.0, -10.0]   # c_k (I/I_fs)^k, k = 1, 2, 3 ...
    full_scale_dps = 100.0        # I_fs (default: max |table rate|)
    periodic_ppm = 0.0            # rate-periodic component
    periodic_period_dps = 10.0
    periodic_phase_deg = 0.0
    temp_ppm_per_c = 0.0          # eps_T, driven by node, from t_ref_c
    node = "core"
    t_ref_c = 21.0
    lock_in_dph = 0.0             # RLG dead band L: output sign(x) sqrt(x^2 - L^2)
    saturation_dps = 450          # optional: output clipped at ± this input (input range)

    [rate_table]
    rates_dps = [0, 1, -1, 10, -10, 100, -100]
    dwell_s = 60                  # one value or one per plateau
    settle_tau_s = 0.5            # first-order table settling
    exclude_s = 5                 # settling excluded from the truth's plateau means
    column = "table_dps"          # commanded rate column, deg/s ("" = not recorded)

    [runs]                        # power-on runs, one file each
    count = 3
    sf_offsets_ppm = [0, 12, -7]  # or sf_sigma_ppm = 10 (random, 1 sigma)
    bias_offsets_dph = [0, 0.02, -0.01]   # or bias_sigma_dph

    [file]
    time = "seconds"              # seconds | iso | none (then the profile gives sample_rate_hz)
    time_column = "t_s"           # default t_s ("timestamp" for iso)
    t0_s = 0.0                    # time origin
    start_iso = "2024-05-01T08:00:00"
    output_column = "omega_dph"   # default by kind: omega_<unit>, pulses, cnt, v_out
    up_column = "up"
    down_column = "down"
    position_column = "pos"
    [file.faults]                 # for ingest tests
    drop = [[100.0, 2.5]]         # [start_s, duration_s] rows removed (gaps)
    drop_random = 0               # single random rows removed
    jitter_s = 0.0                # timestamp jitter (1 sigma; < 0.2 tau0)
    duplicate_rows = 0            # exact duplicate rows inserted

Files written beside the log: ``<stem>.truth.json`` (every true parameter in reporting units:
N deg/sqrt(h), B deg/h, K deg/h/sqrt(h), R deg/h/h, Q arcsec, D_F deg/h, earth-rate component
deg/h, thermal/magnetic coefficients, scale factor from the noise-free plateau means,
asymmetry and linearity in ppm, file faults) and ``<stem>.profile.toml`` (the bench profile
that tells :func:`gyrotest.io.ingest.read_log` how to read the file).
'''

from __future__ import annotations

from .core import simulate
from .scenario import ANTONOVA_MATVEEV, load_scenario, parse_scenario
from .simrun import SimResult, SimRun
from .specs import Scenario
from .writer import WriteResult, profile_toml, sidecar_paths, write_log

__all__ = [
    "ANTONOVA_MATVEEV",
    "Scenario",
    "SimResult",
    "SimRun",
    "WriteResult",
    "load_scenario",
    "parse_scenario",
    "profile_toml",
    "sidecar_paths",
    "simulate",
    "write_log",
]
