"""blender_shapesig.core: shape analysis of curves in SO(3)^d.

Pure numpy/scipy (iisignature optional); never imports bpy, so it is usable as a library outside
Blender. The public names are fixed by interfaces.md; see docs/ for the maths.
"""

from .errors import CurveError, ParseError, ShapeSigError
from .curves import (
    as_curve,
    geodesic_interpolate,
    inverse_srvt,
    l2_distance,
    move_to_identity,
    right_log_derivative,
    srvt,
)
from .elastic import elastic_align, elastic_distance, reparametrize
from .signatures import (
    concat_distance,
    group_distance,
    linear_distance,
    log_signature,
    normalized_distance,
    signature,
)
from .blend import geodesic_blend

__all__ = [
    "ShapeSigError", "CurveError", "ParseError",
    "as_curve", "move_to_identity", "right_log_derivative", "srvt", "inverse_srvt",
    "geodesic_interpolate", "l2_distance",
    "elastic_align", "elastic_distance", "reparametrize",
    "signature", "log_signature", "group_distance", "concat_distance", "linear_distance",
    "normalized_distance",
    "geodesic_blend",
]
