"""The logged channels' own measurement noise in the drift model (errors in variables).

A thermocouple, a humidity or pressure sensor reads its node plus its own noise e (white noise
and, for a coarse sensor, quantisation steps of q). A term built from the reading carries
that noise into the model: β·x_read = β·x_node + β·e. Two things follow (Fuller 1987):

* the residual holds −β·e (filtered by the term: a rate term differentiates it), which the
  gyro's noise model alone does not describe; :func:`eiv_draws` simulates it (white noise of
  the channel's σ², or for a quantised channel the rounding error along its path,
  :func:`error_draw`, added to the channel and every term that reads it rebuilt) and
  :func:`eiv_acov` turns it into an autocovariance that joins the noise model of the
  likelihood (:mod:`gyrotest.envmodel.likelihood`), taken at the attenuation-corrected
  coefficients (the residual carries the noise times the true β, not the attenuated one);
* least squares attenuates β by the reliability ratio λ = var(x)/(var(x) + var(e)); the
  workbench corrects its GLS coefficients by the method of moments, (X̃ᵀX̃ − M)⁻¹X̃ᵀỹ with M
  what the noise adds to X̃ᵀX̃ (:func:`eiv_moment`), and names a term whose λ is below ½
  as limited by its sensor.

A second sensor of the same node, or a lag or rate of the same sensor, can average the first
one's noise out and so "explain" part of the residual: a better reading, not a new effect;
the verdict tests a candidate's gain against what a noise-free reading of the model's own
sensors would give (:func:`gyrotest.envmodel.calibration.sensor_limit`).

Each channel's σ is the robust scale of its second differences (white noise:
var(Δ²x) = 6σ²), or, below a quantiser's step where those are mostly zero, the σ that makes
simulated readings toggle as often as the logged one (:func:`dither_sigma`); the channels
themselves are used as read (a filter applied to a regressor and not to the gyro rate would
bias the coefficient).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass
class SensorNoise:
    """A channel's measurement noise: white σ (per sample of the grid) and the quantisation
    step (0 when not quantised)."""

    sigma: float
    step: float

    @property
    def variance(self) -> float:
        """Variance per sample of the white noise model: σ², at least q²/12."""
        return max(self.sigma * self.sigma, self.step * self.step / 12.0)

    def to_dict(self) -> dict:
        return {"white_sigma": self.sigma, "quantisation_step": self.step}


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
            q = quantisation_step(v)
            sig = white_sigma(v)
            if q > 0 and sig < q:
                # below its step the white noise is hidden in the rounding: read it from how
                # often the reading toggles instead
                sig = dither_sigma(v, q)
            found[name] = SensorNoise(sig, q)
    return found


from .workbench_rules import EIV_DRAWS  # noqa: E402  (draws of each channel's noise)


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
        if not terms or not sn.variance > 0:
            continue
        group = "temperature" if ch in fr.temperature else "extra"
        base = getattr(fr, group)[ch]
        ref = {s.label: _block_on(wd, fr, s, thetas.get(s.label)) for s in terms}
        path = node_path(wd, ch, sn, base) if sn.step > 0 else None
        draws = []
        for _ in range(EIV_DRAWS):
            e = error_draw(path, sn, rng) if path is not None else \
                rng.normal(0.0, math.sqrt(sn.variance), fr.n)
            fr2 = dataclasses.replace(fr, **{group: {**getattr(fr, group), ch: base + e}})
            draws.append({s.label: _block_on(wd, fr2, s, thetas.get(s.label)) - ref[s.label]
                          for s in terms})
        out[ch] = draws
    return out


def node_path(wd, ch: str, sn: SensorNoise, x: np.ndarray) -> np.ndarray:
    """:func:`reading_path` of channel ``ch`` (reading ``x``, noise ``sn``), computed once per
    log (cached on the :class:`gyrotest.envmodel.workdata.WorkData`)."""
    cache = getattr(wd, "sensor_paths", None)
    key = (ch, sn.step, sn.sigma)
    path = cache.get(key) if cache is not None else None
    if path is None or len(path) != len(x):
        path = reading_path(np.asarray(x, float), sn.step, sn.sigma)
        if cache is not None:
            cache[key] = path
    return path


def reading_path(x: np.ndarray, step: float, sigma: float = 0.0) -> np.ndarray:
    """The path a quantised channel's node follows under its steps: the Whittaker smoother
    of the reading, z minimising ‖x − z‖² + λ‖D²z‖² (Eilers, "A perfect smoother",
    *Analytical Chemistry* 75, 2003), with λ set by the discrepancy principle (Morozov
    1966): the smoothest path from which the reading departs by exactly the sensor's own
    error variance, mean (x − z)² = σ² + q²/12. The node moves within a cell while the
    reading is flat, and that movement is what the quantiser's error holds: a moving average
    of the reading is flat there and loses it, a path through the threshold crossings keeps
    the movement but not its curvature; on the campaign's 0.0625-degC thermocouples draws
    along this path carry 0.93× the actual error's smoothed level and rate (0.6× for a
    moving average of the reading). A reading with no change is returned as read."""
    from scipy.linalg import LinAlgError, solveh_banded

    x = np.asarray(x, float)
    n = len(x)
    if n < 5 or not np.any(np.diff(x)):
        return x.copy()
    target = sigma * sigma + step * step / 12.0
    m = float(np.mean(x))
    x0 = x - m
    # D²ᵀD² for second differences (upper banded form)
    d0 = np.full(n, 6.0)
    d0[[0, -1]] = 1.0
    d0[[1, -2]] = 5.0
    d1 = np.full(n - 1, -4.0)
    d1[[0, -1]] = -2.0

    def solve(log_lam: float) -> np.ndarray:
        lam = 10.0 ** log_lam
        ab = np.zeros((3, n))
        ab[2] = 1.0 + lam * d0
        ab[1, 1:] = lam * d1
        ab[0, 2:] = lam
        return solveh_banded(ab, x0, check_finite=False)

    lo, hi = -2.0, 12.0
    z = None
    try:
        for _ in range(12):  # λ to 14/2¹² of a decade
            mid = 0.5 * (lo + hi)
            zm = solve(mid)
            if np.mean((x0 - zm) ** 2) > target:
                hi = mid
            else:
                lo, z = mid, zm
    except (LinAlgError, ValueError):
        pass
    if z is None:
        z = solve(lo)
    return z + m


def dither_sigma(x: np.ndarray, step: float, seed: int = 1953) -> float:
    """The white noise σ under a quantiser's rounding, by the method of moments: the σ
    (0 … step/2) whose simulated readings Q(path + c + w) (:func:`error_draw`; four
    offsets c, the same draws of w scaled for every σ, so the count is a smooth function
    of σ) change level as often as the logged reading does, interpolated between
    fortieths of the step. Second differences cannot see it: most are zero when σ is below
    the step, yet that noise makes the reading toggle at each crossing, and the derivative
    of a toggling reading is what a rate term reads. The path (:func:`reading_path`)
    depends on σ: it is taken at σ = 0, then once more at the σ found."""
    x = np.asarray(x, float)
    obs = np.count_nonzero(np.diff(x))
    if obs == 0 or not step > 0:
        return 0.0
    rng = np.random.default_rng(seed)
    offs = rng.uniform(0.0, step, 4)
    zs = [rng.standard_normal(len(x)) for _ in offs]

    def count(path: np.ndarray, s: float) -> float:
        return float(np.mean([np.count_nonzero(np.diff(np.round((path + c + s * z) / step)))
                              for c, z in zip(offs, zs)]))

    sigma = 0.0
    for _ in range(2):
        path = reading_path(x, step, sigma)
        prev_s, prev_c = 0.0, count(path, 0.0)
        sigma = 0.0 if prev_c >= obs else step / 2.0
        for k in range(1, 21):
            s = k * step / 40.0
            c = count(path, s)
            if c >= obs:
                # log-linear between the fortieths that bracket the logged count
                lo, hi = math.log(max(prev_c, 1.0)), math.log(max(c, 1.0))
                f = (math.log(obs) - lo) / (hi - lo) if hi > lo else 1.0
                sigma = prev_s + min(max(f, 0.0), 1.0) * (s - prev_s)
                break
            prev_s, prev_c = s, c
    return sigma


def error_draw(path: np.ndarray, sn: SensorNoise, rng: np.random.Generator) -> np.ndarray:
    """One realisation of a quantised channel's measurement error along ``path``
    (:func:`reading_path`): its white noise w (σ) and the quantiser at a random offset c of
    its grid, Q(path + c + w) − c − path with Q rounding to the step q. On a channel that
    moves by many steps between samples this is white noise of variance σ² + q²/12 (Widrow
    and Kollár, *Quantization Noise*, Cambridge University Press, 2008, ch. 4); on a slow
    one it is the sawtooth the quantiser really adds, correlated over each step's
    duration, which white noise of the same variance would understate after smoothing."""
    q = sn.step
    c = rng.uniform(0.0, q)
    v = path + c + (rng.normal(0.0, sn.sigma, len(path)) if sn.sigma > 0 else 0.0)
    return np.round(v / q) * q - c - path


def eiv_series(all_draws: dict[str, list[dict]], beta: dict, nb: int
               ) -> dict[str, list[np.ndarray]]:
    """Per channel, each draw's Σ_j β_j·Δx_j (:func:`eiv_draws`): a realisation of what that
    sensor's noise puts into the block-level residual (nb,) at the coefficients ``beta``
    {term label: coefficients}; draws that touch no term of ``beta`` are left out."""
    out: dict[str, list[np.ndarray]] = {}
    for ch, draws in all_draws.items():
        ds = []
        for dr in draws:
            d = sum((dx @ np.asarray(beta[lab], float) for lab, dx in dr.items()
                     if lab in beta), np.zeros(nb))
            if np.any(d):
                ds.append(d)
        if ds:
            out[ch] = ds
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
    for ch, series in eiv_series(all_draws, beta, grid.nb).items():
        acc = np.zeros(nlag)
        count = 0
        for d in series:
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


__all__ = ["EIV_DRAWS", "SensorNoise", "dither_sigma", "eiv_acov", "eiv_draws", "eiv_moment",
           "eiv_series", "error_draw",
           "measure_frame", "node_path", "quantisation_step", "reading_path", "term_channels",
           "white_sigma"]
