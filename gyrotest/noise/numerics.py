"""The small solvers of the noise fit in numpy, so that ``allan`` never imports
scipy.optimize (≈ 0.15 s of start-up on every run).

:func:`nnls` — non-negative least squares, min ‖Ax − b‖ subject to x ≥ 0: the active-set
algorithm of Lawson & Hanson ("Solving Least Squares Problems", Prentice-Hall
1974, ch. 23): variables enter the passive set one at a time by the largest gradient
component, and an infeasible unconstrained step is cut back to the feasible boundary. For a
matrix of full column rank the solution is unique, so it equals ``scipy.optimize.nnls`` to
rounding (checked in the tests).

:func:`root_bracketed` — a root of a continuous function inside a sign-changing bracket by the
Illinois variant of regula falsi (Dowell & Jarratt, BIT 11, 1971), with a bisection step
whenever the bracket shrinks too slowly, to an absolute tolerance.

:func:`minimize_bounded` — a minimum of a function of one variable on [a, b]: Brent's method
(golden-section steps with parabolic interpolation; R. P. Brent, "Algorithms for Minimization
without Derivatives", Prentice-Hall 1973, ch. 5; the FMIN routine of Forsythe, Malcolm & Moler,
"Computer Methods for Mathematical Computations", 1977), with the step rules, tolerances and
stopping test of ``scipy.optimize.minimize_scalar(method="bounded")`` — the same iterates,
so the same minimum to the last bit (checked in the tests).

:func:`nelder_mead` — the downhill simplex method of Nelder & Mead ("A simplex method for
function minimization", The Computer Journal 7, 1965) with the standard coefficients
(reflection 1, expansion 2, contraction ½, shrink ½), the initial simplex, ordering and
stopping test (x and f spreads ≤ xatol, fatol) of ``scipy.optimize.minimize(method=
"Nelder-Mead")`` — again the same iterates (tested).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

__all__ = ["minimize_bounded", "nelder_mead", "nnls", "root_bracketed"]


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


def minimize_bounded(f: Callable[[float], float], a: float, b: float, *, xatol: float = 1e-5,
                     maxiter: int = 500) -> tuple[float, float]:
    """(x, f(x)) minimising f on [a, b] by Brent's bounded method (module docstring)."""
    sqrt_eps = math.sqrt(2.2e-16)
    golden_mean = 0.5 * (3.0 - math.sqrt(5.0))
    fulc = a + golden_mean * (b - a)
    nfc = xf = fulc
    rat = e = 0.0
    fx = f(xf)
    num = 1
    ffulc = fnfc = fx
    xm = 0.5 * (a + b)
    tol1 = sqrt_eps * abs(xf) + xatol / 3.0
    tol2 = 2.0 * tol1
    while abs(xf - xm) > (tol2 - 0.5 * (b - a)):
        golden = True
        if abs(e) > tol1:  # try a parabola through the three best points
            golden = False
            r = (xf - nfc) * (fx - ffulc)
            q = (xf - fulc) * (fx - fnfc)
            p = (xf - fulc) * q - (xf - nfc) * r
            q = 2.0 * (q - r)
            if q > 0.0:
                p = -p
            q = abs(q)
            r = e
            e = rat
            if abs(p) < abs(0.5 * q * r) and p > q * (a - xf) and p < q * (b - xf):
                rat = (p + 0.0) / q
                x = xf + rat
                if (x - a) < tol2 or (b - x) < tol2:
                    rat = tol1 * (1.0 if xm - xf >= 0 else -1.0)
            else:
                golden = True
        if golden:
            e = (a - xf) if xf >= xm else (b - xf)
            rat = golden_mean * e
        x = xf + (1.0 if rat >= 0 else -1.0) * max(abs(rat), tol1)
        fu = f(x)
        num += 1
        if fu <= fx:
            if x >= xf:
                a = xf
            else:
                b = xf
            fulc, ffulc = nfc, fnfc
            nfc, fnfc = xf, fx
            xf, fx = x, fu
        else:
            if x < xf:
                a = x
            else:
                b = x
            if fu <= fnfc or nfc == xf:
                fulc, ffulc = nfc, fnfc
                nfc, fnfc = x, fu
            elif fu <= ffulc or fulc == xf or fulc == nfc:
                fulc, ffulc = x, fu
        xm = 0.5 * (a + b)
        tol1 = sqrt_eps * abs(xf) + xatol / 3.0
        tol2 = 2.0 * tol1
        if num >= maxiter:
            break
    return xf, fx


def nelder_mead(f: Callable[[np.ndarray], float], x0, *, xatol: float = 1e-4,
                fatol: float = 1e-4, maxiter: int | None = None) -> tuple[np.ndarray, float]:
    """(x, f(x)) of the best simplex vertex by the Nelder–Mead method (module docstring);
    ``maxiter`` iterations at most (default 200 per variable)."""
    x0 = np.asarray(x0, dtype=np.float64).ravel()
    N = x0.size
    if maxiter is None:
        maxiter = 200 * N
    rho, chi, psi, sigma = 1.0, 2.0, 0.5, 0.5
    sim = np.empty((N + 1, N))
    sim[0] = x0
    for k in range(N):
        y = x0.copy()
        y[k] = (1 + 0.05) * y[k] if y[k] != 0 else 0.00025
        sim[k + 1] = y

    def fv(x: np.ndarray) -> float:
        return float(f(x.copy()))

    fsim = np.array([fv(sim[k]) for k in range(N + 1)])
    ind = np.argsort(fsim)
    sim, fsim = np.take(sim, ind, 0), np.take(fsim, ind, 0)
    iterations = 1
    while iterations < maxiter:
        if np.max(np.ravel(np.abs(sim[1:] - sim[0]))) <= xatol and np.max(np.abs(fsim[0] - fsim[1:])) <= fatol:
            break
        xbar = np.add.reduce(sim[:-1], 0) / N
        xr = (1 + rho) * xbar - rho * sim[-1]
        fxr = fv(xr)
        shrink = False
        if fxr < fsim[0]:
            xe = (1 + rho * chi) * xbar - rho * chi * sim[-1]
            fxe = fv(xe)
            if fxe < fxr:
                sim[-1], fsim[-1] = xe, fxe
            else:
                sim[-1], fsim[-1] = xr, fxr
        elif fxr < fsim[-2]:
            sim[-1], fsim[-1] = xr, fxr
        elif fxr < fsim[-1]:  # outside contraction
            xc = (1 + psi * rho) * xbar - psi * rho * sim[-1]
            fxc = fv(xc)
            if fxc <= fxr:
                sim[-1], fsim[-1] = xc, fxc
            else:
                shrink = True
        else:  # inside contraction
            xcc = (1 - psi) * xbar + psi * sim[-1]
            fxcc = fv(xcc)
            if fxcc < fsim[-1]:
                sim[-1], fsim[-1] = xcc, fxcc
            else:
                shrink = True
        if shrink:
            for j in range(1, N + 1):
                sim[j] = sim[0] + sigma * (sim[j] - sim[0])
                fsim[j] = fv(sim[j])
        iterations += 1
        ind = np.argsort(fsim)
        sim, fsim = np.take(sim, ind, 0), np.take(fsim, ind, 0)
    return sim[0], float(np.min(fsim))
