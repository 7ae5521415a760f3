"""The FBX and glTF files of tests/blender/readers/test_interchange.py, written by Blender's own exporters from a real CMU
walk, in a process of their own (``python -m tests.helpers.interchange_files OUT``), so that no exporter's garbage
is left in the process that goes on testing (in Blender 4.2 such garbage, collected after its data was freed,
crashed later tests now and then)."""

import math
import os
import pathlib
import sys

import bpy

BVH = pathlib.Path(__file__).resolve().parents[1] / "data" / "bvh" / "07_01.bvh"
FRAMES = 90  # the first 90 frames (0.75 s at 120 fps) of the walk are exported


def _skinned_walk():
    """The BVH walk on its armature with a small cube skinned to it (so that the FBX exporter writes the bind
    pose: without one, Blender's FBX importer takes the pose of the export's current frame as the rest)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_anim.bvh(filepath=str(BVH), rotate_mode="NATIVE", frame_start=1, use_fps_scale=False,
                            update_scene_fps=True, update_scene_duration=True)
    arm = bpy.context.object
    scene = bpy.context.scene
    scene.render.fps, scene.render.fps_base = 120, 1.0
    scene.frame_start, scene.frame_end = 1, FRAMES
    scene.frame_set(1)
    mesh = bpy.data.meshes.new("cube")
    mesh.from_pydata([(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], [],
                     [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)])
    cube = bpy.data.objects.new("cube", mesh)
    scene.collection.objects.link(cube)
    cube.parent = arm
    cube.modifiers.new("rig", "ARMATURE").object = arm
    cube.vertex_groups.new(name="hip").add(list(range(8)), 1.0, "REPLACE")
    return arm


def _export_glb(path, arm):
    bpy.ops.object.select_all(action="DESELECT")
    bpy.ops.export_scene.gltf(filepath=str(path), export_format="GLB", export_animation_mode="ACTIONS",
                              export_force_sampling=True, export_optimize_animation_size=False,
                              export_frame_range=True)


def make_files(out):
    """walk.fbx (one take), walk.glb (two animations: 07_01 and its copy cut to 40 frames, walk_short) and
    tiny.glb (the walk under nested nodes: scales 0.01 x 0.1 and turns about X that cancel, Michelle's layout)."""
    out = pathlib.Path(out)
    arm = _skinned_walk()
    bpy.ops.export_scene.fbx(filepath=str(out / "walk.fbx"), object_types={"ARMATURE", "MESH"},
                             add_leaf_bones=False, bake_anim_use_all_actions=False, bake_anim_use_nla_strips=False,
                             bake_anim_simplify_factor=0.0)
    short = arm.animation_data.action.copy()
    short.name = "walk_short"
    short.use_frame_range, short.frame_start, short.frame_end = True, 1, 40
    arm.animation_data.nla_tracks.new().strips.new("walk_short", 1, short)
    _export_glb(out / "walk.glb", arm)
    arm.animation_data.nla_tracks.remove(arm.animation_data.nla_tracks[0])
    top = bpy.data.objects.new("Top", None)
    bpy.context.scene.collection.objects.link(top)
    top.rotation_euler, top.scale = (math.pi / 2, 0.0, 0.0), (0.01,) * 3
    arm.parent = top
    arm.rotation_euler, arm.scale = (-math.pi / 2, 0.0, 0.0), (0.1,) * 3
    _export_glb(out / "tiny.glb", arm)
    return out


if __name__ == "__main__":
    make_files(sys.argv[1])
    # the files are written and closed: leave without the interpreter's teardown, where Blender 4.2's bpy module
    # crashes after a glTF export (every time, here)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0)
