"""Transitions between clips: ``best_cuts(a, b)`` ranks where A can hand over to B (``cuts``: motion graphs' cost
over a short window after a rigid fit on the ground, local minima), ``inbetween(before, after, frames)`` makes the
frames of a gap (``inbetween``: the velocity-carrying geodesic; with ``library``, ``bridge``: a library segment
that meets both ends), ``transition(a, b)`` joins A up to its cut, the generated frames and B from its cut, with B
moved on the ground so that it continues where A goes. Clips of any rigs the bone maps join; the result is on A's
skeleton and frame rate. See docs/transitions.md.
"""

from dataclasses import replace

import numpy as np

from ..clip.skeleton import from_aligned, rest_of, root_translation_from_heads, up_vector
from ..errors import ShapeSigError, check_integer
from ..geometry import so3
from .body import Body, aligned_and_root, on_rig
from .cuts import Cut, ground_fit, pair_cost, rank_cuts
from .inbetween import geodesic_gap, seam_velocities

__all__ = ["Cut", "best_cuts", "inbetween", "transition", "DEFAULT_SECONDS", "MAX_FRAMES"]

DEFAULT_SECONDS = 0.3  # the generated frames of a transition when not given
MAX_FRAMES = 10_000


def best_cuts(a, b, *, top=5):
    """The ``top`` best places where clip ``a`` can hand over to clip ``b``, best first: ``Cut``s with ``a_frame``,
    ``b_frame`` (0-based frame indices of each clip) and ``cost`` (leg lengths; ``cuts`` module)."""
    from ..blas import one_blas_thread

    top = check_integer(top, "top", 1)
    with one_blas_thread():  # a few mid-sized products: OpenBLAS's threads only cost here
        return rank_cuts(Body(a), Body(b), top)


def _clip_from(rig, X, root, name, frame_start, meta, translated=None):
    """A clip on ``rig``'s skeleton from world-aligned rotations and root heads (a root translation when ``rig`` has
    one, or ``translated``)."""
    rest = rest_of(rig)
    R = from_aligned(rig, X)
    rt = None
    if (rig.root_translation is not None if translated is None else translated) and rest.root is not None:
        rt = root_translation_from_heads(rig, rest, root)
    base = {k: v for k, v in rig.meta.items() if k not in ("frame_numbers", "trim", "range", "cycle")}
    return replace(rig, name=name, rotations=R, root_translation=rt, frame_start=frame_start, meta=dict(base, **meta))


def inbetween(before, after, frames, *, library=None):
    """A Clip of exactly ``frames`` generated frames between ``before``'s last frame and ``after``'s first, on
    ``before``'s skeleton and frame rate, root translation included (``before + result + after`` plays on).
    Without ``library``: the velocity-carrying geodesic (``inbetween.geodesic_gap``); with it (clips, paths of
    clips and folders, or a ``bridge.Bridges``): the best library segment (``bridge``), the geodesic when no clip
    has the joints. ``meta["inbetween"]`` says which was made."""
    frames = check_integer(frames, "frames", 1, maximum=MAX_FRAMES)
    if before.frames < 1 or after.frames < 1:
        raise ShapeSigError("in-betweening needs a frame before the gap and one after it")
    after = on_rig(after, before)
    X0, p0 = aligned_and_root(before)
    X1, p1 = aligned_and_root(after)
    made = None
    if library is not None:
        from .bridge import as_bridges

        got = as_bridges(library, before.fps).fill(before, after, frames)
        if got is not None:
            X, root, info = got
            made = dict(info, generator="bridge")
    if made is None:
        w0, v0 = seam_velocities(X0, p0, before.fps, True)
        w1, v1 = seam_velocities(X1, p1, before.fps, False)
        X, root = geodesic_gap(X0[-1], p0[-1], w0, v0, X1[0], p1[0], w1, v1, frames, before.fps)
        made = {"generator": "geodesic"}
    X = _planted(before, X0, p0, X, root, X1, p1, steps=made["generator"] == "geodesic")
    return _clip_from(before, X, root, f"{before.name}_to_{after.name}", before.frame_end + 1, {"inbetween": made})


KNOWN_SECONDS = 0.5  # known frames on each side the planted feet look at


def _planted(rig, X0, p0, X, root, X1, p1, steps=True):
    """The generated rotations X with the heels planted where they are down (``plant.plant_gap``; with ``steps``
    a heel the gap would slide over the floor steps: the geodesic's, which cannot step; a bridge's frames step as
    its library does), looking at up to KNOWN_SECONDS of the known frames on each side."""
    from .plant import plant_gap

    k = max(1, int(round(KNOWN_SECONDS * rig.fps)))
    X0, p0, X1, p1 = X0[-k:], p0[-k:], X1[:k], p1[:k]
    seq = np.concatenate([X0, X, X1])
    path = np.concatenate([p0, root, p1])
    return plant_gap(rig, seq, path, len(X0), len(X0) + len(X) - 1, steps)[len(X0):len(X0) + len(X)]


def _check_cut(cut, a, b):
    try:
        i, j = (int(x) for x in cut)
    except (TypeError, ValueError):
        raise ShapeSigError(f"cut: expected a pair (A frame, B frame), got {cut!r}") from None
    if not 0 <= i < a.frames:
        raise ShapeSigError(f"cut: frame {i} is outside clip {a.name!r} (0..{a.frames - 1})")
    if not 0 <= j < b.frames:
        raise ShapeSigError(f"cut: frame {j} is outside clip {b.name!r} (0..{b.frames - 1})")
    return i, j


def place(a, b, i, j, frames):
    """``b`` (on ``a``'s rig and rate) turned about up and moved on the ground so that its window at frame ``j``
    lies on ``a``'s at ``i`` (``cuts.ground_fit``), then on by the root's travel over the ``frames + 1`` steps of
    the gap (the mean of both roots' ground velocities there): B continues where A goes. When one of them stands
    (its root slower than STANDING) and a heel is down at both cut frames, B is moved on so that heel comes down on
    A's spot instead (``_planted_shift``: standing into a walk keeps the standing foot). Returns (clip, info)."""
    ba, bb = Body(a), Body(b)
    angle, shift = ground_fit(ba, bb, i, j)
    up = up_vector(a)
    G = ba.basis
    T = so3.exp(angle * up)
    X, root = aligned_and_root(b)
    rest = rest_of(b)
    tops = np.flatnonzero(rest.ancestor < 0)
    X = X.copy()
    X[:, tops] = T[None, None] @ X[:, tops]
    root = root @ T.T + ba.leg * (shift[0] * G[0] + shift[1] * G[1])
    _Xa, ra = aligned_and_root(a)

    def ground_velocity(path, k):
        k0, k1 = max(k - 1, 0), min(k + 1, len(path) - 1)
        v = (path[k1] - path[k0]) / max(k1 - k0, 1)
        return v - (v @ up) * up

    va, vb = ground_velocity(ra, i), ground_velocity(root, j)
    travel = 0.5 * (va + vb) * (frames + 1)
    translated = a.root_translation is not None
    out = _clip_from(b, X, root, b.name, b.frame_start, {}, translated=translated)
    if min(np.linalg.norm(va), np.linalg.norm(vb)) * a.fps < STANDING * ba.leg:  # one of them stands
        shared = _planted_shift(a, out, i, j, ba, bb, up)
        if shared is not None:
            turn, travel = shared
            X[:, tops] = turn[None, None] @ X[:, tops]
            root = root @ turn.T
            angle = angle + float(so3.heading(turn, up))
    root = root + travel
    out = _clip_from(b, X, root, b.name, b.frame_start, {}, translated=translated)
    return out, {"turn_degrees": round(float(np.degrees(angle)), 4),
                 "moved": [round(float(x), 6) for x in (root[j] - aligned_and_root(b)[1][j])]}


STANDING = 0.25  # leg lengths per second: a root slower than this on the ground stands
MAX_FOOT_TURN = np.radians(30.0)  # the most B is turned about up to put its planted feet on A's


def _planted_shift(a, b, i, j, ba, bb, up):
    """(turn (3, 3) about up through the origin, move (3,) on the ground) that put ``b``'s planted feet at frame
    ``j`` on ``a``'s at ``i``: the least-squares rigid fit on the ground of the heels and balls of the feet whose
    heel is down in both (``Body.contacts``), so a foot's heading matches as well as its heel (else its ball slides
    as the foot turns over the gap); the move alone when the fit would turn more than MAX_FOOT_TURN. None when no
    heel is down in both or the move is longer than half a leg (then not the same stance)."""
    from .contacts import feet_positions, legs_of

    down = [side for side, col in (("L", 0), ("R", 2)) if ba.contacts[i, col] and bb.contacts[j, col]]
    if not down:
        return None
    try:
        pa, pb = feet_positions(a, legs_of(a)), feet_positions(b, legs_of(b))
    except ShapeSigError:
        return None
    flat = lambda v: v - np.outer(v @ up, up)  # noqa: E731
    qa = flat(np.array([pa[side][point][i] for side in down for point in ("heel", "ball")]))
    qb = flat(np.array([pb[side][point][j] for side in down for point in ("heel", "ball")]))
    ca, cb = qa.mean(axis=0), qb.mean(axis=0)
    # the turn about up that best lays B's points (about their mean) on A's: 2-D Procrustes, atan2 of the summed
    # cross (about up) and dot products of the centred pairs
    pa_c, pb_c = qa - ca, qb - cb
    theta = float(np.arctan2(np.sum(np.cross(pb_c, pa_c) @ up), np.sum(pb_c * pa_c)))
    if abs(theta) > MAX_FOOT_TURN:
        theta = 0.0
    turn = so3.exp(theta * up)
    d = flat((ca - turn @ cb)[None])[0]
    return (turn, d) if np.linalg.norm(d) <= 0.5 * ba.leg else None


def transition(a, b, *, cut=None, frames=None, library=None):
    """The joined clip: ``a`` up to its cut frame, ``frames`` generated frames (``inbetween``; default
    DEFAULT_SECONDS of A), ``b`` from its cut frame on, B put on A's rig and rate and moved so its root position
    and heading continue where A goes (``place``); B's timing is kept. ``cut``: an (A frame, B frame) pair of
    0-based frame indices, None for the best (``best_cuts``). ``meta["transition"]`` records the cut, the
    frames and the generator."""
    if cut is None:
        found = best_cuts(a, b, top=1)
        if not found:
            raise ShapeSigError(f"no place found where {a.name!r} can hand over to {b.name!r}")
        chosen = found[0]
    else:
        i, j = _check_cut(cut, a, b)
        chosen = Cut(i, j, pair_cost(Body(a), Body(b), i, j))
    i, j = chosen.a_frame, chosen.b_frame
    if frames is None:
        frames = max(1, int(round(DEFAULT_SECONDS * a.fps)))
    frames = check_integer(frames, "frames", 1, maximum=MAX_FRAMES)
    onto = on_rig(b, a)
    jj = min(int(round(j * a.fps / float(b.fps))), onto.frames - 1)
    placed, where = place(a, onto, i, jj, frames)
    before = a.crop(a.frame_start, a.frame_start + i)
    after = placed.crop(placed.frame_start + jj, None)
    gap = inbetween(before, after, frames, library=library)
    R = np.concatenate([before.rotations, gap.rotations, after.rotations])
    rt = None
    if a.root_translation is not None:
        rt = np.concatenate([before.root_translation, gap.root_translation, after.root_translation])
    info = {"cut": chosen.as_dict(), "b_frame_on_a_rate": jj, "frames": frames, "a_frames": i + 1,
            "b_frames": after.frames, **where, "inbetween": gap.meta["inbetween"]}
    return replace(gap, name=f"{a.name}_to_{b.name}", rotations=R, root_translation=rt, frame_start=a.frame_start,
                   meta=dict(gap.meta, transition=info))
