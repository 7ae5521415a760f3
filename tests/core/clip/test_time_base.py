"""One time base in seconds (core.clip.prepare): the same motion at 120 / 60 / 30 fps compares as the same, on real
CMU clips (ASF/AMC, no bpy); blends last the weighted average of their sources' durations in seconds."""

from dataclasses import replace

import numpy as np
import pytest

from blender_shapesig.core.geometry import so3
from blender_shapesig.core.blend import blend_clips
from blender_shapesig.core.clip.clip import Clip
from blender_shapesig.core.errors import ShapeSigError
from blender_shapesig.core.io.acclaim import load_acclaim
from blender_shapesig.core.metrics import clip_distance
from blender_shapesig.core.clip.prepare import decimate_clip, prepare_clip, prepare_rotations, smooth_increments


def _amc(data_dir, name, asf):
    return load_acclaim(data_dir / "acclaim" / f"{name}.amc", data_dir / "acclaim" / asf, axes="blender")


def same_span(clip, step=4):
    """The clip cut to a multiple of ``step`` intervals, so that its decimated copies end on its last frame."""
    n = (clip.frames - 1) // step * step + 1
    return replace(clip, rotations=clip.rotations[:n], root_translation=clip.root_translation[:n])


@pytest.fixture(scope="module")
def walks(data_dir):
    return [same_span(_amc(data_dir, n, "07-walk.asf")) for n in ("07_01", "07_02")]


@pytest.fixture(scope="module")
def runs(data_dir):
    return [_amc(data_dir, n, "09-run.asf") for n in ("09_02", "09_03")]


# The bounds: a clip against its decimated copy, relative to the nearest clip of the other class.
BOUNDS = {"sim3": 0.05, "elastic": 0.15}


@pytest.mark.parametrize("metric", ["sim3", "elastic"])
def test_a_walk_and_its_60_and_30_fps_copies_are_close(walks, runs, metric):
    for walk in walks:
        near = min(clip_distance(walk, r, metric) for r in runs)
        for step in (2, 4):
            ratio = clip_distance(walk, decimate_clip(walk, step), metric) / near
            assert ratio < BOUNDS[metric], (walk.name, step, ratio)


def test_without_the_time_base_d_s_star_sees_the_frame_rate(walks, runs):
    """The preparation is what makes the elastic bound hold: raw curves at 30 fps are far from 120 fps."""
    walk = walks[0]
    near = min(clip_distance(walk, r, "elastic", time_base=False) for r in runs)
    ratio = clip_distance(walk, decimate_clip(walk, 4), "elastic", time_base=False) / near
    assert ratio > 0.3


def test_a_30_fps_walk_is_nearer_to_walks_than_to_runs(walks, runs):
    q = decimate_clip(walks[0], 4)
    for metric in ("sim3", "elastic"):
        to_walk = clip_distance(q, walks[1], metric)
        assert to_walk < min(clip_distance(q, r, metric) for r in runs)


def test_prepare_keeps_durations_and_a_constant_speed_rotation():
    axis = np.array([0.3, -1.0, 0.5]) / np.linalg.norm([0.3, -1.0, 0.5])
    t = np.arange(121) / 120.0  # one second at 120 fps, 2 rad/s
    R = so3.exp((2.0 * t)[:, None, None] * axis[None, None])
    P = prepare_rotations(R, 120.0)
    assert P.shape[0] == 31  # 1 s at 30 fps
    expected = so3.exp((2.0 * np.arange(31) / 30.0)[:, None, None] * axis[None, None])
    np.testing.assert_allclose(P, expected, atol=1e-10)
    steps = so3.relative_rotvecs(R)
    np.testing.assert_allclose(smooth_increments(steps, 120.0), steps, atol=1e-14)
    clip = Clip(name="c", bones=("a",), rotations=R, fps=120.0, root_translation=np.zeros((121, 3)))
    out = prepare_clip(clip)
    assert out.fps == 30.0 and (out.frames - 1) / out.fps == pytest.approx(1.0)
    assert out.root_translation.shape == (31, 3)


def test_implausible_rates_are_refused():
    clip = Clip(name="c", bones=("a",), rotations=np.broadcast_to(np.eye(3), (5, 1, 3, 3)), fps=5000.0)
    with pytest.raises(ShapeSigError, match="plausible"):
        prepare_clip(clip)


@pytest.mark.parametrize("w", [0.0, 0.25, 0.5, 1.0])
def test_a_blend_of_120_and_30_fps_clips_lasts_the_weighted_average_in_seconds(walks, runs, w):
    a = walks[0]  # 120 fps
    b = decimate_clip(runs[0], 4)  # 30 fps
    da, db = (a.frames - 1) / a.fps, (b.frames - 1) / b.fps
    out = blend_clips(a, b, w)
    assert out.fps == 120.0
    seconds = (out.frames - 1) / out.fps
    assert seconds == pytest.approx((1 - w) * da + w * db, abs=0.5 / out.fps)
    # and the same with the rates swapped: the blend is sampled at the higher rate
    swapped = blend_clips(b, a, 1 - w)
    assert swapped.fps == 120.0 and swapped.frames == out.frames
