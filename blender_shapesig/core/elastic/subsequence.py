"""The elastic distance with a free start and end on the long curve (the open-begin/open-end, or subsequence, DP):
where in R1 does R0 occur? The pinned recursion of ``elastic`` with a zero first row and the minimum read over the
last row; the path's first and last columns name the window. Numba and numpy kernels share the floating-point
contract of ``_dp_kernels`` (no penalty term); ``path_costs`` splits a path's energy exactly into (query interval
x joint) pieces for ``explain``. Derivation in docs/elastic.md, "Implementation notes".
"""

from dataclasses import dataclass

import numpy as np

from . import _dp_kernels
from .elastic import (_check_depth, _check_method, _entry_coefficients, _srvt_matrix, _window_sums, step_entries,
                      step_table)
from ..errors import CurveError
from . import DEFAULT_DEPTH

__all__ = ["Subsequence", "subsequence_align", "subsequence_dp_numpy", "subsequence_dp_numba", "path_costs"]

# Largest DP grid (nodes) one call may build (G, A and the back-pointers: 26 bytes a node).
MAX_NODES = 60_000_000


@dataclass
class Subsequence:
    """The best match of R0 inside R1: frames ``start``..``end`` of R1 (inclusive), ``distance`` = sqrt(energy),
    ``nodes`` the DP path (count, 2) of (frame of R0, frame of R1) from (0, start) to (frames0-1, end)."""

    start: int
    end: int
    distance: float
    energy: float
    nodes: np.ndarray


def _chunk(vals):
    """The canonical sum of 1..4 terms (the contract of ``_dp_kernels``): v1, v1 + v2, (v1 + v2) + v3,
    (v1 + v2) + (v3 + v4)."""
    c = vals[0]
    if len(vals) >= 2:
        c = c + vals[1]
    if len(vals) == 3:
        c = c + vals[2]
    elif len(vals) == 4:
        c = c + (vals[2] + vals[3])
    return c


def subsequence_dp_numpy(G, B0, B1, di, dj, start, ea, eb, coef):
    """The reference kernel: (A (n0+1, n1+1), back (n0+1, n1+1) step indices, -1 on row 0)."""
    n0, n1 = G.shape
    S = di.shape[0]
    A = np.full((n0 + 1, n1 + 1), np.inf)
    A[0] = 0.0
    back = np.full((n0 + 1, n1 + 1), -1, dtype=np.int32)
    cand = np.empty((S, n1 + 1))
    for i in range(1, n0 + 1):
        cand.fill(np.inf)
        for s in range(S):
            a, b = int(di[s]), int(dj[s])
            k = i - a
            if k < 0 or b > n1:
                continue
            m = n1 + 1 - b  # columns j = b..n1, l = j - b = 0..n1-b
            x = None
            for e in range(int(start[s]), int(start[s + 1]), 4):
                terms = [coef[f] * G[k + ea[f], eb[f]:eb[f] + m] for f in range(e, min(e + 4, int(start[s + 1])))]
                c = _chunk(terms)
                x = c if x is None else x + c
            cand[s, b:] = A[k, :m] + ((B0[a, i] + B1[b, b:]) - x)
        arg = np.argmin(cand, axis=0)
        A[i] = cand[arg, np.arange(n1 + 1)]
        back[i] = np.where(np.isfinite(A[i]), arg, -1)
    return A, back


if _dp_kernels.HAVE_NUMBA:
    _numba = _dp_kernels._numba

    @_numba.njit(cache=True, nogil=True)
    def _subsequence_numba(G, B0, B1, di, dj, start, ea, eb, coef):
        n0, n1 = G.shape
        S = di.shape[0]
        A = np.full((n0 + 1, n1 + 1), np.inf)
        back = np.full((n0 + 1, n1 + 1), -1, dtype=np.int32)
        for j in range(n1 + 1):
            A[0, j] = 0.0
        for i in range(1, n0 + 1):
            for j in range(n1 + 1):
                best = np.inf
                arg = -1
                for s in range(S):
                    a = di[s]
                    b = dj[s]
                    k = i - a
                    l = j - b
                    if k < 0 or l < 0:
                        continue
                    e = start[s]
                    eend = start[s + 1]
                    x = 0.0
                    first = True
                    while e < eend:
                        n = min(4, eend - e)  # one chunk, summed as _chunk does
                        c = coef[e] * G[k + ea[e], l + eb[e]]
                        if n >= 2:
                            c = c + coef[e + 1] * G[k + ea[e + 1], l + eb[e + 1]]
                        if n == 3:
                            c = c + coef[e + 2] * G[k + ea[e + 2], l + eb[e + 2]]
                        elif n == 4:
                            c = c + (coef[e + 2] * G[k + ea[e + 2], l + eb[e + 2]]
                                     + coef[e + 3] * G[k + ea[e + 3], l + eb[e + 3]])
                        if first:
                            x = c
                            first = False
                        else:
                            x = x + c
                        e += 4
                    cand = A[k, l] + ((B0[a, i] + B1[b, j]) - x)
                    if cand < best:
                        best = cand
                        arg = s
                A[i, j] = best
                back[i, j] = arg
        return A, back


def subsequence_dp_numba(G, B0, B1, di, dj, start, ea, eb, coef):
    """The numba kernel (same arguments and result as ``subsequence_dp_numpy``)."""
    if not _dp_kernels.HAVE_NUMBA:
        raise RuntimeError("numba is not available")
    return _subsequence_numba(np.ascontiguousarray(G, dtype=np.float64), B0, B1, di, dj, start, ea, eb, coef)


def _backtrack(back, di, dj, end):
    i, j = back.shape[0] - 1, int(end)
    nodes = [(i, j)]
    while i > 0:
        s = int(back[i, j])
        if s < 0:  # pragma: no cover - every node of a row >= 1 with j >= 1 has a predecessor
            raise RuntimeError("the subsequence DP path is broken")
        i, j = i - int(di[s]), j - int(dj[s])
        nodes.append((i, j))
    return np.array(nodes[::-1], dtype=np.int64)


def _problem(R0, R1, depth):
    """(Q0, Q1 on R0's spacing, h, step table, entry coefficients, B0, B1)."""
    Q0, j0 = _srvt_matrix(R0, "R0")
    Q1, j1 = _srvt_matrix(R1, "R1")
    if j0 != j1:
        raise CurveError(f"the curves have {j0} and {j1} joints")
    n0, n1 = Q0.shape[0], Q1.shape[0]
    if (n0 + 1) * (n1 + 1) > MAX_NODES:
        raise CurveError(f"the subsequence DP over {n0 + 1} x {n1 + 1} frames is too large; crop the long clip")
    Q1 = Q1 * np.sqrt(n0 / n1)  # the SRVT for R1's spacing h1 = h0 = 1 / n0 (see the module docstring)
    h = 1.0 / n0
    table = step_table(depth, max_di=n0, max_dj=n1)
    coef = _entry_coefficients(table, h, h)
    B0 = _window_sums(np.einsum("ij,ij->i", Q0, Q0) * h, int(table["di"].max()))
    B1 = _window_sums(np.einsum("ij,ij->i", Q1, Q1) * h, int(table["dj"].max()))
    return Q0, Q1, h, table, coef, B0, B1


def subsequence_align(R0, R1, depth=DEFAULT_DEPTH, *, method="auto") -> Subsequence:
    """The window of R1 (frames start..end) that R0 matches best under the elastic distance, and that distance.

    ``R0``: the short curve (all of it is matched), ``R1``: the long one, both on uniform grids of one frame
    rate (e.g. both prepared by ``core.clip.prepare``), the same joints, at least two frames each. ``depth``: the
    largest step D on either axis (not raised: windows whose length is beyond a slope of D are not
    considered). ``method``: 'auto', 'numba' or 'numpy' (identical results)."""
    depth = _check_depth(depth)
    method = _check_method(method)
    Q0, Q1, h, t, coef, B0, B1 = _problem(R0, R1, depth)
    G = _dp_kernels.gram(Q0, Q1)
    kernel = subsequence_dp_numba if method == "numba" else subsequence_dp_numpy
    A, back = kernel(G, B0, B1, t["di"], t["dj"], t["start"], t["ea"], t["eb"], coef)
    end = int(np.argmin(A[-1]))
    energy = float(A[-1, end])
    if not np.isfinite(energy):
        raise CurveError(f"no window of R1 matches R0 within a slope of {depth}; raise the depth")
    nodes = _backtrack(back, t["di"], t["dj"], end)
    return Subsequence(int(nodes[0, 1]), end, float(np.sqrt(max(energy, 0.0))), energy, nodes)


def path_costs(R0, R1, nodes, *, same_spacing=True):
    """The energy of a DP path split exactly into (query interval, joint) pieces, shape (frames0-1, joints).

    ``nodes``: a path (count, 2) of frame pairs, strictly increasing in both columns (from
    ``subsequence_align``, or ``elastic_align(..., return_info=True)["nodes"]``). ``same_spacing``: R1 has R0's
    spacing (the subsequence DP), else each curve runs over [0, 1] (the pinned DP). A step (k, l) -> (i, j)
    is cut at the merged breakpoints of both grids (``elastic.step_table``'s entries); a piece of length w in
    query interval a and interval b of R1 costs w |q0_a - sqrt(phi') q1_b|^2, summed per joint. The total is the
    DP energy up to rounding; every piece is >= 0."""
    Q0, _ = _srvt_matrix(R0, "R0")
    Q1, _ = _srvt_matrix(R1, "R1")
    n0, n1 = Q0.shape[0], Q1.shape[0]
    h0 = 1.0 / n0
    if same_spacing:
        Q1, h1 = Q1 * np.sqrt(n0 / n1), h0
    else:
        h1 = 1.0 / n1
    J = Q0.shape[1] // 3
    q0, q1 = Q0.reshape(n0, J, 3), Q1.reshape(n1, J, 3)
    nodes = np.asarray(nodes, dtype=np.int64)
    steps = np.diff(nodes, axis=0)
    if np.any(steps <= 0):
        raise CurveError("a DP path must increase strictly in both columns")
    entries = {}  # only the steps the path takes (a long clip against a short one: steps of up to e.g. 9 x 800)
    out = np.zeros((n0, J))
    for (k, l), (a, b) in zip(nodes[:-1], steps):
        key = (int(a), int(b))
        if key not in entries:
            entries[key] = step_entries(*key)
        ea, eb, ew = entries[key]
        ia, ib = k + ea, l + eb
        length = ew * h0 / b  # in units of curve 0's time
        rate = np.sqrt(b * h1 / (a * h0))     # sqrt(phi')
        diff = q0[ia] - rate * q1[ib]
        np.add.at(out, ia, length[:, None] * np.einsum("pjc,pjc->pj", diff, diff))
    return out
