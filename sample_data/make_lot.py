"""Simulate a production lot for ``gyrotest fleet``: one acceptance campaign per serial.

Usage (from the repository root, with gyrotest installed)::

    python sample_data/make_lot.py DIR [N] [--small]
    gyrotest fleet DIR/campaign_*.toml --pdf lot.pdf

Writes, into DIR, N (default 6) serials 1101, 1102, ... of a GT-FOG-100 lot, each with a
static run (bias, Allan analysis) and a rate-table run (scale factor), their truth and
profile files, and ``campaign_<serial>.toml``; serial 1104 has a bias far from the rest of
the lot (within its limit), and serials 1101 and 1102 also have an earlier acceptance test
(``campaign_<serial>_early.toml``, 90 days before). ``lot.json`` lists the true parameters.
--small writes 30-minute static runs (what the tests use); the default is 2 h. See
:func:`gyrotest.simulation.lot.write_lot`.
"""

from __future__ import annotations

import sys
import time


def main(argv: list[str]) -> int:
    """Write the lot; print what was written."""
    from gyrotest.simulation.lot import SMALL, write_lot

    args = [a for a in argv if not a.startswith("--")]
    if not args:
        print(__doc__)
        return 2
    n = int(args[1]) if len(args) > 1 else 6
    t0 = time.perf_counter()
    lot = write_lot(args[0], n, size=SMALL if "--small" in argv else None)
    for m in lot.members:
        print(f"{m.campaign}  serial {m.serial}  {m.date}"
              + ("  (earlier test)" if m.earlier else ""))
    print(f"{len(lot.members)} campaigns in {time.perf_counter() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
