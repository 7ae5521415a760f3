"""Scratch data of the readers: what an import creates is removed again, and what Blender prints is kept
off the terminal.

``id_snapshot()`` remembers every removable data-block; ``remove_new_ids(before)`` removes whatever was
created since (objects, armatures, actions, scenes, ...), so reading a clip leaves the file as it was.
``quiet_fds()`` sends file descriptors 1 and 2 (Blender's C-level messages and an importer's prints) to a
temporary file for the duration.
"""

import contextlib
import io
import os
import sys
import tempfile

import bpy

__all__ = ["id_snapshot", "remove_new_ids", "quiet_fds"]

# bpy.data collections of the user interface: never scratch data
_UI_COLLECTIONS = ("window_managers", "screens", "workspaces")


def _id_collections():
    """Names of the bpy.data collections of removable data-blocks."""
    out = []
    for prop in bpy.data.bl_rna.properties:
        name = prop.identifier
        if prop.type != "COLLECTION" or name in _UI_COLLECTIONS:
            continue
        if hasattr(getattr(bpy.data, name, None), "remove"):
            out.append(name)
    return out


def id_snapshot():
    """A set naming every removable data-block now (collection name, pointer)."""
    return {(coll, id_.as_pointer()) for coll in _id_collections() for id_ in getattr(bpy.data, coll)}


def remove_new_ids(before):
    """Remove every data-block created since the snapshot ``before`` (scenes last, one by one)."""
    new = [id_ for coll in _id_collections() for id_ in getattr(bpy.data, coll, ())
           if (coll, id_.as_pointer()) not in before]
    scenes = [i for i in new if isinstance(i, bpy.types.Scene)]
    others = [i for i in new if not isinstance(i, bpy.types.Scene)]
    if others:
        bpy.data.batch_remove(others)
    for sc in scenes:
        with contextlib.suppress(RuntimeError, ReferenceError):
            bpy.data.scenes.remove(sc)


@contextlib.contextmanager
def quiet_fds():
    """Send the process's stdout and stderr (file descriptors 1 and 2, and Python's streams) to a temporary
    file for the duration."""
    saved = []
    with tempfile.TemporaryFile() as sink:
        try:
            for stream in (sys.stdout, sys.stderr):
                with contextlib.suppress(Exception):
                    stream.flush()
            for fd in (1, 2):
                saved.append((fd, os.dup(fd)))
                os.dup2(sink.fileno(), fd)
        except OSError:
            pass
        try:
            with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
                yield
        finally:
            for fd, copy in saved:
                os.dup2(copy, fd)
                os.close(copy)
