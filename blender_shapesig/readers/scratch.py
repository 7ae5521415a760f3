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

__all__ = ["id_snapshot", "remove_new_ids", "quiet_fds", "scratch_scene"]

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


@contextlib.contextmanager
def scratch_scene(name="shapesig_import"):
    """Import into a new scene (with a window), else into the current one with its selection, active object and
    frame rate restored (importers set the scene's rate); every data-block created meanwhile is removed at the
    end."""
    before = id_snapshot()
    window = getattr(bpy.context, "window", None)
    old_scene = window.scene if window is not None else None
    old_selected, old_active = None, None
    if window is None:
        # names, not references: nothing held across the import can dangle (a freed struct crashes 4.2's bpy)
        old_selected = [o.name for o in bpy.context.scene.objects if o.select_get()]
        active = bpy.context.view_layer.objects.active
        old_active = active.name if active is not None else None
        render = bpy.context.scene.render
        old_rate = (render.fps, render.fps_base)
    try:
        if window is not None:
            window.scene = bpy.data.scenes.new(name)
        yield
    finally:
        if window is not None:
            window.scene = old_scene
        remove_new_ids(before)
        if old_selected is not None:
            scene = bpy.context.scene
            with contextlib.suppress(ReferenceError, RuntimeError):
                scene.render.fps, scene.render.fps_base = old_rate
            objects = scene.objects
            for name in old_selected:
                o = objects.get(name)
                if o is not None:
                    with contextlib.suppress(ReferenceError, RuntimeError):
                        o.select_set(True)
            with contextlib.suppress(ReferenceError, RuntimeError):
                bpy.context.view_layer.objects.active = objects.get(old_active) if old_active else None
