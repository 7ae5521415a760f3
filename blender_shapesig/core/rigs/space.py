"""The comparison space across rigs (``to_comparison_space``: each mapped bone's world rotation relative to rest,
the heading removed, bones named by their joints; ``apply_bone_map``, the front door's step, with the map a
``bone_map`` option gives, ``resolve_map``), the body's heading, rest facing, leg length and hips path in leg
lengths, and ``check_comparable`` (mapped clips against one whose bones could not be mapped). See docs/rigs.md and
docs/model.md, "Comparison space across rigs".
"""

from dataclasses import replace
from typing import Dict, Mapping, Optional, Tuple

import numpy as np

from ..clip import skeleton
from ..clip.clip import Clip
from ..errors import ShapeSigError
from ..geometry import so3
from .detect import RigReport, analyse_rig
from .maps import check_map, load_map
from .names import JOINTS, SIDES

__all__ = ["TABLES_VERSION", "TRAVEL_RATIO", "analyse_clip", "resolve_map", "world_rotations", "heading",
           "rest_forward", "clip_heading", "leg_length", "hips_path", "to_comparison_space", "apply_bone_map",
           "check_comparable"]

# bump when the tables or the comparison space change (it is part of every clip's cache key)
TABLES_VERSION = 4


def analyse_clip(clip: Clip) -> RigReport:
    """``analyse_rig`` of a clip's rig: its bones, hierarchy and rest skeleton (``meta``)."""
    m = clip.meta
    return analyse_rig(clip.bones, m.get("parents"), m.get(skeleton.REST_HEADS), m.get(skeleton.REST_TAILS))


def resolve_map(bone_map, clip: Clip, report: Optional[RigReport] = None) -> Optional[Dict[str, str]]:
    """The map to apply to ``clip`` for a ``bone_map`` option: "none" -> None (names as they are); a saved map
    (a path) or a dict -> its entries for the clip's bones, when it names any (a saved map is for the rig it
    names: clips of other rigs fall back to "auto"); "auto" -> the detected map (``analyse_clip``, or
    ``report`` when given; None when nothing maps)."""
    if bone_map is None or bone_map == "none":
        return None
    if bone_map != "auto":
        mapping = check_map(bone_map) if isinstance(bone_map, Mapping) else load_map(bone_map)
        present = {b: mapping[b] for b in clip.bones if b in mapping}
        if present:
            return present
    return (report or analyse_clip(clip)).mapping or None


def world_rotations(clip: Clip) -> np.ndarray:
    """(frames, joints, 3, 3): each bone's rotation relative to its rest pose in the armature's axes,
    ``W_b = W_parent X_b`` down the hierarchy (``meta["parents"]``; bones whose parent is not in the clip start
    their chain there). ``X`` are the clip's local rotations in armature axes."""
    parents = clip.meta.get("parents") or {}
    index = {b: j for j, b in enumerate(clip.bones)}
    W = np.empty_like(clip.rotations)
    done = {}

    def world(j):
        if j in done:
            return W[:, j]
        b = clip.bones[j]
        p, seen = parents.get(b), {b}
        while p is not None and p not in index and p not in seen:  # skip bones the clip does not hold
            seen.add(p)
            p = parents.get(p)
        if p is None or p not in index:
            W[:, j] = clip.rotations[:, j]
        else:
            W[:, j] = world(index[p]) @ clip.rotations[:, j]
        done[j] = True
        return W[:, j]

    for j in range(len(clip.bones)):
        world(j)
    return W


_Z = np.array([0.0, 0.0, 1.0])  # up in the comparison space (Blender's Z)
# a clip travels when its net horizontal displacement is at least this fraction of its horizontal path
TRAVEL_RATIO = 0.5


def heading(W_root: np.ndarray, root_translation: Optional[np.ndarray] = None,
            forward: Optional[np.ndarray] = None) -> np.ndarray:
    """The rotation about the vertical (Z) that ``to_comparison_space`` removes: where the take goes.

    * A clip that travels (net horizontal displacement of the root >= ``TRAVEL_RATIO`` of its horizontal path):
      the direction of travel, turned so that it becomes Blender's forward (-Y). Positions do not depend on
      rest poses or bone axes, so this heading is the same for the take on any rig.
    * Otherwise, with the rig's rest facing ``forward`` (3,) (``rest_forward``): where the body faces, the mean
      over the frames of ``W_root(t) forward``'s horizontal part, turned to -Y. Also a fact of positions: the
      same for a rig whose rest faces elsewhere (a whole rig turned about the vertical turns it along).
    * Without it: the circular mean over the frames of the root's yaw (its twist about Z), the facing relative
      to the rig's rest pose (only rigs whose rests face the same way agree)."""
    if root_translation is not None and len(root_translation) > 1:
        flat = np.asarray(root_translation, dtype=np.float64)[:, :2]
        net = flat[-1] - flat[0]
        path = np.linalg.norm(np.diff(flat, axis=0), axis=1).sum()
        if path > 0 and np.linalg.norm(net) >= TRAVEL_RATIO * path:
            return so3.exp((np.arctan2(net[1], net[0]) + np.pi / 2) * _Z)
    if forward is not None:
        # unnormalized: frames where the body lies (facing up or down) weigh less
        f = (np.asarray(W_root, dtype=np.float64) @ np.asarray(forward, dtype=np.float64))[:, :2].mean(axis=0)
        if np.linalg.norm(f) > 1e-6:
            return so3.exp(np.arctan2(f[0], -f[1]) * _Z)  # the turn about Z taking -Y to f
    yaw = so3.twist(W_root, _Z)
    return so3.exp(np.arctan2(np.sin(yaw).mean(), np.cos(yaw).mean()) * _Z)


def rest_forward(clip: Clip, by_joint: Mapping[str, str]) -> Optional[np.ndarray]:
    """The unit direction the rig's body faces at rest, in armature axes: left x up, left from the right to the
    left thigh's rest head (else the upper arms', the feet's), up from the hips (else the thighs' midpoint) to the
    neck (else the head, the chest); None without a rest skeleton or those joints."""
    heads = clip.meta.get(skeleton.REST_HEADS) or {}
    h = {j: np.asarray(heads[b], dtype=np.float64) for j, b in by_joint.items() if b in heads}
    left = next((h[f"{j}.L"] - h[f"{j}.R"] for j in ("thigh", "upper_arm", "foot")
                 if f"{j}.L" in h and f"{j}.R" in h), None)
    low = h.get("hips", 0.5 * (h["thigh.L"] + h["thigh.R"]) if "thigh.L" in h and "thigh.R" in h else None)
    top = next((h[j] for j in ("neck", "head", "chest") if j in h), None)
    if left is None or low is None or top is None:
        return None
    up = _unit(top - low)
    return None if up is None else _unit(np.cross(left - (left @ up) * up, up))


def clip_heading(clip: Clip, by_joint: Mapping[str, str], W: Optional[np.ndarray] = None) -> np.ndarray:
    """``heading`` of a clip read in armature axes with its map ``{joint: bone}``: of its hips (else its first
    mapped bone), its root translation and its rest facing (``rest_forward``). ``W``: ``world_rotations(clip)``
    when already computed."""
    W = world_rotations(clip) if W is None else W
    root = by_joint.get("hips", next((by_joint[j] for j in JOINTS if j in by_joint), None))
    return heading(W[:, clip.bones.index(root)], clip.root_translation, rest_forward(clip, by_joint))


def leg_length(clip: Clip, by_joint: Mapping[str, str]) -> Optional[float]:
    """The rig's leg (hip to ankle: the rest heads of the mapped thigh and foot, else the thigh's head and the
    shin's tail for a rig without a foot bone; mean over sides) in the clip's units, or None without a mapped leg
    or rest skeleton."""
    heads = clip.meta.get(skeleton.REST_HEADS) or {}
    tails = clip.meta.get(skeleton.REST_TAILS) or {}
    ankles = {s: heads.get(by_joint.get(f"foot.{s}"), tails.get(by_joint.get(f"shin.{s}"))) for s in SIDES}
    lengths = [np.linalg.norm(np.subtract(heads[by_joint[f"thigh.{s}"]], ankles[s])) for s in SIDES
               if by_joint.get(f"thigh.{s}") in heads and ankles[s] is not None]
    length = float(np.mean(lengths)) if lengths else 0.0
    return length if length > 0 else None


def hips_path(clip: Clip, by_joint: Mapping[str, str], W: np.ndarray) -> Optional[Tuple[np.ndarray, float]]:
    """(path, leg): the hips joint's head (frames, 3) in the armature's axes in **leg lengths**, and the rig's leg
    (``leg_length``) in its units; None when it cannot be had (no root translation, not in armature axes, no rest
    skeleton, no hips or legs mapped).

    Rigs translate different bones (a floor-level ``RL_BoneRoot`` in Character Creator, the pelvis in Daz and
    CMU), in different units (metres for Acclaim, centimetres in these BVH files) and for bodies of other sizes,
    so a root path is comparable across rigs as the hips' in leg lengths (the root's head plus
    ``skeleton.chain_offset`` to the hips, over ``leg_length``): retargeted so, a blend's hips keep the height
    and stride that fit the rig it is written onto. ``onto_rig`` inverts it."""
    if clip.root_translation is None or clip.meta.get("rotation_space") != "armature":
        return None
    off = skeleton.chain_offset(clip, W, by_joint.get("hips"))
    leg = leg_length(clip, by_joint)
    if off is None or leg is None:
        return None
    return (clip.root_translation + off) / leg, leg


def to_comparison_space(clip: Clip, mapping: Mapping[str, str]) -> Clip:
    """The clip in the comparison space: the mapped bones only, renamed to their joints (canonical order),
    rotations ``H^T W_b(t)`` (``world_rotations``, ``clip_heading``: of the hips or the first mapped bone, and the
    rig's rest facing). The root
    translation is the hips' path in leg lengths (``hips_path``; ``meta["root_path"] = "hips_legs"``, else the
    root's translation as read), turned with the heading. ``meta["bone_map"]`` keeps ``{joint: bone}``."""
    mapping = {b: j for b, j in mapping.items() if b in clip.bones}
    if not mapping:
        raise ShapeSigError(f"clip {clip.name!r}: no bone maps to a canonical joint")
    W = world_rotations(clip)
    index = {b: i for i, b in enumerate(clip.bones)}
    by_joint = {j: b for b, j in mapping.items()}
    joints = [j for j in JOINTS if j in by_joint]
    H = clip_heading(clip, by_joint, W)
    R = H.T[None, None] @ W[:, [index[by_joint[j]] for j in joints]]
    hips = hips_path(clip, by_joint, W)
    rt = clip.root_translation if hips is None else hips[0]
    rt = None if rt is None else rt @ H
    meta = dict(clip.meta, bone_map={j: by_joint[j] for j in joints}, rotation_space="comparison",
                rig_bones=len(clip.bones))
    if hips is not None:
        meta["root_path"] = "hips_legs"
    meta.pop("parents", None)
    return replace(clip, bones=tuple(joints), rotations=R, root_translation=rt, root_bone="hips",
                   rotation_modes=(), meta=meta)



def _unit(v):
    n = np.linalg.norm(v)
    return v / n if n > 1e-12 else None



def apply_bone_map(clip: Clip, bone_map="auto") -> Clip:
    """The front door's comparison-space step (``sources.read``): the clip mapped by ``resolve_map`` and moved
    to the comparison space, with ``meta["rig_joints"]`` (the canonical joints its rig has, ``analyse_clip``)
    and ``meta["unmapped_joints"]`` (those of them no bone is mapped to); a clip "auto" cannot map is returned as
    it is, marked ``meta["unmapped"]`` and, for a rig that is not a humanoid, ``meta["not_humanoid"]`` (one line;
    comparing it with a mapped clip is refused by ``check_comparable``)."""
    if clip.meta.get("rotation_space") == "comparison":
        return clip
    if bone_map in (None, "none"):
        return clip
    report = analyse_clip(clip)
    mapping = resolve_map(bone_map, clip, report)
    if mapping is None:
        meta = dict(clip.meta, unmapped=True)
        if report.refusal:
            meta["not_humanoid"] = report.refusal
        return replace(clip, meta=meta)
    out = to_comparison_space(clip, mapping)
    has = [j for j in JOINTS if j in set(report.joints) | set(out.bones)] if report.joints else list(out.bones)
    out.meta.update(rig_joints=tuple(has), unmapped_joints=tuple(j for j in has if j not in out.bones))
    return out


def _names(bones, limit=12):
    return ", ".join(bones[:limit]) + (f", ... ({len(bones)} bones)" if len(bones) > limit else "")


def check_comparable(*clips: Clip) -> None:
    """ShapeSigError (one line, naming the unmapped bones, or why the rig is not a humanoid) when some clips are
    in the comparison space and another's bones could not be mapped to the canonical joints."""
    mapped = [c for c in clips if c.meta.get("rotation_space") == "comparison"]
    if not mapped:
        return
    for c in clips:
        if c.meta.get("rotation_space") != "comparison" and not set(c.bones) & set(mapped[0].bones):
            why = c.meta.get("not_humanoid")
            if why:
                raise ShapeSigError(f"clip {c.name!r} is {why}; it is compared only with clips of its own rig "
                                    f"(or give a bone map)")
            raise ShapeSigError(f"clips {mapped[0].name!r} and {c.name!r} share no bones: no bone of {c.name!r} "
                                f"maps to a canonical joint (unmapped bones: {_names(list(c.bones))}); give a bone "
                                f"map")
