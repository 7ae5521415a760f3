"""Panels and UI lists (sidebar tab "ShapeSig"). Each submodule lists its classes in ``classes`` and may define
``menu_register``/``menu_unregister`` for menu entries. Operators are thin: parse inputs, call
core, write results, report."""

import importlib

_SUBMODULES = ("search",)


def _submodules():
    return [importlib.import_module(f"{__name__}.{name}") for name in _SUBMODULES]


def register():
    import bpy

    for mod in _submodules():
        for cls in mod.classes:
            bpy.utils.register_class(cls)
        if hasattr(mod, "menu_register"):
            mod.menu_register()


def unregister():
    import bpy

    for mod in reversed(_submodules()):
        if hasattr(mod, "menu_unregister"):
            mod.menu_unregister()
        for cls in reversed(mod.classes):
            bpy.utils.unregister_class(cls)
