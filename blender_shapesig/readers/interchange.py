"""FBX and glTF clips through Blender's bundled importers (``bpy.ops.import_scene.fbx`` / ``.gltf``):
``read_interchange_here(path, animation=None)`` imports the file into a scratch scene, reads every animation of an
armature as a Clip in the world's axes and removes what the import made. Run in a child process
(``readers.child``), so a file that crashes an importer is a ParseError. The file is checked first
(``core.io.interchange.check_interchange``). Rate: FBX's own (the importer sets the scene's); glTF keys are seconds,
imported at the key rate of the densest channel. See docs/formats.md and docs/dev/blender_layer.md.
"""

import os
import re

import bpy

from .. import compat
from ..actions import action_io
from ..actions.bone_channels import bone_channels
from ..core.errors import ParseError, ShapeSigError
from ..core.io.interchange import check_interchange
from ..actions.owners import find_owner
from .scratch import quiet_fds, scratch_scene

__all__ = ["read_interchange_here", "animation_name"]


def _import(path, info):
    """Run the importer on ``path`` (ParseError in one line when it fails)."""
    kind = "FBX" if info["format"] == "fbx" else "glTF"
    try:
        with quiet_fds():  # both importers print progress; failures go to stderr
            if info["format"] == "fbx":
                result = bpy.ops.import_scene.fbx(filepath=path, use_anim=True, use_custom_props=False,
                                                  use_image_search=False)
            else:
                result = bpy.ops.import_scene.gltf(filepath=path, import_pack_images=False)
    except RuntimeError as exc:
        lines = [ln.strip() for ln in str(exc).splitlines() if ln.strip() and not ln.startswith("Location")]
        text = (lines[-1] if lines else str(exc)).removeprefix("Error: ")
        if "draco" in text.lower():  # a Draco-compressed mesh and a Blender built without the decoder
            text = "the file's meshes are Draco-compressed and this Blender has no Draco decoder"
        else:  # the importer's words without a Python exception name or this machine's paths
            text = re.sub(r"^[A-Za-z]*(Error|Exception): ", "", text)
            text = re.sub(r"(/[^\s:'\"]+)+/", "", text)
        raise ParseError(f"Blender's {kind} importer failed: {text[:200]}", path) from None
    if "FINISHED" not in result:
        raise ParseError(f"Blender's {kind} importer did not finish", path)


def animation_name(action, owner, info):
    """The animation's name as the file stores it: the glTF animation (the action's name, without the ``.001``
    Blender adds when the name is taken, or the ``_NODE`` suffix Blender 4.2's importer adds) or the FBX take
    (Blender names the action ``OBJECT|TAKE|LAYER``, or ``OBJECT|TAKE`` when the layer is named like the take)."""
    name = action.name
    if info["format"] != "fbx":
        if name in info["animations"]:
            return name
        base = re.sub(r"\.\d{3}$", "", name)
        suffix = f"_{owner.name}" if owner is not None else None
        candidates = [base] + ([base[:-len(suffix)]] if suffix and base.endswith(suffix) else [])
        return next((c for c in candidates if c in info["animations"]), name)
    if owner is None or not name.startswith(owner.name + "|"):
        return name
    rest = name[len(owner.name) + 1:]
    take, sep, _layer = rest.rpartition("|")
    return take if sep else rest


def read_interchange_here(path, animation=None, space="armature"):
    """The clips of an FBX / glTF file (every armature animation, or the one named ``animation``), read in this
    process. Each clip is in the world's axes (``action_spaces.to_armature_space``: the nodes above the armature, the
    file's up axis and units as Blender imported them), named after the file when it holds one animation, else after
    the animation; ``meta["animation"]`` is its name in the file (``FILE#ANIMATION``)."""
    path = os.path.abspath(os.fspath(path))
    info = check_interchange(path)
    fmt = info["format"]
    with scratch_scene("shapesig_interchange"):
        scene = bpy.context.scene
        if fmt == "gltf":
            scene.render.fps, scene.render.fps_base = max(1, round(info["rate"] or 30.0)), 1.0
        before_obj = {o.as_pointer() for o in bpy.data.objects}
        before_act = {a.as_pointer() for a in bpy.data.actions}
        _import(path, info)
        fps = float(scene.render.fps)  # keys sit on integer frames at this rate (FBX: the file's, rounded)
        armatures = [o for o in bpy.data.objects if o.as_pointer() not in before_obj and o.type == "ARMATURE"]
        found = []
        for action in [a for a in bpy.data.actions if a.as_pointer() not in before_act]:
            if not bone_channels(compat.all_action_fcurves(action)):
                continue
            owner = find_owner(action, armatures)
            if owner is not None:
                found.append((animation_name(action, owner, info), action, owner))
        return _clips(path, found, animation, fps, fmt, space)


def _clips(path, found, animation, fps, fmt, space):
    names = [n for n, _a, _o in found]
    if not found:
        raise ParseError("the file has no animation of an armature", path)
    if animation is not None:
        found = [f for f in found if f[0] == animation]
        if not found:
            shown = ", ".join(names[:8]) + (" ..." if len(names) > 8 else "")
            raise ParseError(f"no animation {animation!r} in the file (it has: {shown})", path)
    stem = os.path.splitext(os.path.basename(path))[0]
    clips = []
    for name, action, arm in found:
        compat.assign_action(arm, action)  # its slot for this armature (scratch data, removed after)
        keyed = set(bone_channels(compat.action_fcurves(action, compat.object_action_slot(arm))))
        bones = [b.name for b in arm.data.bones if b.name in keyed]
        if not bones:
            continue
        try:
            clip = action_io.read_action(action, armature=arm, bones=bones, fps=fps,
                                         name=stem if len(names) == 1 else name,
                                         space="armature" if space == "armature" else "pose")
        except ShapeSigError as exc:
            raise exc if isinstance(exc, ParseError) else ParseError(str(exc), path) from None
        clip.source = f"{path}#{name}" if len(names) > 1 else path
        clip.meta.update(format=fmt, animation=name)
        clips.append(clip)
    if not clips:
        raise ParseError("the file's animations move no bone of its armature", path)
    return clips


def import_armature_of(path, animation=None):
    """Blender's importer on the FBX / glTF ``path`` into the current scene (``check_interchange``'s pre-checks
    first): the armature object that plays ``animation`` (default: the first that plays one), with everything else
    the file brings (meshes, the nodes above it) kept and every imported action removed (the command line's
    ``blend`` and ``transition`` write their own actions onto it). ParseError in one line."""
    path = os.path.abspath(os.fspath(path))
    info = check_interchange(path)
    before_obj = {o.as_pointer() for o in bpy.data.objects}
    before_act = {a.as_pointer() for a in bpy.data.actions}
    _import(path, info)
    armatures = [o for o in bpy.data.objects if o.as_pointer() not in before_obj and o.type == "ARMATURE"]
    actions = [a for a in bpy.data.actions if a.as_pointer() not in before_act]
    owned = [(a, find_owner(a, armatures)) for a in actions if bone_channels(compat.all_action_fcurves(a))]
    owned = [(a, o) for a, o in owned if o is not None]
    pick = [o for a, o in owned if animation is None or animation_name(a, o, info) == animation]
    if not pick:
        raise ParseError("the file has no animation of an armature" if animation is None else
                         f"no animation {animation!r} in the file", path)
    for obj in armatures:
        if obj.animation_data is not None:
            obj.animation_data.action = None
    for action in actions:
        compat.remove_action(action)
    bpy.context.view_layer.update()
    return pick[0]
