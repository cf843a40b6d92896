'''The commented campaign printed by ``gyrotest report --template`` (docs/campaign.md).

It is a valid campaign: beside the sample logs (sample_data/) it runs as it stands.
'''

TEMPLATE = """\
# gyrotest campaign file: 'gyrotest report CAMPAIGN.toml' runs every test below and writes the
# spec sheet. Paths are relative to this file. Unknown sections or keys are errors; the whole
# file is checked before any analysis runs. Full reference: docs/campaign.md.

[campaign]
title = "Acceptance test, single-axis FOG"   # optional
operator = "A. Tester"                       # required: who ran the tests
date = 2024-05-12                            # required: date of test (TOML date or "YYYY-MM-DD")
organisation = "Gyro lab"                    # optional
report_id = "GT-0427-ACC-01"                 # optional: printed with the revision
customer = "Example Customer Ltd"            # optional
notes = "Printed under the title block."     # optional

[gyro]
model = "GT-FOG-100"                         # required
serial = "0427"                              # required
type = "FOG, closed loop, pulse output"      # optional
nominal_scale_factor = 0.2                   # S0
scale_factor_unit = "arcsec/pulse"           # arcsec/pulse | (deg/h)/V | 1

[site]
latitude_deg = 48.137                        # every analysis gets --latitude
name = "Munich, bench 2"

# ---- the laboratory parts of the report (ISO/IEC 17025 §7.8) ---------------------------
[lab]
name = "Gyro test laboratory"
address = "Test Street 1, 80000 Munich"
accreditation = "accredited to ISO/IEC 17025 (certificate D-PL-00000)"   # optional
# logo = "logo.png"                          # PNG or JPEG, top of the title block
contact = "lab@example.com"

[approval]                                   # names in the sign-off block (signatures by pen)
prepared_by = "A. Tester"
reviewed_by = "B. Reviewer"
approved_by = "C. Head"
approved_title = "Head of laboratory"
# approval_date = 2024-05-20

[decision]                                   # ILAC-G8 decision rule
rule = "guard-band"                          # guard-band (w = U, default) | simple (w = 0)
coverage_factor = 2.0                        # k of the expanded uncertainty U = k·u

[[equipment]]                                # one entry per instrument
name = "Rate table"
model = "RT-500"
serial = "1234"
asset_id = "LAB-017"
calibrated = 2023-11-02
calibration_due = 2024-11-02                 # required; flagged if before the test date
certificate = "CAL-2023-0456"
tests = ["scale_factor"]                     # which tests used it (default: all)

[[equipment]]
name = "Thermal chamber"
model = "TC-80"
serial = "88"
calibration_due = 2025-01-15
tests = ["thermal", "scale_factor"]

[[revisions]]                                # revision history (the last one is current)
revision = "1"
date = 2024-05-20
description = "first issue"
author = "A. Tester"

# ---- the tests (a test that is absent reads "not tested") -------------------------------
[tests.bias]                                 # static runs: D_F and its repeatability
logs = ["static.parquet", "bias_run1.parquet"]
profile = "static.profile.toml"              # bench profile (columns, units, gyro)
skip = "30min"                               # warm-up trim
warmup_band = "0.2deg/h"                     # warm-up time: bias within ± band (logs from power-on)
warmup_block = "300s"                        # its block length (resolution)
conditions = "IA up; power off for at least 12 h between runs"
environment = { temperature = "22 ± 1 °C", humidity = "40 … 50 % RH", vibration = "isolated pier" }
limits = { bias_dph = 3.0, repeatability_1sigma_dph = 0.05, warmup_time_s = 1800 }

[tests.allan]                                # one static log: N, B, K, R, Q
log = "static.parquet"
profile = "static.profile.toml"
skip = "30min"
terms = "Q,N,B,K,R"
vehicle_rates = ["10deg/s", "100deg/s"]      # platform vs strapdown note
horizon = "1h"
environment = { temperature = "22 ± 1 °C" }
limits = { N = 0.012, B = 0.06, K = 0.1, R = 0.1, Q = 0.1 }

[tests.scale_factor]                         # rate-table runs, one log per run
logs = ["ratetable_22a.parquet", "ratetable_22b.parquet", "ratetable_45.parquet"]
profile = "ratetable_22a.profile.toml"
settle = "10s"
environment = { temperature = "22 ± 1 °C (runs 1, 2); 45 °C chamber (run 3)" }
limits = { scale_factor_error_ppm = 300, linearity_max_ppm_fs = 20, asymmetry_ppm = 50 }

[tests.thermal]                              # chamber run: IEEE E terms, Antonova–Matveev model
log = "thermal.parquet"
profile = "thermal.profile.toml"
t_ref = 21.0
sensor = "T_chamber_C"
gradient = ["T_coil_a_C", "T_coil_b_C"]
model_steps = ["T", "T,T2", "T,T2,dTdt"]     # model history (engineering report)
limits = { D_T = 0.5, D_Tdot = 3.0, D_gradTdot = 1.0 }

[tests.magnetic]                             # Helmholtz coils: w_x, w_y, w_z per 100 µT
log = "magnetic.parquet"
profile = "magnetic.profile.toml"
settle = "10s"
limits = { wx = 0.7, wy = 0.7, wz = 0.7 }

[tests.multiposition]                        # IA alignment from a multi-position test
log = "multipos.csv"
profile = "multipos.profile.toml"
settle = "30s"
limits = { azimuth_misalignment_deg = 1.0 }

# [tests.accel]                              # accelerometer noise (IEEE Std 1293), a log
# log = "imu.csv"                            # with accelerometer columns (ax_g, acc_y ...)
# skip = "10min"
# limits = { N = 0.06, B = 50, K = 1.0 }     # VRW m/s/sqrt(h), B ug, K m/s/h/sqrt(h)

# [tests.supply]                             # supply-voltage sensitivity
# log = "supply.csv"
# profile = "supply.profile.toml"
# limits = { supply_dph_per_v = 0.05 }
"""
