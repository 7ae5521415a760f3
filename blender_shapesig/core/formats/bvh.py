"""BVH files without bpy: the text Blender's importer can read and the checks it lacks.

Blender's BVH importer (``io_anim_bvh``) reads plain UTF-8 only and fails with a traceback on a malformed
file; ``check_bvh`` validates the structure (HIERARCHY, balanced braces, CHANNELS counts, MOTION header,
one number per channel in every frame) and every number (finite, within float32: Blender keys 32-bit
floats) first, naming the line, so the importer only ever sees a file it reads. The Blender half is
``blender_shapesig.readers.bvh``.
"""

from ..errors import ParseError
from .text import decode_text, finite_float

__all__ = ["bvh_text", "check_bvh"]

def bvh_text(path):
    """(text, plain): the file's text (UTF-8; UTF-16/32 or UTF-8 with a byte-order mark; else latin-1) and
    whether it is plain UTF-8 without a BOM, the only encoding Blender's importer reads."""
    try:
        with open(path, "rb") as fh:
            data = fh.read()
    except OSError as exc:
        raise ParseError(f"cannot read BVH file: {exc.strerror or exc}", path) from None
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
    lines = bvh_text(path)[0].splitlines()
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


def _header_value(line, label, convert, what, path, no):
    """``convert`` of the value of a MOTION header line ``label: value`` (case and spacing free)."""
    line = " ".join(line.split())
    try:
        if not line.lower().startswith(label.lower()):
            raise ValueError
        return convert(line.split(":", 1)[1])
    except (IndexError, ValueError):
        raise ParseError(f"expected '{label}: {what}'", path, no) from None
