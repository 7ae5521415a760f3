"""Combine curves: the time-aligned SRVT geodesic blend of two or more curves (eq. 5.14, generalised):
``geodesic_blend`` moves the curves to P*, aligns them by the elastic warp (``compute_warp``), averages their SRVTs
on the merged grid, resamples with the blended timing and restores the blended start pose; also the weights'
checks and names and ``default_frames``. Per-joint weights (masks) act on the SRVT and the start pose only.
See docs/blending.md.
"""

import math

import numpy as np

from ..geometry import so3
from ..geometry.curves import (
    as_curve_pair,
    geodesic_interpolate,
    move_to_identity,
    relative_rotvecs,
    srvt_of_velocity,
    uniform_times,
)
from ..elastic.elastic import check_warp
from ..errors import ShapeSigError, check_inbetweens, check_integer, check_number, check_weight, check_weights
from ..elastic import DEFAULT_DEPTH

__all__ = [
    "geodesic_blend", "blend_weights", "blend_name", "compute_warp", "identity_warp", "default_frames",
    "default_frames_many", "mean_start",
]

# Grid points closer than this (in [0, 1]) are merged; they would make zero-length intervals.
_GRID_TOL = 1e-12


def _check_frames(frames):
    return check_integer(frames, "frames", minimum=2, allow_none=True)


def identity_warp():
    """The warp of no alignment: phi(t) = t."""
    return np.array([[0.0, 0.0], [1.0, 1.0]])


def default_frames_many(frames, weights, durations=None, fps=None):
    """The default length of a blend of clips of ``frames`` samples: ``sum_i w_i (N_i - 1) + 1`` (rounded half
    up), or with durations (seconds) and an output ``fps``: ``round(sum_i w_i D_i fps) + 1``."""
    if durations is None or fps is None:
        span = weights[0] * (frames[0] - 1)
        for w, n in zip(weights[1:], frames[1:]):
            span = span + w * (n - 1)
    else:
        span = weights[0] * durations[0]
        for w, d in zip(weights[1:], durations[1:]):
            span = span + w * d
        span = span * fps
    # 1e-9 guards against 0.49999999 from rounding so that blend(a, b, w) and blend(b, a, 1 - w)
    # get the same length.
    return max(2, int(math.floor(span + 0.5 + 1e-9)) + 1)


def default_frames(frames0, frames1, weight, duration0=None, duration1=None, fps=None):
    """The default blend length: ``(1 - w) N0 + w N1`` frames (rounded half up).

    With durations (seconds) and an output ``fps``: ``round(((1 - w) D0 + w D1) fps) + 1``, which is
    the same when both clips share the frame rate.
    """
    w = check_weight(weight)
    durations = None if duration0 is None or duration1 is None else (duration0, duration1)
    return default_frames_many((frames0, frames1), (1.0 - w, w), durations, fps)


def blend_weights(count, weight=0.5):
    """Weights of ``count`` in-betweens: ``[weight]`` for one, else i / (count + 1), i = 1..count."""
    k = check_inbetweens(count)  # 1..MAX_INBETWEENS, the same check as the operator and the CLI
    if k == 1:
        return [check_weight(weight)]
    return [i / (k + 1) for i in range(1, k + 1)]


def blend_name(name_a, name_b, weight):
    """``<A>_x_<B>_<weight>`` with two decimals, e.g. ``walk_x_run_0.50``; with a list of names and weights (more
    than two clips) ``<A>_x_<B>_x_<C>_<wA>_<wB>_<wC>``."""
    if isinstance(name_b, (list, tuple)):
        names = [name_a] + list(name_b)
        return "_x_".join(names) + "_" + "_".join(f"{w:.2f}" for w in weight)
    return f"{name_a}_x_{name_b}_{check_weight(weight):.2f}"


def _joint_weights(W, i):
    """Weight of source i, broadcastable against (intervals, joints, 3) arrays: a scalar or (1, joints, 1)."""
    w = W[i]
    return w if np.ndim(w) == 0 else np.asarray(w)[None, :, None]


def mean_start(starts, W):
    """The blended start pose per joint: the weighted Karcher mean of ``starts`` (list of (joints, 3, 3)) with
    weights ``W`` (per source: a scalar or one per joint). Two sources: the closed form
    ``exp(w log(S1 S0^T)) S0`` (the point at w on their geodesic); more: the fixed point of
    ``m <- exp(sum_i w_i log(S_i m^T)) m`` from S0 (independent of the order of the sources)."""
    S0 = starts[0]

    def step(m, first):
        xi = None
        for i in range(0 if not first else 1, len(starts)):
            w = W[i] if np.ndim(W[i]) == 0 else np.asarray(W[i])[:, None]
            term = w * so3.log(starts[i] @ np.swapaxes(m, -1, -2))
            xi = term if xi is None else xi + term
        return xi

    if len(starts) == 2:
        return so3.exp(step(S0, True)) @ S0
    m = S0
    for _ in range(50):
        xi = step(m, False)
        m = so3.exp(xi) @ m
        if np.abs(xi).max(initial=0.0) < 1e-13:
            break
    return m


# ---------------------------------------------------------------------------------------------
# the plan: merged grid, warps on it, output time map


class _Plan:
    """Grids and time maps shared by every bone (and the root) of one blend of n sources.

    ``grid`` (G): merged grid on source 0's parameter u; ``phis[i]``: phi_i(G) (source i's times, phis[0] = G);
    ``phi``: phis[1]; ``u_out``: the parameter of each output frame; ``times[i]``: source i's uniform grid.
    ``weights``: the timing weights (one per source)."""

    def __init__(self, frames_list, weights, warps, frames=None, durations=None):
        n = len(frames_list)
        self.weights = tuple(weights)
        self.weight = self.weights[1] if n == 2 else None
        self.warps = list(warps)
        self.times = [uniform_times(f) for f in frames_list]
        self.times0 = self.times[0]
        grid = self.times0
        for i, warp in enumerate(self.warps, start=1):
            pre = np.interp(self.times[i], warp[:, 1], warp[:, 0])
            grid = np.union1d(np.union1d(grid, warp[:, 0]), pre)
        keep = np.concatenate([[True], np.diff(grid) > _GRID_TOL])
        keep[-1] = True
        grid = grid[keep]
        if grid.size > 2 and grid[-1] - grid[-2] <= _GRID_TOL:
            grid = np.delete(grid, -2)
        grid[0], grid[-1] = 0.0, 1.0
        self.grid = grid
        self.phis = [grid] + [self._phi(warp, self.times[i], frames_list[i])
                              for i, warp in enumerate(self.warps, start=1)]
        if n >= 2:
            self.phi, self.times1 = self.phis[1], self.times[1]
        if durations is None:
            ds = [float(f - 1) for f in frames_list]
        else:
            ds = [float(d) for d in durations]
            if len(ds) != n or not all(d > 0 and math.isfinite(d) for d in ds):
                raise ShapeSigError(f"durations: expected {n} positive numbers, got {durations!r}")
        self.durations = tuple(ds)
        w = self.weights
        total = w[0] * ds[0]
        for i in range(1, n):
            total = total + w[i] * ds[i]
        # Blended clip time of each grid point, normalized to [0, 1]; strictly increasing.
        v = w[0] * ds[0] * grid
        for i in range(1, n):
            v = v + w[i] * ds[i] * self.phis[i]
        v = v / total
        v[0], v[-1] = 0.0, 1.0
        self.v_grid = v
        if frames is None:
            if durations is None:
                frames = default_frames_many(frames_list, w)
            else:
                span = w[0] * frames_list[0]
                for i in range(1, n):
                    span = span + w[i] * frames_list[i]
                frames = max(2, int(math.floor(span + 0.5 + 1e-9)))
        self.frames = frames
        v_out = uniform_times(frames)
        u = np.interp(v_out, v, grid)
        # Exact knots at the ends and wherever an output time hits a grid time.
        hit = np.clip(np.searchsorted(v, v_out), 0, grid.size - 1)
        exact = np.abs(v[hit] - v_out) <= 1e-13
        u[exact] = grid[hit[exact]]
        u[0], u[-1] = 0.0, 1.0
        self.u_out = u

        # Interval bookkeeping: every grid interval lies inside one interval of each source's grid (at phi_i),
        # where every curve is a single geodesic.
        self.dg = np.diff(grid)
        self.ks, self.slopes = [], []
        for i in range(n):
            mid = 0.5 * (self.phis[i][:-1] + self.phis[i][1:])
            self.ks.append(np.clip(np.searchsorted(self.times[i], mid, side="right") - 1, 0, frames_list[i] - 2))
            self.slopes.append(np.diff(self.phis[i]) / self.dg)

    def _phi(self, warp, times, frames):
        phi = np.clip(np.interp(self.grid, warp[:, 0], warp[:, 1]), 0.0, 1.0)
        # Points that are phi^-1 of the source's knots map back onto those knots exactly (no round-off),
        # so that its samples are reproduced unchanged at weight 1.
        idx = np.clip(np.searchsorted(times, phi), 0, frames - 1)
        for cand in (idx, np.clip(idx - 1, 0, frames - 1)):
            near = np.abs(times[cand] - phi) <= 1e-12
            phi[near] = times[cand[near]]
        phi[0], phi[-1] = 0.0, 1.0
        return phi

    # -- curves on the grid ------------------------------------------------------------------

    def q_on_grid(self, i, rel):
        """SRVT of source i (o phi_i) on the grid from its increments rel = log(R[k+1] R[k]^T): exact. Source 0
        is on its own parameter; source i >= 1 is q_i(phi_i) sqrt(phi_i') (eq. 4.6), exact for a piecewise-linear
        phi_i."""
        dt = np.diff(self.times[i])
        eta = (rel / dt[:, None, None])[self.ks[i]]
        if i > 0:
            eta = eta * self.slopes[i][:, None, None]
        return srvt_of_velocity(eta, rel[self.ks[i]])

    def r_on_grid(self, i, R):
        return geodesic_interpolate(R, self.times[i], self.phis[i])

    def r0_on_grid(self, R0):
        return self.r_on_grid(0, R0)

    def blend_q(self, qs, W=None):
        """(blended curve on the grid in P*, its per-interval increments log(B[k+1] B[k]^T)): ``q = sum_i W_i
        q_i``; ``W`` per source a scalar or one weight per joint (default: the timing weights)."""
        W = self.weights if W is None else W
        q = _joint_weights(W, 0) * qs[0]
        for i in range(1, len(qs)):
            q = q + _joint_weights(W, i) * qs[i]
        steps = q * np.linalg.norm(q, axis=-1, keepdims=True) * self.dg[:, None, None]
        return so3.integrate(steps), steps

    def resample(self, Bg, steps):
        """A curve on the grid (with its increments), evaluated at the output frames."""
        return geodesic_interpolate(Bg, self.grid, self.u_out, increments=steps)

    def r0_out(self, R0, rel0):
        """Source 0's own motion in the blended timing (rel0: R0's increments)."""
        return geodesic_interpolate(R0, self.times0, self.u_out, increments=rel0)

    def source_times(self):
        """Per source, the time (in its own normalized parameter, 0..1) of every output frame."""
        return [self.u_out] + [np.interp(self.u_out, self.grid, phi) for phi in self.phis[1:]]


def compute_warp(R0, R1, align=True, depth=DEFAULT_DEPTH, penalty=0.0):
    """(warp, elastic distance or None): the DP warp of R1 onto R0, or the identity without align."""
    if not align:
        return identity_warp(), None
    from ..elastic.elastic import elastic_align

    warp, dist = elastic_align(R0, R1, depth=depth, penalty=penalty)
    return check_warp(warp, strict=True), float(dist)


# ---------------------------------------------------------------------------------------------
# curves


def geodesic_blend(R0, R1, weight, align=True, depth=DEFAULT_DEPTH, *, frames=None, warp=None, durations=None,
                   penalty=0.0, return_info=False):
    """The SRVT geodesic blend (eq. 5.14) of R0 and R1 at ``weight`` (0 gives R0, 1 gives R1).

    ``R0``, ``R1``: curves (frames, joints, 3, 3) or quaternions (frames, joints, 4) with the same
    joints, at least two frames each, on uniform grids. ``align``: warp R1 onto R0 elastically first
    (``elastic_align`` with ``depth`` and ``penalty``); ``warp``: use this warp (nodes, 2) instead of
    computing one (e.g. one warp for several weights). ``frames``: output length (default
    ``(1 - w) N0 + w N1``); ``durations``: the clips' durations (D0, D1) for the blended timing
    (default N0 - 1 and N1 - 1 frames). See the module docstring for the construction.

    Returns the blended curve (frames, joints, 3, 3); with ``return_info`` also a dict:
    ``warp``; ``grid`` (G, on R0's parameter); ``phi`` (phi(G)); ``curve0``, ``curve1``: R0 and
    R1 o phi moved to P* and sampled on G; ``curve``: the blend on G in P* (before resampling);
    ``time_map``: the parameter u of every output frame; ``start``: the start pose;
    ``distance``: d_P*(R0, R1 o phi) (on G); ``elastic_distance``: the DP's value (None without
    align).
    """
    w = check_weight(weight)
    R0, R1 = as_curve_pair(R0, R1)
    frames = _check_frames(frames)
    if warp is not None:
        warp, edist = check_warp(warp, strict=True), None
    else:
        warp, edist = compute_warp(R0, R1, align, depth, penalty)
    plan = _Plan((R0.shape[0], R1.shape[0]), (1.0 - w, w), [warp], frames, durations)
    qs = [plan.q_on_grid(0, relative_rotvecs(R0)), plan.q_on_grid(1, relative_rotvecs(R1))]
    Bg, steps = plan.blend_q(qs)
    start = mean_start([R0[0], R1[0]], (1.0 - w, w))
    out = plan.resample(Bg, steps) @ start[None]
    if not return_info:
        return out
    from ..geometry.curves import l2_distance

    R0g = plan.r_on_grid(0, move_to_identity(R0))
    R1g = plan.r_on_grid(1, move_to_identity(R1))
    info = {
        "warp": warp,
        "grid": plan.grid,
        "phi": plan.phi,
        "curve0": R0g,
        "curve1": R1g,
        "curve": Bg,
        "time_map": plan.u_out,
        "start": start,
        "distance": l2_distance(R0g, R1g, plan.grid, plan.grid),
        "elastic_distance": edist,
    }
    return out, info
