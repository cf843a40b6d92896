"""3-axis scale-factor and misalignment matrix from a multi-position rate-table run (IEEE 952
§8.3 model equation, per axis; the error model of a strapdown triad δω = a + M·ω + n).

The sequence (the classic rotation-about-each-axis procedure): the unit is mounted with one
case axis along the table axis — the log's position column names it (``+x``, ``-y``, ``z`` …)
— and the table turns at several rates of both signs; then the next axis. For the position
with case axis e_a (sign σ) and table rate ω, the true input is ω·σ·e_a (plus the earth rate,
constant within a position). The three gyro outputs follow

    y_i = c_i,a + K_ia·σ·ω,        K = I + M

so a weighted straight line of each output against σ·ω over that position's plateaus gives
column a of K (slope K_ia, its σ from the plateau standard errors; the intercept c_i,a holds
bias + earth rate and is not used). M = K − I: diagonal = scale-factor errors (ppm), off-diagonal
= misalignment/cross-coupling of gyro i into case axis a (µrad; small-angle, K_ia ≈ angle).
Plateaus and their settling as in :func:`~gyrotest.scalefactor.plateaus.extract_plateaus`
(commanded-rate column, settling found from the data on the on-axis gyro). Rates in deg/h
inside, M in ppm / µrad out.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..core.errors import InputError
from .plateaus import DPS, constant_runs, mean_stderr
from .settling import find_settling

_AXES = {"x": 0, "y": 1, "z": 2}


def parse_axis_label(label: str) -> tuple[int, float] | None:
    """``+x``/``x``/``-y``/``pz``… → (case axis index, sign); None for anything else."""
    s = str(label).strip().lower().replace(" ", "")
    sign = 1.0
    if s[:1] in "+-":
        sign = -1.0 if s[0] == "-" else 1.0
        s = s[1:]
    for pre in ("p", "n"):  # px / nx spellings
        if len(s) == 2 and s[0] == pre and s[1] in _AXES:
            sign = -1.0 if pre == "n" else 1.0
            s = s[1]
    if s in _AXES:
        return _AXES[s], sign
    return None


@dataclass
class MatrixResult:
    """K = I + M with 1σ; M in ppm on the diagonal (scale-factor error) and µrad off it."""

    axes: list[str]  # gyro output columns, in x, y, z order
    K: np.ndarray
    K_sigma: np.ndarray
    n_plateaus: list[int]  # per case axis (column)
    settling_worst_s: float
    notes: list[str] = field(default_factory=list)

    @property
    def M(self) -> np.ndarray:
        return self.K - np.eye(3)

    def to_dict(self) -> dict:
        M = self.M
        return {"gyro_axes": self.axes,
                "K": self.K.tolist(), "K_sigma": self.K_sigma.tolist(),
                "scale_factor_error_ppm": [float(M[i, i] * 1e6) for i in range(3)],
                "scale_factor_error_sigma_ppm": [float(self.K_sigma[i, i] * 1e6) for i in range(3)],
                "misalignment_urad": (M * 1e6 * (1 - np.eye(3))).tolist(),
                "misalignment_sigma_urad": (self.K_sigma * 1e6 * (1 - np.eye(3))).tolist(),
                "n_plateaus_per_case_axis": self.n_plateaus,
                "settling_worst_s": self.settling_worst_s,
                "definition": "y = c + K w (rate output per input, per position); K = I + M; "
                              "row i = gyro i, column a = case axis a; off-diagonal M_ia: "
                              "sensitivity of gyro i to rotation about case axis a (small angle, "
                              "rad)",
                "notes": self.notes}


def misalignment_matrix(log, *, settle_s: float = 0.0, auto_settle: bool = True,
                        min_dwell_s: float = 2.0, n_batches: int = 32) -> MatrixResult:
    """K = I + M of a 3-axis log (see the module doc). Needs three rate columns (x, y, z order),
    a commanded table-rate column and a position column naming the case axis on the table."""
    src = log.source
    if len(log.rates) < 3:
        raise InputError(f"{src}: the matrix needs three gyro rate columns (x, y, z); the log "
                         f"has {len(log.rates)} ({', '.join(log.rates)})")
    if log.table_rate is None:
        raise InputError(f"{src}: the matrix needs the commanded table rate (--table-col)")
    if log.position is None:
        raise InputError(f"{src}: the matrix needs a position column naming the case axis on "
                         "the table (+x, -y, z …); name it in the profile ([columns] position)")
    axes = list(log.rates)[:3]
    Y = np.column_stack([log.rates[a] for a in axes])
    t, tau0 = log.t, log.tau0
    pos = log.position
    # stretches of constant (position, command)
    code = np.unique(pos, return_inverse=True)[1].astype(float)
    key = log.table_rate + 1e9 * code
    starts, stops = constant_runs(key)
    rows: dict[int, list[tuple[float, np.ndarray, np.ndarray]]] = {0: [], 1: [], 2: []}
    worst = 0.0
    bad = set()
    for s, e in zip(starts.tolist(), stops.tolist()):
        if (e - s) * tau0 < min_dwell_s:
            continue
        ax = parse_axis_label(pos[s])
        if ax is None:
            bad.add(str(pos[s]))
            continue
        a, sign = ax
        w = float(log.table_rate[s]) * sign
        st = find_settling(Y[s:e, a], tau0)
        if auto_settle and not st.settled:
            raise InputError(f"{src}: the plateau at {log.table_rate[s] / DPS:+g} deg/s (position "
                             f"{pos[s]}, t = {t[s]:.6g} s) is still settling at its end; record "
                             "longer dwells or use --settle S --fixed-settle")
        settle = max(settle_s, st.found_s) if auto_settle else settle_s
        worst = max(worst, st.found_s)
        i0 = s + int(math.ceil(settle / tau0))
        if e - i0 < 8:
            raise InputError(f"{src}: the plateau at {log.table_rate[s] / DPS:+g} deg/s (position "
                             f"{pos[s]}) lasts {(e - s) * tau0:.4g} s, not longer than its "
                             f"settling time {settle:.3g} s")
        means, ses = np.empty(3), np.empty(3)
        for i in range(3):
            mu, se, _ = mean_stderr(Y[i0:e, i], n_batches)
            means[i], ses[i] = mu, se
        rows[a].append((w, means, ses))
    notes = []
    if bad:
        notes.append(f"positions not naming a case axis were skipped: {', '.join(sorted(bad))}")
    K = np.full((3, 3), math.nan)
    Ks = np.full((3, 3), math.nan)
    npl = []
    for a in range(3):
        pts = rows[a]
        npl.append(len(pts))
        if len({round(p[0], 6) for p in pts}) < 2:
            notes.append(f"case axis {'xyz'[a]}: fewer than two table rates; column {a + 1} of "
                         "K not measured")
            continue
        w = np.array([p[0] for p in pts])
        for i in range(3):
            y = np.array([p[1][i] for p in pts])
            se = np.array([p[2][i] for p in pts])
            se = np.where(np.isfinite(se) & (se > 0), se, np.nanmax(se) if np.any(se > 0) else 1.0)
            X = np.column_stack([np.ones_like(w), w])
            W = 1 / se ** 2
            cov = np.linalg.inv(X.T @ (X * W[:, None]))
            beta = cov @ (X.T @ (W * y))
            dof = len(w) - 2
            chi = float(np.sum(W * (y - X @ beta) ** 2)) / dof if dof > 0 else 1.0
            K[i, a] = beta[1]
            Ks[i, a] = math.sqrt(cov[1, 1] * max(1.0, chi))
    return MatrixResult(axes, K, Ks, npl, worst, notes)
