"""The mixed file of issue 31, built in headless Blender from tests/data: the CMU walk 07_01 imported by the add-on's
Acclaim importer (armature '07-walk', action '07_01', 120 fps recorded), and through Blender's own BVH importer at
its default settings the Daz-friendly 07_01 (action '07_01.001'), 09_02 and 02_03, the MotionBuilder 16_15 and the
iClone 002_03 (same take as 02_03, another skeleton); no rate is recorded for those. ``save_reopen`` saves and
reopens the file."""

import contextlib
import io
import pathlib

import bpy

DATA = pathlib.Path(__file__).resolve().parent.parent / "data"
BVHS = {"07_01.001": "bvh/07_01.bvh", "09_02": "bvh/09_02.bvh", "16_15": "acclaim/16_15.bvh",
        "02_03": "cross_rig/02_03.bvh", "002_03": "cross_rig/002_03.bvh"}
TRUE_FPS = {"07_01": 120.0, "07_01.001": 120.0, "09_02": 120.0, "16_15": 120.0, "02_03": 120.0, "002_03": 60.0}


def import_bvh_default(rel):
    """Blender's BVH importer at its default settings; returns the new armature."""
    try:
        bpy.ops.import_anim.bvh.get_rna_type()
    except (AttributeError, KeyError):
        import addon_utils

        addon_utils.enable("io_anim_bvh", default_set=False)
    with contextlib.redirect_stdout(io.StringIO()):
        bpy.ops.import_anim.bvh(filepath=str(DATA / rel))
    return bpy.context.view_layer.objects.active


def build(names=("07_01.001", "09_02", "16_15", "02_03", "002_03"), amc=(("07_01", "07-walk"),)):
    """The file: {action name: armature}; ``amc``: (take, skeleton) pairs imported by the add-on first. The scene
    stays at 24 fps."""
    out = {}
    for take, asf in amc:
        bpy.ops.shapesig.import_acclaim("EXEC_DEFAULT", filepath=str(DATA / "acclaim" / f"{take}.amc"),
                                        asf_path=str(DATA / "acclaim" / f"{asf}.asf"))
        arm = bpy.context.view_layer.objects.active
        out[arm.animation_data.action.name] = arm
    bpy.context.scene.render.fps, bpy.context.scene.render.fps_base = 24, 1.0
    for name in names:
        arm = import_bvh_default(BVHS[name])
        out[arm.animation_data.action.name] = arm
    assert set(names) <= set(out), sorted(out)
    return out


def one_frame_pose(arm, name="pose"):
    """A one-frame action keying every pose bone's rotation of ``arm`` (a pose-library pose), with a fake user."""
    act = bpy.data.actions.new(name)
    act.use_fake_user = True
    prev = arm.animation_data.action
    arm.animation_data.action = act
    for pb in arm.pose.bones:
        prop = "rotation_quaternion" if pb.rotation_mode == "QUATERNION" else "rotation_euler"
        pb.keyframe_insert(prop, frame=1)
    arm.animation_data.action = prev
    return act


def save_reopen(path):
    """Save to ``path`` and open it again (a fresh file in this process)."""
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    bpy.ops.wm.open_mainfile(filepath=str(path))


def activate(obj):
    for o in bpy.context.view_layer.objects:
        o.select_set(False)
    bpy.context.view_layer.objects.active = obj
    obj.select_set(True)
