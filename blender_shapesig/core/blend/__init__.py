"""Time-aligned SRVT geodesic blends of curves and clips (reference eq. 5.14, sec. 9.1), in verb-named modules
(``combine``, ``move_root``, ``mix``, ``mask``, ``cycle``, ``make``, ``contacts``, ``feet``); the public names are importable from
``blender_shapesig.core.blend``. See docs/blending.md.
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
from .cycle import apply_cycle, close_loop, closed_cycle, crop_range, find_cycle, one_cycle, parse_range, pose_steps
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
    "closed_cycle",
    "apply_cycle",
    "close_loop",
    "pose_steps",
    "make_blends",
    "FEET_MODES",
    "editable_timing",
    "sample_at",
]
