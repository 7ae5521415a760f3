"""DP kernels for the elastic distance (see elastic.py for the maths).

Both kernels take the same arguments and return ``(value, back)``: the minimal energy at node
(n0, n1) and the step index chosen at every node (-1 where none). They evaluate every
candidate with the same floating-point expression, in the same order:

    cross = sum over the step's entries e (in table order) of coef[e] * G[k + ea[e], l + eb[e]]
    energy = (B0[di, i] + B1[dj, j]) - cross  [+ penalty term]
    candidate = A[k, l] + energy

and break ties by the first step in table order, so their results are identical.
``B0[d, i]`` is the integral of |q0|^2 over the d intervals before node i (summed locally, not
as a difference of cumulative sums, which would cost accuracy on long curves); ``B1`` likewise.

``dp_numba`` needs numba (JIT-compiled on first use, cached on disk, releases the GIL);
``HAVE_NUMBA`` says whether it can be imported. ``dp_numpy`` is pure numpy: energies for a
block of DP rows at once by shifted slices of G, then one vectorized min over all steps per row.
"""

import numpy as np

try:  # numba is optional: Blender's Python does not ship it
    import numba as _numba
except Exception:  # pragma: no cover - exercised by monkeypatching in the tests
    _numba = None

HAVE_NUMBA = _numba is not None

__all__ = ["HAVE_NUMBA", "dp_numpy", "dp_numba"]

# Bytes of energies held at once by the numpy kernel.
_BLOCK_BYTES = 8_000_000


def _penalty_terms(di, dj, h0, h1):
    """Per step: r (slope excess), P1 = di (di+1), P2 = di (di+1) (2 di+1) / 6 (floats).

    The penalty of a step from (k, l) is lam * sum_{m=1..di} (delta + m r)^2 with
    delta = l h1 - k h0, written as lam * ((di delta^2 + r P1 delta) + r^2 P2).
    """
    a = di.astype(np.float64)
    r = dj.astype(np.float64) * h1 / a - h0
    P1 = a * (a + 1.0)
    P2 = a * (a + 1.0) * (2.0 * a + 1.0) / 6.0
    return r, P1, P2


def dp_numpy(G, B0, B1, h0, h1, lam, di, dj, start, ea, eb, coef, lo, hi):
    n0, n1 = G.shape
    S = di.shape[0]
    D = int(max(di.max(), dj.max()))
    r, P1, P2 = _penalty_terms(di, dj, h0, h1)
    fdi = di.astype(np.float64)
    # Padded copies: index x of the original is x + D here; the pads are never on a path (A is
    # +inf there) and only keep the slices in range.
    A = np.full((n0 + 1 + D, n1 + 1 + D), np.inf)
    A[D, D] = 0.0
    Gp = np.zeros((n0 + D, n1 + D))
    Gp[D:, D:] = G
    back = np.full((n0 + 1, n1 + 1), -1, dtype=np.int16)
    cols = np.arange(n1 + 1)
    # For the gather of A[k, l]: rows i - di, columns j - dj (padded).
    col_idx = cols[None, :] - dj[:, None] + D
    b1 = B1[dj]  # (S, n1 + 1)
    step_ids = np.arange(S)
    block = max(1, _BLOCK_BYTES // (8 * S * (n1 + 1)))
    E = np.empty((S, block, n1 + 1))
    for r0 in range(1, n0 + 1, block):
        r1 = min(r0 + block, n0 + 1)
        nb = r1 - r0
        rows = np.arange(r0, r1)
        X = E[:, :nb]
        for s in range(S):
            a, b = int(di[s]), int(dj[s])
            xs = X[s]
            xs.fill(0.0)
            for e in range(start[s], start[s + 1]):
                ra = r0 - a + int(ea[e]) + D
                cb = D - b + int(eb[e])
                xs += coef[e] * Gp[ra:ra + nb, cb:cb + n1 + 1]
            b0 = B0[a, r0:r1]  # (nb,)
            # energy = ((b0 + b1) - cross) [+ penalty]
            np.subtract(b0[:, None] + b1[s][None, :], xs, out=xs)
            if lam != 0.0:
                delta = (cols[None, :] - b) * h1 - (rows[:, None] - a) * h0
                pen = (fdi[s] * delta * delta + r[s] * P1[s] * delta) + r[s] * r[s] * P2[s]
                xs += lam * pen
        for i in range(r0, r1):
            cand = A[(i - di + D)[:, None], col_idx] + X[:, i - r0]
            arg = np.argmin(cand, axis=0)
            best = cand[arg, cols]
            jl, jh = int(lo[i]), int(hi[i])
            A[i + D, D + jl:D + jh + 1] = best[jl:jh + 1]
            ok = np.isfinite(best[jl:jh + 1])
            back[i, jl:jh + 1] = np.where(ok, arg[jl:jh + 1], -1)
    del step_ids
    return float(A[n0 + D, n1 + D]), back


if HAVE_NUMBA:

    @_numba.njit(cache=True, nogil=True)
    def _dp_numba_kernel(G, B0, B1, h0, h1, lam, di, dj, start, ea, eb, coef, lo, hi,
                         rr, P1, P2):
        n0, n1 = G.shape
        S = di.shape[0]
        A = np.full((n0 + 1, n1 + 1), np.inf)
        A[0, 0] = 0.0
        back = np.full((n0 + 1, n1 + 1), -1, dtype=np.int16)
        cross = np.zeros(n1 + 1)
        best = np.empty(n1 + 1)
        arg = np.empty(n1 + 1, dtype=np.int16)
        for i in range(1, n0 + 1):
            jl = lo[i]
            jh = hi[i]
            for j in range(jl, jh + 1):
                best[j] = np.inf
                arg[j] = -1
            for s in range(S):
                a = di[s]
                b = dj[s]
                k = i - a
                if k < 0:
                    continue
                j0 = max(jl, lo[k] + b)
                j1 = min(jh, hi[k] + b)
                if j0 > j1:
                    continue
                # Slices and 0-based loops let LLVM vectorize (no negative-index wraparound).
                m = j1 + 1 - j0
                cr = cross[j0:j1 + 1]
                for t in range(m):
                    cr[t] = 0.0
                for e in range(start[s], start[s + 1]):
                    c = coef[e]
                    off = j0 + eb[e] - b
                    g = G[k + ea[e], off:off + m]
                    for t in range(m):
                        cr[t] += c * g[t]
                b0 = B0[a, i]
                Ak = A[k, j0 - b:j1 + 1 - b]
                B1a = B1[b, j0:j1 + 1]
                bs = best[j0:j1 + 1]
                ar = arg[j0:j1 + 1]
                ss = np.int16(s)
                if lam == 0.0:
                    for t in range(m):
                        cand = Ak[t] + ((b0 + B1a[t]) - cr[t])
                        if cand < bs[t]:
                            bs[t] = cand
                            ar[t] = ss
                else:
                    fa = np.float64(a)
                    r_s = rr[s]
                    p1 = P1[s]
                    p2 = P2[s]
                    for t in range(m):
                        en = (b0 + B1a[t]) - cr[t]
                        delta = (j0 + t - b) * h1 - (i - a) * h0
                        pen = (fa * delta * delta + r_s * p1 * delta) + r_s * r_s * p2
                        en += lam * pen
                        cand = Ak[t] + en
                        if cand < bs[t]:
                            bs[t] = cand
                            ar[t] = ss
            for j in range(jl, jh + 1):
                A[i, j] = best[j]
                back[i, j] = arg[j]
        return A[n0, n1], back


def dp_numba(G, B0, B1, h0, h1, lam, di, dj, start, ea, eb, coef, lo, hi):
    if not HAVE_NUMBA:
        raise RuntimeError("numba is not available")
    r, P1, P2 = _penalty_terms(di, dj, h0, h1)
    value, back = _dp_numba_kernel(
        np.ascontiguousarray(G, dtype=np.float64), B0, B1, float(h0), float(h1), float(lam),
        di, dj, start, ea, eb, coef, lo, hi, r, P1, P2,
    )
    return float(value), back
