"""Another rig's motion on an armature (Blender layer), the retargeting the command line's blends use: the source clip
(in its own armature's axes) goes to the comparison space through its bone map (``core.rigs.apply_bone_map``), is
made relative to the target's rest pose (``core.rigs.rest_retarget`` against the target at rest) and written back
onto the target's bones (``core.rigs.onto_rig``): mapped bones take the motion, the root moves the hips by the same
leg lengths at the target's size, bones between two written spine / neck joints share the chain's rotation, bones
without a counterpart keep their rest (``Retargeted.kept``). A Rigify rig (``control_rigs.is_rigify``) is mapped by its
deform skeleton and written by keying its FK controls (``control_rigs.write_onto_controls``). Results of the search
(Assign, Preview, Blend) go through ``onto_armature``; the source is only read. See docs/rigs.md.
"""

from dataclasses import dataclass, replace
from typing import Tuple

import numpy as np

from ..actions import action_spaces, control_rigs, scene_motion
from . import rigmap
from ..core import rigs
from ..core.clip.clip import Clip
from ..core.clip.skeleton import rest_meta
from ..core.errors import ShapeSigError

__all__ = ["rest_clip", "needs_retarget", "onto_armature", "Retargeted", "action_on_armature"]


@dataclass
class Retargeted:
    """The clip on the target armature (its armature space) and the target's bones that kept their rest."""

    clip: Clip
    kept: Tuple[str, ...]


def rest_clip(armature, frames=2, fps=24.0, name="rest") -> Clip:
    """``armature`` standing in its rest pose for ``frames`` frames, in its armature space (with its hierarchy and
    rest skeleton in ``meta``, as ``action_io.read_action`` gives them)."""
    bones = armature.data.bones
    names = [b.name for b in bones]
    root = next((b.name for b in bones if b.parent is None), names[0])
    clip = Clip(name=name, bones=tuple(names), rotations=np.broadcast_to(np.eye(3), (frames, len(names), 3, 3)).copy(),
                fps=float(fps), frame_start=1, root_translation=np.zeros((frames, 3)), root_bone=root,
                meta={"parents": {b.name: (b.parent.name if b.parent else None) for b in bones},
                      "rotation_space": "pose"})
    clip.meta.update(rest_meta(names, [b.head_local for b in bones], [b.tail_local for b in bones]))
    return action_spaces.to_armature_space(clip, armature)


def needs_retarget(clip: Clip, armature) -> bool:
    """True when ``clip`` (read with its own rig, armature space) is of another rig than ``armature``: bones the
    armature lacks, or the same bones in another rest pose (``core.rigs.other_rigs``)."""
    if not set(clip.bones) <= {b.name for b in armature.data.bones}:
        return True
    return rigs.other_rigs(clip, _restricted_rest(armature, clip.bones))


def _restricted_rest(armature, bones):
    rest = rest_clip(armature)
    index = [rest.bones.index(b) for b in bones]
    return replace(rest, bones=tuple(bones), rotations=rest.rotations[:, index])


def onto_armature(clip: Clip, source_map, armature, name=None) -> Retargeted:
    """``clip`` (armature space of its own rig with ``meta`` parents and rest skeleton, or already in the
    comparison space) on ``armature``'s bones through
    ``source_map`` (the source rig's bone map: "auto" or a dict) and the armature's (``rigmap.bone_map_of``).
    ShapeSigError (one line) when either rig maps no joint or they share too few."""
    if clip.meta.get("rotation_space") not in ("armature", "comparison"):  # files come mapped (sources.read)
        raise ShapeSigError(f"clip {clip.name!r}: another rig's motion is retargeted from its armature's axes")
    mb = rigs.apply_bone_map(clip, source_map)
    if control_rigs.is_rigify(armature):  # its deform skeleton is the body (write_onto_controls keys its controls)
        rest = scene_motion.in_world(control_rigs.deform_rest_clip(armature, clip.frames, clip.fps, name or clip.name),
                                     armature)
    else:
        rest = rest_clip(armature, clip.frames, clip.fps, name or clip.name)
    ma = rigs.apply_bone_map(rest, rigmap.bone_map_of(armature))
    for c, rig in ((mb, clip.name), (ma, armature.name)):
        if c.meta.get("rotation_space") != "comparison":
            raise ShapeSigError(f"no bone of {rig!r} maps to a body joint: map its bones in the Bone Map panel")
    shared = [j for j in mb.bones if j in ma.bones]
    if len(shared) < rigs.MIN_COVERAGE * min(len(ma.bones), rigs.moving_count(mb) or 1):
        raise ShapeSigError(f"{clip.name!r} and {armature.name!r} share only {len(shared)} body joints: map their "
                            f"bones in the Bone Map panel")
    moved = rigs.rest_retarget(mb, ma)
    out = rigs.onto_rig(replace(moved, name=name or clip.name), rest, ma)
    joint_bones = {ma.meta["bone_map"][j] for j in shared}
    # bones between two written spine / neck joints share the chain's rotation (core.rigs.chains): not kept
    kept = tuple(b for b in rest.bones if b not in joint_bones and b not in out.meta.get("chain_bones", ()))
    out.meta["kept_bones"] = kept
    out.meta["rotation_space"] = "armature"
    return Retargeted(out, kept)


def action_on_armature(clip: Clip, source_map, armature, name):
    """(new action on ``armature`` holding ``clip`` retargeted, keyed at the scene's rate, bones kept at rest; on a
    Rigify rig the action keys its FK controls: ``scene_motion.write_motion``)."""
    got = onto_armature(clip, source_map, armature, name)
    action = scene_motion.write_motion(got.clip, armature, name=name)
    action["shapesig_retargeted_from"] = clip.name
    return action, got.kept
