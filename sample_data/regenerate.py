"""Rebuild every bundled sample log from its scenario, with the scenario's fixed seed.

Usage (from the repository root, with gyrotest installed)::

    python sample_data/regenerate.py            # all logs
    python sample_data/regenerate.py static     # only the named ones

Each log is written by the simulator (``gyrotest.simulation``) together with its
``<stem>.truth.json`` (the true parameters) and ``<stem>.profile.toml`` (the bench profile the
campaign uses to read it). Parquet logs are then rewritten with zstd compression (same columns,
same values, about a third of the size) to keep the repository small. The simulation is
deterministic for a given seed, so the regenerated logs hold the same samples as the bundled
ones (the Parquet bytes may differ with the pyarrow version).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
SCENARIOS = HERE / "scenarios"

#: output file (in sample_data/) <- scenario file (in sample_data/scenarios/)
LOGS: dict[str, str] = {
    "static.parquet": "campaign_static.toml",
    "bias.parquet": "campaign_bias.toml",  # 3 runs: bias_run1..3.parquet
    "ratetable_22a.parquet": "campaign_ratetable_22a.toml",
    "ratetable_22b.parquet": "campaign_ratetable_22b.toml",
    "ratetable_45.parquet": "campaign_ratetable_45.toml",
    "thermal.parquet": "campaign_thermal.toml",
    "magnetic.parquet": "campaign_magnetic.toml",
    "multipos.csv": "campaign_multipos.toml",
}


def recompress(path: Path) -> None:
    """Rewrite a Parquet file with zstd and byte-stream-split floats (lossless)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    from gyrotest.core.output import atomic_path

    table = pq.read_table(path)
    floats = [f.name for f in table.schema if pa.types.is_floating(f.type)]
    with atomic_path(path) as tmp:
        pq.write_table(table, tmp, compression="zstd", compression_level=19,
                       use_byte_stream_split=floats or False, use_dictionary=False)


def main(argv: list[str]) -> int:
    """Regenerate the logs named in ``argv`` (stems, default all); print what was written."""
    from gyrotest.simulation import simulate, write_log

    wanted = set(argv)
    total = 0
    for out, scen in LOGS.items():
        if wanted and Path(out).stem not in wanted:
            continue
        t0 = time.perf_counter()
        res = simulate(SCENARIOS / scen)
        written = write_log(res, HERE / out)
        for p in written.logs:
            if p.suffix == ".parquet":
                recompress(p)
            p.chmod(0o644)
        for p in [*written.truths, *written.profiles] + ([written.summary] if written.summary
                                                         else []):
            p.chmod(0o644)
        size = sum(p.stat().st_size for p in written.logs)
        total += size
        print(f"{scen} (seed {res.seed}) -> " + ", ".join(p.name for p in written.logs)
              + f"  {size / 1e6:.2f} MB in {time.perf_counter() - t0:.1f} s")
    print(f"logs: {total / 1e6:.2f} MB")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
