"""shapesig.transition across rigs and rates in a 24 fps scene: a CMU ASF/AMC walk imported by the add-on's
importer hands over to a Character Creator run (BVH, 60 fps) on an armature turned as Blender's FBX importer leaves
Mixamo characters (``turned_characters.turned``). Measured with Blender's own evaluation (pose heads in the world by
``scene.frame_set``): the new action plays the joined clip's true duration at the scene's rate, its root does not
snap at either seam, the sources are unchanged, one undo step takes it all back, and a fresh Blender process that
reopens the saved file evaluates the same world motion."""

import json
import pathlib
import subprocess
import sys
import textwrap

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from blender_shapesig.actions.action_hashes import action_hash  # noqa: E402

from blender_shapesig import compat  # noqa: E402
from blender_shapesig.blend import transitions  # noqa: E402
from tests.helpers.turned_characters import turned, world_heads  # noqa: E402

DATA = pathlib.Path(__file__).resolve().parents[2] / "data"
FRAMES = 12  # generated frames, at A's rate


def _hashes():
    return {act.name: action_hash(act) for act in bpy.data.actions}


def _root_path(arm, action):
    """The root bone's head in the world at every scene frame of ``action`` played on ``arm``."""
    arm.animation_data.action = action
    first, last = (int(round(x)) for x in action.frame_range)
    frames = np.arange(first, last + 1)
    return frames, world_heads(arm, frames)[:, 0]  # the first pose bone: the root


@pytest.fixture
def scene(empty_file):
    bpy.context.scene.render.fps, bpy.context.scene.render.fps_base = 24, 1.0
    bpy.ops.shapesig.import_acclaim("EXEC_DEFAULT", filepath=str(DATA / "acclaim" / "07_01.amc"),
                                    asf_path=str(DATA / "acclaim" / "07-walk.asf"))
    walk = bpy.context.view_layer.objects.active
    run = turned(DATA / "cross_rig" / "002_03.bvh", "cc_run", "fbx")
    run.animation_data.action.use_fake_user = True
    for o in bpy.context.view_layer.objects:
        o.select_set(False)
    walk.select_set(True)
    bpy.context.view_layer.objects.active = walk
    return walk, run


def test_amc_walk_into_a_turned_cc_run_in_a_24_fps_scene(scene, tmp_path):
    from blender_shapesig.core.blend.transition import transition

    walk, run = scene
    walk_name, act_a, act_b = walk.name, walk.animation_data.action.name, run.animation_data.action.name
    a, b = transitions.read_pair(walk, walk.animation_data.action, run.animation_data.action)
    assert a.fps == 120.0 and b.fps == 24.0  # the AMC at its own rate, the BVH one frame a scene frame
    before = _hashes()
    names = sorted(bpy.data.actions.keys())
    # one undo step takes it all back
    bpy.ops.ed.undo_push(message="before transition")
    assert bpy.ops.shapesig.transition("EXEC_DEFAULT", True, action_b=act_b, frames=FRAMES) == {"FINISHED"}
    assert len(bpy.data.actions) == len(names) + 1 and _hashes().items() >= before.items()
    bpy.ops.ed.undo()
    assert sorted(bpy.data.actions.keys()) == names
    walk = bpy.data.objects[walk_name]
    assert walk.animation_data.action.name == act_a
    # again, kept: the sources unchanged
    assert bpy.ops.shapesig.transition("EXEC_DEFAULT", action_b=act_b, frames=FRAMES) == {"FINISHED"}
    out = walk.animation_data.action
    assert out.name not in names and {k: v for k, v in _hashes().items() if k in before} == before
    # the true duration: the joined clip at A's rate (120 fps), keyed at the scene's 24 fps
    clip = transition(a, b, frames=FRAMES)
    seconds = (clip.frames - 1) / clip.fps
    first, last = out.frame_range
    assert abs((last - first) / 24.0 - seconds) <= 1.0 / 24.0
    # no root snap in the world at either seam: the root's steps there against A's own steps on its armature and
    # the joined action's largest step away from the seams (Blender's evaluation, no package code)
    frames, path = _root_path(walk, out)
    steps = np.linalg.norm(np.diff(path, axis=0), axis=1)
    info = clip.meta["transition"]
    seams = [first + (info["a_frames"] - 1) / clip.fps * 24.0, first + (info["a_frames"] + FRAMES) / clip.fps * 24.0]
    near = np.zeros(len(steps), bool)
    for s in seams:
        near |= np.abs(frames[:-1] + 0.5 - s) <= 2.0
    assert near.any() and (~near).sum() > 20
    _f, own = _root_path(walk, bpy.data.actions[act_a])
    largest = max(np.linalg.norm(np.diff(own, axis=0), axis=1).max(), steps[~near].max())
    assert steps[near].max() <= 1.5 * largest, (steps[near].max(), largest)
    # save, then a fresh Blender process evaluates the same world root path
    walk.animation_data.action = out
    sample = [int(f) for f in frames[::max(1, len(frames) // 12)]]
    here = world_heads(walk, sample)[:, 0]
    path_file = tmp_path / "t.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path_file))
    code = textwrap.dedent(f"""
        import bpy, json
        bpy.ops.wm.open_mainfile(filepath={str(path_file)!r})
        arm = bpy.data.objects[{walk_name!r}]
        sc = bpy.context.scene
        out = []
        for f in {sample!r}:
            sc.frame_set(f)
            out.append(list(arm.matrix_world @ arm.pose.bones[0].head))
        print(json.dumps({{"action": arm.animation_data.action.name, "fps": sc.render.fps, "heads": out}}))
    """)
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    got = json.loads(p.stdout.strip().splitlines()[-1])
    assert got["action"] == out.name and got["fps"] == 24
    np.testing.assert_allclose(np.array(got["heads"]), here, atol=1e-4)


def test_as_nla_strips_plays_what_the_action_plays(scene):
    """With As NLA Strips the transition plays from a new track as three strips of the new action (A's part, the
    frames between, B's part) meeting end to end over the action's range; the active action is cleared and the
    one it was keeps a user; Blender's evaluation through the NLA gives the same world root path as the action
    assigned directly; one undo step takes it back."""
    walk, run = scene
    walk_name, act_a, act_b = walk.name, walk.animation_data.action.name, run.animation_data.action.name
    before = _hashes()
    names = sorted(bpy.data.actions.keys())
    bpy.ops.ed.undo_push(message="before transition")
    assert bpy.ops.shapesig.transition("EXEC_DEFAULT", True, action_b=act_b, frames=FRAMES, strips=True) \
        == {"FINISHED"}
    walk = bpy.data.objects[walk_name]
    out = next(bpy.data.actions[n] for n in bpy.data.actions.keys() if n not in names)
    assert {k: v for k, v in _hashes().items() if k in before} == before
    ad = walk.animation_data
    assert ad.action is None
    assert bpy.data.actions[act_a].users + int(bpy.data.actions[act_a].use_fake_user) >= 1
    track = next(t for t in ad.nla_tracks if t.name == out.name)
    strips = list(track.strips)
    assert len(strips) == 3 and all(s.action == out for s in strips)
    first, last = out.frame_range
    assert strips[0].frame_start == first and strips[-1].frame_end == last
    for s0, s1 in zip(strips, strips[1:]):
        assert s0.frame_end == s1.frame_start
    for s in strips:
        assert (s.action_frame_start, s.action_frame_end) == (s.frame_start, s.frame_end)
    frames = [int(f) for f in np.linspace(first, last, 15)]
    through_nla = world_heads(walk, frames)[:, 0]
    track.mute = True
    compat.assign_action(walk, out)
    direct = world_heads(walk, frames)[:, 0]
    assert np.linalg.norm(direct[-1] - direct[0]) > 0.3 * np.linalg.norm(np.ptp(direct, axis=0))  # it travels
    np.testing.assert_allclose(through_nla, direct, atol=1e-5)
    compat.assign_action(walk, None)
    bpy.ops.ed.undo()
    assert sorted(bpy.data.actions.keys()) == names
    walk = bpy.data.objects[walk_name]
    assert walk.animation_data.action.name == act_a and not len(walk.animation_data.nla_tracks)
