"""BVH files written by core.io.bvh_write read by Blender's own BVH importer (``readers.bvh.import_bvh``) equal the
clip written, to 1e-5 (rotations; root path relative to the clip's largest coordinate, the importer keys 32-bit
floats), for real clips of three rigs and a transition across rigs."""

import pathlib

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from blender_shapesig.core.blend.transition import transition  # noqa: E402
from blender_shapesig.core.io.bvh_write import write_bvh  # noqa: E402
from blender_shapesig.core.io.sources import read_one  # noqa: E402
from blender_shapesig.readers.bvh import import_bvh  # noqa: E402

DATA = pathlib.Path(__file__).resolve().parents[2] / "data"


def _read(name, asf=None):
    return read_one(str(DATA / name), asf=None if asf is None else str(DATA / asf), bone_map="none", trim="none")


def _same(back, clip):
    assert set(back.bones) == set(clip.bones) and back.frames == clip.frames
    assert back.fps == pytest.approx(clip.fps, rel=1e-4)  # the importer rounds 59.9988 (Frame Time 0.016667) to 60
    idx = [back.bones.index(b) for b in clip.bones]
    np.testing.assert_allclose(back.rotations[:, idx], clip.rotations, rtol=0, atol=1e-5)
    scale = max(1.0, float(np.abs(clip.root_translation).max()))
    np.testing.assert_allclose(back.root_translation / scale, clip.root_translation / scale, rtol=0, atol=1e-5)
    assert {b: back.meta["parents"][b] for b in clip.bones} == {b: clip.meta["parents"][b] for b in clip.bones}


@pytest.mark.parametrize("name,asf", [("bvh/07_01.bvh", None), ("cross_rig/002_03.bvh", None),
                                      ("acclaim/07_01.amc", "acclaim/07-walk.asf")])
def test_blender_reads_back_the_clip(empty_file, tmp_path, name, asf):
    clip = _read(name, asf)
    _same(import_bvh(write_bvh(clip, tmp_path / "out.bvh")), clip)


def test_blender_reads_back_a_transition(empty_file, tmp_path):
    joined = transition(_read("bvh/07_01.bvh"), _read("cross_rig/002_03.bvh"), frames=15)
    _same(import_bvh(write_bvh(joined, tmp_path / "joined.bvh")), joined)
