"""Two small solvers of the noise fit in numpy, so that ``allan`` does not import
scipy.optimize (≈ 0.15 s of start-up on every run) unless a shape parameter is optimised.

:func:`nnls` — non-negative least squares, min ‖Ax − b‖ subject to x ≥ 0: the active-set
algorithm of Lawson & Hanson ("Solving Least Squares Problems", Prentice-Hall
1974, ch. 23): variables enter the passive set one at a time by the largest gradient
component, and an infeasible unconstrained step is cut back to the feasible boundary. For a
matrix of full column rank the solution is unique, so it equals ``scipy.optimize.nnls`` to
rounding (checked in the tests).

:func:`root_bracketed` — a root of a continuous function inside a sign-changing bracket by the
Illinois variant of regula falsi (Dowell & Jarratt, BIT 11, 1971), with a bisection step
whenever the bracket shrinks too slowly, to an absolute tolerance.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

__all__ = ["nnls", "root_bracketed"]


def nnls(A: np.ndarray, b: np.ndarray, maxiter: int | None = None) -> tuple[np.ndarray, float]:
    """(x ≥ 0 minimising ‖Ax − b‖₂, the residual norm). Raises RuntimeError after ``maxiter``
    inner iterations (default 3·columns), as scipy's does."""
    A = np.asarray(A, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    m, n = A.shape
    maxiter = 3 * n if maxiter is None else int(maxiter)
    x = np.zeros(n)
    passive = np.zeros(n, dtype=bool)
    tol = 10.0 * np.finfo(float).eps * max(m, n) * max(float(np.abs(A).sum(axis=0).max()), 1.0)
    w = A.T @ b
    it = 0
    while not passive.all():
        cand = np.where(passive, -np.inf, w)
        j = int(np.argmax(cand))
        if cand[j] <= tol:
            break
        passive[j] = True
        while True:
            s = np.zeros(n)
            idx = np.flatnonzero(passive)
            s[idx] = np.linalg.lstsq(A[:, idx], b, rcond=None)[0]
            if s[idx].min() > 0:
                x = s
                break
            it += 1
            if it > maxiter:
                raise RuntimeError("nnls: maximum number of iterations reached")
            neg = passive & (s <= 0)
            alpha = float(np.min(x[neg] / (x[neg] - s[neg])))
            x = x + alpha * (s - x)
            leave = passive & (x <= tol)
            x[leave] = 0.0
            passive &= ~leave
            if not passive.any():
                break
        w = A.T @ (b - A @ x)
    return x, float(np.linalg.norm(A @ x - b))


def root_bracketed(f: Callable[[float], float], a: float, b: float, *, xtol: float = 1e-6,
                   maxiter: int = 200) -> float:
    """x in [a, b] with f(x) = 0 to within about ``xtol`` (the bracket width, or the last
    interpolation step once convergence is superlinear), given f(a)·f(b) ≤ 0 (ValueError if
    not)."""
    fa, fb = f(a), f(b)
    if fa == 0:
        return a
    if fb == 0:
        return b
    if fa * fb > 0:
        raise ValueError("f(a) and f(b) must have different signs")
    for _ in range(maxiter):
        width = abs(b - a)
        if width <= 2 * xtol:
            break
        c = (a * fb - b * fa) / (fb - fa)
        if not (min(a, b) < c < max(a, b)) or not math.isfinite(c):
            c = 0.5 * (a + b)
        fc = f(c)
        if fc == 0:
            return c
        if abs(c - b) < 0.5 * xtol:  # converged: the interpolation step is below the tolerance
            return c
        if fc * fb < 0:  # the root lies between c and b: a ← b
            a, fa = b, fb
        else:  # a is kept again: halve its value (Illinois)
            fa *= 0.5
        b, fb = c, fc
        if abs(b - a) > 0.5 * width:  # slow progress: bisect
            m = 0.5 * (a + b)
            fm = f(m)
            if fm == 0:
                return m
            if fm * fb < 0:
                a, fa = m, fm
            else:
                b, fb = m, fm
    return 0.5 * (a + b)
