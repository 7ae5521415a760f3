"""``.blend`` clips: ``read_blend_file(path, action_name=None)`` reads the actions of a .blend file that animate pose
bones, in a child process (``_blend_file_child``), so a damaged file is a ParseError, never a crash; the file's
structure is checked first (``core.io.blend_file.check_blend``). ``SHAPESIG_BLEND_IN_PROCESS=1`` reads in this
process. See docs/dev/blender_layer.md.
"""

import os

import bpy

from .. import compat
from ..actions import action_io, action_spaces
from ..actions.bone_channels import bone_channels
from ..core.clip.clip import Clip
from ..core.errors import ParseError, ShapeSigError
from ..core.io.files import check_file
from ..core.io.blend_file import check_blend
from .blend_isolated import BLEND_CHILD_TIMEOUT, BLEND_IN_PROCESS_ENV, read_blend_isolated  # noqa: F401
from ..actions.owners import find_owner
from .scratch import id_snapshot, remove_new_ids

__all__ = ["read_blend_file", "read_blend_here", "rig_of", "BLEND_IN_PROCESS_ENV"]



def read_blend_file(path, action_name=None, space="armature", rig=False):
    """The clips of a .blend file (every action animating pose bones, or ``action_name``), read in a child
    process. ``rig``: each clip's ``meta["rig"]`` describes the armature that owns its action (``rig_of``: what
    ``write_blend_file`` rebuilds the armature from), absent when no armature holds its bones."""
    check_blend(path)
    if os.environ.get(BLEND_IN_PROCESS_ENV) == "1":
        return read_blend_here(path, action_name, space, rig)
    return read_blend_isolated(path, action_name, space, rig)


def read_blend_here(path, action_name=None, space="armature", rig=False):
    """``read_blend_file`` in this process (what the child process runs): a regular file within the size cap
    (``core.io.files``) only."""
    check_file(path)
    try:
        with bpy.data.libraries.load(path, link=False) as (data_from, _to):
            available = list(data_from.actions)
            objects = list(data_from.objects)
    except (OSError, RuntimeError) as exc:
        raise ParseError(f"cannot read .blend file: {str(exc).splitlines()[0] if str(exc) else exc}", path) from None
    except UnicodeDecodeError:
        raise ParseError("corrupt .blend file (a name is not valid UTF-8 text)", path) from None
    if action_name is not None and action_name not in available:
        shown = ", ".join(available[:8]) + (" ..." if len(available) > 8 else "")
        raise ParseError(f"no action {action_name!r} in the file (it has: {shown or 'none'})", path)
    wanted = [action_name] if action_name is not None else available
    if not wanted:
        raise ParseError("the file has no actions", path)
    before = id_snapshot()
    try:
        with bpy.data.libraries.load(path, link=False) as (data_from, data_to):
            data_to.actions = list(wanted)
            data_to.objects = objects
        loaded_objects = [o for o in data_to.objects if o is not None]
        armatures = [o for o in loaded_objects if o.type == "ARMATURE"]
        clips = []
        for want, action in zip(wanted, data_to.actions):
            if action is None:
                continue
            if not bone_channels(compat.all_action_fcurves(action)):
                if action_name is not None:
                    raise ParseError(f"action {action_name!r} animates no pose bones", path)
                continue
            arm = find_owner(action, armatures)
            clip = action_io.read_action(action, armature=arm, name=want,
                                         bones=None if arm is None else _animated_bones(action, arm),
                                         space="armature" if (space == "armature" and arm is not None) else "pose")
            clip.source = f"{path}#{want}"
            clip.meta["format"] = "blend"
            if rig and arm is not None:
                clip.meta["rig"] = rig_of(arm)
            clips.append(clip)
        if not clips:
            raise ParseError("no action in the file animates pose bones", path)
        return clips
    except ShapeSigError as exc:
        if isinstance(exc, ParseError):
            raise
        raise ParseError(str(exc), path) from None
    except UnicodeDecodeError:
        raise ParseError("corrupt .blend file (a name is not valid UTF-8 text)", path) from None
    finally:
        remove_new_ids(before)


def _animated_bones(action, arm):
    """The armature's bones (armature order) that the action animates."""
    keyed = set(bone_channels(compat.all_action_fcurves(action)))
    return [b.name for b in arm.data.bones if b.name in keyed]


def rig_of(arm):
    """What rebuilds the armature object ``arm`` (JSON values): its names and world matrix, and per bone (in the
    armature's order) its parent, head, tail and z axis in armature space, its flags of inheritance and its pose
    rotation mode. Nothing else of the file (no drivers, constraints, custom properties or other data-blocks)."""
    bones = []
    for b in arm.data.bones:
        pb = arm.pose.bones.get(b.name)
        bones.append({
            "name": b.name, "parent": b.parent.name if b.parent is not None else None,
            "head": list(b.head_local), "tail": list(b.tail_local), "z": list(b.matrix_local.to_3x3().col[2]),
            "connect": b.use_connect, "inherit_rotation": b.use_inherit_rotation, "inherit_scale": b.inherit_scale,
            "local_location": b.use_local_location, "deform": b.use_deform,
            "rotation_mode": pb.rotation_mode if pb is not None else "QUATERNION",
        })
    world = action_spaces.world_matrix(arm)  # an appended object's matrix_world is not evaluated: composed here
    return {"object": arm.name, "data": arm.data.name, "matrix_world": [list(r) for r in world],
            "bones": bones}
