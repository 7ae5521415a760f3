"""shapesig.blend_actions on real CMU clips imported with Blender's BVH importer (walk 07_01, run 09_02):
names, frames and keys of the written actions, their content against core.blend, sources untouched
(F-curve buffers hashed with foreach_get), one undo step, clean errors."""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from blender_shapesig import compat  # noqa: E402
from blender_shapesig.actions import action_io  # noqa: E402
from blender_shapesig.core.blend import blend_clips, default_frames  # noqa: E402
from blender_shapesig.core.blend.feet import lock_feet  # noqa: E402
from tests.helpers.blender_clips import (action_fcurves, angle, buffer_hash, read_keyed,  # noqa: E402
                                         reopen_hashes, walk_with_run)


@pytest.fixture
def rig(empty_file):
    """The walk's armature (active, action 'walk') and a second action 'run' (from the run's import,
    whose armature is deleted; the action keeps a fake user)."""
    return walk_with_run()


def test_operator_is_registered_as_one_undo_step(addon):
    op = bpy.ops.shapesig.blend_actions.get_rna_type()
    cls = bpy.types.SHAPESIG_OT_blend_actions
    assert op.identifier == "SHAPESIG_OT_blend_actions"
    assert cls.bl_options == {"REGISTER", "UNDO"}


def test_blend_writes_a_new_action(rig):
    arm = rig
    before = {a.name: buffer_hash(a) for a in bpy.data.actions}
    result = bpy.ops.shapesig.blend_actions(action_a="walk", action_b="run", weight=0.5)
    assert result == {"FINISHED"}
    assert {a.name for a in bpy.data.actions} == {"walk", "run", "walk_x_run_0.50"}
    out = bpy.data.actions["walk_x_run_0.50"]
    assert out.use_fake_user
    assert arm.animation_data.action == out
    # Sources are bit-identical.
    assert {a: buffer_hash(bpy.data.actions[a]) for a in ("walk", "run")} == before

    walk, run = read_keyed("walk", arm), read_keyed("run", arm)
    n = default_frames(walk.frames, run.frames, 0.5)
    assert n == 224  # (317 + 131) / 2
    fcs = action_fcurves(out)
    # One F-curve per rotation channel of every bone of the walk, plus the root's location.
    n_rot = sum(4 if m in ("QUATERNION", "AXIS_ANGLE") else 3 for m in walk.rotation_modes)
    assert len(fcs) == n_rot + 3
    for fc in fcs:
        assert len(fc.keyframe_points) == n
        co = np.empty(2 * n, dtype=np.float32)
        fc.keyframe_points.foreach_get("co", co)
        assert np.array_equal(co[0::2], np.arange(1, n + 1, dtype=np.float32))

    # Content: the core blend of the two actions as read, feet planted by default (float32 keys: ~1e-6).
    expected, _report = lock_feet(blend_clips(walk, run, 0.5, up_axis=_up(arm, walk.root_bone)), [walk, run])
    got = read_keyed("walk_x_run_0.50", arm)
    assert got.bones == expected.bones
    assert angle(got.rotations, expected.rotations) < 1e-5
    assert np.abs(got.root_translation - expected.root_translation).max() < 1e-3


def _up(arm, bone):
    from blender_shapesig.actions.action_spaces import up_in_bone_frame

    return up_in_bone_frame(arm, bone)


def test_weight_zero_and_one_reproduce_the_sources(rig):
    arm = rig
    assert bpy.ops.shapesig.blend_actions(action_a="walk", action_b="run", weight=0.0) == {"FINISHED"}
    assert bpy.ops.shapesig.blend_actions(action_a="walk", action_b="run", weight=1.0) == {"FINISHED"}
    walk, run = read_keyed("walk", arm), read_keyed("run", arm)
    w0, w1 = read_keyed("walk_x_run_0.00", arm), read_keyed("walk_x_run_1.00", arm)
    assert w0.frames == walk.frames and w1.frames == run.frames
    assert angle(w0.rotations, walk.rotations) < 1e-5
    assert angle(w1.rotations, run.rotations) < 1e-5
    assert np.abs(w0.root_translation - walk.root_translation).max() < 1e-3
    assert np.abs(w1.root_translation - run.root_translation).max() < 1e-3


def test_blend_actions_progress_counts_blends_and_writes_and_a_cancel_creates_nothing(rig):
    """``progress(done, total)``: one call per blend, then one per written action; True cancels (Cancelled) and
    removes what was written."""
    from blender_shapesig.blend.blend_actions import blend_actions
    from blender_shapesig.core.errors import Cancelled

    arm, walk, run = rig, bpy.data.actions["walk"], bpy.data.actions["run"]
    calls = []
    result = blend_actions(arm, walk, run, [0.25, 0.75], frames=40, progress=lambda d, t: calls.append((d, t)))
    assert calls == [(1, 4), (2, 4), (3, 4), (4, 4)] and len(result.actions) == 2
    names = {a.name for a in bpy.data.actions}
    for stop in (1, 3):  # while blending, after the first action is written
        calls = []
        with pytest.raises(Cancelled):
            blend_actions(arm, walk, run, [0.25, 0.75], frames=40,
                          progress=lambda d, t: calls.append((d, t)) or d >= stop)
        assert calls[-1] == (stop, 4) and len(calls) == stop
        assert {a.name for a in bpy.data.actions} == names
    assert arm.animation_data.action == walk


def test_inbetweens_length_and_names(rig):
    arm = rig
    result = bpy.ops.shapesig.blend_actions(action_a="walk", action_b="run", inbetweens=3, frames=120,
                                            assign=False)
    assert result == {"FINISHED"}
    names = ["walk_x_run_0.25", "walk_x_run_0.50", "walk_x_run_0.75"]
    for name in names:
        act = bpy.data.actions[name]
        assert act.use_fake_user
        assert {len(fc.keyframe_points) for fc in action_fcurves(act)} == {120}
        assert tuple(act.frame_range) == (1.0, 120.0)
    assert arm.animation_data.action.name == "walk"
    # Again: names are kept unique without Blender's ".001" mangling of "0.50".
    assert bpy.ops.shapesig.blend_actions(action_a="walk", action_b="run", weight=0.5) == {"FINISHED"}
    assert "walk_x_run_0.50_2" in bpy.data.actions
    assert arm.animation_data.action.name == "walk_x_run_0.50_2"


def test_bone_list_blends_only_the_subset(rig):
    arm = rig
    upper = ["abdomen", "chest", "lShldr", "rShldr", "lForeArm", "rForeArm"]
    result = bpy.ops.shapesig.blend_actions(action_a="walk", action_b="run", weight=0.5,
                                            bone_subset="LIST", bone_list=", ".join(upper))
    assert result == {"FINISHED"}
    walk, run = read_keyed("walk", arm), read_keyed("run", arm)
    expected, _report = lock_feet(blend_clips(walk, run, 0.5, bones=upper, up_axis=_up(arm, walk.root_bone)),
                                  [walk, run])
    got = read_keyed("walk_x_run_0.50", arm)
    assert angle(got.rotations, expected.rotations) < 1e-5
    # A lower-body bone is the walk's own motion in the blended timing, not the full blend.
    full = blend_clips(walk, run, 0.5, up_axis=_up(arm, walk.root_bone))
    j = walk.bones.index("lThigh")
    assert angle(got.rotations[:, j], full.rotations[:, j]) > 0.05


def test_undo_restores_the_file(rig):
    arm_name = rig.name
    bpy.ops.ed.undo_push(message="before blend")
    before = sorted(a.name for a in bpy.data.actions)
    hashes = {a: buffer_hash(bpy.data.actions[a]) for a in ("walk", "run")}
    # Python calls push an undo step only when asked (the UI does it for UNDO operators).
    result = bpy.ops.shapesig.blend_actions("EXEC_DEFAULT", True, action_a="walk", action_b="run",
                                            inbetweens=2)
    assert result == {"FINISHED"}
    assert len(bpy.data.actions) == 4
    bpy.ops.ed.undo()  # one step
    assert sorted(a.name for a in bpy.data.actions) == before
    assert bpy.data.objects[arm_name].animation_data.action.name == "walk"
    assert {a: buffer_hash(bpy.data.actions[a]) for a in ("walk", "run")} == hashes
    bpy.ops.ed.redo()
    assert "walk_x_run_0.67" in bpy.data.actions


def _assert_fails(match, **kw):
    names = sorted(a.name for a in bpy.data.actions)
    with pytest.raises(RuntimeError, match=match):
        bpy.ops.shapesig.blend_actions(**kw)
    assert sorted(a.name for a in bpy.data.actions) == names


def test_errors_report_cleanly_and_create_nothing(rig):
    arm = rig
    hashes = {a: buffer_hash(bpy.data.actions[a]) for a in ("walk", "run")}
    _assert_fails("same action", action_a="walk", action_b="walk")
    _assert_fails("no action named 'nope'", action_a="walk", action_b="nope")
    _assert_fails("choose two actions", action_a="walk", action_b="")
    _assert_fails("not animated in both", action_a="walk", action_b="run", bone_subset="LIST",
                  bone_list="chest, tail")
    for pb in arm.pose.bones:  # 5.0: PoseBone.select; 4.2: Bone.select
        if "select" in pb.bl_rna.properties:
            pb.select = False
        else:
            pb.bone.select = False
    _assert_fails("no pose bones are selected", action_a="walk", action_b="run", bone_subset="SELECTED")
    # Two actions that animate disjoint bones.
    arm.animation_data.action = None
    arm.pose.bones["head"].keyframe_insert("rotation_euler", frame=1)
    arm.pose.bones["head"].keyframe_insert("rotation_euler", frame=5)
    only_head = arm.animation_data.action
    only_head.name = "only_head"
    arm.animation_data.action = None
    arm.pose.bones["lHand"].keyframe_insert("rotation_euler", frame=1)
    arm.pose.bones["lHand"].keyframe_insert("rotation_euler", frame=5)
    arm.animation_data.action.name = "only_hand"
    _assert_fails("share no bones", action_a="only_head", action_b="only_hand")
    # No armature.
    bpy.context.view_layer.objects.active = None
    _assert_fails("must be an armature", action_a="walk", action_b="run")
    assert {a: buffer_hash(bpy.data.actions[a]) for a in ("walk", "run")} == hashes


def test_selected_pose_bones_subset(rig):
    arm = rig
    chosen = {"chest", "lShldr", "rShldr"}
    for pb in arm.pose.bones:
        sel = pb.name in chosen
        if "select" in pb.bl_rna.properties:
            pb.select = sel
        else:
            pb.bone.select = sel
    result = bpy.ops.shapesig.blend_actions(action_a="walk", action_b="run", weight=0.4,
                                            bone_subset="SELECTED", align=False)
    assert result == {"FINISHED"}
    walk, run = read_keyed("walk", arm), read_keyed("run", arm)
    expected, _report = lock_feet(blend_clips(walk, run, 0.4, align=False, bones=sorted(chosen),
                                              up_axis=_up(arm, walk.root_bone)), [walk, run])
    got = read_keyed("walk_x_run_0.40", arm)
    assert angle(got.rotations, expected.rotations) < 1e-5


# ------------------------------------------------------------ animator safety: never orphan an action

def test_blend_assign_keeps_the_previous_action_through_save_and_reopen(rig, tmp_path):
    walk = bpy.data.actions["walk"]
    assert walk.users == 1 and not walk.use_fake_user  # only the armature uses it: assigning would orphan it
    before = {a.name: buffer_hash(a) for a in bpy.data.actions}
    bpy.ops.shapesig.blend_actions("EXEC_DEFAULT", action_a="walk", action_b="run", weight=0.5, align=False,
                                   assign=True)
    assert rig.animation_data.action.name.startswith("walk_x_run")
    tracks = [t for t in rig.animation_data.nla_tracks if t.name == compat.STASH_TRACK]
    assert len(tracks) == 1 and tracks[0].mute and tracks[0].strips[0].action == walk
    path = tmp_path / "kept.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    after = reopen_hashes(path)
    for name, digest in before.items():
        assert after.get(name) == digest, name
    assert len(after) == len(before) + 1


def test_assign_does_not_stash_an_action_that_has_other_users(rig):
    walk = bpy.data.actions["walk"]
    walk.use_fake_user = True
    clip = action_io.read_action(bpy.data.actions["run"], armature=rig)
    action_io.write_action(clip, rig, name="copy", assign=True)
    assert not any(t.name == compat.STASH_TRACK for t in rig.animation_data.nla_tracks)
    # assigning back and forth stashes nothing twice
    walk.use_fake_user = False
    action_io.assign_action(rig, walk)
    action_io.assign_action(rig, bpy.data.actions["copy"])
    action_io.assign_action(rig, walk)
    action_io.assign_action(rig, bpy.data.actions["copy"])
    stashed = [s.action.name for t in rig.animation_data.nla_tracks for s in t.strips]
    assert stashed == ["walk"]
