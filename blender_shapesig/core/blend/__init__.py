"""Time-aligned SRVT geodesic blends of curves and clips (reference eq. 5.14, sec. 9.1), as a package of
verb-named modules; everything is importable from ``blender_shapesig.core.blend`` as before.

* ``combine``: the curves: the merged grid, the SRVT average, the blended timing (``geodesic_blend``,
  ``compute_warp``, ``default_frames``, weights and names); two or more curves.
* ``move_root``: the blended root translation about the clips' up axis.
* ``mix``: clips: ``blend_clips`` (two), ``blend_many`` (two or more, aligned to the first),
  ``blend_clip_series`` (several weights, one warp); every result carries ``meta["source_times"]``.
* ``mask``: per-bone-group weights through the canonical joints (``GROUPS``, ``bone_weights``).
* ``cycle``: frame ranges, cycle detection (one stride) and seamless loops (``find_cycle``, ``one_cycle``,
  ``close_loop``).
* ``make``: ``make_blends``, the one recipe of the command line and the operator: ranges, cycles, the blend,
  back onto the rig, planted feet (``core.blend.feet``), loops.

See docs/blending.md.
"""

from .combine import (  # noqa: F401
    _Plan,
    blend_name,
    blend_weights,
    compute_warp,
    default_frames,
    default_frames_many,
    geodesic_blend,
    identity_warp,
    mean_start,
)
from .cycle import close_loop, crop_range, find_cycle, one_cycle, parse_range, pose_steps
from .mask import GROUPS, bone_weights, parse_groups, parse_mask
from .make import FEET_MODES, editable_timing, make_blends, sample_at
from .mix import blend_clip_series, blend_clips, blend_fps, blend_many

__all__ = [
    "geodesic_blend",
    "blend_clips",
    "blend_weights",
    "blend_name",
    "compute_warp",
    "identity_warp",
    "default_frames",
    "blend_fps",
    "blend_clip_series",
    "blend_many",
    "default_frames_many",
    "mean_start",
    "GROUPS",
    "bone_weights",
    "parse_mask",
    "parse_groups",
    "parse_range",
    "crop_range",
    "find_cycle",
    "one_cycle",
    "close_loop",
    "pose_steps",
    "make_blends",
    "FEET_MODES",
    "editable_timing",
    "sample_at",
]
