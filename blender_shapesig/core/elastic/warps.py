"""Warps: the piecewise-linear reparametrizations phi that ``elastic_align`` returns, as arrays (nodes, 2) of
matching times (t0, t1) from (0, 0) to (1, 1). ``check_warp`` (the checked form), ``reparametrize`` (a curve composed
with a warp, eq. 5.9) and ``warp_grid`` (the times where that composition has a kink). See docs/elastic.md.
"""

import numpy as np

from ..errors import CurveError
from ..geometry.curves import as_curve, as_times, geodesic_interpolate

__all__ = ["check_warp", "reparametrize", "warp_grid"]


def check_warp(warp, strict=False):
    """A warp as a float array (nodes, 2) of matching times (t0, t1) from (0, 0) to (1, 1) (ends within 1e-9,
    then set exactly); t0 strictly increasing, t1 non-decreasing (``strict``: strictly increasing too, an
    invertible warp). CurveError otherwise."""
    w = np.asarray(warp, dtype=np.float64)
    if w.ndim != 2 or w.shape[1] != 2 or w.shape[0] < 2:
        raise CurveError(f"warp: expected an array (nodes >= 2, 2) of times (t0, t1), got shape {w.shape}")
    if not np.all(np.isfinite(w)):
        raise CurveError("warp: contains NaN or infinite values")
    tol = 1e-9
    if np.any(np.abs(w[0]) > tol) or np.any(np.abs(w[-1] - 1.0) > tol):
        raise CurveError(f"warp: must run from (0, 0) to (1, 1), got {tuple(w[0])} to {tuple(w[-1])}")
    if np.any(np.diff(w[:, 0]) <= 0.0):
        raise CurveError("warp: the t0 column must be strictly increasing")
    if strict and np.any(np.diff(w[:, 1]) <= 0.0):
        raise CurveError("warp: the t1 column must be strictly increasing")
    if np.any(np.diff(w[:, 1]) < 0.0):
        raise CurveError("warp: the t1 column must be non-decreasing")
    w = w.copy()
    w[0] = (0.0, 0.0)
    w[-1] = (1.0, 1.0)
    return w


def reparametrize(R, t, warp, t_new=None):
    """Samples of R(phi(s)): the curve R composed with the warp, by geodesic interpolation (eq. 5.9).

    ``R``: a curve (frames, joints, 3, 3) or quaternions, sampled at times ``t`` (None: uniform).
    ``warp``: an array (nodes, 2) of times (t0, t1) from (0, 0) to (1, 1) as returned by
    ``elastic_align(R0, R, ...)``; phi is the piecewise-linear map through its nodes
    (phi(warp[:, 0]) = warp[:, 1]). ``t_new``: the times s at which R(phi(s)) is sampled; by
    default the curve's own grid ``t`` (so the result has as many frames as R; to put it on R0's
    grid pass ``t_new=`` R0's times). R(phi(s)) is evaluated with ``geodesic_interpolate``, so
    samples that land on R's knots are R's frames unchanged. R is not moved to P*.

    On the grid ``warp_grid(warp, t)`` the geodesic interpolation of the result equals R o phi
    exactly (every kink of R o phi is a sample), so ``l2_distance(R0, result, t1=that grid)`` is
    then the square root of the warp's energy (without penalty): for the DP's warp, d_S*.

    Returns an array (len(t_new), joints, 3, 3).
    """
    R = as_curve(R, "R")
    t = as_times(t, R.shape[0], "t")
    w = check_warp(warp)
    if t_new is None:
        s = t
    else:
        s = np.asarray(t_new, dtype=np.float64).reshape(-1)
        if not np.all(np.isfinite(s)):
            raise CurveError("t_new: contains NaN or infinite values")
        if s.size and (s.min() < -1e-12 or s.max() > 1.0 + 1e-12):
            raise CurveError("t_new: times must lie in [0, 1]")
        s = np.clip(s, 0.0, 1.0)
    u = np.clip(np.interp(s, w[:, 0], w[:, 1]), 0.0, 1.0)
    return geodesic_interpolate(R, t, u)


def warp_grid(warp, t):
    """The times s at which R o phi has a kink: the warp's t0 nodes and phi^-1 of R's grid ``t``.

    ``t`` is R's time grid (an array) or its frame count (an int: uniform). Needs a warp that is
    strictly increasing in both columns (as returned by ``elastic_align``). Returns a sorted
    array of unique times from 0 to 1.
    """
    w = check_warp(warp)
    if np.any(np.diff(w[:, 1]) <= 0.0):
        raise CurveError("warp: the t1 column must be strictly increasing to invert it")
    if np.isscalar(t) or np.ndim(t) == 0:
        t = as_times(None, int(t), "t")
    else:
        t = as_times(t, len(t), "t")
    s = np.interp(t, w[:, 1], w[:, 0])
    grid = np.union1d(w[:, 0], s)
    # Drop near-duplicates from rounding (they would give zero-length intervals).
    keep = np.concatenate([[True], np.diff(grid) > 1e-13])
    grid = grid[keep]
    grid[0], grid[-1] = 0.0, 1.0
    return grid
