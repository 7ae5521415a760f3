"""Elastic shape distance d_S* (reference secs. 4.3, 6.2): ``elastic_align`` / ``elastic_distance`` find the best
piecewise-linear warp phi of curve 1 onto curve 0 by a dynamic programme on the grid of frame pairs, with the
exact energy of eq. 4.8 per step, pinned ends, pruned non-coprime steps and an automatic slope limit
(``step_table``, ``required_depth``); also ``elastic_distance_matrix`` (the warps' ``check_warp``, ``reparametrize``
and ``warp_grid`` are owned by ``warps``). Curves must be sampled uniformly. ``method`` picks the numba kernel of
``_dp_kernels`` or the numpy one of ``_dp_numpy`` (identical results). See docs/elastic.md.
"""

import math
import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from . import _dp_kernels, _dp_numpy, _srvt_kernel
from ..geometry import curves
from ._workspace import memo as _memo
from ..geometry.curves import as_curve, as_times, srvt
from ..errors import CurveError, ShapeSigError, check_integer, check_number
from ..progress import Counter
from . import DEFAULT_DEPTH
from .warps import check_warp, reparametrize, warp_grid

__all__ = [
    "check_warp",
    "elastic_align",
    "elastic_distance",
    "elastic_distance_matrix",
    "reparametrize",
    "warp_grid",
    "step_table",
    "step_entries",
    "required_depth",
    "dp_problem",
]

METHODS = ("auto", "numba", "numpy")


# ---------------------------------------------------------------------------------------------
# input preparation


def _check_depth(depth):
    return check_integer(depth, "depth", minimum=1)


def _check_penalty(penalty):
    return check_number(penalty, "penalty", 0.0)


def _check_method(method):
    if method not in METHODS:
        raise ShapeSigError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    if method == "auto":
        return "numba" if _dp_kernels.HAVE_NUMBA else "numpy"
    if method == "numba" and not _dp_kernels.HAVE_NUMBA:
        raise ShapeSigError("method='numba' needs the numba package, which cannot be imported")
    return method


def _srvt_matrix(R, name, work=None):
    """Flattened SRVT (frames-1, 3 joints) of a curve moved to P*, on the uniform grid.

    The SRVT depends only on the increments R[k+1] R[k]^T, which a right translation leaves unchanged, so
    the curve is not moved explicitly (that product cost a third of a whole 300-frame call; the result
    differs only in rounding). ``work``: None, or the name of this thread's reused array for the result
    (``_workspace``: only for a result that does not outlive the call; compiled route only)."""
    R = as_curve(R, name)
    if R.shape[0] < 2:
        raise CurveError(f"{name}: needs at least two frames for an elastic distance, got {R.shape[0]}")
    if _dp_kernels.HAVE_NUMBA and _srvt_kernel.HAVE_NUMBA and curves.DEFAULT_SRVT_NORM == "joint":
        # one compiled pass, the same operations as srvt (to an ulp or so; docs/elastic.md, fourth pass)
        dt = _memo(("dt", R.shape[0]), lambda: np.diff(as_times(None, R.shape[0])))
        return _srvt_kernel.srvt_rows(R, dt, curves.ZERO_STEP, work), R.shape[1]
    q = srvt(R)
    return np.ascontiguousarray(q.reshape(q.shape[0], -1)), R.shape[1]


def required_depth(frames0, frames1):
    """The smallest depth D for which a DP path joins (0, 0) to (frames0-1, frames1-1)."""
    n0, n1 = int(frames0) - 1, int(frames1) - 1
    if n0 < 1 or n1 < 1:
        raise CurveError("each curve needs at least two frames")
    return -(-max(n0, n1) // min(n0, n1))


# ---------------------------------------------------------------------------------------------
# the step table


_TABLES = {}

# Largest step table built (weights); beyond it the frame counts are too different for the DP.
MAX_TABLE_ENTRIES = 2_000_000


def _table_size(mi, mj, prune):
    di = np.arange(1, mi + 1)[:, None]
    dj = np.arange(1, mj + 1)[None, :]
    keep = np.gcd(di, dj) == 1 if prune else np.ones((mi, mj), dtype=bool)
    return int(np.sum((di + dj - 1) * keep))


def step_table(depth, prune=True, *, max_di=None, max_dj=None):
    """The DP steps and their breakpoint-overlap weights (uniform grids).

    Steps (di, dj) have 1 <= di <= min(depth, max_di) and 1 <= dj <= min(depth, max_dj) (steps
    longer than a curve are useless, so the DP cuts the table to the frame counts).

    Returns a dict of int64/float64 arrays: ``di``, ``dj`` (per step); ``start`` (per step, the
    first entry index, plus one final end index); ``ea``, ``eb``, ``ew`` (per entry, in order
    along the step): interval ``k + ea`` of curve 0 meets interval ``l + eb`` of curve 1 on a
    length ``ew`` in units of h0 / dj (an integer). With ``prune`` only coprime steps are kept.
    """
    mi = int(depth) if max_di is None else min(int(depth), int(max_di))
    mj = int(depth) if max_dj is None else min(int(depth), int(max_dj))
    return _step_table(mi, mj, prune)


def _step_table(mi, mj, prune=True):
    key = (int(mi), int(mj), bool(prune))
    if key in _TABLES:
        return _TABLES[key]
    size = _table_size(mi, mj, prune)
    if size > MAX_TABLE_ENTRIES:
        raise CurveError(
            f"the DP would need steps of up to {mi} x {mj} frames ({size} weights): the frame counts "
            f"are too different; shorten the longer clip (a frame range or a lower frame rate) or lower the depth"
        )
    di_l, dj_l, start, parts = [], [], [0], []
    for di in range(1, mi + 1):
        for dj in range(1, mj + 1):
            if prune and math.gcd(di, dj) != 1:
                continue
            parts.append(step_entries(di, dj))
            di_l.append(di)
            dj_l.append(dj)
            start.append(start[-1] + parts[-1].shape[1])
    ent = np.concatenate(parts, axis=1)
    table = {
        "di": np.array(di_l, dtype=np.int64),
        "dj": np.array(dj_l, dtype=np.int64),
        "start": np.array(start, dtype=np.int64),
        "ea": np.ascontiguousarray(ent[0], dtype=np.int64),
        "eb": np.ascontiguousarray(ent[1], dtype=np.int64),
        "ew": np.ascontiguousarray(ent[2], dtype=np.float64),
    }
    for v in table.values():
        v.setflags(write=False)
    _TABLES[key] = table
    return table


def step_entries(di, dj):
    """The entries of one step (di, dj), shape (3, count) int64: rows ``ea``, ``eb``, ``ew`` as in ``step_table``.

    The step's breakpoints in units of h0 / dj: curve 0's at multiples of dj, curve 1's at multiples of di; each
    merged piece [u, v] lies in interval u // dj of curve 0 and u // di of curve 1."""
    pts = np.union1d(np.arange(int(di) + 1) * int(dj), np.arange(int(dj) + 1) * int(di))
    u = pts[:-1]
    return np.stack([u // dj, u // di, np.diff(pts)])


def dp_problem(intervals0, intervals1, depth=DEFAULT_DEPTH, max_bytes=None):
    """Why ``elastic_align`` cannot take curves of ``intervals0`` x ``intervals1`` intervals at ``depth``:
    'steps' (the frame ratio needs a step table above MAX_TABLE_ENTRIES), 'memory' (the DP needs more than
    ``max_bytes``, default MAX_DP_BYTES), or None when it can."""
    n0, n1 = int(intervals0), int(intervals1)
    if n0 < 1 or n1 < 1:
        raise CurveError("each curve needs at least two frames")
    mi, mj = _max_steps(n0, n1, _check_depth(depth))
    if _table_size(mi, mj, True) > MAX_TABLE_ENTRIES:
        return "steps"
    if DP_BYTES_PER_NODE * n0 * n1 > (MAX_DP_BYTES if max_bytes is None else max_bytes):
        return "memory"
    return None


def _max_steps(n0, n1, depth):
    """Largest steps (on curve 0's axis, on curve 1's axis) for n0 x n1 intervals at a depth.

    Both are ``depth`` (cut to the interval counts) unless the interval ratio exceeds it: then
    the long axis gets the smallest maximal step that still reaches (0, 0) -> (n0, n1), and the
    short axis keeps ``depth``.
    """
    need = required_depth(n0 + 1, n1 + 1)
    mi = mj = depth
    if need > depth:
        if n1 > n0:
            mj = need
        else:
            mi = need
    return min(mi, n0), min(mj, n1)


def _entry_coefficients(table, h0, h1):
    """Per entry: the factor of G in the step energy, 2 W sqrt(h0 h1 / (di dj))."""
    step = np.repeat(np.arange(len(table["di"])), np.diff(table["start"]))
    di = table["di"][step].astype(np.float64)
    dj = table["dj"][step].astype(np.float64)
    return np.ascontiguousarray(2.0 * table["ew"] * np.sqrt(h0 * h1 / (di * dj)))


def _band(n0, n1, mi, mj):
    """Per DP row i, the range [lo, hi] of columns j on some path from (0, 0) to (n0, n1)
    with steps of 1..mi rows and 1..mj columns."""
    i = np.arange(n0 + 1)
    lo = np.maximum(-(-i // mi), n1 - (n0 - i) * mj)
    hi = np.minimum(i * mj, n1 - (-(-(n0 - i) // mi)))
    lo[0] = hi[0] = 0
    return lo.astype(np.int64), hi.astype(np.int64)


# ---------------------------------------------------------------------------------------------
# the DP


def _window_sums(x, depth):
    """B[d, i] = x[i-d] + ... + x[i-1] for 1 <= d <= min(i, depth) (0 elsewhere), shape (depth+1, n+1).

    Summed directly (in the order x[i-1] + x[i-2] + ...) rather than as differences of a
    cumulative sum, whose rounding error would grow with the length of the curve.
    """
    n = x.shape[0]
    B = np.zeros((depth + 1, n + 1))
    for d in range(1, min(depth, n) + 1):
        B[d, d:] = B[d - 1, d:] + x[:n + 1 - d]
    return B


# Memory of one DP: the inner-product matrix G and the DP values, 16 bytes per grid node. Two 10,000-frame
# clips need 1.5 GiB; above MAX_DP_BYTES elastic_align refuses with a clear error instead of exhausting memory.
DP_BYTES_PER_NODE = 16
MAX_DP_BYTES = 4 * 2**30


class _Problem:
    """Everything the kernels need for one pair of curves (uniform grids)."""

    def __init__(self, Q0, Q1, depth, penalty, prune=True, work=False):
        n0, n1 = Q0.shape[0], Q1.shape[0]
        need = DP_BYTES_PER_NODE * n0 * n1
        if need > MAX_DP_BYTES:
            raise CurveError(
                f"the elastic DP over {n0 + 1} x {n1 + 1} frames needs about {need / 2**30:.1f} GiB "
                f"(limit {MAX_DP_BYTES / 2**30:.1f} GiB): crop or resample the clips, or raise "
                f"core.elastic.MAX_DP_BYTES")
        self.n0, self.n1 = n0, n1
        self.max_step = _max_steps(n0, n1, depth)
        mi, mj = self.max_step
        self.depth = max(depth, required_depth(n0 + 1, n1 + 1))
        self.penalty = penalty
        self.h0, self.h1 = 1.0 / n0, 1.0 / n1
        self.table = _step_table(mi, mj, prune)
        self.coef = _memo(("coef", mi, mj, prune, n0, n1), lambda: _entry_coefficients(self.table, self.h0, self.h1))
        self.work = work  # G and the DP values in this thread's reused arrays (_workspace): not kept past the call
        self.G = _dp_kernels.gram(Q0, Q1, work)
        self.B0 = _window_sums(np.einsum("ij,ij->i", Q0, Q0) * self.h0, mi)
        self.B1 = _window_sums(np.einsum("ij,ij->i", Q1, Q1) * self.h1, mj)
        self.lo, self.hi = _memo(("band", n0, n1, mi, mj), lambda: _band(n0, n1, mi, mj))

    def solve(self, method, want_path=True, threads=1):
        """(DP minimum, path nodes (count, 2) from (0, 0) to (n0, n1) or None); ``threads``: numba only."""
        t = self.table
        args = (self.G, self.B0, self.B1, self.h0, self.h1, self.penalty,
                t["di"], t["dj"], t["start"], t["ea"], t["eb"], self.coef, self.lo, self.hi)
        if method == "numba":
            return _dp_kernels.dp_numba(*args, want_path=want_path, threads=threads, work=self.work)
        return _dp_numpy.dp_numpy(*args, want_path=want_path)


def _check_threads(threads):
    """Threads for one DP: None is 2 on machines with at least 4 CPUs (a second core is then likely free; on a
    busy one, two threads only cost more CPU: docs/elastic.md), else 1."""
    if threads is None:
        return 2 if (os.cpu_count() or 1) >= 4 else 1
    return check_integer(threads, "threads", minimum=1)


def _align(R0, R1, depth, penalty, method, prune, want_path, threads=1):
    depth = _check_depth(depth)
    threads = _check_threads(threads)
    penalty = _check_penalty(penalty)
    method = _check_method(method)
    Q0, j0 = _srvt_matrix(R0, "R0", "Q0")
    Q1, j1 = _srvt_matrix(R1, "R1", "Q1")
    if j0 != j1:
        raise CurveError(f"the curves have {j0} and {j1} joints")
    prob = _Problem(Q0, Q1, depth, penalty, prune, work=True)
    value, nodes = prob.solve(method, want_path, threads)
    return prob, value, nodes


def elastic_align(R0, R1, depth=DEFAULT_DEPTH, penalty=0.0, *, method="auto", prune=True, return_info=False,
                  threads=None):
    """The DP reparametrization of R1 onto R0 (sec. 4.3) and the elastic distance d_S*.

    ``R0``, ``R1``: curves (frames, joints, 3, 3) or quaternions (frames, joints, 4) on uniform
    grids of [0, 1], the same joints, at least two frames each (frame counts may differ).
    ``depth``: the largest step D on either axis (raised automatically when the frame ratio needs
    it); ``penalty``: lambda of eq. 4.8 (>= 0). Keyword-only: ``method`` ('auto', 'numba',
    'numpy'), ``prune`` (drop the redundant non-coprime steps; the result is the same),
    ``return_info`` (also return a dict with 'depth' (the depth used), 'max_step' (the largest
    step on curve 0's and on curve 1's axis), 'energy' (the DP minimum), 'method', 'nodes' (the
    path's grid nodes)), ``threads`` (1 or 2 threads for the numba DP of a large pair, the same result bit for
    bit; None: 2 on machines with at least 4 CPUs).

    Returns ``(warp, distance)``: ``warp`` is an array (nodes, 2) of matching times (t0, t1)
    from (0, 0) to (1, 1), strictly increasing in both columns (the vertices of the
    piecewise-linear phi with R1(phi(t0)) matched to R0(t0)); ``distance`` is the square root
    of the DP minimum.
    """
    prob, value, nodes = _align(R0, R1, depth, penalty, method, prune, True, threads)
    warp = np.column_stack([nodes[:, 0] / prob.n0, nodes[:, 1] / prob.n1])
    warp[-1] = (1.0, 1.0)
    dist = float(np.sqrt(max(value, 0.0)))
    if return_info:
        info = {"depth": prob.depth, "max_step": prob.max_step, "energy": float(value),
                "method": _check_method(method), "nodes": nodes}
        return warp, dist, info
    return warp, dist


def elastic_distance(R0, R1, depth=DEFAULT_DEPTH, penalty=0.0, *, method="auto", prune=True, threads=None):
    """d_S*(R0, R1): the square root of the DP minimum of ``elastic_align`` (no backtracking)."""
    _, value, _ = _align(R0, R1, depth, penalty, method, prune, False, threads)
    return float(np.sqrt(max(value, 0.0)))


def elastic_distance_matrix(curves, depth=DEFAULT_DEPTH, penalty=0.0, workers=2, *, method="auto", progress=None):
    """All-pairs d_S* of a list of curves: a symmetric (n, n) array with a zero diagonal.

    Entry [a, b] for a < b is ``elastic_distance(curves[a], curves[b])`` and is mirrored to
    [b, a] (d_S* is symmetric for penalty 0; with a penalty the a < b order is the one used).
    The SRVTs are computed once per curve. ``workers`` threads share the pairs; the numba kernel
    releases the GIL, so they run in parallel (the numpy kernel mostly does too). ``progress(done, total)``
    (``core.progress``) is called in the calling thread each time a pair is done; when it returns True the pairs
    not started are dropped and Cancelled is raised.
    """
    depth = _check_depth(depth)
    penalty = _check_penalty(penalty)
    method = _check_method(method)
    try:
        workers = int(workers)
    except (TypeError, ValueError):
        raise ShapeSigError(f"workers must be an integer >= 1, got {workers!r}") from None
    if workers < 1:
        raise ShapeSigError(f"workers must be an integer >= 1, got {workers!r}")
    curves = list(curves)
    qs = []
    joints = None
    for n, R in enumerate(curves):
        Q, j = _srvt_matrix(R, f"curve {n}")
        if joints is not None and j != joints:
            raise CurveError(f"curve {n} has {j} joints, curve 0 has {joints}")
        joints = j
        qs.append(Q)
    n = len(qs)
    out = np.zeros((n, n))
    pairs = [(a, b) for a in range(n) for b in range(a + 1, n)]
    # Longest first, so that the threads finish together.
    pairs.sort(key=lambda p: -qs[p[0]].shape[0] * qs[p[1]].shape[0])

    def run(pair):
        a, b = pair
        value, _ = _Problem(qs[a], qs[b], depth, penalty).solve(method, want_path=False)
        return a, b, float(np.sqrt(max(value, 0.0)))

    count = Counter(progress, len(pairs))
    if workers == 1 or len(pairs) < 2:
        results = map(run, pairs)
    else:
        pool = ThreadPoolExecutor(max_workers=workers)
        results = pool.map(run, pairs)
    try:
        for a, b, d in results:
            out[a, b] = out[b, a] = d
            count.add()
    finally:
        if workers > 1 and len(pairs) >= 2:
            pool.shutdown(wait=True, cancel_futures=True)
    return out


def warm_up():
    """Compile (or load from numba's on-disk cache) every kernel a distance or an alignment uses, on a tiny
    problem: afterwards the first ``elastic_distance`` of a new process only loads the cache (~0.4 s instead of
    ~8 s of JIT). numba caches next to this file, or in its per-user cache folder when that is read-only
    (``NUMBA_CACHE_DIR`` overrides both). Returns False without numba."""
    if not _dp_kernels.HAVE_NUMBA:
        return False
    from ..geometry.so3 import integrate

    steps = np.linspace(0.01, 0.05, 6 * 2 * 3).reshape(6, 2, 3)
    R0, R1 = integrate(steps), integrate(steps[::-1])
    elastic_distance(R0, R1, depth=3)
    R0.setflags(write=False)  # read-only curves (e.g. cached arrays) are another type for the SRVT kernels
    elastic_distance(R0, R1, depth=3)
    elastic_align(R0, R1, depth=3)
    elastic_align(R0, R1, depth=3, penalty=0.1)
    return True
