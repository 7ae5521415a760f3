"""Clips that already are one cycle loop as they are (issue 38: a Mixamo walk made to loop, 0.96 s, "showed no
cycle"; a 0.63 s dash was "too short"). The truth is independent of the cycle finder: one gait period is read from
the feet's heights (forward kinematics of real CMU takes in tests/data), a stride of exactly that period is cut out of
the take (its last frame repeating the first, or the first following the last), also resampled to the rates of
exported loops (24 and 30 fps). Done when: the loop's seam step is at most the source's largest joint step + 5°."""

import functools
import pathlib

import numpy as np
import pytest

from blender_shapesig.core.blend import close_loop, closed_cycle, make_blends, one_cycle, pose_steps
from blender_shapesig.core.clip.clip import Clip
from blender_shapesig.core.clip.prepare import resample_seconds
from blender_shapesig.core.clip.skeleton import forward_kinematics
from blender_shapesig.core.errors import ShapeSigError
from blender_shapesig.core.geometry import so3
from blender_shapesig.core.io.acclaim import load_acclaim

ACC = pathlib.Path(__file__).resolve().parents[2] / "data" / "acclaim"
TAKES = {"walk": ("07_01.amc", "07-walk.asf"), "run": ("09_02.amc", "09-run.asf"), "run5": ("09_05.amc", "09-run.asf"),
         "walk16": ("16_15.amc", "16.asf")}
SEAM_MARGIN = np.radians(5.0)


@functools.lru_cache(maxsize=None)
def take(name):
    amc, asf = TAKES[name]
    return load_acclaim(str(ACC / amc), str(ACC / asf), axes="blender")


@functools.lru_cache(maxsize=None)
def foot_period(name):
    """Frames of one gait cycle from the feet alone: the lag at which both feet's heights repeat best
    (0.4 s up to the take's length less 0.3 s)."""
    clip = take(name)
    heads, _tails, _w = forward_kinematics(clip)
    z = heads[:, [clip.bones.index("lfoot"), clip.bones.index("rfoot")], 2]
    lags = np.arange(int(0.4 * clip.fps), clip.frames - int(0.3 * clip.fps))
    return int(lags[np.argmin([np.mean((z[lag:] - z[:-lag]) ** 2) for lag in lags])])


def stride(name, start, repeat=True, share=1.0):
    """``share`` of one foot period cut from the take at ``start`` (its own frame numbers): with ``repeat`` the
    last frame is the first one period on, else the frame before it."""
    clip, period = take(name), foot_period(name)
    return clip.crop(start, start + int(round(share * period)) - (0 if repeat else 1))


def at_rate(clip, fps):
    """The clip resampled to ``fps`` over its duration (rotations along the geodesics, the root linearly)."""
    R = resample_seconds(clip.rotations, clip.fps, fps)
    t = np.linspace(0.0, 1.0, R.shape[0])
    src = np.linspace(0.0, 1.0, clip.frames)
    rt = np.stack([np.interp(t, src, clip.root_translation[:, k]) for k in range(3)], axis=1)
    return Clip(name=clip.name, bones=clip.bones, rotations=R, fps=fps, frame_start=1, root_translation=rt,
                root_bone=clip.root_bone, rotation_modes=clip.rotation_modes, meta=dict(clip.meta))


def joint_angles(A, B):
    """Per-joint rotation angles between pose arrays (..., joints, 3, 3)."""
    return np.linalg.norm(so3.log(A @ np.swapaxes(B, -1, -2)), axis=-1)


def largest_joint_step(clip):
    return float(joint_angles(clip.rotations[1:], clip.rotations[:-1]).max())


def seam_step(loop):
    """The largest joint step from the loop's last distinct frame to its first (frame M repeats frame 0)."""
    R = loop.rotations
    assert joint_angles(R[-1], R[0]).max() < 1e-9
    return float(joint_angles(R[-2], R[0]).max())


def test_the_foot_period_is_one_gait_cycle():
    # independent of the finder: the walks' strides last about 1.1 s, the runs' about 0.75 s at 120 fps
    assert 125 <= foot_period("walk") <= 135 and 135 <= foot_period("walk16") <= 145
    assert 85 <= foot_period("run") <= 95 and 85 <= foot_period("run5") <= 95


CUTS = [("walk", 100), ("walk", 150), ("run", 20), ("run5", 42), ("walk16", 200)]


@pytest.mark.parametrize("name,start", CUTS)
@pytest.mark.parametrize("repeat", [True, False])
def test_a_stride_cut_from_a_take_is_one_cycle_and_parts_of_strides_are_not(name, start, repeat):
    got = closed_cycle(stride(name, start, repeat))
    assert got is not None and got["gap"] < 0.3
    for share in (0.7, 1.5):
        if start + share * foot_period(name) <= take(name).frame_end:
            assert closed_cycle(stride(name, start, share=share)) is None
    assert closed_cycle(take(name)) is None  # a take of several strides ending at another phase


@pytest.mark.parametrize("name,start", CUTS)
@pytest.mark.parametrize("fps", [None, 30.0, 24.0])
def test_a_one_cycle_clip_loops_as_it_is(name, start, fps):
    """A stride at the take's rate or resampled as an exported loop (a walk of 1.1 s at 24 fps is ~26 frames, a run
    of 0.75 s at 24 fps 18 frames: shorter than the cycle finder can see) loops whole, with no step at the seam
    beyond the source's largest joint step + 5°."""
    source = stride(name, start)
    if fps:
        source = at_rate(source, fps)
    cycle = one_cycle(source)
    info = cycle.meta["cycle"]
    assert info["whole"] and info["period"] in (source.frames - 1, source.frames)
    loop = close_loop(cycle)
    assert loop.frames - 1 == info["period"]  # every pose of the stride plays, none twice
    assert seam_step(loop) <= largest_joint_step(source) + SEAM_MARGIN
    # closer: the seam's root mean square step over the joints is no larger than the source's median step
    R = loop.rotations
    assert pose_steps(np.stack([R[-2], R[0]]))[0] <= np.median(pose_steps(source.rotations))
    # and nowhere a pop: the cycle's steps stay within the source's
    assert joint_angles(loop.rotations[1:], loop.rotations[:-1]).max() <= largest_joint_step(source) + SEAM_MARGIN


@pytest.mark.parametrize("fps", [30.0, 24.0])
def test_loop_blend_of_one_cycle_clips_and_a_take(fps):
    """Through make_blends (the command line's --loop and the Blend dialog's Loop): a one-cycle walk and a short
    run cycle, and a take with a one-cycle clip as B, which starts at the take's stride phase."""
    walk, run = at_rate(stride("walk", 100), fps), at_rate(stride("run5", 42), fps)
    assert (run.frames - 1) / fps < 0.8  # the short run cycle
    (got,), info = make_blends([walk, run], [(0.5, 0.5)], loop=True, feet="none")
    assert all(s["cycle"]["whole"] for s in info["sources"])
    assert seam_step(got) <= max(largest_joint_step(walk), largest_joint_step(run)) + SEAM_MARGIN
    # a take (several strides, A) with a one-cycle run (B): A's stride is found, B is turned to A's phase
    (got,), info = make_blends([take("run"), run], [(0.5, 0.5)], loop=True, feet="none")
    a_cycle, b_cycle = (s["cycle"] for s in info["sources"])
    assert not a_cycle.get("whole") and b_cycle["whole"]
    assert seam_step(got) <= max(largest_joint_step(take("run")), largest_joint_step(run)) + SEAM_MARGIN
    b = one_cycle(run, like=one_cycle(take("run")))
    a0 = one_cycle(take("run")).rotations[0]
    phase = np.sqrt(np.mean(joint_angles(b.rotations[0], a0) ** 2))
    others = [np.sqrt(np.mean(joint_angles(R, a0) ** 2)) for R in b.rotations]
    assert phase <= min(others) + 1e-12 and b.meta["cycle"]["shift"] > 0


def test_a_short_clip_that_is_not_a_cycle_says_so_in_words():
    part = stride("walk", 100, share=0.3)  # 40 frames at 120 fps
    with pytest.raises(ShapeSigError) as err:
        one_cycle(part)
    assert str(err.value) == "clip '07_01' lasts 0.33 s: too short to loop (a loop needs a stride of 0.4 s or more)"
    part = stride("walk", 100, share=0.45)  # 0.48 s: too short for the cycle finder, and not a cycle
    with pytest.raises(ShapeSigError) as err:
        one_cycle(part)
    text = str(err.value)
    assert "too short to find a repeating stride" in text and "nor does it end where it starts" in text
    assert "self-distance" not in text and "median" not in text
    half = stride("walk", 100, share=0.7)  # long enough to look for a stride, and not one
    with pytest.raises(ShapeSigError, match="does not repeat.*nor does it end where it starts, so it cannot loop"):
        one_cycle(half)


def test_a_held_pose_is_not_a_cycle():
    clip = take("walk").crop(100, 140)
    held = Clip(name="held", bones=clip.bones, rotations=np.repeat(clip.rotations[:1], 41, axis=0), fps=clip.fps,
                root_translation=np.repeat(clip.root_translation[:1], 41, axis=0), root_bone=clip.root_bone)
    assert closed_cycle(held) is None
    assert pose_steps(held.rotations).max() == 0.0
