"""The spaces of an armature's rotations (Blender layer): ``to_armature_space`` turns pose-bone rotations (each
bone's rest frame) into the world's axes as the scene shows the armature (the package's comparison space) and
``to_pose_space`` back; ``world_matrix`` / ``object_matrix`` give an armature object's world transform (also for
one loaded from a library into no scene), ``up_in_bone_frame`` the world's up in a bone's rest frame. See
docs/action_io.md.
"""

from dataclasses import replace

import numpy as np

from ..core.clip.clip import Clip
from ..core.errors import ShapeSigError
from ..core.clip.skeleton import from_world_axes, to_world_axes
from ..core.geometry.so3 import nearest_rotation

__all__ = ["to_armature_space", "to_pose_space", "object_matrix", "world_matrix", "up_in_bone_frame"]


def up_in_bone_frame(armature, bone_name):
    """The world's up (+Z) in the rest frame of ``bone_name`` (where its location and rotation channels live),
    as a unit 3-vector; None when the bone does not exist."""
    bone = armature.data.bones.get(bone_name) if bone_name else None
    if bone is None:
        return None
    obj_rot = np.array(armature.matrix_world.to_3x3().normalized(), dtype=np.float64)
    rest = np.array(bone.matrix_local.to_3x3().normalized(), dtype=np.float64)
    up = rest.T @ (obj_rot.T @ np.array([0.0, 0.0, 1.0]))  # world -> armature -> bone rest space
    n = float(np.linalg.norm(up))
    return None if n < 1e-9 else tuple(float(c) / n for c in up)


def _rest_frames(bones, armature):
    """(B, heads): armature-space rest orientation (bones, 3, 3) and head (bones, 3) of each named bone."""
    missing = [b for b in bones if b not in armature.data.bones]
    if missing:
        raise ShapeSigError(f"armature {armature.name!r} has no bone(s) {', '.join(missing[:5])}")
    B = nearest_rotation(
        np.array([np.array(armature.data.bones[b].matrix_local.to_3x3()) for b in bones], dtype=np.float64))
    heads = np.array([np.array(armature.data.bones[b].head_local) for b in bones], dtype=np.float64)
    return B, heads


def world_matrix(obj):
    """``obj``'s world matrix (mathutils): ``matrix_world`` for an object of a scene; for one loaded from a
    library into no scene (a reader's), whose ``matrix_world`` was never evaluated here, its own transform
    composed with its parents' (``parent world @ matrix_parent_inverse @ matrix_basis``; an object parent)."""
    if obj.users_scene or obj.parent is None:
        return obj.matrix_world if obj.users_scene else obj.matrix_basis
    return world_matrix(obj.parent) @ obj.matrix_parent_inverse @ obj.matrix_basis


def object_matrix(armature):
    """The armature object's world matrix (4x4 numpy; rotation, scale, parents), or None when it is the identity
    (then nothing is re-expressed: the numbers stay exactly those of the armature's own axes); ``world_matrix``."""
    M = np.array(world_matrix(armature), dtype=np.float64)
    return None if np.array_equal(M, np.eye(4)) else M


def to_armature_space(clip: Clip, armature) -> Clip:
    """Pose-bone rotations P (each bone's rest frame) -> the same rotations in the world's axes as the scene shows
    the armature: X = A B P B^T A^T with B the bone's rest orientation and A the rotation of the object's world
    matrix (``object_matrix``: its rotation, scale and parents; ``skeleton.to_world_axes``); the root translation
    becomes the root bone's head in the world, M (head + B loc). (The space keeps its name, "armature": for an
    armature object at the identity, as every reader's, both are the same.)

    This is the space the package compares and blends clips in: it does not depend on bone rolls nor on how the
    armature object is turned or scaled (an FBX character imported lying in its armature's axes, a rig parented
    to a turned empty), so rigs with other roll conventions, BVH and ASF/AMC imports of the same take, and folder
    clips all agree. d_P*, d_S* and tensor-basis signatures of one rig are unchanged by it (a constant rotation
    per joint); Lyndon coordinates change slightly.
    """
    if clip.meta.get("rotation_space", "pose") != "pose":
        raise ShapeSigError(f"clip {clip.name!r} is not in pose space")
    B, heads = _rest_frames(clip.bones, armature)
    X = B[None] @ clip.rotations @ np.swapaxes(B, -1, -2)[None]
    rt = clip.root_translation
    if rt is not None and clip.root_bone in armature.data.bones:
        Br, hr = _rest_frames([clip.root_bone], armature)
        rt = hr[0] + rt @ Br[0].T
    meta = dict(clip.meta, rotation_space="armature", up_axis="Z")
    out = replace(clip, rotations=X, root_translation=rt, meta=meta)
    M = object_matrix(armature)
    return out if M is None else to_world_axes(out, M)


def to_pose_space(clip: Clip, armature) -> Clip:
    """The inverse of ``to_armature_space`` for ``armature``'s bones: the world's axes back into the armature's
    (``skeleton.from_world_axes``), then P = B^T X B, loc = B^T (x - head)."""
    if clip.meta.get("rotation_space") != "armature":
        raise ShapeSigError(f"clip {clip.name!r} is not in armature space")
    M = object_matrix(armature)
    if M is not None:
        clip = from_world_axes(clip, M)
    B, _heads = _rest_frames(clip.bones, armature)
    P = np.swapaxes(B, -1, -2)[None] @ clip.rotations @ B[None]
    rt = clip.root_translation
    if rt is not None:
        root = clip.root_bone if clip.root_bone in armature.data.bones else None
        if root is None:
            rt = None
        else:
            Br, hr = _rest_frames([root], armature)
            rt = (rt - hr[0]) @ Br[0]
    meta = dict(clip.meta, rotation_space="pose")
    meta.pop("up_axis", None)
    meta.pop("axes", None)
    return replace(clip, rotations=P, root_translation=rt, meta=meta)
