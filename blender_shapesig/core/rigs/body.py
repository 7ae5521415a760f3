"""The canonical body posed like a clip (issue 29's local search; its thumbnails draw it): ``rig_positions``, every
canonical joint's head and tail by forward kinematics down the canonical hierarchy (``names.CANONICAL_PARENTS``)
from a comparison-space clip's world rotations and its rig's rest offsets in leg lengths (``space.leg_length``),
and ``body_positions``, the key points ``POINTS`` of a body of an adult's proportions (``SEGMENTS``, in leg lengths)
along the directions of the rig's segments, so rigs, body sizes and units do not matter. Pure numpy; measured in
experiments/local_search/RESULTS.md.
"""

import numpy as np

from ..clip.clip import Clip
from ..errors import ShapeSigError
from .names import CANONICAL_PARENTS
from .space import leg_length

__all__ = ["POINTS", "SEGMENTS", "rig_positions", "body_positions"]

# the canonical body's key points and segment lengths (leg lengths: hip joint to ankle = 1; after Winter's
# anthropometric table: thigh and shank 0.245 and 0.246 of the height, upper arm 0.186, forearm 0.146, hip and
# shoulder widths 0.191 and 0.259, hip joints to shoulders 0.288, shoulders to the skull's base about 0.1)
POINTS = ("head", "shoulder.L", "shoulder.R", "elbow.L", "elbow.R", "wrist.L", "wrist.R", "knee.L", "knee.R",
          "ankle.L", "ankle.R")
SEGMENTS = {"hip": 0.195, "thigh": 0.5, "shin": 0.5, "torso": 0.59, "shoulder": 0.265, "upper_arm": 0.38,
            "forearm": 0.30, "head": 0.2}


def _rest_offsets(clip: Clip, joints):
    heads = clip.meta.get("rest_heads") or {}
    tails = clip.meta.get("rest_tails") or {}
    by_joint = clip.meta.get("bone_map") or {}
    h = {j: np.asarray(heads[by_joint[j]], float) for j in joints if by_joint.get(j) in heads}
    t = {j: np.asarray(tails[by_joint[j]], float) for j in joints if by_joint.get(j) in tails}
    return h, t


def rig_positions(clip: Clip):
    """(heads, tails): {joint: (frames, 3)} every canonical joint's head and (where the rest skeleton has it) its
    bone's tail, in leg lengths in the comparison space's axes (Z up), by forward kinematics down the canonical
    joints with the rig's own rest offsets. ``clip`` must be in the comparison space (``rigs.to_comparison_space``,
    what ``sources.read`` gives with a bone map)."""
    if clip.meta.get("rotation_space") != "comparison":
        raise ShapeSigError(f"clip {clip.name!r} is not mapped to body joints (map its bones in the Bone Map panel "
                            f"or with a bone map file)")
    joints = [j for j in CANONICAL_PARENTS if j in clip.bones]
    index = {b: i for i, b in enumerate(clip.bones)}
    h, t = _rest_offsets(clip, joints)
    leg = leg_length(clip, clip.meta.get("bone_map") or {})
    if leg is None:
        raise ShapeSigError("local search needs the legs (thigh and foot or shin) and the rest skeleton")
    R = clip.rotations
    if clip.meta.get("root_path") == "hips_legs" and clip.root_translation is not None:
        hips = np.asarray(clip.root_translation, float)
    else:
        hips = np.zeros((R.shape[0], 3))
    heads, tails = {}, {}
    for j in joints:
        if j not in h:
            continue
        p = CANONICAL_PARENTS[j]
        while p is not None and p not in h:
            p = CANONICAL_PARENTS[p]
        heads[j] = hips.copy() if p is None else heads[p] + R[:, index[p]] @ ((h[j] - h[p]) / leg)
        if j in t and np.linalg.norm(t[j] - h[j]) > 1e-9:
            tails[j] = heads[j] + R[:, index[j]] @ ((t[j] - h[j]) / leg)
    return heads, tails


def _unit(v):
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-9)


def _need(heads, tails, clip, *options):
    for kind, j in options:
        src = heads if kind == "head" else tails
        if j in src:
            return src[j]
    raise ShapeSigError(f"clip {clip.name!r}: no {options[0][1]!r} joint for the local search (bone map)")


def body_positions(clip: Clip):
    """(pelvis, P, side): the key points (frames, len(POINTS), 3) of a **canonical body** posed like the clip, its
    pelvis' path (frames, 3) and its left-minus-right vector (hip joints plus shoulders), in leg lengths, Z up.

    Rigs put joints at other places along a chain (a hips bone's head at the pelvis or between the hip joints, a
    clavicle's head at the sternum or by the neck) and bodies have other proportions, so only the **directions**
    of the rig's segments are kept: hip joint to knee to ankle, shoulder to elbow to wrist, pelvis to the
    shoulders' midpoint, neck to the top of the head, the hip and shoulder lines; their lengths are
    ``SEGMENTS``' (an adult's proportions in leg lengths, hip joint to ankle = 1)."""
    heads, tails = rig_positions(clip)
    need = lambda *o: _need(heads, tails, clip, *o)  # noqa: E731
    hip = {s: need(("head", f"thigh.{s}")) for s in "LR"}
    knee = {s: need(("head", f"shin.{s}"), ("tail", f"thigh.{s}")) for s in "LR"}
    ankle = {s: need(("head", f"foot.{s}"), ("tail", f"shin.{s}")) for s in "LR"}
    shoulder = {s: need(("head", f"upper_arm.{s}")) for s in "LR"}
    elbow = {s: need(("head", f"forearm.{s}"), ("tail", f"upper_arm.{s}")) for s in "LR"}
    wrist = {s: need(("head", f"hand.{s}"), ("tail", f"forearm.{s}")) for s in "LR"}
    top = need(("head", "head"), ("tail", "neck"))  # the skull's base: head bones' tails point up or forward
    pelvis = 0.5 * (hip["L"] + hip["R"])
    neck_rig = 0.5 * (shoulder["L"] + shoulder["R"])
    L = SEGMENTS
    neck = pelvis + L["torso"] * _unit(neck_rig - pelvis)
    out = {"head": neck + L["head"] * _unit(top - neck_rig)}
    hip_dir, sh_dir = _unit(hip["L"] - hip["R"]), _unit(shoulder["L"] - shoulder["R"])
    for s, sign in (("L", 1.0), ("R", -1.0)):
        c_hip = pelvis + sign * L["hip"] * hip_dir
        out[f"knee.{s}"] = c_hip + L["thigh"] * _unit(knee[s] - hip[s])
        out[f"ankle.{s}"] = out[f"knee.{s}"] + L["shin"] * _unit(ankle[s] - knee[s])
        out[f"shoulder.{s}"] = neck + sign * L["shoulder"] * sh_dir
        out[f"elbow.{s}"] = out[f"shoulder.{s}"] + L["upper_arm"] * _unit(elbow[s] - shoulder[s])
        out[f"wrist.{s}"] = out[f"elbow.{s}"] + L["forearm"] * _unit(wrist[s] - elbow[s])
    return pelvis, np.stack([out[p] for p in POINTS], axis=1), hip_dir + sh_dir

