"""Blends animators can use, through ``core.blend.make_blends``, the recipe the command line and the
Blend operator share: three clips, ranges, loops, masks and planted feet on real CMU clips from tests/data."""

import functools
import pathlib

import numpy as np
import pytest

from blender_shapesig.core.blend import feet
from blender_shapesig.core.blend import blend_clips, blend_many, make_blends, pose_steps
from blender_shapesig.core.errors import ShapeSigError
from blender_shapesig.core.io.acclaim import load_acclaim
from blender_shapesig.core.io.bvh import load_bvh
from blender_shapesig.core.rigs import apply_bone_map, onto_rig

ACC = pathlib.Path(__file__).resolve().parents[2] / "data" / "acclaim"
BVH = pathlib.Path(__file__).resolve().parents[2] / "data" / "bvh"


@functools.lru_cache(maxsize=None)
def _amc(amc, asf):
    return load_acclaim(str(ACC / amc), str(ACC / asf), axes="blender")


def walk():
    return _amc("07_01.amc", "07-walk.asf")


def walk2():
    return _amc("07_02.amc", "07-walk.asf")


def run():
    return _amc("09_02.amc", "09-run.asf")


def _angle(Ra, Rb):
    """Largest rotation angle between corresponding rotation matrices (radians), from the Frobenius distance."""
    fro = np.sqrt(np.sum((np.asarray(Ra) - np.asarray(Rb)) ** 2, axis=(-2, -1)))
    return float((2.0 * np.arcsin(np.clip(fro / (2.0 * np.sqrt(2.0)), 0.0, 1.0))).max())


# ------------------------------------------------------------------------------------------------ three clips

@pytest.mark.parametrize("align", [True, False])
def test_three_clips_weight_one_on_the_first_reproduces_it(align):
    a, b, c = walk().crop(100, 220), run(), walk2().crop(50, 200)
    got = blend_many([a, b, c], (1.0, 0.0, 0.0), align=align)
    assert got.frames == a.frames and got.frame_start == a.frame_start
    assert _angle(got.rotations, a.rotations) < 1e-9
    np.testing.assert_allclose(got.root_translation, a.root_translation, atol=1e-9)
    # through the recipe with planted feet: the feet of a blend equal to its first source are left as they are
    (locked,), info = make_blends([a, b, c], [(1.0, 0.0, 0.0)], align=align)
    assert _angle(locked.rotations, a.rotations) < 1e-6
    assert info["feet"][0]["root_lowered"] == 0.0


def test_three_equal_weights_are_symmetric_under_reordering():
    a, b, c = walk().crop(100, 220), run(), walk2().crop(50, 200)
    third = (1 / 3, 1 / 3, 1 / 3)
    # aligned: the clips after the reference in any order (each has its own warp onto the reference)
    abc, acb = blend_many([a, b, c], third), blend_many([a, c, b], third)
    assert abc.frames == acb.frames
    assert _angle(abc.rotations, acb.rotations) < 1e-9
    np.testing.assert_allclose(abc.root_translation, acb.root_translation, atol=1e-9)
    # without alignment every order is the same curve, the reference's included
    ref = blend_many([a, b, c], third, align=False)
    for order in ([b, a, c], [c, b, a], [b, c, a]):
        got = blend_many(order, third, align=False)
        assert got.frames == ref.frames
        assert _angle(got.rotations, ref.rotations) < 1e-9
    # and it differs from every source: a true three-way blend
    assert _angle(abc.rotations[:5], a.rotations[:5]) > 0.05


def test_two_clips_through_the_recipe_are_the_two_clip_blend():
    a, b = walk(), run()
    (got,), _info = make_blends([a, b], [(0.75, 0.25)], feet="none")
    want = blend_clips(a, b, 0.25)
    assert np.array_equal(got.rotations, want.rotations) and got.frames == want.frames


def test_weights_are_checked():
    a, b, c = walk(), run(), walk2()
    with pytest.raises(ShapeSigError, match="summing to 1"):
        make_blends([a, b, c], [(0.5, 0.5, 0.5)])
    with pytest.raises(ShapeSigError, match="one weight per clip"):
        make_blends([a, b, c], [(0.5, 0.5)])
    with pytest.raises(ShapeSigError, match="mask needs exactly two clips"):
        make_blends([a, b, c], [(0.4, 0.3, 0.3)], mask={"upper": 1.0}, feet="none")


# ------------------------------------------------------------------------------------------------ ranges

def test_ranges_crop_each_source_in_its_own_frames():
    a, b = walk(), run()
    (got,), info = make_blends([a, b], [(0.5, 0.5)], ranges=["125:253", (36, 126)], feet="none")
    want = blend_clips(a.crop(125, 253), b.crop(36, 126), 0.5)
    assert np.array_equal(got.rotations, want.rotations)
    assert got.frame_start == 125
    assert [s["range"] for s in info["sources"]] == [[125, 253], [36, 126]]
    # the weighted average of the durations in seconds
    assert (got.frames - 1) / got.fps == pytest.approx(0.5 * 128 / 120 + 0.5 * 90 / 120, abs=0.5 / 120)
    for bad, match in (("300:400", "outside"), ("20:10", "must end after"), ("a:b", "START:END")):
        with pytest.raises(ShapeSigError, match=match):
            make_blends([a, b], [(0.5, 0.5)], ranges=[bad, None], feet="none")


# ------------------------------------------------------------------------------------------------ loops

def test_loop_blend_closes_on_its_first_pose():
    a, b = walk(), run()
    (got,), info = make_blends([a, b], [(0.5, 0.5)], loop=True)
    cycles = [s["cycle"] for s in info["sources"]]
    assert 0.9 < cycles[0]["seconds"] < 1.25 and 0.6 < cycles[1]["seconds"] < 0.9  # one stride each
    R = got.rotations
    assert _angle(R[-1], R[0]) < 1e-12  # the last frame is the first: the cycle is frames 0..M-1
    steps = pose_steps(R[:-1])
    seam = pose_steps(np.stack([R[-2], R[0]]))[0]  # the step M-1 -> 0 when it repeats
    assert seam <= np.median(steps)
    # and no pop anywhere in the cycle (the closure's residual is spread, not left where the seam was)
    assert steps.max() <= 3.0 * np.median(steps)
    assert info["loop"][0]["closure_degrees"] > 1.0  # there was a residual to spread
    # the root height joins; the travel per cycle is the offset the loop reports
    up = np.asarray(got.meta["up_axis"], float)
    rt = got.root_translation
    assert abs((rt[-1] - rt[0]) @ up) < 1e-9
    np.testing.assert_allclose(info["loop"][0]["offset"], rt[-1] - rt[0], atol=1e-9)
    # root velocity across the seam (last step) is within the range of the cycle's own steps
    v = np.linalg.norm(np.diff(rt, axis=0), axis=1)
    assert v.min() - 1e-9 <= v[-1] <= v.max() + 1e-9
    # without closing, the blend of one stride each would jump at the seam
    (raw,), _ = make_blends([a, b], [(0.5, 0.5)], ranges=None, loop=False, feet="none")
    assert raw.frames != got.frames


# ------------------------------------------------------------------------------------------------ masks

def test_mask_upper_body_keeps_the_legs_and_the_travel_of_a():
    a, b = walk().crop(125, 253), run().crop(36, 126)
    (got,), _ = make_blends([a, b], [(0.0, 1.0)], mask={"legs": 0.0}, feet="none")
    w = got.meta["bone_weights"]
    assert w["lfemur"] == 0.0 and w["rhumerus"] == 1.0
    # the timing follows the legs (A's): A's frames, A's root path
    assert got.frames == a.frames
    np.testing.assert_allclose(got.root_translation, a.root_translation, atol=1e-9)
    legs = [a.bones.index(x) for x in ("lfemur", "ltibia", "rfemur", "rtibia")]
    assert _angle(got.rotations[:, legs], a.rotations[:, legs]) < 1e-9
    arm = a.bones.index("rhumerus")
    assert _angle(got.rotations[:, arm], a.rotations[:, arm]) > 0.1


# ------------------------------------------------------------------------------------------------ feet

@pytest.mark.parametrize("order,weights", [("ab", (0.5, 0.5)), ("ab", (0.25, 0.75)), ("ba", (0.5, 0.5)),
                                           ("abc", (0.4, 0.3, 0.3))])
@pytest.mark.parametrize("feet_mode", ["lock", "none"])
def test_loop_seams_of_other_blends(order, weights, feet_mode):
    clips = {"a": walk(), "b": run(), "c": walk2()}
    (got,), _info = make_blends([clips[k] for k in order], [weights], loop=True, feet=feet_mode)
    R = got.rotations
    steps = pose_steps(R[:-1])
    assert pose_steps(np.stack([R[-2], R[0]]))[0] <= np.median(steps)
    if feet_mode == "none" or order != "ba":
        assert steps.max() <= 3.0 * np.median(steps)
    # known leftover: with the run as reference its toe-off leg is fully straight in the blend and the IK knee
    # passes through straight within one frame (one step of 0.066 rad RMS, docs/blending.md, limits)


@pytest.mark.parametrize("weight", [0.25, 0.5])
def test_feet_lock_across_rigs_as_the_command_line(weight):
    """08_01 (Daz BVH walk) x 09_05 (AMC run), one stride each, blended through the canonical joints and written
    back on the walk's rig (the command line's path): the issue's stance drift bounds."""
    a = load_bvh(BVH / "08_01.bvh")
    b = load_acclaim(str(ACC / "09_05.amc"), str(ACC / "09-run.asf"), axes="blender")
    (got,), info = make_blends([a, b], [(1 - weight, weight)], mapped=[apply_bone_map(a), apply_bone_map(b)],
                               back=onto_rig, ranges=["147:269", "42:132"])
    da, db = feet.source_drifts(a.crop(147, 269)), feet.source_drifts(b.crop(42, 132))
    report = info["feet"][0]
    after = [d for f in report["feet"] for d in f["drift_after"]]
    before = [d for f in report["feet"] for d in f["drift_before"]]
    assert len(after) >= 4  # both feet planted, heel and ball
    assert np.median(after) <= max(np.median(da), np.median(db)) + 0.02
    assert max(after) <= max(max(da), max(db)) + 0.05
    assert max(after) < max(before)
    assert got.bones == a.bones and got.meta["feet"] == "lock"


def test_feet_skipped_on_request_or_refused_when_required():
    a, b = walk(), run()
    bare = [x.__class__(**{**x.__dict__, "meta": {k: v for k, v in x.meta.items() if not k.startswith("rest_")}})
            for x in (a, b)]
    with pytest.raises(ShapeSigError):
        make_blends(bare, [(0.5, 0.5)])
    (got,), info = make_blends(bare, [(0.5, 0.5)], feet_required=False)
    assert "skipped" in info["feet"][0]
    with pytest.raises(ShapeSigError, match="feet"):
        make_blends([a, b], [(0.5, 0.5)], feet="glue")
