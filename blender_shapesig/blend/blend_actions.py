"""Blend two or more actions of an armature into new actions, the Blender half of ``core.blend``: ``blend_actions``
reads the actions, blends them with ``core.blend.make_blends`` and writes each blend as a new action (or, with
``timing="nla"``, a pose curve played by an NLA strip with an editable clock; ``bake_strip`` bakes it). Sources
are never modified; on any error nothing is created. See docs/blending.md.
"""

from dataclasses import dataclass, field, replace
from typing import List, Optional, Sequence

import bpy
import numpy as np

from .. import compat
from ..actions import action_io, action_spaces, control_rigs, frame_rates, scene_motion
from ..rigs import rigmap
from ..core.blend import make_blends
from ..core.errors import ShapeSigError
from ..core.metrics import DEFAULT_DEPTH
from ..core.progress import check as check_progress

__all__ = ["BlendResult", "blend_actions", "unique_action_name", "selected_bone_names", "stride_ranges",
           "bake_strip", "timed_strips", "TIMING_TRACK"]

TIMING_TRACK = "ShapeSig Timing"  # the NLA track of a blend written with editable timing
TIMED = "shapesig_timed_blend"    # the custom property marking such a blend's action (its fps)


@dataclass
class BlendResult:
    """The new actions, the blended clips (their ``meta`` holds the warp and d_S*) and the bones of A that
    B does not animate (they keep A's motion)."""

    actions: List["bpy.types.Action"]
    clips: list
    unmatched: Sequence[str] = field(default_factory=tuple)
    info: dict = field(default_factory=dict)
    strips: list = field(default_factory=list)


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


def _read_all(armature, actions, bones, rates=None, allow_partial=False):
    """(clips on their own rigs, clips in the comparison space or None, bones, across): every action read with the
    armature that plays it (at ``rates[i]`` when given, else its own rate); through the bone maps when one is of
    another rig (``rigmap``)."""
    from ..core.rigs import apply_bone_map
    from ..search.library import owner_armature

    owners = [armature] + [owner_armature(act, armature) for act in actions[1:]]
    across = any(rigmap.across_rigs(armature, o) for o in owners[1:])
    # one rig blends in its pose space, unless its object is turned, scaled or parented: then in the world's axes
    # (the same blend, conjugation-equivariant, with planted feet found and kept with the world's up and units)
    # (a control rig, e.g. Rigify, is read through its deform bones' evaluated pose: scene_motion.read_motion)
    space = "armature" if (across or action_spaces.object_matrix(armature) is not None
                           or control_rigs.is_control_rig(armature)) else "pose"
    rates = list(rates or ()) + [None] * (len(actions) - len(rates or ()))
    if space == "armature":
        own = [scene_motion.read_motion(act, o if across else armature, fps=float(r) if r else None)
               for act, o, r in zip(actions, owners, rates)]
    else:
        own = [action_io.read_action(act, armature=armature, exclude_unkeyed=True, space="pose",
                                     fps=float(r) if r else None) for act, r in zip(actions, rates)]
    mapped = None
    if across:
        ma, mb, bones = rigmap.onto_comparison(own[0], armature, own[1], owners[1], bones, allow_partial)
        mapped = [ma, mb] + [apply_bone_map(x, rigmap.bone_map_of(o)) for x, o in zip(own[2:], owners[2:])]
    work = mapped or own
    if bones is not None:
        shared = set(work[0].bones).intersection(*(x.bones for x in work[1:]))
        missing = [x for x in bones if x not in shared]
        if missing:
            names = " and ".join(repr(a.name) for a in actions)
            raise ShapeSigError(f"bone(s) {', '.join(missing[:5])} are not animated in "
                                f"{'both' if len(actions) == 2 else 'all of'} {names}")
    return own, mapped, bones, across


def stride_ranges(armature, action_a, action_b):
    """One stride of each of two cyclic actions as ((first, last), (first, last)) in their own frames, B's starting
    at A's phase (the strides Loop blends: ``core.blend.cycle.one_cycle``), looked for after a converter's rest
    frame and ramp (``core.clip.trim``), or None when either shows no clear cycle or cannot be read (the Blend
    dialog's default ranges)."""
    from ..core.blend.cycle import one_cycle
    from ..core.clip.trim import trim_clip

    try:
        own, mapped, _bones, _across = _read_all(armature, [action_a, action_b], None, allow_partial=True)
        work = [trim_clip(c) for c in (mapped or own)]
        first = one_cycle(work[0])
        second = one_cycle(work[1], like=first)
    except ShapeSigError:
        return None
    return tuple((int(c.meta["cycle"]["start"]), int(c.meta["cycle"]["end"])) for c in (first, second))


def blend_actions(armature, action_a, action_b, weights, *, align=True, depth=DEFAULT_DEPTH, frames=None,
                  bones: Optional[Sequence[str]] = None, root="blend", progress=None, extra=(), ranges=None,
                  loop=False, feet="none", mask=None, groups=None, timing="bake", rates=None,
                  allow_long=False, allow_partial=False) -> BlendResult:
    """Blend ``action_a`` towards ``action_b`` at each weight into new actions on ``armature``.

    ``weights``: B's weight per blend (two actions); with ``extra`` (pairs (action, weight)) one blend whose
    weights are A: 1 - B's - the extras', B, the extras. ``bones``: blend only these (the others keep A's motion);
    each must be animated in every action. ``root``: "blend" or "a" (A's root path). ``ranges``: (A's, B's) frame
    ranges ((S, E) or None, the actions' own frames). ``loop``, ``feet`` ("lock"/"none"; a rig without legs is
    kept unplanted, said in ``info``), ``mask``/``groups``: see ``core.blend.make_blends``. ``timing``: "bake"
    (the blended timing in the keys) or "nla" (editable, see the module docstring). ``progress(done, total)``
    (``core.progress``): called after each blend and each written action (2 per blend); returning True raises
    Cancelled and creates nothing. ``rates``: per action (A, B, the extras) the frame rate to read it at, or None
    for its own (``frame_rates.rate_of``); ``info["rates"]`` holds (name, fps, known) per action and
    ``info["rate_note"]`` the one line when an assumed rate meets known ones. ``allow_long``: blend sources lasting
    more than ``core.blend.make.MAX_DURATION_RATIO`` times as long as each other. ``allow_partial``: blend two rigs
    whose maps compare fewer of the joints they both have than ``core.rigs.MIN_COVERAGE`` (refused otherwise)."""
    if action_a == action_b:
        raise ShapeSigError(f"A and B are the same action {action_a.name!r}; choose two different actions")
    actions = [action_a, action_b] + [act for act, _w in extra]
    for i, act in enumerate(actions):
        if act in actions[:i]:
            raise ShapeSigError(f"the action {act.name!r} is chosen twice; choose different actions")
    if extra:
        if len(weights) != 1:
            raise ShapeSigError("in-betweens blend two actions; with extra actions make one blend")
        ws = [float(weights[0])] + [float(w) for _a, w in extra]
        vectors = [(1.0 - sum(ws), *ws)]
        if vectors[0][0] < -1e-9:
            raise ShapeSigError(f"the weights of B and the extra actions sum to {sum(ws):g}: more than 1 leaves "
                                f"A a negative weight")
        vectors = [(max(vectors[0][0], 0.0),) + vectors[0][1:]]
    else:
        vectors = [(1.0 - float(w), float(w)) for w in weights]
    if timing not in ("bake", "nla"):
        raise ShapeSigError(f"timing: expected 'bake' or 'nla', got {timing!r}")
    if timing == "nla" and loop:
        raise ShapeSigError("a loop is written baked: choose Bake timing or switch Loop off")
    own, mapped, bones, across = _read_all(armature, actions, bones, rates, allow_partial)
    n = len(vectors)
    clips, info = make_blends(
        own, vectors, mapped=mapped, back=rigmap.back_onto_armature if across else None, ranges=ranges,
        loop=loop, feet=feet, feet_required=False, mask=mask, groups=groups, align=align, depth=depth,
        frames=frames, bones=bones, root=root, allow_long=allow_long,
        up_axis=None if own[0].meta.get("rotation_space") == "armature" else
        action_spaces.up_in_bone_frame(armature, own[0].root_bone),
        progress=(lambda i, _n: progress(i, 2 * n)) if progress else None)
    created, names, strips = [], [], []
    try:
        for i, clip in enumerate(clips):
            names.append(unique_action_name(clip.name, names))
            if timing == "nla":
                act, strip = _write_timed(clip, armature, names[-1])
                created.append(act)
                strips.append(strip)
            else:
                created.append(scene_motion.write_motion(clip, armature, name=names[-1]))
            check_progress(progress, n + i + 1, 2 * n)
    except BaseException:
        for strip in strips:
            _remove_strip(armature, strip)
        for act in created:
            compat.remove_action(act)
        raise
    unmatched = tuple(clips[0].meta.get("kept_bones" if across else "unmatched_a", ()))
    info["rates"] = [(act.name, float(r), True) if r else (act.name, *frame_rates.rate_of(act)[:2])
                     for act, r in zip(actions, list(rates or ()) + [None] * len(actions))]
    info["rate_note"] = frame_rates.mixed_note(info["rates"])
    return BlendResult(created, clips, unmatched, info, strips)


def _write_timed(clip, armature, name):
    """(the action of the pose curve, the NLA strip playing it with the blended clock as animated Strip Time)."""
    from ..core.blend import editable_timing

    curve, keys = editable_timing(clip)
    action = action_io.write_action(curve, armature=armature, name=name, fake_user=True)
    action[TIMED] = float(clip.fps)
    ad = armature.animation_data or armature.animation_data_create()
    track = ad.nla_tracks.new()
    track.name = TIMING_TRACK
    try:
        strip = track.strips.new(name, int(clip.frame_start), action)
        if hasattr(strip, "action_slot") and strip.action_slot is None and len(getattr(action, "slots", ())):
            strip.action_slot = action.slots[0]
        strip.extrapolation = "HOLD_FORWARD"
        strip.use_animated_time = True
        fc = strip.fcurves.find("strip_time")
        fc.keyframe_points.clear()
        fc.keyframe_points.add(len(keys))
        co = np.empty(2 * len(keys), dtype=np.float32)
        # the clock runs in the scene's frames: the blend's frame k plays at scene frame start + k * scene / blend rate
        co[0::2] = keys[:, 0] * (frame_rates.scene_rate() / float(clip.fps)) + clip.frame_start
        co[1::2] = keys[:, 1] + clip.frame_start
        fc.keyframe_points.foreach_set("co", co)
        fc.keyframe_points.foreach_set("interpolation", np.full(len(keys), 1, dtype=np.int32))  # LINEAR
        fc.update()
        strip.frame_end = float(co[-2])  # the strip lasts as long as its clock (in the scene's frames)
    except BaseException:
        ad.nla_tracks.remove(track)
        compat.remove_action(action)
        raise
    return action, strip


def _remove_strip(armature, strip):
    ad = armature.animation_data
    for track in list(ad.nla_tracks) if ad is not None else ():
        if any(s == strip for s in track.strips):
            ad.nla_tracks.remove(track)
            return


def timed_strips(armature):
    """The NLA strips of ``armature`` that play a blend written with editable timing (animated Strip Time)."""
    ad = armature.animation_data if armature is not None else None
    if ad is None:
        return []
    return [s for t in ad.nla_tracks for s in t.strips
            if s.action is not None and s.action.get(TIMED) is not None and s.use_animated_time]


def bake_strip(armature, strip, name=None):
    """A new action (fake user) holding what ``strip`` plays: its action's pose curve at the Strip Time of every
    scene frame of the strip (``core.blend.sample_at``). The strip and its action are left as they are."""
    from ..core.blend import sample_at

    fc = strip.fcurves.find("strip_time")
    if fc is None:
        raise ShapeSigError(f"strip {strip.name!r} has no animated Strip Time")
    curve = action_io.read_action(strip.action, armature=armature, exclude_unkeyed=True)
    first, last = int(round(strip.frame_start)), int(round(strip.frame_end))
    at = np.array([fc.evaluate(f) for f in range(first, last + 1)], dtype=np.float64) - curve.frame_start
    baked = replace(sample_at(curve, at, name=unique_action_name(name or f"{strip.action.name}_baked")),
                    frame_start=first, fps=frame_rates.scene_rate())  # one key per scene frame
    return action_io.write_action(baked, armature=armature, name=baked.name, fake_user=True)
