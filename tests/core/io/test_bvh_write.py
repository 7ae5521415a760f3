"""The BVH writer (core.io.bvh_write) against our reader: real clips of three rigs (CMU Daz BVH, Character Creator
BVH at 60 fps, CMU ASF/AMC) written and read back give the same bones, rotation modes, frame rate, rotations,
root path and rest skeleton to 1e-5; a transition written on A's skeleton reads back as the transition; an existing
file is never replaced; a clip without a skeleton is refused in one line."""

import pathlib

import numpy as np
import pytest

from blender_shapesig.core.blend.transition import transition
from blender_shapesig.core.errors import ShapeSigError
from blender_shapesig.core.io.bvh import load_bvh
from blender_shapesig.core.io.bvh_write import write_bvh
from blender_shapesig.core.io.sources import read_one

DATA = pathlib.Path(__file__).resolve().parents[2] / "data"
CLIPS = [("bvh/07_01.bvh", None), ("cross_rig/002_03.bvh", None), ("acclaim/07_01.amc", "acclaim/07-walk.asf")]


def _read(name, asf=None):
    return read_one(str(DATA / name), asf=None if asf is None else str(DATA / asf), bone_map="none", trim="none")


def same_clip(back, clip, tol=1e-5):
    """``back`` (read from a written file) equals ``clip``: bones (as a set; rows matched by name), modes, rate,
    frames, rotations, root path, rest heads and hierarchy."""
    assert set(back.bones) == set(clip.bones) and back.frames == clip.frames
    assert back.fps == pytest.approx(clip.fps, rel=1e-9)
    idx = [back.bones.index(b) for b in clip.bones]
    assert tuple(back.rotation_modes[i] for i in idx) == tuple(m if m in ("XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX")
                                                                else "ZXY" for m in clip.rotation_modes)
    np.testing.assert_allclose(back.rotations[:, idx], clip.rotations, rtol=0, atol=tol)
    np.testing.assert_allclose(back.root_translation, clip.root_translation, rtol=0, atol=tol)
    for b in clip.bones:
        np.testing.assert_allclose(back.meta["rest_heads"][b], clip.meta["rest_heads"][b], rtol=0, atol=tol)
    assert {b: back.meta["parents"][b] for b in clip.bones} == {b: clip.meta["parents"][b] for b in clip.bones}


@pytest.mark.parametrize("name,asf", CLIPS)
def test_round_trip_through_our_reader(tmp_path, name, asf):
    clip = _read(name, asf)
    path = write_bvh(clip, tmp_path / "out.bvh")
    same_clip(load_bvh(path), clip)


def test_transition_written_on_a_skeleton(tmp_path):
    a, b = _read("bvh/07_01.bvh"), _read("acclaim/09_02.amc", "acclaim/09-run.asf")
    joined = transition(a, b, frames=12)
    same_clip(load_bvh(write_bvh(joined, tmp_path / "joined.bvh")), joined)


def test_never_replaces_and_refuses_clips_without_a_skeleton(tmp_path):
    clip = _read("bvh/09_02.bvh")
    path = tmp_path / "x.bvh"
    path.write_text("mine")
    with pytest.raises(ShapeSigError, match="exists"):
        write_bvh(clip, path)
    assert path.read_text() == "mine"
    bare = type(clip)(name="bare", bones=clip.bones, rotations=clip.rotations, fps=clip.fps)
    with pytest.raises(ShapeSigError, match="rest skeleton"):
        write_bvh(bare, tmp_path / "bare.bvh")
    assert not (tmp_path / "bare.bvh").exists()
