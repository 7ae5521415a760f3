"""Clips written as Blender actions: ``write_action`` makes a new action (never modifies one) with one LINEAR key
per frame per channel, in each bone's rotation mode, and records the frame rate and the modes on it;
``assign_action`` plays it without losing the replaced action. ``action_io`` re-exports both beside its reader.
Version differences go through ``compat``. See docs/action_io.md.
"""

import bpy
import numpy as np

from .. import compat
from .action_spaces import to_pose_space
from .bone_channels import bone_channels, mode_from_channels, modes_lookup, prop_for_mode
from ..core.clip.clip import Clip
from ..core.errors import ShapeSigError
from ..core.geometry.so3 import ROTATION_MODES, channels_from_matrices

__all__ = ["write_action", "assign_action"]

_INTERP_LINEAR = 1  # Keyframe.interpolation enum value of 'LINEAR' (CONSTANT=0, LINEAR=1, BEZIER=2)


def _bone_path(bone, prop):
    return f'pose.bones["{bpy.utils.escape_identifier(bone)}"].{prop}'


def _write_fcurve(bag, bone, prop, index, frames_f32, values, co_buf, interp):
    fc = compat.new_fcurve(bag, _bone_path(bone, prop), index, bone)
    kp = fc.keyframe_points
    kp.add(len(frames_f32))
    co_buf[1::2] = values
    kp.foreach_set("co", co_buf)
    kp.foreach_set("interpolation", interp)
    fc.update()
    return fc


def write_action(clip: Clip, armature=None, name=None, rotation_modes=None, fake_user=True,
                 assign=False, root_bone=None) -> "bpy.types.Action":
    """A new action holding ``clip`` (one key per frame per channel). Rotation mode per bone:
    ``rotation_modes`` (one mode, a dict or a sequence parallel to clip.bones), else the armature's pose bone,
    else ``clip.rotation_modes``, else QUATERNION. The root translation is written as the ``location`` of
    ``root_bone`` (default ``clip.root_bone`` when it is in clip.bones, else the first bone). With ``assign`` the armature's active
    action becomes the new action. On error nothing is left behind."""
    if not isinstance(clip, Clip):
        raise ShapeSigError("write_action needs a Clip")
    if armature is not None and getattr(armature, "type", None) != "ARMATURE":
        raise ShapeSigError(f"{getattr(armature, 'name', armature)!r} is not an armature object")
    space = clip.meta.get("rotation_space", "pose")
    if space == "armature":
        if armature is None:
            raise ShapeSigError(f"clip {clip.name!r} is in armature space: writing it needs the target armature")
        clip = to_pose_space(clip, armature)
    # any other space is written as it is: its rotations become the pose-bone rotations
    override = modes_lookup(rotation_modes, clip.bones)
    clip_modes = dict(zip(clip.bones, clip.rotation_modes)) if clip.rotation_modes else {}
    modes = []
    for b in clip.bones:
        if b in override:
            mode = override[b]
        elif armature is not None and b in armature.pose.bones:
            mode = armature.pose.bones[b].rotation_mode
        elif clip_modes.get(b) in ROTATION_MODES:
            mode = clip_modes[b]
        else:
            mode = "QUATERNION"
        modes.append(mode)

    nf = clip.frames
    frames = np.arange(clip.frame_start, clip.frame_start + nf, dtype=np.float32)
    co_buf = np.empty(2 * nf, dtype=np.float32)
    co_buf[0::2] = frames
    interp = np.full(nf, _INTERP_LINEAR, dtype=np.int32)
    # compute every channel before creating anything
    channel_values = [channels_from_matrices(m, clip.rotations[:, j]) for j, m in enumerate(modes)]
    root = root_bone or (clip.root_bone if clip.root_bone in clip.bones else clip.bones[0])
    f32 = float(np.finfo(np.float32).max)
    for what, values in [("root translation", clip.root_translation)] + list(zip(clip.bones, channel_values)):
        if values is not None and not (np.all(np.isfinite(values)) and np.abs(values).max(initial=0.0) < f32):
            raise ShapeSigError(f"clip {clip.name!r}: {what} values are not finite or too large for keyframes")
    if abs(clip.frame_start) + nf > 2 ** 24:
        raise ShapeSigError(f"clip {clip.name!r}: frame numbers {clip.frame_start}..{clip.frame_end} are too large "
                            f"for keyframes")

    action = bpy.data.actions.new(name or clip.name)
    try:
        bag, _slot = compat.ensure_channelbag(action, "OBJECT", name=(armature.name if armature else None))
        for j, (b, mode) in enumerate(zip(clip.bones, modes)):
            prop = prop_for_mode(mode)
            vals = channel_values[j]
            if b == root and clip.root_translation is not None:
                for i in range(3):
                    _write_fcurve(bag, b, "location", i, frames, clip.root_translation[:, i], co_buf, interp)
            for i in range(vals.shape[1]):
                _write_fcurve(bag, b, prop, i, frames, vals[:, i], co_buf, interp)
        if root_bone is not None and root not in clip.bones and clip.root_translation is not None:
            for i in range(3):
                _write_fcurve(bag, root, "location", i, frames, clip.root_translation[:, i], co_buf, interp)
        action.use_fake_user = bool(fake_user)
        # what an action cannot say by itself, for read_action without an armature
        action["shapesig_fps"] = float(clip.fps)
        action["shapesig_rotation_modes"] = dict(zip(clip.bones, modes))
        if assign and armature is not None:
            assign_action(armature, action)
    except Exception:
        compat.remove_action(action)
        raise
    return action


def assign_action(armature, action, keep_previous=True):
    """Make ``action`` the armature's active action, with each bone it keys rotations for switched to the
    rotation mode of those curves (the exact Euler order recorded by ``write_action`` when there is one). A bone
    the action keys no rotation for keeps its mode: a bone is never left in a mode the action has no curves for.

    ``keep_previous``: the action it replaces is never left without users (it would vanish on save): when the
    armature was its only user and it has no fake user, it is stashed in the NLA (``compat.stash_action``)."""
    ad = armature.animation_data
    previous = ad.action if ad is not None else None
    if keep_previous and previous is not None and previous != action and not previous.use_fake_user \
            and previous.users <= 1:
        compat.stash_action(armature, previous)
    written = action.get("shapesig_rotation_modes")
    written = written.to_dict() if hasattr(written, "to_dict") else dict(written or {})
    for bone, props in bone_channels(compat.all_action_fcurves(action)).items():
        pb = armature.pose.bones.get(bone)
        if pb is None or not any(p.startswith("rotation_") for p in props):
            continue
        mode = written.get(bone)
        if mode not in ROTATION_MODES or prop_for_mode(mode) not in props:
            if prop_for_mode(pb.rotation_mode) in props:
                continue  # the current mode already plays the action's curves
            mode = mode_from_channels(props)
        if pb.rotation_mode != mode:
            pb.rotation_mode = mode
    compat.assign_action(armature, action)
