"""Write a Clip as a BVH file on its own skeleton (``write_bvh``): the hierarchy from the clip's rest skeleton
(``meta`` ``parents`` and ``rest_heads``/``rest_tails``, as the readers store it), each joint's rotation relative to
its rest in world-aligned axes as Euler channels in its rotation mode (BVH axes: ``A^T X A``, the inverse of
``bvh.load_bvh``), the root's head as position channels. What ``bvh.load_bvh`` and Blender's BVH importer read back
is the clip (``docs/transitions.md``, "BVH out"). A file that exists is never replaced.
"""

import os

import numpy as np

from ..clip.skeleton import aligned_rotations, rest_of, root_heads
from ..errors import ShapeSigError
from ..geometry.so3 import EULER_MODES, euler_from_matrix
from .bvh import BVH_TO_BLENDER

__all__ = ["write_bvh", "bvh_lines", "DEFAULT_ORDER"]

DEFAULT_ORDER = "ZXY"  # the channel order of joints whose rotation mode is not an Euler order


def _name(bone):
    """A joint name BVH can hold: whitespace becomes '_' (a BVH name is one word)."""
    return "_".join(str(bone).split()) or "joint"


def _children(rest):
    kids = {i: [] for i in range(len(rest.bones))}
    for i, a in enumerate(rest.ancestor):
        if a >= 0:
            kids[int(a)].append(i)
    return kids


def _order(clip, k):
    mode = clip.rotation_modes[k] if k < len(clip.rotation_modes) else ""
    return mode if mode in EULER_MODES else DEFAULT_ORDER


def _hierarchy(clip, rest, root):
    """(lines, joint indices in file order, channel orders)."""
    A = BVH_TO_BLENDER
    kids = _children(rest)
    lines, order, modes = ["HIERARCHY"], [], []

    def fmt(v):
        return " ".join(f"{x:.6f}" for x in (np.asarray(v, dtype=np.float64) @ A))  # Blender -> BVH axes: A^T v

    def walk(j, depth):
        pad = "\t" * depth
        parent = rest.ancestor[j]
        offset = rest.heads[j] - (rest.heads[parent] if parent >= 0 else 0.0)
        mode = _order(clip, j)
        lines.append(f"{pad}{'ROOT' if parent < 0 else 'JOINT'} {_name(clip.bones[j])}")
        lines.append(f"{pad}{{")
        lines.append(f"{pad}\tOFFSET {fmt(offset)}")
        rot = " ".join(f"{c}rotation" for c in mode)
        lines.append(f"{pad}\tCHANNELS 6 Xposition Yposition Zposition {rot}" if parent < 0 else
                     f"{pad}\tCHANNELS 3 {rot}")
        order.append(j)
        modes.append(mode)
        if kids[j]:
            for c in kids[j]:
                walk(c, depth + 1)
        else:
            end = rest.tails[j] - rest.heads[j]
            if np.linalg.norm(end) < 1e-9:
                end = offset if np.linalg.norm(offset) > 1e-9 else np.array([0.0, 0.0, 1.0])
            lines.append(f"{pad}\tEnd Site")
            lines.append(f"{pad}\t{{")
            lines.append(f"{pad}\t\tOFFSET {fmt(end)}")
            lines.append(f"{pad}\t}}")
        lines.append(f"{pad}}}")

    walk(root, 0)
    return lines, order, modes


def bvh_lines(clip):
    """The lines of the BVH text of ``clip`` (module docstring). ShapeSigError for a clip without a rest skeleton
    or with several root bones."""
    rest = rest_of(clip)
    tops = [int(i) for i in np.flatnonzero(rest.ancestor < 0)]
    if len(tops) != 1:
        raise ShapeSigError(f"clip {clip.name!r} has {len(tops)} root bones; a BVH file holds one skeleton")
    names = [_name(b) for b in clip.bones]
    if len(set(names)) != len(names):
        raise ShapeSigError(f"clip {clip.name!r}: bone names that differ only in spaces cannot be told apart in BVH")
    lines, order, modes = _hierarchy(clip, rest, tops[0])
    A = BVH_TO_BLENDER
    X = aligned_rotations(clip)
    E = A.T[None, None] @ X[:, order] @ A[None, None]
    cols = []
    heads = root_heads(clip, rest)
    if heads is None:
        heads = np.tile(rest.heads[tops[0]], (clip.frames, 1))
    cols.append(heads @ A)
    for k, mode in enumerate(modes):
        ang = np.degrees(euler_from_matrix(E[:, k], mode[::-1]))  # Blender's mode: the last channel first
        cols.append(ang[:, ::-1])
    values = np.concatenate(cols, axis=1)
    if not np.all(np.isfinite(values)):
        raise ShapeSigError(f"clip {clip.name!r} holds non-finite values")
    fps = float(clip.fps)
    lines += ["MOTION", f"Frames: {clip.frames}", f"Frame Time: {1.0 / fps:.10g}"]
    lines += [" ".join(f"{v:.6f}" for v in row) for row in values]
    return lines


def write_bvh(clip, path):
    """Write ``clip`` as the BVH file ``path`` (module docstring); returns the path. ShapeSigError when the file
    exists (never replaced) or the clip cannot be written; OSError when the folder cannot be written."""
    path = os.fspath(path)
    text = "\n".join(bvh_lines(clip)) + "\n"
    try:
        with open(path, "x", encoding="utf-8", newline="\n") as f:
            f.write(text)
    except FileExistsError:
        raise ShapeSigError(f"{path} exists: not replaced (choose another name)") from None
    return path
