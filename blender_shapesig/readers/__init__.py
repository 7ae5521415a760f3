"""The Blender half of reading clips: readers that need bpy, registered in ``core.sources`` by module path
(``.bvh``: Blender's importer; ``.blend``: appended actions, read in a child process)."""

def read_bvh(spec):
    from ..clips import import_bvh

    return [import_bvh(spec.path)]


def read_blend(spec):
    from ..clips import _load_blend

    return _load_blend(spec.path, spec.action)


__all__ = ["read_bvh", "read_blend"]
