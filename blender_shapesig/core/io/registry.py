"""The clip reader registry: one reader per file extension, ``reader(spec: ClipSpec) -> [Clip]``, and the one list
of clip file types (``EXTENSIONS``; ``NAMED_CLIPS``: the types that hold several named clips, ``FILE#NAME``).
``sources`` registers the pure readers (``.amc``, ``.bvh``, SMPL/AMASS ``.npz``); the package's ``__init__`` registers
the Blender layer's (``.blend``, ``.fbx``, ``.glb``, ``.gltf``, ``.vrma``) by module path, imported on first use, so
core never imports it and stays usable without bpy."""

import importlib
from typing import Callable

from ..errors import ShapeSigError
from .interchange import INTERCHANGE_EXTENSIONS

__all__ = ["EXTENSIONS", "NAMED_CLIPS", "INTERCHANGE_EXTENSIONS", "register_reader", "reader_for", "extensions_text"]

# files that hold several named clips: FILE.blend#ACTION, FILE.glb#ANIMATION, ...
NAMED_CLIPS = (".blend",) + INTERCHANGE_EXTENSIONS
EXTENSIONS = (".bvh", ".amc", ".npz") + NAMED_CLIPS
_READERS = {}


def extensions_text(last="or") -> str:
    """The clip file types for a message: '.bvh, .amc, .blend, .fbx, .glb, .gltf or .vrma'."""
    return ", ".join(EXTENSIONS[:-1]) + f" {last} {EXTENSIONS[-1]}"


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
