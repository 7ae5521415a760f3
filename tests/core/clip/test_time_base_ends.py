"""The comparison lattice of core.clip.prepare: a clip and its decimated copies that lost their last frames (a 120 fps
clip of N frames keeps (N - 1) // 4 intervals at 30 fps, up to 25 ms less) compare as the same motion, on real CMU
clips whole (ASF/AMC, no bpy); the trimmed range a report shows (core.clip.trim.trimmed_range)."""

from dataclasses import replace

import numpy as np
import pytest

from blender_shapesig.core.geometry import so3
from blender_shapesig.core.clip.clip import Clip, restrict_to_shared
from blender_shapesig.core.io.acclaim import load_acclaim
from blender_shapesig.core.metrics import clip_distance, curve_distance, time_base_smoothing
from blender_shapesig.core.clip.prepare import (decimate_clip, lattice_cut, lattice_frames, prepare_clip,
                                           prepare_rotations)
from blender_shapesig.core.clip.trim import detect_trim, trim_clip, trim_note, trimmed_range

BOUNDS = {"sim3": 0.05, "elastic": 0.15}  # decimated copy / nearest clip of the other class


def _amc(data_dir, name, asf):
    return load_acclaim(data_dir / "acclaim" / f"{name}.amc", data_dir / "acclaim" / asf, axes="blender")


@pytest.fixture(scope="module")
def walks(data_dir):
    """Whole walks: 07_01 (316 frames: loses 1 frame at 60 fps and 3 at 30 fps), 16_15 (471: 0 and 2), 07_02."""
    return {"07_01": _amc(data_dir, "07_01", "07-walk.asf"), "16_15": _amc(data_dir, "16_15", "16.asf"),
            "07_02": _amc(data_dir, "07_02", "07-walk.asf")}


@pytest.fixture(scope="module")
def runs(data_dir):
    return [_amc(data_dir, n, "09-run.asf") for n in ("09_02", "09_03")]


def _lost(clip, step):
    return clip.frames - 1 - (decimate_clip(clip, step).frames - 1) * step


def test_the_walks_lose_their_last_frames(walks):
    assert (_lost(walks["07_01"], 2), _lost(walks["07_01"], 4)) == (1, 3)
    assert (_lost(walks["16_15"], 2), _lost(walks["16_15"], 4)) == (0, 2)


@pytest.mark.parametrize("metric", ["sim3", "elastic"])
@pytest.mark.parametrize("name", ["07_01", "16_15"])
def test_a_whole_walk_and_its_60_and_30_fps_copies_are_close(walks, runs, metric, name):
    walk = walks[name]
    near = min(clip_distance(walk, r, metric) for r in runs)
    for step in (2, 4):
        ratio = clip_distance(walk, decimate_clip(walk, step), metric) / near
        assert ratio < BOUNDS[metric], (name, step, ratio)


def test_without_the_lattice_the_lost_end_breaks_the_sim3_bound(walks, runs):
    """The failure the lattice fixes: the grid stretched over the whole duration (``keep_end=True``, the warps'
    grid) puts the 30 fps copy of 07_01, 3 frames short, at 0.08 of the nearest run (bound 0.05)."""
    walk, low = restrict_to_shared(walks["07_01"], decimate_clip(walks["07_01"], 4))

    def dist(a, b, keep_end):
        return curve_distance(prepare_clip(a, smooth=0.0, keep_end=keep_end).rotations,
                              prepare_clip(b, smooth=0.0, keep_end=keep_end).rotations, "sim3")

    near = min(clip_distance(walks["07_01"], r, "sim3") for r in runs)
    assert dist(walk, low, True) / near > BOUNDS["sim3"]
    assert dist(walk, low, False) / near < 1e-6  # no low-pass: the lattice samples the very same frames


@pytest.mark.parametrize("name", ["07_01", "16_15"])
def test_a_whole_30_fps_walk_ranks_walks_first(walks, runs, name):
    q = decimate_clip(walks[name], 4)
    others = [w for n, w in walks.items() if n != name]
    for metric in ("sim3", "elastic"):
        assert min(clip_distance(q, w, metric) for w in others) < min(clip_distance(q, r, metric) for r in runs)


def test_the_lattice_of_a_clip_and_of_its_copies_is_the_same():
    # 316 frames at 120 fps: 2.625 s, J = 78; its 60 fps copy (158 frames, 2.617 s) and 30 fps copy (79 frames)
    assert lattice_frames(316, 120.0, 30.0) == lattice_frames(158, 60.0, 30.0) == lattice_frames(79, 30.0, 30.0) == 79
    assert lattice_cut(316, 120.0, 30.0) == 313 and lattice_cut(158, 60.0, 30.0) == 157
    assert lattice_cut(79, 30.0, 30.0) == 79
    assert lattice_frames(121, 120.0, 30.0) == 31  # 1 s exactly: no rounding down to 29 intervals
    assert lattice_frames(3, 120.0, 30.0) == 2 and lattice_cut(3, 120.0, 30.0) == 3  # shorter than 1/30 s


def test_the_lattice_at_a_rate_that_does_not_divide_30():
    """24 fps: t_j = j / 30 s fall between frames; a constant-speed rotation is sampled exactly on the lattice,
    and the root path at the same times."""
    axis = np.array([0.3, -1.0, 0.5]) / np.linalg.norm([0.3, -1.0, 0.5])
    t = np.arange(38) / 24.0  # 1.542 s: J = 46 (t_46 = 1.533 s), the remainder 8 ms dropped
    R = so3.exp((2.0 * t)[:, None, None] * axis[None, None])
    P = prepare_rotations(R, 24.0, keep_end=False)
    assert P.shape[0] == 47
    expected = so3.exp((2.0 * np.arange(47) / 30.0)[:, None, None] * axis[None, None])
    np.testing.assert_allclose(P, expected, atol=1e-10)
    assert prepare_rotations(R, 24.0).shape[0] == 47  # keep_end: 46 intervals stretched over 1.542 s
    root = np.stack([t, 2 * t, np.zeros_like(t)], axis=1)
    clip = Clip(name="c", bones=("a",), rotations=R, fps=24.0, root_translation=root)
    out = prepare_clip(clip)
    assert out.fps == 30.0 and out.frames == 47
    np.testing.assert_allclose(out.root_translation[:, 0], np.arange(47) / 30.0, atol=1e-12)


def test_the_low_pass_sees_the_same_frames_on_every_copy(walks):
    """The clip is cut at the lattice's last time before the low-pass: a clip and the same clip with 3 more
    frames prepare to the same curve (the low-pass reflects at the same time)."""
    walk = walks["07_02"]  # 329 frames: 328 intervals, a multiple of 4
    longer = replace(walk, rotations=np.concatenate([walk.rotations, walks["07_01"].rotations[:3]]),
                     root_translation=None)
    smooth = time_base_smoothing("elastic")
    a = prepare_clip(replace(walk, root_translation=None), smooth=smooth)
    b = prepare_clip(longer, smooth=smooth)
    assert a.frames == b.frames == 83
    np.testing.assert_allclose(a.rotations, b.rotations, atol=1e-12)


def _with_rest_and_ramp(clip, ramp=5):
    R = clip.rotations
    xi = so3.log(R[0])
    head = np.stack([so3.exp(xi * (k / (ramp + 1))) for k in range(ramp + 1)])
    return Clip(name=clip.name, bones=clip.bones, rotations=np.concatenate([head, R]), fps=clip.fps)


def test_the_trimmed_range_is_the_detection(walks):
    raw = _with_rest_and_ramp(walks["07_01"])
    cut = detect_trim(raw.rotations, raw.fps)
    assert cut.head >= 6 and cut.tail == 0
    out = trim_clip(raw)
    got = trimmed_range(out)
    assert got == {"frames": [raw.frame_start + cut.head, raw.frame_end], "cut": [cut.head, 0]}
    assert trim_note(out).startswith(f"07_01: trimmed {cut.head} at the start")
    # an explicit crop after trimming: the end it moves counts no trimmed frame
    cropped = out.crop(out.frame_start + 10, None)
    assert trimmed_range(cropped)["cut"] == [0, 0] and trim_note(cropped) == ""
    assert trimmed_range(walks["07_01"]) == {"frames": [1, 316], "cut": [0, 0]}
