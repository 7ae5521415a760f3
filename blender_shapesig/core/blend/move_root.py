"""Move the root: the blended root translation of a blend (height blended, horizontal displacements in each
source's heading frame) and the up axis it needs (given, from the clips' metadata, or estimated)."""

import math

import numpy as np

from ..geometry import so3
from ..errors import ShapeSigError

__all__ = ["estimate_up_axis", "resolve_up", "blend_root_path", "interp_rows"]

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


def resolve_up(up_axis, clips, roots):
    """Explicit up_axis, else the clips' meta["up_axis"] (first given), else Y for Acclaim data, else a guess
    (``estimate_up_axis`` on the ``roots`` bones of the clips)."""
    for cand in [up_axis] + [c.meta.get("up_axis") for c in clips]:
        up = _parse_up(cand)
        if up is not None:
            return up
    if all(c.meta.get("format") == "acclaim" for c in clips):
        return _parse_up("Y")  # the ASF world is Y up
    return estimate_up_axis([c.rotations[:, c.bones.index(r)] for c, r in zip(clips, roots)],
                            [c.root_translation for c in clips])


def _heading_angles(R, up, ref):
    """Heading (twist about ``up``) of rotations R (n, 3, 3), measured on the ``ref`` vector."""
    g = R @ ref
    g = g - np.outer(g @ up, up)
    return np.arctan2(np.cross(ref, g) @ up, g @ ref)


def _rotate_about(up, angles, d):
    """Rotate horizontal vectors d (n, 3) about ``up`` by ``angles`` (n,)."""
    c, s = np.cos(angles)[:, None], np.sin(angles)[:, None]
    return d * c + np.cross(up, d) * s


def blend_root_path(plan, ps, rots, rotb, up, W):
    """Blended root translation on the grid.

    ps: the sources' translations (N_i, 3); rots: their roots' rotations on the grid (G, 3, 3) (R_i o phi_i);
    rotb: the blended root rotation on the grid; W: one weight per source. The height (component along ``up``)
    is blended directly; horizontal per-interval displacements are expressed in each root's heading frame,
    blended with the weights, turned back with the blended root's heading and integrated from the blended
    start position.
    """
    gs = [interp_rows(phi, t, p) for phi, t, p in zip(plan.phis, plan.times, ps)]
    ref = np.eye(3)[int(np.argmin(np.abs(up)))]
    ref = ref - (ref @ up) * up
    ref /= np.linalg.norm(ref)
    local = start = height = None
    for w, g, rot in zip(W, gs, rots):
        d = np.diff(g, axis=0)
        d -= np.outer(d @ up, up)
        term = w * _rotate_about(up, -_heading_angles(rot[:-1], up, ref), d)
        local = term if local is None else local + term
        start = w * g[0] if start is None else start + w * g[0]
        height = w * (g @ up) if height is None else height + w * (g @ up)
    steps = _rotate_about(up, _heading_angles(rotb[:-1], up, ref), local)
    start_h = start - (start @ up) * up
    path = np.empty_like(gs[0])
    path[0] = start_h
    np.cumsum(steps, axis=0, out=path[1:])
    path[1:] += start_h
    return path + np.outer(height, up)


def interp_rows(x_new, x, values):
    return np.stack([np.interp(x_new, x, values[:, i]) for i in range(values.shape[1])], axis=1)
