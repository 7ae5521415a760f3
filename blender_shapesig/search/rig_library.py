"""Which of the file's actions the search compares with an armature's (Blender layer): every action that animates
pose bones and either shares bone names with the armature or is of a rig (the armature that plays it, its slot's,
the one its bones fit: ``owners.find_owner``) whose bone map shares at least ``MIN_JOINTS`` canonical joints with
the armature's (``rigmap.armature_map``); an action no armature plays that fits two others is left out (whose it is
cannot be told). Each is then read with that rig (``library.action_item``), so actions of
other rigs meet through the canonical joints rather than a bone that happens to share a name. See docs/search.md.
"""

from typing import Dict, List, Set

import bpy

from ..actions import action_io
from ..rigs import rigmap
from ..core.errors import ShapeSigError
from ..actions.owners import animated_bones, find_owner, playing_map

__all__ = ["MIN_JOINTS", "library_actions", "rig_joints"]

# another rig's action joins the library when its rig maps at least this many of the armature's joints
MIN_JOINTS = 6


def rig_joints(obj, memo: Dict[int, Set[str]] = None) -> Set[str]:
    """The canonical joints ``obj``'s bone map names (empty when it maps none or cannot be read)."""
    memo = {} if memo is None else memo
    key = obj.as_pointer()
    if key not in memo:
        try:
            memo[key] = set(rigmap.armature_map(obj).values())
        except ShapeSigError:
            memo[key] = set()
    return memo[key]


def library_actions(obj, owners: Dict = None) -> List:
    """The actions (bpy.data order) the search of ``obj`` compares: the module docstring's rule. ``owners``: a
    dict that receives each listed action's ``find_owner(action, prefer=obj)`` by the action's pointer (left
    out when it raised), so that reading them does not look again."""
    names = {b.name for b in obj.data.bones}
    memo: Dict[int, Set[str]] = {}
    mine = rig_joints(obj, memo)
    bone_names: Dict[int, Set[str]] = {}
    armatures = [o for o in bpy.data.objects if o.type == "ARMATURE"]
    played = playing_map(armatures)
    out = []
    for action in action_io.armature_actions(None):
        try:
            owner = find_owner(action, armatures, prefer=obj, bone_names=bone_names, played=played)
            if owners is not None:
                owners[action.as_pointer()] = owner
        except ShapeSigError:
            continue  # played by none and fits two armatures other than obj: whose it is cannot be told
        if owner is None or owner == obj or owner.data == obj.data:
            if owner is not None or not names.isdisjoint(animated_bones(action)):
                out.append(action)
        elif len(rig_joints(owner, memo) & mine) >= MIN_JOINTS or not names.isdisjoint(animated_bones(action)):
            out.append(action)
    return out
