"""Blender armature actions <-> ``core.clip.clip.Clip``: ``read_action`` samples an action's pose-bone rotations on every
integer frame (every rotation mode; pose space or the armature's axes, ``space``), with the root translation, the
frame rate and ``meta``; ``write_action`` (a new action, one LINEAR key per frame per channel) and ``assign_action``
(play it without losing the replaced action) are owned by ``action_write`` and re-exported here. Version differences
go through ``compat``. See docs/action_io.md.
"""

import math

import bpy
import numpy as np

from .. import compat
from .action_hashes import action_hash, read_hash
from .action_spaces import _rest_frames, to_armature_space
from .action_write import assign_action, write_action
from .bone_channels import PROPS as _PROPS, bone_channels, mode_from_channels, modes_lookup, prop_for_mode
from ..core.clip.clip import Clip
from ..core.errors import ShapeSigError, check_frame_range
from ..core.clip.skeleton import fold_root_motion, rest_meta
from ..core.io.files import check_frames
# the rotation maths is core.geometry.so3's; the channel conversions are re-exported here, where callers know them
from ..core.geometry.so3 import EULER_MODES, ROTATION_MODES, channels_from_matrices, matrices_from_channels

__all__ = ["read_action", "write_action", "assign_action", "action_hash", "read_hash", "armature_actions",
           "EULER_MODES", "SPACES", "channels_from_matrices", "matrices_from_channels"]

SPACES = ("pose", "armature")

_DEFAULTS = {
    "rotation_quaternion": (1.0, 0.0, 0.0, 0.0),
    "rotation_euler": (0.0, 0.0, 0.0),
    "rotation_axis_angle": (0.0, 0.0, 1.0, 0.0),
    "location": (0.0, 0.0, 0.0),
}


def _content_hash(action, co_cache):
    """``read_hash``, or the session's remembered fingerprint of it (``action_changes``) when current."""
    from .action_changes import remembered_hash

    return remembered_hash(action) or read_hash(action, co_cache)


def armature_actions(obj=None):
    """Actions in bpy.data that animate pose bones; with an armature object, only those that animate at
    least one of its bones. In bpy.data order. (The bones an action animates are remembered with its
    fingerprint: see ``action_changes``.)"""
    from .action_changes import action_bones  # remembered per session with the action's fingerprint

    names = None
    if obj is not None:
        if getattr(obj, "type", None) != "ARMATURE":
            raise ShapeSigError(f"{getattr(obj, 'name', obj)!r} is not an armature object")
        names = {b.name for b in obj.data.bones}
    out = []
    for action in bpy.data.actions:
        bones = action_bones(action)
        if not bones:
            continue
        if names is not None and names.isdisjoint(bones):
            continue
        out.append(action)
    return out


def _keys_on_every_frame(fc, start, n, co_cache=None):
    """The key values when ``fc`` has exactly one key on each frame start..start+n-1 and no modifiers."""
    kp = fc.keyframe_points
    if len(kp) != n or len(fc.modifiers):
        return None
    co = np.empty(2 * n, dtype=np.float32)
    kp.foreach_get("co", co)
    if co_cache is not None:
        co_cache[fc.as_pointer()] = co
    if not np.array_equal(co[0::2], np.arange(start, start + n, dtype=np.float32)):
        return None
    return co[1::2].astype(np.float64)


def _sample(fc, frames, start, co_cache=None):
    values = _keys_on_every_frame(fc, start, len(frames), co_cache)
    if values is not None:
        return values
    ev = fc.evaluate
    return np.fromiter((ev(f) for f in frames), dtype=np.float64, count=len(frames))


def _sample_prop(chans, prop, frames, start, co_cache=None):
    size = _PROPS[prop]
    out = np.empty((len(frames), size))
    default = _DEFAULTS[prop]
    got = chans.get(prop, {})
    for i in range(size):
        fc = got.get(i)
        out[:, i] = default[i] if fc is None else _sample(fc, frames, start, co_cache)
    return out


def _action_frame_range(action, channels, bones):
    if getattr(action, "use_frame_range", False):
        return int(round(action.frame_start)), int(round(action.frame_end))
    lo, hi = math.inf, -math.inf
    for b in bones:
        for prop in channels.get(b, {}).values():
            for fc in prop.values():
                if len(fc.keyframe_points):
                    a, z = fc.range()
                    lo, hi = min(lo, a), max(hi, z)
    if lo == math.inf:
        return None
    # keys within a thousandth of a frame of an integer frame are on it (glTF keys are float32 seconds: 317/120 s
    # is frame 317.00015 at 120 fps)
    return int(math.floor(lo + 1e-3)), int(math.ceil(hi - 1e-3))


_ROT_PROPS = ("rotation_quaternion", "rotation_euler", "rotation_axis_angle")


def _check_read(action, armature, space):
    if action is None:
        raise ShapeSigError("no action given")
    if space not in SPACES:
        raise ShapeSigError(f"space must be one of {', '.join(SPACES)}, got {space!r}")
    if space == "armature" and armature is None:
        raise ShapeSigError(f"reading action {action.name!r} in armature space needs its armature")
    if armature is not None and getattr(armature, "type", None) != "ARMATURE":
        raise ShapeSigError(f"{getattr(armature, 'name', armature)!r} is not an armature object")


def _read_bones(action, armature, bones, channels, exclude_unkeyed):
    """(bone names to read, names among them the action keys no rotation for)."""
    if bones is not None:
        names = list(bones)
    elif armature is not None:
        names = [b.name for b in armature.data.bones]
    else:
        names = list(channels)
    if armature is not None:
        missing = [b for b in names if b not in armature.pose.bones]
        if missing:
            raise ShapeSigError(f"armature {armature.name!r} has no bone(s) {', '.join(missing[:5])}")
    if not names:
        raise ShapeSigError(f"action {action.name!r} animates no pose bones")
    unkeyed = [b for b in names if not any(p in channels.get(b, {}) for p in _ROT_PROPS)]
    if exclude_unkeyed:
        names = [b for b in names if b not in unkeyed]
        if not names:
            raise ShapeSigError(f"action {action.name!r} has no rotation channels for the bones asked for")
    return names, unkeyed


def _read_range(action, channels, names, frame_range):
    """(first, last) frame to sample: ``frame_range``, else the action's (manual or keyed) range."""
    if frame_range is not None:
        return check_frame_range(int(frame_range[0]), int(frame_range[1]), what=f"action {action.name!r}", frames=1)
    rng = _action_frame_range(action, channels, names)
    if rng is None:
        rng = _action_frame_range(action, channels, list(channels))
    if rng is None:
        raise ShapeSigError(f"action {action.name!r} has no keyframes")
    # a key at frame 10,000,000 would be sampled frame by frame: the clip files' frame cap (core.io.files)
    check_frames(int(rng[1]) - int(rng[0]) + 1, None, what=f"clip (action {action.name!r})")
    return rng


def _stored_modes(action):
    """The rotation modes ``write_action`` recorded on the action ({} when none or damaged)."""
    try:
        stored = action.get("shapesig_rotation_modes")
        return {b: m for b, m in stored.items() if m in ROTATION_MODES} if stored is not None else {}
    except (ValueError, TypeError, AttributeError):
        return {}  # a damaged custom property (e.g. a corrupt .blend): infer the modes from the channels


def _bone_mode(bone, chans, armature, override, stored):
    """The rotation mode a bone's channels are read in."""
    if bone in override:
        return override[bone]
    mode = armature.pose.bones[bone].rotation_mode if armature is not None else None
    if mode is None or (prop_for_mode(mode) not in chans and any(p in chans for p in _ROT_PROPS)):
        # no armature, or the action keys another kind of rotation than the pose bone's mode
        mode = stored.get(bone)
        if mode is None or prop_for_mode(mode) not in chans:
            mode = mode_from_channels(chans)
    return mode


def _read_rotations(action, channels, names, frames, start, modes_override, armature, co_cache):
    """(rotations (frames, bones, 3, 3), modes): a bone without curves of its mode is the identity."""
    override = modes_lookup(modes_override, names)
    stored = _stored_modes(action)
    modes, by_mode = [], {}
    R = np.empty((len(frames), len(names), 3, 3))
    for j, b in enumerate(names):
        chans = channels.get(b, {})
        mode = _bone_mode(b, chans, armature, override, stored)
        modes.append(mode)
        prop = prop_for_mode(mode)
        if prop not in chans:
            R[:, j] = np.eye(3)
            continue
        values = _sample_prop(chans, prop, frames, start, co_cache)
        if not np.all(np.isfinite(values)):
            bad = int(frames[np.argmax(~np.all(np.isfinite(values), axis=1))])
            raise ShapeSigError(f"action {action.name!r}: bone {b!r} has NaN or infinite {prop} values "
                                f"(first at frame {bad})")
        by_mode.setdefault(mode, ([], []))
        by_mode[mode][0].append(j)
        by_mode[mode][1].append(values)
    for mode, (idx, values) in by_mode.items():  # one conversion per rotation mode (row by row: same result)
        M = matrices_from_channels(mode, np.concatenate(values))
        R[:, idx] = np.swapaxes(M.reshape(len(idx), len(frames), 3, 3), 0, 1)
    return R, modes


def _root_bone(armature, names, channels):
    """The armature's first parentless bone, else (no armature) the first read bone with location curves."""
    if armature is not None:
        return next((b.name for b in armature.data.bones if b.parent is None), None)
    return next((b for b in names if "location" in channels.get(b, {})), None)


def _action_fps(action, fps):
    """``fps``, else the action's known rate (recorded, or its source file's: ``frame_rates.rate_of``), else the
    scene's (24 without a scene)."""
    if fps is None:
        from .frame_rates import rate_of

        fps = rate_of(action)[0]
    return float(fps)


def read_action(action, armature=None, bones=None, frame_range=None, exclude_unkeyed=False,
                rotation_modes=None, slot=None, fps=None, name=None, space="pose") -> Clip:
    """The action as a Clip (see the module docstring). ``armature``: an armature object (bone order, rotation
    modes, root bone); ``bones``: names to read, in that order; ``slot``: the action slot to read (4.4+; default:
    the armature's slot when it uses this action, else the first slot with F-curves); ``fps``: default the
    scene's. ``space``: "pose" (Blender's pose-bone rotations) or "armature" (the same rotations in the
    armature's axes, ``B R B^T``; needs the armature; see ``to_armature_space``)."""
    _check_read(action, armature, space)
    if slot is None and armature is not None and getattr(armature.animation_data, "action", None) == action:
        slot = compat.object_action_slot(armature)
    channels = bone_channels(compat.action_fcurves(action, slot))
    names, unkeyed = _read_bones(action, armature, bones, channels, exclude_unkeyed)
    start, end = _read_range(action, channels, names, frame_range)
    frames = np.arange(start, end + 1, dtype=np.float64)
    co_cache = {}
    R, modes = _read_rotations(action, channels, names, frames, start, rotation_modes, armature, co_cache)
    root = _root_bone(armature, names, channels)
    root_translation = None
    if root is not None and "location" in channels.get(root, {}):
        root_translation = _sample_prop(channels[root], "location", frames, start, co_cache)
    carrier = None
    if armature is not None and root in names:
        root_translation, carrier = _fold_below_root(armature, names, channels, frames, start, co_cache, R, root,
                                                     root_translation)
    source = action.name_full
    if getattr(action, "library", None) is not None:
        source = f"{action.library.filepath}#{action.name}"
    clip = Clip(
        name=name or action.name,
        bones=tuple(names),
        rotations=R,
        fps=_action_fps(action, fps),
        frame_start=start,
        root_translation=root_translation,
        root_bone=root,
        rotation_modes=tuple(modes),
        source=source,
        meta={
            "action": action.name,
            "slot": getattr(slot, "identifier", None),
            "missing_rotation_bones": tuple(unkeyed),
            "fcurve_hash": _content_hash(action, co_cache),
            **({"root_motion_bone": carrier} if carrier else {}),
        },
    )
    clip.meta["still_bones"] = clip.still_bones()
    if armature is not None:
        # armature-space rest orientation of each bone: world-aligned local rotation = B R B^T
        clip.meta["rest_rotations"] = _rest_frames(names, armature)[0]
        # the hierarchy (every bone of the armature): core.rigs builds world rotations and bone maps from it
        clip.meta["parents"] = {b.name: (b.parent.name if b.parent else None) for b in armature.data.bones}
        # the rest skeleton in armature space (core.clip.skeleton: forward kinematics of the feet)
        bones = armature.data.bones
        clip.meta.update(rest_meta([b.name for b in bones], [b.head_local for b in bones],
                                   [b.tail_local for b in bones]))
    clip.meta["rotation_space"] = "pose"
    if space == "armature":
        return to_armature_space(clip, armature)
    return clip


def _fold_below_root(armature, names, channels, frames, start, co_cache, R, root, loc):
    """(root location, carrier): the root's pose location with the location curves of the bones below it folded in
    as Blender plays them (``skeleton.fold_root_motion``: a bone's head moves by B loc in its parent's frame), e.g. a
    BVH import with a static reference root above the hips; ``loc`` and None when no bone below the root carries
    the motion."""
    index = {b: i for i, b in enumerate(names)}
    parents, size = [], np.ones(len(names), dtype=int)
    for b in names:
        p = armature.data.bones[b].parent
        while p is not None and p.name not in index:
            p = p.parent
        parents.append(index[p.name] if p is not None else -1)
    for j in range(len(names)):
        a = parents[j]
        while a >= 0:
            size[a] += 1
            a = parents[a]
    # only bones holding most of the skeleton can carry the motion (a few: the chain from the root to the hips)
    below = [b for b in names if b != root and "location" in channels.get(b, {}) and 2 * size[index[b]] > len(names)]
    if not below:
        return loc, None
    B, heads = _rest_frames(names, armature)
    r = index[root]
    moves = {index[b]: _sample_prop(channels[b], "location", frames, start, co_cache) @ B[index[b]].T for b in below}
    head = heads[r] + (np.zeros((len(frames), 3)) if loc is None else loc @ B[r].T)
    moves[r] = head
    X = B[None] @ R @ np.swapaxes(B, -1, -2)[None]
    path, carrier = fold_root_motion(parents, X, head, moves)
    top = carrier
    while top is not None and parents[top] >= 0:
        top = parents[top]
    if carrier in (None, r) or top != r:
        return loc, None
    return (path - heads[r]) @ B[r], names[carrier]
