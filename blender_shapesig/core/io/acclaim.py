"""Acclaim ASF/AMC motion capture (the CMU format) without bpy, the one door to the format: ``load_acclaim`` gives
an AMC take as a Clip in ASF axes or Blender's (``to_blender_axes``), ``forward_kinematics``, and the names of
the parsers ``asf.parse_asf`` and ``amc.parse_amc``. Conventions: docs/action_io.md, "ASF/AMC".
"""

import os
import pathlib
from dataclasses import replace
from typing import Optional

import numpy as np

from ..clip.clip import Clip
from ..errors import ParseError
from ..clip.skeleton import map_rest_meta, rest_meta
from .amc import Motion, forward_kinematics, parse_amc
from .asf import Bone, Skeleton, parse_asf
from .files import file_problem
from .text import decode_text

__all__ = [
    "Bone", "Skeleton", "Motion",
    "parse_asf", "parse_amc", "load_acclaim", "to_blender_axes", "ASF_TO_BLENDER",
    "forward_kinematics", "decode_text",
]


# ASF/AMC worlds are Y up; Blender's is Z up: (x, y, z) -> (x, -z, y), the same map Blender's BVH importer uses.
ASF_TO_BLENDER = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])



def find_asf(amc_path, asf=None) -> str:
    """The skeleton of an ``.amc``: ``asf`` when given (it must exist), else the ``.asf`` in the AMC's folder: the
    only one, or among several the one whose name the AMC's own name starts with (CMU ``07.asf`` for
    ``07_01.amc``, HDM05 ``HDM_bd.asf`` for ``HDM_bd_hop_001_120.amc``); ParseError when none or several fit."""
    amc_path = os.fspath(amc_path)
    if asf:
        asf = os.fspath(asf)
        if not os.path.isfile(asf):
            raise ParseError("skeleton file not found", asf)
        return asf
    folder = os.path.dirname(os.path.abspath(amc_path))
    try:
        found = sorted(f for f in os.listdir(folder)
                       if f.lower().endswith(".asf") and file_problem(os.path.join(folder, f)) is None)
    except OSError:
        raise ParseError("cannot list the folder to find its .asf skeleton", amc_path) from None
    if not found:
        raise ParseError("no .asf skeleton beside the .amc; give its skeleton file", amc_path)
    if len(found) > 1:
        name = os.path.basename(amc_path).lower()
        owners = [f for f in found if _owns(f[:-4].lower(), name)]
        longest = max((len(f) for f in owners), default=0)
        owners = [f for f in owners if len(f) == longest]
        if len(owners) != 1:
            raise ParseError(f"{len(found)} .asf files beside the .amc ({', '.join(found[:4])}"
                             f"{', ...' if len(found) > 4 else ''}) and none is named as its start; choose its skeleton file",
                             amc_path)
        found = owners
    return os.path.join(folder, found[0])


def _owns(stem, amc_name):
    """True when an AMC named ``amc_name`` starts with the skeleton name ``stem`` followed by a non-alphanumeric."""
    return amc_name.startswith(stem) and len(amc_name) > len(stem) and not amc_name[len(stem)].isalnum()

def to_blender_axes(clip: Clip, scale: float = 1.0) -> Clip:
    """An Acclaim clip in ASF axes re-expressed in Blender's armature axes (Z up, meters times ``scale``).

    Rotations become ``A L A^T`` (A = ASF_TO_BLENDER) and the root translation ``s A T`` with
    ``s = meters_per_unit * scale``. This is exactly what ``action_io.read_action(..., space="armature")``
    returns for the same take imported with ``shapesig.import_acclaim`` (at the same scale), so clips
    loaded from files and actions in a .blend are compared in one space.
    """
    if clip.meta.get("rotation_space") != "asf":
        raise ParseError(f"clip {clip.name!r} is not in ASF axes")
    A = ASF_TO_BLENDER
    R = A[None, None] @ clip.rotations @ A.T[None, None]
    rt = None
    if clip.root_translation is not None:
        rt = float(clip.meta.get("meters_per_unit", 1.0)) * float(scale) * (clip.root_translation @ A.T)
    meta = dict(clip.meta, rotation_space="armature", up_axis="Z")
    s = float(clip.meta.get("meters_per_unit", 1.0)) * float(scale)
    meta.update(map_rest_meta(clip.meta, A, s), unit_meters=1.0 / float(scale))  # the rest skeleton (feet, FK)
    return replace(clip, rotations=R, root_translation=rt, meta=meta)


def load_acclaim(amc_path, asf_path=None, name=None, skeleton: Optional[Skeleton] = None, axes: str = "asf",
                 scale: float = 1.0) -> Clip:
    """An AMC take as a Clip of local rotations ``L = C M C^-1`` (world-aligned, ASF Y-up axes) for
    every skeleton bone (root first; bones without dofs are the identity), 120 fps (the CMU rate),
    ``frame_start`` the first AMC frame number, ``root_translation`` the root position in ASF units.

    ``asf_path`` None: the only .asf beside the .amc (``sources.find_asf``). ``skeleton``: an already parsed ASF (skips parsing).
    ``axes="blender"``: the clip in Blender's armature axes (see ``to_blender_axes``; ``scale`` applies
    there), the space every Blender-side reader compares in.
    """
    if axes not in ("asf", "blender"):
        raise ParseError(f"axes must be 'asf' or 'blender', got {axes!r}")
    amc_path = os.fspath(amc_path)
    if not os.path.isfile(amc_path):
        raise ParseError("no such AMC file", amc_path)
    if skeleton is None:
        if asf_path is None or os.fspath(asf_path) == "":
            asf_path = find_asf(amc_path)
        skeleton = parse_asf(pathlib.Path(asf_path))
    motion = parse_amc(pathlib.Path(amc_path), skeleton)
    modes = tuple(
        skeleton.root_axis if n == "root" else b.rotation_order for n, b in skeleton.bones.items()
    )
    clip = Clip(
        name=name or pathlib.Path(amc_path).stem,
        bones=skeleton.bone_names,
        rotations=motion.local_rotations(),
        fps=120.0,
        frame_start=int(motion.frame_numbers[0]),
        root_translation=motion.root_translation(),
        root_bone="root",
        rotation_modes=modes,
        source=amc_path,
        meta={
            "format": "acclaim",
            "asf": skeleton.path,
            "length_unit": skeleton.length_unit,
            "meters_per_unit": skeleton.meters_per_unit,
            "frame_numbers": motion.frame_numbers,
            "parents": {n: b.parent for n, b in skeleton.bones.items()},
            # world-aligned local rotations C M C^-1 in the ASF's Y-up axes
            "rotation_space": "asf",
            "up_axis": "Y",
            "unit_meters": skeleton.meters_per_unit,
            **rest_meta(skeleton.bone_names, *skeleton.rest_heads_tails()),  # core.clip.skeleton (FK of the feet)
        },
    )
    return to_blender_axes(clip, scale) if axes == "blender" else clip
