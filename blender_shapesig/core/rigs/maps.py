"""A bone map ``{bone: joint}``: what a valid one is (``check_map``: canonical joints, each given once) and saved
maps (``parse_map`` / ``load_map`` read, ``map_json`` / ``save_map`` write) in the file format of
``core.io.bone_map_file``. ``BONE_MAP_MODES`` are the options besides a saved map. See docs/rigs.md.
"""

import os
from typing import Dict, Mapping

from ..errors import ParseError
from ..io import bone_map_file
from ..io.bone_map_file import MAX_MAP_BYTES
from .names import JOINTS

__all__ = ["BONE_MAP_MODES", "MAX_MAP_BYTES", "check_map", "parse_map", "load_map", "save_map", "map_json"]

BONE_MAP_MODES = ("auto", "none")


def check_map(mapping: Mapping[str, str], where: str = "bone map") -> Dict[str, str]:
    """A validated copy of a ``{bone: joint}`` map: joints must be canonical and used once."""
    if not isinstance(mapping, Mapping):
        raise ParseError("a bone map must be a JSON object {\"bone\": \"joint\", ...}", where)
    out, used = {}, {}
    for bone, joint in mapping.items():
        if not isinstance(bone, str) or not isinstance(joint, str):
            raise ParseError("bone map keys and values must be strings", where)
        if joint not in JOINTS:
            raise ParseError(f"unknown joint {joint!r} for bone {bone!r} (joints: {', '.join(JOINTS)})", where)
        if joint in used:
            raise ParseError(f"joint {joint!r} is given to two bones ({used[joint]!r}, {bone!r})", where)
        used[joint] = bone
        out[bone] = joint
    return out


def map_json(mapping: Mapping[str, str], rig: str = "") -> str:
    """The saved-map JSON text: ``{"bone": "joint", ...}`` (a ``"#rig"`` entry names the rig when given)."""
    body = dict(check_map(mapping))
    if rig:
        body = {"#rig": rig, **body}
    return bone_map_file.dumps(body)


def save_map(path, mapping: Mapping[str, str], rig: str = "") -> str:
    """Write a saved map (``map_json``) to ``path``; returns the path."""
    return bone_map_file.write(os.fspath(path), map_json(mapping, rig))


def parse_map(text, where: str = "bone map") -> Dict[str, str]:
    """A saved map's JSON text (str or UTF-8 bytes) as a validated map; keys starting with ``#`` are comments.
    Every defect is one ``ParseError`` naming ``where``: not UTF-8, over ``MAX_MAP_BYTES``, not JSON, nested too
    deeply for the parser (``bone_map_file.decode``), not an object of strings, unknown or repeated joints."""
    return check_map(bone_map_file.decode(text, where), where)


def load_map(path) -> Dict[str, str]:
    """Read a saved map file (``parse_map``); files over ``MAX_MAP_BYTES`` and files that are not regular files
    (a FIFO, a device, a dangling link) are refused without being read (``bone_map_file.read_bytes``)."""
    path = os.fspath(path)
    return parse_map(bone_map_file.read_bytes(path), path)
