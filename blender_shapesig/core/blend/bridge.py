"""A bridge from the library (motion matching for an offline tool): the library segment whose first frame matches
the last known pose (pose relative to the root in its heading frame, joint and root velocities) and whose last
frame matches the target's, with the root's displacement and turn between them matching the gap's, among segment
lengths of 0.8 to 1.25 times the gap (a uniform time warp of the segment onto it); the segment is turned and moved
onto the last known pose and offset (per joint on SO(3), the root linearly, faded with smoothstep weights) so it
meets both ends exactly, and carries the last known velocities in over its first CARRY_SECONDS (``_carry``); the
best segments (one per clip) and the velocity-carrying geodesic (``inbetween``, as a candidate of cost
GEODESIC_COST: it takes over when no segment is close) are averaged with weights 1 / (cost + COST_FLOOR)
(``Bridges.fill``). See docs/transitions.md, "Bridge from the library".
"""

import os
from dataclasses import replace

import numpy as np

from ..errors import ShapeSigError
from ..geometry import so3
from .body import Body, aligned_and_root, on_rig, resample, same_rig
from .inbetween import geodesic_gap, seam_velocities

__all__ = ["Bridges", "as_bridges", "STRETCHES"]

STRETCHES = (0.8, 0.9, 1.0, 1.1, 1.25)  # segment lengths tried, times the gap
VELOCITY_SECONDS = 0.1   # velocities weigh as the displacement over this time
MOVE_WEIGHT = 1.0        # weight of the root displacement over the gap (leg lengths)
TURN_WEIGHT = 0.5        # weight of the turn over the gap (radians)
STRETCH_WEIGHT = 0.02    # cost of a stretch r away from 1: this times log(r)^2
HISTORY = (3, 6, 9)      # frames before the seam matched too (the motion leading into the gap)
HISTORY_WEIGHT = 0.5
BRIDGES = 10             # the best segments (of as many clips) averaged, weighted 1 / (cost + COST_FLOOR)
COST_FLOOR = 0.01
GEODESIC_COST = 1.0      # the velocity-carrying geodesic joins the average as a candidate of this cost
CARRY_SECONDS = 0.5      # each segment carries the context's last velocity in over at most this time


def _features(body, joints):
    """(frames, d): per frame, the joints relative to the root in the root's heading frame, their velocities and
    the root's velocity in that frame (times VELOCITY_SECONDS), and the root's height (leg lengths)."""
    idx = [body.joints.index(j) for j in joints]
    rel = body.points[:, idx] - body.root[:, None]
    c, s = np.cos(body.yaw), np.sin(body.yaw)
    x = c[:, None] * rel[..., 0] + s[:, None] * rel[..., 1]
    y = -s[:, None] * rel[..., 0] + c[:, None] * rel[..., 1]
    pose = np.stack([x, y, rel[..., 2]], axis=-1).reshape(body.frames, -1)
    dv = np.gradient(pose, axis=0) if body.frames > 1 else np.zeros_like(pose)
    dr = np.gradient(body.root, axis=0) if body.frames > 1 else np.zeros_like(body.root)
    rv = np.stack([c * dr[:, 0] + s * dr[:, 1], -s * dr[:, 0] + c * dr[:, 1], dr[:, 2]], axis=1)
    k = VELOCITY_SECONDS * body.fps
    return np.concatenate([pose, k * dv, k * rv, body.root[:, 2:3]], axis=1)


def key_of(joints):
    return tuple(joints)


def _seam_feature(body, joints, at_end):
    """(feature, mask) of a clip's last (``at_end``) or first frame, velocities from the two frames there; the
    mask leaves the velocities out of a one-frame clip (unknown)."""
    f = _features(body, joints)
    mask = np.ones(f.shape[1])
    if body.frames < 2:
        n = 3 * len(joints)
        mask[n:2 * n + 3] = 0.0
    return (f[-1] if at_end else f[0]), mask


class Bridges:
    """A bridge library: clips (``Clip``s) at one frame rate with their bodies (``body.Body``); features per joint
    set are computed once."""

    def __init__(self, clips, fps):
        self.fps = float(fps)
        self.clips = [resample(c, fps) for c in clips if c.frames >= 2]
        self.bodies = []
        for c in self.clips:
            try:
                self.bodies.append(Body(c))
            except ShapeSigError:
                self.bodies.append(None)
        self._cache = {}

    def _table(self, joints):
        """The library's frames as one table for ``joints``: features (n, d), root (n, 3), yaw (n,), clip index and
        the table row of its clip's first frame (n,); None when no clip has the joints."""
        key = tuple(joints)
        if key not in self._cache:
            rows = [(k, b) for k, b in enumerate(self.bodies) if b is not None and all(j in b.joints for j in joints)]
            if not rows:
                self._cache[key] = None
            else:
                starts = np.cumsum([0] + [b.frames for _k, b in rows])[:-1]
                self._cache[key] = (np.concatenate([_features(b, joints) for _k, b in rows]),
                                    np.concatenate([b.root for _k, b in rows]),
                                    np.concatenate([b.yaw for _k, b in rows]),
                                    np.concatenate([np.full(b.frames, k) for k, b in rows]),
                                    np.concatenate([np.full(b.frames, s0) for s0, (_k, b) in zip(starts, rows)]))
        return self._cache[key]

    def _distances(self, key, F, q, mask):
        """(n,) squared distances of the table's rows to ``q`` over the features ``mask`` keeps (0/1 weights):
        ``|F|^2 m - 2 F (m q) + |q|^2 m`` with the rows' squared norms computed once per mask (a product, not a
        difference of every row)."""
        norms = self._cache.setdefault(("norms",) + key, {})
        mk = mask.tobytes()
        if mk not in norms:
            norms[mk] = (F * F) @ mask
        mq = mask * q
        return np.maximum(norms[mk] - 2.0 * (F @ mq) + float(q @ mq), 0.0)

    def search(self, before, after, frames, joints, count=1):
        """[(clip index, start frame, length in frames, cost)] of the best segments (one per clip, the ``count``
        best clips, best first) for a gap of ``frames`` between bodies ``before`` (last frame) and ``after`` (first
        frame); empty when no library clip has the joints. Every clip, start and length at once on the table."""
        table = self._table(joints)
        if table is None:
            return []
        F, root, yaw, clip, first = table
        (q0, m0), (q1, m1) = _seam_feature(before, joints, True), _seam_feature(after, joints, False)
        start_cost = self._distances(key_of(joints), F, q0, m0)
        if before.frames > 1:
            past = _features(before, joints)
            rows = np.arange(len(F))
            ones = np.ones(F.shape[1])
            for d in (d for d in HISTORY if d < before.frames):  # the known frames before the seam
                near = self._distances(key_of(joints), F, past[-1 - d], ones)
                start_cost = start_cost + HISTORY_WEIGHT * near[np.maximum(rows - d, first)]
        end_cost = self._distances(key_of(joints), F, q1, m1)
        move = after.root[0] - before.root[-1]
        c, s = np.cos(before.yaw[-1]), np.sin(before.yaw[-1])
        dq = np.array([c * move[0] + s * move[1], -s * move[0] + c * move[1], move[2]])
        dyaw = after.yaw[0] - before.yaw[-1]
        lengths = sorted({max(1, int(round((frames + 1) * r))) for r in STRETCHES})
        costs = np.full((len(lengths), len(F)), np.inf)
        for row, L in enumerate(lengths):
            if L >= len(F):
                continue
            i = np.arange(len(F) - L)
            same = clip[i] == clip[i + L]
            d = root[i + L] - root[i]
            cy, sy = np.cos(yaw[i]), np.sin(yaw[i])
            local = np.stack([cy * d[:, 0] + sy * d[:, 1], -sy * d[:, 0] + cy * d[:, 1], d[:, 2]], axis=1)
            turn = np.angle(np.exp(1j * (yaw[i + L] - yaw[i] - dyaw)))
            cost = (start_cost[i] + end_cost[i + L] + MOVE_WEIGHT * np.sum((local - dq) ** 2, axis=1)
                    + TURN_WEIGHT * turn ** 2 + STRETCH_WEIGHT * np.log(L / (frames + 1.0)) ** 2)
            costs[row, :len(i)] = np.where(same, cost, np.inf)
        best = np.min(costs, axis=0)
        starts = np.flatnonzero(np.r_[True, clip[1:] != clip[:-1]])
        ends = np.r_[starts[1:], len(F)]
        per_clip = np.minimum.reduceat(best, starts)
        found = []
        for c in np.argsort(per_clip, kind="stable")[:count]:
            if not np.isfinite(per_clip[c]):
                break
            i = starts[c] + int(np.argmin(best[starts[c]:ends[c]]))
            L = lengths[int(np.argmin(costs[:, i]))]
            found.append((int(clip[i]), int(i - first[i]), L, float(best[i])))
        return found

    def fill(self, before, after, frames):
        """(X (frames, bones, 3, 3), root (frames, 3), info) on ``before``'s skeleton (``after`` already on it): the
        module docstring's bridge; None when the library has no clip with the joints of ``before``."""
        from .make import sample_at

        bb, ba = Body(before), Body(after)
        joints = [j for j in bb.joints if j in ba.joints]
        from ..blas import one_blas_thread

        with one_blas_thread():  # matrix-vector products: OpenBLAS's threads only cost here
            found = self.search(bb, ba, frames, joints, BRIDGES)
        if not found:
            return None
        X0, p0 = aligned_and_root(before)
        X1, p1 = aligned_and_root(after)
        w0, v0 = seam_velocities(X0, p0, before.fps, True)
        rots, roots = [], []
        for k, start, length, _cost in found:
            src = self.clips[k]
            step = length / (frames + 1.0)
            lead = 1 if start >= step else 0  # the source frame before the start, when the clip has it
            seg = sample_at(src, np.linspace(start - lead * step, start + length, frames + 2 + lead))
            if same_rig(before, src):
                X, root = aligned_and_root(seg)
                root = root * (bb.leg / self.bodies[k].leg)
            else:
                X, root = aligned_and_root(on_rig(replace(seg, fps=before.fps), before))
            X, root = _meet(before, X, root, X0[-1], p0[-1], X1[0], p1[0], lead)
            if w0 is not None:
                X, root = _carry(X, root, lead, w0, v0, before.fps)
            rots.append(X[lead + 1:-1])
            roots.append(root[lead + 1:-1])
        costs = [c for *_x, c in found]
        if GEODESIC_COST is not None:
            w1, v1 = seam_velocities(X1, p1, before.fps, False)
            X, root = geodesic_gap(X0[-1], p0[-1], w0, v0, X1[0], p1[0], w1, v1, frames, before.fps)
            rots.append(X)
            roots.append(root)
            costs.append(GEODESIC_COST)
        w = np.array([1.0 / (c + COST_FLOOR) for c in costs])
        w /= w.sum()
        X = so3.nearest_rotation(np.einsum("k,k...->...", w, np.array(rots))) if len(rots) > 1 else rots[0]
        root = np.einsum("k,k...->...", w, np.array(roots))
        k, start, length, cost = found[0]
        info = {"clip": self.clips[k].name, "source": self.clips[k].source, "start": int(start),
                "frames": int(length), "cost": round(cost, 6), "segments": len(found)}
        return X, root, info


def _meet(rig, X, root, X0, p0, X1, p1, lead=0):
    """The segment (``lead`` poses before its start, then frames + 2 poses) turned about up and moved so its start's
    (``X[lead]``) root heading and position are the last known pose's, then offset to meet X0, p0 and X1, p1 exactly
    (smoothstep fade from the start; the poses before it take the start's offset)."""
    from ..clip.skeleton import rest_of, up_vector

    rest = rest_of(rig)
    up = up_vector(rig)
    tops = np.flatnonzero(rest.ancestor < 0)
    r = rest.root if rest.root is not None else int(tops[0])
    angle = float(so3.heading(X0[r], up) - so3.heading(X[lead, r], up))
    T = so3.exp(angle * up)
    X = X.copy()
    X[:, tops] = T[None, None] @ X[:, tops]
    root = (root - root[lead]) @ T.T + p0
    s = np.arange(len(X) - lead) / float(len(X) - lead - 1)
    w = np.r_[np.zeros(lead), s * s * (3.0 - 2.0 * s)]
    d0 = so3.log(np.swapaxes(X[lead], -1, -2) @ X0)
    d1 = so3.log(np.swapaxes(X[-1], -1, -2) @ X1)
    X = X @ so3.exp((1.0 - w)[:, None, None] * d0[None] + w[:, None, None] * d1[None])
    root = root + (1.0 - w)[:, None] * (p0 - root[lead]) + w[:, None] * (p1 - root[-1])
    return X, root


def _carry(X, root, lead, w0, v0, fps):
    """The met segment (``_meet``) carrying the context's last body velocities ``w0`` and root velocity ``v0`` in:
    ``X exp(f0(t) (w0 - ws))``, ``root + f0(t) (v0 - vs)``, ws and vs the segment's own velocities into its start
    (from the pose before it: equal to the context's when the library holds the take, which then comes back as it
    is), or out of it without a pose before (``lead`` 0: a segment at its clip's first frame), and
    ``f0 = t (1 - t/T)^2`` (zero after T = min(the gap, CARRY_SECONDS); f0(0) = 0, f0'(0) = 1: generator 1's start
    term, undamped)."""
    ws, vs = seam_velocities(X[:2], root[:2], fps, False)
    t = np.maximum(np.arange(len(X)) - lead, 0) / float(fps)
    f0 = t * (1.0 - np.minimum(t / min(t[-1], CARRY_SECONDS), 1.0)) ** 2
    return X @ so3.exp(f0[:, None, None] * (w0 - ws)[None]), root + f0[:, None] * (v0 - vs)[None]


def as_bridges(library, fps):
    """``library`` as ``Bridges`` at ``fps``: a ``Bridges`` (re-used when at that rate), clips, or paths of clip files
    and folders (read on their own rigs, ``core.io.sources``; unreadable files skipped)."""
    if isinstance(library, Bridges):
        return library if abs(library.fps - fps) < 1e-9 else Bridges(library.clips, fps)
    if isinstance(library, (str, os.PathLike)):
        library = [library]
    items = list(library)
    clips = [x for x in items if not isinstance(x, (str, os.PathLike))]
    paths = [x for x in items if isinstance(x, (str, os.PathLike))]
    if paths:
        from ..io.sources import discover, read

        for spec in discover(paths):
            try:
                clips.extend(read(spec, bone_map="none"))
            except ShapeSigError:
                continue
    if not clips:
        raise ShapeSigError("the bridge library holds no clip")
    return Bridges(clips, fps)
