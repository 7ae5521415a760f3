"""Operators (bpy.ops.shapesig.*). Operators are thin: parse inputs, call the library, write results, report.
Each submodule lists its classes in ``classes`` and may add menu entries (``menus``: (menu class name, draw
function) pairs, appended here).
Every class is guarded (``errors_ui.guard_operator``): whatever escapes its execute / invoke / modal is one ERROR
line, its ``cleanup`` runs and the traceback goes to the console."""

import bpy

from ..errors_ui import guard_operator
from . import blend, import_acclaim, moments, rates, rigmap, search, transition

_MODULES = (import_acclaim, blend, search, moments, rigmap, rates, transition)
classes = tuple(guard_operator(cls) for module in _MODULES for cls in module.classes)
_register_classes, _unregister_classes = bpy.utils.register_classes_factory(classes)


_MENU_ENTRIES = tuple(entry for module in _MODULES for entry in getattr(module, "menus", ()))


def register():
    _register_classes()
    for name, draw in _MENU_ENTRIES:
        menu = getattr(bpy.types, name, None)
        if menu is not None:
            menu.append(draw)


def unregister():
    for name, draw in reversed(_MENU_ENTRIES):
        menu = getattr(bpy.types, name, None)
        if menu is not None:
            menu.remove(draw)
    _unregister_classes()
