"""The clip reader registry: one reader per file extension, ``reader(spec: ClipSpec) -> [Clip]``. ``sources``
registers the pure readers (``.amc``, ``.bvh``, SMPL/AMASS ``.npz``); the package's ``__init__`` registers the Blender layer's
(``.blend``) by module path, imported on first use, so core never imports it and stays usable without bpy."""

import importlib
from typing import Callable

from ..errors import ShapeSigError

__all__ = ["EXTENSIONS", "register_reader", "reader_for"]

EXTENSIONS = (".bvh", ".amc", ".blend", ".npz")
_READERS = {}


def register_reader(ext, reader):
    """Use ``reader(spec) -> [Clip]`` (or a ``"module:function"`` string) for files ending in ``ext``."""
    ext = ext.lower()
    if ext not in EXTENSIONS:
        raise ShapeSigError(f"unknown clip extension {ext!r}")
    _READERS[ext] = reader


def reader_for(ext) -> Callable:
    """The reader registered for ``ext`` (a string reader is imported now); ShapeSigError when it cannot be had."""
    reader = _READERS.get(ext)
    if reader is None:
        raise ShapeSigError(f"no reader for {ext} files is registered")
    if isinstance(reader, str):
        module, _, attr = reader.partition(":")
        try:
            reader = getattr(importlib.import_module(module), attr)
        except ImportError as exc:
            raise ShapeSigError(f"reading {ext} files needs Blender (the bpy module): {exc}") from None
    return reader
