"""Acclaim ASF/AMC motion capture files (the CMU database format), without bpy.

ASF (skeleton) sections: ``:version``, ``:name``, ``:units`` (``mass``, ``length``, ``angle deg|rad``),
``:documentation``, ``:root`` (``order``, ``axis``, ``position``, ``orientation``), ``:bonedata`` (per bone
``begin``/``end`` with ``id``, ``name``, ``direction``, ``length``, ``axis ax ay az ORDER``, ``dof``,
``limits``), ``:hierarchy`` (``begin``, ``parent child...`` lines, ``end``). AMC (motion): header lines
(``#`` comments, ``:FULLY-SPECIFIED``, ``:DEGREES`` or ``:RADIANS``), then frames: a frame number alone on
a line followed by one ``bone value...`` line per animated bone, values in the bone's ``dof`` order (the
root's in its ``order``).

Conventions (all in the ASF's world: right-handed, Y up):

* ``C`` (a bone's ``axis``) is the orientation of the bone's local frame in the world:
  ``C = R_3(a_3) R_2(a_2) R_1(a_1)`` for axis order ``"123"`` (the first named axis is applied first).
* ``M`` (a frame's AMC rotation) is built the same way from the bone's ``dof`` angles in their listed order
  (the root's from its ``axis`` order), about the bone's local axes.
* A bone's *local rotation* (relative to its parent, in world-aligned axes) is ``L = C M C^-1``; its world
  rotation is ``G = G_parent L``; its head is its parent's tail (the root's head is the AMC root
  translation), and its tail is ``head + G (direction * length)``.
* Lengths and translations are in the ASF's units. CMU files say ``length 0.45``: one unit is
  ``1/0.45`` inch, so ``meters = value * 0.0254 / length_unit`` (``Skeleton.meters_per_unit``).
* Only rotations (``rx``, ``ry``, ``rz``) of non-root bones are animated; ``tx/ty/tz/l`` channels of
  non-root bones are read (value count checked) and ignored.
"""

import os
import pathlib
from dataclasses import dataclass, field, replace
from typing import Dict, List, Optional, Tuple

import numpy as np
from scipy.spatial.transform import Rotation

from .clip import Clip
from .errors import ParseError

__all__ = [
    "Bone", "Skeleton", "Motion",
    "parse_asf", "parse_amc", "load_acclaim", "find_asf", "to_blender_axes", "ASF_TO_BLENDER",
    "euler_matrices", "forward_kinematics",
]

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
        return euler_matrices(self.axis[None], self.axis_order)[0]

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


@dataclass
class Motion:
    """A parsed AMC file for a skeleton. ``values[bone]`` is (frames, len(dof)) with angles in radians,
    in the bone's dof order (the root's in ``skeleton.root_order``)."""

    skeleton: Skeleton
    frame_numbers: np.ndarray
    values: Dict[str, np.ndarray]
    path: Optional[str] = None

    @property
    def frames(self) -> int:
        return len(self.frame_numbers)

    def amc_rotations(self) -> np.ndarray:
        """M per frame and bone, (frames, bones, 3, 3); identity for bones without rotation dofs."""
        sk = self.skeleton
        out = np.empty((self.frames, len(sk.bones), 3, 3))
        out[:] = np.eye(3)
        for j, (name, bone) in enumerate(sk.bones.items()):
            vals = self.values.get(name)
            if name == "root":
                order = [c for c in sk.root_order if c.startswith("R")]
                if not order or vals is None:
                    continue
                angles = np.zeros((self.frames, 3))
                for k, c in enumerate(sk.root_order):
                    if c.startswith("R"):
                        angles[:, "XYZ".index(c[1])] = vals[:, k]
                seq = sk.root_axis
                ordered = angles[:, ["XYZ".index(a) for a in seq]]
                out[:, j] = euler_matrices(ordered, seq)
                continue
            rdofs = bone.rotation_dofs
            if not rdofs or vals is None:
                continue
            cols = [bone.dof.index(d) for d in rdofs]
            out[:, j] = euler_matrices(vals[:, cols], "".join(d[1].upper() for d in rdofs))
        return out

    def local_rotations(self) -> np.ndarray:
        """L = C M C^-1 per frame and bone (frames, bones, 3, 3): rotation relative to the parent in
        world-aligned (ASF, Y-up) axes; identity in the rest pose."""
        C = self.skeleton.axis_matrices()
        M = self.amc_rotations()
        return C[None] @ M @ np.swapaxes(C, -1, -2)[None]

    def root_translation(self) -> np.ndarray:
        """The root's world position per frame (frames, 3), ASF units; the ASF ``position`` for axes the
        root order does not animate."""
        sk = self.skeleton
        out = np.tile(np.asarray(sk.root_position, dtype=np.float64), (self.frames, 1))
        vals = self.values.get("root")
        if vals is not None:
            for k, c in enumerate(sk.root_order):
                if c.startswith("T"):
                    out[:, "XYZ".index(c[1])] = vals[:, k]
        return out

    def global_rotations(self) -> np.ndarray:
        """G per frame and bone (frames, bones, 3, 3): world rotation relative to the rest pose."""
        L = self.local_rotations()
        parents = self.skeleton.parent_indices()
        G = np.empty_like(L)
        for j, p in enumerate(parents):
            G[:, j] = L[:, j] if p < 0 else G[:, p] @ L[:, j]
        return G


def euler_matrices(angles, order: str) -> np.ndarray:
    """Rotation matrices (n, 3, 3) for angles (n, len(order)) in radians about fixed axes applied in
    ``order`` (first letter first): ``R = R_last ... R_first``. Blender's Euler mode of the same name."""
    angles = np.asarray(angles, dtype=np.float64)
    if angles.ndim == 1:
        angles = angles[None]
    if angles.shape[1] == 0:
        return np.tile(np.eye(3), (angles.shape[0], 1, 1))
    return Rotation.from_euler(order.lower(), angles).as_matrix()


def forward_kinematics(motion: Motion):
    """World-space heads and tails per frame, each (frames, bones, 3), ASF units and axes."""
    sk = motion.skeleton
    G = motion.global_rotations()
    parents = sk.parent_indices()
    offsets = np.stack([b.direction * b.length for b in sk.bones.values()])
    heads = np.empty((motion.frames, len(parents), 3))
    tails = np.empty_like(heads)
    root = motion.root_translation()
    for j, p in enumerate(parents):
        heads[:, j] = root if p < 0 else tails[:, p]
        tails[:, j] = heads[:, j] + G[:, j] @ offsets[j]
    return heads, tails


# --------------------------------------------------------------------------------------- reading


def _read_source(path_or_text, kind):
    """(text, path or None). A pathlib.Path, or a str without a newline, is a path."""
    if isinstance(path_or_text, (bytes, bytearray)):
        path_or_text = decode_text(bytes(path_or_text))
    if isinstance(path_or_text, str) and ("\n" in path_or_text or path_or_text.strip() == ""):
        return path_or_text, None
    path = os.fspath(path_or_text)
    if not os.path.isfile(path):
        raise ParseError(f"no such {kind} file", path)
    try:
        with open(path, "rb") as fh:
            return decode_text(fh.read()), path
    except OSError as exc:
        raise ParseError(f"cannot read {kind} file: {exc.strerror or exc}", path) from None


def decode_text(data: bytes) -> str:
    """Text of a motion file: UTF-8, or UTF-16 / UTF-32 with a byte-order mark (a UTF-8 BOM is dropped);
    bytes that are not UTF-8 (e.g. latin-1 names in comments) become U+FFFD."""
    for bom, codec in ((b"\xff\xfe\x00\x00", "utf-32-le"), (b"\x00\x00\xfe\xff", "utf-32-be"),
                       (b"\xff\xfe", "utf-16-le"), (b"\xfe\xff", "utf-16-be"), (b"\xef\xbb\xbf", "utf-8")):
        if data.startswith(bom):
            return data[len(bom):].decode(codec, errors="replace")
    return data.decode("utf-8", errors="replace")


def _float(token, where, what, line):
    try:
        value = float(token)
    except ValueError:
        raise ParseError(f"{what}: {token!r} is not a number", where, line) from None
    if not np.isfinite(value):
        raise ParseError(f"{what}: {token!r} is not a finite number", where, line)
    return value


def _floats(tokens, n, where, what, line):
    if len(tokens) != n:
        raise ParseError(f"{what}: expected {n} numbers, got {len(tokens)}", where, line)
    return np.array([_float(t, where, what, line) for t in tokens])


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
    text, path = _read_source(path_or_text, "ASF")
    where = path or "<ASF text>"
    if not text.strip():
        raise ParseError("empty ASF file", where)
    sections = _sections(text.splitlines(), where)
    found = {}
    for sec in sections:
        if sec[0] in found and sec[0] in (":root", ":bonedata", ":hierarchy", ":units"):
            raise ParseError(f"section {sec[0]} appears twice", where, sec[1])
        found[sec[0]] = sec
    for required in (":root", ":bonedata", ":hierarchy"):
        if required not in found:
            raise ParseError(f"missing {required} section (is this an ASF file?)", where)

    sk_name = " ".join(found[":name"][2]) if ":name" in found else ""
    version = " ".join(found[":version"][2]) if ":version" in found else ""

    # :units
    length_unit, mass_unit, angle_unit = 1.0, 1.0, "deg"
    if ":units" in found:
        for no, tokens in found[":units"][3]:
            key = tokens[0].lower()
            if key in ("length", "mass"):
                if len(tokens) != 2:
                    raise ParseError(f"units {key}: expected one number", where, no)
                value = _float(tokens[1], where, f"units {key}", no)
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
                    raise ParseError(f"units angle must be 'deg' or 'rad', got {' '.join(tokens[1:])!r}",
                                     where, no)
                angle_unit = unit
    to_rad = np.pi / 180.0 if angle_unit == "deg" else 1.0

    # :root
    root_order, root_axis = _ROOT_CHANNELS, "XYZ"
    position, orientation = np.zeros(3), np.zeros(3)
    root_line = found[":root"][1]
    for no, tokens in found[":root"][3]:
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

    bones: Dict[str, Bone] = {}
    root = Bone(name="root", id=0, axis=orientation, axis_order=root_axis,
                dof=tuple(c.lower() for c in root_order), line=root_line)
    bones["root"] = root

    # :bonedata
    current = None
    pending_limits = 0
    for no, tokens in found[":bonedata"][3]:
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
        raise ParseError("no bones in :bonedata", where, found[":bonedata"][1])

    # :hierarchy
    parents: Dict[str, str] = {}
    children: Dict[str, List[str]] = {}
    state = "before"
    for no, tokens in found[":hierarchy"][3]:
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

    # Order: depth-first from the root, children in hierarchy order; every bone must be reached.
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

    return Skeleton(
        name=sk_name, bones=ordered, length_unit=length_unit, mass_unit=mass_unit, angle_unit=angle_unit,
        root_order=root_order, root_axis=root_axis, root_position=position, root_orientation=orientation,
        path=path, version=version,
    )


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


def parse_amc(path_or_text, skeleton: Skeleton) -> Motion:
    """Parse an AMC motion for ``skeleton``. Every frame must give every bone that has dofs, with one
    value per dof. Angles are returned in radians."""
    text, path = _read_source(path_or_text, "AMC")
    where = path or "<AMC text>"
    if not text.strip():
        raise ParseError("empty AMC file", where)
    amc_unit = None
    counts = {}
    for name, bone in skeleton.bones.items():
        counts[name] = len(bone.dof)
    animated = [n for n, c in counts.items() if c > 0]
    frame_numbers: List[int] = []
    rows: Dict[str, List[list]] = {n: [] for n in animated}
    lines_of: Dict[str, List[int]] = {n: [] for n in animated}
    current: Optional[dict] = None
    frame_line = 0

    def close_frame():
        missing = [n for n in animated if n not in current]
        if missing:
            raise ParseError(
                f"frame {frame_numbers[-1]} has no values for bone(s) {', '.join(missing[:5])}"
                f"{' ...' if len(missing) > 5 else ''} (truncated file?)", where, frame_line)
        for n in animated:
            rows[n].append(current[n])

    lines = text.splitlines()
    last = max((k for k, ln in enumerate(lines, 1) if ln.strip()), default=0)
    for no, raw in enumerate(lines, 1):
        cut = " (truncated file?)" if no == last else ""  # a bad last line is most likely a cut one
        text_line = raw.strip()
        if not text_line or text_line.startswith("#"):
            continue
        if text_line.startswith(":"):
            if frame_numbers:
                raise ParseError(f"header line {text_line.split()[0]!r} after the first frame", where, no)
            key = text_line.split()[0].upper()
            if key == ":DEGREES":
                amc_unit = "deg"
            elif key == ":RADIANS":
                amc_unit = "rad"
            continue
        tokens = text_line.split()
        if len(tokens) == 1 and tokens[0].lstrip("+-").isdigit():
            number = int(tokens[0])
            if current is not None:
                close_frame()
            if frame_numbers and number != frame_numbers[-1] + 1:
                raise ParseError(f"frame number {number} follows {frame_numbers[-1]} (frames must be "
                                 f"consecutive)", where, no)
            frame_numbers.append(number)
            current = {}
            frame_line = no
            continue
        name = tokens[0]
        if current is None:
            raise ParseError(f"expected a frame number, got {text_line[:40]!r}", where, no)
        if name not in counts:
            raise ParseError(f"bone {name!r} is not in the skeleton {skeleton.path or skeleton.name!r}{cut}",
                             where, no)
        if name in current:
            raise ParseError(f"bone {name!r} given twice in frame {frame_numbers[-1]}", where, no)
        n = counts[name]
        if len(tokens) - 1 != n:
            raise ParseError(f"bone {name!r} needs {n} values (its dof), got {len(tokens) - 1}{cut}", where, no)
        if n:
            current[name] = tokens  # converted in bulk below (line number kept for errors)
            lines_of[name].append(no)
    if current is None:
        raise ParseError("no frames (is this an AMC file?)", where)
    close_frame()

    unit = amc_unit or skeleton.angle_unit
    to_rad = np.pi / 180.0 if unit == "deg" else 1.0
    values: Dict[str, np.ndarray] = {}
    for name in animated:
        arr = _to_floats(rows[name], lines_of[name], name, where).reshape(len(frame_numbers), counts[name])
        chans = skeleton.root_order if name == "root" else skeleton.bones[name].dof
        for k, c in enumerate(chans):
            if c.lower().startswith("r"):
                arr[:, k] *= to_rad
        values[name] = arr
    return Motion(skeleton=skeleton, frame_numbers=np.array(frame_numbers), values=values, path=path)


def _to_floats(rows, line_numbers, name, where):
    """(rows, values) floats from rows of tokens ``[bone, v1, v2, ...]``; ParseError naming the first bad line."""
    try:
        arr = np.array([r[1:] for r in rows], dtype=np.float64)
    except ValueError:
        arr = None
    if arr is not None and np.all(np.isfinite(arr)):
        return arr
    for r, no in zip(rows, line_numbers):
        for t in r[1:]:
            try:
                v = float(t)
            except ValueError:
                raise ParseError(f"bone {name!r}: {t!r} is not a number", where, no) from None
            if v != v or v in (float("inf"), float("-inf")):
                raise ParseError(f"bone {name!r}: {t!r} is not a finite number", where, no)
    raise ParseError(f"bone {name!r}: bad values", where)  # not reached


def find_asf(amc_path) -> str:
    """The only .asf file in the AMC's folder; ParseError when there is none or several."""
    amc_path = os.fspath(amc_path)
    folder = os.path.dirname(os.path.abspath(amc_path))
    try:
        candidates = sorted(f for f in os.listdir(folder) if f.lower().endswith(".asf"))
    except OSError:
        raise ParseError("cannot list the folder to find its .asf skeleton", amc_path) from None
    if not candidates:
        raise ParseError("no .asf skeleton beside the .amc; give the skeleton explicitly", amc_path)
    if len(candidates) > 1:
        raise ParseError(
            f"{len(candidates)} .asf files beside the .amc ({', '.join(candidates[:4])}"
            f"{', ...' if len(candidates) > 4 else ''}); give the skeleton explicitly", amc_path)
    return os.path.join(folder, candidates[0])


# ASF/AMC worlds are Y up; Blender's is Z up: (x, y, z) -> (x, -z, y), the same map Blender's BVH importer uses.
ASF_TO_BLENDER = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])


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
    return replace(clip, rotations=R, root_translation=rt, meta=meta)


def load_acclaim(amc_path, asf_path=None, name=None, skeleton: Optional[Skeleton] = None, axes: str = "asf",
                 scale: float = 1.0) -> Clip:
    """An AMC take as a Clip of local rotations ``L = C M C^-1`` (world-aligned, ASF Y-up axes) for
    every skeleton bone (root first; bones without dofs are the identity), 120 fps (the CMU rate),
    ``frame_start`` the first AMC frame number, ``root_translation`` the root position in ASF units.

    ``asf_path`` None: the only .asf beside the .amc. ``skeleton``: an already parsed ASF (skips parsing).
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
            # world-aligned local rotations C M C^-1 in the ASF's Y-up axes
            "rotation_space": "asf",
            "up_axis": "Y",
        },
    )
    return to_blender_axes(clip, scale) if axes == "blender" else clip
