"""Feet: Lock without pops in real headless Blender (issue 31): the CMU walk 07_01 and run 09_02 imported by the
add-on's Acclaim importer, and the iClone 002_03 run and the Daz 07_01 walk through Blender's BVH importer, saved and
reopened; blends at 0.25/0.5/0.75 with the feet locked, read back from the new action: the largest per-frame bone
rotation stays within the faster source's (time-aligned, ``feet.rotation_steps``) + 5 degrees, and the planted feet
drift less than unlocked."""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from blender_shapesig.actions import action_io, frame_rates  # noqa: E402
from blender_shapesig.blend.blend_actions import blend_actions  # noqa: E402
from blender_shapesig.core.blend import feet  # noqa: E402
from blender_shapesig.core.geometry import so3  # noqa: E402
from blender_shapesig.search.library import owner_armature  # noqa: E402
from tests.helpers.mixed_scene import activate, build, save_reopen  # noqa: E402


@pytest.fixture(scope="module")
def scene(addon, tmp_path_factory):
    bpy.ops.wm.read_homefile(use_empty=True)
    frame_rates.forget()
    build(names=("07_01.001", "002_03"), amc=(("07_01", "07-walk"), ("09_02", "09-run")))
    # the scene at the blends' rate (120 fps): the written actions keep the blends' frames, compared step for step
    # with the sources' (in a 24 fps scene they are keyed at 24: tests/blender/actions/test_scene_world.py)
    bpy.context.scene.render.fps = 120
    save_reopen(tmp_path_factory.mktemp("feet") / "feet.blend")
    yield
    frame_rates.forget()


def _largest_step(action, arm):
    clip = action_io.read_action(action, armature=arm, exclude_unkeyed=True, space="pose")
    return float(np.degrees(np.linalg.norm(so3.relative_rotvecs(clip.rotations), axis=-1).max()))


# (A, B, A's armature (None: the one playing A), rate, first frames of A and B: the iClone file's first frame is a
# T-pose, the Daz file's first frame a rest pose and frames 2-6 a ramp from it; tests/data/README.md)
CASES = [("07_01", "09_02", "07-walk", 120.0, None), ("002_03", "07_01.001", None, None, (2, 7))]


@pytest.mark.parametrize("w", [0.25, 0.5, 0.75])
@pytest.mark.parametrize("a, b, arm_name, fps, first", CASES)
def test_locked_blends_turn_no_bone_faster_than_the_sources(scene, a, b, arm_name, fps, first, w):
    act_a, act_b = bpy.data.actions[a], bpy.data.actions[b]
    arm = bpy.data.objects[arm_name] if arm_name else owner_armature(act_a, None)
    activate(arm)
    rates = [fps, fps] if fps else [60.0, 120.0]  # the true rates (the BVH importer records none)
    ranges = [(f, int(x.frame_range[1])) for f, x in zip(first, (act_a, act_b))] if first else None
    steps = {}
    for mode in ("none", "lock"):
        result = blend_actions(arm, act_a, act_b, [w], feet=mode, rates=rates, ranges=ranges)
        steps[mode] = _largest_step(result.actions[0], arm)
        if mode == "lock":
            report = result.info["feet"][0]
            assert "skipped" not in report, report
            clip = result.clips[0]
        for act in result.actions:
            bpy.data.actions.remove(act)
    _own, source = feet.rotation_steps(clip, _sources(arm, act_a, act_b, rates, first))
    assert 3.0 < source < 40.0
    print(f"{a} x {b} at {w}: largest step {steps['lock']:.1f} deg locked, {steps['none']:.1f} unlocked, "
          f"sources {source:.1f}")
    assert steps["lock"] <= source + 5.0, (steps, source)
    before = [d for f in report["feet"] for d in f["drift_before"]]
    after = [d for f in report["feet"] for d in f["drift_after"]]
    assert np.median(after) < np.median(before)


def _sources(arm, act_a, act_b, rates, first):
    out = []
    for act, r in zip((act_a, act_b), rates):
        owner = owner_armature(act, arm)
        out.append(action_io.read_action(act, armature=owner, exclude_unkeyed=True, space="pose", fps=r))
    if first:
        out = [x.crop(f, x.frame_end) for x, f in zip(out, first)]
    return out
