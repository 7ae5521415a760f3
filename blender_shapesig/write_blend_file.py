"""Write blends to a .blend file (the command line's ``blend``): the file holds clip A's armature, brought in by the
reader of A's format, and one new action per blended clip, the first one assigned."""

import os

import bpy

from . import action_io
from .compat import remove_action
from .core.errors import ShapeSigError
from .core.io.sources import ClipSpec
from .readers.acclaim import import_acclaim
from .readers.bvh import import_armature

__all__ = ["source_armature", "write_blend"]


def source_armature(spec: ClipSpec):
    """Make the current Blender file hold clip A's armature; returns the armature object.

    .blend: the file itself is opened (the armature that plays the action, else the first one);
    .bvh: Blender's importer (``readers.bvh.import_armature``), its imported action removed;
    .amc: the Acclaim armature builder (``readers.acclaim.import_acclaim``), its action removed.
    """
    if spec.ext == ".blend":
        bpy.ops.wm.open_mainfile(filepath=os.path.abspath(spec.path))
        arms = [o for o in bpy.data.objects if o.type == "ARMATURE"]
        for o in arms:
            ad = o.animation_data
            if spec.action and ad is not None and ad.action is not None and ad.action.name == spec.action:
                return o
        if not arms:
            raise ShapeSigError(f"{spec.path}: the file holds no armature to carry the blend")
        return arms[0]
    bpy.ops.wm.read_factory_settings(use_empty=True)
    if spec.ext == ".bvh":
        arm, _frame_time = import_armature(spec.path)
    else:
        arm, _actions = import_acclaim(bpy.context, spec.skeleton(), [spec.path])
    ad = arm.animation_data
    if ad is not None and ad.action is not None:
        old = ad.action
        ad.action = None
        remove_action(old)
    return arm


def write_blend(spec_a: ClipSpec, blended, out_path):
    """Save a .blend with A's armature and one new action per blended clip (the first one assigned);
    returns the action names."""
    armature = source_armature(spec_a)
    names = []
    for i, clip in enumerate(blended):
        action = action_io.write_action(clip, armature, name=clip.name, fake_user=True, assign=(i == 0))
        names.append(action.name)
    bpy.context.scene.frame_start = blended[0].frame_start
    bpy.context.scene.frame_end = blended[0].frame_end
    bpy.ops.wm.save_as_mainfile(filepath=out_path, check_existing=False)
    return names
