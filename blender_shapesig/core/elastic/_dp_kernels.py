"""DP kernels of the elastic distance: ``dp_numba`` (JIT-compiled, cached, releases the GIL; ``HAVE_NUMBA`` says
whether it exists; ``threads=2`` splits a large band's columns over two threads: ``_dp_threads``), ``gram`` (the
Gram matrix of the DP's SRVT matrices) and the penalty terms both kernels share; the pure numpy kernel
``dp_numpy`` is in ``_dp_numpy``. Both kernels take the same arguments, return ``(value, nodes)`` and evaluate
every candidate with one floating-point expression in one order, so their results are identical. The maths is in
``elastic``; the floating-point contract is in docs/elastic.md, "Implementation notes".
"""

import numpy as np

from . import _workspace
from ._dp_threads import PARALLEL_MIN_NODES, ROW_BLOCK, column_split, dp_two_threads

try:  # numba is optional: Blender's Python does not ship it
    import numba as _numba
except Exception:  # pragma: no cover - exercised by monkeypatching in the tests
    _numba = None

HAVE_NUMBA = _numba is not None

__all__ = ["HAVE_NUMBA", "dp_numba", "gram"]


def _penalty_terms(di, dj, h0, h1):
    """Per step: r (slope excess), P1 = di (di+1), P2 = di (di+1) (2 di+1) / 6 (floats).

    The penalty of a step from (k, l) is lam * sum_{m=1..di} (d + m r)^2 with d = l h1 - k h0,
    written as lam * ((di d^2 + r P1 d) + r^2 P2).
    """
    a = di.astype(np.float64)
    r = dj.astype(np.float64) * h1 / a - h0
    P1 = a * (a + 1.0)
    P2 = a * (a + 1.0) * (2.0 * a + 1.0) / 6.0
    return r, P1, P2


if HAVE_NUMBA:

    @_numba.njit(cache=True, nogil=True, inline="always")
    def _term(G, k, o, m, ea, eb, coef, e):
        """Term ``e`` of a step over the m nodes from column offset o: its coefficient and its row of G."""
        return coef[e], G[k + ea[e], o + eb[e]:o + eb[e] + m]

    @_numba.njit(cache=True, nogil=True, inline="always")
    def _accumulate(cr, G, k, o, m, ea, eb, coef, e, assign):
        c1, g1 = _term(G, k, o, m, ea, eb, coef, e)
        c2, g2 = _term(G, k, o, m, ea, eb, coef, e + 1)
        c3, g3 = _term(G, k, o, m, ea, eb, coef, e + 2)
        c4, g4 = _term(G, k, o, m, ea, eb, coef, e + 3)
        if assign:
            for t in range(m):
                cr[t] = (c1 * g1[t] + c2 * g2[t]) + (c3 * g3[t] + c4 * g4[t])
        else:
            for t in range(m):
                cr[t] += (c1 * g1[t] + c2 * g2[t]) + (c3 * g3[t] + c4 * g4[t])

    @_numba.njit(cache=True, nogil=True, inline="always")
    def _thin_min(best, A, run, B1, k, b, j0, j1, b0, c, lam, fa, r_s, p1, p2, h0, h1):
        """The candidates of a thin step (di, 1) or (1, b) into the nodes j0..j1 of a row: x = P + c run[j]."""
        m = j1 + 1 - j0
        Ak = A[k, j0 - b:j1 + 1 - b]
        B1a = B1[b, j0:j1 + 1]
        bs = best[j0:j1 + 1]
        rt = run[j0:j1 + 1]
        if lam != 0.0:
            for t in range(m):
                delta = (j0 - b + t) * h1 - k * h0
                x = -(lam * ((fa * delta * delta + r_s * p1 * delta) + r_s * r_s * p2)) + c * rt[t]
                cand = Ak[t] + ((b0 + B1a[t]) - x)
                if cand < bs[t]:
                    bs[t] = cand
        else:
            for t in range(m):
                cand = Ak[t] + ((b0 + B1a[t]) - c * rt[t])
                if cand < bs[t]:
                    bs[t] = cand

    @_numba.njit(cache=True, nogil=True)
    def _thin_steps(A, G, B0, B1, h0, h1, lam, coef, start, lo, hi, rr, P1, P2, col_step, row_step, i, jl, jh,
                    col_run, row_run, best):
        """The thin steps into the nodes jl..jh of row i, from running sums (the module docstring): (a, 1) for
        a = 1, 2, ... with col_run[j] = G[i-1, j-1] + ... + G[i-a, j-1], then (1, b) for b = 2, 3, ... with
        row_run[j] = G[i-1, j-1] + ... + G[i-1, j-b]. One load of G per step and node instead of a or b."""
        js = max(jl, 1)
        n = jh + 1 - js
        cv = col_run[js:jh + 1]
        for a in range(1, col_step.shape[0]):
            s = col_step[a]
            k = i - a
            if s < 0 or k < 0:
                break
            g = G[k, js - 1:jh]
            if a == 1:
                for t in range(n):
                    cv[t] = g[t]
            else:
                for t in range(n):
                    cv[t] += g[t]
            j0 = max(jl, lo[k] + 1)
            j1 = min(jh, hi[k] + 1)
            if j0 <= j1:
                _thin_min(best, A, col_run, B1, k, 1, j0, j1, B0[a, i], coef[start[s]], lam, np.float64(a), rr[s],
                          P1[s], P2[s], h0, h1)
        k = i - 1
        rv = row_run[js:jh + 1]
        g = G[k, js - 1:jh]
        for t in range(n):
            rv[t] = g[t]
        for b in range(2, row_step.shape[0]):
            s = row_step[b]
            jb = max(jl, b)
            if s < 0 or jb > jh:
                break
            rb = row_run[jb:jh + 1]
            g = G[k, jb - b:jh + 1 - b]
            for t in range(jh + 1 - jb):
                rb[t] += g[t]
            j0 = max(jl, lo[k] + b)
            j1 = min(jh, hi[k] + b)
            if j0 <= j1:
                _thin_min(best, A, row_run, B1, k, b, j0, j1, B0[1, i], coef[start[s]], lam, 1.0, rr[s], P1[s],
                          P2[s], h0, h1)

    @_numba.njit(cache=True, nogil=True)
    def _dp_rows(A, G, B0, B1, h0, h1, lam, di, dj, start, ea, eb, coef, lo, hi, rr, P1, P2, col_step, row_step,
                 row0, row1, col0, col1):
        """A[i, j] for the rows row0 <= i < row1 and the columns col0 <= j <= col1 of the band; reads A[k, l] of earlier
        rows only (l < j), so column blocks of one row are independent (``dp_numba``'s two threads)."""
        n1 = G.shape[1]
        S = di.shape[0]
        cross = np.zeros(n1 + 1)
        col_run = np.empty(n1 + 1)
        row_run = np.empty(n1 + 1)
        for i in range(row0, row1):
            jl = max(lo[i], col0)
            jh = min(hi[i], col1)
            if jl > jh:
                continue
            best = A[i]  # +inf until this row is computed; the candidates only read earlier rows
            _thin_steps(A, G, B0, B1, h0, h1, lam, coef, start, lo, hi, rr, P1, P2, col_step, row_step, i, jl, jh,
                        col_run, row_run, best)
            for s in range(S):
                a = di[s]
                b = dj[s]
                k = i - a
                if k < 0 or a == 1 or b == 1:  # thin steps: done above
                    continue
                j0 = max(jl, lo[k] + b)
                j1 = min(jh, hi[k] + b)
                if j0 > j1:
                    continue
                # 0-based loops over slices: no negative-index wraparound, so LLVM vectorizes.
                m = j1 + 1 - j0
                o = j0 - b
                e = start[s]
                eend = start[s + 1]
                cr = cross[j0:j1 + 1]
                has_prev = False
                if lam != 0.0:
                    fa = np.float64(a)
                    r_s = rr[s]
                    p1 = P1[s]
                    p2 = P2[s]
                    for t in range(m):
                        delta = (o + t) * h1 - k * h0
                        pen = (fa * delta * delta + r_s * p1 * delta) + r_s * r_s * p2
                        cr[t] = -(lam * pen)
                    has_prev = True
                while eend - e > 4:
                    _accumulate(cr, G, k, o, m, ea, eb, coef, e, not has_prev)
                    has_prev = True
                    e += 4
                b0 = B0[a, i]
                Ak = A[k, o:o + m]
                B1a = B1[b, j0:j1 + 1]
                bs = best[j0:j1 + 1]
                r = eend - e
                c1, g1 = _term(G, k, o, m, ea, eb, coef, e)
                if r == 1:
                    if has_prev:
                        for t in range(m):
                            cand = Ak[t] + ((b0 + B1a[t]) - (cr[t] + c1 * g1[t]))
                            if cand < bs[t]:
                                bs[t] = cand
                    else:
                        for t in range(m):
                            cand = Ak[t] + ((b0 + B1a[t]) - (c1 * g1[t]))
                            if cand < bs[t]:
                                bs[t] = cand
                elif r == 2:
                    c2, g2 = _term(G, k, o, m, ea, eb, coef, e + 1)
                    if has_prev:
                        for t in range(m):
                            cand = Ak[t] + ((b0 + B1a[t]) - (cr[t] + (c1 * g1[t] + c2 * g2[t])))
                            if cand < bs[t]:
                                bs[t] = cand
                    else:
                        for t in range(m):
                            cand = Ak[t] + ((b0 + B1a[t]) - ((c1 * g1[t] + c2 * g2[t])))
                            if cand < bs[t]:
                                bs[t] = cand
                elif r == 3:
                    c2, g2 = _term(G, k, o, m, ea, eb, coef, e + 1)
                    c3, g3 = _term(G, k, o, m, ea, eb, coef, e + 2)
                    if has_prev:
                        for t in range(m):
                            cand = Ak[t] + ((b0 + B1a[t]) - (cr[t] + ((c1 * g1[t] + c2 * g2[t]) + c3 * g3[t])))
                            if cand < bs[t]:
                                bs[t] = cand
                    else:
                        for t in range(m):
                            cand = Ak[t] + ((b0 + B1a[t]) - (((c1 * g1[t] + c2 * g2[t]) + c3 * g3[t])))
                            if cand < bs[t]:
                                bs[t] = cand
                elif r == 4:
                    c2, g2 = _term(G, k, o, m, ea, eb, coef, e + 1)
                    c3, g3 = _term(G, k, o, m, ea, eb, coef, e + 2)
                    c4, g4 = _term(G, k, o, m, ea, eb, coef, e + 3)
                    if has_prev:
                        for t in range(m):
                            cand = Ak[t] + ((b0 + B1a[t]) - (cr[t] + ((c1 * g1[t] + c2 * g2[t]) + (c3 * g3[t] + c4 * g4[t]))))
                            if cand < bs[t]:
                                bs[t] = cand
                    else:
                        for t in range(m):
                            cand = Ak[t] + ((b0 + B1a[t]) - (((c1 * g1[t] + c2 * g2[t]) + (c3 * g3[t] + c4 * g4[t]))))
                            if cand < bs[t]:
                                bs[t] = cand

    @_numba.njit(cache=True, nogil=True)
    def _gram_numba(Q0, Q1T, G):
        """G = Q0 Q1^T (Q0 with a multiple of four rows), each entry summed as ((x0 q0 + x1 q1) + (x2 q2 + x3 q3))
        per group of four columns, then the rest one by one. Four rows of G per pass, so that each value of Q1^T
        loaded serves all four; indexed as 2-D arrays, not as row slices (LLVM then vectorizes the loop over b
        without runtime alias checks between six row pointers: 0.38 instead of 0.67 ms at 299 x 93 x 299)."""
        n0, c = Q0.shape
        n1 = Q1T.shape[1]
        G[:, :] = 0.0
        c4 = c - c % 4
        for a in range(0, n0 - 3, 4):
            for r in range(0, c4, 4):
                x0, x1, x2, x3 = Q0[a, r], Q0[a, r + 1], Q0[a, r + 2], Q0[a, r + 3]
                y0, y1, y2, y3 = Q0[a + 1, r], Q0[a + 1, r + 1], Q0[a + 1, r + 2], Q0[a + 1, r + 3]
                u0, u1, u2, u3 = Q0[a + 2, r], Q0[a + 2, r + 1], Q0[a + 2, r + 2], Q0[a + 2, r + 3]
                v0, v1, v2, v3 = Q0[a + 3, r], Q0[a + 3, r + 1], Q0[a + 3, r + 2], Q0[a + 3, r + 3]
                for b in range(n1):
                    q0, q1, q2, q3 = Q1T[r, b], Q1T[r + 1, b], Q1T[r + 2, b], Q1T[r + 3, b]
                    G[a, b] += (x0 * q0 + x1 * q1) + (x2 * q2 + x3 * q3)
                    G[a + 1, b] += (y0 * q0 + y1 * q1) + (y2 * q2 + y3 * q3)
                    G[a + 2, b] += (u0 * q0 + u1 * q1) + (u2 * q2 + u3 * q3)
                    G[a + 3, b] += (v0 * q0 + v1 * q1) + (v2 * q2 + v3 * q3)
            for r in range(c4, c):
                x, y, u, v = Q0[a, r], Q0[a + 1, r], Q0[a + 2, r], Q0[a + 3, r]
                for b in range(n1):
                    q = Q1T[r, b]
                    G[a, b] += x * q
                    G[a + 1, b] += y * q
                    G[a + 2, b] += u * q
                    G[a + 3, b] += v * q

    @_numba.njit(cache=True, nogil=True)
    def _candidate(A, G, B0, B1, h0, h1, lam, di, dj, start, ea, eb, coef, rr, P1, P2, i, j, s):
        """The DP candidate of step s into node (i, j), exactly as _dp_rows computes it."""
        a = di[s]
        b = dj[s]
        k = i - a
        l = j - b
        e = start[s]
        eend = start[s + 1]
        x = 0.0
        has_prev = False
        if lam != 0.0:
            delta = l * h1 - k * h0
            pen = (np.float64(a) * delta * delta + rr[s] * P1[s] * delta) + rr[s] * rr[s] * P2[s]
            x = -(lam * pen)
            has_prev = True
        if a == 1 or b == 1:  # a thin step: the running sum of its column or row, times its one coefficient
            run = G[i - 1, j - 1]
            for d in range(2, max(a, b) + 1):
                run += G[i - d, j - 1] if b == 1 else G[i - 1, j - d]
            c = coef[e] * run
            x = x + c if has_prev else c
            e = eend
        while e < eend:
            n = min(4, eend - e)
            v1 = coef[e] * G[k + ea[e], l + eb[e]]
            if n == 1:
                c = v1
            else:
                v2 = coef[e + 1] * G[k + ea[e + 1], l + eb[e + 1]]
                if n == 2:
                    c = v1 + v2
                else:
                    v3 = coef[e + 2] * G[k + ea[e + 2], l + eb[e + 2]]
                    if n == 3:
                        c = (v1 + v2) + v3
                    else:
                        v4 = coef[e + 3] * G[k + ea[e + 3], l + eb[e + 3]]
                        c = (v1 + v2) + (v3 + v4)
            if has_prev:
                x = x + c
            else:
                x = c
                has_prev = True
            e += 4
        return A[k, l] + ((B0[a, i] + B1[b, j]) - x)

    @_numba.njit(cache=True, nogil=True)
    def _dp_path(A, G, B0, B1, h0, h1, lam, di, dj, start, ea, eb, coef, rr, P1, P2):
        n0, n1 = G.shape
        out = np.empty((n0 + 1, 2), dtype=np.int64)
        count = 0
        i = n0
        j = n1
        out[0, 0] = i
        out[0, 1] = j
        count = 1
        while i > 0 or j > 0:
            target = A[i, j]
            found = -1
            for s in range(di.shape[0]):
                if di[s] > i or dj[s] > j:
                    continue
                if A[i - di[s], j - dj[s]] == np.inf:
                    continue
                if _candidate(A, G, B0, B1, h0, h1, lam, di, dj, start, ea, eb, coef, rr, P1, P2,
                              i, j, s) == target:
                    found = s
                    break
            if found < 0:
                return out[:0]
            i -= di[found]
            j -= dj[found]
            out[count, 0] = i
            out[count, 1] = j
            count += 1
        return out[:count][::-1].copy()


def gram(Q0, Q1, work=False):
    """G = Q0 Q1^T (inner products of all pairs of rows).

    With numba: a single-threaded loop that releases the GIL (BLAS would start its own threads
    inside every worker thread of elastic_distance_matrix); without it: numpy's matmul. ``work``: G and
    the kernel's inputs in this thread's reused arrays (``_workspace``), for a G that does not outlive the call.
    """
    if not HAVE_NUMBA:
        return Q0 @ Q1.T
    n0, c = Q0.shape
    n1 = Q1.shape[0]
    rows = n0 + (-n0) % 4  # zero rows to group the last ones with (rows are computed independently)
    Q0p = _workspace.array("gram_Q0", (rows, c), work)
    Q0p[:n0] = Q0
    Q0p[n0:] = 0.0
    Q1T = _workspace.array("gram_Q1T", (c, n1), work)
    Q1T[:] = Q1.T
    G = _workspace.array("G", (rows, n1), work)
    _gram_numba(Q0p, Q1T, G)
    return G[:n0]


def _thin_index(di, dj):
    """Table indices of the thin steps: col_step[a] of (a, 1), row_step[b] of (1, b) (-1: none); once per table."""
    return _workspace.memo(("thin", di.tobytes(), dj.tobytes()), lambda: _make_thin_index(di, dj))


def _make_thin_index(di, dj):
    col_step = np.full(int(di.max()) + 1, -1, dtype=np.int64)
    row_step = np.full(int(dj.max()) + 1, -1, dtype=np.int64)
    for s in np.flatnonzero(dj == 1):
        col_step[di[s]] = s
    for s in np.flatnonzero(di == 1):
        row_step[dj[s]] = s
    return col_step, row_step


def dp_numba(G, B0, B1, h0, h1, lam, di, dj, start, ea, eb, coef, lo, hi, want_path=True, threads=1, work=False):
    """``threads`` = 2: the rows' column halves on two threads (``_dp_threads.dp_two_threads``) when the band has at
    least ``PARALLEL_MIN_NODES`` nodes; the result is the same bit for bit. ``work``: the DP values in this thread's
    reused array (``_workspace``)."""
    if not HAVE_NUMBA:
        raise RuntimeError("numba is not available")
    r, P1, P2 = _penalty_terms(di, dj, h0, h1)
    G = np.ascontiguousarray(G, dtype=np.float64)
    h0, h1, lam = float(h0), float(h1), float(lam)
    n0, n1 = G.shape
    A = _workspace.array("A", (n0 + 1, n1 + 1), work)
    A.fill(np.inf)
    A[0, 0] = 0.0
    col_step, row_step = _thin_index(di, dj)
    args = (G, B0, B1, h0, h1, lam, di, dj, start, ea, eb, coef, lo, hi, r, P1, P2, col_step, row_step)
    nodes = int(np.sum(hi - lo + 1))
    split = column_split(lo, hi, n1) if threads > 1 and nodes >= PARALLEL_MIN_NODES and n0 > ROW_BLOCK else 0
    if 0 < split <= n1:
        dp_two_threads(_dp_rows, A, args, n0, n1, split)
    else:
        _dp_rows(A, *args, 1, n0 + 1, 0, n1)
    value = float(A[-1, -1])
    if not want_path:
        return value, None
    nodes = _dp_path(A, G, B0, B1, h0, h1, lam, di, dj, start, ea, eb, coef, r, P1, P2)
    if nodes.shape[0] == 0:  # pragma: no cover - the candidates are re-evaluated bit for bit
        raise RuntimeError("the DP path could not be recovered")
    return value, nodes
