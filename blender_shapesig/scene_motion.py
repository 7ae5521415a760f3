"""An armature's motion as the animator sees it in the scene, and motion written back the same way (the one owner
of both): ``read_motion`` reads an action of an armature in the world's axes (``action_io.to_armature_space``: the
object's world matrix, its rotation, scale and parents, applied: an FBX character imported lying in its
armature's axes reads standing); ``write_motion`` writes a clip in those axes (or in the armature's pose space)
onto an armature as a new action through the inverse of the same matrix, keyed at the scene's frame rate
(``core.clip.prepare.retime``: resampled along the SO(3)^d geodesics, root included), so it plays at its true
speed. See docs/action_io.md, "The scene's axes and time".
"""

from . import action_io, frame_rates
from .core.clip.clip import Clip
from .core.clip.prepare import retime

__all__ = ["read_motion", "write_motion", "at_scene_rate"]


def read_motion(action, armature, *, frame_range=None, bones=None, fps=None, name=None,
                exclude_unkeyed=True) -> Clip:
    """``action`` played by ``armature`` as a Clip in the world's axes (rotation space "armature", up +Z), with
    the hierarchy and the rest skeleton in ``meta``; ``fps`` the rate to read it at (None: the action's own)."""
    return action_io.read_action(action, armature=armature, frame_range=frame_range, bones=bones, fps=fps,
                                 name=name, exclude_unkeyed=exclude_unkeyed, space="armature")


def at_scene_rate(clip: Clip, scene=None) -> Clip:
    """``clip`` keyed at the scene's frame rate (``core.clip.prepare.retime``; itself when the rates agree)."""
    return retime(clip, frame_rates.scene_rate(scene))


def write_motion(clip: Clip, armature, name=None, *, fake_user=True, assign=False, scene=None):
    """A new action on ``armature`` holding ``clip`` (world axes, or ``armature``'s pose space) keyed at the
    scene's frame rate: it lasts as long in the scene as the motion did where it came from. Returns the action;
    on error nothing is created (``action_io.write_action``)."""
    return action_io.write_action(at_scene_rate(clip, scene), armature=armature, name=name, fake_user=fake_user,
                                  assign=assign)
