"""Control rigs (Blender layer): armatures whose deform bones move only through constraints (Rigify: ``DEF-`` bones
copy ``ORG-`` / tweak bones that follow the keyed controls, IK feet, FK/IK switches, ``torso``). ``is_control_rig``
tells them; ``evaluated_clip`` reads the motion the deform bones make from the evaluated pose, frame by frame, in the
layout ``action_io.read_action(..., space="armature")`` gives; ``deform_rest_clip`` is their deform skeleton at rest
(the target ``retarget`` maps onto); ``write_onto_controls`` writes a motion of the deform bones as a new action
keying Rigify's FK controls (limbs switched to FK) by a visual solve through the depsgraph. Armature space in and out:
no world matrix, no scene rate. See docs/rigs.md, "Control rigs".
"""

import math
from typing import Dict, List, Optional, Tuple

import bpy
import numpy as np
from mathutils import Matrix

from .. import compat
from . import action_io
from .action_hashes import read_hash
from ..core.clip.clip import Clip
from ..core.clip.skeleton import rest_meta
from ..core.errors import ShapeSigError, check_frame_range
from ..core.io.files import check_frames
from ..core.geometry.so3 import nearest_rotation

__all__ = ["is_control_rig", "is_rigify", "deform_bones", "deform_parents", "deform_rest_clip", "evaluated_clip",
           "write_onto_controls", "RIGIFY_CONTROLS", "IK_FK"]

# Rigify's FK controls and the deform bone each follows (solved in the order their dependencies give,
# ``_solve_order``); the torso also takes its deform bone's position
RIGIFY_CONTROLS = (
    ("torso", "DEF-spine"), ("hips", "DEF-spine"), ("chest", "DEF-spine.003"), ("spine_fk", "DEF-spine"),
    ("spine_fk.001", "DEF-spine.001"), ("spine_fk.002", "DEF-spine.002"), ("spine_fk.003", "DEF-spine.003"),
    ("neck", "DEF-spine.004"), ("head", "DEF-spine.006"),
    *((f"{c}.{s}", f"DEF-{d}.{s}") for s in "LR" for c, d in (
        ("shoulder", "shoulder"), ("thigh_fk", "thigh"), ("shin_fk", "shin"), ("foot_fk", "foot"), ("toe_fk", "toe"),
        ("upper_arm_fk", "upper_arm"), ("forearm_fk", "forearm"), ("hand_fk", "hand"))),
)
# Rigify's FK/IK switch: a custom property of each limb's parent bone (0 IK, 1 FK)
IK_FK = "IK_FK"
_TARGETED = {"COPY_TRANSFORMS", "COPY_ROTATION", "COPY_LOCATION", "CHILD_OF", "IK", "DAMPED_TRACK", "STRETCH_TO",
             "TRACK_TO", "LOCKED_TRACK", "ARMATURE", "ACTION", "TRANSFORM"}


def _armature(obj):
    if obj is None or getattr(obj, "type", None) != "ARMATURE":
        raise ShapeSigError(f"{getattr(obj, 'name', obj)!r} is not an armature object")
    return obj


def is_control_rig(armature) -> bool:
    """True when some deform bone of ``armature`` is driven by a constraint with a target (Rigify's ``DEF-`` bones
    copy tweak / ``ORG-`` bones; a plain rig with an IK constraint on a deform shin): its keyed channels are not
    the motion its deform bones make. Muted constraints and those of zero influence do not count."""
    obj = _armature(armature)
    for bone in obj.data.bones:
        if not bone.use_deform:
            continue
        for c in obj.pose.bones[bone.name].constraints:
            if c.type in _TARGETED and getattr(c, "enabled", not c.mute) and c.influence > 0 \
                    and getattr(c, "target", None) is not None:
                return True
    return False


def is_rigify(armature) -> bool:
    """True for a control rig (``is_control_rig``) with Rigify's controls: a ``torso`` and the FK/IK switches
    (``IK_FK``) that ``write_onto_controls`` keys. Other control rigs are read through ``evaluated_clip`` but
    written onto their bones as before."""
    obj = _armature(armature)
    pose = obj.pose.bones
    return "torso" in pose and any(IK_FK in pb.keys() for pb in pose) and is_control_rig(obj)


def deform_bones(armature) -> List[str]:
    """The deform bones (``use_deform``) in armature order; every bone when none deforms."""
    bones = _armature(armature).data.bones
    names = [b.name for b in bones if b.use_deform]
    return names or [b.name for b in bones]


def deform_parents(armature) -> Dict[str, Optional[str]]:
    """{deform bone: its parent among the deform bones}: the nearest ancestor that deforms, or an ``ORG-`` bone
    whose ``DEF-`` twin exists (Rigify hangs ``DEF-upper_arm.L`` from ``ORG-shoulder.L``, ``DEF-thigh.L`` from
    ``ORG-spine``); None at the top."""
    bones = _armature(armature).data.bones
    names = set(deform_bones(armature))
    out = {}
    for name in deform_bones(armature):
        p = bones[name].parent
        found = None
        while p is not None:
            twin = "DEF-" + p.name[4:] if p.name.startswith("ORG-") else None
            if p.name in names and p.name != name:
                found = p.name
            elif twin in names and twin != name:
                found = twin
            if found is not None:
                break
            p = p.parent
        out[name] = found
    return out


def _root(parents: Dict[str, Optional[str]]) -> Optional[str]:
    """The top deform bone with the most deform bones under it (Rigify: ``DEF-spine``)."""
    below = {b: 0 for b in parents}
    for b in parents:
        p, seen = parents[b], {b}
        while p is not None and p not in seen:
            seen.add(p)
            below[p] += 1
            p = parents.get(p)
    tops = [b for b, p in parents.items() if p is None]
    return max(tops, key=lambda b: below[b]) if tops else None


def _rest(armature, names):
    """(B (bones, 3, 3) rest orientations, heads, tails) of ``names`` in armature space."""
    bones = armature.data.bones
    B = nearest_rotation(np.array([np.array(bones[b].matrix_local.to_3x3()) for b in names], dtype=np.float64))
    heads = np.array([tuple(bones[b].head_local) for b in names], dtype=np.float64)
    tails = np.array([tuple(bones[b].tail_local) for b in names], dtype=np.float64)
    return B, heads, tails


def _meta(armature, names, parents, B, heads, tails) -> dict:
    meta = {"rest_rotations": B, "parents": dict(parents), "rotation_space": "armature", "up_axis": "Z",
            "deform_of": armature.name}
    meta.update(rest_meta(list(names), list(map(tuple, heads)), list(map(tuple, tails))))
    return meta


def deform_rest_clip(armature, frames=2, fps=24.0, name="rest") -> Clip:
    """The deform skeleton of ``armature`` (``deform_bones``, ``deform_parents``) standing at rest for ``frames``
    frames, in armature space (``retarget.rest_clip`` for a control rig)."""
    names = deform_bones(armature)
    parents = deform_parents(armature)
    B, heads, tails = _rest(armature, names)
    root = _root(parents)
    rt = np.broadcast_to(heads[names.index(root)], (frames, 3)).copy() if root else None
    return Clip(name=name, bones=tuple(names), rotations=np.broadcast_to(np.eye(3), (frames, len(names), 3, 3)).copy(),
                fps=float(fps), frame_start=1, root_translation=rt, root_bone=root,
                meta=_meta(armature, names, parents, B, heads, tails))


def _frame_range(action, frame_range) -> Tuple[int, int]:
    if frame_range is not None:
        return check_frame_range(int(frame_range[0]), int(frame_range[1]), what=f"action {action.name!r}", frames=1)
    lo, hi = action.frame_range
    return int(math.floor(lo + 1e-3)), max(int(math.ceil(hi - 1e-3)), int(math.floor(lo + 1e-3)))


class _Borrowed:
    """The armature playing another action (or none) for a while, without its NLA strips: its action, slot, NLA
    switch and the scene frame come back."""

    def __init__(self, armature, action):
        self.obj, self.action = armature, action

    def __enter__(self):
        ad = self.obj.animation_data
        self.had = ad is not None
        self.old = (ad.action, compat.object_action_slot(self.obj)) if ad is not None else (None, None)
        scene = bpy.context.scene
        self.frame = (scene.frame_current, scene.frame_subframe)
        self.nla = ad.use_nla if ad is not None else None
        if self.action is not None or self.had:
            ad = self.obj.animation_data or self.obj.animation_data_create()
            ad.use_nla = False  # the action alone, not blended with the NLA's strips
            if ad.action != self.action:
                ad.action = None
                compat.assign_action(self.obj, self.action)
        return self

    def __exit__(self, *exc):
        ad = self.obj.animation_data
        if ad is not None:
            if ad.action != self.old[0]:
                ad.action = self.old[0]
            if self.old[1] is not None and hasattr(ad, "action_slot") and ad.action_slot != self.old[1]:
                ad.action_slot = self.old[1]
            if self.nla is not None:
                ad.use_nla = self.nla
            if not self.had and ad.action is None:
                self.obj.animation_data_clear()
        bpy.context.scene.frame_set(self.frame[0], subframe=self.frame[1])
        return False


def evaluated_clip(armature, action, frame_range=None, fps=None, name=None) -> Clip:
    """The motion ``armature``'s deform bones make when it plays ``action``: on every integer frame (the action's
    range, or ``frame_range``) the evaluated pose (constraints, drivers, IK) of each deform bone, ``R(t) =
    pose_bone.matrix`` (armature space; scale from stretching removed), as the local rotation relative to rest in
    the armature's axes ``X_b = W_parent^T W_b`` with ``W_b = R_b(t) B_b^T`` (``B`` the rest orientation;
    parents: ``deform_parents``). ``meta`` as ``action_io.read_action(..., space="armature")`` (rest rotations,
    parents, rest heads and tails, ``fcurve_hash``, ...); the root translation is the head of the top deform
    bone. The armature's action, slot and the scene frame are restored. ``fps``: default the action's rate."""
    obj = _armature(armature)
    if action is None:
        raise ShapeSigError("no action given")
    names = deform_bones(obj)
    parents = deform_parents(obj)
    start, end = _frame_range(action, frame_range)
    check_frames(end - start + 1, None, what=f"clip (action {action.name!r})")  # a key at frame 10**7
    B, heads, tails = _rest(obj, names)
    n = end - start + 1
    R = np.empty((n, len(names), 3, 3))
    P = np.empty((n, len(names), 3))
    pose = [obj.pose.bones[b] for b in names]
    with _Borrowed(obj, action):
        scene = bpy.context.scene
        for i, f in enumerate(range(start, end + 1)):
            scene.frame_set(f)
            for j, pb in enumerate(pose):
                m = pb.matrix
                R[i, j] = m.to_3x3()
                P[i, j] = m.translation
    W = nearest_rotation(R.reshape(-1, 3, 3)).reshape(R.shape) @ np.swapaxes(B, -1, -2)[None]
    index = {b: j for j, b in enumerate(names)}
    X = W.copy()
    for b, p in parents.items():
        if p is not None:
            X[:, index[b]] = np.swapaxes(W[:, index[p]], -1, -2) @ W[:, index[b]]
    root = _root(parents)
    clip = Clip(name=name or action.name, bones=tuple(names), rotations=X, fps=float(fps or _rate(action)),
                frame_start=start, root_translation=None if root is None else P[:, index[root]].copy(),
                root_bone=root, source=action.name_full,
                meta=dict(_meta(obj, names, parents, B, heads, tails), action=action.name,
                          slot=None, missing_rotation_bones=(), fcurve_hash=read_hash(action), evaluated=True))
    clip.meta["still_bones"] = clip.still_bones()
    return clip


def _rate(action) -> float:
    from .frame_rates import rate_of  # the rate read_action takes by default

    return float(rate_of(action)[0])


def _depends(armature, name, memo) -> set:
    """The bones ``name``'s pose depends on: its parents and constraint targets in the armature, recursively."""
    if name in memo:
        return memo[name]
    memo[name] = set()
    pb = armature.pose.bones[name]
    direct = {pb.parent.name} if pb.parent else set()
    direct |= {c.subtarget for c in pb.constraints if getattr(c, "target", None) is armature
               and getattr(c, "subtarget", "") in armature.pose.bones}
    out = set(direct)
    for d in direct:
        out |= _depends(armature, d, memo)
    memo[name] = out
    return out


def _controls(armature, clip) -> List[Tuple[str, str]]:
    """(control, deform bone) of ``RIGIFY_CONTROLS`` the armature and the clip have, in an order where every
    control comes after the controls its pose depends on (Rigify's lower FK spine hangs from the upper one)."""
    pose, held = armature.pose.bones, set(clip.bones)
    pairs = [(c, d) for c, d in RIGIFY_CONTROLS if c in pose and d in held]
    memo, out, left = {}, [], list(pairs)
    deps = {c: _depends(armature, c, memo) for c, _d in pairs}
    while left:
        ready = next((p for p in left if not any(q[0] in deps[p[0]] for q in left if q is not p)), left[0])
        out.append(ready)
        left.remove(ready)
    return out


def _follows(pb):
    """The bone ``pb``'s pose follows rigidly, as ("parent", name) or ("copy", name), or None: no constraints but
    unit-scale copies, or one full ``COPY_TRANSFORMS`` in pose space (Rigify's MCH bones)."""
    copy = None
    for c in pb.constraints:
        if c.mute or c.influence == 0 or c.type == "COPY_SCALE":
            continue
        if c.type == "COPY_TRANSFORMS" and copy is None and c.influence == 1.0 and c.target is pb.id_data \
                and c.subtarget and c.target_space == c.owner_space == "WORLD" and c.mix_mode == "REPLACE":
            copy = c.subtarget
            continue
        return None
    if copy is not None:
        return "copy", copy
    if pb.parent is None or not pb.bone.use_inherit_rotation:
        return None
    return "parent", pb.parent.name


def _predicted(armature, name, known, rest):
    """The pose matrix (4x4) ``name`` gets from the bones of ``known`` it follows rigidly (``_follows``) with its
    current basis; None when it depends on something else (then the depsgraph says)."""
    if name in known:
        return known[name]
    pb = armature.pose.bones[name]
    how = _follows(pb)
    if how is None:
        return None
    M = _predicted(armature, how[1], known, rest)
    if M is not None and how[0] == "parent":
        M = M @ np.linalg.solve(rest(how[1]), rest(name)) @ np.array(pb.matrix_basis, dtype=np.float64)
    if M is not None:
        known[name] = M
    return M


def _solve(armature, pairs, W, heads, index, frames):
    """Per frame: each control's pose matrix set from its deform bone's target, in solve order: analytically
    where its parent's pose is known (``_predicted``), else through the depsgraph (updated only when something
    changed since); its basis read back. Returns {control: (frames, 4, 4) basis}."""
    pose, bones = armature.pose.bones, armature.data.bones
    view_layer = bpy.context.view_layer
    basis = {c: np.empty((frames, 4, 4)) for c, _d in pairs}
    rests = {}

    def rest(b):
        if b not in rests:
            rests[b] = np.array(bones[b].matrix_local, dtype=np.float64)
        return rests[b]

    start = {c: np.array(pose[c].matrix_basis, dtype=np.float64) for c in basis}
    for f in range(frames):
        known, dirty = {}, True
        for c, d in pairs:
            j = index[d]
            T = W[f, j] @ rest(c)[:3, :3]
            parent = pose[c].parent
            Mp = None if c == "torso" or parent is None else _predicted(armature, parent.name, known, rest)
            if Mp is not None:  # the basis that turns the control to T where its parent puts it
                A = Mp @ np.linalg.solve(rest(parent.name), rest(c))
                B = start[c].copy()
                B[:3, :3] = nearest_rotation(A[:3, :3]).T @ T
                pose[c].matrix_basis = Matrix(B.tolist())
                known[c], dirty = A @ B, True
                continue
            if dirty:
                view_layer.update()
                dirty = False
            M = np.eye(4)
            M[:3, :3] = T
            if c == "torso":  # torso: moved with its deform bone (its head carried rigidly)
                M[:3, 3] = heads[f, j] + W[f, j] @ (rest(c)[:3, 3] - np.asarray(bones[d].head_local))
            else:  # the others turn where their parents put them
                M[:3, 3] = np.asarray(pose[c].matrix.translation)
            pose[c].matrix = Matrix(M.tolist())
            known[c], dirty = M, True
        for c in basis:
            basis[c][f] = np.array(pose[c].matrix_basis, dtype=np.float64)
    return basis


def _switch_bones(armature) -> List[str]:
    return [pb.name for pb in armature.pose.bones if IK_FK in pb.keys()]


def write_onto_controls(clip: Clip, armature, name: str):
    """A new action on ``armature`` (a Rigify rig) keying its FK controls (``RIGIFY_CONTROLS``: torso with its
    location, hips, chest, the FK spine, neck, head, shoulders, the limbs' FK bones) and each limb's FK/IK switch
    at FK (``IK_FK`` = 1 on the limbs' parent bones, keyed), so that its deform bones make ``clip``'s motion.

    ``clip``: a motion of the deform bones in armature space (``deform_rest_clip``'s layout, e.g. from
    ``retarget.onto_armature``). A visual solve: frame by frame each control's pose matrix is set from its deform
    bone's target (``W_d`` times the control's rest orientation; the torso also from the deform bone's head),
    parents before children, through the depsgraph; the resulting channels are written by
    ``action_io.write_action``. The armature's action, pose and switches are as before afterwards; the new action
    is not assigned. ShapeSigError when the armature has none of these controls."""
    from dataclasses import replace

    from ..core.clip import skeleton

    obj = _armature(armature)
    if clip.meta.get("rotation_space") != "armature":
        raise ShapeSigError(f"clip {clip.name!r}: a motion for the controls is given in the armature's axes")
    pairs = _controls(obj, clip)
    if not any(c == "torso" for c, _d in pairs):
        raise ShapeSigError(f"armature {obj.name!r} has no Rigify controls (torso, FK limbs) for {clip.name!r}")
    parents = dict(deform_parents(obj), **(clip.meta.get("parents") or {}))
    B, h, t = _rest(obj, list(clip.bones))
    full = replace(clip, meta=dict(clip.meta, parents=parents, **rest_meta(list(clip.bones), list(map(tuple, h)),
                                                                           list(map(tuple, t)))))
    heads, _tails, W = skeleton.forward_kinematics(full)
    index = {b: j for j, b in enumerate(clip.bones)}
    switches = _switch_bones(obj)
    saved = {pb.name: pb.matrix_basis.copy() for pb in obj.pose.bones}
    saved_switch = {b: obj.pose.bones[b][IK_FK] for b in switches}
    with _Borrowed(obj, None):
        try:
            for b in switches:
                obj.pose.bones[b][IK_FK] = 1.0
            basis = _solve(obj, pairs, W, heads, index, clip.frames)
        finally:
            for b, m in saved.items():
                obj.pose.bones[b].matrix_basis = m
            for b, v in saved_switch.items():
                obj.pose.bones[b][IK_FK] = v
            bpy.context.view_layer.update()
    controls = list(basis)
    P = np.stack([nearest_rotation(basis[c][:, :3, :3]) for c in controls], axis=1)
    keyed = Clip(name=name, bones=tuple(controls), rotations=P, fps=clip.fps, frame_start=clip.frame_start,
                 root_translation=basis["torso"][:, :3, 3].copy(), root_bone="torso",
                 meta={"rotation_space": "pose"})
    action = action_io.write_action(keyed, armature=obj, name=name, root_bone="torso")
    try:
        bag, _slot = compat.ensure_channelbag(action, "OBJECT", name=obj.name)
        ends = np.array([clip.frame_start, 1.0, clip.frame_end, 1.0], dtype=np.float32)
        for b in switches:
            fc = compat.new_fcurve(bag, f'pose.bones["{bpy.utils.escape_identifier(b)}"]["{IK_FK}"]', 0, b)
            fc.keyframe_points.add(2)
            fc.keyframe_points.foreach_set("co", ends)
            fc.update()
    except Exception:
        compat.remove_action(action)
        raise
    action["shapesig_controls"] = True
    return action
