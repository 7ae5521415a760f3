"""A motion clip: a named SO(3)^d curve with its bone names, timing and root translation.

This is the common currency between readers (Blender actions, ASF/AMC, BVH), the maths in core and
the writers. It holds no Blender objects, so it works with or without bpy.
"""

from dataclasses import dataclass, field, replace
from typing import Optional, Sequence, Tuple

import numpy as np

from ..geometry.curves import as_curve
from ..errors import CurveError, check_frame_range
from ..geometry.so3 import STILL_TOLERANCE, still_joints  # the one stillness rule (re-exported: callers import it here)

__all__ = ["Clip", "shared_bones", "still_joints", "restrict_to_shared", "STILL_TOLERANCE"]


@dataclass
class Clip:
    """One motion clip.

    ``rotations``: (frames, joints, 3, 3), each bone's local rotation (relative to its rest pose).
    ``root_translation``: (frames, 3) location of the root bone in its parent space, or None.
    ``frame_start``: the scene frame of the first sample; ``fps``: samples per second.
    ``rotation_modes``: per bone, Blender's rotation mode names (e.g. 'QUATERNION', 'ZXY'), when known.
    """

    name: str
    bones: Tuple[str, ...]
    rotations: np.ndarray
    fps: float = 120.0
    frame_start: int = 1
    root_translation: Optional[np.ndarray] = None
    root_bone: Optional[str] = None
    rotation_modes: Tuple[str, ...] = ()
    source: str = ""
    meta: dict = field(default_factory=dict)

    def __post_init__(self):
        self.bones = tuple(self.bones)
        self.rotations = as_curve(self.rotations, name=f"clip {self.name!r}")
        if len(self.bones) != self.rotations.shape[1]:
            raise CurveError(
                f"clip {self.name!r}: {len(self.bones)} bone names for {self.rotations.shape[1]} joints"
            )
        if len(set(self.bones)) != len(self.bones):
            raise CurveError(f"clip {self.name!r}: repeated bone names")
        if self.root_translation is not None:
            rt = np.asarray(self.root_translation, dtype=np.float64)
            if rt.shape != (self.frames, 3):
                raise CurveError(
                    f"clip {self.name!r}: root translation has shape {rt.shape}, expected ({self.frames}, 3)"
                )
            if not np.all(np.isfinite(rt)):
                raise CurveError(f"clip {self.name!r}: root translation contains NaN or infinite values")
            self.root_translation = rt
        self.rotation_modes = tuple(self.rotation_modes)

    @property
    def frames(self) -> int:
        return self.rotations.shape[0]

    @property
    def frame_end(self) -> int:
        return self.frame_start + self.frames - 1

    def select(self, bones: Sequence[str]) -> "Clip":
        """The clip restricted to ``bones`` (in that order); every name must exist."""
        index = {b: i for i, b in enumerate(self.bones)}
        missing = [b for b in bones if b not in index]
        if missing:
            raise CurveError(f"clip {self.name!r} has no bone(s) {', '.join(missing)}")
        idx = [index[b] for b in bones]
        modes = tuple(self.rotation_modes[i] for i in idx) if self.rotation_modes else ()
        return replace(self, bones=tuple(bones), rotations=self.rotations[:, idx], rotation_modes=modes)

    def crop(self, start: Optional[int] = None, end: Optional[int] = None, *, clamp: bool = False) -> "Clip":
        """Keep scene frames start..end inclusive (None: from the first / to the last frame). A range reaching
        outside the clip is refused, or with ``clamp`` cut to it (``errors.check_frame_range``)."""
        first, last = check_frame_range(start, end, self.frame_start, self.frame_end, f"clip {self.name!r}",
                                         frames=1, clamp=clamp)
        a, b = first - self.frame_start, last - self.frame_start + 1
        rt = None if self.root_translation is None else self.root_translation[a:b]
        return replace(self, rotations=self.rotations[a:b], root_translation=rt, frame_start=first)

    def still_bones(self, tolerance: float = STILL_TOLERANCE) -> Tuple[str, ...]:
        """Bones whose rotation never moves more than ``tolerance`` radians from the first frame
        (``so3.still_joints``)."""
        mask = still_joints(self.rotations, tolerance)
        return tuple(b for b, m in zip(self.bones, mask) if m)


def shared_bones(*clips: Clip) -> Tuple[str, ...]:
    """Bones present in every clip, in the order of the first clip."""
    if not clips:
        return ()
    common = set(clips[0].bones)
    for c in clips[1:]:
        common &= set(c.bones)
    return tuple(b for b in clips[0].bones if b in common)


def restrict_to_shared(*clips: Clip, drop_still: bool = True, tolerance: float = STILL_TOLERANCE):
    """The clips restricted to their shared bones, consistently ordered.

    With ``drop_still``, bones that are still in *every* clip are dropped (they contribute nothing to
    any of the distances but cost). Raises CurveError when no bone is shared (or none moves).
    """
    bones = shared_bones(*clips)
    if not bones:
        names = ", ".join(repr(c.name) for c in clips)
        raise CurveError(f"clips {names} share no bones")
    selected = [c.select(bones) for c in clips]
    if drop_still:
        still = np.ones(len(bones), dtype=bool)
        for c in selected:
            still &= still_joints(c.rotations, tolerance)
        if still.all():
            # Nothing moves anywhere: keep the bones, every distance is then 0.
            return tuple(selected)
        keep = [b for b, s in zip(bones, still) if not s]
        selected = [c.select(keep) for c in selected]
    return tuple(selected)
