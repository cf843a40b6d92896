"""The noise level a drift model's residual can reach at the working resolution, and the check
that a static reference run can stand for the log's noise.

The gyro's noise model itself (white, flicker and random-walk rate noise fitted by maximum
likelihood) is in :mod:`gyrotest.envmodel.likelihood`; :func:`floor_rms` turns its parameters
into the RMS of the block-mean residual that noise alone leaves.
"""

from __future__ import annotations

import math

#: ln 2 factor of the flicker plateau: σ² = B²·(2 ln 2)/… — see :func:`floor_rms`
_LN2 = math.log(2.0)


def floor_rms(N: float, B: float, K: float, t_eff_s: float, duration_s: float) -> float:
    """RMS (deg/h) of mean-removed working-resolution residuals of white, flicker and
    random-walk rate noise.

    Formula: rms² = N²/T_eff + B²·ln(T/(2·T_eff))/(2 ln 2) + K²·T/6, with N in
    (deg/h)·√s (σ² = N²/τ), B the flicker Allan plateau in deg/h, K in (deg/h)/√s
    (σ² = K²τ/3), T_eff the averaging time of the working filter (smoother and block mean,
    :func:`gyrotest.envmodel.modelfit.effective_averaging_time`) and T the record length: white
    noise averaged over T_eff; flicker with one-sided PSD B²/(2 ln 2·f) integrated from 1/T to
    1/(2·T_eff); a random walk of diffusion K² has a mean-removed variance K²·T/6 over T.
    Source: IEEE Std 952-1997 Annex C (σ² of white, flicker and random-walk rate noise);
    gyrotest (integration over the record).
    """
    ratio = duration_s / (2.0 * t_eff_s)
    flick = B * B * math.log(ratio) / (2 * _LN2) if ratio > 1 else 0.0
    rw = K * K * duration_s / 6.0 if K > 0 else 0.0
    return math.sqrt(N * N / t_eff_s + flick + rw)


def check_reference(ref_log, log, wd, noise) -> None:
    """A reference run must be the same kind of record: InputError (one line, naming the
    file and the fix) when its sample interval is coarser than the log's working grid or its
    white noise (``noise``: its :class:`~gyrotest.envmodel.likelihood.NoiseParams`) differs
    from the log's own (the robust scale of the rate's first differences) by more than 10×
    (another unit or another gyro)."""
    from ..core.errors import InputError
    from .frame import _white_sigma

    if ref_log.tau0 > wd.frame.dt * (1 + 1e-6):
        raise InputError(f"--reference {ref_log.source}: sampled every {ref_log.tau0:g} s, "
                         f"coarser than the log's working grid ({wd.frame.dt:g} s); record "
                         "the reference at the log's sample rate or faster")
    own = _white_sigma(wd.frame) * math.sqrt(wd.frame.dt)  # (deg/h)·√s
    ref = noise.N * 60.0
    if math.isfinite(own) and own > 0 and math.isfinite(ref) and ref > 0:
        r = ref / own
        if r > 10 or r < 0.1:
            raise InputError(f"--reference {ref_log.source}: its white noise "
                             f"({ref:.3g} (deg/h)·√s) is {r:.3g}× that of "
                             f"{log.source}; a different rate unit or another gyro? read it "
                             "with the same --rate-unit/--profile as the log")


__all__ = ["check_reference", "floor_rms"]
