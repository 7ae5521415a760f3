"""Write blends to a .blend file (the command line's ``blend``): the file holds clip A's armature, brought in by the
reader of A's format, and one new action per blended clip, the first one assigned. A .blend source is never opened
in this process: its child-process reader (``readers.blend_file``) describes the armature that owns A's action
(``rig_of``) and ``build_rig`` rebuilds it in an empty file, so nothing else of the source (text blocks, drivers,
other data-blocks) reaches the output and a damaged file cannot crash the command line."""

import bpy
from mathutils import Matrix

from . import action_io
from ..compat import remove_action
from ..core.errors import ShapeSigError
from ..core.io.sources import ClipSpec
from ..readers.acclaim import import_acclaim
from ..readers.blend_file import read_blend_file
from ..readers.bvh import import_armature

__all__ = ["source_armature", "build_rig", "write_blend"]


def build_rig(rig):
    """A new armature object in the current scene rebuilt from ``readers.blend_file.rig_of``'s description (bones
    with their rest frames, parents, inheritance flags and rotation modes; the object's world matrix)."""
    data = bpy.data.armatures.new(rig["data"])
    obj = bpy.data.objects.new(rig["object"], data)
    bpy.context.scene.collection.objects.link(obj)
    obj.matrix_world = Matrix(rig["matrix_world"])
    bpy.context.view_layer.objects.active = obj
    obj.select_set(True)
    bpy.ops.object.mode_set(mode="EDIT", toggle=False)
    try:
        ebs = data.edit_bones
        for b in rig["bones"]:
            eb = ebs.new(b["name"])
            eb.head, eb.tail = b["head"], b["tail"]
            eb.align_roll(b["z"])
            eb.use_inherit_rotation, eb.inherit_scale = b["inherit_rotation"], b["inherit_scale"]
            eb.use_local_location, eb.use_deform = b["local_location"], b["deform"]
        for b in rig["bones"]:
            if b["parent"] is not None:
                eb = ebs[b["name"]]
                eb.parent = ebs[b["parent"]]
                eb.use_connect = b["connect"]
    finally:
        bpy.ops.object.mode_set(mode="OBJECT", toggle=False)
    for b in rig["bones"]:
        obj.pose.bones[b["name"]].rotation_mode = b["rotation_mode"]
    return obj


def source_armature(spec: ClipSpec):
    """Make the current Blender file an empty one holding clip A's armature; returns the armature object.

    .blend: the armature that owns the action (``owners.find_owner``, in the child process), rebuilt;
    .bvh: Blender's importer (``readers.bvh.import_armature``), its imported action removed;
    .amc: the Acclaim armature builder (``readers.acclaim.import_acclaim``), its action removed;
    .fbx, .glb, .gltf: Blender's importer (``readers.interchange.import_armature_of``: the character with its
    meshes, the imported actions removed); any other format has no armature (ShapeSigError).
    """
    if spec.ext == ".blend":
        clip = read_blend_file(spec.path, spec.action, rig=True)[0]
        if "rig" not in clip.meta:
            raise ShapeSigError(f"{spec.path}: no armature in the file holds the bones of action {clip.name!r}: "
                                f"none can carry the blend")
        bpy.ops.wm.read_factory_settings(use_empty=True)
        return build_rig(clip.meta["rig"])
    bpy.ops.wm.read_factory_settings(use_empty=True)
    if spec.ext == ".bvh":
        arm, _frame_time = import_armature(spec.path)
    elif spec.ext in (".fbx", ".glb", ".gltf"):
        from ..readers.interchange import import_armature_of

        return import_armature_of(spec.path, spec.action)  # the character as Blender's importer brings it
    elif spec.ext in (".amc",):
        arm, _actions = import_acclaim(bpy.context, spec.skeleton(), [spec.path])
    else:
        raise ShapeSigError(f"{spec.path}: a {spec.ext} clip has no armature to carry the result: give a .bvh, "
                            f".amc, .fbx, .glb or .blend clip first, or write the result as BVH")
    ad = arm.animation_data
    if ad is not None and ad.action is not None:
        old = ad.action
        ad.action = None
        remove_action(old)
    return arm


def write_blend(spec_a: ClipSpec, blended, out_path):
    """Save a .blend with A's armature and one new action per blended clip (the first one assigned), the scene at
    the blends' frame rate; returns the action names."""
    armature = source_armature(spec_a)
    names = []
    for i, clip in enumerate(blended):
        action = action_io.write_action(clip, armature, name=clip.name, fake_user=True, assign=(i == 0))
        names.append(action.name)
    scene = bpy.context.scene
    scene.frame_start = blended[0].frame_start
    scene.frame_end = blended[0].frame_end
    # the scene plays the blend at its own rate (its true speed): fps / fps_base = the blend's rate
    rate = float(blended[0].fps)
    scene.render.fps = max(1, int(round(rate)))
    scene.render.fps_base = scene.render.fps / rate
    bpy.ops.wm.save_as_mainfile(filepath=out_path, check_existing=False)
    return names
