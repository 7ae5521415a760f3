"""Acclaim AMC motions (the CMU database format), without bpy.

Header lines (``#`` comments, ``:FULLY-SPECIFIED``, ``:DEGREES`` or ``:RADIANS``), then frames: a frame number
alone on a line followed by one ``bone value...`` line per animated bone, values in the bone's ``dof`` order
(the root's in its ``order``). Conventions (M, L = C M C^-1, G): ``formats.acclaim``.
"""

import re
from dataclasses import dataclass
from typing import Dict, List, Optional

import numpy as np

from ..errors import ParseError
from ..geometry.so3 import matrix_from_euler
from .asf import Skeleton
from .files import MAX_FRAMES_ENV, check_frames, max_frames
from .text import finite_float, read_text

_FRAME_NUMBER = re.compile(r"[+-]?\d+")  # a frame-number line: digits with one optional sign
_HEADER_LINES = 10_000  # comments and header lines an AMC may have besides its frames

__all__ = ["Motion", "parse_amc", "forward_kinematics"]


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
                out[:, j] = matrix_from_euler(ordered, seq)
                continue
            rdofs = bone.rotation_dofs
            if not rdofs or vals is None:
                continue
            cols = [bone.dof.index(d) for d in rdofs]
            out[:, j] = matrix_from_euler(vals[:, cols], "".join(d[1].upper() for d in rdofs))
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

def parse_amc(path_or_text, skeleton: Skeleton) -> Motion:
    """Parse an AMC motion for ``skeleton``. Every frame must give every bone that has dofs, with one
    value per dof. Angles are returned in radians."""
    text, path = read_text(path_or_text, "AMC")
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

    limit = max_frames()
    _check_line_count(text, (len(animated) + 1) * limit, where)
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
        if len(tokens) == 1 and _FRAME_NUMBER.fullmatch(tokens[0]):  # one optional sign ("--1" is not one)
            number = int(tokens[0])
            if current is not None:
                close_frame()
            if frame_numbers and number != frame_numbers[-1] + 1:
                raise ParseError(f"frame number {number} follows {frame_numbers[-1]} (frames must be "
                                 f"consecutive)", where, no)
            frame_numbers.append(number)
            if len(frame_numbers) > limit:
                check_frames(len(frame_numbers), where, no, more=True)
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

def _check_line_count(text, frame_lines, where):
    """The frame cap before an AMC's text is split into lines: a frame takes a line per animated bone and one for
    its number, so more lines than ``frame_lines`` (and a header) means more frames than the cap."""
    lines = text.count("\n") or text.count("\r")
    if lines > frame_lines + _HEADER_LINES:
        raise ParseError(f"{lines:,} lines, more than the frame limit allows ({max_frames():,} frames; "
                         f"${MAX_FRAMES_ENV} raises it)", where)


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
            finite_float(t, where, no, f"bone {name!r}")
    raise ParseError(f"bone {name!r}: bad values", where)  # not reached
