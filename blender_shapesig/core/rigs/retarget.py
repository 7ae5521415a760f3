"""Back from the comparison space onto a rig: ``rest_retarget`` (a clip's rotations made relative to the rest pose
of another rig, for a blend), ``rests_differ`` / ``other_rigs`` (two rigs for a blend: other bones, or the same
bones in other rest poses) and ``onto_rig`` (a comparison-space clip written back as local rotations of a rig,
its other bones keeping their motion, chains between written joints shared: ``chains``). See docs/rigs.md.
"""

from dataclasses import replace
from typing import Dict, Iterable, Mapping, Optional, Sequence

import numpy as np

from ..clip import skeleton
from ..clip.clip import Clip
from ..errors import ShapeSigError
from ..geometry import so3
from .chains import chains_between, share_chains
from .names import BODY
from .space import _unit, clip_heading, leg_length, world_rotations

__all__ = ["REST_DEGREES", "rest_retarget", "rests_differ", "other_rigs", "onto_rig"]


# the canonical joint whose rest head a joint's rest bone points at (the first one the rig maps)
_CHILDREN = {"spine": ("spine_mid", "chest"), "spine_mid": ("chest",), "chest": ("neck", "head"), "neck": ("head",),
             "clavicle": ("upper_arm",), "upper_arm": ("forearm",), "forearm": ("hand",), "thigh": ("shin",),
             "shin": ("foot",), "foot": ("toe",)}



def _rest_heads_by_joint(clip: Clip) -> Dict[str, np.ndarray]:
    heads = clip.meta.get(skeleton.REST_HEADS) or {}
    return {j: np.asarray(heads[b], dtype=np.float64) for j, b in (clip.meta.get("bone_map") or {}).items()
            if b in heads}


def _body_frame(h: Mapping[str, np.ndarray]) -> Optional[np.ndarray]:
    """The rest body frame (columns: left, forward, up) from the rest heads by joint: up from the hips to the
    neck (or head, chest), left from the right thigh to the left one; None when those are not mapped."""
    top = next((h[j] for j in ("neck", "head", "chest") if j in h), None)
    if "hips" not in h or top is None or "thigh.L" not in h or "thigh.R" not in h:
        return None
    up, left = _unit(top - h["hips"]), h["thigh.L"] - h["thigh.R"]
    left = None if up is None else _unit(left - (left @ up) * up)
    if left is None:
        return None
    return np.column_stack([left, np.cross(up, left), up])


def _best_twist(axis, M):
    """The angle t maximizing tr(Rot(axis, t)^T M): f(t) = a cos t + b sin t + c, read off at 0, pi/2, pi."""
    f = [np.trace(so3.exp(axis * t).T @ M) for t in (0.0, 0.5 * np.pi, np.pi)]
    c = 0.5 * (f[0] + f[2])
    return float(np.arctan2(f[1] - c, f[0] - c))


def rest_retarget(clip: Clip, like: Clip, samples: int = 64) -> Clip:
    """``clip`` (comparison space) with its rotations relative to the rest pose of ``like``'s rig: for a blend.

    A comparison-space rotation is relative to its rig's rest, ``W(t) = F(t) F_rest^T`` (F the segment's
    orientation), so the same motion on rigs with other rest poses (T- or A-pose, a rest lying down, other
    facing, other bone-axis conventions) differs by a constant right factor ``K_j`` per joint. Comparisons do
    not see it; a blend does (two rotations half a turn apart have no sensible midpoint: a Character Creator
    walk blended with a Daz run crossed its legs). Here ``W_j K_j``:

    * ``G`` turns ``like``'s rest body frame (``_body_frame``: hips to neck, right to left thigh) onto
      ``clip``'s;
    * a joint with a next joint in both rigs (``_CHILDREN``: thigh -> shin, ...) turns, after ``G``, by the
      smallest rotation that takes ``like``'s rest bone (head to the next joint's head) onto ``clip``'s, or not
      (rigs place joints differently: the same rest can give bones 20-40 degrees apart), whichever makes the two
      motions agree better; the rotation about the bone itself, which rest positions cannot give, is the angle
      that best matches them (``_best_twist`` of ``sum_t (W_B(t) K)^T W_A(t)`` over normalized time);
    * a joint without one (hips, hands, feet without toes, head) takes the rotation that best matches the two
      motions (``so3.nearest_rotation`` of ``M``: orthogonal Procrustes), which also takes up the mean difference of its orientation between them.

    ``clip`` is returned unchanged when either rig has no rest skeleton or body frame."""
    from ..geometry.curves import geodesic_interpolate, uniform_times

    ha, hb = _rest_heads_by_joint(like), _rest_heads_by_joint(clip)
    fa, fb = _body_frame(ha), _body_frame(hb)
    if fa is None or fb is None:
        return clip
    G = fb @ fa.T
    u = np.linspace(0.0, 1.0, samples)
    RA = geodesic_interpolate(like.rotations, uniform_times(like.frames), u)
    RB = geodesic_interpolate(clip.rotations, uniform_times(clip.frames), u)
    R = clip.rotations.copy()
    for k, j in enumerate(clip.bones):
        if j not in like.bones:
            continue
        WA = RA[:, like.bones.index(j)]
        base, side = (j[:-2], j[-2:]) if j[-2:] in (".L", ".R") else (j, "")
        child = next((c + side for c in _CHILDREN.get(base, ()) if c + side in ha and c + side in hb), None)
        ra = None if child is None or j not in ha else _unit(ha[child] - ha[j])
        rb = None if child is None or j not in hb else _unit(hb[child] - hb[j])
        M = (np.swapaxes(RB[:, k], -1, -2) @ WA).sum(axis=0)  # tr(K^T M): how well W_B K matches W_A
        if ra is None or rb is None:
            K = so3.nearest_rotation(M)
        else:
            # the body frame alone or with the rest bones' swing (joints are placed differently by rigs: a
            # clavicle's rest bone may point 20-40 degrees elsewhere on a rig whose rest is the same), each
            # with its best twist; the one under which the motions agree better
            turns = [G, so3.align(G @ ra, rb) @ G]
            turns = [T @ so3.exp(ra * _best_twist(ra, T.T @ M)) for T in turns]
            K = max(turns, key=lambda T: np.trace(T.T @ M))
        R[:, k] = R[:, k] @ K
    return replace(clip, rotations=R, meta=dict(clip.meta, rest_of=like.name))


# bones of one name pointing further apart than this in two rests: another rest pose (an A-pose against a T-pose
# turns the upper arms about 45 degrees); the ASF skeletons of CMU subjects 07, 09 and 16 differ by 9.5-16.5
REST_DEGREES = 25.0


def rests_differ(heads_a: Mapping[str, Iterable[float]], parents_a: Mapping[str, Optional[str]],
                 heads_b: Mapping[str, Iterable[float]], parents_b: Mapping[str, Optional[str]],
                 degrees: float = REST_DEGREES) -> bool:
    """True when two rigs with bone names in common hold them in other rest poses: some bone present in both
    with the same parent points (parent's head to its head, armature axes) more than ``degrees`` elsewhere.
    Such rigs blend through the comparison space and ``rest_retarget``, not in their local rotations (which are
    relative to each rest). False when either rest skeleton is missing."""
    cos = np.cos(np.radians(degrees))
    for bone, parent in parents_a.items():
        if parent is None or parents_b.get(bone) != parent:
            continue
        if not all(x in h for x in (bone, parent) for h in (heads_a, heads_b)):
            continue
        da = _unit(np.subtract(heads_a[bone], heads_a[parent], dtype=np.float64))
        db = _unit(np.subtract(heads_b[bone], heads_b[parent], dtype=np.float64))
        if da is not None and db is not None and da @ db < cos:
            return True
    return False


def other_rigs(a: Clip, b: Clip) -> bool:
    """True when clips ``a`` and ``b`` are of two rigs for a blend: other bones, or the same bones in other rest
    poses (``rests_differ``)."""
    if tuple(a.bones) != tuple(b.bones):
        return True
    return rests_differ(a.meta.get(skeleton.REST_HEADS) or {}, a.meta.get("parents") or {},
                        b.meta.get(skeleton.REST_HEADS) or {}, b.meta.get("parents") or {})



def onto_rig(clip: Clip, rig: Clip, mapped: Clip) -> Clip:
    """A comparison-space clip (e.g. a blend of ``mapped`` with a clip of another rig) written back onto the
    rig of ``rig`` (the same source as ``mapped``, read with ``bone_map="none"``): local rotations in armature
    axes ``X_b = W_parent^T W_b`` for every bone of the rig, where a joint of ``clip`` sets ``W_b = H W~_b``
    (``H``: ``mapped``'s heading) and every other bone keeps ``rig``'s own motion (local rotation, re-timed
    to ``clip``'s frames by geodesic interpolation). ``meta["kept_bones"]`` lists the rig's bones that kept
    their motion (no counterpart in ``clip``)."""
    from ..geometry.curves import geodesic_interpolate, uniform_times

    bone_map = mapped.meta.get("bone_map") or {}
    unblended = set(clip.meta.get("unmatched_a", ()))  # joints a blend copied from A: A's local motion stays
    joint_of = {b: j for j, b in bone_map.items() if j in clip.bones and j not in unblended}
    parents = rig.meta.get("parents") or {}
    H = clip_heading(rig, {j: b for j, b in bone_map.items() if b in rig.bones})
    X_rig = geodesic_interpolate(rig.rotations, uniform_times(rig.frames), uniform_times(clip.frames))
    index = {b: i for i, b in enumerate(rig.bones)}
    W = np.empty_like(X_rig)
    X = np.empty_like(X_rig)
    done = set()

    def parent_world(b):
        p = parents.get(b)
        while p is not None and p not in index:
            p = parents.get(p)
        return None if p is None else world(index[p])

    def world(i):
        if i in done:
            return W[:, i]
        b = rig.bones[i]
        Wp = parent_world(b)
        if b in joint_of:
            W[:, i] = H[None] @ clip.rotations[:, clip.bones.index(joint_of[b])]
            X[:, i] = W[:, i] if Wp is None else np.swapaxes(Wp, -1, -2) @ W[:, i]
        else:
            X[:, i] = X_rig[:, i]
            W[:, i] = X[:, i] if Wp is None else Wp @ X[:, i]
        done.add(i)
        return W[:, i]

    for i in range(len(rig.bones)):
        world(i)
    # bones between two written body joints with no motion of their own share the chain's rotation (a Mixamo
    # Spine1 under a source with two spine bones): core.rigs.chains
    body = [b for b, j in joint_of.items() if j in BODY]
    still = [b for b in rig.bones if b not in joint_of and np.allclose(X_rig[:, index[b]], np.eye(3))]
    chains = chains_between(rig.bones, parents, body, still)
    if chains:
        X = share_chains(X, rig.bones, chains)
        W = _forward(X, rig.bones, parents)
    rt = None if clip.root_translation is None else clip.root_translation @ H.T
    if rt is not None and mapped.meta.get("root_path") == "hips_legs":
        # the blended hips (leg lengths) -> the rig's root head: hips_path inverted with the blend's rotations
        off = skeleton.chain_offset(rig, W, bone_map.get("hips"))
        leg = leg_length(rig, bone_map)
        if off is None or leg is None:
            raise ShapeSigError(f"clip {rig.name!r}: cannot place its root under the blended hips (no rest skeleton)")
        rt = rt * leg - off
    kept = tuple(b for b in rig.bones if b not in joint_of and not np.allclose(X_rig[:, index[b]], np.eye(3)))
    meta = dict(rig.meta, kept_bones=kept, chain_bones=tuple(b for c in chains.values() for b in c))
    # the blend's timing and weights (core.blend.feet carries the sources' contacts through them)
    meta.update({k: clip.meta[k] for k in ("weight", "weights", "warp", "time_map", "source_times") if k in clip.meta})
    return replace(rig, name=clip.name, rotations=X, root_translation=rt, frame_start=clip.frame_start,
                   fps=clip.fps, meta=meta)


def _forward(X: np.ndarray, bones: Sequence[str], parents: Mapping[str, Optional[str]]) -> np.ndarray:
    """World rotations ``W_b = W_parent X_b`` of local rotations ``X`` (``world_rotations`` of a bare array)."""
    clip = Clip(name="", bones=tuple(bones), rotations=X, fps=1.0, meta={"parents": dict(parents)})
    return world_rotations(clip)
