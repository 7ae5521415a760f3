"""Our bpy-free BVH reader (``core.io.bvh.load_bvh``): rotations against an independent reading of the
Euler channels (scipy), names and channel orders as Blender's importer makes them, errors naming the line.
Its equality with Blender's importer is tests/blender/readers/test_bvh_reader_vs_importer.py."""

import pathlib

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from blender_shapesig.core.errors import ParseError
from blender_shapesig.core.io.bvh import BVH_TO_BLENDER, load_bvh
from blender_shapesig.core.io.sources import read
from tests.helpers.synthetic_bvh import SYNTHETIC

DATA = pathlib.Path(__file__).resolve().parents[2] / "data" / "bvh"
A = BVH_TO_BLENDER


@pytest.mark.parametrize("name", sorted(p.name for p in DATA.glob("*.bvh")))
def test_rotations_equal_the_channels_in_blender_axes(name, bvh_channels):
    clip = load_bvh(DATA / name)
    _names, truth, data = bvh_channels(DATA / name)
    assert clip.frames == len(data) and clip.fps == 120.0 and clip.frame_start == 1
    for j, R in enumerate(truth):
        np.testing.assert_allclose(clip.rotations[:, j], A @ R @ A.T, atol=1e-12, err_msg=clip.bones[j])
    # the root's position channels (X Y Z) in Blender axes
    np.testing.assert_allclose(clip.root_translation, data[:, :3] @ A.T, atol=1e-12)
    assert clip.meta["rotation_space"] == "armature" and clip.meta["up_axis"] == "Z"


def test_names_orders_and_extra_frames(tmp_path):
    path = tmp_path / "synthetic.bvh"
    path.write_bytes(SYNTHETIC.encode())
    clip = load_bvh(path)
    assert clip.bones == ("Hips", "Left_Leg", "Foot", "Foot.001")
    assert clip.rotation_modes == ("ZYX", "XYZ", "XYZ", "YXZ")  # channel order; no channels: the importer's XYZ
    assert clip.meta["missing_rotation_bones"] == ("Foot",)
    assert clip.frames == 3 and clip.fps == 30.0 and clip.root_bone == "Hips"
    np.testing.assert_allclose(clip.root_translation[1], A @ [5.0, 6.0, 4.0])  # Zposition Xposition Yposition
    R = Rotation.from_euler("YXZ", [179, 89, -179], degrees=True).as_matrix()
    np.testing.assert_allclose(clip.rotations[1, 3], A @ R @ A.T, atol=1e-12)
    assert np.array_equal(clip.rotations[:, 2], np.broadcast_to(np.eye(3), (3, 3, 3)))
    # the registry reads .bvh with this reader (no Blender)
    (same,) = read(str(path))
    np.testing.assert_array_equal(same.rotations, clip.rotations)


@pytest.mark.parametrize("bad, match", [
    ("Frame Time: 0.0333333\r\n1 2 3 10 20 30 -40 50 60 70 -80 90\r\n4 5 x 1 1 1 1 1 1 1 1 1", "not a number"),
    ("Frame Time: 0.0333333\r\n1 2 3 10 20 30 -40 50 60 70 -80 90\r\n4 5 6 nan 1 1 1 1 1 1 1 1", "not a finite"),
    ("Frame Time: 0.0333333\r\n1 2 3 10 20 30 -40 50 60 70 -80 90\r\n4 5 6 1 1 1 1 1 1 1 1", "11 values for 12"),
    ("Frame Time: 0\r\n1 2 3 10 20 30 -40 50 60 70 -80 90\r\n", "positive"),
])
def test_bad_motion_names_the_line(tmp_path, bad, match):
    text = SYNTHETIC.split("Frame Time")[0] + bad + "\r\n"
    path = tmp_path / "bad.bvh"
    path.write_bytes(text.encode())
    with pytest.raises(ParseError, match=match):
        load_bvh(path)


def test_bad_hierarchy(tmp_path):
    path = tmp_path / "bad.bvh"
    path.write_text(SYNTHETIC.replace("CHANNELS 3 Xrotation Yrotation Zrotation", "CHANNELS 3 Xrotation Zrotation Xposition"))
    with pytest.raises(ParseError, match="rotation channels"):
        load_bvh(path)
    path.write_text("hello\n")
    with pytest.raises(ParseError, match="HIERARCHY"):
        load_bvh(path)
    path.write_text(SYNTHETIC.split("MOTION")[0])
    with pytest.raises(ParseError, match="MOTION"):
        load_bvh(path)
    with pytest.raises(ParseError, match="no such file"):
        load_bvh(tmp_path / "missing.bvh")
