"""The Blender half of reading clips (needs bpy): ``bvh`` (Blender's BVH importer), ``blend`` (the actions of
a .blend file, read in a child process), ``interchange`` (FBX and glTF through Blender's importers, in the reading
child of ``child``), ``acclaim`` (the Acclaim armature builder) and ``scratch`` (removing what an import created).
``read_blend`` and ``read_interchange`` are the readers the package registers with ``core.io.registry``
(``read_bvh`` reads through Blender's importer, for comparisons with it); the pure parsers are ``core.io``."""


def read_bvh(spec):
    """The clip of a ``.bvh`` ClipSpec (``bvh.import_bvh``)."""
    from .bvh import import_bvh

    return [import_bvh(spec.path)]


def read_blend(spec):
    """The clips of a ``.blend`` ClipSpec: every action, or ``spec.action``, read in a child process
    (``blend_isolated``: no bpy in this process, so a thread pool may call this); in this process
    (``blend_file.read_blend_file``) with ``SHAPESIG_BLEND_IN_PROCESS=1`` when bpy is already imported or this is
    the main thread (bpy imported first in another thread crashes the process at exit)."""
    import os
    import sys
    import threading

    from ..core.io.blend_file import check_blend
    from .blend_isolated import BLEND_IN_PROCESS_ENV, read_blend_isolated

    if os.environ.get(BLEND_IN_PROCESS_ENV) == "1" and (
            "bpy" in sys.modules or threading.current_thread() is threading.main_thread()):
        from .blend_file import read_blend_file

        return read_blend_file(spec.path, spec.action)
    check_blend(spec.path)
    return read_blend_isolated(spec.path, spec.action)


_KINDS = {".fbx": "FBX", ".glb": "glTF", ".gltf": "glTF", ".vrma": "VRM animation"}


def read_interchange(spec):
    """The clips of an ``.fbx`` / ``.glb`` / ``.gltf`` ClipSpec: every armature animation, or ``spec.action``,
    read by Blender's importer in the reading child (``child.read_in_child``); the file is checked here first
    (``core.io.interchange.check_interchange``), so a file no importer can read starts no Blender."""
    import os

    from ..core.io.interchange import check_interchange
    from .child import read_in_child

    check_interchange(spec.path)
    return read_in_child("interchange", {"path": os.path.abspath(spec.path), "animation": spec.action}, spec.path,
                         _KINDS.get(spec.ext, "clip"))


__all__ = ["read_bvh", "read_blend", "read_interchange"]
