"""Blend two actions of an armature into new actions: the Blender half of ``core.blend`` (issue 6).

``blend_actions(armature, action_a, action_b, weights, ...)`` reads both actions (keyed bones only, in
armature space), blends them with ``core.blend.blend_clip_series`` (one elastic warp for every in-between),
writes each blend as a new action ``<A>_x_<B>_<weight>`` with a fake user and returns them. A and B are never
modified; on any error nothing is created. The operator ``shapesig.blend_actions`` only parses its
properties, calls this and reports. See docs/blending.md.
"""

from dataclasses import dataclass, field
from typing import List, Optional, Sequence

import bpy
import numpy as np

from . import action_io, compat, rigmap
from .core.blend import blend_clip_series
from .core.errors import ShapeSigError
from .core.metrics import DEFAULT_DEPTH

__all__ = ["BlendResult", "blend_actions", "armature_up_axis", "unique_action_name", "selected_bone_names"]


@dataclass
class BlendResult:
    """The new actions, the blended clips (their ``meta`` holds the warp and d_S*) and the bones of A that
    B does not animate (they keep A's motion)."""

    actions: List["bpy.types.Action"]
    clips: list
    unmatched: Sequence[str] = field(default_factory=tuple)


def armature_up_axis(armature, bone_name):
    """The world's up (+Z) in the rest frame of ``bone_name`` (where its location and rotation channels live),
    as a unit 3-vector; None when the bone does not exist."""
    bone = armature.data.bones.get(bone_name) if bone_name else None
    if bone is None:
        return None
    obj_rot = np.array(armature.matrix_world.to_3x3().normalized(), dtype=np.float64)
    rest = np.array(bone.matrix_local.to_3x3().normalized(), dtype=np.float64)
    # world vector -> armature space -> bone rest space
    up = rest.T @ (obj_rot.T @ np.array([0.0, 0.0, 1.0]))
    n = float(np.linalg.norm(up))
    return None if n < 1e-9 else tuple(float(c) / n for c in up)


def unique_action_name(base, taken=()):
    """``base`` when no action has that name, else ``base_2``, ``base_3``, ... (Blender would turn a taken
    ``walk_x_run_0.50`` into ``walk_x_run_0.001``: it reads ``.50`` as a number suffix)."""
    if base not in bpy.data.actions and base not in taken:
        return base
    k = 2
    while f"{base}_{k}" in bpy.data.actions or f"{base}_{k}" in taken:
        k += 1
    return f"{base}_{k}"


def selected_bone_names(armature):
    """Names of the armature's selected pose bones."""
    return [pb.name for pb in armature.pose.bones if compat.pose_bone_selected(pb)]


def blend_actions(armature, action_a, action_b, weights, *, align=True, depth=DEFAULT_DEPTH, frames=None,
                  bones: Optional[Sequence[str]] = None, root="blend", progress=None) -> BlendResult:
    """Blend ``action_a`` towards ``action_b`` at each weight into new actions on ``armature``.

    ``bones``: blend only these (the others keep A's motion); each must be animated in both actions.
    ``root``: "blend" (root displacements blended in the heading frame) or "a" (A's root path).
    ``progress(done, total)``: called after each blend and each written action (2 per weight)."""
    if action_a == action_b:
        raise ShapeSigError(f"A and B are the same action {action_a.name!r}; choose two different actions")
    # B of another rig (issue 14): both through their armatures' bone maps (rigmap.bone_map_of), back onto A's rig
    from .library import owner_armature

    other = owner_armature(action_b, armature)
    across = rigmap.across_rigs(armature, other)
    space = "armature" if across else "pose"
    a = action_io.read_action(action_a, armature=armature, exclude_unkeyed=True, space=space)
    b = action_io.read_action(action_b, armature=other if across else armature, exclude_unkeyed=True, space=space)
    if across:
        a_rig, (a, b, bones) = a, rigmap.onto_comparison(a, armature, b, other, bones)
    if bones is not None:
        shared = set(a.bones) & set(b.bones)
        missing = [x for x in bones if x not in shared]
        if missing:
            raise ShapeSigError(f"bone(s) {', '.join(missing[:5])} are not animated in both {action_a.name!r} "
                                f"and {action_b.name!r}")
    n = len(weights)
    clips = blend_clip_series(a, b, weights, align=align, depth=depth, frames=frames, bones=bones, root=root,
                              up_axis=None if across else armature_up_axis(armature, a.root_bone),
                              progress=(lambda i, _n: progress(i, 2 * n)) if progress else None)
    if across:
        clips = [rigmap.back_onto_armature(x, a_rig, a) for x in clips]
    created, names = [], []
    try:
        for i, clip in enumerate(clips):
            names.append(unique_action_name(clip.name, names))
            created.append(action_io.write_action(clip, armature=armature, name=names[-1], fake_user=True))
            if progress:
                progress(n + i + 1, 2 * n)
    except BaseException:
        for act in created:
            compat.remove_action(act)
        raise
    return BlendResult(created, clips, tuple(clips[0].meta.get("kept_bones" if across else "unmatched_a", ())))
