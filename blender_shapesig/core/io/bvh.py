"""BVH files without bpy: ``load_bvh`` reads a take as a Clip equal to what Blender's importer gives in armature
space (to its 32-bit floats), the reader of the index and the command line; ``check_bvh`` validates the
structure and every number first, naming the line, so Blender's importer only ever sees a file it reads. Why the
two agree: docs/dev/rotations.md. The Blender half is ``blender_shapesig.readers.bvh``.
"""

import os
import re
import warnings
from dataclasses import dataclass, field
from typing import List, Optional

import numpy as np

from ..errors import ParseError
from .files import check_frames, max_frames, read_bytes
from .text import decode_text, finite_float

__all__ = ["bvh_text", "check_bvh", "motion_header", "rate_of_frame_time", "load_bvh", "parse_bvh", "BvhJoint", "BVH_TO_BLENDER"]

# The axis conversion of Blender's importer (axis_forward '-Z', axis_up 'Y' -> Blender's Y forward, Z up).
BVH_TO_BLENDER = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
# A E A^T by indexing (batched 3x3 products are slow in numpy): A[i] = _SIGN[i] e_{_PERM[i]}.
_PERM = np.argmax(np.abs(BVH_TO_BLENDER), axis=1)
_SIGNS = np.outer(BVH_TO_BLENDER[np.arange(3), _PERM], BVH_TO_BLENDER[np.arange(3), _PERM])
# The MOTION header's frame count (checked against the frame cap before the text is split into lines), and the
# most lines a hierarchy may add to the frames (5 lines a joint: 20,000 joints).
_FRAMES_HEADER = re.compile(r"(?i)\bMOTION\s+Frames\s*:\s*(\d{1,30})")
_HIERARCHY_LINES = 100_000
# Blender's bone names hold at most 63 bytes.
_MAX_NAME_BYTES = 63

def bvh_text(path):
    """(text, plain): the file's text (UTF-8; UTF-16/32 or UTF-8 with a byte-order mark; else latin-1) and
    whether it is plain UTF-8 without a BOM, the only encoding Blender's importer reads. UnreadableFileError
    for a file the readers do not open (``core.io.files``: not a regular file, over the size or line cap)."""
    data = read_bytes(path, "BVH")  # a regular file within the size and line caps (core.io.files)
    if data.startswith((b"\xff\xfe", b"\xfe\xff", b"\xef\xbb\xbf", b"\x00\x00\xfe\xff")):
        return decode_text(data), False
    try:
        return data.decode("utf-8"), True
    except UnicodeDecodeError:
        return data.decode("latin-1"), False


_FLOAT32_MAX = 3.4028234e38


def check_bvh(path):
    """Validate a BVH file's structure and numbers before Blender's importer sees it (its failures are
    tracebacks); returns the frame time. Raises ParseError naming the line."""
    lines = _bvh_lines(path)
    if not any(ln.strip() for ln in lines):
        raise ParseError("empty BVH file", path)
    channels, depth, joints = 0, 0, 0
    motion_line = None
    seen_header = False
    for no, raw in enumerate(lines, 1):
        tokens = raw.split()
        if not tokens:
            continue
        key = tokens[0].upper()
        if not seen_header:
            if key != "HIERARCHY":
                raise ParseError("expected HIERARCHY (is this a BVH file?)", path, no)
            seen_header = True
            continue
        if key in ("ROOT", "JOINT"):
            joints += 1
        elif key == "{":
            depth += 1
        elif key == "}":
            depth -= 1
            if depth < 0:
                raise ParseError("unbalanced '}'", path, no)
        elif key == "CHANNELS":
            try:
                n = int(tokens[1])
            except (IndexError, ValueError):
                raise ParseError("bad CHANNELS line", path, no) from None
            if len(tokens) != n + 2:
                raise ParseError(f"CHANNELS says {n} but lists {len(tokens) - 2}", path, no)
            channels += n
        elif key == "OFFSET":
            if len(tokens) != 4:
                raise ParseError("OFFSET needs 3 numbers", path, no)
            for v in tokens[1:]:
                finite_float(v, path, no, limit=_FLOAT32_MAX)
        elif key == "MOTION":
            motion_line = no
            break
    if motion_line is None or joints == 0:
        raise ParseError("no MOTION section (truncated BVH?)" if joints else "no joints (is this a BVH file?)", path)
    if depth != 0:
        raise ParseError("unbalanced braces in HIERARCHY", path, motion_line)
    head = [(i, ln) for i, ln in enumerate(lines[motion_line:], motion_line + 1) if ln.strip()][:2]
    if len(head) < 2:
        raise ParseError("MOTION section without Frames / Frame Time", path, motion_line)
    (n1, frames_line), (n2, time_line) = head
    frames = _header_value(frames_line, "Frames", int, "N", path, n1)
    frame_time = _header_value(time_line, "Frame Time", float, "seconds", path, n2)
    if not frame_time > 0 or frame_time != frame_time or frame_time == float("inf"):
        raise ParseError("'Frame Time' must be a positive number", path, n2)
    if frames < 1:
        raise ParseError("no frames", path, n1)
    check_frames(frames, path, n1)
    data = [(i, ln) for i, ln in enumerate(lines[n2:], n2 + 1) if ln.strip()]
    if len(data) < frames:
        raise ParseError(f"{len(data)} frames of motion data for 'Frames: {frames}' (truncated file?)", path)
    for i, ln in data[:frames]:
        values = ln.split()
        if len(values) != channels:
            raise ParseError(f"{len(values)} values for {channels} channels", path, i)
        for v in values:
            finite_float(v, path, i, limit=_FLOAT32_MAX)
    return frame_time


_FRAME_TIME = re.compile(r"(?i)\bFrame\s+Time\s*:\s*([0-9.eE+-]{1,40})")


def rate_of_frame_time(frame_time: float) -> float:
    """The frame rate of a ``Frame Time``, rounded to a whole rate when within 0.1 % of one ("0.00833333": 120;
    "0.016667", 59.9988: 60)."""
    fps = 1.0 / frame_time
    return float(round(fps)) if abs(fps - round(fps)) <= 1e-3 * fps else fps


def motion_header(path):
    """(frames, fps) of a BVH file's MOTION header, without parsing its hierarchy or data; ParseError when the
    header is missing or not positive."""
    text = bvh_text(path)[0]
    frames, time = _FRAMES_HEADER.search(text), _FRAME_TIME.search(text)
    try:
        frame_time = float(time.group(1)) if time else 0.0
    except ValueError:
        frame_time = 0.0
    if frames is None or not 0.0 < frame_time < float("inf"):
        raise ParseError("no MOTION header with Frames and a positive Frame Time", path)
    return int(frames.group(1)), rate_of_frame_time(frame_time)


def _bvh_lines(path):
    """The lines of a BVH file, after the frame cap (``core.io.files.check_frames``) was checked on its text: the
    MOTION header's ``Frames:`` and the number of lines (every data line is a frame), so that a file claiming or
    holding millions of frames is refused before it is split into lines and parsed."""
    text = bvh_text(path)[0]
    header = _FRAMES_HEADER.search(text)
    if header is not None:
        check_frames(int(header.group(1)), path, text.count("\n", 0, header.start(1)) + 1)
    lines = text.count("\n") or text.count("\r")
    if lines > max_frames() + _HIERARCHY_LINES:
        check_frames(lines - _HIERARCHY_LINES, path, more=True)  # every line of motion data is a frame
    return text.splitlines()


def _header_value(line, label, convert, what, path, no):
    """``convert`` of the value of a MOTION header line ``label: value`` (case and spacing free)."""
    line = " ".join(line.split())
    try:
        if not line.lower().startswith(label.lower()):
            raise ValueError
        return convert(line.split(":", 1)[1])
    except (IndexError, ValueError):
        raise ParseError(f"expected '{label}: {what}'", path, no) from None


# ------------------------------------------------------------------------------------------------ reader

@dataclass
class BvhJoint:
    """One ROOT/JOINT: ``name`` (as Blender's importer names the bone), ``parent`` (index, -1 for a root),
    ``channels`` (lower-case channel names in file order) and ``first`` (column of its first channel)."""

    name: str
    parent: int
    channels: List[str] = field(default_factory=list)
    first: int = 0
    offset: tuple = (0.0, 0.0, 0.0)  # OFFSET (BVH axes and units); ``end``: its End Site's OFFSET, if any
    end: Optional[tuple] = None

    def columns(self, kind):
        """{axis letter: column} of its ``kind`` ("position" or "rotation") channels, in file order."""
        return {c[0]: self.first + i for i, c in enumerate(self.channels) if c[1:] == kind}


def _bone_name(raw, taken):
    """Blender's bone name for a joint: truncated to 63 bytes, then ``.001``, ``.002``... while taken."""
    def cut(text, limit):
        return text.encode("utf-8")[:limit].decode("utf-8", errors="ignore")

    name = cut(raw, _MAX_NAME_BYTES)
    n = 0
    while name in taken:
        n += 1
        suffix = f".{n:03d}"
        name = cut(raw, _MAX_NAME_BYTES - len(suffix)) + suffix
    taken.add(name)
    return name


def _hierarchy(lines, path):
    """(joints, index of the MOTION line) from the HIERARCHY section (the importer's reading of it)."""
    joints, stack, taken = [], [], set()
    columns = 0
    for no, raw in enumerate(lines):
        tokens = raw.split()
        if not tokens:
            continue
        key = tokens[0].lower()
        if key in ("root", "joint"):
            if len(tokens) < 2:
                raise ParseError(f"{tokens[0]} without a name", path, no + 1)
            parent = next((p for p in reversed(stack) if p is not None), -1) if key == "joint" else -1
            joints.append(BvhJoint(_bone_name("_".join(tokens[1:]), taken), parent))
            stack.append(len(joints) - 1)
        elif key == "end":
            stack.append(None)
        elif key == "}":
            if not stack:
                raise ParseError("unbalanced '}'", path, no + 1)
            stack.pop()
        elif key == "offset":
            if len(tokens) != 4:
                raise ParseError("OFFSET needs 3 numbers", path, no + 1)
            if joints and stack:  # after "End Site {" the top of the stack is None: the last joint's end
                try:
                    xyz = tuple(float(v) for v in tokens[1:])
                except ValueError:
                    raise ParseError("OFFSET needs 3 numbers", path, no + 1) from None
                if stack[-1] is None:
                    joints[next(p for p in reversed(stack) if p is not None)].end = xyz
                else:
                    joints[stack[-1]].offset = xyz
        elif key == "channels":
            if not joints:
                raise ParseError("CHANNELS before any joint", path, no + 1)
            joint = joints[-1]
            joint.channels = [c.lower() for c in tokens[2:]]
            joint.first = columns
            columns += len(joint.channels)
            rot = [c for c in joint.channels if c.endswith("rotation")]
            if rot and sorted(rot) != ["xrotation", "yrotation", "zrotation"]:
                raise ParseError(f"joint {joint.name!r}: rotation channels {' '.join(rot)} (need X, Y and Z once each)",
                                 path, no + 1)
        elif key == "motion":
            if stack:
                raise ParseError("unbalanced braces in HIERARCHY", path, no + 1)
            return joints, no, columns
    raise ParseError("no MOTION section (truncated BVH?)", path)


def _motion(lines, start, columns, path):
    """(frame time, values (frames, columns)) of the MOTION section; every data line is a frame (as the importer
    reads it). Numbers are converted at once; on any problem ``check_bvh`` names the line."""
    body = [ln for ln in lines[start + 1:] if ln.strip()]
    if len(body) < 3:
        raise ParseError("MOTION section without frames", path)
    frames = _header_value(body[0], "Frames", int, "N", path, start + 2)
    frame_time = _header_value(body[1], "Frame Time", float, "seconds", path, start + 3)
    rows = body[2:]
    check_frames(max(frames, len(rows)), path)
    if len(rows) < max(frames, 1):
        raise ParseError(f"{len(rows)} frames of motion data for 'Frames: {frames}' (truncated file?)", path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # numpy 1.26: a bad token ends the C parser early (a warning) ...
        try:
            values = np.fromstring(" ".join(rows), dtype=np.float64, sep=" ")
        except ValueError:  # ... numpy 2 raises instead; either way the size check below names the problem
            values = np.zeros(0)
    if (values.size != len(rows) * columns or not np.all(np.abs(values) < _FLOAT32_MAX)
            or any(len(r.split()) != columns for r in rows)):
        raise ParseError(f"every frame needs {columns} finite numbers", path)
    if not frame_time > 0 or frame_time == float("inf"):
        raise ParseError("'Frame Time' must be a positive number", path)
    return frame_time, values.reshape(len(rows), columns)


def parse_bvh(path):
    """(joints, frame time, values (frames, channels)) of a BVH file, in file order."""
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise ParseError("no such file", path)
    try:
        lines = _bvh_lines(path)
        first = next((ln.split()[0] for ln in lines if ln.strip()), "")
        if first.upper() != "HIERARCHY":
            raise ParseError("expected HIERARCHY (is this a BVH file?)" if first else "empty BVH file", path)
        joints, motion_line, columns = _hierarchy(lines, path)
        if not joints:
            raise ParseError("no joints (is this a BVH file?)", path)
        frame_time, values = _motion(lines, motion_line, columns, path)
    except ParseError:
        check_bvh(path)  # the validator's message, naming the line, when it finds the problem
        raise
    return joints, frame_time, values


def load_bvh(path, name: Optional[str] = None):
    """A BVH take as a Clip in Blender's armature space (``A E A^T`` per joint and frame, the root's position
    ``A p``; see the module docstring): the clip ``readers.bvh.import_bvh`` gives, without Blender."""
    from ..clip.clip import Clip
    from ..geometry.so3 import matrix_from_euler

    path = os.fspath(path)
    joints, frame_time, values = parse_bvh(path)
    frames = values.shape[0]
    R = np.empty((frames, len(joints), 3, 3))
    R[:] = np.eye(3)
    modes, missing, groups = [], [], {}
    for j, joint in enumerate(joints):
        rot = joint.columns("rotation")
        order = "".join(rot).upper()  # channel order: E = R_c1 R_c2 R_c3
        modes.append(order or "XYZ")
        if not rot:
            missing.append(joint.name)
            continue
        group = groups.setdefault(order, ([], []))
        group[0].append(j)
        group[1].extend(rot[c] for c in reversed(list(rot)))  # Blender's Euler mode: the last channel first
    for order, (idx, cols) in groups.items():  # one Euler conversion per channel order
        angles = np.radians(values[:, cols]).reshape(frames, len(idx), 3)
        E = matrix_from_euler(angles, order[::-1])
        R[:, idx] = E[..., _PERM, :][..., _PERM] * _SIGNS  # A E A^T: A is a signed permutation
    root_translation, carrier = _root_motion(joints, values, R)
    fps = 1.0 / frame_time
    if abs(fps - round(fps)) < 1e-3:
        fps = float(round(fps))  # "Frame Time: 0.00833333" means 120 fps
    clip = Clip(name=name or os.path.splitext(os.path.basename(path))[0], bones=tuple(j.name for j in joints),
                rotations=R, fps=fps, frame_start=1, root_translation=root_translation, root_bone=joints[0].name,
                rotation_modes=tuple(modes), source=path,
                meta={"missing_rotation_bones": tuple(missing), "rotation_space": "armature", "up_axis": "Z",
                      "format": "bvh", **({"root_motion_bone": carrier} if carrier else {}),
                      # the hierarchy (core.rigs composes world rotations down it for the comparison space)
                      "parents": {j.name: (joints[j.parent].name if j.parent >= 0 else None) for j in joints},
                      **_rest_skeleton(joints)})
    return clip


def _positions(joint, values):
    """(frames, 3) a joint's position channels (BVH axes; a missing axis reads 0, as in Blender's importer), or
    None without any."""
    pos = joint.columns("position")
    if not pos:
        return None
    p = np.zeros((values.shape[0], 3))
    for axis, col in pos.items():
        p[:, "xyz".index(axis)] = values[:, col]
    return p


def _root_motion(joints, values, R):
    """(root translation, carrier name or None): the ROOT's path in armature axes, with the position channels of
    the joints below it folded in as Blender's importer plays them (``skeleton.fold_root_motion``: its channels
    replace a joint's OFFSET, so its head moves by A (channels - OFFSET) in its parent's frame). Position channels
    below the carrier or off its chain (bone stretches) are left out; these exporters write them equal to the
    OFFSETs."""
    from ..clip.skeleton import fold_root_motion

    A = BVH_TO_BLENDER
    locs = [_positions(j, values) for j in joints]
    moves = {j: (loc - np.asarray(joints[j].offset)) @ A.T for j, loc in enumerate(locs) if loc is not None and j}
    root = locs[0] if locs[0] is not None else np.tile(joints[0].offset, (values.shape[0], 1))
    if locs[0] is not None:
        moves[0] = locs[0] @ A.T  # the ROOT's own path takes part in the carrier's choice (the largest, it stays)
    path, carrier = fold_root_motion([j.parent for j in joints], R, root @ A.T, moves)
    if carrier in (None, 0):
        return (None if locs[0] is None else locs[0] @ A.T), None
    return path, joints[carrier].name


def _rest_skeleton(joints):
    """The rest skeleton Blender's importer builds (``core.clip.skeleton.rest_meta``, armature axes, file units): heads
    are OFFSET sums; a tail is the End Site, else the one child's head, else the mean of the children's heads."""
    from ..clip.skeleton import rest_meta

    heads = np.zeros((len(joints), 3))
    for j, joint in enumerate(joints):
        heads[j] = np.asarray(joint.offset) + (heads[joint.parent] if joint.parent >= 0 else 0.0)
    tails = heads.copy()
    for j, joint in enumerate(joints):
        kids = [k for k, other in enumerate(joints) if other.parent == j]
        if joint.end is not None:
            tails[j] = heads[j] + np.asarray(joint.end)
        elif kids:
            tails[j] = heads[kids].mean(axis=0)
    return rest_meta([j.name for j in joints], heads @ BVH_TO_BLENDER.T, tails @ BVH_TO_BLENDER.T)
