"""Automatic rest-pose / ramp trimming (core.clip.trim) and how ClipSpec applies it (core.io.sources)."""

import numpy as np
import pytest

from blender_shapesig.core.geometry import so3
from blender_shapesig.core.io import sources
from blender_shapesig.core.clip.clip import Clip
from blender_shapesig.core.errors import ShapeSigError
from blender_shapesig.core.io.acclaim import load_acclaim
from blender_shapesig.core.clip.trim import Trim, detect_trim, rest_ratios, step_ratios, trim_clip


def _amc(data_dir, name, asf):
    return load_acclaim(data_dir / "acclaim" / f"{name}.amc", data_dir / "acclaim" / asf, axes="blender")


@pytest.fixture(scope="module")
def walk(data_dir):
    return _amc(data_dir, "07_01", "07-walk.asf")


@pytest.mark.parametrize("name,asf", [("07_01", "07-walk.asf"), ("07_02", "07-walk.asf"),
                                      ("09_02", "09-run.asf"), ("09_03", "09-run.asf"), ("16_15", "16.asf")])
def test_amc_originals_have_nothing_to_trim(data_dir, name, asf):
    clip = _amc(data_dir, name, asf)
    assert detect_trim(clip.rotations, clip.fps) == Trim(0, 0)
    out = trim_clip(clip)
    assert out.frames == clip.frames and out.meta["trim"] == {"kept": (1, clip.frames), "read": (1, clip.frames)}


def _with_rest_and_ramp(clip, ramp=5, tail=False):
    """The clip with a rest-pose frame and a ``ramp``-frame geodesic ramp from the rest pose into its first pose
    prepended (the Daz BVH conversion's head), or appended in reverse order (``tail``)."""
    R = clip.rotations
    first = R[-1] if tail else R[0]
    xi = so3.log(first)  # per joint, from the identity (the rest pose) to the first pose
    head = np.stack([so3.exp(xi * (k / (ramp + 1))) for k in range(ramp + 1)])  # rest, then the ramp
    R2 = np.concatenate([R, head[::-1]]) if tail else np.concatenate([head, R])
    return Clip(name=clip.name, bones=clip.bones, rotations=R2, fps=clip.fps)


def test_a_rest_pose_and_ramp_are_found_at_both_ends(walk):
    head = _with_rest_and_ramp(walk)
    cut = detect_trim(head.rotations, head.fps)
    assert cut.tail == 0 and 6 <= cut.head <= 8  # the rest frame and the 5 ramp frames (+ the ramp's end)
    both = _with_rest_and_ramp(head, tail=True)
    cut = detect_trim(both.rotations, both.fps)
    assert 6 <= cut.head <= 8 and 6 <= cut.tail <= 8
    out = trim_clip(both)
    assert out.meta["trim"]["read"] == (1, both.frames)
    assert out.frames == both.frames - cut.head - cut.tail


def test_a_t_pose_first_frame_is_dropped(walk):
    R = np.concatenate([np.broadcast_to(np.eye(3), (1,) + walk.rotations.shape[1:]), walk.rotations])
    clip = Clip(name="tpose", bones=walk.bones, rotations=R, fps=walk.fps)
    assert detect_trim(clip.rotations, clip.fps).head == 1


def test_ratios_are_one_on_a_typical_frame(walk):
    r, rest = step_ratios(walk.rotations), rest_ratios(walk.rotations)
    assert abs(np.median(r) - 1.0) < 0.2 and abs(np.median(rest) - 1.0) < 0.05
    assert rest.min() > 0.5  # no frame of a real take is near the rest pose


def test_clipspec_trim_is_in_the_key_and_checked(data_dir):
    path = data_dir / "acclaim" / "07_01.amc"
    asf = data_dir / "acclaim" / "07-walk.asf"
    keys = {sources.ClipSpec.parse(path, asf=asf, trim=t).key() for t in ("auto", "none")}
    keys.add(sources.ClipSpec.parse(path, asf=asf, fps=60).key())
    assert len(keys) == 3
    with pytest.raises(ShapeSigError, match="trim"):
        sources.ClipSpec.parse(path, asf=asf, trim="yes")
    with pytest.raises(ShapeSigError, match="plausible"):
        sources.ClipSpec.parse(path, asf=asf, fps=0.01)


def test_an_explicit_start_wins_over_trim(tmp_path, walk):
    # a synthetic AMC is not needed: the rule is applied by sources.read through trim_ends (an explicit crop wins)
    clip = _with_rest_and_ramp(walk)
    auto = sources.trim_ends(clip)
    assert auto.frame_start > 1
    kept = sources.trim_ends(clip, start=1)
    assert kept.frame_start == 1 and kept.frames == clip.frames
