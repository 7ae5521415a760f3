"""blender_shapesig.core: shape analysis of curves in SO(3)^d, pure numpy/scipy (numba, iisignature optional);
never imports bpy. Packages: ``geometry`` (rotations, curves, the SRVT), ``clip`` (the ``Clip``, rest skeletons,
trimming, the comparison time base), ``io`` (sources, file formats), ``elastic`` (d_S*), ``signatures``, ``index``
(search, moments, near duplicates), ``blend`` (geodesic blends, planted feet), ``rigs`` (canonical joints, bone
maps, the comparison space, retargeting); modules ``metric_names`` (the metric grammar, defaults), ``measure_words``
(the engines' and measures' names a person reads), ``distances``/``metrics``/``pairwise`` (named measures,
matrices), ``errors``. The public names below are fixed by the project's interface contract, which is kept outside
this repository: add names, never rename them. docs/architecture.md shows who owns what."""

from .errors import CurveError, ParseError, ShapeSigError

# The maths modules are imported on first use of one of their names (PEP 562), so that importing a core
# submodule (the command line, the readers) does not pay for numba, scipy.sparse or iisignature.
_LAZY = {
    "as_curve": "geometry.curves", "geodesic_interpolate": "geometry.curves", "inverse_srvt": "geometry.curves",
    "l2_distance": "geometry.curves", "move_to_identity": "geometry.curves", "right_log_derivative": "geometry.curves",
    "srvt": "geometry.curves",
    "elastic_align": "elastic.elastic", "elastic_distance": "elastic.elastic", "reparametrize": "elastic.elastic",
    "concat_distance": "signatures.signatures", "group_distance": "signatures.signatures",
    "linear_distance": "signatures.signatures", "log_signature": "signatures.signatures",
    "normalized_distance": "signatures.signatures", "signature": "signatures.signatures",
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
