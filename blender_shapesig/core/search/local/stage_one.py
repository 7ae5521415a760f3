"""The local search's first stage (``core.search.local.features``): the library's windows stacked in one block
(``stack``), a coarse prefilter on a few windows per clip (``coarse_windows``, ``coarse_distances``) and the exact
Chamfer distance of the query's windows to every entry's (``first_stage``), in contiguous blocks of rows with one
BLAS thread. Pure numpy; no bpy. Measured in docs/performance.md ("At library scale").
"""

import math
from typing import Dict, Optional, Sequence

import numpy as np

from ...blas import one_blas_thread

__all__ = ["stack", "nearest", "PREFILTER", "PREFILTER_SHARE", "coarse_windows", "coarse_distances", "gather_rows",
           "first_stage"]

def _sq_dist(A, B):
    d = (A * A).sum(1)[:, None] + (B * B).sum(1)[None] - 2.0 * (A @ B.T)
    return np.maximum(d, 0.0)


def stack(entries: Sequence) -> Dict[str, np.ndarray]:
    """The library's windows in one block for ``first_stage`` (build it once per library): ``windows`` (all, DIM)
    float32, their squared norms, ``bounds`` (each entry's first row, and the end) and each entry's rows
    (``starts``, ``ends``). A library file (``local_library.LibraryFile.stack``) gives the same keys but the
    ``bounds``, memory-mapped, its entries' rows in any order."""
    wins = [np.asarray(e.windows, dtype=np.float32) for e in entries]
    W = np.concatenate(wins) if wins else np.zeros((0, 1), np.float32)
    bounds = np.concatenate([[0], np.cumsum([len(w) for w in wins])]).astype(np.int64)
    return {"windows": W, "norms": (W * W).sum(1), "bounds": bounds, "starts": bounds[:-1], "ends": bounds[1:]}


PREFILTER = 1000  # clips the prefilter keeps for the exact first stage (``first_stage(keep=)``) ...
PREFILTER_SHARE = 0.02  # ... and at least this share of the library (a larger library holds more near neighbours:
# keeping 1,000 of 100,000 found 90 % of the exact top 10, 2 % 96 %; docs/performance.md, "At library scale")


def nearest(d, n) -> np.ndarray:
    """The indices of the ``n`` smallest of ``d`` in the order of ``np.argsort(d, kind="stable")`` (ties by index),
    without sorting the rest."""
    d = np.asarray(d)
    if n >= len(d):
        return np.argsort(d, kind="stable")
    cand = np.flatnonzero(d <= np.partition(d, n - 1)[n - 1])
    if len(cand) < n:  # NaNs among the first n: the whole sort's rule
        return np.argsort(d, kind="stable")[:n]
    return cand[np.argsort(d[cand], kind="stable")][:n]


def _chunks(lengths, block):
    """Slices of consecutive entries (``lengths`` their rows) of at most ``block`` rows each (an entry longer than
    ``block`` alone), found without a loop per entry."""
    first = np.concatenate([[0], np.cumsum(lengths)[:-1]]) // max(int(block), 1)
    cuts = np.flatnonzero(np.diff(first)) + 1
    return [slice(a, b) for a, b in zip(np.concatenate([[0], cuts]), np.concatenate([cuts, [len(lengths)]]))]


def gather_rows(starts, ends):
    """(rows, offsets): the row numbers of the entries' row ranges [starts, ends) one after another, and where each
    entry's rows begin in them (a contiguous block of candidates is ``W[rows]``; ``reduceat`` by ``offsets``)."""
    lengths = np.asarray(ends - starts, np.int64)
    offsets = np.concatenate([[0], np.cumsum(lengths)[:-1]]).astype(np.int64)
    rows = np.repeat(np.asarray(starts, np.int64) - offsets, lengths) + np.arange(int(lengths.sum()), dtype=np.int64)
    return rows, offsets


def _take(A, rows):
    """A[rows] read at once: a slice when the rows are consecutive (a memory map read in one piece)."""
    if len(rows) and rows[-1] - rows[0] + 1 == len(rows):
        return A[int(rows[0]):int(rows[-1]) + 1]
    return A[rows]


def coarse_windows(windows, k) -> np.ndarray:
    """(k, DIM) float32: ``k`` of a clip's windows evenly spaced over them (repeated when it has fewer)."""
    w = np.asarray(windows)
    return np.asarray(w[np.linspace(0, len(w) - 1, k).round().astype(int)], np.float32)


def coarse_distances(query, coarse, norms=None, block: int = 4096) -> np.ndarray:
    """(entries,) the prefilter: the Chamfer distance of the query's windows subsampled like the entries'
    (``coarse`` (entries, k, DIM), ``coarse_windows``, 4k of the query's) to each entry's k. ``norms``: the coarse
    windows' squared norms (entries * k,) when the caller keeps them (``first_stage`` does, per library). Run
    ``block`` entries at a time (the distances of a block stay in the processor's cache)."""
    n, k = coarse.shape[0], coarse.shape[1]
    q = coarse_windows(query.windows, 4 * k)
    qn, q2 = (q * q).sum(1)[:, None], -2.0 * q  # (-2 q) C^T is -2 (q C^T) to the bit: one product, no copies
    out = np.empty(n)
    for a in range(0, n, block):
        b = min(n, a + block)
        C = np.asarray(coarse[a:b], np.float32).reshape(-1, coarse.shape[2])
        cn = (C * C).sum(1) if norms is None else norms[a * k:b * k]
        D = q2 @ C.T
        D += qn + cn[None]
        D = D.reshape(len(q), b - a, k)  # squared distances
        near = D[:, :, 0].copy()  # the nearest of an entry's k windows: k - 1 elementwise minima (not a
        for j in range(1, k):     # reduction over a short axis, which numpy runs slowly)
            np.minimum(near, D[:, :, j], out=near)
        q_side = np.sqrt(np.maximum(near, 0.0)).mean(axis=0)
        e_side = np.sqrt(np.maximum(D.min(axis=0), 0.0)).mean(axis=1)
        out[a:b] = 0.5 * (q_side + e_side)
    return out


def _coarse_norms(lib):
    """The library's coarse windows' squared norms, computed on its first query and kept in its block."""
    got = lib.get("coarse_norms")
    if got is None:
        C = np.asarray(lib["coarse"], np.float32).reshape(-1, lib["coarse"].shape[2])
        got = (C * C).sum(1)
        lib["coarse_norms"] = got
    return got


def first_stage(query, library, block: int = 65536, keep: Optional[int] = None,
                share: float = PREFILTER_SHARE) -> np.ndarray:
    """(entries,) Chamfer distances: 1/2 (mean over the query's windows of the nearest entry window's distance + the
    same from the entry's side). ``query``: an ``index_entry``; ``library``: a ``stack`` of entries (or a library
    file's), or the entries. The entries' rows (a memory-mapped library's in any order) are gathered into
    contiguous blocks of at most ``block`` rows, each compared in one product, with one BLAS thread (small
    products). ``keep``: with a library that has ``coarse`` windows and more entries than ``keep`` (raised to
    ``share`` of the entries when that is more), only that many nearest by ``coarse_distances`` are computed exactly;
    the others come after them in the prefilter's order (the largest exact distance plus their coarse distance)."""
    lib = library if isinstance(library, dict) and "starts" in library else stack(library)
    q = np.asarray(query.windows, dtype=np.float32)
    qn, q2 = (q * q).sum(1)[:, None], -2.0 * q
    W, norms, starts, ends = lib["windows"], lib["norms"], lib["starts"], lib["ends"]
    n = len(starts)
    out = np.full(n, np.inf)
    if n == 0:
        return out
    idx = np.arange(n)
    coarse = None
    with one_blas_thread():
        keep = None if keep is None else max(int(keep), int(math.ceil(share * n)))
        if keep is not None and lib.get("coarse") is not None and n > keep:
            coarse = coarse_distances(query, lib["coarse"], _coarse_norms(lib))
            idx = np.argpartition(coarse, keep)[:keep]
            idx = idx[np.argsort(starts[idx], kind="stable")]  # the file's order: the map is read forward
        lengths = ends[idx] - starts[idx]
        for part in _chunks(lengths, block):
            run = idx[part]
            rows, rel = gather_rows(starts[run], ends[run])
            D = q2 @ np.asarray(_take(W, rows), np.float32).T
            D += qn + np.asarray(_take(norms, rows), np.float32)[None]
            np.sqrt(np.maximum(D, 0.0, out=D), out=D)
            q_side = np.minimum.reduceat(D, rel, axis=1).mean(axis=0)
            e_side = np.add.reduceat(D.min(axis=0), rel) / lengths[part]
            out[run] = 0.5 * (q_side + e_side)
    if coarse is not None:
        rest = np.isinf(out)
        out[rest] = out[~rest].max() + coarse[rest]
    return out
