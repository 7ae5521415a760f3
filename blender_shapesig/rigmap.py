"""Bone maps of armatures in Blender: what the map editor (panel) and the library need.

A bone map ``{"bone": "joint"}`` (joints: ``core.rigs.JOINTS``) tells the package which canonical joint each
bone of a rig is. It is detected from the bone names and hierarchy (``core.rigs.detect_map``), can be edited and
is **stored on the armature data** as the custom property ``shapesig_bone_map`` (JSON text, so it travels with
the .blend file and every object using that armature), exported to / imported from the saved-map JSON format
(``core.rigs.save_map`` / ``load_map``), and looked up in a folder of saved maps (the preferences' maps folder).

    rows(obj)                      -> [(bone, joint or "", detected joint or "")]  the editor's list
    armature_map(obj)              -> the stored map, else the detected one
    store_map(obj, mapping) / clear_map(obj) / stored_map(obj)
    export_map(obj, path) / import_map(obj, path)
    best_saved_map(obj, folder)    -> (path, mapping) of the folder's map that names most of the bones

The panel drawing of the editor is not here (the panels are thin; they call these functions).
"""

import json
import os
from typing import Dict, List, Optional, Tuple

from .core import rigs
from .core.errors import ShapeSigError

__all__ = ["PROP", "armature_parents", "detect_armature_map", "stored_map", "store_map", "clear_map",
           "armature_map", "rows", "export_map", "import_map", "saved_maps", "best_saved_map", "map_digest"]

PROP = "shapesig_bone_map"


def _armature_data(obj):
    if obj is None or getattr(obj, "type", None) != "ARMATURE":
        raise ShapeSigError("a bone map needs an armature object")
    return obj.data


def armature_parents(obj) -> Dict[str, Optional[str]]:
    """{bone: parent name or None} of every bone of the armature."""
    return {b.name: (b.parent.name if b.parent else None) for b in _armature_data(obj).bones}


def detect_armature_map(obj) -> Dict[str, str]:
    """The automatic map of the armature's bones (``core.rigs.detect_map``)."""
    parents = armature_parents(obj)
    return rigs.detect_map(list(parents), parents)


def stored_map(obj) -> Optional[Dict[str, str]]:
    """The map stored on the armature data, or None."""
    text = _armature_data(obj).get(PROP)
    if not text:
        return None
    try:
        return rigs.check_map(json.loads(text), f"armature {obj.name!r}")
    except ValueError:
        raise ShapeSigError(f"armature {obj.name!r}: its stored bone map is not valid JSON") from None


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


def armature_map(obj) -> Dict[str, str]:
    """The map the package uses for this armature: the stored one, else the detected one."""
    stored = stored_map(obj)
    return stored if stored is not None else detect_armature_map(obj)


def map_digest(obj) -> str:
    """The stored map's text ("" when none): part of an armature's cache digest."""
    return str(_armature_data(obj).get(PROP, ""))


def rows(obj) -> List[Tuple[str, str, str]]:
    """The editor's list: (bone, joint in use or "", detected joint or "") for every bone, in armature order."""
    used, detected = armature_map(obj), detect_armature_map(obj)
    return [(b, used.get(b, ""), detected.get(b, "")) for b in armature_parents(obj)]


def export_map(obj, path) -> str:
    """Write the armature's map (stored, else detected) as a saved-map JSON file; returns the path."""
    return rigs.save_map(path, armature_map(obj), rig=obj.data.name)


def import_map(obj, path) -> Dict[str, str]:
    """Read a saved map and store the entries for bones this armature has (ShapeSigError when none match)."""
    mapping = rigs.load_map(path)
    bones = _armature_data(obj).bones
    usable = {b: j for b, j in mapping.items() if b in bones}
    if not usable:
        raise ShapeSigError(f"{os.path.basename(os.fspath(path))}: none of its bones are in armature "
                            f"{obj.name!r}")
    return store_map(obj, usable)


def saved_maps(folder) -> List[str]:
    """The ``.json`` files of a maps folder, sorted (an empty list when the folder is not set or missing)."""
    if not folder or not os.path.isdir(folder):
        return []
    return sorted(os.path.join(folder, f) for f in os.listdir(folder) if f.lower().endswith(".json"))


def best_saved_map(obj, folder) -> Tuple[Optional[str], Dict[str, str]]:
    """(path, map) of the folder's saved map that names most of the armature's bones ((None, {}) when none
    names any); unreadable files are skipped."""
    bones = set(armature_parents(obj))
    best, best_map = None, {}
    for path in saved_maps(folder):
        try:
            mapping = rigs.load_map(path)
        except ShapeSigError:
            continue
        usable = {b: j for b, j in mapping.items() if b in bones}
        if len(usable) > len(best_map):
            best, best_map = path, usable
    return best, best_map
