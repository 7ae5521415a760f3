"""Every difference between Blender versions (4.2 LTS .. 5.2 LTS) in one place, detected on the instances, never on
version numbers: legacy F-curves (4.2), slotted actions with channelbags (4.4 / 4.5) and channelbags only (5.0 and
later). API: ``is_layered``, ``action_slots``, ``action_fcurves``, ``all_action_fcurves``, ``ensure_channelbag``,
``new_fcurve``, ``assign_action``, ``channelbag_for_object``. See docs/action_io.md, "Blender versions", and
docs/dev/blender_layer.md.
"""

import bpy

__all__ = [
    "is_layered", "action_slots", "action_fcurves", "all_action_fcurves", "ensure_channelbag",
    "new_fcurve", "assign_action", "stash_action", "object_action_slot", "remove_action",
]


def is_layered(action) -> bool:
    """True for slotted/layered actions (4.4+), False for 4.2 actions."""
    return hasattr(action, "slots") and hasattr(action, "layers")


def action_slots(action):
    """The action's slots (4.4+), or ``[None]`` on 4.2 (one implicit slot)."""
    if not is_layered(action):
        return [None]
    return list(action.slots)


def _channelbag(action, slot):
    """The first channelbag of ``slot`` over all layers and strips, or None."""
    for layer in action.layers:
        for strip in layer.strips:
            getter = getattr(strip, "channelbag", None)
            if getter is None:
                continue
            bag = getter(slot)
            if bag is not None:
                return bag
    return None


def _default_slot(action):
    """The slot to read when none is given: the first OBJECT slot that has F-curves, else the first
    slot that has F-curves, else None."""
    candidates = []
    for slot in action.slots:
        bag = _channelbag(action, slot)
        if bag is not None and len(bag.fcurves):
            candidates.append(slot)
    for slot in candidates:
        if getattr(slot, "target_id_type", "OBJECT") == "OBJECT":
            return slot
    return candidates[0] if candidates else None


def action_fcurves(action, slot=None):
    """The F-curves of ``action`` for ``slot`` (4.4+; None = the first slot with F-curves, OBJECT slots
    first) or all of them (4.2). Returns a list (possibly empty)."""
    if not is_layered(action):
        return list(action.fcurves)
    if slot is None:
        slot = _default_slot(action)
        if slot is None:
            # 4.4/4.5 legacy actions that were never converted still answer action.fcurves
            legacy = getattr(action, "fcurves", None)
            return list(legacy) if legacy is not None else []
    bag = _channelbag(action, slot)
    return list(bag.fcurves) if bag is not None else []


def all_action_fcurves(action):
    """Every F-curve of the action, over all slots, layers and strips."""
    if not is_layered(action):
        return list(action.fcurves)
    out = []
    for layer in action.layers:
        for strip in layer.strips:
            for bag in getattr(strip, "channelbags", ()):
                out.extend(bag.fcurves)
    if not out and getattr(action, "fcurves", None) is not None:
        out = list(action.fcurves)
    return out


def ensure_channelbag(action, id_type="OBJECT", name=None):
    """A container with ``.fcurves`` and ``.groups`` to write F-curves into. 4.2: the action itself.
    4.4+: the channelbag of a slot of ``id_type`` (the first existing one, else a new slot called ``name``),
    creating the layer and keyframe strip when needed. Returns ``(bag, slot)`` (slot None on 4.2)."""
    if not is_layered(action):
        if "id_root" in action.bl_rna.properties:
            action.id_root = id_type
        return action, None
    slot = None
    for s in action.slots:
        if getattr(s, "target_id_type", id_type) == id_type:
            slot = s
            break
    if slot is None:
        slot = action.slots.new(id_type=id_type, name=name or action.name)
    try:
        from bpy_extras.anim_utils import action_ensure_channelbag_for_slot
    except ImportError:  # 4.4 has slots but may lack the helper
        action_ensure_channelbag_for_slot = None
    if action_ensure_channelbag_for_slot is not None:
        bag = action_ensure_channelbag_for_slot(action, slot)
    else:
        layer = action.layers[0] if len(action.layers) else action.layers.new("Layer")
        strip = layer.strips[0] if len(layer.strips) else layer.strips.new(type="KEYFRAME")
        bag = strip.channelbag(slot, ensure=True)
    return bag, slot


def new_fcurve(bag, data_path, index, group):
    """A new F-curve in ``bag`` (from ensure_channelbag) in the group named ``group`` (created if needed)."""
    if not is_layered_bag(bag):
        return bag.fcurves.new(data_path, index=index, action_group=group)
    try:
        return bag.fcurves.new(data_path, index=index, group_name=group)  # 5.0
    except TypeError:
        pass
    fcurve = bag.fcurves.new(data_path, index=index)  # 4.4 / 4.5
    grp = bag.groups.get(group) if hasattr(bag.groups, "get") else None
    if grp is None:
        grp = bag.groups.new(group)
    try:
        fcurve.group = grp
    except (AttributeError, TypeError, RuntimeError):
        pass
    return fcurve


def is_layered_bag(bag) -> bool:
    """True for a channelbag (4.4+), False for a 4.2 action used as its own container."""
    return not isinstance(bag, bpy.types.Action)


def object_action_slot(obj):
    """The slot the object's animation data uses (4.4+), else None."""
    ad = getattr(obj, "animation_data", None)
    if ad is None:
        return None
    return getattr(ad, "action_slot", None)


def assign_action(obj, action):
    """Make ``action`` the object's active action (and pick its slot on 4.4+)."""
    ad = obj.animation_data or obj.animation_data_create()
    ad.action = action
    if action is not None and hasattr(ad, "action_slot") and ad.action_slot is None:
        for slot in action.slots:
            if getattr(slot, "target_id_type", "OBJECT") in ("OBJECT", "UNSPECIFIED"):
                ad.action_slot = slot
                break
    return ad


def remove_action(action):
    """Remove an action from bpy.data (used for clean-up of temporary or half-made actions)."""
    try:
        bpy.data.actions.remove(action, do_unlink=True)
    except (ReferenceError, RuntimeError):
        pass


def pose_bone_selected(pose_bone) -> bool:
    """Whether a pose bone is selected (5.0: ``PoseBone.select``; before: ``Bone.select``)."""
    if "select" in pose_bone.bl_rna.properties:
        return pose_bone.select
    return pose_bone.bone.select


STASH_TRACK = "[Action Stash]"  # the name Blender's own action switching gives its stash tracks


def stash_action(obj, action):
    """Keep ``action`` in the object's NLA as Blender does when an action editor switches away from an action
    nobody else uses: a muted track "[Action Stash]" holding one strip of it (on 4.4+ the strip plays the slot
    the object used). The strip is a user, so the action survives saving."""
    ad = obj.animation_data or obj.animation_data_create()
    for track in ad.nla_tracks:
        if any(strip.action == action for strip in track.strips):
            return track  # already kept
    slot = getattr(ad, "action_slot", None) if ad.action == action else None
    track = ad.nla_tracks.new()
    track.name = STASH_TRACK
    track.mute = True
    strip = track.strips.new(action.name, int(round(action.frame_range[0])), action)
    if slot is not None and hasattr(strip, "action_slot"):
        try:
            strip.action_slot = slot
        except (TypeError, RuntimeError, AttributeError):
            pass
    return track
