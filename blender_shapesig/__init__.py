"""blender_shapesig: shape analysis of motions (SRVT elastic distance, geodesic blends and
signature search) as a Blender extension.

This file only registers: the Blender layer's clip readers with core (at import) and the add-on's classes with
Blender (``register``). It imports nothing from Blender at module level, so that ``blender_shapesig.core`` and the
command line can be imported without bpy.
"""

from .core.io import registry as _registry

_registry.register_reader(".blend", f"{__name__}.readers:read_blend")
for _ext in _registry.INTERCHANGE_EXTENSIONS:
    _registry.register_reader(_ext, f"{__name__}.readers:read_interchange")

# Blender-layer modules with register()/unregister(), in registration order.
_MODULE_NAMES = ("preferences", "properties", "operators", "panels")
_WARM_UP = []  # the kernels' warm-up thread of this session (see _warm_up_kernels)


def _modules():
    import importlib

    return [importlib.import_module(f"{__name__}.{name}") for name in _MODULE_NAMES]


def register():
    from . import action_changes

    for module in _modules():
        module.register()
    action_changes.start_change_detection()
    _warm_up_kernels()


def unregister():
    from . import action_changes, thumbnails

    action_changes.stop_change_detection()
    thumbnails.free_previews()
    for module in reversed(_modules()):
        module.unregister()
    # numba writes its compiled kernels beside the package: an uninstall right after enabling must not have them
    # written into a folder being removed, so a warm-up still compiling is waited for
    while _WARM_UP:
        _WARM_UP.pop().join()


def _warm_up_kernels():
    """Compile numba's DP kernels, or load them from numba's on-disk cache, in a background thread at enable: the
    first distance of a session then does not pay the JIT (19 s cold; 0.7 s once cached, benchmarks/bench_elastic.py)."""
    import atexit
    import threading

    from .core.elastic import elastic

    def run():
        try:
            elastic.warm_up()
        except Exception:  # noqa: BLE001 - a read-only cache or a missing numba only costs the first call
            pass

    thread = threading.Thread(target=run, name="shapesig-warm-up", daemon=True)
    thread.start()
    _WARM_UP.append(thread)
    # never let the interpreter shut down under a compiling thread (it crashed Blender 4.2 at exit)
    atexit.register(thread.join)
