"""``gyrotest allan``'s table against Stable32 on the shared real records (GPS 1PPS, Cs 5071A,
Keysight TIC, pink noise; AllanTools test data): σ to Stable32's 5 printed digits, n, and the
default (Stable32-type) interval to 1e-3 on every row of the tables Stable32 made with its own
noise identification. The printed α follows Stable32's rule (lag-1 ACF from 30 averages; B1 at
8 … 29 averages — 6 … 29 for TOTDEV — against Barnes' theory at the statistic's number of terms;
the previous α below), the noise-model fit keeps the statistical rule (B1 theory at the number
of averages; tests/test_noise_fit.py, benchmarks/bench_noise_id.py). Tables Stable32 made with
a fixed α are compared on σ only."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import bench_conformance as bc  # noqa: E402

from gyrotest.noise.edf import chi2_interval, edf_for  # noqa: E402

pytestmark = pytest.mark.skipif(
    not bc.REAL.is_dir(),
    reason=f"shared real records not found at {bc.REAL} (CI checks out ../shared beside the repo)")

#: (table, m) interval rows outside 1e-3 although the α agrees, and why. TOTDEV with α = 1 has
#: no TOTDEV EDF in NIST SP 1065 (Table 7 covers α = 0, −1, −2), so the Table 5 simple EDF is
#: used; Stable32's EDF at α = 1, 2 is 1–5 % larger on every such row of the GPS and TIC tables
#: (as if N were ≈ 1.01·N: no published formula reproduces it). At 3.7 averages (EDF ≈ 42) that
#: moves the bounds by 2.1e-3 / 3.3e-3; at every other row by < 1e-3.
KNOWN_EDF_DIFF = {("gps_TOTDEV_octave", 65536): "TOTDEV α = 1 simple EDF, 3.7 averages"}


@pytest.fixture(scope="module")
def results():
    return {p.stem: bc.compare(p) for p in bc.tables()} if bc.REAL.is_dir() else {}


def test_every_table_is_compared(results):
    assert len(results) >= 36


def test_sigma_and_n_match_every_row(results):
    for name, c in results.items():
        assert c["sig"] <= 5e-5, (name, c["sig_bad"][:3])
        assert c["n_bad"] == 0, name


def test_every_interval_matches(results):
    total = 0
    for name, c in results.items():
        if c["fixed_alpha"]:
            continue
        total += c["ci_rows"]
        for r, alpha, lo, hi in c["ci_bad"]:
            assert alpha == r.alpha, ("α differs", name, r, alpha)
            assert (name, r.m) in KNOWN_EDF_DIFF, (name, r, lo, hi)
            assert abs(lo / r.lo - 1) <= 5e-3 and abs(hi / r.hi - 1) <= 5e-3, (name, r, lo, hi)
    assert total == 305  # every row with an interval in the 33 tables of Stable32's own α


def test_with_stable32_alpha_the_edf_reproduces_the_interval(results):
    """Independent of the identification: our EDF at Stable32's α gives its interval."""
    for name, c in results.items():
        if c["fixed_alpha"] or c["kind"] not in ("totdev", "oadev"):
            continue
        y, _ = bc.load(bc.record_for(name))
        for r in bc.read_stable32(bc.REAL / "stable32" / f"{name}.txt"):
            if not (r.lo > 0 and r.hi > 0):
                continue
            edf, _ = edf_for(c["kind"], r.alpha, r.m, y.size + 1)
            lo, hi = chi2_interval(r.sigma, edf, 0.683)
            tol = 5e-3 if (name, r.m) in KNOWN_EDF_DIFF else 1e-3
            assert abs(lo / r.lo - 1) <= tol and abs(hi / r.hi - 1) <= tol, (name, r, lo, hi)


def test_alpha_is_stable32s_on_the_clock_records(results):
    """Every α of the Cs 5071A/GPS/TIC OADEV/MDEV/TDEV/OHDEV/TOTDEV tables (and the decade/
    octave ADEV/HDEV tables) equals Stable32's. The 47 differing rows left are in all-τ tables
    that print no interval: lag-1 decisions near the ±0.25 threshold (pink, TIC ADEV) and B1
    at 7–8 averages of the non-overlapping ADEV/HDEV (pink, Cs 5071A HDEV)."""
    for name, c in results.items():
        if not name.startswith("pink") and not name.endswith("_all") and name != "tic_adev" \
                and not c["fixed_alpha"]:
            assert not c["alpha_bad"], (name, c["alpha_bad"][:3])
    assert sum(len(c["alpha_bad"]) for c in results.values() if not c["fixed_alpha"]) <= 47
