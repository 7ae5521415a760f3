"""core.rigs: canonical joints, name tables, saved maps, the comparison space (pure: AMC clips, no Blender)."""

import dataclasses
import json
import re

import numpy as np
import pytest

from blender_shapesig.core import rigs
from blender_shapesig.core.io import sources
from blender_shapesig.core.geometry import so3
from blender_shapesig.core.clip.clip import Clip
from blender_shapesig.core.errors import ParseError, ShapeSigError
from blender_shapesig.core.metrics import check_coverage, clip_distance, compare_clips


def _bvh_names(path):
    return re.findall(r"(?:ROOT|JOINT)\s+(\S+)", path.read_text().split("MOTION")[0])


@pytest.fixture(scope="module")
def walk(data_dir):
    spec = sources.ClipSpec(str(data_dir / "acclaim" / "07_01.amc"), asf=str(data_dir / "acclaim" / "07-walk.asf"))
    return sources.read_one(spec), sources.read_one(sources.ClipSpec(spec.path, asf=spec.asf, bone_map="none"))


# --- name tables -----------------------------------------------------------------------------------------

def test_cmu_asf_daz_and_iclone_files_map_every_limb(data_dir):
    asf = sources.read_one(sources.ClipSpec(str(data_dir / "acclaim" / "07_01.amc"),
                                            asf=str(data_dir / "acclaim" / "07-walk.asf"), bone_map="none"))
    assert rigs.detect_family(asf.bones)[0] == "cmu_asf"
    assert set(rigs.detect_map(asf.bones).values()) == set(rigs.JOINTS)
    daz = _bvh_names(data_dir / "bvh" / "07_01.bvh")
    m = rigs.detect_map(daz)
    assert rigs.detect_family(daz)[0] == "daz"
    assert m["rShldr"] == "upper_arm.R" and m["lShin"] == "shin.L" and m["abdomen"] == "spine"
    assert set(rigs.JOINTS) - set(m.values()) == {"spine_mid", "toe.L", "toe.R"}  # the Daz rig has none
    cc = _bvh_names(data_dir / "cross_rig" / "002_03.bvh")
    m = rigs.detect_map(cc)
    assert rigs.detect_family(cc)[0] == "cc"
    assert set(m.values()) == set(rigs.JOINTS)
    assert m["CC_Base_L_Calf"] == "shin.L" and "CC_Base_L_ThighTwist01" not in m


@pytest.mark.parametrize("names, expect", [
    (["mixamorig:Hips", "mixamorig:Spine", "mixamorig:Spine1", "mixamorig:Spine2", "mixamorig:LeftShoulder",
      "mixamorig:LeftArm", "mixamorig:LeftUpLeg", "mixamorig:LeftLeg", "mixamorig:LeftToeBase"],
     {"mixamorig:Spine2": "chest", "mixamorig:LeftShoulder": "clavicle.L", "mixamorig:LeftArm": "upper_arm.L",
      "mixamorig:LeftLeg": "shin.L", "mixamorig:LeftToeBase": "toe.L"}),
    (["mixamorig1:Hips", "mixamorig1:RightUpLeg", "mixamorig1:RightForeArm", "mixamorig1:Neck"],
     {"mixamorig1:RightUpLeg": "thigh.R", "mixamorig1:RightForeArm": "forearm.R", "mixamorig1:Neck": "neck"}),
    (["Hips", "LHipJoint", "LeftHip", "LeftKnee", "LeftAnkle", "LeftToe", "lowerback", "Chest", "Chest2",
      "LeftCollar", "LeftShoulder", "LeftElbow", "LeftWrist", "lhand"],
     {"LeftShoulder": "upper_arm.L", "LeftCollar": "clavicle.L", "Chest2": "chest", "LeftHip": "thigh.L",
      "lhand": "hand.L"}),
    (["DEF-spine", "DEF-spine.001", "DEF-spine.003", "DEF-thigh.L", "DEF-shin.R", "DEF-upper_arm.L",
      "DEF-upper_arm.L.001", "DEF-shoulder.R"],
     {"DEF-spine": "hips", "DEF-thigh.L": "thigh.L", "DEF-upper_arm.L": "upper_arm.L", "DEF-shoulder.R": "clavicle.R"}),
    (["pelvis", "left_hip", "right_knee", "spine3", "left_shoulder", "left_collar"],
     {"pelvis": "hips", "left_hip": "thigh.L", "right_knee": "shin.R", "left_shoulder": "upper_arm.L"}),
    (["Pelvis", "L_Hip", "R_Ankle", "L_Collar", "L_Shoulder", "L_Wrist"],
     {"L_Hip": "thigh.L", "R_Ankle": "foot.R", "L_Shoulder": "upper_arm.L", "L_Wrist": "hand.L"}),
])
def test_families_and_prefixes(names, expect):
    m = rigs.detect_map(names)
    for bone, joint in expect.items():
        assert m.get(bone) == joint, (bone, m)
    assert len(set(m.values())) == len(m)  # one bone per joint


def test_longer_spine_chain_spreads_over_spine_mid_and_chest():
    """The hierarchy places the spine: the bone the arms branch from is the chest (whatever the table says),
    the first above the hips the spine, the middle one spine_mid; extra spine bones stay unmapped."""
    names = ["Hips", "Spine", "Spine1", "Spine2", "Spine3", "Spine4", "Neck", "Head", "LeftUpLeg", "LeftLeg",
             "RightUpLeg", "RightLeg", "LeftArm", "LeftForeArm", "RightArm", "RightForeArm"]
    parents = {"Hips": None, "Spine": "Hips", "Spine1": "Spine", "Spine2": "Spine1", "Spine3": "Spine2",
               "Spine4": "Spine3", "Neck": "Spine4", "Head": "Neck", "LeftUpLeg": "Hips", "LeftLeg": "LeftUpLeg",
               "RightUpLeg": "Hips", "RightLeg": "RightUpLeg", "LeftArm": "Spine4", "LeftForeArm": "LeftArm",
               "RightArm": "Spine4", "RightForeArm": "RightArm"}
    m = rigs.detect_map(names, parents)
    assert m["Spine"] == "spine" and m["Spine2"] == "spine_mid" and m["Spine4"] == "chest"
    assert "Spine1" not in m and "Spine3" not in m
    assert m["LeftArm"] == "upper_arm.L" and m["RightForeArm"] == "forearm.R" and m["LeftLeg"] == "shin.L"
    assert rigs.detect_map(["a", "b", "c"]) == {} and rigs.detect_map(["Hips", "b", "c"]) == {}
    assert rigs.detect_map(["root"]) == {"root": "hips"}  # every bone of a one-bone clip maps


# --- saved maps ------------------------------------------------------------------------------------------

def test_saved_map_round_trip_and_errors(tmp_path):
    m = {"lThigh": "thigh.L", "hip": "hips"}
    path = rigs.save_map(tmp_path / "daz.json", m, rig="daz")
    assert json.loads(open(path).read())["#rig"] == "daz"
    assert rigs.load_map(path) == m
    (tmp_path / "bad.json").write_text('{"lThigh": "femur"}')
    with pytest.raises(ParseError, match="unknown joint 'femur'"):
        rigs.load_map(tmp_path / "bad.json")
    (tmp_path / "twice.json").write_text('{"a": "hips", "b": "hips"}')
    with pytest.raises(ParseError, match="given to two bones"):
        rigs.load_map(tmp_path / "twice.json")
    (tmp_path / "broken.json").write_text('{"a": ')
    with pytest.raises(ParseError, match="not valid JSON"):
        rigs.load_map(tmp_path / "broken.json")


def test_saved_map_file_through_the_front_door(data_dir, tmp_path, walk):
    """A saved map renames exactly what it names; the key follows the map's content."""
    mapped, _raw = walk
    path = tmp_path / "legs.json"
    rigs.save_map(path, {"root": "hips", "lfemur": "thigh.L", "rfemur": "thigh.R"})
    spec = sources.ClipSpec(str(data_dir / "acclaim" / "07_01.amc"), asf=str(data_dir / "acclaim" / "07-walk.asf"),
                            bone_map=str(path))
    legs = sources.read_one(spec)
    assert legs.bones == ("hips", "thigh.L", "thigh.R")
    np.testing.assert_allclose(legs.rotations, mapped.select(legs.bones).rotations, atol=1e-12)
    key = spec.key()
    rigs.save_map(path, {"root": "hips", "lfemur": "thigh.L"})
    assert spec.key() != key and spec.key() != sources.ClipSpec(spec.path, asf=spec.asf).key()


# --- the comparison space --------------------------------------------------------------------------------

def _other_rig(raw: Clip, seed=0):
    """The same motion on a rig with other rest poses / bone rolls (a constant right factor K_b per bone), facing
    elsewhere (a yaw G on the left) and with other bone names: local X'_b = W'_parent^T W'_b, W'_b = G W_b K_b."""
    rng = np.random.default_rng(seed)
    W = rigs.world_rotations(raw)
    K = so3.exp(rng.normal(scale=0.6, size=(len(raw.bones), 3)))
    G = so3.exp(np.array([0.0, 0.0, 2.1]))
    W2 = G[None, None] @ W @ K[None]
    parents = raw.meta["parents"]
    index = {b: i for i, b in enumerate(raw.bones)}
    X = np.empty_like(W2)
    for b, i in index.items():
        p = parents.get(b)
        X[:, i] = W2[:, i] if p is None else np.swapaxes(W2[:, index[p]], -1, -2) @ W2[:, i]
    rename = {b: "X_" + b for b in raw.bones}
    return Clip(name="other", bones=[rename[b] for b in raw.bones], rotations=X, fps=raw.fps,
                root_translation=0.3 * raw.root_translation @ G.T,  # inches or meters: only the direction counts
                meta={"parents": {rename[b]: (rename[p] if p else None) for b, p in parents.items()}})


def test_world_space_survives_rest_poses_rolls_and_heading(walk):
    mapped, raw = walk
    other = _other_rig(raw)
    table = {"X_" + b: j for b, j in rigs.detect_map(raw.bones).items()}
    moved = rigs.to_comparison_space(other, table)
    assert moved.bones == mapped.bones
    # increments agree up to the heading (a yaw): the SRVT and the signature see the same curve
    assert clip_distance(mapped, moved, "sim3") < 1e-6
    assert clip_distance(mapped, moved, "l2") < 1e-6
    # the local rotations of the same two rigs do not agree
    local = Clip(name="x", bones=raw.bones, rotations=other.rotations, fps=raw.fps)
    assert clip_distance(raw, local, "sim3") > 0.1


def _turned(raw, degrees):
    """The whole rig turned about the vertical: rest skeleton, every bone's motion (armature axes) and the root
    path, ``X' = T X T^T``."""
    from blender_shapesig.core.clip import skeleton

    T = so3.exp(np.radians(degrees) * np.array([0.0, 0.0, 1.0]))
    meta = dict(raw.meta)
    for key in (skeleton.REST_HEADS, skeleton.REST_TAILS):
        meta[key] = {b: tuple(T @ np.asarray(v)) for b, v in raw.meta[key].items()}
    return dataclasses.replace(raw, rotations=T[None, None] @ raw.rotations @ T.T[None, None],
                               root_translation=raw.root_translation @ T.T, meta=meta), T


def _in_place(raw):
    rt = raw.root_translation.copy()
    rt[:, :2] = rt[0, :2]  # an in-place take (Mixamo's "in place", an idle): the heading is the body's facing
    return dataclasses.replace(raw, root_translation=rt)


@pytest.mark.parametrize("degrees", [30.0, 90.0, 180.0])
@pytest.mark.parametrize("path, in_place", [(("acclaim", "07_01.amc"), False), (("acclaim", "07_01.amc"), True),
                                            (("cross_rig", "002_03.bvh"), True), (("bvh", "13_32.bvh"), True)])
def test_a_rig_turned_about_up_gives_the_same_comparison_space(data_dir, path, in_place, degrees):
    """Closed form: a rig whose rest and motion are turned together about the vertical by T is the same take.
    Its comparison-space rotations are the unturned ones times T^T on the right (relative to its own, turned,
    rest), so the increments every measure sees, the hips' path and the joints' positions (FK with the rig's
    own rest offsets) agree to rounding; before, an in-place take turned 30 degrees was sim3 0.70 away."""
    from blender_shapesig.core.geometry.curves import relative_rotvecs
    from blender_shapesig.core.search.local.features import rig_positions

    asf = str(data_dir / "acclaim" / "07-walk.asf") if path[1].endswith(".amc") else None
    raw = sources.read_one(sources.ClipSpec(str(data_dir.joinpath(*path)), asf=asf, bone_map="none"))
    raw = _in_place(raw) if in_place else raw
    a = rigs.apply_bone_map(raw)
    moved, T = _turned(raw, degrees)
    b = rigs.apply_bone_map(moved)
    assert b.bones == a.bones and len(a.bones) >= 19
    np.testing.assert_allclose(b.rotations, a.rotations @ T.T[None, None], atol=1e-9)
    np.testing.assert_allclose(relative_rotvecs(b.rotations), relative_rotvecs(a.rotations), atol=1e-9)
    np.testing.assert_allclose(b.root_translation, a.root_translation, atol=1e-9)
    if "thigh.L" in a.bones and "foot.L" in a.bones:
        pa, pb = rig_positions(a)[0], rig_positions(b)[0]
        for j in pa:
            np.testing.assert_allclose(pb[j], pa[j], atol=1e-9)
    assert clip_distance(a, b, "sim3") < 1e-9
    # and the way back onto the turned rig is exact
    back = rigs.onto_rig(b, moved, b)
    np.testing.assert_allclose(back.rotations, moved.rotations, atol=1e-9)


def test_rest_forward_faces_the_way_the_rig_faces(walk):
    mapped, raw = walk
    f = rigs.rest_forward(raw, mapped.meta["bone_map"])
    assert f @ np.array([0.0, -1.0, 0.0]) > 0.95  # Acclaim rigs read into Blender's axes face -Y
    moved, T = _turned(raw, 90.0)
    np.testing.assert_allclose(rigs.rest_forward(moved, mapped.meta["bone_map"]), T @ f, atol=1e-12)


def test_onto_rig_inverts_the_comparison_space(walk):
    mapped, raw = walk
    back = rigs.onto_rig(mapped, raw, mapped)
    assert back.bones == raw.bones
    np.testing.assert_allclose(back.rotations, raw.rotations, atol=1e-9)
    assert set(back.meta["kept_bones"]) <= set(raw.bones) - set(mapped.meta["bone_map"].values())


def test_coverage_and_refusal(walk):
    mapped, raw = walk
    bones, cov = check_coverage(mapped, mapped)
    assert cov == 1.0 and bones == len(mapped.bones) - len(mapped.still_bones())
    # four joints of a rig that has 22: coverage 4/22, the others named; without the rigs' joints (clips read by
    # name) the old rule: the smaller clip's moving joints
    legs = mapped.select(["thigh.L", "shin.L", "foot.L", "thigh.R"])
    got = compare_clips(mapped, legs, "sim3", allow_partial=True)
    assert got["bones"] == 4 and got["coverage"] == pytest.approx(4 / 22)
    assert got["unmapped"] == [j for j in rigs.JOINTS if j not in legs.bones]
    with pytest.raises(ShapeSigError, match=r"coverage 0\.18 < 0\.5 \(unmapped: hips, spine, "):
        compare_clips(mapped, legs, "sim3")
    plain = dataclasses.replace(legs, meta={k: v for k, v in legs.meta.items() if k != "rig_joints"})
    got = compare_clips(mapped, plain, "sim3")
    assert got["bones"] == 4 and got["coverage"] == 1.0  # the smaller clip is covered
    # 2 shared of the smaller clip's 6 moving joints: refused, one line naming the coverage
    six = mapped.select(["hips", "thigh.L", "shin.L", "foot.L", "thigh.R", "shin.R"])
    other = Clip(name="six", bones=["hips", "thigh.L", "x1", "x2", "x3", "x4"], rotations=six.rotations)
    with pytest.raises(ShapeSigError, match=r"^clips '07_01' and 'six' share 2 moving joints, coverage 0\.33 < 0\.5"):
        check_coverage(mapped, other)
    assert compare_clips(mapped, other, "sim3", allow_partial=True)["coverage"] == pytest.approx(2 / 6)
    # a clip whose bones map to no canonical joint against a mapped one: one line naming the unmapped bones
    custom = Clip(name="custom", bones=["a_" + b for b in raw.bones], rotations=raw.rotations,
                  meta={"unmapped": True})
    with pytest.raises(ShapeSigError, match=r"^clips '07_01' and 'custom' share no bones: no bone of 'custom' maps "
                                            r"to a canonical joint \(unmapped bones: a_root, a_lhipjoint"):
        compare_clips(mapped, custom)


def test_same_bones_in_another_rest_pose_are_another_rig(walk):
    """rests_differ / other_rigs: the same CMU rig is one rig; its arms lowered 45 degrees into an A-pose (rest
    heads of the arm chains turned about the shoulders) make another rig, which blends through the comparison
    space and rest_retarget; other bone names are another rig."""
    _mapped, raw = walk
    assert not rigs.other_rigs(raw, raw)
    heads, parents = raw.meta["rest_heads"], raw.meta["parents"]
    turn = so3.exp(np.array([0.0, np.radians(45.0), 0.0]))  # about the forward axis

    def below(bone, top):
        while bone is not None and bone != top:
            bone = parents.get(bone)
        return bone == top

    posed = {}
    for side, sign in (("l", 1.0), ("r", -1.0)):
        shoulder = np.asarray(heads[f"{side}humerus"])
        R = turn if sign > 0 else turn.T
        posed.update({b: tuple(shoulder + R @ (np.asarray(h) - shoulder)) for b, h in heads.items()
                      if below(b, f"{side}humerus")})
    a_pose = dataclasses.replace(raw, meta=dict(raw.meta, rest_heads={**heads, **posed}))
    assert rigs.rests_differ(heads, parents, a_pose.meta["rest_heads"], parents)
    assert rigs.other_rigs(raw, a_pose) and rigs.other_rigs(a_pose, raw)
    assert rigs.other_rigs(raw, dataclasses.replace(raw, bones=tuple(reversed(raw.bones))))
    assert not rigs.rests_differ(heads, parents, {}, {})  # no rest skeleton: nothing to tell


def test_a_bone_between_two_written_spine_joints_shares_the_chain(walk):
    """A source without spine_mid written onto a rig that has one (the AMC rig's ``upperback`` between
    ``lowerback`` and ``thorax``; issue 38's Mixamo ``Spine1``): the bone between takes an equal share of the
    rotation from the spine to the chest instead of its rest, the chain's composed rotation is the source's (the
    chest keeps its orientation in the armature) and it is not listed as kept."""
    mapped, raw = walk
    by_joint = mapped.meta["bone_map"]
    src = mapped.select([j for j in mapped.bones if j != "spine_mid"])
    rest = dataclasses.replace(raw, rotations=np.broadcast_to(np.eye(3), raw.rotations.shape).copy())
    back = rigs.onto_rig(src, rest, mapped)
    i = {b: k for k, b in enumerate(raw.bones)}
    lower, mid, chest = by_joint["spine"], by_joint["spine_mid"], by_joint["chest"]
    # upperback between the spine and the chest; upperneck between the neck and the head (both at rest here)
    assert back.meta["chain_bones"] == (mid, "upperneck") and mid not in back.meta["kept_bones"]
    W_back, W_raw = rigs.world_rotations(back), rigs.world_rotations(raw)
    # the chest (and the spine) keep the source's orientation: the composed chain is the source's rotation
    for b in (lower, chest, by_joint["head"]):
        np.testing.assert_allclose(W_back[:, i[b]], W_raw[:, i[b]], atol=1e-9)
    composed = back.rotations[:, i[mid]] @ back.rotations[:, i[chest]]
    np.testing.assert_allclose(composed, raw.rotations[:, i[mid]] @ raw.rotations[:, i[chest]], atol=1e-9)
    # equal geodesic steps, and the middle bone moves as much as the chest does above it
    np.testing.assert_allclose(back.rotations[:, i[mid]], back.rotations[:, i[chest]], atol=1e-9)
    swing = so3.angle(back.rotations[:, i[mid]])
    assert np.ptp(swing) > np.radians(1.0) and np.ptp(swing) >= 0.3 * np.ptp(so3.angle(composed))
    # without the chain rule the middle bone kept its rest (the Spine1)
    full = rigs.onto_rig(mapped, rest, mapped)
    assert full.meta["chain_bones"] == ("upperneck",)
    # a bone with motion of its own (a blend onto A's rig keeps A's motion) is not a chain bone
    assert rigs.onto_rig(src, raw, mapped).meta["chain_bones"] == ()
