"""Registration of a package's submodules: each lists its classes in ``classes`` and may define
``menu_register()``/``menu_unregister()`` for menu entries (used by operators/ and panels/)."""

import importlib


def submodules(package, names):
    return [importlib.import_module(f"{package}.{name}") for name in names]


def register(package, names):
    import bpy

    for mod in submodules(package, names):
        for cls in mod.classes:
            bpy.utils.register_class(cls)
        if hasattr(mod, "menu_register"):
            mod.menu_register()


def unregister(package, names):
    import bpy

    for mod in reversed(submodules(package, names)):
        if hasattr(mod, "menu_unregister"):
            mod.menu_unregister()
        for cls in reversed(mod.classes):
            bpy.utils.unregister_class(cls)
