"""ASF/AMC parser: structure of real CMU skeletons, forward kinematics against an independent BVH
conversion of the same take (MotionBuilder's 16_15.bvh), and clear one-line errors on bad input."""

import pathlib
import shutil

import numpy as np
import pytest

from blender_shapesig.core.io.acclaim import (
    forward_kinematics, load_acclaim, parse_amc, parse_asf,
)
from blender_shapesig.core.geometry.so3 import matrix_from_euler as euler_matrices
from blender_shapesig.core.io.acclaim import find_asf
from blender_shapesig.core.errors import ParseError

DATA = pathlib.Path(__file__).resolve().parents[2] / "data" / "acclaim"
ASF16 = DATA / "16.asf"
AMC16 = DATA / "16_15.amc"


# ------------------------------------------------------------------ an independent BVH reader


def _rot(axis, deg):
    a = np.radians(deg)
    c, s = np.cos(a), np.sin(a)
    one, zero = np.ones_like(a), np.zeros_like(a)
    if axis == "X":
        m = [[one, zero, zero], [zero, c, -s], [zero, s, c]]
    elif axis == "Y":
        m = [[c, zero, s], [zero, one, zero], [-s, zero, c]]
    else:
        m = [[c, -s, zero], [s, c, zero], [zero, zero, one]]
    return np.moveaxis(np.array(m), [0, 1], [-2, -1])


def bvh_joint_positions(path):
    """{joint name: (frames, 3)} world positions by plain BVH forward kinematics (channels in file order,
    each rotation applied in the parent's frame: R = R_c1 R_c2 R_c3)."""
    tokens = pathlib.Path(path).read_text().split()
    joints, stack, i = [], [], 0
    while tokens[i] != "MOTION":
        t = tokens[i]
        if t in ("ROOT", "JOINT", "End"):
            name = tokens[i + 1] if t != "End" else None
            joints.append({"name": name, "parent": stack[-1] if stack else -1, "channels": []})
            i += 2
        elif t == "{":
            stack.append(len(joints) - 1)
            i += 1
        elif t == "}":
            stack.pop()
            i += 1
        elif t == "OFFSET":
            joints[-1]["offset"] = np.array([float(x) for x in tokens[i + 1:i + 4]])
            i += 4
        elif t == "CHANNELS":
            n = int(tokens[i + 1])
            joints[-1]["channels"] = tokens[i + 2:i + 2 + n]
            i += 2 + n
        else:
            i += 1
    frames = int(tokens[i + 2])
    data = np.array([float(x) for x in tokens[i + 6:]]).reshape(frames, -1)
    pos, rot, col, out = {}, {}, 0, {}
    for j, joint in enumerate(joints):
        ch = joint["channels"]
        vals = data[:, col:col + len(ch)]
        col += len(ch)
        offset = np.tile(joint["offset"], (frames, 1))
        R = np.tile(np.eye(3), (frames, 1, 1))
        for k, c in enumerate(ch):
            if c.endswith("position"):
                offset[:, "XYZ".index(c[0])] = vals[:, k]
            else:
                R = R @ _rot(c[0], vals[:, k])
        p = joint["parent"]
        if p < 0:
            pos[j], rot[j] = offset, R
        else:
            pos[j] = pos[p] + np.einsum("fij,fj->fi", rot[p], offset)
            rot[j] = rot[p] @ R
        if joint["name"]:
            out[joint["name"]] = pos[j]
    return out


# ------------------------------------------------------------------------------- structure


def test_asf_structure_of_cmu_subject_16():
    sk = parse_asf(ASF16)
    names = sk.bone_names
    assert len(names) == 31 and names[0] == "root"
    assert sk.length_unit == 0.45 and sk.angle_unit == "deg"
    assert sk.root_order == ("TX", "TY", "TZ", "RX", "RY", "RZ") and sk.root_axis == "XYZ"
    # parents come before their children
    parents = sk.parent_indices()
    assert all(p < j for j, p in enumerate(parents))
    lfemur = sk.bones["lfemur"]
    assert lfemur.parent == "lhipjoint" and lfemur.children == ["ltibia"]
    assert lfemur.dof == ("rx", "ry", "rz") and len(lfemur.limits) == 3
    assert lfemur.limits[0] == (-160.0, 20.0)
    np.testing.assert_allclose(lfemur.axis, np.radians([0, 0, 20]))
    np.testing.assert_allclose(lfemur.length, 7.03469)
    assert sk.bones["ltibia"].dof == ("rx",)
    assert sk.bones["lhipjoint"].dof == ()
    assert sk.bones["thorax"].children == ["lowerneck", "lclavicle", "rclavicle"]


def test_euler_matrices_apply_the_first_axis_first():
    a = np.array([[10.0, -35.0, 70.0]])
    np.testing.assert_allclose(
        euler_matrices(np.radians(a), "XYZ")[0], _rot("Z", 70.0) @ _rot("Y", -35.0) @ _rot("X", 10.0), atol=1e-12
    )
    np.testing.assert_allclose(
        euler_matrices(np.radians(a), "ZXY")[0], _rot("Y", 70.0) @ _rot("X", -35.0) @ _rot("Z", 10.0), atol=1e-12
    )


def test_amc_values_and_units():
    sk = parse_asf(ASF16)
    m = parse_amc(AMC16, sk)
    assert m.frames == 471 and m.frame_numbers[0] == 1 and m.frame_numbers[-1] == 471
    # first frame, straight from the file: "root 1.22935 17.2598 -26.9208 0.489518 -4.81374 -3.87663"
    np.testing.assert_allclose(m.values["root"][0, :3], [1.22935, 17.2598, -26.9208])
    np.testing.assert_allclose(m.values["root"][0, 3:], np.radians([0.489518, -4.81374, -3.87663]))
    np.testing.assert_allclose(m.values["rtibia"][0], np.radians([18.8225]))
    np.testing.assert_allclose(m.root_translation()[0], [1.22935, 17.2598, -26.9208])


def test_forward_kinematics_matches_motionbuilder_bvh_of_the_same_take():
    """16_15.bvh (MotionBuilder) holds exact poses on every 4th frame (0, 4, 8, ...; it keyed at 30 Hz and
    interpolated in between). There, every shared joint agrees with our FK to 1e-3 of the shortest bone
    (0.024 mm; the BVH prints 6 significant digits, ~1e-3 cm at 150 cm from the origin).
    Units: the BVH is in cm = ASF units * 2.54 / 0.45 (CMU: ``length 0.45`` = 1/0.45 inch)."""
    sk = parse_asf(ASF16)
    m = parse_amc(AMC16, sk)
    heads, tails = forward_kinematics(m)
    cm = heads * sk.meters_per_unit * 100.0
    bvh = bvh_joint_positions(DATA / "16_15.bvh")
    shared = [n for n in sk.bone_names if n in bvh]
    assert len(shared) == 29  # all but lhipjoint/rhipjoint (no dof, merged into the root by MotionBuilder)
    lengths = np.array([b.length for b in sk.bones.values() if b.length > 0]) * sk.meters_per_unit * 100
    tolerance = 1e-3 * lengths.min()
    worst_exact, worst_between = 0.0, 0.0
    for name in shared:
        j = sk.bone_names.index(name)
        err = np.linalg.norm(bvh[name] - cm[:, j], axis=-1)
        worst_exact = max(worst_exact, err[0::4].max())
        worst_between = max(worst_between, err[1::4].max())
    assert worst_exact < tolerance, worst_exact
    # ... and the in-between frames really are different (so the comparison above can fail)
    assert worst_between > 100 * tolerance


def test_clip_rotations_are_conjugated_amc_rotations():
    sk = parse_asf(ASF16)
    clip = load_acclaim(AMC16, ASF16)
    assert clip.bones == sk.bone_names and clip.frames == 471 and clip.fps == 120.0
    assert clip.frame_start == 1 and clip.root_bone == "root"
    assert clip.rotation_modes[clip.bones.index("ltibia")] == "XYZ"
    R = clip.rotations
    np.testing.assert_allclose(R @ np.swapaxes(R, -1, -2), np.broadcast_to(np.eye(3), R.shape), atol=1e-12)
    # bones without dof never move
    assert "lhipjoint" in clip.still_bones() and "rhipjoint" in clip.still_bones()
    # ltibia: one dof rx about the bone's local X axis = C's first column; L rotates about it
    j = clip.bones.index("ltibia")
    C = sk.bones["ltibia"].axis_matrix
    m = parse_amc(AMC16, sk)
    expected = C @ _rot("X", np.degrees(m.values["ltibia"][:, 0])) @ C.T
    np.testing.assert_allclose(R[:, j], expected, atol=1e-12)
    np.testing.assert_allclose(clip.root_translation[0], [1.22935, 17.2598, -26.9208])


def test_skeleton_found_beside_amc(tmp_path):
    shutil.copy(ASF16, tmp_path / "16.asf")
    shutil.copy(AMC16, tmp_path / "16_15.amc")
    clip = load_acclaim(tmp_path / "16_15.amc")
    assert clip.name == "16_15" and clip.meta["asf"] == str(tmp_path / "16.asf")
    assert find_asf(tmp_path / "16_15.amc") == str(tmp_path / "16.asf")


def test_skeleton_none_or_several(tmp_path):
    shutil.copy(AMC16, tmp_path / "16_15.amc")
    with pytest.raises(ParseError, match="no .asf"):
        load_acclaim(tmp_path / "16_15.amc")
    with pytest.raises(ParseError, match="3 .asf files"):
        load_acclaim(DATA / "07_01.amc")  # tests/data/acclaim holds three skeletons


def test_other_subjects_parse():
    for amc, asf, frames in (("07_01.amc", "07-walk.asf", 316), ("09_02.amc", "09-run.asf", 130)):
        clip = load_acclaim(DATA / amc, DATA / asf)
        assert clip.frames == frames and len(clip.bones) == 31


# ------------------------------------------------------------------------------- bad input

ASF_TEXT = ASF16.read_text()
AMC_TEXT = AMC16.read_text()


def _asf_error(text):
    with pytest.raises(ParseError) as info:
        parse_asf(text if "\n" in text or not text else text)
    msg = str(info.value)
    assert "\n" not in msg
    return msg


def _amc_error(text, sk=None):
    sk = sk or parse_asf(ASF16)
    with pytest.raises(ParseError) as info:
        parse_amc(text, sk)
    msg = str(info.value)
    assert "\n" not in msg
    return msg


def test_asf_errors():
    assert "empty" in _asf_error("")
    assert "empty" in _asf_error("  \n\n")
    assert "missing :bonedata" in _asf_error(ASF_TEXT.split(":bonedata")[0])
    assert "missing :hierarchy" in _asf_error(ASF_TEXT.split(":hierarchy")[0])
    # truncated inside a bone
    cut = ASF_TEXT[: ASF_TEXT.index("name ltibia") + 20]
    assert "missing :hierarchy" in _asf_error(cut) or "'end'" in _asf_error(cut)
    # truncated inside the hierarchy
    assert "not closed" in _asf_error(ASF_TEXT[: ASF_TEXT.rindex("end")])
    bad = ASF_TEXT.replace("length 7.03469", "length seven", 1)
    assert "'seven' is not a number" in _asf_error(bad)
    bad = ASF_TEXT.replace("length 7.03469", "length nan", 1)
    assert "not a finite number" in _asf_error(bad)
    bad = ASF_TEXT.replace("direction 0.34202 -0.939693 0 ", "direction 0.34202 -0.939693", 1)
    assert "expected 3 numbers, got 2" in _asf_error(bad)
    bad = ASF_TEXT.replace("lfemur ltibia", "lfemur ltibiaX", 1)
    assert "unknown bone 'ltibiaX'" in _asf_error(bad)
    bad = ASF_TEXT.replace("axis 0 0 20  XYZ", "axis 0 0 20  XYQ", 1)
    assert "axis order" in _asf_error(bad)
    bad = ASF_TEXT.replace("    lfemur ltibia\n", "", 1)
    assert "not connected to the root" in _asf_error(bad)
    bad = ASF_TEXT.replace("angle deg", "angle grad", 1)
    assert "units angle" in _asf_error(bad)
    with pytest.raises(ParseError, match="no such ASF file"):
        parse_asf(DATA / "nothere.asf")


def test_amc_errors():
    assert "empty" in _amc_error("")
    assert "no frames" in _amc_error(":FULLY-SPECIFIED\n:DEGREES\n")
    bad = AMC_TEXT.replace("rtibia 18.8225", "rtibiaX 18.8225", 1)
    assert "bone 'rtibiaX' is not in the skeleton" in _amc_error(bad)
    bad = AMC_TEXT.replace("rtibia 18.8225", "rtibia 18.8225 3.0", 1)
    assert "needs 1 values (its dof), got 2" in _amc_error(bad)
    bad = AMC_TEXT.replace("rtibia 18.8225", "rtibia abc", 1)
    assert "'abc' is not a number" in _amc_error(bad)
    bad = AMC_TEXT.replace("rtibia 18.8225", "rtibia NaN", 1)
    assert "not a finite number" in _amc_error(bad)
    bad = AMC_TEXT.replace("rtibia 18.8225", "rtibia inf", 1)
    assert "not a finite number" in _amc_error(bad)
    # truncated: the last frame loses its last lines
    lines = AMC_TEXT.rstrip("\n").split("\n")
    msg = _amc_error("\n".join(lines[:-3]) + "\n")
    assert "frame 471 has no values for bone(s)" in msg and "truncated" in msg
    # truncated mid-line
    msg = _amc_error("\n".join(lines[:-1]) + "\n" + lines[-1].split()[0] + "\n")
    assert "needs" in msg
    # a bone twice, frames out of order, values before any frame number
    bad = AMC_TEXT.replace("rtibia 18.8225\n", "rtibia 18.8225\nrtibia 18.8225\n", 1)
    assert "given twice" in _amc_error(bad)
    bad = AMC_TEXT.replace("\n2\n", "\n5\n", 1)
    assert "consecutive" in _amc_error(bad)
    assert "expected a frame number" in _amc_error(":DEGREES\nroot 1 2 3 4 5 6\n")
    # a non-AMC file given as AMC
    assert "expected a frame number, got 'mass 1.0'" in _amc_error(ASF_TEXT)


def test_radians_header():
    sk = parse_asf(ASF16)
    text = AMC_TEXT.replace(":DEGREES", ":RADIANS", 1)
    m = parse_amc(text, sk)
    np.testing.assert_allclose(m.values["rtibia"][0], [18.8225])
