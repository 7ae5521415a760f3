"""The Blend dialog for animators, headless on real CMU clips imported with Blender's BVH importer:
A/B frame ranges, more actions with weights, loops, planted feet, masks, editable timing (an NLA strip with
animated Strip Time) and its bake; sources untouched, nothing orphaned through save and a fresh process, bad input
refused in one line creating nothing."""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from blender_shapesig import compat  # noqa: E402
from blender_shapesig.actions import action_io  # noqa: E402
from blender_shapesig.blend.blend_actions import TIMING_TRACK, timed_strips  # noqa: E402
from blender_shapesig.core.blend import pose_steps  # noqa: E402
from blender_shapesig.core.geometry import so3  # noqa: E402
from tests.helpers.blender_clips import angle, buffer_hash, import_bvh, read_keyed, reopen_hashes  # noqa: E402
from tests.helpers.fake_layout import FakeLayout  # noqa: E402


@pytest.fixture
def rig(empty_file):
    """The walk 07_01's armature (active action 'walk'), and the actions 'run' (09_02) and 'walk2' (07_02) of
    the same skeleton (their armatures deleted; fake users), in a 120 fps scene."""
    bpy.context.scene.render.fps = 120  # the clips' rate (the importer leaves the scene's alone)
    arm = import_bvh("07_01.bvh", "walk")
    for file, name in (("09_02.bvh", "run"), ("07_02.bvh", "walk2")):
        other = import_bvh(file, name)
        bpy.data.actions[name].use_fake_user = True
        bpy.data.objects.remove(other)
    bpy.context.view_layer.objects.active = arm
    arm.select_set(True)
    return arm


def _hashes():
    return {a: buffer_hash(bpy.data.actions[a]) for a in ("walk", "run", "walk2")}


def test_ranges_and_planted_feet(rig):
    before = _hashes()
    # one stride each (the AMC strides 125-253 and 36-126; the BVH numbers frames from 1 with a rest frame first)
    assert bpy.ops.shapesig.blend_actions(action_a="walk", action_b="run", weight=0.5, range_a=(126, 254),
                                          range_b=(37, 127)) == {"FINISHED"}
    out = bpy.data.actions["walk_x_run_0.50"]
    assert out.use_fake_user and _hashes() == before
    assert tuple(out.frame_range) == (126.0, 126.0 + round(0.5 * 128 + 0.5 * 90))
    got = read_keyed("walk_x_run_0.50", rig)
    unplanted = rig.animation_data.action
    assert unplanted == out
    assert bpy.ops.shapesig.blend_actions(action_a="walk", action_b="run", weight=0.5, range_a=(126, 254),
                                          range_b=(37, 127), feet="NONE") == {"FINISHED"}
    free = read_keyed("walk_x_run_0.50_2", rig)
    legs = [got.bones.index(b) for b in ("lShin", "rShin")]
    arms = [got.bones.index(b) for b in ("lForeArm", "rForeArm")]
    assert angle(got.rotations[:, legs], free.rotations[:, legs]) > 0.05  # the knees work to plant the feet
    assert angle(got.rotations[:, arms], free.rotations[:, arms]) < 1e-5  # the arms are the blend's


def test_three_actions(rig):
    before = _hashes()
    assert bpy.ops.shapesig.blend_actions(action_a="walk", action_b="run", weight=0.0, extra="walk2=0",
                                          feet="NONE") == {"FINISHED"}
    name = "walk_x_run_x_walk2_1.00_0.00_0.00"
    walk = read_keyed("walk", rig)
    got = read_keyed(name, rig)
    assert got.frames == walk.frames and angle(got.rotations, walk.rotations) < 1e-5
    third = 1 / 3
    for b, c in (("run", "walk2"), ("walk2", "run")):
        assert bpy.ops.shapesig.blend_actions(action_a="walk", action_b=b, weight=third, extra=f"{c}={third}",
                                              assign=False) == {"FINISHED"}
    x = read_keyed("walk_x_run_x_walk2_0.33_0.33_0.33", rig)
    y = read_keyed("walk_x_walk2_x_run_0.33_0.33_0.33", rig)
    assert x.frames == y.frames and angle(x.rotations, y.rotations) < 1e-4  # float32 keys
    assert _hashes() == before


def test_loop(rig):
    # the ranges leave out the BVH conversion's rest frame and ramp (frames 1-6)
    assert bpy.ops.shapesig.blend_actions(action_a="walk", action_b="run", weight=0.5, loop=True, range_a=(7, 317),
                                          range_b=(7, 131)) == {"FINISHED"}
    got = read_keyed("walk_x_run_0.50", rig)
    R = got.rotations
    assert angle(R[-1], R[0]) < 1e-4
    steps = pose_steps(R[:-1])
    assert pose_steps(np.stack([R[-2], R[0]]))[0] <= np.median(steps)


def _foot_period(clip):
    """Frames of one gait cycle from the feet alone (apart from the cycle finder): the lag at which both feet's
    heights repeat best, 0.4 s up to the clip's length less 0.3 s."""
    from blender_shapesig.core.clip.skeleton import forward_kinematics, up_vector

    heads, _tails, _w = forward_kinematics(clip)
    z = heads[:, [clip.bones.index("lFoot"), clip.bones.index("rFoot")]] @ up_vector(clip)
    lags = np.arange(int(0.4 * clip.fps), clip.frames - int(0.3 * clip.fps))
    return int(lags[np.argmin([np.mean((z[lag:] - z[:-lag]) ** 2) for lag in lags])])


def _joint_steps(R):
    """Per frame step and joint, the rotation angle (radians)."""
    return np.linalg.norm(so3.log(R[1:] @ np.swapaxes(R[:-1], -1, -2)), axis=-1)


def test_loop_of_exactly_one_stride_each(rig):
    """A and B cropped by their ranges to exactly one stride (the period of the feet, found apart): Loop takes each
    range whole as its cycle (it used to find no cycle in a clip of one) and the seam steps no more than the
    sources' largest joint step + 5 degrees (issue 38)."""
    walk, run = read_keyed("walk", rig), read_keyed("run", rig)
    pa, pb = _foot_period(walk), _foot_period(run)
    assert 125 <= pa <= 135 and 85 <= pb <= 95
    ra, rb = (100, 100 + pa), (20, 20 + pb)
    assert bpy.ops.shapesig.blend_actions(action_a="walk", action_b="run", weight=0.5, loop=True, range_a=ra,
                                          range_b=rb) == {"FINISHED"}
    got = read_keyed("walk_x_run_0.50", rig)
    R = got.rotations
    assert angle(R[-1], R[0]) < 1e-4 and got.frames - 1 == round(0.5 * pa + 0.5 * pb)  # both strides whole
    largest = max(_joint_steps(c.crop(*r).rotations).max() for c, r in ((walk, ra), (run, rb)))
    seam = np.linalg.norm(so3.log(R[0] @ np.swapaxes(R[-2], -1, -2)), axis=-1).max()
    assert seam <= largest + np.radians(5.0)
    assert pose_steps(np.stack([R[-2], R[0]]))[0] <= np.median(pose_steps(R[:-1]))


def test_mask_keeps_the_legs_of_a(rig):
    assert bpy.ops.shapesig.blend_actions(action_a="walk", action_b="run", weight=1.0, mask="legs=0",
                                          feet="NONE", align=False) == {"FINISHED"}
    walk, got = read_keyed("walk", rig), read_keyed("walk_x_run_1.00", rig)
    assert got.frames == walk.frames  # the timing follows the legs
    legs = [walk.bones.index(b) for b in ("lThigh", "lShin", "rThigh", "rShin")]
    assert angle(got.rotations[:, legs], walk.rotations[:, legs]) < 1e-5
    j = walk.bones.index("rForeArm")
    assert angle(got.rotations[:, j], walk.rotations[:, j]) > 0.05


def test_editable_timing_strip_bake_and_save(rig, tmp_path):
    before = _hashes()
    walk = bpy.data.actions["walk"]
    assert bpy.ops.shapesig.blend_actions("EXEC_DEFAULT", True, action_a="walk", action_b="run", weight=0.5,
                                          range_a=(126, 254), range_b=(37, 127), timing="NLA") == {"FINISHED"}
    ad = rig.animation_data
    assert ad.action is None  # the strip plays
    strips = timed_strips(rig)
    assert len(strips) == 1 and strips[0].action.name == "walk_x_run_0.50"
    track = [t for t in ad.nla_tracks if t.name == TIMING_TRACK]
    assert len(track) == 1
    fc = strips[0].fcurves.find("strip_time")
    assert fc is not None and 2 < len(fc.keyframe_points) < 200  # one key per warp node: something to nudge
    stash = [t for t in ad.nla_tracks if t.name == compat.STASH_TRACK]
    assert stash and stash[0].strips[0].action == walk  # the replaced active action is kept
    # bake the unedited clock: the baked blend, up to one more geodesic resampling
    assert bpy.ops.shapesig.bake_blend_timing() == {"FINISHED"}
    baked = read_keyed("walk_x_run_0.50_baked", rig)
    assert bpy.ops.shapesig.blend_actions(action_a="walk", action_b="run", weight=0.5, range_a=(126, 254),
                                          range_b=(37, 127), assign=False) == {"FINISHED"}
    direct = read_keyed("walk_x_run_0.50_2", rig)
    assert baked.frames == direct.frames and baked.frame_start == direct.frame_start
    err = np.linalg.norm(baked.rotations - direct.rotations, axis=(-2, -1))
    assert np.median(err) < 2e-3 and np.median(pose_steps(direct.rotations)) > 5 * np.median(err)
    # nudge the clock: the bake follows it
    keys = fc.keyframe_points
    k = len(keys) // 2
    keys[k].co.y += 3.0
    fc.update()
    assert bpy.ops.shapesig.bake_blend_timing() == {"FINISHED"}
    nudged = read_keyed("walk_x_run_0.50_baked_2", rig)
    assert angle(nudged.rotations, baked.rotations) > 0.02
    assert _hashes() == before
    # save, reopen in a fresh process: every action is there, the sources unchanged
    names = {a.name for a in bpy.data.actions}
    path = tmp_path / "timed.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    after = reopen_hashes(path)
    assert set(after) == names
    for name, digest in before.items():
        assert after[name] == digest


def test_bake_needs_a_timed_strip(rig):
    assert not bpy.ops.shapesig.bake_blend_timing.poll()


@pytest.mark.parametrize("kw,message", [
    (dict(extra="nope=0.2"), "no action named 'nope'"),
    (dict(extra="walk2"), "NAME=WEIGHT"),
    (dict(extra="walk2=0.8"), "more than 1"),
    (dict(extra="walk2=0.1", inbetweens=2), "In-betweens to 1"),
    (dict(extra="run=0.1"), "chosen twice"),
    (dict(mask="legs=2"), "mask weight"),
    (dict(mask="wings=1"), "no group"),
    (dict(range_a=(500, 600)), "outside"),
    (dict(range_b=(40, 30)), "must end after"),
    (dict(loop=True, timing="NLA"), "written baked"),
])
def test_bad_input_is_refused_creating_nothing(rig, kw, message):
    names = sorted(a.name for a in bpy.data.actions)
    tracks = len(rig.animation_data.nla_tracks)
    with pytest.raises(RuntimeError, match=message):
        bpy.ops.shapesig.blend_actions(action_a="walk", action_b="run", weight=0.5, **kw)
    assert sorted(a.name for a in bpy.data.actions) == names
    assert len(rig.animation_data.nla_tracks) == tracks and rig.animation_data.action.name == "walk"


def _dialog(**props):
    """A stand-in for the dialog's operator: every property at its default (or ``props``) and the methods draw
    calls, with a recording layout."""
    from types import SimpleNamespace

    from blender_shapesig.operators.blend import SHAPESIG_OT_blend_actions as Op
    values = {k: v.keywords.get("default", "") for k, v in Op.__annotations__.items()}
    values.update(props, layout=FakeLayout())
    op = SimpleNamespace(**values)
    op._strides_note = lambda: Op._strides_note(op)
    op._default_strides = lambda obj: Op._default_strides(op, obj)
    return Op, op


def test_cyclic_actions_default_to_one_stride(rig):
    """Walk x run: the dialog opens with one stride of each (cycles found after the converter's rest frame and ramp,
    B at A's phase), says so in one line, and blends them (the same as those ranges given by hand); the ranges are
    fields to change; the same ranges left for other actions are not used."""
    from blender_shapesig.blend.blend_actions import stride_ranges

    from types import SimpleNamespace

    Op, op = _dialog(action_b="run")  # A: the armature's action
    opened = []
    wm = SimpleNamespace(invoke_props_dialog=lambda o, width: opened.append(o) or {"RUNNING_MODAL"})
    assert Op.invoke(op, SimpleNamespace(active_object=rig, window_manager=wm), None) == {"RUNNING_MODAL"}
    assert opened == [op] and op.action_a == "walk"
    (a0, a1), (b0, b1), strides_for = tuple(op.range_a), tuple(op.range_b), op.strides_for
    assert 7 <= a0 < a1 and 7 <= b0 < b1
    walk, run = read_keyed("walk", rig), read_keyed("run", rig)
    for clip, (s, e) in ((walk, (a0, a1)), (run, (b0, b1))):
        seconds = (e - s) / clip.fps
        assert 0.6 <= seconds <= 1.3  # a stride of a walk or a run (two steps)
        R = clip.rotations
        i, j, h = s - clip.frame_start, e - clip.frame_start, (s + e) // 2 - clip.frame_start
        assert angle(R[i], R[j]) < 0.5 * angle(R[i], R[h])  # a cycle: it ends where it starts
    Op.draw(op, bpy.context)
    assert "One stride of each" in op.layout.labels()
    # OK in the dialog: the blend of those strides (headless Blender runs no invoke: the dialog's values are given)
    assert bpy.ops.shapesig.blend_actions(action_a="walk", action_b="run", weight=0.5, range_a=(a0, a1),
                                          range_b=(b0, b1), strides_for=strides_for) == {"FINISHED"}
    assert bpy.ops.shapesig.blend_actions(action_a="walk", action_b="run", weight=0.5, range_a=(a0, a1),
                                          range_b=(b0, b1)) == {"FINISHED"}
    by_dialog, by_hand = read_keyed("walk_x_run_0.50", rig), read_keyed("walk_x_run_0.50_2", rig)
    assert by_dialog.frames == by_hand.frames == round(0.5 * (a1 - a0) + 0.5 * (b1 - b0)) + 1
    assert angle(by_dialog.rotations, by_hand.rotations) < 1e-6
    # ranges given (or Loop) are left alone; the strides found for walk x run are not used for walk x walk2
    _, op = _dialog(action_a="walk", action_b="run", range_a=(10, 200))
    op._default_strides(rig)
    assert tuple(op.range_b) == (0, 0)
    Op, op = _dialog(action_a="walk", action_b="walk2", range_a=(a0, a1), range_b=(b0, b1), strides_for=strides_for)
    Op.draw(op, bpy.context)
    assert "found for walk and run" in op.layout.labels()
    assert bpy.ops.shapesig.blend_actions(action_a="walk", action_b="walk2", weight=0.5, range_a=(a0, a1),
                                          range_b=(b0, b1), strides_for=strides_for, feet="NONE") == {"FINISHED"}
    whole = read_keyed("walk_x_walk2_0.50", rig)
    assert whole.frames > 250  # whole actions (317 and 330 frames), not the strides
    # a pose (one frame) shows no cycle: whole actions
    action_io.write_action(walk.crop(50, 50), armature=rig, name="pose").use_fake_user = True
    assert stride_ranges(rig, bpy.data.actions["walk"], bpy.data.actions["pose"]) is None
