"""BVH clips through Blender's own importer (``io_anim_bvh``), leaving the file as it was: ``import_armature`` is the
one call of ``bpy.ops.import_anim.bvh`` (fixed settings, the file validated first by ``core.io.bvh.check_bvh`` and held to the caps of ``core.io.files``),
``import_bvh`` reads the imported action with ``action_io.read_action`` and removes everything the import created.
Every frame is kept (trimming is ``core.clip.trim``'s). See docs/dev/blender_layer.md.
"""

import contextlib
import os
import tempfile

import bpy

from ..actions import action_io
from ..core.errors import ParseError, ShapeSigError
from ..core.io.files import check_file
from ..core.io.bvh import bvh_text, check_bvh
from .scratch import quiet_fds, scratch_scene

__all__ = ["import_bvh", "import_armature"]

SPACES = ("armature", "native")


def _ensure_importer():
    try:
        bpy.ops.import_anim.bvh.get_rna_type()
        return
    except (AttributeError, KeyError):
        pass
    import addon_utils

    addon_utils.enable("io_anim_bvh", default_set=False)
    try:
        bpy.ops.import_anim.bvh.get_rna_type()
    except (AttributeError, KeyError):
        raise ShapeSigError("Blender's BVH importer (io_anim_bvh) is not available") from None


@contextlib.contextmanager
def _utf8(path):
    """The path of the file as UTF-8 text: the file itself, or a temporary UTF-8 copy with the same name."""
    text, plain = bvh_text(path)
    if plain:
        yield path
        return
    with tempfile.TemporaryDirectory(prefix="shapesig_bvh_") as tmp:
        copy = os.path.join(tmp, os.path.basename(path))
        with open(copy, "w", encoding="utf-8", newline="") as fh:
            fh.write(text)
        yield copy


def import_armature(path):
    """Blender's BVH importer (our settings) on a validated file: ``(armature, frame time)``, the new
    armature object with its imported action, in the current scene. ParseError (one line) on any failure."""
    path = os.fspath(path)
    frame_time = check_bvh(path)
    _ensure_importer()
    before = {o.as_pointer() for o in bpy.data.objects}
    with _utf8(path) as readable:
        try:
            with quiet_fds():  # the importer prints progress; Blender prints failures to stderr
                result = bpy.ops.import_anim.bvh(filepath=os.path.abspath(readable), rotate_mode="NATIVE",
                                                 frame_start=1, use_fps_scale=False, update_scene_fps=False,
                                                 update_scene_duration=False, global_scale=1.0)
        except RuntimeError as exc:
            lines = [ln.strip() for ln in str(exc).splitlines() if ln.strip() and not ln.startswith("Location")]
            raise ParseError(f"Blender's BVH importer failed: {lines[-1] if lines else exc}", path) from None
    if "FINISHED" not in result:
        raise ParseError("Blender's BVH importer did not finish", path)
    armatures = [o for o in bpy.data.objects if o.as_pointer() not in before and o.type == "ARMATURE"]
    if len(armatures) != 1 or armatures[0].animation_data is None or armatures[0].animation_data.action is None:
        raise ParseError("the BVH importer made no animated armature", path)
    return armatures[0], frame_time


def import_bvh(path, name=None, space="armature"):
    """One BVH file as a Clip through Blender's importer, leaving the file as it was.

    ``space``: "armature" (the package's comparison space, ``action_spaces.to_armature_space``) or "native"
    (pose-bone rotations)."""
    if space not in SPACES:
        raise ShapeSigError(f"space must be one of {', '.join(SPACES)}, got {space!r}")
    path = os.fspath(path)
    if not os.path.lexists(path):
        raise ParseError("no such file", path)
    check_file(path)  # a regular file within the size cap; check_bvh then reads it within the frame cap
    with scratch_scene():
        arm, frame_time = import_armature(path)
        fps = 1.0 / frame_time
        if abs(fps - round(fps)) <= 1e-4 * fps:
            # "Frame Time: 0.00833333" means 120 fps, "0.016667" (6 decimals, 59.9988) means 60
            fps = float(round(fps))
        clip = action_io.read_action(arm.animation_data.action, armature=arm, fps=fps,
                                     name=name or os.path.splitext(os.path.basename(path))[0],
                                     space="armature" if space == "armature" else "pose")
    clip.source = path
    clip.meta["format"] = "bvh"
    return clip
