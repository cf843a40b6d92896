"""MTOTDEV kernel: Σ over subsequences of the squared MTOT differences, exact, O(N) per τ, in a
working set bounded by a fixed number of chunk buffers (pure numpy).

Definition (NIST SP1065, Riley 2008, "Handbook of Frequency Stability Analysis", eq. 27):
for every 3m-point subsequence x_n … x_{n+3m−1} of the angle (phase) series, remove the
half-average slope, extend it by even reflection to 9m points and take the 6m second
differences of its m-point averages. :func:`mtot_direct` does exactly that (O(N·m) per τ);
:func:`mtot_sum` rearranges the same sum into inner products of prefix sums over blocks of
B = 4m consecutive subsequences (see :func:`_mtot_products`), which is exact (the tests compare
the two to 1e-10) and O(N) per τ.

Memory: every prefix sum a block needs (C, Σ C·tᵏ, the stride-2 sums) is streamed along the
block in chunks of L positions by :class:`_Stream` cursors that resume from carries saved
every L positions, so nothing of the block's length is held. The working set is a few dozen
buffers of ``_budget(N)`` float64 elements (≈ N/64, between 4 Ki and 64 Ki elements):
≈ 0.1–0.8× the record at 10⁶–10⁷ points, and at most ≈ 25 MB whatever N
(benchmarks/bench_mtot_memory.py). The kernel makes many numpy calls on small buffers, so the
τ loop runs its τ values one at a time: on threads they contend for the GIL (measured: more
CPU time and more wall time than serial).
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from . import edf as _edf

__all__ = ["mtot_direct", "mtot_sum"]

_EPS3 = (-1.0, 3.0, -3.0, 1.0)  # A = F(j+3m) − 3F(j+2m) + 3F(j+m) − F(j): coefficients on F(j+tm)
_DIRECT_MAX_M = 1
#: subsequences per block = BLOCK_FACTOR·m (see :func:`mtot_sum`)
BLOCK_FACTOR = 4

#: Elements (rows × positions) of one chunk buffer; None = :func:`_budget` of the record length.
#: The tests set a small value to put chunk boundaries everywhere.
BATCH_ELEMS: int | None = None


#: optional ``hook(fraction)`` of the current τ's subsequences done (0 ≤ fraction < 1), called
#: at most every ``STEP_INTERVAL_S`` from the calling thread while one τ runs (the τ loop of
#: ``deviations._raw_variances`` sets it for the CLI's progress bar)
STEP: Callable[[float], None] | None = None
STEP_INTERVAL_S = 0.25


class _Steps:
    """Throttled calls of :data:`STEP` with the fraction of the n_sub subsequences done."""

    def __init__(self, n_sub: int):
        self.fn, self.n_sub, self.base, self.size = STEP, n_sub, 0, 0
        self.t, self.last = time.monotonic(), 0.0

    def batch(self, base: int, size: int) -> None:
        self.base, self.size = base, size

    def tick(self, frac: float) -> None:
        if self.fn is None:
            return
        now = time.monotonic()
        f = min(0.999, (self.base + frac * self.size) / self.n_sub)
        if now - self.t >= STEP_INTERVAL_S and f > self.last:  # strictly increasing
            self.t, self.last = now, f
            self.fn(f)


def _budget(n: int) -> int:
    """Elements per chunk buffer: ≈ N/64, between 4 Ki and 64 Ki (one τ at a time: the τ loop
    of ``deviations._raw_variances`` does not put MTOTDEV on threads)."""
    if BATCH_ELEMS is not None:
        return max(4, int(BATCH_ELEMS))
    return int(min(1 << 16, max(1 << 12, n // 64)))


def mtot_direct(v: np.ndarray, m: int) -> float:
    """Σ_n Σ_j A_j(n)² for MTOTDEV by the definition (SP1065 eq. 27), vectorised over the
    subsequence start n; O(N·m) per τ — used for m = 1, where it is the fastest."""
    N = v.size
    n_sub = N - 3 * m + 1
    h = (3 * m) // 2
    D = 3 * m - h
    total = 0.0
    step = max(1, _budget(N) // (9 * m + 1))
    jj = np.arange(6 * m)
    for n0 in range(0, n_sub, step):
        n1 = min(n_sub, n0 + step)
        idx = np.arange(n0, n1)[:, None] + np.arange(3 * m)[None, :]
        X = v[idx]
        X -= X[:, :1]  # constant shift per subsequence: MTOT is invariant to it
        s = (X[:, 3 * m - h :].mean(axis=1) - X[:, :h].mean(axis=1)) / D
        Z = X - s[:, None] * np.arange(3 * m)[None, :]
        ext = np.concatenate([Z[:, ::-1], Z, Z[:, ::-1]], axis=1)
        Cs = np.zeros((ext.shape[0], 9 * m + 1))
        np.cumsum(ext, axis=1, out=Cs[:, 1:])
        A = Cs[:, jj + 3 * m] - 3.0 * Cs[:, jj + 2 * m] + 3.0 * Cs[:, jj + m] - Cs[:, jj]
        total += float(np.sum(A * A))
    return total


def _block_terms(b: int, m: int):
    """Coefficients of A_j, j = b·m + r (r = 0 … m−1), in terms of the window's prefix sums.

    With S(a) = Σ_{i<a} z_i the prefix sums of the detrended subsequence z (3m points), the
    even-reflected 9m-point series has the cumulative sum F(p) = −S(3m − p) (p ≤ 3m),
    S(p − 3m) (3m ≤ p ≤ 6m), 2S(3m) − S(9m − p) (p ≥ 6m), and A_j = Σ_t ε_t F(j + t·m).
    Returns (fwd, bwd, c3, poly): A = Σ_a fwd[a]·D(a + r) + Σ_a bwd[a]·D(a − r) + c3·D(3m)
    + s·(p0 + p1 r + p2 r²), with D(a) the raw window sums and s the removed slope
    (S(a) = D(a) − s·a(a−1)/2).
    """
    fwd: dict[int, float] = {}
    bwd: dict[int, float] = {}
    c3 = 0.0
    p = np.zeros(3)

    def q_fwd(a: int) -> np.ndarray:  # a(a-1)/2 at a + r, as a polynomial in r
        return np.array([(a * a - a) / 2.0, (2 * a - 1) / 2.0, 0.5])

    def q_bwd(a: int) -> np.ndarray:  # at a - r
        return np.array([(a * a - a) / 2.0, (1 - 2 * a) / 2.0, 0.5])

    for t in range(4):
        k = b + t
        e = _EPS3[t]
        if k <= 2:  # F = -S((3-k)m - r)
            a = (3 - k) * m
            bwd[a] = bwd.get(a, 0.0) - e
            p += e * q_bwd(a)
        elif k <= 5:  # F = S((k-3)m + r)
            a = (k - 3) * m
            fwd[a] = fwd.get(a, 0.0) + e
            p -= e * q_fwd(a)
        else:  # F = 2S(3m) - S((9-k)m - r)
            a = (9 - k) * m
            c3 += 2.0 * e
            p[0] -= 2.0 * e * (3 * m) * (3 * m - 1) / 2.0
            bwd[a] = bwd.get(a, 0.0) - e
            p += e * q_bwd(a)
    return fwd, bwd, c3, p


# --- streamed prefix sums --------------------------------------------------------------------


class _Stream:
    """Prefix sums along a batch of ``nb`` blocks (rows) of Lx points each, served chunk-wise.

    For positions j of a block: X_j = θ_{start+j} − θ_start − (θ_{start+Lx−1} − θ_start)·j/(Lx−1)
    (0 past the block: MTOT is invariant to that straight line, and it keeps every quantity of
    the size of the local fluctuation), C_j = Σ_{i<j} X_i, P_k(j) = Σ_{i<j} C_i·iᵏ (k = 0, 1, 2)
    and the stride-2 sums E_j = Σ_{i<j, i ≡ j (mod 2)} C_i. The carries (C, P_k, E_j, E_{j+1})
    are saved every K ≈ L/4 positions in one first pass (one cumulative sum of X per stretch;
    the carries of P_k and E are dot products and sums); :meth:`run` rebuilds any range from a
    carry.
    """

    def __init__(self, v: np.ndarray, starts: np.ndarray, Lx: int, L: int):
        nb = starts.size
        step = int(starts[1] - starts[0]) if nb > 1 else 1
        self.rows = np.lib.stride_tricks.as_strided(
            v[int(starts[0]) :], shape=(nb, Lx), strides=(step * v.strides[0], v.strides[0]),
            writeable=False,
        )
        self.first = self.rows[:, 0].copy()
        self.rise = self.rows[:, Lx - 1] - self.first
        self.nb, self.Lx, self.L = nb, Lx, L
        self.end = Lx + 3  # positions 0 … Lx+2 are ever asked for
        self.whole = None
        zero = np.zeros(nb)
        state = (zero, (zero, zero, zero), zero, zero)
        if self.end <= L:  # one chunk: keep it whole (the small-m batches)
            self.whole = self.run(state, 0, self.end, True, True)
            return
        self.K = K = max(4, L // 4)
        n_ck = (self.end - 1) // K + 1
        self.ck = [state]
        for c in range(1, n_ck):
            self.ck.append(self._advance(self.ck[-1], (c - 1) * K, c * K))

    def _advance(self, state, p: int, q: int):
        """The carries at q from those at p."""
        c0, p0, e0, e1 = state
        X = self._x(p, q)
        C = np.empty_like(X)  # C at p … q−1
        C[:, 0] = c0
        np.cumsum(X[:, :-1], axis=1, out=C[:, 1:])
        C[:, 1:] += c0[:, None]
        t = np.arange(p, q, dtype=float)
        pk = (p0[0] + C.sum(axis=1), p0[1] + C @ t, p0[2] + C @ (t * t))
        ev, od = C[:, 0::2].sum(axis=1), C[:, 1::2].sum(axis=1)  # positions ≡ p, ≡ p + 1
        if (q - p) % 2 == 0:
            eq, eq1 = e0 + ev, e1 + od
        else:
            eq, eq1 = e1 + od, e0 + ev
        return (C[:, -1] + X[:, -1], pk, eq, eq1)

    @staticmethod
    def state_at(C, P, E, i: int):
        """Carries at offset i of a :meth:`run` result (needs offset i + 1 for E)."""
        return (C[:, i].copy(), tuple(P[k][:, i].copy() for k in range(3)) if P is not None else None,
                E[:, i].copy() if E is not None else None,
                E[:, i + 1].copy() if E is not None else None)

    def _x(self, p: int, q: int) -> np.ndarray:
        out = np.zeros((self.nb, q - p))
        e = min(q, self.Lx)
        if e > p:
            seg = out[:, : e - p]
            np.subtract(self.rows[:, p:e], self.first[:, None], out=seg)
            seg -= self.rise[:, None] * (np.arange(p, e) / (self.Lx - 1))
        return out

    def run(self, state, p: int, q: int, want_p: bool, want_e: bool):
        """C, P (three nb × n arrays, or None), E over positions [p, q) from the carries at p."""
        c0, p0, e0, e1 = state
        n = q - p
        C = np.empty((self.nb, n))
        C[:, 0] = c0
        if n > 1:
            np.cumsum(self._x(p, q - 1), axis=1, out=C[:, 1:])
            C[:, 1:] += c0[:, None]
        P = None
        if want_p:
            # three arrays, not one 3 × nb × n block: each stays under glibc's mmap threshold
            # (pinned at 1 MiB by gyrotest.io.stream), so buffers are reused instead of faulted in
            P = [np.empty((self.nb, n)) for _ in range(3)]
            t = np.arange(p, q - 1, dtype=float)
            for k in range(3):
                P[k][:, 0] = p0[k]
                if n > 1:
                    w = C[:, :-1] * t if k else C[:, :-1]
                    if k == 2:
                        w *= t
                    np.cumsum(w, axis=1, out=P[k][:, 1:])
                    P[k][:, 1:] += p0[k][:, None]
        E = None
        if want_e:
            E = np.empty((self.nb, n))
            for par, ep in ((0, e0), (1, e1)):
                Ev = E[:, par::2]
                k = Ev.shape[1]
                if k:
                    Ev[:, 0] = ep
                if k > 1:
                    np.cumsum(C[:, par::2][:, : k - 1], axis=1, out=Ev[:, 1:])
                    Ev[:, 1:] += ep[:, None]
        return C, P, E


class _Cursor:
    """Serves ranges [q0, q1) of a :class:`_Stream`, resuming from where the previous range
    ended when it moves forward (cost ≈ the range), else from the nearest saved carry."""

    def __init__(self, stream: _Stream):
        self.s = stream
        self.p = -1
        self.state = None

    def take(self, q0: int, q1: int, want_p: bool = False, want_e: bool = False):
        s = self.s
        if s.whole is not None:
            C, P, E = s.whole
            return (C[:, q0:q1], tuple(pk[:, q0:q1] for pk in P) if want_p else None,
                    E[:, q0:q1] if want_e else None)
        K = s.K
        st = self.state
        ok = (
            st is not None and self.p <= q0 and (q0 // K) * K <= self.p
            and (st[1] is not None or not want_p) and (st[2] is not None or not want_e)
        )
        if not ok:
            self.p = (q0 // K) * K
            st = s.ck[q0 // K]
        C, P, E = s.run(st, self.p, q1, want_p, want_e)
        r = q1 - 2 - self.p
        if r >= 0:
            self.state = s.state_at(C, P, E, r)
            base, self.p = self.p, q1 - 2
        else:
            self.state, base = st, self.p
        o = q0 - base
        return C[:, o:], (tuple(pk[:, o:] for pk in P) if want_p else None), (E[:, o:] if want_e else None)


def _mtot_products(v: np.ndarray, m: int, starts: np.ndarray, B: int, L: int,
                   steps: _Steps | None = None) -> dict:
    """The inner products of shifted prefix sums that Σ_{n,r} A² of a batch of blocks needs.

    Each block gets local prefix sums C of its own stretch of θ (minus the straight line
    through its end points — MTOT is invariant to that), so every quantity stays of the size
    of the local fluctuation. For each sixth b of the j range (j = b·m + r, r < m),
    A = U(n+r) + V(n−r) + W0(n) + s(n)·π(r), where U = Σ_a c_a·C[·+a] (a ∈ {0, m, 2m}) moves
    forward with r, V = Σ_a c'_a·C[·+a] (a ∈ {m, 2m, 3m}) backward, W0 = c3·C[n+3m] − c·C[n]
    and the removed slope s depend on n only, and π is quadratic in r (``_block_terms``).
    Σ_{n,r} A² is then a fixed quadratic form in a few dozen inner products of shifted C
    arrays: trapezoid-weighted ⟨C_a, C_a'⟩ (U², V²), boxcar and r^k-weighted window sums of C
    (U·W0, U·s·π), and stride-2 window sums (the anti-diagonal Σ_{n,r} U(n+r)·V(n−r)).

    All of them are sums over one index x (n ∈ [0, B) or u = n + r ∈ [0, B + m − 1)) of
    products of C or P_k at x plus a fixed offset, or of E at a position piecewise linear in
    x, so they are accumulated over chunks of L values of x, each cursor of the block's
    :class:`_Stream` moving forward in step.
    """
    Lx = B + 3 * m - 1
    h = (3 * m) // 2
    D = 3 * m - h
    W = B + m - 1  # u = n + r ∈ [0, W); i = n − r + m − 1 ∈ [0, W)
    stream = _Stream(v, starts, Lx, L)
    fwd_off = (0, m, 2 * m)
    bwd_off = (m, 2 * m, 3 * m)
    fs = (0, 3 * m)
    cur = {o: _Cursor(stream) for o in (0, m, 2 * m, 3 * m, h)}  # h ≤ 3m − h ≤ h + 1
    cur_e = {(b, side): _Cursor(stream) for b in bwd_off for side in (0, 1)}
    acc: dict = {}

    def add(key, val: float) -> None:
        acc[key] = acc.get(key, 0.0) + val

    one_row = starts.size == 1

    def dot(x: np.ndarray, y: np.ndarray, wgt: np.ndarray | None = None) -> float:
        if one_row:  # the streamed case: BLAS on the single row (≈ 5× einsum's speed)
            return float(np.dot(x[0] * wgt if wgt is not None else x[0], y[0]))
        if wgt is None:
            return float(np.einsum("ij,ij->", x, y))
        return float(np.einsum("ij,ij,j->", x, y, wgt))

    for x0 in range(0, W, L):
        x1 = min(W, x0 + L)
        nx = x1 - x0
        # C (and P where n-part) at x + o over the chunk: one take per cursor and chunk, so
        # every cursor moves forward only
        Cu, Pu = {}, {}
        for o in fwd_off:
            Cu[o], Pu[o], _ = cur[o].take(x0 + o, x1 + o + 1, want_p=x0 < B)
        # --- n-part: n ∈ [x0, x1') ---------------------------------------------------------
        if x0 < B:
            nn = min(x1, B) - x0
            Cn, Pn = dict(Cu), dict(Pu)
            Cn[3 * m], Pn[3 * m], _ = cur[3 * m].take(x0 + 3 * m, x0 + 3 * m + nn + 1, want_p=True)
            chd = cur[h].take(x0 + h, x0 + 3 * m - h + nn)[0]
            ch, cd = chd[:, :nn], chd[:, 3 * m - 2 * h : 3 * m - 2 * h + nn]
            CF = {0: Cn[0][:, :nn], 3 * m: Cn[3 * m][:, :nn]}
            s = ((CF[3 * m] - cd) - (ch - CF[0])) / (h * D)
            del ch, cd, chd
            nf = np.arange(x0, x0 + nn, dtype=float)
            for f in fs:
                for g in fs:
                    if f <= g:
                        add(("FF", f, g), dot(CF[f], CF[g]))
                add(("Fs", f), dot(CF[f], s))
            add("ss", dot(s, s))
            for a in fwd_off:  # G[a][k](n) = Σ_{r<m} r^k C[n + a + r]
                S0, S1, S2 = (Pn[a + m][k][:, :nn] - Pn[a][k][:, :nn] for k in range(3))
                base = nf + a
                G = (S0, S1 - base * S0, S2 - 2.0 * base * S1 + base * base * S0)
                for f in fs:
                    add(("FG", f, a), dot(CF[f], G[0]))
                for k in range(3):
                    add(("sG", a, k), dot(s, G[k]))
            for a in bwd_off:  # H[a][k](n) = Σ_{r<m} r^k C[n + a − r]
                S0, S1, S2 = (Pn[a][k][:, 1 : nn + 1] - Pn[a - m][k][:, 1 : nn + 1] for k in range(3))
                w = nf + a
                H = (S0, w * S0 - S1, w * w * S0 - 2.0 * w * S1 + S2)
                for f in fs:
                    add(("FH", f, a), dot(CF[f], H[0]))
                for k in range(3):
                    add(("sH", a, k), dot(s, H[k]))
            del Cn, Pn, CF, s, S0, S1, S2, G, H
        del Pu
        # --- u-part: u ∈ [x0, x1) ----------------------------------------------------------
        u = np.arange(x0, x1)
        cU = np.minimum(np.minimum(u + 1, m), np.minimum(B, B + m - 1 - u)).astype(float)
        vv = u - (m - 1)
        cV = (np.minimum(m - 1, B - 1 - vv) - np.maximum(0, -vv) + 1).astype(float)
        CA = {a: Cu[a][:, :nx] for a in fwd_off}
        CV = {a: Cu[a - m][:, 1 : nx + 1] for a in bwd_off}  # C[u + a − (m − 1)]
        for a in fwd_off:
            for b in fwd_off:
                if a <= b:
                    add(("UU", a, b), dot(CA[a], CA[b], cU))
        for a in bwd_off:
            for b in bwd_off:
                if a <= b:
                    add(("VV", a, b), dot(CV[a], CV[b], cV))
        # anti-diagonal: for each u, C[i + b − (m − 1)] summed over i = ilo, ilo+2, …, ihi
        ilo = 2 * np.maximum(0, u - m + 1) - u
        ihi = 2 * np.minimum(B - 1, u) - u + 2
        for b in bwd_off:
            win = None
            for side, pos in ((1, ihi + b), (0, ilo + b)):
                q0 = int(pos.min())
                E = cur_e[b, side].take(q0, int(pos.max()) + 1, want_e=True)[2]
                vals = E[:, pos - q0]
                win = vals if win is None else win - vals
            for a in fwd_off:
                add(("UW", a, b), dot(CA[a], win))
        if steps is not None:
            steps.tick(x1 / W)
    return acc


def _mtot_blocks(v: np.ndarray, m: int, starts: np.ndarray, B: int, L: int,
                 steps: _Steps | None = None) -> float:
    """Σ over subsequences n ∈ [start, start+B) of Σ_j A_j(n)², for a batch of blocks: the
    products of :func:`_mtot_products` combined with the coefficients of each sixth of the j
    range (``_block_terms``)."""
    acc = _mtot_products(v, m, starts, B, L, steps)
    fwd_off = (0, m, 2 * m)
    bwd_off = (m, 2 * m, 3 * m)
    fs = (0, 3 * m)

    def quad(tag: str, offs, c: dict) -> float:
        tot = 0.0
        for a in offs:
            for b in offs:
                if a <= b:
                    tot += (1.0 if a == b else 2.0) * c.get(a, 0.0) * c.get(b, 0.0) * acc[tag, a, b]
        return tot

    # Σ_r π(r) and Σ_r π(r)², π(r) = p0 + p1 r + p2 r², in chunks of r (no m-long array)
    chunk = max(1024, _budget(v.size))
    total = 0.0
    for b in range(6):
        fwd, bwd, c3, p = _block_terms(b, m)
        csum = sum(fwd.values()) + sum(bwd.values()) + c3
        cf = {0: -csum, 3 * m: c3}  # W0 = Σ_f cf[f]·C[n + f]
        s_pi = s_pi2 = 0.0
        for r0 in range(0, m, chunk):
            r = np.arange(r0, min(m, r0 + chunk), dtype=float)
            pir = p[0] + p[1] * r + p[2] * r * r
            s_pi += float(pir.sum())
            s_pi2 += _edf.blocked_dot(pir, pir)
        q = quad("UU", fwd_off, fwd) + quad("VV", bwd_off, bwd) + m * quad("FF", fs, cf)
        q += s_pi2 * acc["ss"]
        for f, cfv in cf.items():
            q += 2.0 * cfv * sum(c * acc["FG", f, a] for a, c in fwd.items())
            q += 2.0 * cfv * sum(c * acc["FH", f, a] for a, c in bwd.items())
            q += 2.0 * s_pi * cfv * acc["Fs", f]
        q += 2.0 * sum(c * sum(p[k] * acc["sG", a, k] for k in range(3)) for a, c in fwd.items())
        q += 2.0 * sum(c * sum(p[k] * acc["sH", a, k] for k in range(3)) for a, c in bwd.items())
        q += 2.0 * sum(ca * cb * acc["UW", a, bb] for a, ca in fwd.items() for bb, cb in bwd.items())
        total += q
    return total


def mtot_sum(v: np.ndarray, m: int) -> tuple[float, int]:
    """Σ over the N−3m+1 subsequences of Σ_{j<6m} A_j² for MTOTDEV (unscaled), and the count.

    MTOTDEV = sqrt(Σ / (12·m³·τ²·(N−3m+1))): each subsequence contributes (1/6m)Σ_j (A_j/m)²
    and SP1065 eq. 27 divides by 2τ²(N−3m+1).

    Complexity: O(N) per τ. The direct definition costs O(N·m) per τ (AllanTools: minutes for
    a few thousand points); here the sum over the 6m positions j of every subsequence is
    rearranged into prefix sums over blocks of B = 4m subsequences (see :func:`_mtot_products`),
    which is exact — the tests compare it with the direct definition to 1e-10. For m = 1 the
    vectorised direct sum is faster and is used instead. Blocks shorter than the chunk budget
    are batched (rows of one 2-D chunk); longer ones are streamed in chunks, so the working set
    is a few dozen chunk buffers whatever N and m (module docstring).
    """
    N = v.size
    n_sub = N - 3 * m + 1
    if n_sub <= 0:
        return 0.0, 0
    if m <= _DIRECT_MAX_M:
        return mtot_direct(v, m), n_sub
    budget = _budget(N)
    B = min(BLOCK_FACTOR * m, n_sub)
    n_full = n_sub // B
    rem = n_sub - n_full * B
    total = 0.0
    steps = _Steps(n_sub)

    def chunk_of(Bk: int, nb: int) -> int:  # positions per chunk for nb rows of Bk + 3m + 2
        return Bk + 3 * m + 2 if nb > 1 or Bk + 3 * m + 2 <= budget else budget

    if n_full:
        per_batch = max(1, budget // (B + 3 * m + 2))
        for i0 in range(0, n_full, per_batch):
            starts = np.arange(i0, min(n_full, i0 + per_batch), dtype=np.int64) * B
            steps.batch(i0 * B, starts.size * B)
            total += _mtot_blocks(v, m, starts, B, chunk_of(B, starts.size), steps)
    if rem:
        steps.batch(n_full * B, rem)
        total += _mtot_blocks(v, m, np.array([n_full * B], dtype=np.int64), rem, chunk_of(rem, 1),
                              steps)
    return total, n_sub
