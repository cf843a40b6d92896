"""The parsed scenario of the simulator: one frozen dataclass per scenario table (the gyro,
its noise, the site, the record, the temperature, field and supply schedules, the effects,
the rate table, the runs, the faults and the output file) and the :class:`Scenario` that holds
them. :mod:`.scenario` parses and validates a scenario file into these."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any


@dataclass
class MarkovSpec:
    q_c: float  # deg/h/sqrt(h)
    T_c: float  # s


@dataclass
class SineSpec:
    amplitude_dph: float
    freq_hz: float
    phase_deg: float | None  # None: random


@dataclass
class BlueSpec:
    family: str
    alpha: float
    beta: float
    n: float | None


@dataclass
class NoiseSpec:
    N: float = 0.0  # deg/sqrt(h)
    B: float = 0.0  # deg/h
    B_f0_hz: float | None = None
    K: float = 0.0  # deg/h/sqrt(h)
    R: float = 0.0  # deg/h/h
    Q: float = 0.0  # arcsec (additive white angle noise)
    markov: list[MarkovSpec] = field(default_factory=list)
    sinusoid: list[SineSpec] = field(default_factory=list)
    blue: list[BlueSpec] = field(default_factory=list)
    fft_padding: int = 4


@dataclass
class GyroSpec:
    output: str = "rate"
    rate_unit: str = "deg/h"
    scale_factor: float | None = None
    bias_dph: float = 0.0
    counter_bits: int = 32
    counter_start: int | None = None
    dither_counts: float = 0.0
    offset_v: float = 0.0
    adc_bits: int = 0
    adc_range_v: tuple[float, float] = (0.0, 5.0)
    model: str | None = None
    serial: str | None = None
    type: str | None = None
    noise: NoiseSpec = field(default_factory=NoiseSpec)


@dataclass
class PositionSpec:
    label: str
    azimuth_deg: float
    elevation_deg: float
    dwell_s: float
    named: bool  # one of up/down/north/south/east/west


@dataclass
class SiteSpec:
    latitude_deg: float = 0.0
    ia: PositionSpec | None = None  # fixed IA (None when positions are given)
    positions: list[PositionSpec] = field(default_factory=list)
    given: bool = False


@dataclass
class RecordSpec:
    sample_rate_hz: float = 10.0
    duration_s: float | None = None


@dataclass
class SegmentSpec:
    kind: str
    p: dict[str, Any]


@dataclass
class NodeSpec:
    name: str
    tau_s: float
    input: str = "ambient"
    initial_c: float | None = None


@dataclass
class SensorSpec:
    column: str
    node: str = "ambient"
    tau_s: float = 0.0
    noise_c: float = 0.0
    offset_c: float = 0.0
    resolution_c: float = 0.0


@dataclass
class TemperatureSpec:
    initial_c: float = 21.0
    segments: list[SegmentSpec] = field(default_factory=list)
    nodes: list[NodeSpec] = field(default_factory=list)
    sensors: list[SensorSpec] = field(default_factory=list)


@dataclass
class HelmholtzSpec:
    axes: list[str]
    step_uT: float
    max_uT: float
    dwell_s: float
    start_s: float = 0.0
    pause_s: float = 0.0


@dataclass
class FieldSpec:
    background_uT: tuple[float, float, float] = (0.0, 0.0, 0.0)
    noise_uT: float = 0.0
    random_walk_uT_per_sqrt_h: float = 0.0
    sine_amplitude_uT: tuple[float, float, float] = (0.0, 0.0, 0.0)
    sine_period_s: float = 3600.0
    helmholtz: HelmholtzSpec | None = None
    columns: list[str] = field(default_factory=lambda: ["Hx_uT", "Hy_uT", "Hz_uT"])


@dataclass
class SupplySpec:
    nominal_v: float = 15.0
    steps: list[tuple[float, float]] = field(default_factory=list)
    drift_v_per_h: float = 0.0
    ripple_v: float = 0.0
    ripple_hz: float = 50.0
    noise_v: float = 0.0
    column: str = "vsupply"


@dataclass
class ThermalTerm:
    kind: str
    node: str = "ambient"
    nodes: tuple[str, str] | None = None
    t_ref_c: float = 21.0
    D_T: float = 0.0
    D_T2: float = 0.0
    D_T3: float = 0.0
    D_Tdot: float = 0.0
    D_gradTdot: float = 0.0
    amplitude_dph: float = 0.0
    width_c: float = 0.5
    w0: float = 0.0


@dataclass
class ScaleFactorSpec:
    offset_ppm: float = 0.0
    asymmetry_ppm: float = 0.0
    nonlinearity_ppm: list[float] = field(default_factory=list)
    full_scale_dps: float | None = None
    periodic_ppm: float = 0.0
    periodic_period_dps: float = 10.0
    periodic_phase_deg: float = 0.0
    temp_ppm_per_c: float = 0.0
    node: str = "ambient"
    t_ref_c: float = 21.0
    lock_in_dph: float = 0.0
    saturation_dps: float | None = None  # output clipped at ± this input rate (input range)


@dataclass
class EffectsSpec:
    thermal: list[ThermalTerm] = field(default_factory=list)
    magnetic_w: tuple[float, float, float] | None = None  # deg/h per 100 uT
    supply_dph_per_v: float = 0.0
    warmup_amplitude_dph: float = 0.0
    warmup_tau_s: float = 600.0
    scale_factor: ScaleFactorSpec = field(default_factory=ScaleFactorSpec)


@dataclass
class RateTableSpec:
    rates_dps: list[float]
    dwell_s: list[float]
    settle_tau_s: float = 0.5
    exclude_s: float = 5.0
    column: str | None = "table_dps"


@dataclass
class RunsSpec:
    count: int = 1
    sf_offsets_ppm: list[float] | None = None
    sf_sigma_ppm: float = 0.0
    bias_offsets_dph: list[float] | None = None
    bias_sigma_dph: float = 0.0


@dataclass
class FaultSpec:
    drop: list[tuple[float, float]] = field(default_factory=list)
    drop_random: int = 0
    jitter_s: float = 0.0
    duplicate_rows: int = 0


@dataclass
class FileSpec:
    time: str = "seconds"  # seconds | iso | none
    time_column: str | None = None
    t0_s: float = 0.0
    start_iso: str = "2024-01-01T00:00:00"
    output_column: str | None = None
    up_column: str = "up"
    down_column: str = "down"
    position_column: str = "pos"
    faults: FaultSpec = field(default_factory=FaultSpec)


@dataclass
class Scenario:
    """A validated scenario. ``raw`` is the parsed TOML (kept in the truth file)."""

    name: str
    description: str
    seed: int | None
    record: RecordSpec
    gyro: GyroSpec
    site: SiteSpec
    temperature: TemperatureSpec | None
    field: FieldSpec | None
    supply: SupplySpec | None
    effects: EffectsSpec
    rate_table: RateTableSpec | None
    runs: RunsSpec
    file: FileSpec
    raw: dict[str, Any]
    source: str
