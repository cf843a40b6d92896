"""Names and defaults of the noise analysis that the CLI declares its options with.

Plain constants, no numpy or scipy: ``gyrotest allan`` imports this module to build its
options and starts reading the log before the analysis modules (numpy, scipy.special, ≈ 0.2 s)
are imported (:mod:`gyrotest.cli.cmd_allan`). The analysis modules re-export them.
"""

from __future__ import annotations

#: every deviation :func:`gyrotest.noise.deviations.compute_deviation` computes
DEVIATION_KINDS = (
    "oadev", "adev", "mdev", "tdev", "hdev", "ohdev", "totdev", "mtotdev", "akdev", "hkdev",
    # long-τ and gap-tolerant kinds, computed in gyrotest.noise.theo / gyrotest.noise.gapdev
    "theo1", "theoh", "ttotdev", "htotdev", "gapadev",
)
#: deviations a streamed log (θ only, :mod:`gyrotest.io.stream`) supports: those computed from θ
STREAM_DEVS = ("oadev", "adev", "mdev", "tdev", "hdev", "ohdev", "totdev", "mtotdev", "akdev",
               "hkdev")
#: default fitting floor: τ with fewer equivalent degrees of freedom are not fitted (at EDF 2
#: the 68.3 % interval of σ is already ×0.65 … ×2.2; the Stable32 stop ratio 4 keeps
#: EDF ≥ 2.2 for every power-law noise α ≥ −2, so default grids are fitted to their end)
MIN_EDF = 2.0
