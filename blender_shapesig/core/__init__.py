"""blender_shapesig.core: shape analysis of curves in SO(3)^d.

Pure numpy/scipy (iisignature optional); never imports bpy, so it is usable as a library outside
Blender. The public names are fixed by interfaces.md; see docs/ for the maths.
"""

from .errors import CurveError, ParseError, ShapeSigError

# The maths modules are imported on first use of one of their names (PEP 562), so that importing a core
# submodule (the command line, the readers) does not pay for numba, scipy.sparse or iisignature.
_LAZY = {
    "as_curve": "curves", "geodesic_interpolate": "curves", "inverse_srvt": "curves", "l2_distance": "curves",
    "move_to_identity": "curves", "right_log_derivative": "curves", "srvt": "curves",
    "elastic_align": "elastic", "elastic_distance": "elastic", "reparametrize": "elastic",
    "concat_distance": "signatures", "group_distance": "signatures", "linear_distance": "signatures",
    "log_signature": "signatures", "normalized_distance": "signatures", "signature": "signatures",
    "geodesic_blend": "blend",
}


def __getattr__(name):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(f"{__name__}.{module}"), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(list(globals()) + list(_LAZY))


__all__ = [
    "ShapeSigError", "CurveError", "ParseError",
    "as_curve", "move_to_identity", "right_log_derivative", "srvt", "inverse_srvt",
    "geodesic_interpolate", "l2_distance",
    "elastic_align", "elastic_distance", "reparametrize",
    "signature", "log_signature", "group_distance", "concat_distance", "linear_distance",
    "normalized_distance",
    "geodesic_blend",
]
