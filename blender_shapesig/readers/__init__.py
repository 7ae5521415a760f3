"""The Blender half of reading clips (needs bpy): ``bvh`` (Blender's BVH importer), ``blend`` (the actions of
a .blend file, read in a child process), ``acclaim`` (the Acclaim armature builder) and ``scratch`` (removing
what an import created). ``read_blend`` is the ``.blend`` reader the package registers with ``core.io.registry``
(``read_bvh`` reads through Blender's importer, for comparisons with it); the pure parsers are ``core.io``."""


def read_bvh(spec):
    """The clip of a ``.bvh`` ClipSpec (``bvh.import_bvh``)."""
    from .bvh import import_bvh

    return [import_bvh(spec.path)]


def read_blend(spec):
    """The clips of a ``.blend`` ClipSpec: every action, or ``spec.action`` (``blend.read_blend_file``)."""
    from .blend_file import read_blend_file

    return read_blend_file(spec.path, spec.action)


__all__ = ["read_bvh", "read_blend"]
