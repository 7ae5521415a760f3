"""A bridge from the library (motion matching for an offline tool): the library segment whose first frame matches
the last known pose (pose relative to the root in its heading frame, joint and root velocities) and whose last
frame matches the target's, with the root's displacement and turn between them matching the gap's, among segment
lengths of 0.8 to 1.25 times the gap (a uniform time warp of the segment onto it); the segment is turned and moved
onto the last known pose and offset (per joint on SO(3), the root linearly, faded with smoothstep weights) so it
meets both ends exactly; the best segments (one per clip), a few more clips' segments chosen by the start's match
alone and by the end's, and the velocity-carrying geodesic (``inbetween``, as a candidate of cost GEODESIC_COST: it
takes over when no segment is close) are averaged frame by frame with weights 1 / (cost + COST_FLOOR), where a
segment's cost weighs its start's match near the last known pose and its end's near the target (``gap_costs``,
``Bridges.fill``). See docs/transitions.md, "Bridge from the library".
"""

import os
from dataclasses import replace
from typing import NamedTuple

import numpy as np

from ..errors import ShapeSigError
from ..geometry import so3
from .body import Body, aligned_and_root, on_rig, resample, same_rig

__all__ = ["Bridges", "Segment", "as_bridges", "average", "gap_costs", "STRETCHES"]

STRETCHES = (0.8, 0.9, 1.0, 1.1, 1.25)  # segment lengths tried, times the gap
VELOCITY_SECONDS = 0.1   # velocities weigh as the displacement over this time
MOVE_WEIGHT = 1.0        # weight of the root displacement over the gap (leg lengths)
TURN_WEIGHT = 0.5        # weight of the turn over the gap (radians)
STRETCH_WEIGHT = 0.02    # cost of a stretch r away from 1: this times log(r)^2
HISTORY = (3, 6, 9)      # frames before the seam matched too (the motion leading into the gap)
HISTORY_WEIGHT = 0.5
BRIDGES = 10             # the best segments (of as many clips) averaged, weighted 1 / (cost + COST_FLOOR)
ONE_SIDED = 5            # and as many again by the start's match alone and by the end's (gap_costs)
COST_FLOOR = 0.01
GEODESIC_COST = 1.0      # the velocity-carrying geodesic joins the average as a candidate of this cost


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

    def search(self, before, after, frames, joints, count=1, one_sided=0):
        """[``Segment``] of the best segments for a gap of ``frames`` between bodies ``before`` (last frame) and
        ``after`` (first frame), best first: the ``count`` best by the whole cost (one per clip), then the
        ``one_sided`` best by the start's match alone and as many by the end's (the move, turn and stretch terms
        kept; one per clip, of clips not found before); empty when no library clip has the joints. Every
        clip, start and length at once on the table."""
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
        parts = np.full((3, len(lengths), len(F)), np.inf)  # start, end, the rest (move, turn, stretch)
        for row, L in enumerate(lengths):
            if L >= len(F):
                continue
            i = np.arange(len(F) - L)
            same = clip[i] == clip[i + L]
            d = root[i + L] - root[i]
            cy, sy = np.cos(yaw[i]), np.sin(yaw[i])
            local = np.stack([cy * d[:, 0] + sy * d[:, 1], -sy * d[:, 0] + cy * d[:, 1], d[:, 2]], axis=1)
            turn = np.angle(np.exp(1j * (yaw[i + L] - yaw[i] - dyaw)))
            rest = (MOVE_WEIGHT * np.sum((local - dq) ** 2, axis=1) + TURN_WEIGHT * turn ** 2
                    + STRETCH_WEIGHT * np.log(L / (frames + 1.0)) ** 2)
            for k, part in enumerate((start_cost[i], end_cost[i + L], rest)):
                parts[k, row, :len(i)] = np.where(same, part, np.inf)
        found = []
        for rank, n in ((parts[0] + parts[1] + parts[2], count), (2.0 * parts[0] + parts[2], one_sided),
                        (2.0 * parts[1] + parts[2], one_sided)):
            found.extend(_best_per_clip(rank, n, parts, clip, first, lengths, found))
        return found

    def fill(self, before, after, frames):
        """(X (frames, bones, 3, 3), root (frames, 3), info) on ``before``'s skeleton (``after`` already on it): the
        module docstring's bridge; None when the library has no clip with the joints of ``before``."""
        from .make import sample_at

        bb, ba = Body(before), Body(after)
        joints = [j for j in bb.joints if j in ba.joints]
        from ..blas import one_blas_thread

        with one_blas_thread():  # matrix-vector products: OpenBLAS's threads only cost here
            found = self.search(bb, ba, frames, joints, BRIDGES, ONE_SIDED)
        if not found:
            return None
        X0, p0 = aligned_and_root(before)
        X1, p1 = aligned_and_root(after)
        rots, roots = [], []
        for seg_ in found:
            src = self.clips[seg_.clip]
            seg = sample_at(src, np.linspace(seg_.start, seg_.start + seg_.length, frames + 2))
            if same_rig(before, src):
                X, root = aligned_and_root(seg)
                root = root * (bb.leg / self.bodies[seg_.clip].leg)
            else:
                X, root = aligned_and_root(on_rig(replace(seg, fps=before.fps), before))
            X, root = _meet(before, X, root, X0[-1], p0[-1], X1[0], p1[0])
            rots.append(X[1:-1])
            roots.append(root[1:-1])
        costs = list(gap_costs(found, frames))
        if GEODESIC_COST is not None:
            from .inbetween import geodesic_gap, seam_velocities

            w0, v0 = seam_velocities(X0, p0, before.fps, True)
            w1, v1 = seam_velocities(X1, p1, before.fps, False)
            X, root = geodesic_gap(X0[-1], p0[-1], w0, v0, X1[0], p1[0], w1, v1, frames, before.fps)
            rots.append(X)
            roots.append(root)
            costs.append(np.full(frames, GEODESIC_COST))
        X, root = average(np.array(rots), np.array(roots), 1.0 / (np.array(costs) + COST_FLOOR))
        best = found[0]
        info = {"clip": self.clips[best.clip].name, "source": self.clips[best.clip].source, "start": best.start,
                "frames": best.length, "cost": round(best.cost, 6), "segments": len(found)}
        return X, root, info


class Segment(NamedTuple):
    """A library segment for a gap: its clip (index in the library), start frame and length in frames (at the
    library's rate), whole cost and the parts of it that match the start (the last known frames) and the end."""
    clip: int
    start: int
    length: int
    cost: float
    start_cost: float
    end_cost: float


def _best_per_clip(rank, count, parts, clip, first, lengths, taken):
    """The ``count`` best ``Segment``s by ``rank`` (lengths, table rows), one per clip, leaving out the clips
    already in ``taken``."""
    best = np.min(rank, axis=0)
    starts = np.flatnonzero(np.r_[True, clip[1:] != clip[:-1]])
    ends = np.r_[starts[1:], len(best)]
    per_clip = np.minimum.reduceat(best, starts)
    have = {t.clip for t in taken}
    found = []
    for c in np.argsort(per_clip, kind="stable"):
        if len(found) >= count or not np.isfinite(per_clip[c]):
            break
        if int(clip[starts[c]]) in have:
            continue
        i = starts[c] + int(np.argmin(best[starts[c]:ends[c]]))
        r = int(np.argmin(rank[:, i]))
        a, e, m = (float(parts[k, r, i]) for k in range(3))
        found.append(Segment(int(clip[i]), int(i - first[i]), lengths[r], a + e + m, a, e))
    return found


def gap_costs(found, frames):
    """(segments, frames): each segment's cost at each generated frame, its start's match weighing the more the
    nearer the frame is to the last known pose and its end's the nearer to the target:
    ``2 (1 - s) start + 2 s end + rest`` with s = t / (frames + 1) (the whole cost at mid-gap)."""
    s = np.arange(1, frames + 1) / (frames + 1.0)
    a = np.array([f.start_cost for f in found])[:, None]
    e = np.array([f.end_cost for f in found])[:, None]
    rest = np.array([f.cost for f in found])[:, None] - a - e
    return 2.0 * (1.0 - s)[None] * a + 2.0 * s[None] * e + rest


def average(rots, roots, weights):
    """(X (frames, bones, 3, 3), root (frames, 3)): the per-frame weighted mean of candidates ``rots`` (k, frames,
    bones, 3, 3) and ``roots`` (k, frames, 3) with ``weights`` (k, frames) (normalised per frame): the chordal
    mean of the rotations (the nearest rotation to their weighted sum), the weighted mean of the root heads."""
    w = np.asarray(weights, float)
    w = w / w.sum(axis=0, keepdims=True)
    X = so3.nearest_rotation(np.einsum("kf,kf...->f...", w, rots)) if len(rots) > 1 else rots[0]
    return X, np.einsum("kf,kf...->f...", w, roots)


def _meet(rig, X, root, X0, p0, X1, p1):
    """The segment (frames + 2 poses) turned about up and moved so its first pose's root heading and position are
    the last known pose's, then offset to meet X0, p0 and X1, p1 exactly (smoothstep fade)."""
    from ..clip.skeleton import rest_of, up_vector

    rest = rest_of(rig)
    up = up_vector(rig)
    tops = np.flatnonzero(rest.ancestor < 0)
    r = rest.root if rest.root is not None else int(tops[0])
    angle = float(so3.heading(X0[r], up) - so3.heading(X[0, r], up))
    T = so3.exp(angle * up)
    X = X.copy()
    X[:, tops] = T[None, None] @ X[:, tops]
    root = (root - root[0]) @ T.T + p0
    n = len(X)
    s = np.arange(n) / float(n - 1)
    w = s * s * (3.0 - 2.0 * s)
    d0 = so3.log(np.swapaxes(X[0], -1, -2) @ X0)
    d1 = so3.log(np.swapaxes(X[-1], -1, -2) @ X1)
    X = X @ so3.exp((1.0 - w)[:, None, None] * d0[None] + w[:, None, None] * d1[None])
    root = root + (1.0 - w)[:, None] * (p0 - root[0]) + w[:, None] * (p1 - root[-1])
    return X, root


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
