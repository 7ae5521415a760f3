"""Characters as Blender's importers leave them, built by the tests from tests/data with Blender's own operators:
``turned`` makes a BVH import into an armature whose object is turned and scaled as the FBX importer leaves Mixamo
characters (or hangs from a turned empty, or is scaled), its world motion unchanged; ``world_heads`` reads the
pose heads in the world as Blender evaluates them (no package code)."""

import contextlib
import io
import math

import bpy
import numpy as np

from blender_shapesig import compat


def quiet(op, **kw):
    with contextlib.redirect_stdout(io.StringIO()):
        return op(**kw)


def import_bvh(path, name):
    quiet(bpy.ops.import_anim.bvh, filepath=str(path))
    arm = bpy.context.view_layer.objects.active
    arm.name = name
    arm.animation_data.action.name = name
    return arm


def select_only(obj):
    for o in bpy.context.view_layer.objects:
        o.select_set(False)
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj


def turned(path, name, how):
    """Blender's import of ``path`` made into a character whose world motion is the same but whose object carries
    a transform T: "fbx" (T = 90 degrees about X and scale 0.01, as Blender's FBX importer leaves Mixamo
    characters), "empty" (the same T on a parent empty, the armature object at the identity), "scaled" (T = scale
    2.5). The armature data gets T^-1 by Apply Transform; the root's location keys (in its bone's frame) are
    scaled by T's inverse scale, which Apply Transform does not do."""
    arm = import_bvh(path, name)
    turn, scale = {"fbx": (math.pi / 2, 0.01), "empty": (math.pi / 2, 0.01), "scaled": (0.0, 2.5)}[how]
    select_only(arm)
    arm.rotation_euler = (-turn, 0.0, 0.0)
    arm.scale = (1 / scale,) * 3
    quiet(bpy.ops.object.transform_apply, location=False, rotation=True, scale=True)
    scale_location_keys(arm.animation_data.action, 1 / scale)
    if how == "empty":
        empty = bpy.data.objects.new(f"{name}_parent", None)
        bpy.context.collection.objects.link(empty)
        empty.rotation_euler, empty.scale = (turn, 0.0, 0.0), (scale,) * 3
        arm.parent = empty
    else:
        arm.rotation_euler, arm.scale = (turn, 0.0, 0.0), (scale,) * 3
    bpy.context.view_layer.update()
    return arm


def scale_location_keys(action, factor):
    for fc in compat.all_action_fcurves(action):
        if fc.data_path.endswith(".location"):
            for k in fc.keyframe_points:
                k.co.y *= factor
                k.handle_left.y *= factor
                k.handle_right.y *= factor


def world_heads(arm, frames):
    """(frames, bones, 3): every pose bone's head in the world as Blender evaluates it (no package code)."""
    out = []
    scene = bpy.context.scene
    for f in frames:
        scene.frame_set(int(f))
        M = np.array(arm.matrix_world)
        out.append([(M @ np.append(np.array(pb.head), 1.0))[:3] for pb in arm.pose.bones])
    return np.array(out)
