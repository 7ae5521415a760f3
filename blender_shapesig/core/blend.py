"""Time-aligned SRVT geodesic blends between two curves or clips (reference eq. 5.14, sec. 9.1).

The blend of R0 and R1 at weight w (w = 0 gives R0, w = 1 gives R1; in the notation of eq. 5.14,
s = 1 - w) is built in five steps:

1. Both curves are moved to P* (right-translated to start at the identity).
2. With ``align``, the elastic warp phi of R1 onto R0 is found by dynamic programming
   (``elastic_align``, sec. 4.3) and R1 is replaced by R1 o phi; without it phi is the identity.
3. Both curves are sampled on the *merged grid* G: R0's knots, the warp's nodes and phi^-1 of R1's
   knots. On every interval of G both R0 and R1 o phi are single geodesics (eq. 5.8), so their SRVTs
   q0 and q1 (eq. 5.11) are exact piecewise constants there, and the blend
   ``q = (1 - w) q0 + w q1`` is the straight line between them in L2 (eq. 5.14): the curve
   ``inverse_srvt(q, G)`` lies on the d_P* geodesic from R0 to R1 o phi, at distance w from R0
   and 1 - w from R1 o phi (in units of d_P*(R0, R1 o phi)).
4. The blended curve lives on R0's (the warp's) parameter u. It is resampled to the output frame
   count with the *blended timing*: the sample at parameter u is placed at the clip time
   ``(1 - w) D0 u + w D1 phi(u)`` (D0, D1 the two durations), i.e. the corresponding instants of
   both clips are averaged. At w = 0 this is R0's own timing, at w = 1 it is R1's own timing
   (u = phi^-1(time)), and a blend of a 130-frame run and a 420-frame walk lasts in between. The
   default length is ``(1 - w) N0 + w N1`` frames (same frame rate), or any ``frames``.
5. The result is right-translated by the geodesic interpolation at w of the two start poses
   ``exp(w log(R1[0] R0[0]^T)) R0[0]`` per joint.

``blend_clips`` applies this to two ``Clip`` objects: bones are matched by name, an optional subset
is blended with the warp found on all shared moving bones, the other bones of clip A follow A's
motion in the blended timing, and the root translation is blended through per-frame root
displacements expressed in the root's heading frame (see ``blend_clips``).
"""

import math

import numpy as np

from . import so3
from .clip import Clip, shared_bones, still_joints
from .curves import (
    as_curve,
    geodesic_interpolate,
    move_to_identity,
    relative_rotvecs,
    srvt_of_velocity,
    uniform_times,
)
from .elastic import check_warp
from .errors import CurveError, ShapeSigError, check_inbetweens, check_integer, check_number
from .metrics import DEFAULT_DEPTH
from .prepare import prepare_rotations

__all__ = [
    "geodesic_blend",
    "blend_clips",
    "blend_weights",
    "blend_name",
    "compute_warp",
    "identity_warp",
    "default_frames",
    "blend_fps",
]

# Grid points closer than this (in [0, 1]) are merged; they would make zero-length intervals.
_GRID_TOL = 1e-12


# ---------------------------------------------------------------------------------------------
# small helpers


def _check_weight(weight):
    return check_number(weight, "weight", 0.0, 1.0)


def _check_frames(frames):
    return check_integer(frames, "frames", minimum=2, allow_none=True)


def identity_warp():
    """The warp of no alignment: phi(t) = t."""
    return np.array([[0.0, 0.0], [1.0, 1.0]])


def default_frames(frames0, frames1, weight, duration0=None, duration1=None, fps=None):
    """The default blend length: ``(1 - w) N0 + w N1`` frames (rounded half up).

    With durations (seconds) and an output ``fps``: ``round(((1 - w) D0 + w D1) fps) + 1``, which is
    the same when both clips share the frame rate.
    """
    w = _check_weight(weight)
    if duration0 is None or duration1 is None or fps is None:
        span = (1.0 - w) * (frames0 - 1) + w * (frames1 - 1)
    else:
        span = ((1.0 - w) * duration0 + w * duration1) * fps
    # 1e-9 guards against 0.49999999 from rounding so that blend(a, b, w) and blend(b, a, 1 - w)
    # get the same length.
    return max(2, int(math.floor(span + 0.5 + 1e-9)) + 1)


def blend_weights(count, weight=0.5):
    """Weights of ``count`` in-betweens: ``[weight]`` for one, else i / (count + 1), i = 1..count."""
    k = check_inbetweens(count)  # 1..MAX_INBETWEENS, the same check as the operator and the CLI
    if k == 1:
        return [_check_weight(weight)]
    return [i / (k + 1) for i in range(1, k + 1)]


def blend_name(name_a, name_b, weight):
    """``<A>_x_<B>_<weight>`` with two decimals, e.g. ``walk_x_run_0.50``."""
    return f"{name_a}_x_{name_b}_{_check_weight(weight):.2f}"


def _geodesic_start(S0, S1, w):
    """exp(w log(S1 S0^T)) S0 per joint: the point at w on the geodesic from S0 to S1."""
    xi = so3.log(S1 @ np.swapaxes(S0, -1, -2))
    return so3.exp(w * xi) @ S0


# ---------------------------------------------------------------------------------------------
# the plan: merged grid, warp on it, output time map


class _Plan:
    """Grids and time maps shared by every bone (and the root) of one blend.

    ``grid`` (G): merged grid on R0's parameter u; ``phi``: phi(G) (R1's times); ``u_out``: the
    parameter of each output frame; ``times0``/``times1``: R0's and R1's uniform grids.
    """

    def __init__(self, frames0, frames1, weight, warp, frames=None, durations=None):
        self.weight = w = weight
        self.warp = warp
        self.times0 = uniform_times(frames0)
        self.times1 = uniform_times(frames1)
        pre1 = np.interp(self.times1, warp[:, 1], warp[:, 0])
        grid = np.union1d(np.union1d(self.times0, warp[:, 0]), pre1)
        keep = np.concatenate([[True], np.diff(grid) > _GRID_TOL])
        keep[-1] = True
        grid = grid[keep]
        if grid.size > 2 and grid[-1] - grid[-2] <= _GRID_TOL:
            grid = np.delete(grid, -2)
        grid[0], grid[-1] = 0.0, 1.0
        self.grid = grid
        phi = np.clip(np.interp(grid, warp[:, 0], warp[:, 1]), 0.0, 1.0)
        # Points that are phi^-1 of R1's knots map back onto those knots exactly (no round-off),
        # so that R1's samples are reproduced unchanged at w = 1.
        idx = np.searchsorted(self.times1, phi)
        idx = np.clip(idx, 0, frames1 - 1)
        for cand in (idx, np.clip(idx - 1, 0, frames1 - 1)):
            near = np.abs(self.times1[cand] - phi) <= 1e-12
            phi[near] = self.times1[cand[near]]
        phi[0], phi[-1] = 0.0, 1.0
        self.phi = phi
        if durations is None:
            d0, d1 = float(frames0 - 1), float(frames1 - 1)
        else:
            d0, d1 = (float(d) for d in durations)
            if not (d0 > 0 and d1 > 0 and math.isfinite(d0) and math.isfinite(d1)):
                raise ShapeSigError(f"durations: expected two positive numbers, got {durations!r}")
        self.durations = (d0, d1)
        total = (1.0 - w) * d0 + w * d1
        # Blended clip time of each grid point, normalized to [0, 1]; strictly increasing.
        v = ((1.0 - w) * d0 * grid + w * d1 * phi) / total
        v[0], v[-1] = 0.0, 1.0
        self.v_grid = v
        if frames is None:
            frames = default_frames(frames0, frames1, w) if durations is None else max(
                2, int(math.floor((1.0 - w) * frames0 + w * frames1 + 0.5 + 1e-9)))
        self.frames = frames
        v_out = uniform_times(frames)
        u = np.interp(v_out, v, grid)
        # Exact knots at the ends and wherever an output time hits a grid time.
        hit = np.searchsorted(v, v_out)
        hit = np.clip(hit, 0, grid.size - 1)
        exact = np.abs(v[hit] - v_out) <= 1e-13
        u[exact] = grid[hit[exact]]
        u[0], u[-1] = 0.0, 1.0
        self.u_out = u

        # Interval bookkeeping: every grid interval lies inside one interval of R0's grid and
        # one of R1's (at phi), where both curves are single geodesics.
        mid = 0.5 * (grid[:-1] + grid[1:])
        self.k0 = np.clip(np.searchsorted(self.times0, mid, side="right") - 1, 0, frames0 - 2)
        mid1 = 0.5 * (phi[:-1] + phi[1:])
        self.k1 = np.clip(np.searchsorted(self.times1, mid1, side="right") - 1, 0, frames1 - 2)
        self.dg = np.diff(grid)
        self.slope = np.diff(phi) / self.dg

    # -- curves on the grid ------------------------------------------------------------------

    def q0_on_grid(self, rel0):
        """SRVT of R0 on the grid from R0's increments rel0 = log(R0[k+1] R0[k]^T) (exact)."""
        dt0 = np.diff(self.times0)
        return srvt_of_velocity((rel0 / dt0[:, None, None])[self.k0], rel0[self.k0])

    def q1_on_grid(self, rel1):
        """SRVT of R1 o phi on the grid: q1(phi) sqrt(phi') (eq. 4.6), exact for piecewise-linear phi."""
        dt1 = np.diff(self.times1)
        eta = (rel1 / dt1[:, None, None])[self.k1] * self.slope[:, None, None]
        return srvt_of_velocity(eta, rel1[self.k1])

    def r0_on_grid(self, R0):
        return geodesic_interpolate(R0, self.times0, self.grid)

    def r1_on_grid(self, R1):
        return geodesic_interpolate(R1, self.times1, self.phi)

    def blend_q(self, q0, q1):
        """(blended curve on the grid in P*, its per-interval increments log(B[k+1] B[k]^T))."""
        w = self.weight
        q = (1.0 - w) * q0 + w * q1
        steps = q * np.linalg.norm(q, axis=-1, keepdims=True) * self.dg[:, None, None]
        return so3.integrate(steps), steps

    def resample(self, Bg, steps):
        """A curve on the grid (with its increments), evaluated at the output frames."""
        return geodesic_interpolate(Bg, self.grid, self.u_out, increments=steps)

    def r0_out(self, R0, rel0):
        """Clip A's own motion in the blended timing (rel0: R0's increments)."""
        return geodesic_interpolate(R0, self.times0, self.u_out, increments=rel0)


def compute_warp(R0, R1, align=True, depth=DEFAULT_DEPTH, penalty=0.0):
    """(warp, elastic distance or None): the DP warp of R1 onto R0, or the identity without align."""
    if not align:
        return identity_warp(), None
    from .elastic import elastic_align

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
    w = _check_weight(weight)
    R0 = as_curve(R0, "R0")
    R1 = as_curve(R1, "R1")
    if R0.shape[1] != R1.shape[1]:
        raise CurveError(f"the curves have {R0.shape[1]} and {R1.shape[1]} joints")
    if R0.shape[0] < 2 or R1.shape[0] < 2:
        raise CurveError("each curve needs at least two frames")
    frames = _check_frames(frames)
    if warp is not None:
        warp, edist = check_warp(warp, strict=True), None
    else:
        warp, edist = compute_warp(R0, R1, align, depth, penalty)
    plan = _Plan(R0.shape[0], R1.shape[0], w, warp, frames, durations)
    rel0 = relative_rotvecs(R0)
    rel1 = relative_rotvecs(R1)
    Bg, steps = plan.blend_q(plan.q0_on_grid(rel0), plan.q1_on_grid(rel1))
    start = _geodesic_start(R0[0], R1[0], w)
    out = plan.resample(Bg, steps) @ start[None]
    if not return_info:
        return out
    from .curves import l2_distance

    R0g = plan.r0_on_grid(move_to_identity(R0))
    R1g = plan.r1_on_grid(move_to_identity(R1))
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


# ---------------------------------------------------------------------------------------------
# root motion


_AXES = {"X": 0, "Y": 1, "Z": 2}


def _parse_up(up):
    """'X'/'Y'/'Z' (optionally signed) or a 3-vector -> unit vector, or None."""
    if up is None:
        return None
    if isinstance(up, str):
        s = up.strip().upper().lstrip("+-")
        if s not in _AXES:
            raise ShapeSigError(f"up_axis: expected X, Y, Z or a 3-vector, got {up!r}")
        v = np.zeros(3)
        v[_AXES[s]] = 1.0
        return v
    v = np.asarray(up, dtype=np.float64).reshape(-1)
    if v.shape != (3,) or not np.all(np.isfinite(v)) or np.linalg.norm(v) < 1e-9:
        raise ShapeSigError(f"up_axis: expected X, Y, Z or a non-zero 3-vector, got {up!r}")
    return v / np.linalg.norm(v)


def estimate_up_axis(root_rotations, root_translations=()):
    """Guess the vertical axis (in the root's parent space) of one or more clips.

    ``root_rotations``: a list of root-rotation curves (frames, 3, 3); ``root_translations``: the
    matching root translations (frames, 3) (or empty). Two cues, pooled over the clips:

    * the vertical is perpendicular to the direction of travel: each clip that travels (net
      displacement more than three times the spread of its positions across it) removes its
      travel direction from the candidates (a second direction only when it is more than about
      20 degrees from the first: then the vertical is their normal);
    * among what is left, the vertical is the axis of the root's largest rotation oscillation
      about its mean orientation (pelvic rotation in gait, turns).

    The result is snapped to the nearest coordinate axis when it lies within 20 degrees of it (the
    usual case for capture data and rigs). A guess: pass ``up_axis`` to ``blend_clips`` when the
    vertical is known. Returns a unit vector.
    """
    S = np.zeros((3, 3))
    for R in root_rotations:
        R = np.asarray(R, dtype=np.float64).reshape(-1, 3, 3)
        r = so3.log(R @ so3.nearest_rotation(R.sum(axis=0)).T)  # about the mean orientation
        S += r.T @ r / max(len(r), 1)
    P = np.eye(3)
    for p in root_translations:
        if p is None:
            continue
        p = np.asarray(p, dtype=np.float64).reshape(-1, 3)
        d = p[-1] - p[0]
        line = p[0] + np.outer(np.linspace(0.0, 1.0, len(p)), d)
        spread = np.sqrt(np.mean(np.sum((p - line) ** 2, axis=1)))
        if np.linalg.norm(d) <= 3.0 * spread or np.linalg.norm(d) < 1e-9:
            continue
        r = P @ d
        if np.linalg.norm(r) < 0.35 * np.linalg.norm(d):
            continue
        r /= np.linalg.norm(r)
        P = P - np.outer(r, r)
        if np.trace(P) < 1.5:
            break
    if np.trace(P) < 1.5:
        # Two travel directions: the vertical is their normal (the one left in P).
        vals, vecs = np.linalg.eigh(P)
    else:
        vals, vecs = np.linalg.eigh(P @ S @ P)
    u = vecs[:, -1]
    if vals[-1] <= 1e-15:
        u = np.array([0.0, 0.0, 1.0])
    axis = int(np.argmax(np.abs(u)))
    if abs(u[axis]) >= math.cos(math.radians(20.0)):
        u = np.zeros(3)
        u[axis] = 1.0
    return u / np.linalg.norm(u)


def _resolve_up(up_axis, a, b, root_a, root_b):
    """Explicit up_axis, else a.meta / b.meta["up_axis"], else Y for Acclaim data, else a guess."""
    for cand in (up_axis, a.meta.get("up_axis"), b.meta.get("up_axis")):
        up = _parse_up(cand)
        if up is not None:
            return up
    if a.meta.get("format") == "acclaim" and b.meta.get("format") == "acclaim":
        return _parse_up("Y")  # the ASF world is Y up
    return estimate_up_axis(
        [a.rotations[:, a.bones.index(root_a)], b.rotations[:, b.bones.index(root_b)]],
        [a.root_translation, b.root_translation])


def _heading_angles(R, up, ref):
    """Heading (twist about ``up``) of rotations R (n, 3, 3), measured on the ``ref`` vector."""
    g = R @ ref
    g = g - np.outer(g @ up, up)
    return np.arctan2(np.cross(ref, g) @ up, g @ ref)


def _rotate_about(up, angles, d):
    """Rotate horizontal vectors d (n, 3) about ``up`` by ``angles`` (n,)."""
    c, s = np.cos(angles)[:, None], np.sin(angles)[:, None]
    return d * c + np.cross(up, d) * s


def _blend_root_path(plan, p0, p1, rot0, rot1, rotb, up):
    """Blended root translation on the grid.

    p0: A's translations (N0, 3); p1: B's (N1, 3). rot0/rot1: the two roots' rotations on the grid
    (G, 3, 3) (R0 and R1 o phi); rotb: the blended root rotation on the grid. The height (component
    along ``up``) is blended directly; horizontal per-interval displacements are expressed in each
    root's heading frame, blended with the weight, turned back with the blended root's heading and
    integrated from the blended start position.
    """
    w = plan.weight
    g0 = np.stack([np.interp(plan.grid, plan.times0, p0[:, i]) for i in range(3)], axis=1)
    g1 = np.stack([np.interp(plan.phi, plan.times1, p1[:, i]) for i in range(3)], axis=1)
    h0, h1 = g0 @ up, g1 @ up
    d0 = np.diff(g0, axis=0)
    d1 = np.diff(g1, axis=0)
    d0 -= np.outer(d0 @ up, up)
    d1 -= np.outer(d1 @ up, up)
    ref = np.eye(3)[int(np.argmin(np.abs(up)))]
    ref = ref - (ref @ up) * up
    ref /= np.linalg.norm(ref)
    a0 = _heading_angles(rot0[:-1], up, ref)
    a1 = _heading_angles(rot1[:-1], up, ref)
    ab = _heading_angles(rotb[:-1], up, ref)
    local = (1.0 - w) * _rotate_about(up, -a0, d0) + w * _rotate_about(up, -a1, d1)
    steps = _rotate_about(up, ab, local)
    start = (1.0 - w) * g0[0] + w * g1[0]
    start_h = start - (start @ up) * up
    path = np.empty_like(g0)
    path[0] = start_h
    np.cumsum(steps, axis=0, out=path[1:])
    path[1:] += start_h
    return path + np.outer((1.0 - w) * h0 + w * h1, up)


def _interp_rows(x_new, x, values):
    return np.stack([np.interp(x_new, x, values[:, i]) for i in range(values.shape[1])], axis=1)


# ---------------------------------------------------------------------------------------------
# clips


def _bone_list(bones):
    if bones is None:
        return None
    if isinstance(bones, str):
        bones = [b.strip() for b in bones.split(",")]
    out = []
    for b in bones:
        b = str(b).strip()
        if b and b not in out:
            out.append(b)
    if not out:
        raise ShapeSigError("bones: the bone subset is empty")
    return out


def blend_fps(a, b):
    """A blend's frame rate: the higher of its sources' (neither source's detail is lost)."""
    return max(float(a.fps), float(b.fps))


def blend_clips(a, b, weight, align=True, depth=DEFAULT_DEPTH, frames=None, bones=None, root="blend", *,
                warp=None, up_axis=None, penalty=0.0, name=None, time_base=True):
    """Blend clip ``a`` (weight 0) with clip ``b`` (weight 1) into a new Clip.

    * Bones are matched by name. Bones only in ``a`` keep A's motion (in the blended timing); bones
      only in ``b`` are dropped; both lists are in ``result.meta["unmatched_bones"]``.
    * ``bones``: blend only this subset (names or a comma-separated string; every name must be in
      both clips); the other bones keep A's motion in the blended timing. The warp is always
      computed on *all* shared bones that move (the timing of the whole body, e.g. foot contacts),
      so a subset blend stays in step with the rest of the body; pass ``warp=`` to override.
    * ``align``/``depth``/``penalty``: the elastic alignment (see ``geodesic_blend``).
    * ``frames``: default ``round(((1 - w) D0 + w D1) fps) + 1``, D the durations in seconds, fps = ``blend_fps``:
      the weighted average of the durations whatever the rates. Frame start, bones and rotation modes are A's.
    * ``time_base``: align on the comparison time base (``prepare.prepare_rotations``); False: as read.
    * ``root="blend"``: the root translation is blended time-aligned: its height (along the up axis)
      directly, its horizontal per-frame displacements in the root's heading frame (twist of the
      root rotation about the up axis), then integrated from the blended start position, so a blend
      of two forward locomotions moves forward. ``root="a"``: A's root path (in the blended timing).
      ``up_axis``: 'X', 'Y', 'Z' or a vector in the root's parent space; default
      ``a.meta["up_axis"]``, else estimated from the root rotations (``estimate_up_axis``).
      When only one clip has a root translation, or the root bone is not shared, A's path is used.

    ``result.meta`` holds ``weight``, ``sources``, ``blended_bones``, ``unmatched_bones``,
    ``warp``, ``warp_bones``, ``elastic_distance`` (None without align), ``root_mode`` and
    ``up_axis``.
    """
    w = _check_blend_inputs(a, b, weight, root)
    frames = _check_frames(frames)
    shared, blended = _blended_bones(a, b, bones)
    ia = {x: i for i, x in enumerate(a.bones)}
    ib = {x: i for i, x in enumerate(b.bones)}
    warp_bones = _warp_bones(a, b, shared, ia, ib)
    given_warp = warp is not None
    if given_warp:
        warp, edist = check_warp(warp, strict=True), None
    else:
        wa = [ia[x] for x in warp_bones]
        wb = [ib[x] for x in warp_bones]
        Ra, Rb = a.rotations[:, wa], b.rotations[:, wb]
        if time_base:  # a warp maps normalized times and the preparation keeps durations: it applies as is
            Ra, Rb = prepare_rotations(Ra, a.fps), prepare_rotations(Rb, b.fps)
        warp, edist = compute_warp(Ra, Rb, align, depth, penalty)

    d0 = (a.frames - 1) / float(a.fps)
    d1 = (b.frames - 1) / float(b.fps)
    fps = blend_fps(a, b)
    if frames is None:
        frames = default_frames(a.frames, b.frames, w, d0, d1, fps)
    plan = _Plan(a.frames, b.frames, w, warp, frames, (d0, d1))

    # Every bone of A in the blended timing, then the blended bones replaced.
    rel_a = relative_rotvecs(a.rotations)
    out = plan.r0_out(a.rotations, rel_a)
    ba = [ia[x] for x in blended]
    bb = [ib[x] for x in blended]
    rel_b = relative_rotvecs(b.rotations[:, bb])
    Bg, steps = plan.blend_q(plan.q0_on_grid(rel_a[:, ba]), plan.q1_on_grid(rel_b))
    start = _geodesic_start(a.rotations[0, ba], b.rotations[0, bb], w)
    out[:, ba] = plan.resample(Bg, steps) @ start[None]
    translation, root_mode, up = _blend_translation(plan, a, b, ia, ib, blended, Bg, start, root, up_axis)

    only_a = [x for x in a.bones if x not in ib]
    only_b = [x for x in b.bones if x not in ia]
    meta = {
        "weight": w,
        "sources": (a.name, b.name),
        "blended_bones": tuple(blended),
        "unmatched_bones": tuple(only_a + only_b),
        "unmatched_a": tuple(only_a),
        "unmatched_b": tuple(only_b),
        "warp": warp,
        "warp_bones": tuple(warp_bones),
        "elastic_distance": edist,
        "aligned": bool(align) or given_warp,
        "root_mode": root_mode,
        "up_axis": None if up is None else tuple(float(x) for x in up),
        "time_map": plan.u_out,
    }
    if a.meta.get("rotation_space") is not None:
        # the blend is in A's rotation space (write_action converts an armature-space blend back to pose)
        meta["rotation_space"] = a.meta["rotation_space"]
    return Clip(
        name=name if name is not None else blend_name(a.name, b.name, w),
        bones=a.bones,
        rotations=out,
        fps=fps,
        frame_start=a.frame_start,
        root_translation=translation,
        root_bone=a.root_bone,
        rotation_modes=a.rotation_modes,
        source=f"blend of {a.name} and {b.name}",
        meta=meta,
    )


def _check_blend_inputs(a, b, weight, root):
    """The checked weight; ShapeSigError for clips of different rotation spaces, a bad root mode or a clip of
    fewer than two frames."""
    if not isinstance(a, Clip) or not isinstance(b, Clip):
        raise ShapeSigError("blend_clips: expected two Clip objects")
    space_a, space_b = a.meta.get("rotation_space"), b.meta.get("rotation_space")
    if space_a is not None and space_b is not None and space_a != space_b:
        raise ShapeSigError(f"clips {a.name!r} and {b.name!r} have rotations in different spaces "
                            f"({space_a} and {space_b}); read both in the same space")
    w = _check_weight(weight)
    if root not in ("blend", "a"):
        raise ShapeSigError(f"root: expected 'blend' or 'a', got {root!r}")
    for c in (a, b):
        if c.frames < 2:
            raise ShapeSigError(f"clip {c.name!r}: needs at least two frames, has {c.frames}")
    return w


def _blended_bones(a, b, bones):
    """(shared bones, the bones to blend: all shared or the subset, in A's order)."""
    shared = shared_bones(a, b)
    if not shared:
        raise ShapeSigError(f"clips {a.name!r} and {b.name!r} share no bones")
    subset = _bone_list(bones)
    if subset is None:
        return shared, list(shared)
    missing = [x for x in subset if x not in shared]
    if missing:
        raise ShapeSigError(f"bone(s) {', '.join(missing)} not in both clips {a.name!r} and {b.name!r}")
    return shared, [x for x in a.bones if x in subset]


def _warp_bones(a, b, shared, ia, ib):
    """The bones the alignment is computed on: every shared bone that moves in at least one clip."""
    sa = [ia[x] for x in shared]
    sb = [ib[x] for x in shared]
    moving = ~(still_joints(a.rotations[:, sa]) & still_joints(b.rotations[:, sb]))
    return [x for x, m in zip(shared, moving) if m] or list(shared)


def _blend_translation(plan, a, b, ia, ib, blended, Bg, start, root, up_axis):
    """(root translation of the blend, root mode used, up axis or None): A's path in the blended timing, or with
    ``root="blend"`` (both clips move their shared root) the blended path of ``_blend_root_path``."""
    translation = None
    if a.root_translation is not None:
        translation = _interp_rows(plan.u_out, plan.times0, a.root_translation)
    root_a = a.root_bone if a.root_bone in ia else None
    root_b = b.root_bone if b.root_bone in ib else None
    if not (root == "blend" and a.root_translation is not None and b.root_translation is not None
            and root_a is not None and root_b is not None):
        return translation, "a", None
    rot0 = plan.r0_on_grid(a.rotations[:, [ia[root_a]]])[:, 0]
    rot1 = plan.r1_on_grid(b.rotations[:, [ib[root_b]]])[:, 0]
    if root_a in blended:
        rotb = Bg[:, blended.index(root_a)] @ start[blended.index(root_a)]
    else:
        rotb = rot0
    up = _resolve_up(up_axis, a, b, root_a, root_b)
    path = _blend_root_path(plan, a.root_translation, b.root_translation, rot0, rot1, rotb, up)
    return _interp_rows(plan.u_out, plan.grid, path), "blend", up


def blend_clip_series(a, b, weights, align=True, depth=DEFAULT_DEPTH, frames=None, bones=None, root="blend", *,
                      up_axis=None, penalty=0.0, progress=None, time_base=True):
    """``blend_clips`` at several weights with one warp (computed once). ``progress(i, n)`` is called
    after each blend. Returns a list of Clips."""
    weights = [_check_weight(x) for x in weights]
    if not weights:
        raise ShapeSigError("weights: at least one weight is needed")
    first = blend_clips(a, b, weights[0], align, depth, frames, bones, root, up_axis=up_axis,
                        penalty=penalty, time_base=time_base)
    out = [first]
    if progress is not None:
        progress(1, len(weights))
    warp = first.meta["warp"]
    for i, x in enumerate(weights[1:], start=2):
        c = blend_clips(a, b, x, align, depth, frames, bones, root, warp=warp, up_axis=up_axis,
                        penalty=penalty)
        c.meta["elastic_distance"] = first.meta["elastic_distance"]
        c.meta["aligned"] = first.meta["aligned"]
        out.append(c)
        if progress is not None:
            progress(i, len(weights))
    return out


__all__.append("blend_clip_series")
__all__.append("estimate_up_axis")
