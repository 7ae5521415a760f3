"""Transitions in Blender, the Blender half of ``core.blend.transition``: ``ranked_cuts`` and ``make_transition``
read action A with the armature the user works on and action B with the armature that owns it (``library``), at
their frame rates (``frame_rates``), join them on A's rig and write one new action (``write_transition``: the
one place a transition is written). Sources are never modified; on any error nothing is created. See
docs/transitions.md.
"""

from dataclasses import dataclass, field

from ..actions import frame_rates, scene_motion
from ..core.errors import ShapeSigError

__all__ = ["TransitionResult", "read_pair", "ranked_cuts", "make_transition", "write_transition", "place_as_strips",
           "GENERATORS"]

GENERATORS = ("geodesic", "library")


@dataclass
class TransitionResult:
    """The new action, the joined clip and its ``meta["transition"]`` with the cut in scene frames."""

    action: object
    clip: object
    info: dict = field(default_factory=dict)


def _read(action, armature, fps):
    return scene_motion.read_motion(action, armature, fps=fps)  # the world's axes; control rigs' deform bones


def read_pair(armature, action_a, action_b, rates=(None, None)):
    """(A, B) as clips in armature space on their own rigs, at ``rates`` (None: each action's own rate)."""
    from ..search.library import owner_armature

    if action_a == action_b:
        raise ShapeSigError(f"A and B are the same action {action_a.name!r}; choose two different actions")
    fa = rates[0] or frame_rates.rate_of(action_a)[0]
    fb = rates[1] or frame_rates.rate_of(action_b)[0]
    return _read(action_a, armature, fa), _read(action_b, owner_armature(action_b, armature), fb)


def ranked_cuts(armature, action_a, action_b, top=5):
    """The ``top`` best cuts as (A frame, B frame, cost) in each action's own scene frames."""
    from ..core.blend.transition import best_cuts

    a, b = read_pair(armature, action_a, action_b)
    return [(c.a_frame + a.frame_start, c.b_frame + b.frame_start, c.cost) for c in best_cuts(a, b, top=top)]


def _library(armature, exclude):
    """Every other action of the file that can be read on its owner's rig (the bridge library)."""
    import bpy

    from ..search.library import owner_armature

    clips = []
    for act in bpy.data.actions:
        if act in exclude:
            continue
        try:
            clips.append(_read(act, owner_armature(act, armature), frame_rates.rate_of(act)[0]))
        except ShapeSigError:
            continue
    if not clips:
        raise ShapeSigError("the file holds no other action to bridge from: choose the geodesic in-between")
    return clips


def make_transition(armature, action_a, action_b, *, cut=None, frames=None, generator="geodesic", name=None):
    """Join ``action_a`` (on ``armature``) into ``action_b`` at ``cut`` ((A frame, B frame) in the actions' own
    scene frames; None: the best cut) with ``frames`` generated frames (None: 0.3 s) made by ``generator``
    ("geodesic", or "library": a bridge from the file's other actions); one new action on ``armature``."""
    from .blend_actions import unique_action_name
    from ..core.blend.transition import transition

    if generator not in GENERATORS:
        raise ShapeSigError(f"generator: expected one of {', '.join(GENERATORS)}, got {generator!r}")
    a, b = read_pair(armature, action_a, action_b)
    index = None
    if cut is not None:
        index = (int(cut[0]) - a.frame_start, int(cut[1]) - b.frame_start)
        if not 0 <= index[0] < a.frames:
            raise ShapeSigError(f"frame {cut[0]} is outside {action_a.name!r} ({a.frame_start}-{a.frame_end})")
        if not 0 <= index[1] < b.frames:
            raise ShapeSigError(f"frame {cut[1]} is outside {action_b.name!r} ({b.frame_start}-{b.frame_end})")
    library = _library(armature, (action_a, action_b)) if generator == "library" else None
    clip = transition(a, b, cut=index, frames=frames, library=library)
    info = dict(clip.meta["transition"])
    info["cut_frames"] = (info["cut"]["a_frame"] + a.frame_start, info["cut"]["b_frame"] + b.frame_start)
    act = write_transition(clip, armature, unique_action_name(name or clip.name))
    return TransitionResult(act, clip, info)


def write_transition(clip, armature, name):
    """Write the joined clip as a new action on ``armature``, keyed at the scene's frame rate
    (``scene_motion.write_motion``: through the object's world matrix; a Rigify rig's controls)."""
    return scene_motion.write_motion(clip, armature, name=name)


def place_as_strips(armature, result):
    """Play ``result``'s action from a new NLA track of ``armature`` as three strips of it: A's part, the
    generated frames, B's part (each can then be moved or scaled in the NLA editor), split halfway between their
    frames at the scene's rate; the bones take the action's rotation modes and the armature's active action is
    cleared so the track plays (the one it had is stashed when it would lose its last user). Returns the track."""
    from .. import compat
    from ..actions import action_io

    act, clip, info = result.action, result.clip, result.info
    first, last = (float(x) for x in act.frame_range)
    per = frame_rates.scene_rate() / float(clip.fps)  # scene frames per frame of the joined clip
    b1 = min(max(first + round((info["a_frames"] - 0.5) * per), first + 1), last - 1)
    b2 = min(max(first + round((info["a_frames"] + info["frames"] - 0.5) * per), b1 + 1), last)
    ad = armature.animation_data or armature.animation_data_create()
    track = ad.nla_tracks.new()
    track.name = act.name
    try:
        parts = [("A", first, b1), ("between", b1, b2), ("B", b2, last)]
        for label, lo, hi in parts:
            if hi <= lo:
                continue
            strip = track.strips.new(f"{act.name} {label}", int(lo), act)
            if hasattr(strip, "action_slot") and strip.action_slot is None and len(getattr(act, "slots", ())):
                strip.action_slot = act.slots[0]
            strip.action_frame_start, strip.action_frame_end = lo, hi
            strip.frame_start, strip.frame_end = lo, hi
    except BaseException:
        ad.nla_tracks.remove(track)
        raise
    action_io.assign_action(armature, act)  # the bones take its rotation modes; the previous action is kept
    compat.assign_action(armature, None)
    return track
