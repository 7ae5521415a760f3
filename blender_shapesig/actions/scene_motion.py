"""An armature's motion as the animator sees it in the scene, and motion written back the same way (the one owner
of both): ``read_motion`` reads an action of an armature in the world's axes (``action_spaces.to_armature_space``: the
object's world matrix, its rotation, scale and parents, applied: an FBX character imported lying in its
armature's axes reads standing), through the evaluated pose of the deform bones where constraints drive them (a
Rigify rig: ``control_rigs.evaluated_clip``); ``write_motion`` writes a clip in those axes (or in the armature's
pose space) onto an armature as a new action through the inverse of the same matrix (a Rigify rig's FK controls:
``control_rigs.write_onto_controls``), keyed at the scene's frame rate (``core.clip.prepare.retime``: resampled
along the SO(3)^d geodesics, root included), so it plays at its true speed. See docs/action_io.md, "The scene's
axes and time", and docs/rigs.md, "Rig kinds".
"""

from . import action_io, action_spaces, control_rigs, frame_rates
from ..core.clip.clip import Clip
from ..core.clip.prepare import retime
from ..core.clip.skeleton import from_world_axes, to_world_axes

__all__ = ["read_motion", "write_motion", "at_scene_rate", "in_world", "in_armature_axes", "timing_text"]

SOURCE_RATE = "shapesig_source_fps"  # the rate a written action's motion had before it was keyed at the scene's


def in_world(clip: Clip, armature) -> Clip:
    """A clip in ``armature``'s own axes (rotation space "armature") re-expressed in the world's
    (``skeleton.to_world_axes`` by the object's world matrix; itself at the identity)."""
    M = action_spaces.object_matrix(armature)
    return clip if M is None else to_world_axes(clip, M)


def in_armature_axes(clip: Clip, armature) -> Clip:
    """The inverse of ``in_world``."""
    M = action_spaces.object_matrix(armature)
    return clip if M is None else from_world_axes(clip, M)


def read_motion(action, armature, *, frame_range=None, bones=None, fps=None, name=None,
                exclude_unkeyed=True) -> Clip:
    """``action`` played by ``armature`` as a Clip in the world's axes (rotation space "armature", up +Z), with
    the hierarchy and the rest skeleton in ``meta``; ``fps`` the rate to read it at (None: the action's own). A
    control rig (``control_rigs.is_control_rig``) is read as the motion of its deform bones (``bones`` and
    ``exclude_unkeyed`` do not apply: every deform bone moves)."""
    if control_rigs.is_control_rig(armature):
        clip = control_rigs.evaluated_clip(armature, action, frame_range=frame_range, fps=fps, name=name)
        return in_world(clip, armature)
    return action_io.read_action(action, armature=armature, frame_range=frame_range, bones=bones, fps=fps,
                                 name=name, exclude_unkeyed=exclude_unkeyed, space="armature")


def at_scene_rate(clip: Clip, scene=None) -> Clip:
    """``clip`` keyed at the scene's frame rate (``core.clip.prepare.retime``; itself when the rates agree)."""
    return retime(clip, frame_rates.scene_rate(scene))


def _deform_motion(clip: Clip, armature) -> bool:
    return (clip.meta.get("rotation_space") == "armature" and control_rigs.is_rigify(armature)
            and set(clip.bones) <= set(control_rigs.deform_bones(armature)))


def write_motion(clip: Clip, armature, name=None, *, fake_user=True, assign=False, scene=None):
    """A new action on ``armature`` holding ``clip`` (world axes, or ``armature``'s pose space) keyed at the
    scene's frame rate: it lasts as long in the scene as the motion did where it came from. A motion of a Rigify
    rig's deform bones keys its FK controls (limbs switched to FK) so that the deform bones follow. Returns the
    action; on error nothing is created."""
    clip = at_scene_rate(clip, scene)
    if _deform_motion(clip, armature):
        action = control_rigs.write_onto_controls(in_armature_axes(clip, armature), armature, name or clip.name)
        action.use_fake_user = bool(fake_user)
        if assign:
            action_io.assign_action(armature, action)
    else:
        action = action_io.write_action(clip, armature=armature, name=name, fake_user=fake_user, assign=assign)
    if "source_fps" in clip.meta:
        action[SOURCE_RATE] = float(clip.meta["source_fps"])
    return action


def timing_text(action, scene=None) -> str:
    """How ``action`` plays in the scene, for a report line: "33 frames at the scene's 24 fps, 1.33 s (resampled
    from 120 fps)"; for an action keyed at another rate (assigned as it is), how much slower or faster it plays."""
    first, last = action.frame_range
    frames = int(round(last - first)) + 1
    here = frame_rates.scene_rate(scene)
    fps, known = frame_rates.rate_of(action)[:2]
    if abs(fps - here) > 1e-6 * here:
        speed = f"{fps / here:.2g}x slower" if fps > here else f"{here / fps:.2g}x faster"
        return (f"{frames} frames keyed at {frame_rates.rate_text(fps)}{'' if known else ' (assumed)'}: it plays "
                f"{speed} in this {frame_rates.rate_text(here)} scene")
    text = f"{frames} frames at the scene's {frame_rates.rate_text(here)}, {(frames - 1) / here:.2f} s"
    source = action.get(SOURCE_RATE)
    if isinstance(source, float) and abs(source - here) > 1e-6 * here:
        text += f" (resampled from {frame_rates.rate_text(source)})"
    return text
