"""The demo's blend (tools/demo.py: walk 07_01 and run 09_02 from the Daz-friendly BVH files, trimmed by
``trim_action``, blended by shapesig.blend_actions) starts in motion, not in the files' rest pose (a
T-pose that snapped into the walk, 43-46 degrees between frames 2 and 4)."""

import importlib.util
import pathlib

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from blender_shapesig.actions import action_io  # noqa: E402
from blender_shapesig.core.geometry import so3  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[3]
BVH = ROOT / "tests" / "data" / "bvh"
_spec = importlib.util.spec_from_file_location("shapesig_demo", ROOT / "tools" / "demo.py")
demo = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(demo)

HEAD = 12  # frames checked at the start of the blend
MAX_STEP_DEG = 10.0  # a walk's largest step between frames at 120 fps is a few degrees


def _import(name, trim):
    from blender_shapesig.readers.bvh import import_armature

    arm, frame_time = import_armature(BVH / f"{name}.bvh")
    action = arm.animation_data.action
    action.name = name
    kept = demo.trim_action(action, arm, round(1.0 / frame_time, 3)) if trim else None
    return arm, kept


def _largest_steps(action, arm):
    """Largest rotation step (degrees) over the bones between consecutive frames, per frame interval."""
    clip = action_io.read_action(action, armature=arm, exclude_unkeyed=True)
    steps = np.linalg.norm(so3.relative_rotvecs(clip.rotations), axis=-1)
    return np.degrees(steps.max(axis=1))


def _blend(trim):
    # the scene at the clips' 120 fps: the blend is keyed at the scene's rate, and a walk's steps between frames
    # are a few degrees at 120 fps (five times that at 24)
    bpy.context.scene.render.fps = 120
    walk, kept = _import("07_01", trim)
    run, _ = _import("09_02", trim)
    bpy.context.view_layer.objects.active = walk
    before = set(bpy.data.actions)
    assert bpy.ops.shapesig.blend_actions(action_a="07_01", action_b="09_02", weight=0.5, align=True,
                                          assign=True) == {"FINISHED"}
    (out,) = [a for a in bpy.data.actions if a not in before]
    return _largest_steps(out, walk), kept


def test_the_demo_blend_starts_in_motion(empty_file):
    steps, kept = _blend(trim=True)
    assert kept == (9, 317)  # the rest pose, the ramp and three fast frames (tests/blender/search/test_time_base_bvh.py)
    assert steps[:HEAD].max() < MAX_STEP_DEG, steps[:HEAD]


def test_untrimmed_sources_start_in_the_rest_pose(empty_file):
    """The control: the same blend of the files as imported snaps from the rest pose into the motion."""
    steps, _ = _blend(trim=False)
    assert steps[:HEAD].max() > MAX_STEP_DEG, steps[:HEAD]
