"""Bone maps by names and topology (core.rigs.detect): rigs the tables do not know, built as BVH text by the test
(tests/helpers/rig_skeletons.py), read by the package's BVH reader; joints placed by the hierarchy and the rest pose,
left/right from the rest feet, non-humanoids refused in one line; coverage over the joints both rigs have."""

import json

import numpy as np
import pytest

from blender_shapesig.core import rigs
from blender_shapesig.core.errors import ShapeSigError
from blender_shapesig.core.io import sources
from blender_shapesig.core.metrics import compare_clips
from blender_shapesig.core.rigs.names import tokens, word_role
from tests.helpers.rig_skeletons import BIOVISION, BLENDER_LR, UNITY, side_names, write_bvh

# names that lie about anatomy (a stylised rig): the arm is hand, hand.001, hand.002
LYING = side_names({"hips": "root", "spine": "body.001", "chest": "body.002", "head": "head"},
                   {"upper_arm": ("hand.{s}", "LR"), "forearm": ("hand.{s}.001", "LR"), "hand": ("hand.{s}.002", "LR"),
                    "thigh": ("foot.{s}", "LR"), "shin": ("foot.{s}.001", "LR"), "foot": ("foot.{s}.002", "LR")})


def _read(path, **kw):
    return sources.read_one(sources.ClipSpec(str(path), trim="none", **kw))


@pytest.mark.parametrize("names, root, absent", [
    (UNITY, "joint_Root", {"spine_mid"}),
    (BIOVISION, None, {"spine_mid", "toe.L", "toe.R"}),
    (BLENDER_LR, None, {"spine_mid", "clavicle.L", "clavicle.R"}),
    (LYING, None, {"spine_mid", "neck", "clavicle.L", "clavicle.R", "toe.L", "toe.R"}),
])
def test_rigs_from_the_issue_map_every_joint_they_have(tmp_path, names, root, absent):
    """Every joint the rig has is mapped to the bone the layout gave it; the joints it lacks are not claimed."""
    path = write_bvh(tmp_path / "rig.bvh", names, root=root)
    raw = _read(path, bone_map="none")
    report = rigs.analyse_clip(raw)
    assert report.mapping == {b: j for j, b in names.items()}
    assert set(report.joints) == set(rigs.JOINTS) - absent and report.unmapped == []
    assert report.sides == "rest"
    mapped = _read(path)
    assert mapped.meta["rig_joints"] == tuple(j for j in rigs.JOINTS if j not in absent)
    assert mapped.meta["unmapped_joints"] == ()


def test_unity_rig_against_cmu_is_fully_covered_and_a_partial_map_says_so(tmp_path, data_dir):
    """The Unity-style rig of the issue (mapped 4 of 22 with "coverage 1.0" before): 21 joints against the CMU
    rig's 22, coverage 1.0; a saved map naming only its torso compares 4 of the 21 joints both have: coverage
    0.19, refused naming the unmapped joints, and no arm or leg chain is compared."""
    path = write_bvh(tmp_path / "unity.bvh", UNITY, root="joint_Root")
    amc = sources.read_one(sources.ClipSpec(str(data_dir / "acclaim" / "07_01.amc"),
                                            asf=str(data_dir / "acclaim" / "07-walk.asf")))
    got = compare_clips(amc, _read(path), "sim3")
    assert got["bones"] == 21 and got["coverage"] == 1.0 and got["unmapped"] == []
    torso = tmp_path / "torso.json"
    torso.write_text(json.dumps({"Hips": "hips", "Spine": "spine", "Neck": "neck", "Head": "head"}))
    partial = _read(path, bone_map=str(torso))
    assert partial.meta["unmapped_joints"][:3] == ("chest", "clavicle.L", "upper_arm.L")
    got = compare_clips(amc, partial, "sim3", allow_partial=True)
    assert got["bones"] == 4 and got["coverage"] == pytest.approx(4 / 21)
    assert got["unmapped"] == [j for j in rigs.JOINTS if j not in ("hips", "spine", "neck", "head", "spine_mid")]
    with pytest.raises(ShapeSigError, match=r"coverage 0\.19 < 0\.5 \(unmapped: chest, clavicle\.L, "):
        compare_clips(amc, partial, "sim3")
    assert rigs.chains_covered(amc.bones, partial.bones, amc.meta["rig_joints"], partial.meta["rig_joints"]) == (0, 4)


def test_the_rest_pose_tells_left_from_right_not_the_names(tmp_path):
    """Names that call the +X limbs "Right" on a rig facing +Z (its left is +X): the rest pose wins."""
    swapped = {j: (b.replace("_L", "_x").replace("_R", "_L").replace("_x", "_R")) for j, b in UNITY.items()}
    raw = _read(write_bvh(tmp_path / "mirror.bvh", swapped), bone_map="none")
    report = rigs.analyse_clip(raw)
    assert report.sides == "rest"
    assert report.mapping["UpperLeg_R"] == "thigh.L" and report.mapping["Hand_L"] == "hand.R"


def test_twist_and_helper_bones_are_ignored(tmp_path):
    extras = [("UpperArm_L_Twist", "UpperArm_L", (10.0, 0.0, 0.0)), ("HandIK_L", "joint_Root", (40.0, 100.0, 0.0)),
              ("IndexFinger_L", "HandIK_L", (5.0, 0.0, 0.0)), ("FootPole_R", "joint_Root", (-9.0, 40.0, 30.0))]
    raw = _read(write_bvh(tmp_path / "helpers.bvh", UNITY, root="joint_Root", extras=extras), bone_map="none")
    m = rigs.analyse_clip(raw).mapping
    assert m == {b: j for j, b in UNITY.items()}


def test_non_humanoids_are_refused_in_one_line():
    """A four-legged rig named like a person (front legs called arms) is refused by its rest pose; six legs by
    the names; the refusal reaches a comparison as one line."""
    parents = {"b_Hip": None, "b_Spine01": "b_Hip", "b_Spine02": "b_Spine01", "b_Neck": "b_Spine02",
               "b_Head": "b_Neck"}
    heads = {"b_Hip": (0, 0, 100), "b_Spine01": (0, -30, 100), "b_Spine02": (0, -60, 100), "b_Neck": (0, -80, 110),
             "b_Head": (0, -90, 120)}
    for side, x in (("Left", 10), ("Right", -10)):
        for k, (name, z) in enumerate((("UpperArm", 95), ("ForeArm", 60), ("Hand", 20))):
            parents[f"b_{side}{name}"] = "b_Spine02" if k == 0 else f"b_{side}{('UpperArm', 'ForeArm')[k - 1]}"
            heads[f"b_{side}{name}"] = (x, -60, z)
        for k, (name, z) in enumerate((("Leg01", 95), ("Leg02", 60), ("Foot01", 20))):
            parents[f"b_{side}{name}"] = "b_Hip" if k == 0 else f"b_{side}{('Leg01', 'Leg02')[k - 1]}"
            heads[f"b_{side}{name}"] = (x, 0, z)
    report = rigs.analyse_rig(list(parents), parents, heads)
    assert report.mapping == {} and report.joints == ()
    assert report.refusal.startswith("not a humanoid rig: its spine leaves the hips 90 degrees from its legs")
    # the same bones standing up (spine above the legs) are a humanoid
    legs = {b for b in heads if "Leg" in b or "Foot" in b}  # they stay; the rest turns up about the hips
    up = {b: (h if b in legs else (h[0], 0, 100 - h[1] + (h[2] - 100))) for b, h in heads.items()}
    assert rigs.analyse_rig(list(parents), parents, up).refusal == ""
    crab = {"Body": None, **{f"Leg_{s}_{k}{i}": ("Body" if i == 0 else f"Leg_{s}_{k}{i - 1}")
                             for s in "LR" for k in "abc" for i in range(3)},
            **{f"Arm_{s}_{i}": ("Body" if i == 0 else f"Arm_{s}_{i - 1}") for s in "LR" for i in range(3)}}
    assert rigs.analyse_rig(list(crab), crab).refusal == "not a humanoid rig: 6 legs found by the bone names " \
                                                         "(a humanoid has two)"


@pytest.mark.parametrize("name, side, words, role", [
    ("mixamorig7:LeftUpLeg", "L", ("upleg",), ("leg", "thigh")),
    ("lhumerus", "L", ("humerus",), ("arm", "upper_arm")),
    ("DEF-upper_arm.L.001", "L", ("upperarm",), ("arm", "upper_arm")),
    ("CC_Base_R_Calf", "R", ("calf",), ("leg", "shin")),
    ("Character1_LeftHandThumb1", "L", ("hand", "thumb"), ("skip", "")),
    ("leftUpperArm", "L", ("upperarm",), ("arm", "upper_arm")),
    ("Bip01_R_Clavicle", "R", ("clavicle",), ("arm", "clavicle")),
    ("thigh.l", "L", ("thigh",), ("leg", "thigh")),
    ("handIK.L", "L", ("hand", "ik"), ("skip", "")),
    ("CC_Base_NeckTwist01", None, ("neck", "twist"), ("twist", "")),
    ("LeftShoulder", "L", ("shoulder",), ("arm", "")),
])
def test_name_words(name, side, words, role):
    assert tokens(name) == (side, words)
    assert word_role(words) == role


def test_a_rig_bone_the_clip_does_not_hold_is_skipped_in_the_hierarchy(tmp_path):
    """A clip of some of a rig's bones (an importer leaves an unanimated root out, as the glTF fox's
    ``b_Root_00``): the bones below it hang from the nearest bone the clip holds; the map is the same (a
    KeyError before)."""
    path = write_bvh(tmp_path / "rig.bvh", UNITY, root="joint_Root")
    raw = _read(path, bone_map="none")
    m = raw.meta
    whole = rigs.analyse_rig(raw.bones, m["parents"], m["rest_heads"], m["rest_tails"])
    held = [b for b in raw.bones if b not in ("joint_Root", "Spine")]
    part = rigs.analyse_rig(held, m["parents"], m["rest_heads"], m["rest_tails"])
    assert part.mapping == {b: j for b, j in whole.mapping.items() if b in held}
    assert part.sides == "rest" and not part.refusal


def _ik_feet_robot(style):
    """A robot-like rig (Blender axes: Z up, facing -Y, left at +X) whose feet are IK bones parented to the root,
    with their rest heads at the lower legs' tails; ``style`` spells the side (``UpperLegL``, ``UpperLeg.L``,
    ``upperleg_l``)."""
    def name(word, side):
        return {"glued": f"{word}{side}", "dot": f"{word}.{side}", "snake": f"{word.lower()}_{side.lower()}"}[style]

    bones = {"Root": (None, (0, 0, 0), (0, 0.3, 0)), "Hips": ("Root", (0, 0, 1.0), (0, 0, 1.1)),
             "Spine": ("Hips", (0, 0, 1.1), (0, 0, 1.3)), "Chest": ("Spine", (0, 0, 1.3), (0, 0, 1.5)),
             "Neck": ("Chest", (0, 0, 1.5), (0, 0, 1.6)), "Head": ("Neck", (0, 0, 1.6), (0, 0, 1.8))}
    for side, x in (("L", 1.0), ("R", -1.0)):
        bones.update({
            name("Shoulder", side): ("Chest", (0.05 * x, 0, 1.45), (0.18 * x, 0, 1.45)),
            name("UpperArm", side): (name("Shoulder", side), (0.18 * x, 0, 1.45), (0.45 * x, 0, 1.45)),
            name("LowerArm", side): (name("UpperArm", side), (0.45 * x, 0, 1.45), (0.7 * x, 0, 1.45)),
            name("Hand", side): (name("LowerArm", side), (0.7 * x, 0, 1.45), (0.8 * x, 0, 1.45)),
            name("UpperLeg", side): ("Hips", (0.1 * x, 0, 0.95), (0.1 * x, 0, 0.5)),
            name("LowerLeg", side): (name("UpperLeg", side), (0.1 * x, 0, 0.5), (0.1 * x, 0, 0.08)),
            name("Foot", side): ("Root", (0.1 * x, 0, 0.08), (0.1 * x, -0.15, 0.0)),  # the IK foot
        })
    parents = {b: v[0] for b, v in bones.items()}
    heads = {b: v[1] for b, v in bones.items()}
    tails = {b: v[2] for b, v in bones.items()}
    return list(bones), parents, heads, tails, name


@pytest.mark.parametrize("style", ["glued", "dot", "snake"])
def test_ik_feet_parented_to_the_root_are_the_legs_feet(style):
    """Issue 38: a foot whose parent is not the lower leg is still the foot when its rest head sits at the lower
    leg's tail; before, the two feet made four legs and the rig was refused ("4 legs found")."""
    bones, parents, heads, tails, name = _ik_feet_robot(style)
    report = rigs.analyse_rig(bones, parents, heads, tails)
    assert not report.refusal and report.sides == "rest"
    expect = {"Hips": "hips", "Spine": "spine", "Chest": "chest", "Neck": "neck", "Head": "head"}
    for side in "LR":
        expect.update({name("Shoulder", side): f"clavicle.{side}", name("UpperArm", side): f"upper_arm.{side}",
                       name("LowerArm", side): f"forearm.{side}", name("Hand", side): f"hand.{side}",
                       name("UpperLeg", side): f"thigh.{side}", name("LowerLeg", side): f"shin.{side}",
                       name("Foot", side): f"foot.{side}"})
    assert report.mapping == expect
    assert parents[name("Foot", "L")] == "Root"  # the rig's hierarchy is not changed
    # a foot control away from the ankle (e.g. on the floor in front of the toes) is not the foot
    far = dict(heads, **{name("Foot", s): (heads[name("Foot", s)][0], -0.5, 0.0) for s in "LR"})
    assert name("Foot", "L") not in rigs.analyse_rig(bones, parents, far, tails).mapping


def test_rigify_deform_bones_with_twist_segments_map_their_joints():
    """A Rigify rig's deform skeleton (``control_rigs.deform_parents``: ``DEF-thigh.L`` under ``DEF-spine`` through
    ``ORG-spine``, two segments per limb bone, palms and fingers under the hand, breasts and pelvis bones): every
    canonical joint maps to the first segment, the ``.001`` twist segments and helpers stay unmapped."""
    parents = {"DEF-spine": None, "DEF-spine.001": "DEF-spine", "DEF-spine.002": "DEF-spine.001",
               "DEF-spine.003": "DEF-spine.002", "DEF-spine.004": "DEF-spine.003", "DEF-spine.005": "DEF-spine.004",
               "DEF-spine.006": "DEF-spine.005", "DEF-jaw": "DEF-spine.006"}
    for s in "LR":
        chain = {"leg": ["thigh", "thigh.001", "shin", "shin.001", "foot", "toe"],
                 "arm": ["shoulder", "upper_arm", "upper_arm.001", "forearm", "forearm.001", "hand"]}
        for kind, top in (("leg", "DEF-spine"), ("arm", "DEF-spine.003")):
            p = top
            for b in chain[kind]:
                name = f"DEF-{b.split('.')[0]}.{s}" + (".001" if b.endswith(".001") else "")
                parents[name], p = p, name
        parents.update({f"DEF-pelvis.{s}": "DEF-spine", f"DEF-breast.{s}": "DEF-spine.003",
                        f"DEF-palm.01.{s}": f"DEF-hand.{s}", f"DEF-f_index.01.{s}": f"DEF-palm.01.{s}",
                        f"DEF-thumb.01.{s}": f"DEF-hand.{s}"})
    report = rigs.analyse_rig(list(parents), parents)
    expect = {"DEF-spine": "hips", "DEF-spine.001": "spine", "DEF-spine.002": "spine_mid", "DEF-spine.003": "chest",
              "DEF-spine.004": "neck", "DEF-spine.006": "head"}
    for s in "LR":
        expect.update({f"DEF-{b}.{s}": f"{j}.{s}" for b, j in (
            ("shoulder", "clavicle"), ("upper_arm", "upper_arm"), ("forearm", "forearm"), ("hand", "hand"),
            ("thigh", "thigh"), ("shin", "shin"), ("foot", "foot"), ("toe", "toe"))})
    assert report.mapping == expect and not report.refusal
