"""A clip's body for transitions, on any rig the bone maps know: joint positions by forward kinematics in a Z-up
ground frame and in leg lengths (``Body``: the canonical joints through ``rigs.resolve_map``, else the clip's own
bones), its foot contacts (``contacts.find_contacts``), root heading and path; and ``on_rig``, a clip put onto another
clip's rig and frame rate (``rigs.rest_retarget`` / ``rigs.onto_rig``, ``make.sample_at``). See docs/transitions.md.
"""

from dataclasses import replace

import numpy as np

from ..clip.skeleton import aligned_rotations, forward_kinematics, rest_of, root_heads, up_vector
from ..errors import ShapeSigError
from ..geometry import so3

__all__ = ["Body", "ground_basis", "on_rig", "resample", "same_rig"]


def ground_basis(up):
    """(3, 3) rows e1, e2, up: a right-handed frame whose third axis is ``up`` (positions @ basis.T are then
    (ground x, ground y, height))."""
    up = np.asarray(up, dtype=np.float64)
    e1 = np.eye(3)[int(np.argmin(np.abs(up)))]
    e1 = e1 - (e1 @ up) * up
    e1 /= np.linalg.norm(e1)
    return np.stack([e1, np.cross(up, e1), up])


class Body:
    """Positions of a clip's joints, ``points`` (frames, joints, 3) in the ground frame (``ground_basis``) and in
    leg lengths; ``joints``: their names (canonical joints when the rig maps, else bone names); ``contacts``
    (frames, 4) heel and ball of each foot as 0/1 (zeros without legs); ``yaw`` (frames,) the root's heading about
    up (radians, unwrapped); ``leg``: the rig's leg in its units."""

    def __init__(self, clip):
        from ..rigs import leg_length, resolve_map

        rest = rest_of(clip)
        heads, _tails, W = forward_kinematics(clip, rest)
        up = up_vector(clip)
        self.basis = ground_basis(up)
        mapping = resolve_map("auto", clip) or {}
        by_joint = {j: b for b, j in mapping.items() if b in clip.bones}
        if by_joint:
            self.joints = tuple(sorted(by_joint))
            idx = [clip.bones.index(by_joint[j]) for j in self.joints]
        else:
            self.joints, idx = tuple(clip.bones), list(range(len(clip.bones)))
        self.leg = leg_length(clip, by_joint) if by_joint else None
        if not self.leg:
            span = np.ptp(rest.heads @ up) if len(rest.heads) > 1 else 0.0
            self.leg = float(span) / 2.0 if span > 0 else 1.0
        self.points = heads[:, idx] @ self.basis.T / self.leg
        root = rest.root if rest.root is not None else 0
        self.yaw = np.unwrap(so3.heading(W[:, root], up, self.basis[0]))
        self.root = (heads[:, root] @ self.basis.T) / self.leg
        self.contacts = np.zeros((clip.frames, 4))
        try:
            if clip.frames < 3:
                raise ShapeSigError("too short for contacts")
            from .contacts import find_contacts, legs_of

            legs = legs_of(clip, mapping)
            found = find_contacts(clip, legs, (heads, _tails, W))
            cols = [found[s][p] if s in found else np.zeros(clip.frames, bool)
                    for s in ("L", "R") for p in ("heel", "ball")]
            self.contacts = np.stack(cols, axis=1).astype(np.float64)
        except ShapeSigError:
            pass
        self.fps = float(clip.fps)
        self.frames = clip.frames

    def at(self, frames, joints=None):
        """(points, contacts) at fractional ``frames`` (clamped to the clip; linear / nearest), only ``joints``
        (names) when given."""
        f = np.clip(np.asarray(frames, dtype=np.float64), 0.0, self.frames - 1)
        lo = np.floor(f).astype(int)
        hi = np.minimum(lo + 1, self.frames - 1)
        w = (f - lo)[..., None, None]
        P = self.points if joints is None else self.points[:, [self.joints.index(j) for j in joints]]
        pts = P[lo] * (1.0 - w) + P[hi] * w
        return pts, self.contacts[np.rint(f).astype(int)]


def same_rig(a, b):
    """True when ``b`` can be used on ``a``'s skeleton as it is (the same bones and rest skeleton)."""
    from ..rigs import other_rigs

    return a.bones == b.bones and not other_rigs(a, b)


def resample(clip, fps):
    """The clip at ``fps`` (the same seconds; rotations along geodesics, the root linearly: ``make.sample_at``);
    the clip itself when it already is."""
    from .make import sample_at

    if abs(float(clip.fps) - float(fps)) < 1e-9:
        return clip
    step = float(clip.fps) / float(fps)
    count = int(np.floor((clip.frames - 1) / step + 1e-9)) + 1
    out = sample_at(clip, np.arange(count) * step)
    return replace(out, fps=float(fps))


def on_rig(clip, like):
    """``clip`` on ``like``'s skeleton (bones, rest, rotation space) and frame rate: as it is on the same rig, else
    through the comparison space (``rigs.apply_bone_map``, ``rest_retarget``, ``onto_rig``: bones of ``like``
    without a counterpart keep ``like``'s motion). ShapeSigError when the bone maps join no joint."""
    from ..rigs import apply_bone_map, onto_rig, rest_retarget

    if not same_rig(like, clip):
        ma, mb = apply_bone_map(like), apply_bone_map(clip)
        if ma.meta.get("rotation_space") != "comparison" or mb.meta.get("rotation_space") != "comparison" \
                or not set(ma.bones) & set(mb.bones):
            raise ShapeSigError(f"clips {like.name!r} and {clip.name!r} share no joints (give clips of one rig or "
                                f"rigs the bone maps know)")
        out = onto_rig(rest_retarget(mb, ma), like, ma)
        clip = replace(out, name=clip.name, frame_start=clip.frame_start)
    return resample(clip, like.fps)


def aligned_and_root(clip):
    """(X, root): the clip's rotations relative to rest in world-aligned axes (frames, bones, 3, 3) and its root
    bone's head (frames, 3) (zeros without a root translation)."""
    rest = rest_of(clip)
    root = root_heads(clip, rest)
    if root is None:
        root = np.zeros((clip.frames, 3)) if rest.root is None else np.tile(rest.heads[rest.root], (clip.frames, 1))
    return aligned_rotations(clip), root
