"""The local search's second stage (``local.rerank``): dynamic time warping of two pose sequences with a
Sakoe-Chiba band and open ends (``dtw``), compiled by numba when numba is loaded already (``_kernel``), else by numpy
anti-diagonals (``_dtw_numpy``), and a shortlist's DTWs by numpy all at once (``_dtw_many``: the same numbers as one
at a time); ``subsequence_dtw``, the query against every window of a long take at once (the moments). Pure numpy
(numba optional); no bpy.
"""

import math
import sys
from typing import Optional

import numpy as np
from numpy.lib.stride_tricks import as_strided

__all__ = ["dtw", "subsequence_dtw"]

_COMPILED = []  # the compiled DTW kernel, once numba is loaded (``_kernel``)


def _dtw_numpy(a, b, band, free_a, free_b):
    """The DTW recursion by anti-diagonals (every cell of one depends on the two before): numpy, no compiler.
    Costs outside the band (``_outside_band``) are infinite."""
    n, m = len(a), len(b)
    C = ((a[:, None, :] - b[None, :, :]) ** 2).sum(-1)
    if band >= 0:
        C[_outside_band(n, m, band)] = np.inf
    D = np.full((n + 1, m + 1), np.inf)
    D[0, 0] = 0.0
    D[0, 1:free_b + 1] = 0.0  # open begin: the path may start after skipping up to free_b samples of b
    D[1:free_a + 1, 0] = 0.0
    for diag in range(2, n + m + 1):
        i = np.arange(max(1, diag - m), min(n, diag - 1) + 1)
        j = diag - i
        D[i, j] = C[i - 1, j - 1] + np.minimum(np.minimum(D[i - 1, j], D[i, j - 1]), D[i - 1, j - 1])
    return math.sqrt(min(D[n, m - free_b:].min(), D[n - free_a:, m].min()))


def _outside_band(n, m, band):
    """(n, m) True where a cell (row i + 1, column j + 1) is outside the Sakoe-Chiba band of ``band`` samples around
    the diagonal scaled to the lengths (the one band rule of both numpy DTWs; ``_dtw_loops`` computes it per row)."""
    rows = np.arange(n)
    lo = np.maximum(1, np.ceil(rows * m / n).astype(int) - band)
    hi = np.minimum(m, np.floor(rows * m / n).astype(int) + band + 1)
    j = np.arange(1, m + 1)
    return (j[None] < lo[:, None]) | (j[None] > hi[:, None])


def _dtw_many(a, bs, bands, fas, fbs):
    """(len(bs),) ``_dtw_numpy`` of ``a`` against each of ``bs`` (the same numbers), all at once: the recursion by
    anti-diagonals d = i + j run over every candidate together (one diagonal of all of them is a (K, n + 1) array
    by row i), so a shortlist costs about one numpy DTW, not one each. Costs outside a band are infinite; the
    skewed cost array is filled by a strided view (cell (i, j) of candidate k at [i + j, k, i])."""
    n, K = len(a), len(bs)
    ms = np.array([len(b) for b in bs])
    M = int(ms.max())
    S = K * (n + 1)  # one anti-diagonal d = i + j of every candidate: (K, n + 1) cells by row i
    Cs = np.full((n + M + 1, K, n + 1), np.inf)
    flat = Cs.reshape(-1)
    it = flat.itemsize
    for k, b in enumerate(bs):
        C = ((a[:, None, :] - b[None, :, :]) ** 2).sum(-1)
        if bands[k] >= 0:
            C[_outside_band(n, len(b), bands[k])] = np.inf
        as_strided(flat[2 * S + k * (n + 1) + 1:], shape=(n, len(b)), strides=((S + 1) * it, S * it))[...] = C
    prev2, prev, cur = (np.full((K, n + 1), np.inf) for _ in range(3))
    fas, fbs = np.asarray(fas), np.asarray(fbs)
    steps = np.arange(n + M + 1)[:, None]
    start_b = np.where(fbs[None] >= steps, 0.0, np.inf)  # D[0, d]: b's first d samples left out
    start_a = np.where(fas[None] >= steps, 0.0, np.inf)  # D[d, 0]
    row_n = np.full((n + M + 1, K), np.inf)  # D[n, d - n]
    col_m = np.full((n + M + 1, K), np.inf)  # D[d - m_k, m_k], where a's end may be left out
    ends = {}
    for k in range(K):
        for d in range(n + ms[k] - fas[k], n + ms[k] + 1):
            ends.setdefault(d, ([], []))
            ends[d][0].append(k), ends[d][1].append(d - ms[k])
    prev2[:, 0] = 0.0
    prev[:, 0], prev[:, 1] = start_b[1], start_a[1]
    tmp = np.empty((K, n + 1))
    for d in range(2, n + M + 1):
        lo, hi = max(1, d - M), min(n, d - 1)
        cur[:, 0] = start_b[d]
        if d <= n:
            cur[:, d] = start_a[d]
        t = tmp[:, :hi - lo + 1]
        np.minimum(prev[:, lo - 1:hi], prev[:, lo:hi + 1], out=t)
        np.minimum(t, prev2[:, lo - 1:hi], out=t)
        np.add(Cs[d, :, lo:hi + 1], t, out=cur[:, lo:hi + 1])
        if d >= n:
            row_n[d] = cur[:, n]
        if d in ends:
            ks, i = ends[d]
            col_m[d, ks] = cur[ks, i]
        prev2, prev, cur = prev, cur, prev2
    res = np.empty(K)
    for k in range(K):
        m = ms[k]
        res[k] = math.sqrt(min(row_n[n + m - fbs[k]:n + m + 1, k].min(), col_m[n + m - fas[k]:n + m + 1, k].min()))
    return res


def _dtw_loops(a, b, band, free_a, free_b):  # pragma: no cover - run compiled by numba (``_kernel``)
    n, m, d = a.shape[0], b.shape[0], a.shape[1]
    prev = np.full(m + 1, np.inf)
    cur = np.full(m + 1, np.inf)
    prev[0] = 0.0
    for j in range(1, free_b + 1):
        prev[j] = 0.0
    best_end = np.inf
    for i in range(1, n + 1):
        for j in range(m + 1):
            cur[j] = np.inf
        cur[0] = 0.0 if i <= free_a else np.inf
        if band >= 0:
            lo = max(1, int(math.ceil((i - 1) * m / n)) - band)
            hi = min(m, int(math.floor((i - 1) * m / n)) + band + 1)
        else:
            lo, hi = 1, m
        for j in range(lo, hi + 1):
            c = 0.0
            for k in range(d):
                t = a[i - 1, k] - b[j - 1, k]
                c += t * t
            best = prev[j - 1]
            if prev[j] < best:
                best = prev[j]
            if cur[j - 1] < best:
                best = cur[j - 1]
            cur[j] = c + best
        if i >= n - free_a and cur[m] < best_end:
            best_end = cur[m]
        if i == n:
            for j in range(m - free_b, m + 1):
                if cur[j] < best_end:
                    best_end = cur[j]
        prev, cur = cur, prev
    return math.sqrt(best_end)


def _kernel():
    """The compiled DTW when numba is loaded already (the elastic DP loads it; importing it for a few DTWs would
    cost a command-line query more than they take), else None: ``_dtw_numpy`` (equal to 1e-12)."""
    if not _COMPILED and "numba" in sys.modules:
        _COMPILED.append(sys.modules["numba"].njit(cache=True, nogil=True)(_dtw_loops))
    return _COMPILED[0] if _COMPILED else None


def kernel_ready() -> bool:
    """True when the compiled DTW has run in this process. Its first call loads numba's machinery and the kernel
    from the disk cache (0.3-0.7 s: most of a fresh Blender session's first Find Similar), so a shortlist
    (``local.rerank``, ~5 ms by numpy) uses it only once something else has paid that."""
    kernel = _kernel()
    return kernel is not None and bool(kernel.signatures)


def dtw(a, b, band: Optional[int] = None, free_a: int = 0, free_b: int = 0) -> float:
    """Dynamic time warping of two sequences (frames, channels): the square root of the least sum of squared
    Euclidean distances over warping paths (tslearn's and aeon's convention); ``band`` (samples, around the
    diagonal scaled to the lengths; None: no band) restricts the path (Sakoe-Chiba); ``free_a`` / ``free_b``: up to
    that many samples at either end of ``a`` / ``b`` may be left out (open begin and end: crops)."""
    a = np.ascontiguousarray(a, dtype=np.float64)
    b = np.ascontiguousarray(b, dtype=np.float64)
    bw = -1 if band is None else max(int(band), 1)
    fa, fb = max(0, min(int(free_a), len(a) - 1)), max(0, min(int(free_b), len(b) - 1))
    kernel = _kernel()
    return float(kernel(a, b, bw, fa, fb)) if kernel is not None else _dtw_numpy(a, b, bw, fa, fb)


def subsequence_dtw(a, b):
    """(cost (len(b),), start (len(b),)): for every end j of ``b``, the least sum of squared Euclidean distances
    over DTW paths of the whole of ``a`` against b[s..j], s free (open begin and end in ``b``), and that start s.
    One pass of len(a) numpy rows: a row's horizontal steps are a running minimum, D[i, j] = C[j] + min over
    k <= j of (min(D[i-1, k-1], D[i-1, k]) - C[k-1]), C the row's cumulative cost."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    n = len(b)
    at = np.arange(n)
    D = ((b - a[0]) ** 2).sum(axis=1)
    S = at.copy()
    for i in range(1, len(a)):
        cost = np.cumsum(((b - a[i]) ** 2).sum(axis=1))
        diag = np.concatenate([[np.inf], D[:-1]])
        take_diag = diag < D
        X = np.where(take_diag, diag, D)
        XS = np.where(take_diag, np.concatenate([[0], S[:-1]]), S)
        v = X - np.concatenate([[0.0], cost[:-1]])
        run = np.minimum.accumulate(v)
        where = np.maximum.accumulate(np.where(v <= run, at, 0))
        D, S = cost + run, XS[where]
    return D, S
