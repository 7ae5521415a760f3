"""BVH files in the Unity / MotionBuilder layout, built from a file with the walk on its ROOT: a static reference
ROOT above the old root (which keeps its six channels and carries the walk) and six channels on every joint (the
position channels of the other joints equal their OFFSETs, as these exporters write them). ``turn`` turns the old
root's horizontal path about the vertical (BVH Y) around its first frame, the body's facing unchanged: a forward walk
becomes a walk to the side (``turn=90``: to the body's left for these CMU files) with the same limbs.
(``tests/blender/readers/test_bvh_reference_root.py``, ``tests/core/io/test_bvh_root_motion.py``.)"""

import numpy as np

__all__ = ["reference_root_layout", "turned_walk"]


def _split(text):
    lines = text.splitlines()
    motion = next(i for i, ln in enumerate(lines) if ln.strip().upper() == "MOTION")
    rows = [ln for ln in lines[motion + 1:] if ln.strip()]
    return lines[:motion], rows[1], np.array([[float(v) for v in r.split()] for r in rows[2:]])


def _turn_path(values, turn, cols=(0, 2)):
    a = np.radians(turn)
    c, s = np.cos(a), np.sin(a)
    x, z = values[:, cols[0]] - values[0, cols[0]], values[:, cols[1]] - values[0, cols[1]]
    out = values.copy()
    out[:, cols[0]] = values[0, cols[0]] + c * x + s * z  # a turn about +Y: x' = c x + s z, z' = -s x + c z
    out[:, cols[1]] = values[0, cols[1]] - s * x + c * z
    return out


def turned_walk(text, turn):
    """The file (ROOT with X/Y/Z position channels first) with its root's horizontal path turned by ``turn``
    degrees about Y."""
    head, frame_time, values = _split(text)
    body = "\n".join(" ".join(f"{v:.6f}" for v in row) for row in _turn_path(values, turn))
    return "\n".join(head) + f"\nMOTION\nFrames: {len(values)}\n{frame_time}\n{body}\n"


def reference_root_layout(text, turn=0.0, reference=(0.0, 0.0, 0.0, 0.0, 0.0, 0.0), name="Reference"):
    """The Unity-style file of a BVH ``text`` whose ROOT has six channels (positions first) and every other joint
    three rotation channels. ``reference``: the static ROOT's six values (X/Y/Z position, Z/X/Y rotation in
    degrees), the same in every frame."""
    head, frame_time, values = _split(text)
    out, offsets, offset = [], [], None
    for ln in head:
        tokens = ln.split()
        key = tokens[0].upper() if tokens else ""
        indent = ln[:len(ln) - len(ln.lstrip())]
        if key == "ROOT":
            out += ["ROOT " + name, "{", "  OFFSET 0 0 0",
                    "  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation",
                    "  JOINT " + " ".join(tokens[1:])]
            continue
        if key == "OFFSET":
            offset = [float(v) for v in tokens[1:]]
        if key == "CHANNELS" and tokens[1] == "3":
            offsets.append(offset)
            ln = indent + "CHANNELS 6 Xposition Yposition Zposition " + " ".join(tokens[2:])
        out.append("  " + ln if key != "HIERARCHY" else ln)
    out.append("}")
    values = _turn_path(values, turn)
    rows = []
    for row in values:
        cols = [np.asarray(reference, float), row[:6]]
        for j, off in enumerate(offsets):
            cols += [np.asarray(off, float), row[6 + 3 * j:9 + 3 * j]]
        rows.append(" ".join(f"{v:.6f}" for v in np.concatenate(cols)))
    return "\n".join(out) + f"\nMOTION\nFrames: {len(values)}\n{frame_time}\n" + "\n".join(rows) + "\n"
