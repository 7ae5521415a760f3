"""Result rows know their target: a row remembers the read hash of its action or the path, size and
time of its file at the search, and Assign, Preview, Blend and Why Different refuse in one line a target that
changed since (an action deleted and another renamed to its name, a file replaced), creating nothing."""

import shutil

import pytest

bpy = pytest.importorskip("bpy")

from blender_shapesig.search import library, results  # noqa: E402
from tests.helpers.blender_clips import BVH, import_bvh  # noqa: E402
from tests.helpers.operator_scene import cache_env, operator_error, rig  # noqa: E402,F401 - fixtures

CHANGED = "changed since the search; search again"


def _select(name):
    res = library.results_of(bpy.context)
    res.results_index = next(i for i, r in enumerate(res.results) if r.name == name)
    return res.results[res.results_index]


def test_an_action_replaced_under_its_name_is_refused(rig):
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    row = _select("run")
    assert row.target and row.target == results.read_hash(bpy.data.actions["run"])
    bpy.data.actions.remove(bpy.data.actions["run"])
    bpy.data.actions["jump"].name = "run"  # another motion under the ranked name
    actions = sorted(a.name for a in bpy.data.actions)
    active = rig.animation_data.action
    for op in (bpy.ops.shapesig.assign_result, bpy.ops.shapesig.preview_result, bpy.ops.shapesig.explain_result):
        assert CHANGED in operator_error(op) and "'run'" in operator_error(op)
    msg = operator_error(bpy.ops.shapesig.blend_actions, action_a="walk", action_b="run",
                         expect_b=results.expected_hash(row, "run"))
    assert CHANGED in msg
    assert sorted(a.name for a in bpy.data.actions) == actions and rig.animation_data.action == active
    assert not bpy.context.scene.shapesig.preview_object
    assert bpy.ops.shapesig.rank() == {"FINISHED"}  # searching again names the new "run"
    _select("run")
    assert bpy.ops.shapesig.assign_result() == {"FINISHED"} and rig.animation_data.action.name == "run"


def test_an_unchanged_action_row_still_assigns_and_blends(rig):
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    row = _select("walk2")
    expect = results.expected_hash(row, "walk2")
    assert bpy.ops.shapesig.blend_actions(action_a="walk", action_b="walk2", expect_b=expect,
                                          assign=False) == {"FINISHED"}
    assert bpy.ops.shapesig.assign_result() == {"FINISHED"} and rig.animation_data.action.name == "walk2"


def _folder_result(tmp_path):
    """The walk's armature, a folder library holding the take 07_02, Find Similar run and its row selected."""
    arm = import_bvh("07_01.bvh", "walk")
    lib = tmp_path / "lib"
    lib.mkdir()
    shutil.copy(BVH / "07_02.bvh", lib / "07_02.bvh")
    s = bpy.context.scene.shapesig
    s.use_file_actions, s.use_folders, s.folders, s.rerank, s.crop_start = False, True, str(lib), 0, 2
    bpy.context.view_layer.objects.active = arm
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    return arm, lib, _select("07_02")


def test_a_replaced_file_is_refused(empty_file, cache_env, tmp_path):  # noqa: F811
    arm, lib, row = _folder_result(tmp_path)
    assert row.target.endswith(f"|{(lib / '07_02.bvh').stat().st_size}|{(lib / '07_02.bvh').stat().st_mtime_ns}")
    shutil.copy(BVH / "09_02.bvh", lib / "07_02.bvh")  # another take put in its place
    actions = sorted(a.name for a in bpy.data.actions)
    for op in (bpy.ops.shapesig.assign_result, bpy.ops.shapesig.preview_result, bpy.ops.shapesig.explain_result):
        assert CHANGED in operator_error(op)
    assert sorted(a.name for a in bpy.data.actions) == actions and arm.animation_data.action.name == "walk"


def test_a_written_result_edited_since_is_refused(empty_file, cache_env, tmp_path):  # noqa: F811
    arm, _lib, row = _folder_result(tmp_path)
    assert bpy.ops.shapesig.assign_result() == {"FINISHED"}
    written = arm.animation_data.action
    assert row.is_action and row.source == written.name and results.expected_hash(row, written.name)
    bpy.data.actions.remove(written)
    stand_in = import_bvh("09_02.bvh", "x")  # another motion under the written action's name
    stand_in.animation_data.action.name = row.source
    bpy.context.view_layer.objects.active = arm
    assert CHANGED in operator_error(bpy.ops.shapesig.assign_result)
