"""Operators (bpy.ops.shapesig.*). Operators are thin: parse inputs, call core, write results, report.
Each submodule lists its classes in ``classes``; see ``_registry``."""

from .. import _registry

_SUBMODULES = ("import_acclaim", "blend", "search")


def register():
    _registry.register(__name__, _SUBMODULES)


def unregister():
    _registry.unregister(__name__, _SUBMODULES)
