"""The armature an action belongs to, found and never guessed (``find_owner``): the armature that plays it (its
active action, an NLA strip, on 4.4+ a user of one of its slots), else the rig hint the action stores (on 4.4+ an
object slot is named after the object it was made for: Blender names it so when an action is keyed or assigned,
``action_io.write_action`` names it after its armature), else the armature the user works with when its bones hold
every bone the action animates, else the only armature whose bones hold them. Two candidates and nothing to
decide between them is a ShapeSigError in one line naming them; no armature holding its bones is None (the
action is then read in pose space). The search library, the blends of the panel, the .blend reader and the
command line's ``blend`` all ask here."""

import bpy

from .. import compat
from ..core.errors import ShapeSigError

__all__ = ["find_owner", "players", "playing_map", "slot_hint", "fitting", "animated_bones"]


def animated_bones(action) -> frozenset:
    """The names of the pose bones the action's F-curves animate (remembered: ``action_changes.action_bones``)."""
    from .action_changes import action_bones

    return action_bones(action)


def _armatures(objects):
    return [o for o in (bpy.data.objects if objects is None else objects) if getattr(o, "type", "") == "ARMATURE"]


def _plays(ob) -> list:
    """The actions armature ``ob`` plays: its active action and its NLA strips' (None left out)."""
    ad = ob.animation_data
    if ad is None:
        return []
    acts = [ad.action] + [strip.action for track in ad.nla_tracks for strip in track.strips]
    return [a for a in acts if a is not None]


def playing_map(armatures) -> dict:
    """{action pointer: [armatures]}: what each of ``armatures`` plays (``_plays``), in one pass over the
    armatures; ``find_owner(played=)`` takes it instead of asking every armature per action. (A slot's users are
    the animation data that assign the action, so they add no armature to these.)"""
    out = {}
    for ob in armatures:
        for a in _plays(ob):
            got = out.setdefault(a.as_pointer(), [])
            if ob not in got:
                got.append(ob)
    return out


def players(action, armatures):
    """The armatures (of ``armatures``) that play ``action``: active action, an NLA strip or a slot's user."""
    slot_users = set()
    for slot in compat.action_slots(action):
        users = getattr(slot, "users", None) if slot is not None else None
        if users is not None:
            slot_users.update(u.as_pointer() for u in users())
    return [ob for ob in armatures if ob.as_pointer() in slot_users or action in _plays(ob)]


def slot_hint(action, armatures):
    """The armature an object slot of the action is named after (4.4+), when exactly one slot names one of
    ``armatures``; else None."""
    names = {ob.name: ob for ob in armatures}
    hinted = []
    for slot in compat.action_slots(action):
        if slot is None or getattr(slot, "target_id_type", "OBJECT") not in ("OBJECT", "UNSPECIFIED"):
            continue
        ob = names.get(getattr(slot, "name_display", None))
        if ob is not None and ob not in hinted:
            hinted.append(ob)
    return hinted[0] if len(hinted) == 1 else None


def fitting(action, armatures, bones=None, bone_names=None):
    """The armatures whose bones hold every bone the action animates; ``bone_names``: a dict remembering each
    armature's bone names (by its data's pointer) over several calls that see the same armatures unchanged."""
    bones = animated_bones(action) if bones is None else bones
    if not bones:
        return []
    memo = {} if bone_names is None else bone_names
    out = []
    for ob in armatures:
        names = memo.get(ob.data.as_pointer())
        if names is None:
            names = memo[ob.data.as_pointer()] = {b.name for b in ob.data.bones}
        if bones <= names:
            out.append(ob)
    return out


def _names(obs):
    names = sorted(o.name for o in obs)
    return ", ".join(names[:4]) + (", ..." if len(names) > 4 else "")


def find_owner(action, armatures=None, prefer=None, bone_names=None, played=None):
    """The armature object ``action`` belongs to (see the module docstring); ``armatures``: the candidates
    (default: every armature object of the file); ``prefer``: the armature the user works with; ``bone_names``:
    as ``fitting``'s and ``played``: ``playing_map(armatures)`` (for many actions in one pass over an unchanged
    file). None when no armature holds its bones; ShapeSigError (one line) when two or more could own it and
    nothing decides."""
    armatures = _armatures(armatures)
    playing = players(action, armatures) if played is None else played.get(action.as_pointer(), [])
    if prefer is not None and prefer in playing:
        return prefer
    if len(playing) == 1:
        return playing[0]
    if len(playing) > 1:
        hinted = slot_hint(action, playing)
        if hinted is not None:
            return hinted
        raise ShapeSigError(f"action {action.name!r} is played by {len(playing)} armatures ({_names(playing)}); "
                            f"assign it to one of them only")
    fits = fitting(action, armatures, bone_names=bone_names)
    if len(fits) == 1:
        return fits[0]  # whatever a slot is named after (a hint that fits is this one; one that does not loses)
    hinted = slot_hint(action, armatures)
    if hinted is not None and (hinted in fits or not fits):
        return hinted
    if prefer is not None and prefer in fits:
        return prefer
    if len(fits) > 1:
        raise ShapeSigError(f"action {action.name!r} is played by no armature and fits {len(fits)} armatures "
                            f"({_names(fits)}); assign it to its armature (or keep one of them in the file)")
    return None
