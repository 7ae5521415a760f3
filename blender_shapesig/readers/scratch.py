"""Scratch data of the readers: what an import creates is removed again, and what Blender prints is kept
off the terminal.

``id_snapshot()`` remembers every removable data-block; ``remove_new_ids(before)`` removes whatever was
created since (objects, armatures, actions, scenes, ...), so reading a clip leaves the file as it was.
``quiet_fds()`` sends file descriptors 1 and 2 (Blender's C-level messages and an importer's prints) to a
temporary file for the duration.
"""

import contextlib
import gc
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


# what a new scene has and importers read or change (the glTF importer reads the rate and first frame, the FBX
# importer sets the rate, the BVH importer may extend the last frame)
_FRESH = {"fps": 24, "fps_base": 1.0, "frame_start": 1}


@contextlib.contextmanager
def scratch_scene(name="shapesig_import"):
    """Import into a new scene shown in the window (Blender with its interface), else -- in the background, where
    Blender never processes the window's notifiers (each scene switch queues one; Blender 4.2 crashed after
    hundreds) -- into the current one, set to a new scene's rate and first frame, its selection, active object,
    rate and frame range restored afterwards; every data-block created meanwhile is removed at the end."""
    before = id_snapshot()
    window = getattr(bpy.context, "window", None)
    if bpy.app.background:
        window = None
    old_scene = window.scene if window is not None else None
    old_selected, old_active = None, None
    if window is None:
        # names, not references: nothing held across the import can dangle (a freed struct crashes 4.2's bpy)
        scene = bpy.context.scene
        old_selected = [o.name for o in scene.objects if o.select_get()]
        active = bpy.context.view_layer.objects.active
        old_active = active.name if active is not None else None
        old_state = (scene.render.fps, scene.render.fps_base, scene.frame_start, scene.frame_end,
                     scene.frame_current)
        scene.render.fps, scene.render.fps_base = _FRESH["fps"], _FRESH["fps_base"]
        scene.frame_start = _FRESH["frame_start"]
    try:
        if window is not None:
            window.scene = bpy.data.scenes.new(name)
        yield
    finally:
        if window is not None:
            window.scene = old_scene
        # an importer's cyclic garbage (e.g. the BVH importer's node graph) may hold Python wrappers of the data
        # it made: freed now, while that data exists (collected after, the likeliest cause of 4.2's crashes)
        gc.collect()
        remove_new_ids(before)
        if old_selected is not None:
            scene = bpy.context.scene
            with contextlib.suppress(ReferenceError, RuntimeError):
                scene.render.fps, scene.render.fps_base = old_state[:2]
                scene.frame_start, scene.frame_end = old_state[2:4]
                if scene.frame_current != old_state[4]:
                    scene.frame_set(old_state[4])
            objects = scene.objects
            for name in old_selected:
                o = objects.get(name)
                if o is not None:
                    with contextlib.suppress(ReferenceError, RuntimeError):
                        o.select_set(True)
            with contextlib.suppress(ReferenceError, RuntimeError):
                bpy.context.view_layer.objects.active = objects.get(old_active) if old_active else None
