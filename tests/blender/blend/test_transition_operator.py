"""shapesig.transition on real CMU clips imported with Blender's BVH importer (walk 07_01 on the active armature,
run 09_02 as a second action; and a Character Creator run at 60 fps on its own armature): one new action equal to
``core.blend.transition`` of the actions as read, the cut reported in scene frames, sources bit-identical, one undo
step, the previous action kept through save and reopen in a fresh process, refusals in one line creating nothing."""

import contextlib
import io
import json
import pathlib
import subprocess
import sys
import textwrap

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from blender_shapesig.actions.action_hashes import action_hash  # noqa: E402

from blender_shapesig.actions import action_io  # noqa: E402
from blender_shapesig.core.blend.transition import transition  # noqa: E402

DATA = pathlib.Path(__file__).resolve().parents[2] / "data"


def _import(path, action_name):
    with contextlib.redirect_stdout(io.StringIO()):
        bpy.ops.import_anim.bvh(filepath=str(path), rotate_mode="NATIVE", frame_start=1, use_fps_scale=False,
                                update_scene_fps=False, update_scene_duration=False)
    obj = bpy.context.view_layer.objects.active
    obj.animation_data.action.name = action_name
    return obj


@pytest.fixture
def rig(empty_file):
    bpy.context.scene.render.fps, bpy.context.scene.render.fps_base = 120, 1.0
    arm = _import(DATA / "bvh" / "07_01.bvh", "walk")
    other = _import(DATA / "bvh" / "09_02.bvh", "run")
    bpy.data.actions["run"].use_fake_user = True
    bpy.data.objects.remove(other)
    bpy.context.view_layer.objects.active = arm
    arm.select_set(True)
    return arm


def _hashes():
    return {act.name: action_hash(act) for act in bpy.data.actions}


def _read(name, arm):
    return action_io.read_action(bpy.data.actions[name], armature=arm, exclude_unkeyed=True, space="armature",
                                 fps=120.0)


def test_registered_as_one_undo_step_in_the_blend_menus(addon):
    assert bpy.types.SHAPESIG_OT_transition.bl_options == {"REGISTER", "UNDO"}
    from blender_shapesig.operators import transition as op_module

    assert op_module.menu_func in bpy.types.VIEW3D_MT_object_animation._dyn_ui_initialize()


def test_writes_the_core_transition_and_keeps_the_sources(rig):
    before = _hashes()
    walk, run = _read("walk", rig), _read("run", rig)
    result = bpy.ops.shapesig.transition(action_b="run", frames=24)
    assert result == {"FINISHED"}
    assert set(bpy.data.actions.keys()) == {"walk", "run", "walk_to_run"}
    assert {k: v for k, v in _hashes().items() if k in before} == before
    out = bpy.data.actions["walk_to_run"]
    assert rig.animation_data.action == out and out.use_fake_user
    expected = transition(walk, run, frames=24)
    got = _read("walk_to_run", rig)
    assert got.frames == expected.frames
    idx = [got.bones.index(b) for b in expected.bones]
    assert np.abs(got.rotations[:, idx] - expected.rotations).max() < 1e-4
    assert np.abs(got.root_translation - expected.root_translation).max() < 1e-3


def test_a_chosen_cut_in_scene_frames_and_undo(rig):
    bpy.ops.ed.undo_push(message="before transition")
    names = sorted(bpy.data.actions.keys())
    walk, run = _read("walk", rig), _read("run", rig)
    result = bpy.ops.shapesig.transition("EXEC_DEFAULT", True, action_b="run", best_cut=False,
                                         frame_a=walk.frame_start + 150, frame_b=run.frame_start + 30, frames=10)
    assert result == {"FINISHED"}
    got = _read("walk_to_run", rig)
    assert got.frames == 151 + 10 + run.frames - 30
    bpy.ops.ed.undo()
    assert sorted(bpy.data.actions.keys()) == names
    assert bpy.context.view_layer.objects.active.animation_data.action.name == "walk"


def test_across_rigs_and_rates_saved_and_reopened(rig, tmp_path):
    cc = _import(DATA / "cross_rig" / "002_03.bvh", "cc_run")
    bpy.data.actions["cc_run"].use_fake_user = True
    bpy.context.view_layer.objects.active = rig
    result = bpy.ops.shapesig.transition("EXEC_DEFAULT", action_b="cc_run", frames=20)
    assert result == {"FINISHED"}
    assert rig.animation_data.action.name == "walk_to_cc_run"
    assert cc.animation_data.action.name == "cc_run"
    path = tmp_path / "t.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    code = textwrap.dedent(f"""
        import bpy, json
        bpy.ops.wm.open_mainfile(filepath={str(path)!r})
        act = bpy.data.actions["walk_to_cc_run"]
        walk = bpy.data.actions["walk"]
        print(json.dumps({{"range": list(act.frame_range), "walk_users": walk.users + int(walk.use_fake_user)}}))
    """)
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    got = json.loads(p.stdout.strip().splitlines()[-1])
    assert got["range"][1] - got["range"][0] + 1 == _read("walk_to_cc_run", rig).frames
    assert got["walk_users"] >= 1  # the previous action is never left without users


@pytest.mark.parametrize("kw,match", [
    (dict(action_b="nope"), "no action named 'nope'"),
    (dict(action_b="walk"), "same action"),
    (dict(action_b="run", best_cut=False, frame_a=1, frame_b=9999), "outside 'run'"),
])
def test_refusals_are_one_line_and_create_nothing(rig, kw, match):
    names = sorted(bpy.data.actions.keys())
    with pytest.raises(RuntimeError, match=match):
        bpy.ops.shapesig.transition(**kw)
    assert sorted(bpy.data.actions.keys()) == names


def test_poll_says_why(empty_file):
    assert not bpy.ops.shapesig.transition.poll()


def test_dialog_lists_the_ranked_places(rig):
    """The dialog's ranking (invoke) holds the five best places of the chosen action in scene frames, best first,
    and presets the frames to the first (the cut ``core.blend.transition.best_cuts`` finds)."""
    from blender_shapesig.core.blend.transition import best_cuts
    from blender_shapesig.operators.transition import SHAPESIG_OT_transition

    class Op:  # the operator's own methods on a stand-in for its properties
        action_b, cuts_for, frame_a, frame_b = "run", "", 0, 0

    op = Op()
    SHAPESIG_OT_transition._rank(op, rig, bpy.data.actions["walk"])
    parts = op.cuts_for.split("\t")
    assert parts[0] == "run" and len(parts) == 6
    walk, run = _read("walk", rig), _read("run", rig)
    first = best_cuts(walk, run)[0]
    assert (op.frame_a, op.frame_b) == (first.a_frame + walk.frame_start, first.b_frame + run.frame_start)
    costs = [float(p.split(":")[2]) for p in parts[1:]]
    assert costs == sorted(costs)
