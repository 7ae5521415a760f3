"""The numpy kernel of the elastic DP: ``dp_numpy`` (pure numpy, vectorized per block of DP rows) takes the same
arguments as ``_dp_kernels.dp_numba``, returns ``(value, nodes)`` and evaluates every candidate with the same
floating-point expression in the same order (the penalty terms of ``_dp_kernels._penalty_terms``, the canonical sum
of chunks of four terms), so the two kernels' results are identical. The floating-point contract is in
docs/elastic.md, "Implementation notes".
"""

import numpy as np

from ._dp_kernels import _penalty_terms

__all__ = ["dp_numpy"]

# Bytes of energies held at once by the numpy kernel.
_BLOCK_BYTES = 8_000_000


def _chunk_value(vals):
    """The canonical sum of one chunk of 1..4 terms (arrays or floats)."""
    if len(vals) == 1:
        return vals[0]
    if len(vals) == 2:
        return vals[0] + vals[1]
    if len(vals) == 3:
        return (vals[0] + vals[1]) + vals[2]
    return (vals[0] + vals[1]) + (vals[2] + vals[3])


def dp_numpy(G, B0, B1, h0, h1, lam, di, dj, start, ea, eb, coef, lo, hi, want_path=True):
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
    back = np.full((n0 + 1, n1 + 1), -1, dtype=np.int16 if S < 32000 else np.int32)
    cols = np.arange(n1 + 1)
    col_idx = cols[None, :] - dj[:, None] + D  # for the gather of A[k, l], l = j - dj (padded)
    block = max(1, _BLOCK_BYTES // (8 * S * (n1 + 1)))
    E = np.empty((S, block, n1 + 1))
    for r0 in range(1, n0 + 1, block):
        r1 = min(r0 + block, n0 + 1)
        nb = r1 - r0
        rows = np.arange(r0, r1)
        for s in range(S):
            a, b = int(di[s]), int(dj[s])

            def g(e):
                ra = r0 - a + int(ea[e]) + D
                cb = D - b + int(eb[e])
                return coef[e] * Gp[ra:ra + nb, cb:cb + n1 + 1]

            def shifted(da, db):  # G[i - da, j - db] for the block's rows i and all columns j
                return Gp[r0 - da + D:r0 - da + D + nb, D - db:D - db + n1 + 1]

            x = None
            if lam != 0.0:
                delta = (cols[None, :] - b) * h1 - (rows[:, None] - a) * h0
                pen = (fdi[s] * delta * delta + r[s] * P1[s] * delta) + r[s] * r[s] * P2[s]
                x = -(lam * pen)
            if b == 1:  # thin steps (a, 1), a = 1, 2, ... in table order: G[i-1, j-1] + ... + G[i-a, j-1]
                col_run = shifted(1, 1) if a == 1 else col_run + shifted(a, 1)
                chunks = [coef[start[s]] * col_run]
            elif a == 1:  # thin steps (1, b), b = 2, 3, ...: G[i-1, j-1] + ... + G[i-1, j-b]
                row_run = (shifted(1, 1) if b == 2 else row_run) + shifted(1, b)
                chunks = [coef[start[s]] * row_run]
            else:
                chunks = (_chunk_value([g(f) for f in range(e, min(e + 4, int(start[s + 1])))])
                          for e in range(int(start[s]), int(start[s + 1]), 4))
            for chunk in chunks:
                x = chunk if x is None else x + chunk
            E[s, :nb] = (B0[a, r0:r1][:, None] + B1[b][None, :]) - x
        for i in range(r0, r1):
            cand = A[(i - di + D)[:, None], col_idx] + E[:, i - r0]
            jl, jh = int(lo[i]), int(hi[i])
            c = cand[:, jl:jh + 1]
            arg = np.argmin(c, axis=0)
            best = c[arg, np.arange(c.shape[1])]
            A[i + D, D + jl:D + jh + 1] = best
            back[i, jl:jh + 1] = np.where(np.isfinite(best), arg, -1)
    value = float(A[n0 + D, n1 + D])
    if not want_path:
        return value, None
    i, j = n0, n1
    nodes = [(i, j)]
    while i > 0 or j > 0:
        s = back[i, j]
        if s < 0:  # pragma: no cover - every band node is reachable
            raise RuntimeError("the DP path is broken")
        i, j = i - int(di[s]), j - int(dj[s])
        nodes.append((i, j))
    return value, np.array(nodes[::-1], dtype=np.int64)
