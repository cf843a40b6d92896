"""Scale-factor benchmark: reduce a 10⁷-sample rate-table log, compared with ingest alone.

A simulated pulse-output rate-table log (±1…±500 deg/s up and back down, 1 kHz, commanded
column, earth rate, noise) with 10⁷ samples is written as CSV and as Parquet. Measured
(best of ``--repeat``, in-process, after a warm-up):

* ingest alone: ``read_log`` of the CSV (and of the Parquet);
* reduction alone: ``extract_plateaus`` + ``analyse`` on the loaded log (plateaus, Allan-based
  standard errors, IEEE line, model selection with the periodic and lock-in scans,
  asymmetry, linearity) — the part issue #4 adds;
* the reduction again with plateaus detected in the output (no commanded column);
* the whole command in a subprocess: ``gyrotest scale-factor LOG.csv --json``.

The figure of merit is the ratio reduction / CSV ingest (target: a few seconds in all, the
reduction small next to reading the file). Not part of the test suite.

Usage::

    python benchmarks/bench_scalefactor.py               # 10⁷ samples
    python benchmarks/bench_scalefactor.py --samples 2e6 # quicker
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time


def best(fn, repeat: int) -> tuple[float, object]:
    out, times = None, []
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return min(times), out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=float, default=1e7)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--keep", default=None, help="directory to keep the generated logs in")
    a = ap.parse_args(argv)

    from gyrotest.core.profile import load_profile
    from gyrotest.io.ingest import read_log
    from gyrotest.scalefactor import analyse, extract_plateaus
    from gyrotest.simulation import simulate, write_log

    mags = [1, 2, 5, 10, 20, 50, 100, 200, 500]
    up = [0] + [s * m for m in mags for s in (1, -1)]
    rates = up + [0] + [s * m for m in mags[::-1] for s in (-1, 1)]
    fs = 1000.0
    dwell = float(a.samples) / fs / len(rates)
    sc = {
        "scenario": {"name": "bench-sf", "seed": 1},
        "record": {"sample_rate_hz": fs},
        "gyro": {"output": "counts", "scale_factor": 0.1, "bias_dph": 1.0,
                 "noise": {"N": 0.01}},
        "site": {"latitude_deg": 48.137, "ia": "up"},
        "effects": {"scale_factor": {"offset_ppm": 50.0, "asymmetry_ppm": 20.0,
                                     "nonlinearity_ppm": [5.0, -15.0]}},
        "rate_table": {"rates_dps": rates, "dwell_s": dwell, "settle_tau_s": 0.3,
                       "exclude_s": 5},
    }
    d = a.keep or tempfile.mkdtemp(prefix="bench_sf_")
    os.makedirs(d, exist_ok=True)
    t0 = time.perf_counter()
    res = simulate(sc)
    w = write_log(res, os.path.join(d, "rt.csv"))
    wp = write_log(res, os.path.join(d, "rt.parquet"))
    t_gen = time.perf_counter() - t0
    csv, prof = str(w.logs[0]), load_profile(w.profiles[0])
    size_mb = os.path.getsize(csv) / 1e6
    print(f"generated {w.rows[0]:,} samples ({len(rates)} plateaus of {dwell:.0f} s at "
          f"{fs:g} Hz; CSV {size_mb:.0f} MB) in {t_gen:.1f} s -> {d}")

    read_log(csv, profile=prof)  # warm-up (imports, page cache)
    t_csv, log = best(lambda: read_log(csv, profile=prof), a.repeat)
    t_pq, _ = best(lambda: read_log(str(wp.logs[0]), profile=prof), a.repeat)

    def reduce(lg, detect="auto"):
        rp = extract_plateaus(lg, "rt", settle_s=8, detect=detect)
        return analyse([rp], output_kind=lg.gyro.output_kind,
                       nominal_scale_factor=lg.gyro.scale_factor)

    reduce(log)
    t_red, r = best(lambda: reduce(log), a.repeat)
    t_det, r2 = best(lambda: reduce(log, "output"), a.repeat)
    t_ex, _ = best(lambda: extract_plateaus(log, "rt", settle_s=8), a.repeat)
    truth = json.loads(open(w.truths[0]).read())["scale_factor"]
    z = (r.scale_factor - truth["sf_arcsec_per_pulse"]) / r.scale_factor_sigma
    z2 = (r2.scale_factor - truth["sf_arcsec_per_pulse"]) / r2.scale_factor_sigma

    t0 = time.perf_counter()
    cp = subprocess.run([sys.executable, "-c", "from gyrotest.cli import main; main()",
                         "scale-factor", csv, "--profile", w.profiles[0], "--settle", "8s",
                         "--json"], capture_output=True, text=True)
    t_cli = time.perf_counter() - t0

    print(f"ingest CSV (read_log)              {t_csv:7.2f} s")
    print(f"ingest Parquet (read_log)          {t_pq:7.2f} s")
    print(f"reduction, commanded column        {t_red:7.2f} s   ({t_ex:.2f} s of it plateaus + "
          f"standard errors)   ratio to CSV ingest {t_red / t_csv:.2f}, to Parquet "
          f"{t_red / t_pq:.2f}")
    print(f"reduction, plateaus detected       {t_det:7.2f} s   ratio to CSV ingest "
          f"{t_det / t_csv:.2f}")
    print(f"whole command (subprocess, CSV)    {t_cli:7.2f} s   exit {cp.returncode}")
    print(f"check: SF z vs truth {z:+.2f} (commanded), {z2:+.2f} (detected); "
          f"{len(r.points)} / {len(r2.points)} plateaus")
    return 0


if __name__ == "__main__":
    sys.exit(main())
