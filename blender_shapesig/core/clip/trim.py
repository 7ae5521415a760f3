"""Rest-pose and ramp frames at the ends of a clip (converted motion capture that starts in the rest pose or a
T-pose): ``detect_trim`` finds them from robust per-frame ratios over joints (a step against each joint's median
step, an angle from rest against its median angle) and the trimming drops them. See docs/model.md, "Time base",
and docs/evaluation.md, "The rest-pose ramp of the BVH files".
"""

from dataclasses import dataclass, replace

import numpy as np

from ..geometry import so3
from ..geometry.so3 import relative_rotvecs

__all__ = ["TRIM_MODES", "START_RATIO", "REST_RATIO", "LEAVE_RATIO", "KEEP_RATIO", "MAX_SECONDS", "Trim", "step_ratios", "rest_ratios", "detect_trim",
           "trim_clip", "trim_record", "trimmed_range", "trim_note"]

TRIM_MODES = ("auto", "none")
START_RATIO = 4.0
REST_RATIO = 0.25
LEAVE_RATIO = 0.9
KEEP_RATIO = 1.5
MAX_SECONDS = 0.1


@dataclass(frozen=True)
class Trim:
    """Frames to drop: ``head`` at the start, ``tail`` at the end (counts of frames)."""

    head: int = 0
    tail: int = 0

    def __bool__(self):
        return bool(self.head or self.tail)


def step_ratios(R):
    """r_k: the median over moving joints of each joint's step angle divided by that joint's median step
    (1 for a typical frame; joints whose median step is below 1e-9 rad are left out)."""
    a = np.linalg.norm(relative_rotvecs(np.asarray(R, dtype=np.float64)), axis=-1)
    if a.shape[0] == 0:
        return np.zeros(0)
    return _median_ratios(a, 1e-9, 0.0)


def rest_ratios(R):
    """Per frame: the median over moving joints of each joint's angle from the rest orientation (the identity)
    divided by that joint's median angle over the clip (about 1 for a typical frame, near 0 at the rest pose)."""
    return _median_ratios(so3.angle(np.asarray(R, dtype=np.float64)), 1e-6, 1.0)


def _median_ratios(a, moving_above, still_value):
    """Per frame of ``a`` (frames, joints): the median over the joints whose median exceeds ``moving_above`` of
    each one's value divided by its median; ``still_value`` for every frame when no joint moves."""
    med = np.median(a, axis=0)
    moving = med > moving_above
    if not moving.any():
        return np.full(a.shape[0], float(still_value))
    return np.median(a[:, moving] / med[moving], axis=1)


def _leading(mask, limit):
    """How many leading entries of ``mask`` are true (at most ``limit``)."""
    n = 0
    while n < min(limit, mask.size) and mask[n]:
        n += 1
    return n


def _head(r, rest, window):
    """Frames of the rest pose / ramp at the start: none unless the first step is above START_RATIO or the
    first frame is a rest pose; then the longer of the first run of steps above KEEP_RATIO and (from a rest
    pose) the frames still on the way out of it (rest ratio below LEAVE_RATIO), within the window."""
    at_rest = _leading(rest < REST_RATIO, window)
    if r.size == 0 or not (r[0] > START_RATIO or at_rest):
        return 0
    leaving = _leading(rest < LEAVE_RATIO, window) if at_rest else 0
    return max(leaving, _leading(r > KEEP_RATIO, window))


def detect_trim(R, fps) -> Trim:
    """The rest-pose / ramp frames at both ends of the curve R sampled at ``fps`` (see the module docstring)."""
    r = step_ratios(R)
    if r.size < 8:
        return Trim()
    rest = rest_ratios(R)
    window = max(1, min(int(round(MAX_SECONDS * float(fps))), r.size // 4))
    return Trim(head=_head(r, rest, window), tail=_head(r[::-1], rest[::-1], window))


def trim_clip(clip):
    """The clip without its detected rest-pose / ramp frames; ``meta["trim"]`` records the frames kept
    ``(first, last)`` (scene frame numbers, inclusive) and the frames read ``(first, last)``."""
    cut = detect_trim(clip.rotations, clip.fps)
    read = (clip.frame_start, clip.frame_end)
    out = clip.crop(clip.frame_start + cut.head, clip.frame_end - cut.tail) if cut else clip
    return replace(out, meta=dict(out.meta, trim={"kept": (out.frame_start, out.frame_end), "read": read}))


def trim_record(clip):
    """(first kept, last kept, first read, last read) when the automatic trimming (``trim_clip``) cut frames
    from ``clip``, else (): scene frame numbers, inclusive. An end the clip no longer starts (ends) at, because an
    explicit ``start`` / ``end`` cropped it there, counts no trimmed frame. Index entries keep this record
    (``IndexEntry.trimmed``), so results name their trimmed range without reading the clip again."""
    record = clip.meta.get("trim") if clip.meta else None
    if not record:
        return ()
    (kept0, kept1), (read0, read1) = record["kept"], record["read"]
    first, last = int(clip.frame_start), int(clip.frame_end)
    head = kept0 - read0 if first == kept0 else 0
    tail = read1 - kept1 if last == kept1 else 0
    return (first, last, first - head, last + tail) if head or tail else ()


def trimmed_range(record, frames=None):
    """``{"frames": [first, last] | None, "cut": [head, tail]}`` (the JSON of results and reports) from a
    ``trim_record`` (or a clip): the frames compared and how many frames the trimming cut at each end; nothing
    cut: ``frames`` is the clip's own range (``None`` when only a record was given), ``cut`` [0, 0]."""
    if hasattr(record, "rotations"):
        record, frames = trim_record(record), [int(record.frame_start), int(record.frame_end)]
    if not record:
        return {"frames": frames, "cut": [0, 0]}
    k0, k1, r0, r1 = record
    return {"frames": [k0, k1], "cut": [k0 - r0, r1 - k1]}


def trim_note(name, record=None):
    """One line saying what the automatic trimming cut ("" when it cut nothing), for reports, from a clip or a
    (name, ``trim_record``): "07_01: trimmed 5 at the start (rest pose / ramp); frames 6..317 compared"."""
    if hasattr(name, "rotations"):
        name, record = name.name, trim_record(name)
    if not record:
        return ""
    got = trimmed_range(record)
    ends = [f"{n} at the {where}" for n, where in zip(got["cut"], ("start", "end")) if n]
    first, last = got["frames"]
    return f"{name}: trimmed {' and '.join(ends)} (rest pose / ramp); frames {first}..{last} compared"
