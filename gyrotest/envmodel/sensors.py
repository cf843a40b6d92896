"""The logged channels' own measurement noise, and the channels the model's terms are built from.

A thermocouple, a humidity or pressure sensor reads its node plus its own noise e (white noise
and, for a coarse sensor, quantisation steps). A regressor built from the raw reading carries
that noise: its coefficient is attenuated by the reliability ratio var(x)/(var(x) + var(e))
(errors in variables, Fuller 1987), and the part of the effect the noisy regressor misses is
left in the residual -- where a second sensor of the same node, a lag or a rate of another
channel, or a free sinusoid can then "explain" it by averaging the noise out. That is a better
prediction, not a new physical effect.

The workbench therefore builds every term from the channel's best estimate of its node: the
zero-phase Wiener filter of the reading (Wiener 1949), with the noise spectrum estimated from
the channel itself and the signal spectrum from its smoothed periodogram minus that noise
(spectral subtraction, Boll 1979):

    x̂(f) = G(f)·x(f),   G(f) = max(0, 1 − S_e / Ŝ_x(f)),   S_e = σ_e²·dt

σ_e² from the robust scale of the second differences (white noise: var(Δ²x) = 6σ_e²), at
least q²/12 for a channel quantised in steps of q. Ŝ_x is the periodogram of the segment
(mirror-extended, linear trend removed and restored) averaged over log-spaced frequency bins.
Where the node's own variation dominates (slow temperature changes) G ≈ 1 and the reading is
kept; where the sensor noise dominates, it is removed. The filter is symmetric, so it adds no
lag. The coil currents or magnetometer and the supply are not filtered: their steps are
the stimulus, and their sensors' noise is small beside them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

#: log-spaced bins per decade over which the periodogram is averaged for Ŝ_x
BINS_PER_DECADE = 8


@dataclass
class SensorNoise:
    """A channel's measurement noise: white σ (per sample of the grid), the quantisation step
    (0 when not quantised), and the frequency above which the sensor noise dominates; with
    the Wiener gains applied per segment (to filter simulated noise the same way)."""

    sigma: float
    step: float
    crossover_hz: float
    gains: list = field(default_factory=list, repr=False)  # [(start, stop, G)] per segment

    @property
    def variance(self) -> float:
        """Variance per sample of the white noise model: σ², at least q²/12."""
        return max(self.sigma * self.sigma, self.step * self.step / 12.0)

    def filtered(self, e: np.ndarray) -> np.ndarray:
        """White noise ``e`` (one value per grid sample) through the channel's Wiener gains:
        what of the sensor's noise is left in the filtered channel."""
        out = np.zeros_like(e)
        for a, b, G in self.gains:
            if G is None:  # the channel is used as read: its noise passes unfiltered
                out[a:b] = e[a:b]
                continue
            seg = e[a:b]
            ext = np.concatenate([seg, seg[::-1]])
            out[a:b] = np.fft.irfft(np.fft.rfft(ext) * G, len(ext))[:b - a]
        return out

    def to_dict(self) -> dict:
        return {"white_sigma": self.sigma, "quantisation_step": self.step,
                "noise_dominates_above_hz": self.crossover_hz}


def quantisation_step(x: np.ndarray) -> float:
    """The step q of a channel whose sample-to-sample changes are integer multiples of one
    value (a coarse thermometer: 0.0625 degC), else 0."""
    d = np.abs(np.diff(np.asarray(x, float)))
    d = d[np.isfinite(d) & (d > 0)]
    if len(d) < 8:
        return 0.0
    q = float(np.min(d))
    if not q > 0:
        return 0.0
    r = d / q
    if np.mean(np.abs(r - np.round(r)) < 0.02) > 0.99:
        return q
    return 0.0


def white_sigma(x: np.ndarray) -> float:
    """σ of the white part of a channel's noise per sample: 1.4826·MAD of the second
    differences / √6 (slow variation and rare steps do not move the median)."""
    x = np.asarray(x, float)
    if len(x) < 5:
        return 0.0
    d2 = x[2:] - 2 * x[1:-1] + x[:-2]
    return 1.4826 * float(np.median(np.abs(d2 - np.median(d2)))) / math.sqrt(6.0)


def wiener(x: np.ndarray, dt: float, bounds: list[tuple[int, int]] | None = None
           ) -> tuple[np.ndarray, SensorNoise]:
    """The zero-phase Wiener estimate of a channel's node from its reading (module
    docstring), segment by segment. Returns (x̂, the noise found)."""
    x = np.asarray(x, float)
    out = x.copy()
    if bounds is None:
        bounds = [(0, len(x))]
    sig = white_sigma(x)
    q = quantisation_step(x)
    s2 = max(sig * sig, q * q / 12.0)
    cross = []
    gains = []
    if not s2 > 0 or not np.all(np.isfinite(x)):
        return out, SensorNoise(sig, q, math.inf)
    for a, b in bounds:
        n = b - a
        if n < 32:
            continue
        seg = x[a:b]
        k = np.arange(n)
        c = np.polyfit(k, seg, 1)
        trend = np.polyval(c, k)
        r = seg - trend
        ext = np.concatenate([r, r[::-1]])  # mirror: periodic without a jump
        F = np.fft.rfft(ext)
        f = np.fft.rfftfreq(len(ext), dt)
        P = (np.abs(F) ** 2) * dt / len(ext)
        S = _bin_average(f, P)
        Se = s2 * dt
        G = np.clip(1.0 - Se / np.maximum(S, 1e-300), 0.0, 1.0)
        G[0] = 1.0
        out[a:b] = np.fft.irfft(F * G, len(ext))[:n] + trend
        gains.append((a, b, G))
        below = np.flatnonzero(G < 0.5)
        if len(below):
            cross.append(float(f[below[0]]))
    return out, SensorNoise(sig, q, min(cross) if cross else math.inf, gains)


def _bin_average(f: np.ndarray, P: np.ndarray) -> np.ndarray:
    """P averaged over log-spaced frequency bins (:data:`BINS_PER_DECADE`), each frequency
    given its bin's mean (the lowest bin starts at the first non-zero frequency)."""
    out = P.copy()
    if len(f) < 3:
        return out
    lf = np.log10(np.maximum(f[1:], f[1]))
    edges = np.arange(lf[0], lf[-1] + 1.0 / BINS_PER_DECADE, 1.0 / BINS_PER_DECADE)
    idx = np.clip(np.searchsorted(edges, lf, side="right") - 1, 0, len(edges) - 1)
    sums = np.bincount(idx, weights=P[1:], minlength=len(edges))
    cnt = np.bincount(idx, minlength=len(edges))
    mean = sums / np.maximum(cnt, 1)
    out[1:] = mean[idx]
    return out


def stepped(x: np.ndarray) -> bool:
    """Whether a channel changes in steps (a coil current, a supply or a tilt table: most of
    its variance in a few large sample-to-sample changes) rather than continuously."""
    x = np.asarray(x, float)
    d = np.diff(x)
    if len(d) < 8:
        return False
    tot = float(d @ d)
    if not tot > 0:
        return False
    big = np.sort(d * d)[::-1]
    k = max(1, len(d) // 100)
    return float(np.sum(big[:k])) > 0.5 * tot


def measure_frame(frame) -> dict[str, SensorNoise]:
    """The measurement noise of the temperature and extra channels of an EnvFrame (white σ per
    sample, quantisation step), the channels left as read: the noise is carried into the
    noise model through the terms that read them (:func:`eiv_acov`)."""
    found: dict[str, SensorNoise] = {}
    for group in (frame.temperature, frame.extra):
        for name, v in group.items():
            v = np.asarray(v, float)
            if v.shape != frame.t.shape or not np.all(np.isfinite(v)):
                continue
            found[name] = SensorNoise(white_sigma(v), quantisation_step(v), math.inf,
                                      [(a, b, None) for a, b in frame.bounds])
    return found


def denoise_frame(frame) -> dict[str, SensorNoise]:
    """Replace the temperature and extra channels of an EnvFrame by their Wiener estimates;
    returns the noise found per channel. A stepped channel (a tilt table, a vibration switched
    on and off) keeps its steps: their spectrum stands above the sensor noise up to high
    frequencies, where the gain stays 1."""
    found: dict[str, SensorNoise] = {}
    for group in (frame.temperature, frame.extra):
        for name in list(group):
            v = np.asarray(group[name], float)
            if v.shape != frame.t.shape or not np.all(np.isfinite(v)):
                continue
            xh, noise = wiener(v, frame.dt, frame.bounds)
            group[name] = xh
            found[name] = noise
    return found


#: realisations of the sensors' noise simulated for the errors-in-variables noise term
EIV_DRAWS = 8


def term_channels(spec) -> set[str]:
    """The logged channels a term reads (its own, or those its expression names)."""
    chans = set(spec.channels)
    if spec.key == "custom" and spec.expr:
        from .expr import parse_expression

        try:
            chans |= {c.name for c in parse_expression(spec.expr).channels}
        except Exception:  # noqa: BLE001 - an expression already parsed by the fit
            pass
    return chans


def eiv_draws(wd, specs, thetas: dict, seed: int = 1953) -> dict[str, list[dict]]:
    """Realisations of what each noisy channel's own measurement noise does to the terms
    that read it: for each logged channel with a measured noise
    (:attr:`WorkData.sensor_noise`), :data:`EIV_DRAWS` draws of its white noise (σ², at
    least q²/12 for a quantised one) are added to the channel and every term that reads it is
    rebuilt; each draw is {term label: Δx (blocks × coefficients)}."""
    import dataclasses

    out: dict[str, list[dict]] = {}
    noise = getattr(wd, "sensor_noise", None) or {}
    if not noise:
        return out
    rng = np.random.default_rng(seed)
    fr = wd.frame
    for ch, sn in noise.items():
        terms = [s for s in specs if s.key != "bias" and ch in term_channels(s)]
        if not terms or not sn.gains or not sn.variance > 0:
            continue
        group = "temperature" if ch in fr.temperature else "extra"
        base = getattr(fr, group)[ch]
        ref = {s.label: _block_on(wd, fr, s, thetas.get(s.label)) for s in terms}
        draws = []
        for _ in range(EIV_DRAWS):
            e = sn.filtered(rng.normal(0.0, math.sqrt(sn.variance), fr.n))
            fr2 = dataclasses.replace(fr, **{group: {**getattr(fr, group), ch: base + e}})
            draws.append({s.label: _block_on(wd, fr2, s, thetas.get(s.label)) - ref[s.label]
                          for s in terms})
        out[ch] = draws
    return out


def eiv_acov(all_draws: dict[str, list[dict]], grid, beta: dict, nlag: int
             ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Autocovariance (lags 0 … nlag − 1) of the differenced likelihood samples of the noise
    the model's terms carry from their sensors (errors in variables, Fuller 1987): per
    channel, Σ_j β_j·Δx_j of each draw (:func:`eiv_draws`) is a realisation of what that
    sensor puts into the residual; the sample autocovariances (biased, so positive definite)
    are averaged over the draws and summed over the channels. Returns (the sum, each
    channel's part)."""
    out = np.zeros(nlag)
    parts: dict[str, np.ndarray] = {}
    for ch, draws in all_draws.items():
        acc = np.zeros(nlag)
        count = 0
        for dr in draws:
            d = sum((dx @ np.asarray(beta[lab], float) for lab, dx in dr.items()
                     if lab in beta), np.zeros(grid.nb))
            if not np.any(d):
                continue
            for run in grid.diffs(grid.means(d)):
                L = min(nlag, len(run))
                full = np.correlate(run, run, mode="full")[len(run) - 1:len(run) - 1 + L]
                acc[:L] += full
                count += len(run)
        if count:
            parts[ch] = acc / count
            out += parts[ch]
    return out, parts


def eiv_moment(draws: dict[str, list[dict]], lik, offsets: dict, p: int) -> np.ndarray:
    """E[ΔX̃ᵀΔX̃] (p × p): what the sensors' noise adds to the whitened design's cross
    products, averaged over the draws and summed over the (independent) channels. The
    errors-in-variables corrected GLS estimate is (X̃ᵀX̃ − M)⁻¹X̃ᵀỹ (Fuller 1987, §3.1: the
    method-of-moments correction of the attenuation a noisy regressor gives)."""
    M = np.zeros((p, p))
    for _ch, ds in draws.items():
        acc = np.zeros((p, p))
        for dr in ds:
            D = None
            for lab, dx in dr.items():
                a, b = offsets[lab]
                w = lik.whiten(dx)
                if D is None:
                    D = np.zeros((w.shape[0], p))
                D[:, a:b] += w
            if D is not None:
                acc += D.T @ D
        M += acc / max(len(ds), 1)
    return M


def _block_on(wd, frame, spec, theta) -> np.ndarray:
    """A term's block-level regressor built on ``frame`` (the working smoother and block
    means of :class:`gyrotest.envmodel.varpro.Design`)."""
    from .terms import build_term

    if spec.effect.prefiltered:
        x = build_term(frame, spec, theta or {}, wd.refs)
    else:
        x = wd.smooth(build_term(frame, spec, theta or {}, wd.refs, to_be_smoothed=True))
    return wd.bmean(x).reshape(wd.nb, -1)


__all__ = ["EIV_DRAWS", "SensorNoise", "eiv_acov", "eiv_draws", "eiv_moment",
           "measure_frame", "term_channels", "denoise_frame", "quantisation_step", "stepped", "white_sigma",
           "wiener"]
