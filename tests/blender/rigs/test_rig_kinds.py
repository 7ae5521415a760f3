"""Rig kinds of issue 38 built by the test in Blender: a Mixamo-named armature (``Hips, Spine, Spine1, Spine2, Neck,
Head, ...``) onto which a found walk with two spine bones (the CMU Daz BVH: ``abdomen, chest``) is assigned moves
every spine bone (``Spine1`` shares the chain's rotation instead of keeping its rest); a glTF robot whose feet are
IK bones parented to the root (``Hips, UpperLegL, LowerLegL, FootL, ..., Spine, Chest, Neck, Head``), animated
with a CMU walk and exported with Blender's glTF exporter, read back through the package's readers, is recognised
(>= 12 canonical joints, the feet mapped) and its walk finds walks first among the tests/data clips."""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from blender_shapesig.actions import action_io, control_rigs  # noqa: E402
from blender_shapesig.rigs import retarget  # noqa: E402
from blender_shapesig.core import search as index  # noqa: E402
from blender_shapesig.core.geometry import so3  # noqa: E402
from blender_shapesig.core.io import sources  # noqa: E402
from tests.helpers.gltf_export import export_glb  # noqa: E402
from tests.helpers.walks_runs_idles import library, read, walks_first  # noqa: E402



def _armature(name, layout):
    """An armature object from ``{bone: (parent, head, tail)}`` (Blender axes: Z up, facing -Y, left at +X)."""
    data = bpy.data.armatures.new(name)
    obj = bpy.data.objects.new(name, data)
    bpy.context.collection.objects.link(obj)
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.mode_set(mode="EDIT")
    for b, (_p, head, tail) in layout.items():
        eb = data.edit_bones.new(b)
        eb.head, eb.tail = head, tail
    for b, (p, _h, _t) in layout.items():
        if p is not None:
            data.edit_bones[b].parent = data.edit_bones[p]
    bpy.ops.object.mode_set(mode="OBJECT")
    return obj


def _body(names, spine, root=None, ik_feet=False):
    """A humanoid layout: ``names(word, side)`` spells the limb bones, ``spine`` the bones from the hips up to the
    chest; the feet hang from ``root`` when ``ik_feet`` (their heads at the lower legs' tails)."""
    out = {} if root is None else {root: (None, (0, 0, 0), (0, 0.3, 0))}
    z, parent = 1.0, root
    for b in spine:
        out[b] = (parent, (0, 0, z), (0, 0, z + 0.12))
        parent, z = b, z + 0.12
    chest, hips = spine[-1], spine[0]
    neck = names("Neck", "")
    out[neck] = (chest, (0, 0, z), (0, 0, z + 0.1))
    out[names("Head", "")] = (neck, (0, 0, z + 0.1), (0, 0, z + 0.3))
    for side, x in (("L", 1.0), ("R", -1.0)):
        n = {w: names(w, side) for w in ("Shoulder", "UpperArm", "LowerArm", "Hand", "UpperLeg", "LowerLeg", "Foot",
                                         "Toe")}
        out.update({
            n["Shoulder"]: (chest, (0.05 * x, 0, z - 0.05), (0.18 * x, 0, z - 0.05)),
            n["UpperArm"]: (n["Shoulder"], (0.18 * x, 0, z - 0.05), (0.45 * x, 0, z - 0.05)),
            n["LowerArm"]: (n["UpperArm"], (0.45 * x, 0, z - 0.05), (0.7 * x, 0, z - 0.05)),
            n["Hand"]: (n["LowerArm"], (0.7 * x, 0, z - 0.05), (0.8 * x, 0, z - 0.05)),
            n["UpperLeg"]: (hips, (0.1 * x, 0, 0.95), (0.1 * x, 0, 0.5)),
            n["LowerLeg"]: (n["UpperLeg"], (0.1 * x, 0, 0.5), (0.1 * x, 0, 0.08)),
            n["Foot"]: (root if ik_feet else n["LowerLeg"], (0.1 * x, 0, 0.08), (0.1 * x, -0.12, 0.02)),
        })
        if n["Toe"]:
            out[n["Toe"]] = (n["Foot"], (0.1 * x, -0.12, 0.02), (0.1 * x, -0.2, 0.0))
    return out


MIXAMO = {"Shoulder": "Shoulder", "UpperArm": "Arm", "LowerArm": "ForeArm", "Hand": "Hand", "UpperLeg": "UpLeg",
          "LowerLeg": "Leg", "Foot": "Foot", "Toe": "ToeBase"}


def _mixamo(word, side):
    if not side:
        return f"mixamorig:{word}"
    return f"mixamorig:{'Left' if side == 'L' else 'Right'}{MIXAMO[word]}"


def test_assign_onto_a_mixamo_rig_moves_every_spine_bone(empty_file):
    arm = _armature("Mixamo", _body(_mixamo, [f"mixamorig:{b}" for b in ("Hips", "Spine", "Spine1", "Spine2")]))
    bpy.context.scene.render.fps = 30  # the walk's rate: written frame for frame (scene_motion.write_motion)
    walk = read("bvh/07_01.bvh", step=4)  # the Daz rig: hip, abdomen, chest (no spine_mid), neck, head
    assert "spine_mid" not in walk.bones and {"spine", "chest"} <= set(walk.bones)
    assert not control_rigs.is_control_rig(arm)  # a plain rig: its F-curves are its motion
    action, kept = retarget.action_on_armature(walk, "auto", arm, "07_01 on mixamo")
    clip = action_io.read_action(action, armature=arm, space="armature")
    R = {b: clip.rotations[:, clip.bones.index(f"mixamorig:{b}")] for b in ("Spine", "Spine1", "Spine2")}
    for b, r in R.items():
        assert np.ptp(so3.angle(r)) > np.radians(1.0), b  # every spine bone moves
    assert "mixamorig:Spine1" not in kept
    # Spine1 and Spine2 share the rotation from Spine to the chest in equal steps
    np.testing.assert_allclose(R["Spine1"], R["Spine2"], atol=1e-5)
    # the source's spine moves: so does every spine bone, together (their angular speeds correlate)
    src = walk.rotations[:, walk.bones.index("chest")]
    speed = np.linalg.norm(so3.log(src[1:] @ np.swapaxes(src[:-1], -1, -2)), axis=1)
    for b, r in R.items():
        mine = np.linalg.norm(so3.log(r[1:] @ np.swapaxes(r[:-1], -1, -2)), axis=1)
        assert np.corrcoef(mine, speed)[0, 1] > 0.3, b


def _robot(word, side):
    return f"{word}{side}" if side else word


def test_gltf_robot_with_ik_feet_is_recognised_and_its_walk_finds_walks(empty_file, tmp_path):
    layout = _body(lambda w, s: "" if w == "Toe" else _robot(w, s), ["Hips", "Spine", "Chest"], root="Root",
                   ik_feet=True)
    arm = _armature("Robot", layout)
    assert arm.data.bones["FootL"].parent.name == "Root"
    bpy.context.scene.render.fps = 30
    walk = read("bvh/08_01.bvh", step=4)  # 120 -> 30 fps; its files are left out of the library
    action, _kept = retarget.action_on_armature(walk, "auto", arm, "robot walk")
    action_io.assign_action(arm, action)
    start, end = (int(round(x)) for x in action.frame_range)
    bpy.context.scene.frame_start, bpy.context.scene.frame_end = start, end
    path = tmp_path / "robot.glb"
    export_glb(path)  # Blender's exporter, in a child
    clip = sources.read_one(sources.ClipSpec(str(path)))
    bone_map = clip.meta["bone_map"]
    assert len(clip.meta["rig_joints"]) >= 12 and len(bone_map) >= 12, bone_map
    assert bone_map["foot.L"].endswith("FootL") and bone_map["foot.R"].endswith("FootR")
    labels, clips = library("08_01")
    walks_first(index.rank_clips(clip, clips), labels)


def test_a_deform_bone_driven_by_a_constraint_makes_a_control_rig(empty_file):
    """A plain rig with an IK constraint on its deform shin (target: an IK bone of the armature) is a control rig
    (read through the evaluated pose), but not a Rigify one (written onto its bones as before); muting the
    constraint makes it plain again."""
    layout = _body(_mixamo, [f"mixamorig:{b}" for b in ("Hips", "Spine", "Spine1", "Spine2")])
    layout["IK_foot.L"] = (None, (0.1, 0, 0.08), (0.1, -0.1, 0.08))
    arm = _armature("Mixamo", layout)
    arm.data.bones["IK_foot.L"].use_deform = False
    ik = arm.pose.bones["mixamorig:LeftLeg"].constraints.new("IK")
    ik.target, ik.subtarget, ik.chain_count = arm, "IK_foot.L", 2
    assert control_rigs.is_control_rig(arm) and not control_rigs.is_rigify(arm)
    ik.mute = True
    assert not control_rigs.is_control_rig(arm)
