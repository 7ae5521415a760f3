"""Bone maps of armatures in Blender: ``bone_map_of(obj)`` is the one map an armature's actions are read with (the
stored map, else with Auto-Pick the maps folder's map, else "auto"); maps are detected (``core.rigs``), edited
(``rows``, ``set_joint``), stored on the armature data (``shapesig_bone_map``), exported / imported as JSON and
picked from a folder (``best_saved_map``; unreadable files are skipped and named by ``skipped_maps``); ``onto_comparison`` / ``back_onto_armature`` serve blends across rigs.
See docs/rigs.md.
"""

import json
import os
from typing import Dict, List, Optional, Tuple, Union

from ..core import rigs
from ..core.errors import ShapeSigError

__all__ = ["PROP", "armature_parents", "armature_report", "unmapped_joints", "detect_armature_map", "stored_map", "store_map", "clear_map",
           "armature_map", "rows", "export_map", "import_map", "saved_maps", "best_saved_map", "skipped_maps",
           "map_digest", "bone_map_of", "maps_folder", "set_joint", "import_saved", "MIN_PICKED", "across_rigs", "onto_comparison",
           "back_onto_armature"]

PROP = "shapesig_bone_map"
# a saved map is picked automatically (preference Auto-Pick) only when it names at least this many bones of the
# armature (detection's own threshold: three bones of one table)
MIN_PICKED = 3


def _armature_data(obj):
    if obj is None or getattr(obj, "type", None) != "ARMATURE":
        raise ShapeSigError("a bone map needs an armature object")
    return obj.data


def armature_parents(obj) -> Dict[str, Optional[str]]:
    """{bone: parent name or None} of every bone of the armature."""
    return {b.name: (b.parent.name if b.parent else None) for b in _armature_data(obj).bones}


def armature_report(obj) -> rigs.RigReport:
    """``core.rigs.analyse_rig`` of the armature: its bone names, hierarchy and rest pose (every bone's
    ``head_local``/``tail_local``, in the armature's space), so sides come from the rest pose as for files."""
    bones = _armature_data(obj).bones
    parents = {b.name: (b.parent.name if b.parent else None) for b in bones}
    if getattr(obj, "type", None) == "ARMATURE":
        from ..actions import control_rigs

        if control_rigs.is_control_rig(obj):  # read through its deform bones: their map (control_rigs)
            parents = control_rigs.deform_parents(obj)
    heads = {b: tuple(bones[b].head_local) for b in parents}
    tails = {b: tuple(bones[b].tail_local) for b in parents}
    return rigs.analyse_rig(list(parents), parents, heads, tails)


def detect_armature_map(obj) -> Dict[str, str]:
    """The automatic map of the armature's bones (``armature_report``: names, hierarchy and rest pose)."""
    return armature_report(obj).mapping


def unmapped_joints(obj, used: Optional[Dict[str, str]] = None) -> List[str]:
    """The canonical joints the armature's rig has (``armature_report``) that no bone of the map in use
    (``used``, default ``armature_map``) is given, in ``rigs.JOINTS`` order."""
    used = armature_map(obj) if used is None else used
    has, given = set(armature_report(obj).joints), set(used.values())
    return [j for j in rigs.JOINTS if j in has and j not in given]


def stored_map(obj) -> Optional[Dict[str, str]]:
    """The map stored on the armature data, or None."""
    text = _armature_data(obj).get(PROP)
    if not text:
        return None
    try:
        data = json.loads(text) if isinstance(text, str) else None
    except (ValueError, RecursionError):  # RecursionError: a deeply nested text
        data = None
    if not isinstance(data, dict):
        raise ShapeSigError(f"armature {obj.name!r}: its stored bone map is not valid JSON")
    return rigs.check_map(data, f"armature {obj.name!r}")


def store_map(obj, mapping: Dict[str, str]) -> Dict[str, str]:
    """Store a map on the armature data (validated; bones the armature lacks are refused, naming them)."""
    data = _armature_data(obj)
    mapping = rigs.check_map(mapping, f"armature {obj.name!r}")
    missing = [b for b in mapping if b not in data.bones]
    if missing:
        raise ShapeSigError(f"armature {obj.name!r} has no bone(s) {', '.join(missing[:8])}")
    data[PROP] = json.dumps(mapping)
    return mapping


def clear_map(obj) -> None:
    """Remove the stored map (the armature falls back to automatic detection)."""
    data = _armature_data(obj)
    if PROP in data:
        del data[PROP]


def maps_folder(context=None, auto_only=False) -> str:
    """The preferences' folder of saved maps ("" when not set; with ``auto_only``, "" unless Auto-Pick is on)."""
    import bpy

    from ..preferences import get_preferences

    prefs = get_preferences(context)
    if prefs is None or not getattr(prefs, "maps_folder", "") or (auto_only and not prefs.auto_pick_map):
        return ""
    return bpy.path.abspath(prefs.maps_folder)


def bone_map_of(obj, folder=None) -> Union[Dict[str, str], str]:
    """THE bone map this armature's actions are read with (the search library and blends across rigs call only
    this): the map stored on the armature; else, when a maps folder is given (default: the preferences' folder
    with Auto-Pick on), its saved map for this rig (``best_saved_map``, naming at least ``MIN_PICKED`` bones);
    else ``"auto"`` (``core.rigs.resolve_map`` detects the map from the bones read)."""
    stored = stored_map(obj)
    if stored is not None:
        return stored
    folder = maps_folder(auto_only=True) if folder is None else folder
    if folder:
        path, mapping = best_saved_map(obj, folder)
        if path is not None and len(mapping) >= MIN_PICKED:
            return mapping
    return "auto"


def armature_map(obj) -> Dict[str, str]:
    """The map the package uses for this armature (``bone_map_of``) as a dict: "auto" is the detected map."""
    mapping = bone_map_of(obj)
    return detect_armature_map(obj) if mapping == "auto" else dict(mapping)


def map_digest(obj) -> str:
    """The map in use as text ("" for automatic detection): part of an armature's cache digest, so a stored,
    edited or auto-picked map gives the armature's actions new index keys."""
    mapping = bone_map_of(obj)
    return "" if mapping == "auto" else json.dumps(mapping, sort_keys=True)


def set_joint(obj, bone: str, joint: str) -> Dict[str, str]:
    """Give ``bone`` the canonical ``joint`` ("" or "NONE": not a joint) in the map in use and store it; a bone
    that had this joint loses it (a joint is used once). Returns the stored map."""
    if bone not in _armature_data(obj).bones:
        raise ShapeSigError(f"armature {obj.name!r} has no bone {bone!r}")
    mapping = {b: j for b, j in armature_map(obj).items() if b != bone and j != joint}
    if joint and joint != "NONE":
        mapping[bone] = joint
    return store_map(obj, mapping)


def rows(obj) -> List[Tuple[str, str, str]]:
    """The editor's list: (bone, joint in use or "", detected joint or "") for every bone, in armature order."""
    used, detected = armature_map(obj), detect_armature_map(obj)
    return [(b, used.get(b, ""), detected.get(b, "")) for b in armature_parents(obj)]


def export_map(obj, path) -> str:
    """Write the armature's map (``armature_map``) as a saved-map JSON file; returns the path. ShapeSigError
    when no bone is mapped (nothing is written)."""
    mapping = armature_map(obj)
    if not mapping:
        raise ShapeSigError(f"no bone of {obj.name!r} is mapped to a joint: nothing to export")
    return rigs.save_map(path, mapping, rig=obj.data.name)


def import_map(obj, path) -> Dict[str, str]:
    """Read a saved map and store the entries for bones this armature has (ShapeSigError when none match)."""
    mapping = rigs.load_map(path)
    bones = _armature_data(obj).bones
    usable = {b: j for b, j in mapping.items() if b in bones}
    if not usable:
        raise ShapeSigError(f"{os.path.basename(os.fspath(path))}: none of its bones are in armature "
                            f"{obj.name!r}")
    return store_map(obj, usable)


def import_saved(obj, name: str, folder) -> Dict[str, str]:
    """Import the saved map ``name`` (a file name of ``saved_maps(folder)``, with or without ``.json``)."""
    for path in saved_maps(folder):
        if os.path.basename(path) in (name, f"{name}.json"):
            return import_map(obj, path)
    raise ShapeSigError(f"no saved map {name!r} in the maps folder {folder or '(not set)'}")


def saved_maps(folder) -> List[str]:
    """The ``.json`` files of a maps folder, sorted (an empty list when the folder is not set or missing)."""
    if not folder or not os.path.isdir(folder):
        return []
    return sorted(os.path.join(folder, f) for f in os.listdir(folder) if f.lower().endswith(".json"))


# Saved maps best_saved_map skipped: path -> one-line reason (``skipped_maps``: warnings of the search).
_SKIPPED: Dict[str, str] = {}


def best_saved_map(obj, folder) -> Tuple[Optional[str], Dict[str, str]]:
    """(path, map) of the folder's saved map that names most of the armature's bones ((None, {}) when none
    names any); unreadable files (not UTF-8, not JSON, too large or deep, not a map) are skipped and
    remembered for ``skipped_maps``."""
    bones = set(armature_parents(obj))
    best, best_map = None, {}
    for path in saved_maps(folder):
        try:
            mapping = rigs.load_map(path)
            _SKIPPED.pop(path, None)
        except ShapeSigError as exc:
            _SKIPPED[path] = f"saved bone map skipped: {exc}"
            continue
        usable = {b: j for b, j in mapping.items() if b in bones}
        if len(usable) > len(best_map):
            best, best_map = path, usable
    return best, best_map


def skipped_maps(folder) -> List[str]:
    """One warning line per file of the maps folder ``folder`` that ``best_saved_map`` skipped when it last
    read it (each names the file)."""
    present = set(saved_maps(folder))
    return [msg for path, msg in sorted(_SKIPPED.items()) if path in present]


# ------------------------------------------------------------------------------- blends across two rigs

def _rest(armature):
    """({bone: rest head}, {bone: parent}) of an armature, in armature space."""
    bones = _armature_data(armature).bones
    return ({b.name: tuple(b.head_local) for b in bones},
            {b.name: (b.parent.name if b.parent else None) for b in bones})


def across_rigs(armature, other) -> bool:
    """True when actions of ``armature`` and ``other`` are of two rigs (another armature with other bone names,
    or the same names in another rest pose: ``core.rigs.rests_differ``): they are then blended through their
    bone maps; one rig blends in its own space."""
    if other is None or other == armature or _armature_data(other) == _armature_data(armature):
        return False
    if {b.name for b in _armature_data(armature).bones} != {b.name for b in _armature_data(other).bones}:
        return True
    return rigs.rests_differ(*_rest(armature), *_rest(other))


def onto_comparison(a, armature, b, other, bones=None, allow_partial=False):
    """(a, b, bones) for a blend of two rigs: clips ``a`` of ``armature`` and ``b`` of ``other`` (read in
    armature space with their own armatures) in the comparison space through each armature's map
    (``bone_map_of``); ``bones`` (a subset of ``armature``'s bones, or None) becomes their joints. ShapeSigError
    (one line) when a bone of the subset has no joint or the coverage is below ``core.rigs.MIN_COVERAGE`` (unless
    ``allow_partial``)."""
    from ..core.metrics import check_coverage

    ma, mb = rigs.apply_bone_map(a, bone_map_of(armature)), rigs.apply_bone_map(b, bone_map_of(other))
    check_coverage(ma, mb, allow_partial)
    if bones is not None:
        joint_of = {bone: joint for joint, bone in (ma.meta.get("bone_map") or {}).items()}
        missing = [x for x in bones if x not in joint_of]
        if missing:
            raise ShapeSigError(f"bone(s) {', '.join(missing[:5])} of {armature.name!r} map to no joint of the "
                                f"bone map: map them in the Bone Map panel, or blend all shared bones")
        bones = [joint_of[x] for x in bones]
    return ma, mb, bones


def back_onto_armature(clip, rig, mapped):
    """A blend in the comparison space written back onto A's rig (``core.rigs.onto_rig``: mapped bones take
    the blend, the others keep A's motion, listed in ``meta["kept_bones"]``), in A's armature space."""
    out = rigs.onto_rig(clip, rig, mapped)
    out.meta["rotation_space"] = rig.meta.get("rotation_space", "armature")
    return out
