"""The index entry of one clip (``IndexEntry``, ``make_entry``): its moving joints, the unit log-signature direction
on them, |a|, the increments and the count sketch; and distances between entries (``entry_distance``, exact by
word codes) and the increments of two entries on their shared bones (``pair_increments``).
See docs/search.md, "The index and its cache".
"""

from dataclasses import dataclass
from typing import Optional, Sequence, Tuple

import numpy as np

from ...signatures import signatures
from ...geometry import so3
from ...clip.clip import Clip, still_joints
from ...geometry.curves import relative_rotvecs
from ...errors import ShapeSigError
from ...metric_names import DEFAULT_LEVEL, time_base_smoothing
from ...clip.prepare import COMPARE_FPS, prepare_clip, smooth_increments
from ...clip.trim import trim_record
from .words import word_codes, sketch

__all__ = ["IndexEntry", "make_entry", "entry_distance", "pair_increments", "sim_from_increments",
           "curve_from_increments"]


@dataclass
class IndexEntry:
    """The index record of one clip (see the module docstring). ``direction``/``increments`` are the *heavy*
    arrays: a store may leave them unloaded (None) until ``SignatureCache.heavy`` reads them."""

    name: str
    bones: Tuple[str, ...]
    moving: Tuple[int, ...]
    frames: int
    level: int
    norm: float
    direction: Optional[np.ndarray]   # float32 unit vector, or zeros when norm == 0
    increments: Optional[np.ndarray]  # float32 (frames-1, len(moving), 3)
    sketch: np.ndarray                # float32 (SKETCH_DIM,)
    fps: float = 0.0
    source: str = ""
    key: str = ""
    exact: bool = True                # False: the direction is not stored (compact index), sketch only
    # (first kept, last kept, first read, last read) when trimming cut frames (core.clip.trim: meta["trim"]), else ()
    trimmed: Tuple[int, ...] = ()
    # frames of the clip as read (its own rate, what results show); ``frames`` counts the prepared curve's samples
    clip_frames: int = 0
    # the canonical joints the clip's rig has (``rigs.apply_bone_map``: meta["rig_joints"]); () for a clip read by name
    rig_joints: Tuple[str, ...] = ()

    @property
    def nbytes(self):
        return sum(a.nbytes for a in (self.direction, self.increments, self.sketch) if a is not None)

    @property
    def heavy_nbytes(self):
        """Bytes of the arrays a store may drop from memory (direction and increments)."""
        return self.nbytes - self.sketch.nbytes

    @property
    def still(self) -> Tuple[str, ...]:
        """The bones that do not move (those not in ``moving``)."""
        moving = set(self.moving)
        return tuple(b for j, b in enumerate(self.bones) if j not in moving)

    @property
    def loaded(self):
        """True when the arrays the distances need are in memory (no direction is needed when not exact)."""
        return self.increments is not None and (self.direction is not None or not self.exact)


def increments_log_signature(inc, level):
    """Log-signature at ``level`` of the path in R^(3 joints) whose steps are the rotation-vector increments
    ``inc`` (steps, joints, 3) (the development of the curve, started at 0)."""
    dx = np.asarray(inc, np.float64).reshape(inc.shape[0], -1)
    return signatures.increments_log_signature(dx, level)


def make_entry(clip: Clip, level=DEFAULT_LEVEL, key="") -> IndexEntry:
    """Compute the index entry of a clip at ``level``, on the comparison time base.

    The clip is first prepared exactly as ``metrics.clip_distance`` prepares it for sim (``prepare.prepare_clip``
    with ``metrics.time_base_smoothing("sim")``: resampled to ``prepare.COMPARE_FPS``, no low-pass), so that the
    index signs the curve the distance compares: a ranked sim equals ``clip_distance(query, clip, "sim")``.
    ``frames``/``fps`` of the entry are those of the prepared curve (its increments)."""
    level = int(level)
    trimmed, clip_frames = trim_record(clip), int(clip.frames)  # in the clip's own frame numbers
    clip = prepare_clip(clip, smooth=time_base_smoothing("sim"))
    R = clip.rotations
    if R.shape[0] < 2:
        raise ShapeSigError(f"clip {clip.name!r} has {R.shape[0]} frame(s); at least two are needed")
    moving = tuple(int(j) for j in np.flatnonzero(~still_joints(R)))
    inc = relative_rotvecs(R[:, list(moving)]) if moving else np.zeros((R.shape[0] - 1, 0, 3))
    a = increments_log_signature(inc, level) if moving else np.zeros(0)
    norm = float(np.linalg.norm(a))
    if norm <= signatures.ZERO_NORM:
        direction, norm = np.zeros_like(a), 0.0
    else:
        direction = a / norm
    direction = direction.astype(np.float32)
    return IndexEntry(name=clip.name, bones=tuple(clip.bones), moving=moving, frames=int(R.shape[0]),
                      level=level, norm=norm, direction=direction, increments=inc.astype(np.float32),
                      sketch=sketch(direction, len(clip.bones), moving, level), fps=float(clip.fps),
                      source=clip.source, key=key, trimmed=trimmed, clip_frames=clip_frames,
                      rig_joints=tuple(clip.meta.get("rig_joints") or ()))


def entry_distance(a: IndexEntry, b: IndexEntry) -> float:
    """Exact sim between two entries of the same skeleton (same bone tuple), from their directions."""
    if a.bones != b.bones:
        raise ShapeSigError(f"entries {a.name!r} and {b.name!r} have different skeletons")
    za, zb = a.norm == 0.0, b.norm == 0.0
    if za or zb:
        return 0.0 if (za and zb) else 1.0
    u, v = a.direction, b.direction
    if a.moving == b.moving:
        return float(np.linalg.norm(u - v))  # no cancellation for near-duplicates
    ca = word_codes(len(a.bones), a.moving, a.level)
    cb = word_codes(len(b.bones), b.moving, b.level)
    _, ia, ib = np.intersect1d(ca, cb, assume_unique=True, return_indices=True)
    u64, v64 = u.astype(np.float64), v.astype(np.float64)
    common = u64[ia] - v64[ib]
    only = (u64 @ u64 - u64[ia] @ u64[ia]) + (v64 @ v64 - v64[ib] @ v64[ib])
    return float(np.sqrt(max(common @ common + only, 0.0)))


def sketch_distance(a: IndexEntry, b: IndexEntry) -> float:
    """The count-sketch estimate of sim (compact index): 1 when exactly one of the two clips is still."""
    if (a.norm == 0.0) != (b.norm == 0.0):
        return 1.0
    return float(np.linalg.norm(a.sketch - b.sketch))


def curve_from_increments(inc, base=None):
    """A curve (frames, joints, 3, 3) starting at the identity with the given increments (``so3.integrate``).

    ``base``: a metric base name (``metrics.parse_metric``): the increments, on the comparison time base already,
    are first low-passed as that metric's time base does (``metrics.time_base_smoothing``, at COMPARE_FPS), so the
    curve is the one ``metrics.clip_distance`` compares for a clip recorded at COMPARE_FPS (at other rates the
    clip was resampled before this low-pass, where clip_distance low-passes first: close, not equal)."""
    inc = np.asarray(inc, dtype=np.float64)
    if base is not None and time_base_smoothing(base) > 0:
        inc = smooth_increments(inc, COMPARE_FPS, time_base_smoothing(base))
    return so3.integrate(inc)


def increments_on(entry: IndexEntry, bones: Sequence[str]):
    """The entry's increments (frames-1, len(bones), 3) on the given bones (zero for still ones)."""
    pos = {entry.bones[j]: i for i, j in enumerate(entry.moving)}
    out = np.zeros((entry.frames - 1, len(bones), 3))
    for k, b in enumerate(bones):
        i = pos.get(b)
        if i is not None:
            out[:, k] = entry.increments[:, i]
    return out


def pair_increments(q: IndexEntry, e: IndexEntry, bones):
    """Both entries' increments on ``bones``; bones still in both dropped (as clip_distance does)."""
    a, b = increments_on(q, bones), increments_on(e, bones)
    keep = (np.abs(a).max(axis=(0, 2), initial=0.0) > 0) | (np.abs(b).max(axis=(0, 2), initial=0.0) > 0)
    if keep.any():
        a, b = a[:, keep], b[:, keep]
    return a, b


def sim_from_increments(a, b, level):
    """sim^level between two curves given by their increments on the same joints."""
    return signatures.normalized_difference(increments_log_signature(a, level), increments_log_signature(b, level))
