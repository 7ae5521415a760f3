"""Acclaim ASF skeletons (the CMU database format), without bpy.

Sections: ``:version``, ``:name``, ``:units`` (``mass``, ``length``, ``angle deg|rad``), ``:documentation``,
``:root`` (``order``, ``axis``, ``position``, ``orientation``), ``:bonedata`` (per bone ``begin``/``end`` with
``id``, ``name``, ``direction``, ``length``, ``axis ax ay az ORDER``, ``dof``, ``limits``), ``:hierarchy``
(``begin``, ``parent child...`` lines, ``end``). Conventions (axis frames C, units): ``formats.acclaim``.
"""

from dataclasses import dataclass, field
from typing import Dict, List, Optional, Tuple

import numpy as np

from ..errors import ParseError
from ..geometry.so3 import matrix_from_euler
from .text import finite_float, read_text

__all__ = ["Bone", "Skeleton", "parse_asf"]

_ROT_DOFS = ("rx", "ry", "rz")
_ALL_DOFS = ("rx", "ry", "rz", "tx", "ty", "tz", "l")
_ROOT_CHANNELS = ("TX", "TY", "TZ", "RX", "RY", "RZ")


@dataclass


class Bone:
    """One ASF bone. Angles in radians; ``axis_matrix`` is C (see module docstring)."""

    name: str
    id: int = 0
    direction: np.ndarray = field(default_factory=lambda: np.zeros(3))
    length: float = 0.0
    axis: np.ndarray = field(default_factory=lambda: np.zeros(3))
    axis_order: str = "XYZ"
    dof: Tuple[str, ...] = ()
    limits: Tuple[Tuple[float, float], ...] = ()
    parent: Optional[str] = None
    children: List[str] = field(default_factory=list)
    line: int = 0

    @property
    def axis_matrix(self) -> np.ndarray:
        return matrix_from_euler(self.axis, self.axis_order)

    @property
    def rotation_dofs(self) -> Tuple[str, ...]:
        return tuple(d for d in self.dof if d in _ROT_DOFS)

    @property
    def rotation_order(self) -> str:
        """Euler order of the AMC rotation as Blender names it (first applied first), e.g. 'XYZ'.

        Missing axes are appended in X, Y, Z order (their angle is always 0)."""
        axes = [d[1].upper() for d in self.rotation_dofs]
        axes += [a for a in "XYZ" if a not in axes]
        return "".join(axes)


@dataclass


class Skeleton:
    """A parsed ASF file. ``bones`` holds the root (named ``"root"``) first, then every bone with its
    parent before it (hierarchy order)."""

    name: str
    bones: Dict[str, Bone]
    length_unit: float = 1.0
    mass_unit: float = 1.0
    angle_unit: str = "deg"
    root_order: Tuple[str, ...] = _ROOT_CHANNELS
    root_axis: str = "XYZ"
    root_position: np.ndarray = field(default_factory=lambda: np.zeros(3))
    root_orientation: np.ndarray = field(default_factory=lambda: np.zeros(3))
    path: Optional[str] = None
    version: str = ""

    @property
    def bone_names(self) -> Tuple[str, ...]:
        return tuple(self.bones)

    @property
    def meters_per_unit(self) -> float:
        return 0.0254 / self.length_unit

    def parent_indices(self) -> np.ndarray:
        """Index of each bone's parent in ``bone_names`` (-1 for the root)."""
        index = {n: i for i, n in enumerate(self.bones)}
        return np.array([index[b.parent] if b.parent else -1 for b in self.bones.values()])

    def axis_matrices(self) -> np.ndarray:
        """C per bone, shape (bones, 3, 3)."""
        return np.stack([b.axis_matrix for b in self.bones.values()])

    def rest_heads_tails(self):
        """Rest-pose heads and tails (bones, 3) in ASF world units (the root: head = position, tail = head)."""
        names = self.bone_names
        heads = np.zeros((len(names), 3))
        tails = np.zeros((len(names), 3))
        index = {n: i for i, n in enumerate(names)}
        for i, bone in enumerate(self.bones.values()):
            if bone.parent is None:
                heads[i] = self.root_position
            else:
                heads[i] = tails[index[bone.parent]]
            tails[i] = heads[i] + bone.direction * bone.length
        return heads, tails


# --------------------------------------------------------------------------------------- reading


def _floats(tokens, n, where, what, line):
    if len(tokens) != n:
        raise ParseError(f"{what}: expected {n} numbers, got {len(tokens)}", where, line)
    return np.array([finite_float(t, where, line, what) for t in tokens])


def _order(token, where, what, line):
    order = token.upper()
    if len(order) != 3 or sorted(order) != ["X", "Y", "Z"]:
        raise ParseError(f"{what}: {token!r} is not an axis order like XYZ", where, line)
    return order


def _sections(lines, where):
    """Split lines into [(keyword, header_line_no, header_rest_tokens, [(line_no, tokens)...])]."""
    sections = []
    current = None
    for no, raw in enumerate(lines, 1):
        text = raw.split("#", 1)[0].strip()
        if not text:
            continue
        tokens = text.split()
        if tokens[0].startswith(":"):
            current = (tokens[0].lower(), no, tokens[1:], [])
            sections.append(current)
        elif current is None:
            raise ParseError(f"unexpected {tokens[0]!r} before the first ':' section", where, no)
        else:
            current[3].append((no, tokens))
    return sections

def parse_asf(path_or_text) -> Skeleton:
    """Parse an ASF skeleton (a path, or the file's text). Raises ParseError with the line on bad input."""
    text, path = read_text(path_or_text, "ASF")
    where = path or "<ASF text>"
    if not text.strip():
        raise ParseError("empty ASF file", where)
    found = {}
    for sec in _sections(text.splitlines(), where):
        if sec[0] in found and sec[0] in (":root", ":bonedata", ":hierarchy", ":units"):
            raise ParseError(f"section {sec[0]} appears twice", where, sec[1])
        found[sec[0]] = sec
    for required in (":root", ":bonedata", ":hierarchy"):
        if required not in found:
            raise ParseError(f"missing {required} section (is this an ASF file?)", where)
    length_unit, mass_unit, angle_unit = _units(found[":units"][3] if ":units" in found else (), where)
    to_rad = np.pi / 180.0 if angle_unit == "deg" else 1.0
    root_order, root_axis, position, orientation = _root(found[":root"][3], where, to_rad)
    bones: Dict[str, Bone] = {"root": Bone(name="root", id=0, axis=orientation, axis_order=root_axis,
                                          dof=tuple(c.lower() for c in root_order), line=found[":root"][1])}
    _bonedata(found[":bonedata"], bones, where, to_rad)
    ordered = _hierarchy(found[":hierarchy"][3], bones, where)
    return Skeleton(
        name=" ".join(found[":name"][2]) if ":name" in found else "", bones=ordered, length_unit=length_unit,
        mass_unit=mass_unit, angle_unit=angle_unit, root_order=root_order, root_axis=root_axis,
        root_position=position, root_orientation=orientation, path=path,
        version=" ".join(found[":version"][2]) if ":version" in found else "",
    )


def _units(lines, where):
    """(length unit, mass unit, angle unit) of the ``:units`` section (defaults 1, 1, deg)."""
    length_unit, mass_unit, angle_unit = 1.0, 1.0, "deg"
    for no, tokens in lines:
        key = tokens[0].lower()
        if key in ("length", "mass"):
            if len(tokens) != 2:
                raise ParseError(f"units {key}: expected one number", where, no)
            value = finite_float(tokens[1], where, no, f"units {key}")
            if not 1e-30 < value < 1e30:
                raise ParseError(f"units {key} must be a positive number between 1e-30 and 1e30, got "
                                 f"{tokens[1]}", where, no)
            if key == "length":
                length_unit = value
            else:
                mass_unit = value
        elif key == "angle":
            unit = tokens[1].lower() if len(tokens) == 2 else ""
            if unit not in ("deg", "rad"):
                raise ParseError(f"units angle must be 'deg' or 'rad', got {' '.join(tokens[1:])!r}", where, no)
            angle_unit = unit
    return length_unit, mass_unit, angle_unit


def _root(lines, where, to_rad):
    """(channel order, axis order, position, orientation in radians) of the ``:root`` section."""
    root_order, root_axis = _ROOT_CHANNELS, "XYZ"
    position, orientation = np.zeros(3), np.zeros(3)
    for no, tokens in lines:
        key = tokens[0].lower()
        if key == "order":
            chans = tuple(t.upper() for t in tokens[1:])
            bad = [c for c in chans if c not in _ROOT_CHANNELS]
            if bad or len(set(chans)) != len(chans) or not chans:
                raise ParseError(f"root order: bad channel list {' '.join(tokens[1:])!r}", where, no)
            root_order = chans
        elif key == "axis":
            if len(tokens) != 2:
                raise ParseError("root axis: expected an axis order like XYZ", where, no)
            root_axis = _order(tokens[1], where, "root axis", no)
        elif key == "position":
            position = _floats(tokens[1:], 3, where, "root position", no)
        elif key == "orientation":
            orientation = _floats(tokens[1:], 3, where, "root orientation", no) * to_rad
        else:
            raise ParseError(f"unknown root field {tokens[0]!r}", where, no)
    return root_order, root_axis, position, orientation


def _bonedata(section, bones, where, to_rad):
    """Add the bones of the ``:bonedata`` section to ``bones``."""
    current = None
    pending_limits = 0
    for no, tokens in section[3]:
        key = tokens[0].lower()
        if current is None:
            if key != "begin":
                raise ParseError(f"expected 'begin' in :bonedata, got {tokens[0]!r}", where, no)
            current = {"line": no}
            continue
        if pending_limits and key.startswith("("):
            current.setdefault("limits_tokens", []).extend(tokens)
            continue
        if key == "begin":
            raise ParseError("'begin' inside a bone (missing 'end')", where, no)
        if key == "end":
            bone = _make_bone(current, where, to_rad)
            if bone.name in bones:
                raise ParseError(f"bone {bone.name!r} defined twice", where, current["line"])
            bones[bone.name] = bone
            current = None
            pending_limits = 0
            continue
        pending_limits = 0
        if key in current:
            raise ParseError(f"bone field {key!r} given twice", where, no)
        if key == "limits":
            current["limits_tokens"] = tokens[1:]
            current["limits_line"] = no
            pending_limits = 1
        else:
            current[key] = (no, tokens[1:])
    if current is not None:
        raise ParseError("bone not closed with 'end' (truncated file?)", where, current["line"])
    if len(bones) == 1:
        raise ParseError("no bones in :bonedata", where, section[1])


def _hierarchy(lines, bones, where) -> Dict[str, Bone]:
    """The bones in hierarchy order (depth-first from the root, children in the order the ``:hierarchy``
    section lists them) with their parents and children set; every bone must be reached."""
    parents: Dict[str, str] = {}
    children: Dict[str, List[str]] = {}
    state = "before"
    for no, tokens in lines:
        key = tokens[0].lower()
        if state == "before":
            if key != "begin":
                raise ParseError(f"expected 'begin' in :hierarchy, got {tokens[0]!r}", where, no)
            state = "in"
            continue
        if state == "after":
            raise ParseError(f"unexpected {tokens[0]!r} after the hierarchy's 'end'", where, no)
        if key == "end":
            state = "after"
            continue
        parent = tokens[0]
        if parent not in bones:
            raise ParseError(f"hierarchy names unknown bone {parent!r}", where, no)
        if len(tokens) < 2:
            raise ParseError(f"hierarchy line for {parent!r} lists no children", where, no)
        for child in tokens[1:]:
            if child not in bones:
                raise ParseError(f"hierarchy names unknown bone {child!r}", where, no)
            if child == "root":
                raise ParseError("the root cannot be a child in the hierarchy", where, no)
            if child in parents:
                raise ParseError(f"bone {child!r} has two parents in the hierarchy", where, no)
            parents[child] = parent
            children.setdefault(parent, []).append(child)
    if state != "after":
        raise ParseError("hierarchy not closed with 'end' (truncated file?)", where)
    ordered: Dict[str, Bone] = {}
    stack = ["root"]
    while stack:
        name = stack.pop()
        if name in ordered:
            raise ParseError(f"bone {name!r} is in a cycle in the hierarchy", where)
        bone = bones[name]
        bone.parent = parents.get(name)
        bone.children = list(children.get(name, []))
        ordered[name] = bone
        stack.extend(reversed(bone.children))
    missing = [n for n in bones if n not in ordered]
    if missing:
        raise ParseError(f"bone(s) not connected to the root in :hierarchy: {', '.join(missing)}", where)
    return ordered


def _make_bone(fields, where, to_rad) -> Bone:
    line = fields["line"]
    for required in ("name", "direction", "length", "axis"):
        if required not in fields:
            raise ParseError(f"bone has no {required!r}", where, line)
    no, tokens = fields["name"]
    if len(tokens) != 1:
        raise ParseError("bone name: expected one word", where, no)
    name = tokens[0]
    if name == "root":
        raise ParseError("a bone in :bonedata may not be called 'root'", where, no)
    bone_id = 0
    if "id" in fields:
        no, tokens = fields["id"]
        bone_id = int(_floats(tokens, 1, where, f"bone {name} id", no)[0])
    no, tokens = fields["direction"]
    direction = _floats(tokens, 3, where, f"bone {name} direction", no)
    with np.errstate(over="ignore"):  # numpy 2's 3-vector norm warns on overflow (1.26's BLAS dot did not);
        norm = np.linalg.norm(direction)  # a huge direction gives norm inf and the zero vector on both
    if norm > 0:
        direction = direction / norm
    no, tokens = fields["length"]
    length = _floats(tokens, 1, where, f"bone {name} length", no)[0]
    if length < 0:
        raise ParseError(f"bone {name} length is negative", where, no)
    no, tokens = fields["axis"]
    if len(tokens) != 4:
        raise ParseError(f"bone {name} axis: expected three angles and an order like XYZ", where, no)
    axis = _floats(tokens[:3], 3, where, f"bone {name} axis", no) * to_rad
    axis_order = _order(tokens[3], where, f"bone {name} axis", no)
    dof: Tuple[str, ...] = ()
    if "dof" in fields:
        no, tokens = fields["dof"]
        dof = tuple(t.lower() for t in tokens)
        bad = [t for t in dof if t not in _ALL_DOFS]
        if bad or len(set(dof)) != len(dof):
            raise ParseError(f"bone {name} dof: bad channel list {' '.join(tokens)!r}", where, no)
    limits: Tuple[Tuple[float, float], ...] = ()
    if "limits_tokens" in fields:
        no = fields["limits_line"]
        joined = " ".join(fields["limits_tokens"]).replace("(", " ").replace(")", " ").split()
        if len(joined) != 2 * len(dof):
            raise ParseError(f"bone {name} limits: expected {len(dof)} (min max) pairs for its dof",
                             where, no)
        vals = []
        for t in joined:
            try:
                vals.append(float(t))
            except ValueError:
                raise ParseError(f"bone {name} limits: {t!r} is not a number", where, no) from None
        limits = tuple((vals[2 * k], vals[2 * k + 1]) for k in range(len(dof)))
    return Bone(name=name, id=bone_id, direction=direction, length=float(length), axis=axis,
                axis_order=axis_order, dof=dof, limits=limits, line=line)
