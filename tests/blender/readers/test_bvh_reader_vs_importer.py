"""Our bpy-free BVH reader equals Blender's importer (``readers.bvh.import_bvh``, armature space) on every BVH
file in tests/data and on a synthetic file with the importer's naming rules: same bones, rotation modes, frames,
fps, root; rotations to 1e-6 (the importer keys 32-bit floats), root positions to 1e-4 (CMU units, ~30)."""

import pathlib

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from blender_shapesig.core.io.bvh import load_bvh  # noqa: E402
from blender_shapesig.readers.bvh import import_bvh  # noqa: E402

DATA = pathlib.Path(__file__).resolve().parents[2] / "data" / "bvh"


def _same(ours, blender):
    assert ours.bones == blender.bones
    assert ours.rotation_modes == blender.rotation_modes
    assert (ours.name, ours.frames, ours.fps, ours.frame_start, ours.root_bone) == \
        (blender.name, blender.frames, blender.fps, blender.frame_start, blender.root_bone)
    assert ours.meta["missing_rotation_bones"] == blender.meta["missing_rotation_bones"]
    assert ours.meta["rotation_space"] == blender.meta["rotation_space"] == "armature"
    assert ours.meta["parents"] == blender.meta["parents"]  # the hierarchy core.rigs composes rotations down
    np.testing.assert_allclose(ours.rotations, blender.rotations, rtol=0, atol=1e-6)
    assert (ours.root_translation is None) == (blender.root_translation is None)
    if ours.root_translation is not None:
        np.testing.assert_allclose(ours.root_translation, blender.root_translation, rtol=0, atol=1e-4)


@pytest.mark.parametrize("name", sorted(p.name for p in DATA.glob("*.bvh")))
def test_equals_blender_importer(empty_file, name):
    _same(load_bvh(DATA / name), import_bvh(DATA / name))


def test_equals_blender_importer_on_naming_rules(empty_file, tmp_path):
    from tests.helpers.synthetic_bvh import SYNTHETIC

    path = tmp_path / "synthetic.bvh"
    path.write_bytes(SYNTHETIC.encode())
    ours = load_bvh(path)
    _same(ours, import_bvh(path))
    assert ours.bones == ("Hips", "Left_Leg", "Foot", "Foot.001")
