"""Every action's frame rate, known or visibly assumed (Blender layer). A rate is *known* when the action records it
(``RATE``, with ``HOW``: "import" — written by this add-on's readers and blends, "file NAME" — found in the source
file, "user" — set by the animator) or when its source file is found: Blender's BVH importer names the action and
its armature after the file and keys frames 1..N but records no rate, so a ``NAME.bvh`` with N frames in the
.blend's folder or the search's library folders gives it (``found_rate``). Otherwise the scene's rate is *assumed*.
``rate_of`` says which; ``record`` stores a rate on an action (undoable operators only); ``mixed_note`` is the one
line for a comparison or blend that mixes an assumed rate with known ones. See docs/action_io.md.
"""

import os
import re
from typing import Dict, Iterable, List, Optional, Tuple

import bpy

from ..core.errors import ShapeSigError

__all__ = ["RATE", "HOW", "scene_rate", "stored_rate", "found_rate", "rate_of", "record", "mixed_note",
           "rate_text", "forget"]

RATE = "shapesig_fps"       # the action's frame rate (frames per second), also written by action_io.write_action
HOW = "shapesig_fps_from"   # where it came from: "import", "file NAME.bvh", "user"
_SUFFIX = re.compile(r"\.\d{3}$")  # Blender's ".001" of a second import of one file
# the session's look-ups: folder -> {lower-case file name: path}; (action name, frames, folders) -> (fps, path)
_LISTINGS: Dict[str, Dict[str, str]] = {}
_FOUND: Dict[tuple, Optional[Tuple[float, str]]] = {}
_MAX_FILES = 20_000  # a folder walk stops after this many files (a library folder, not a disk)


def forget():
    """Drop the session's folder listings and found files (tests, or after files were added)."""
    _LISTINGS.clear()
    _FOUND.clear()


def scene_rate(scene=None) -> float:
    """The scene's frame rate (fps / fps base; 24 without a scene)."""
    scene = scene or getattr(bpy.context, "scene", None)
    return float(scene.render.fps / scene.render.fps_base) if scene is not None else 24.0


def stored_rate(action) -> Optional[float]:
    """The rate the action records (``RATE``), or None."""
    value = action.get(RATE)
    return float(value) if isinstance(value, (int, float)) and value > 0 else None


def _folders(context=None) -> List[str]:
    """Where source files are looked for: the .blend's folder, the search's folders (else the preferences')."""
    from ..preferences import get_preferences

    out = [os.path.dirname(bpy.data.filepath)] if bpy.data.filepath else []
    scene = getattr(context or bpy.context, "scene", None)
    settings = getattr(scene, "shapesig", None)
    text = getattr(settings, "folders", "") if settings is not None else ""
    if not text:
        prefs = get_preferences(context)
        text = getattr(prefs, "library_folders", "") if prefs is not None else ""
    out += [bpy.path.abspath(p.strip()) for p in text.split(";") if p.strip()]
    return [os.path.abspath(p) for p in out if p and os.path.isdir(p)]


def _listing(folder) -> Dict[str, str]:
    got = _LISTINGS.get(folder)
    if got is None:
        got, count = {}, 0
        for root, dirs, files in os.walk(folder):
            dirs[:] = sorted(d for d in dirs if not d.startswith("."))
            for f in files:
                if f.lower().endswith(".bvh"):
                    got.setdefault(f.lower(), os.path.join(root, f))
            count += len(files)
            if count > _MAX_FILES:
                break
        _LISTINGS[folder] = got
    return got


def _frame_count(action) -> int:
    start, end = action.frame_range
    return int(round(end - start)) + 1


def found_rate(action, context=None) -> Optional[Tuple[float, str]]:
    """(fps, path) of the action's source BVH file: named like the action (a ".001" suffix dropped) with as many
    frames as the action keys, in the folders ``_folders`` names; None when there is none."""
    from ..core.io.bvh import motion_header

    name = _SUFFIX.sub("", action.name)
    frames, folders = _frame_count(action), tuple(_folders(context))
    key = (name, frames, folders)
    if key not in _FOUND:
        _FOUND[key] = None
        for folder in folders:
            path = _listing(folder).get(f"{name.lower()}.bvh")
            if path is None:
                continue
            try:
                n, fps = motion_header(path)
            except (ShapeSigError, OSError):
                continue
            if n == frames:
                _FOUND[key] = (fps, path)
                break
    return _FOUND[key]


def rate_of(action, context=None) -> Tuple[float, bool, str]:
    """(fps, known, how): the recorded rate ("import", "file ...", "user"), else the found file's ("file NAME"),
    else the scene's, assumed ("scene")."""
    fps = stored_rate(action)
    if fps is not None:
        return fps, True, str(action.get(HOW, "import"))
    found = found_rate(action, context)
    if found is not None:
        return found[0], True, f"file {os.path.basename(found[1])}"
    return scene_rate(getattr(context, "scene", None)), False, "scene"


def record(action, fps, how) -> None:
    """Store ``fps`` on the action (``RATE``) and where it came from (``HOW``)."""
    from ..core.clip.prepare import check_fps

    action[RATE] = float(check_fps(float(fps), "frame rate"))
    action[HOW] = str(how)
    from .action_changes import forget_fingerprints

    forget_fingerprints(action)  # a custom property set from Python is reported to no handler


def rate_text(fps: float) -> str:
    """'120 fps', '29.97 fps'."""
    return f"{fps:.0f} fps" if abs(fps - round(fps)) < 0.005 else f"{fps:.2f} fps"


def mixed_note(rates: Iterable[Tuple[str, float, bool]]) -> Optional[str]:
    """One line when assumed rates meet known ones (``rates``: (name, fps, known) per action), else None."""
    rates = list(rates)
    assumed = [(n, f) for n, f, known in rates if not known]
    if not assumed or len(assumed) == len(rates):
        return None
    names = ", ".join(repr(n) for n, _f in assumed[:3]) + (" ..." if len(assumed) > 3 else "")
    return (f"frame rate of {names} assumed ({rate_text(assumed[0][1])}, the scene's) while the others' are known: "
            f"set it in the panel if it differs")


def library_notes(lib) -> List[str]:
    """``mixed_note`` of a search library (``library.SearchLibrary``: its query action, the file's actions with the
    rates their items were made with; folder clips' rates are their files'), as a list of at most one warning
    line."""
    rates = [(lib.action.name, *rate_of(lib.action)[:2])] if lib.action is not None else []
    rates += [(it.action, *it.rate) for it in lib.actions]  # ``library.action_item`` records each one's
    rates += [("", 1.0, True)] if lib.files is not None and len(lib.files) else []  # folder clips
    note = mixed_note(rates)
    return [note] if note else []
