"""blender_shapesig: shape analysis of motions (SRVT elastic distance, geodesic blends and
signature search) as a Blender extension.

This file only registers. It imports nothing from Blender at module level, so that
``blender_shapesig.core`` and the command line can be imported without bpy.
"""

# Blender-layer modules with register()/unregister(), in registration order.
_MODULE_NAMES = ("preferences", "properties", "operators", "panels")


def _modules():
    import importlib

    return [importlib.import_module(f"{__name__}.{name}") for name in _MODULE_NAMES]


def register():
    for module in _modules():
        module.register()


def unregister():
    for module in reversed(_modules()):
        module.unregister()
