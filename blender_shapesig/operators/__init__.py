"""Operators (bpy.ops.shapesig.*). Operators are thin: parse inputs, call the library, write results, report.
Each submodule lists its classes in ``classes`` and may add menu entries (``menu_register``/``menu_unregister``).
Every class is guarded (``errors_ui.guard_operator``): whatever escapes its execute / invoke / modal is one ERROR
line, its ``cleanup`` runs and the traceback goes to the console."""

import bpy

from ..errors_ui import guard_operator
from . import blend, import_acclaim, moments, rates, rigmap, search, transition

_MODULES = (import_acclaim, blend, search, moments, rigmap, rates, transition)
classes = tuple(guard_operator(cls) for module in _MODULES for cls in module.classes)
_register_classes, _unregister_classes = bpy.utils.register_classes_factory(classes)


def register():
    _register_classes()
    for module in _MODULES:
        if hasattr(module, "menu_register"):
            module.menu_register()


def unregister():
    for module in reversed(_MODULES):
        if hasattr(module, "menu_unregister"):
            module.menu_unregister()
    _unregister_classes()
