"""Panels and UI lists (sidebar tab "ShapeSig"). Each submodule lists its classes in ``classes``; see
``_registry``."""

from .. import _registry

_SUBMODULES = ("search",)


def register():
    _registry.register(__name__, _SUBMODULES)


def unregister():
    _registry.unregister(__name__, _SUBMODULES)
