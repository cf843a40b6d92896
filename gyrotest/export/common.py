"""Shared plumbing of the exporters: reading a saved result, recognising its kind, picking the
axes of an Allan document, the noise coefficients of an axis, unit conversions, and writing a
file atomically (temp file + rename: never a half-written deliverable).

The inputs are the documents gyrotest already writes: ``gyrotest allan --json`` (kind
``allan``), a model file of ``gyrotest model fit -o`` / ``thermal-fit -o`` (kind ``envmodel``),
``gyrotest scale-factor --json`` (kind ``scale-factor``). Every malformed input is an
:class:`~gyrotest.core.errors.InputError` naming the file and the fix.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .. import __version__
from ..core.errors import InputError
from ..core.output import atomic_open

DEG = math.pi / 180.0

#: how each kind of input is produced (for messages)
PRODUCERS = {
    "allan": "the --json output of 'gyrotest allan' (gyrotest allan LOG --json > allan.json)",
    "envmodel": "a model file written by 'gyrotest model fit -o model.json' or "
                "'gyrotest thermal-fit -o model.json'",
    "scale-factor": "the --json output of 'gyrotest scale-factor' "
                    "(gyrotest scale-factor RUN... --json > sf.json)",
}


@dataclass
class Document:
    """A saved gyrotest result: its kind, its parsed content and the file it came from."""

    kind: str
    data: dict
    source: str


def detect_kind(d: Any) -> str | None:
    """``allan``, ``envmodel``, ``scale-factor``, ``thermal-fit`` (a --json report without
    the model), or None."""
    if not isinstance(d, dict):
        return None
    if d.get("analysis") == "allan":
        return "allan"
    if d.get("format") == "gyrotest-envmodel":
        return "envmodel"
    if d.get("command") == "scale-factor" or ("epsilon_k" in d and "nonlinearity_model" in d):
        return "scale-factor"
    if "chamber" in d and "setpoints" in d:
        return "thermal-fit"
    return None


def read_document(path: str | Path, want: str) -> Document:
    """Read a JSON (or, for models, TOML) result and check it is of kind ``want``."""
    from ..core.documents import load_document

    p = Path(path)
    try:
        d, _ = load_document(p, fmt="toml" if p.suffix.lower() == ".toml" else "json",
                             what=PRODUCERS[want],
                             not_found=f"file not found; give {PRODUCERS[want]}")
    except InputError as e:
        if "not found" in str(e):
            raise
        raise InputError(f"{e}; cannot parse it, give {PRODUCERS[want]}") from None
    kind = detect_kind(d)
    if kind == "envmodel" and want == "envmodel":
        from ..core.documents import DocumentError
        from ..envmodel.schemas import model_problems

        problems = model_problems(d)  # every problem, naming its key (gyrotest.envmodel.schemas)
        if problems:
            raise DocumentError(str(p), problems)
    if kind != want:
        if kind == "thermal-fit" and want == "envmodel":
            raise InputError(f"{p} is the --json report of 'gyrotest thermal-fit', which does not "
                             "hold the model; save it with 'gyrotest thermal-fit LOG -o "
                             "model.json' and export that file")
        what = f"a {kind} result" if kind else "not a gyrotest result this command knows"
        raise InputError(f"{p}: {what}; this export needs {PRODUCERS[want]}")
    return Document(kind, d, str(p))


def need(d: dict, key: str, source: str, where: str = "") -> Any:
    """``d[key]``, or an InputError naming the missing key and the file."""
    if not isinstance(d, dict) or key not in d or d[key] is None:
        at = f" in {where}" if where else ""
        raise InputError(f"{source}: key {key!r} missing{at}; the file is incomplete or from "
                         "another version — re-run the analysis with --json")
    return d[key]


def number(v: Any, source: str, what: str) -> float:
    try:
        x = float(v)
    except (TypeError, ValueError):
        raise InputError(f"{source}: {what} is not a number ({v!r})") from None
    return x


# ----------------------------------------------------------------------------- Allan axes
@dataclass
class NoiseTerm:
    """One noise coefficient as exported: value (the estimate when identified, the 95 % upper
    bound otherwise), its status, its unit (gyrotest's: N deg/√h, K deg/h/√h, B deg/h, Q arcsec)."""

    key: str
    value: float
    status: str
    unit: str

    @property
    def bound(self) -> bool:
        return self.status != "identified"

    def describe(self) -> str:
        rel = "<=" if self.bound else "="
        extra = " (95 % upper bound, exported at the bound)" if self.bound else " (identified)"
        return f"{self.key} {rel} {self.value:.6g} {self.unit}{extra}"


@dataclass
class AllanAxis:
    """One (log, axis) of an Allan document."""

    source: str
    axis: str
    tau0_s: float
    n_samples: int
    doc: dict  # the axis' JSON object
    log: dict  # the log's JSON object
    file: str = ""  # the document it was read from (for messages)

    @property
    def label(self) -> str:
        return f"{self.source} [{self.axis}]"

    @property
    def quantity(self) -> str:
        """"rate" (a gyro axis) or "acceleration" (an accelerometer axis); documents written
        before accelerometers were analysed hold gyro axes only."""
        return str(self.doc.get("quantity") or "rate")

    @property
    def is_accel(self) -> bool:
        return self.quantity == "acceleration"

    def model_fit(self) -> dict:
        """The noise model the analysis reports (the diagnosed one when the diagnosis changed
        it, as for the conversions of ``gyrotest allan``)."""
        diag = self.doc.get("diagnosis") or {}
        return diag.get("final_fit") or self.doc.get("fit") or {}

    def term(self, key: str) -> NoiseTerm | None:
        for t in self.model_fit().get("terms") or []:
            if t.get("key") != key:
                continue
            status = t.get("status") or "identified"
            if status == "identified":
                v = (t.get("params") or {}).get(key)
            else:
                v = t.get("upper_95")
            if v is None or not math.isfinite(float(v)):
                return None
            unit = (t.get("units") or {}).get(key, "")
            return NoiseTerm(key, float(v), status, unit)
        return None


def allan_axes(doc: Document, axes: list[str] | None = None) -> list[AllanAxis]:
    """Every (log, axis) of an Allan document, or the ``axes`` asked for."""
    src = doc.source
    out = []
    for lg in need(doc.data, "logs", src):
        tau0 = number(need(lg, "tau0_s", src, "logs[]"), src, "tau0_s")
        for ax in need(lg, "axes", src, "logs[]"):
            name = str(need(ax, "axis", src, "logs[].axes[]"))
            out.append(AllanAxis(str(lg.get("source", src)), name, tau0,
                                 int(lg.get("n_samples") or 0), ax, lg, src))
    if not out:
        raise InputError(f"{src}: the Allan document has no analysed axis")
    if axes:
        have = sorted({a.axis for a in out})
        miss = [a for a in axes if a not in have]
        if miss:
            raise InputError(f"{src}: no axis {', '.join(map(repr, miss))} "
                             f"(axes: {', '.join(have)}); fix --axis")
        out = [a for a in out if a.axis in axes]
    return out


# ----------------------------------------------------------------------------- units
def arw_rad_s_rt_hz(n_deg_rt_h: float) -> float:
    """Angle random walk N (deg/√h) as a white-rate noise density in rad/s/√Hz.

    1 deg/√h = (π/180) rad / √(3600 s) = (π/180)/60 rad/√s, and rad/√s = (rad/s)/√Hz.
    The density is the square root of the two-sided rate PSD (IEEE Std 952-1997 Annex C:
    S_Ω = N²), the "continuous-time noise density" of Kalibr (ethz-asl/kalibr wiki, "IMU
    Noise Model") and MATLAB ``gyroparams.NoiseDensity`` with NoiseType double-sided.
    """
    return n_deg_rt_h * DEG / 60.0


def rrw_rad_s2_rt_hz(k_deg_h_rt_h: float) -> float:
    """Rate random walk K (deg/h/√h) in rad/s²/√Hz = (rad/s)·√Hz.

    1 deg/h/√h = (π/180) rad / 3600 s / √(3600 s) = (π/180)/216000 rad/s^1.5. Kalibr's
    ``gyroscope_random_walk`` and MATLAB ``gyroparams.RandomWalk`` (IEEE 952 Annex C:
    S_Ω(f) = (K/2π)²/f²).
    """
    return k_deg_h_rt_h * DEG / (3600.0 * 60.0)


def dph_rad_s(x_deg_h: float) -> float:
    """deg/h → rad/s (÷3600, ×π/180)."""
    return x_deg_h * DEG / 3600.0


#: standard gravity, m/s² (as in :mod:`gyrotest.core.units`)
G0 = 9.80665


def vrw_m_s2_rt_hz(n_m_s_rt_h: float) -> float:
    """Velocity random walk (m/s/√h) as a white-acceleration noise density in m/s²/√Hz.

    1 m/s/√h = 1 m/s / √(3600 s) = (1/60) m/s/√s, and m/s/√s = (m/s²)/√Hz: Kalibr's
    ``accelerometer_noise_density`` and MATLAB ``accelparams.NoiseDensity`` (IEEE Std 1293:
    S_a = VRW², two-sided)."""
    return n_m_s_rt_h / 60.0


def acrw_m_s3_rt_hz(k_m_s_h_rt_h: float) -> float:
    """Acceleration random walk (m/s/h/√h) in m/s³/√Hz = (m/s²)·√Hz: 1 m/s/h/√h =
    (1/3600) m/s² / (60 √s) = 1/216000 m/s²/√s. Kalibr's ``accelerometer_random_walk`` and
    MATLAB ``accelparams.RandomWalk``."""
    return k_m_s_h_rt_h / 216000.0


def ug_m_s2(x_ug: float) -> float:
    """µg → m/s² (g = 9.80665 m/s²)."""
    return x_ug * G0 * 1e-6


# ----------------------------------------------------------------------------- writing
def fnum(x: float, digits: int = 8) -> str:
    """A number for a text deliverable: repr-exact enough, 'nan' never (callers check)."""
    return f"{x:.{digits}g}"


def banner(what: str, sources: list[str]) -> str:
    """One provenance line: generator, version, inputs."""
    return f"{what} written by gyrotest {__version__} from {', '.join(sources)}"


def write_output(path: str | Path, content: str | bytes | None = None, *, writer=None) -> Path:
    """Write ``content`` (or call ``writer(tmp_path)``) atomically to ``path``. A directory
    that does not exist or cannot be written is an InputError naming it; nothing is left
    behind on error."""
    from ..core.output import atomic_path

    p = Path(path)
    if p.is_dir():
        raise InputError(f"cannot write {p}: it is a directory; give a file name with -o")
    try:
        if writer is not None:
            with atomic_path(p) as tmp:
                writer(tmp)
        elif isinstance(content, bytes):
            with atomic_open(p, "wb") as fh:
                fh.write(content)
        else:
            with atomic_open(p, "w", encoding="utf-8", newline="\n") as fh:
                fh.write(content or "")
    except PermissionError as e:
        raise InputError(f"cannot write {p}: permission denied ({e.strerror}); choose another "
                         "directory with -o") from None
    except IsADirectoryError:
        raise InputError(f"cannot write {p}: it is a directory") from None
    except OSError as e:
        raise InputError(f"cannot write {p}: {e.strerror or e}") from None
    return p
