"""SMPL / AMASS .npz files (core.io.smpl): files the test writes (pure numpy), checked by a closed-form forward
kinematics of the SMPL tree; the automatic map; other .npz files and a signature cache in a library folder."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from blender_shapesig.core import rigs
from blender_shapesig.core.clip import skeleton
from blender_shapesig.core.errors import ParseError
from blender_shapesig.core.io import smpl, sources


def _write(path, frames=30, seed=0, **extra):
    rng = np.random.default_rng(seed)
    poses = np.zeros((frames, 156))
    poses[:, :66] = rng.normal(scale=0.4, size=(frames, 66))
    trans = np.cumsum(rng.normal(scale=0.01, size=(frames, 3)), axis=0) + [0.0, 0.0, 0.9]
    data = dict(poses=poses, trans=trans, mocap_framerate=np.array(60.0), betas=np.zeros(16),
                gender=np.array("neutral"))
    data.update(extra)
    np.savez(path, **data)
    return poses, trans


def test_forward_kinematics_is_the_smpl_tree(tmp_path):
    """Joint positions of the clip (the package's FK) equal SMPL's FK of the file's rotations on the rest table:
    p_0 = trans + J_0, G_0 = R_0; G_j = G_parent R_j, p_j = p_parent + G_parent o_j (the file's Z-up world)."""
    poses, trans = _write(tmp_path / "walk.npz")
    clip = sources.read_one(sources.ClipSpec(str(tmp_path / "walk.npz"), bone_map="none", trim="none"))
    assert clip.bones == smpl.BODY_JOINTS and clip.fps == 60.0 and clip.frames == 30
    R = Rotation.from_rotvec(poses[:, :66].reshape(-1, 3)).as_matrix().reshape(30, 22, 3, 3)
    G, p = np.empty_like(R), np.empty((30, 22, 3))
    for j, par in enumerate(smpl.BODY_PARENTS):
        if par < 0:
            G[:, j], p[:, j] = R[:, j], trans + smpl.REST_OFFSETS[0]
        else:
            G[:, j] = G[:, par] @ R[:, j]
            p[:, j] = p[:, par] + np.einsum("fab,b->fa", G[:, par], smpl.REST_OFFSETS[j])
    heads, _tails, _W = skeleton.forward_kinematics(clip)
    np.testing.assert_allclose(heads, p, atol=1e-9)


def test_smpl_maps_every_canonical_joint_with_sides_from_the_rest(tmp_path):
    _write(tmp_path / "a.npz")
    clip = sources.read_one(sources.ClipSpec(str(tmp_path / "a.npz"), bone_map="none", trim="none"))
    report = rigs.analyse_clip(clip)
    assert report.sides == "rest" and set(report.mapping.values()) == set(rigs.JOINTS)
    assert report.mapping["left_hip"] == "thigh.L" and report.mapping["right_shoulder"] == "upper_arm.R"
    assert report.mapping["spine3"] == "chest" and report.mapping["left_foot"] == "toe.L"


def test_smplx_keys_and_refusals_in_one_line(tmp_path):
    poses = np.zeros((5, 165))
    np.savez(tmp_path / "x.npz", poses=poses, trans=np.zeros((5, 3)), mocap_frame_rate=np.array(30.0))
    clip = smpl.load_smpl(tmp_path / "x.npz")
    assert clip.meta["model"] == "SMPL-X" and clip.fps == 30.0
    np.savez(tmp_path / "other.npz", a=np.zeros(3))
    with pytest.raises(ParseError, match=r"not an SMPL/AMASS motion file \(no 'poses'"):
        smpl.load_smpl(tmp_path / "other.npz")
    np.savez(tmp_path / "odd.npz", poses=np.zeros((5, 70)), mocap_framerate=np.array(30.0))
    with pytest.raises(ParseError, match=r"'poses' has shape \(5, 70\)"):
        smpl.load_smpl(tmp_path / "odd.npz")
    np.savez(tmp_path / "norate.npz", poses=np.zeros((5, 72)))
    with pytest.raises(ParseError, match="no frame rate"):
        smpl.load_smpl(tmp_path / "norate.npz")
    _write(tmp_path / "nan.npz", poses=np.full((30, 156), np.nan))
    with pytest.raises(ParseError, match="not finite"):
        smpl.load_smpl(tmp_path / "nan.npz")
    whole = (tmp_path / "a.npz")
    _write(whole)
    (tmp_path / "cut.npz").write_bytes(whole.read_bytes()[:2000])
    with pytest.raises(ParseError) as err:
        smpl.load_smpl(tmp_path / "cut.npz")
    assert "\n" not in str(err.value)
    (tmp_path / "text.npz").write_text("hello")
    with pytest.raises(ParseError, match="not an SMPL/AMASS .npz file"):
        smpl.load_smpl(tmp_path / "text.npz")


def test_a_library_folder_skips_signature_caches(tmp_path):
    """The signature cache writes <sha1>.npz entries: a folder scan never takes them (nor any CACHEDIR.TAG
    folder) for clips; a real SMPL file beside them is found."""
    _write(tmp_path / "walk.npz")
    cache = tmp_path / "blender_shapesig-cache"
    cache.mkdir()
    np.savez(cache / ("0" * 40 + ".npz"), meta=np.zeros(3))
    tagged = tmp_path / "other_cache"
    tagged.mkdir()
    (tagged / "CACHEDIR.TAG").write_text("Signature: 8a477f597d28d172789f06886806bc55\n")
    np.savez(tagged / "x.npz", meta=np.zeros(3))
    assert sources.discover([str(tmp_path)]) == [str(tmp_path / "walk.npz")]
