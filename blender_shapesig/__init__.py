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
    from .actions import action_changes

    for module in _modules():
        module.register()
    action_changes.start_change_detection()
    _warm_up_kernels()


def unregister():
    from .actions import action_changes
    from .search import thumbnails

    action_changes.stop_change_detection()
    thumbnails.free_previews()
    for module in reversed(_modules()):
        module.unregister()
    # numba writes its compiled kernels beside the package: an uninstall right after enabling must not have them
    # written into a folder being removed, so a warm-up still compiling is stopped and waited for
    while _WARM_UP:
        thread = _WARM_UP.pop()
        if thread.proc.poll() is None:
            thread.proc.terminate()
        thread.join()


def _warm_up_kernels():
    """Compile numba's DP kernels into numba's on-disk cache in a child process at enable, so the first distance of
    a session only loads them (19 s cold; 0.7 s once cached, benchmarks/bench_elastic.py). A child, not a thread of
    Blender: LLVM compiling in a thread beside Blender's own work crashed a headless session (one of three cold
    runs), and another LLVM in the process is a known hazard (numba issue 7857). The child needs no bpy: core only."""
    import os
    import subprocess
    import sys
    import threading

    # the child imports the package under this process' name for it (an extension is bl_ext.REPO.blender_shapesig):
    # numba's cached kernels record their module by name and import it when this process loads them
    package_root = os.path.dirname(os.path.abspath(__file__))
    parents, folder = [], package_root
    for k in range(__name__.count("."), 0, -1):
        folder = os.path.dirname(folder)
        parents.append((__name__.rsplit(".", __name__.count(".") - k + 1)[0], folder))
    code = ("import sys, types, importlib\n"
            "sys.path[:0] = {paths!r}\n"
            "for name, folder in {parents!r}:\n"
            "    module = sys.modules.setdefault(name, types.ModuleType(name))\n"
            "    module.__path__ = [folder]\n"
            "importlib.import_module({name!r} + '.core.elastic.elastic').warm_up()\n").format(
        paths=[os.path.dirname(package_root)] + [p for p in sys.path if p], parents=parents[::-1], name=__name__)
    python = sys.executable
    if not python or "blender" in os.path.basename(python).lower():
        return  # no Python interpreter to run the child with: the first distance compiles
    try:
        proc = subprocess.Popen([python, "-c", code], stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL)
    except OSError:
        return  # the first distance compiles

    thread = threading.Thread(target=proc.wait, name="shapesig-warm-up", daemon=True)
    thread.start()
    thread.proc = proc
    _WARM_UP.append(thread)
