"""shapesig.import_acclaim: the imported armature reproduces the take in world space, checked against
(1) core forward kinematics on every frame, (2) Blender's own BVH importer on MotionBuilder's BVH conversion
of the same take (16_15), (3) the cgspeed Daz-friendly BVH of 07_01 (another skeleton: compared by root height
pattern and limb directions). Bad input: one-line errors and nothing created."""

import pathlib
import shutil

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from blender_shapesig.core.io.acclaim import forward_kinematics, parse_amc, parse_asf  # noqa: E402
from blender_shapesig.readers.acclaim import AXIS_CONVERSION  # noqa: E402

DATA = pathlib.Path(__file__).resolve().parents[2] / "data"
ACC = DATA / "acclaim"


def _import(amc, asf, **kw):
    before = set(bpy.data.objects)
    result = bpy.ops.shapesig.import_acclaim(filepath=str(amc), asf_path=str(asf), **kw)
    assert result == {"FINISHED"}
    (obj,) = set(bpy.data.objects) - before
    return obj


def _import_bvh(path):
    import addon_utils

    addon_utils.enable("io_anim_bvh", default_set=False)
    before = set(bpy.data.objects)
    bpy.ops.import_anim.bvh(filepath=str(path), rotate_mode="NATIVE")
    (obj,) = set(bpy.data.objects) - before
    return obj


def _heads(obj, names, frames):
    """World-space pose-bone heads (frames, bones, 3) after scene.frame_set."""
    scene = bpy.context.scene
    out = np.empty((len(frames), len(names), 3))
    mw = obj.matrix_world
    for k, f in enumerate(frames):
        scene.frame_set(f)
        for j, n in enumerate(names):
            out[k, j] = np.array(mw @ obj.pose.bones[n].head)
    return out


def _data_counts():
    return (len(bpy.data.objects), len(bpy.data.armatures), len(bpy.data.actions))


def test_operator_registered_with_menu(addon):
    op = bpy.ops.shapesig.import_acclaim.get_rna_type()
    assert op.identifier == "SHAPESIG_OT_import_acclaim"
    from blender_shapesig.operators.import_acclaim import SHAPESIG_OT_import_acclaim

    assert {"REGISTER", "UNDO"} <= SHAPESIG_OT_import_acclaim.bl_options
    props = op.properties.keys()
    for p in ("filepath", "files", "directory", "asf_path", "scale", "frame_step", "fps"):
        assert p in props
    draw_funcs = bpy.types.TOPBAR_MT_file_import._dyn_ui_initialize()
    assert any(getattr(f, "__module__", "").endswith("import_acclaim") for f in draw_funcs)


def test_pose_matches_forward_kinematics_on_every_frame(empty_file):
    """Blender's posed heads = s A (core FK heads) for all 471 frames and all 31 bones (s: ASF units -> m)."""
    obj = _import(ACC / "16_15.amc", ACC / "16.asf")
    sk = parse_asf(ACC / "16.asf")
    motion = parse_amc(ACC / "16_15.amc", sk)
    fk, _ = forward_kinematics(motion)
    expected = sk.meters_per_unit * fk @ AXIS_CONVERSION.T
    got = _heads(obj, sk.bone_names, range(1, motion.frames + 1))
    shortest = min(b.length for b in sk.bones.values() if b.length > 0) * sk.meters_per_unit
    err = np.linalg.norm(got - expected, axis=-1)
    assert err.max() < 1e-4 * shortest + 2e-6, err.max()  # float32 keys and pose matrices
    action = obj.animation_data.action
    assert action.name == "16_15" and action.use_fake_user
    assert tuple(action.frame_range) == (1.0, 471.0)
    assert len(obj.pose.bones) == 31 and obj.data.bones["ltibia"].parent.name == "lfemur"


def test_against_blender_bvh_import_of_motionbuilder_conversion(empty_file):
    """16_15.amc (our importer, scale 100 = cm) vs 16_15.bvh (Blender's BVH importer; MotionBuilder wrote it
    in cm with exact poses on every 4th frame 1, 5, 9, ... and interpolated ones between). Bone map: same
    names (MotionBuilder dropped the dof-less lhipjoint/rhipjoint; an ASF bone's head is the BVH joint of the
    same name). Tolerance on exact frames: 1e-3 of the shortest bone (0.024 mm; the BVH prints 6 digits)."""
    ours = _import(ACC / "16_15.amc", ACC / "16.asf", scale=100.0)
    bvh = _import_bvh(ACC / "16_15.bvh")
    names = [b.name for b in bvh.pose.bones if b.name in ours.pose.bones]
    assert len(names) == 29
    frames = list(range(1, 472, 4))
    a = _heads(ours, names, frames)
    b = _heads(bvh, names, frames)
    sk = parse_asf(ACC / "16.asf")
    shortest_cm = min(bn.length for bn in sk.bones.values() if bn.length > 0) * sk.meters_per_unit * 100
    err = np.linalg.norm(a - b, axis=-1)
    assert err.max() < 1e-3 * shortest_cm, err.max()
    # negative control: one frame off is far outside that tolerance
    b_shifted = _heads(bvh, names, [f + 4 for f in frames[:-1]])
    assert np.linalg.norm(a[:-1] - b_shifted, axis=-1).max() > 100 * 1e-3 * shortest_cm


DAZ = {  # ASF bone -> Daz-friendly BVH joint at the same place (the bone's head)
    "root": "hip", "lfemur": "lThigh", "ltibia": "lShin", "lfoot": "lFoot",
    "rfemur": "rThigh", "rtibia": "rShin", "rfoot": "rFoot",
    "lhumerus": "lShldr", "lradius": "lForeArm", "lwrist": "lHand",
    "rhumerus": "rShldr", "rradius": "rForeArm", "rwrist": "rHand",
}
SEGMENTS = {  # limb segment (from, to) -> required mean cosine between the two skeletons' directions
    ("lfemur", "ltibia"): 0.98, ("ltibia", "lfoot"): 0.98, ("rfemur", "rtibia"): 0.98, ("rtibia", "rfoot"): 0.98,
    ("lhumerus", "lradius"): 0.97, ("rhumerus", "rradius"): 0.97, ("lradius", "lwrist"): 0.85,
    ("rradius", "rwrist"): 0.85,
}


def test_against_daz_friendly_bvh_of_the_same_take(empty_file):
    """07_01.amc vs bvh/07_01.bvh (cgspeed conversion: other bone lengths and rest pose, one rest frame first,
    so AMC frame k = BVH frame k+1). Compared: the root height's per-frame pattern (correlation), the root's
    horizontal travel, and the world direction of each limb segment (mean cosine over the 316 frames)."""
    ours = _import(ACC / "07_01.amc", ACC / "07-walk.asf", scale=100.0)
    bvh = _import_bvh(DATA / "bvh" / "07_01.bvh")
    names = list(DAZ)
    a = _heads(ours, names, range(1, 317))
    b = _heads(bvh, [DAZ[n] for n in names], range(2, 318))
    height_corr = np.corrcoef(a[:, 0, 2], b[:, 0, 2])[0, 1]
    assert height_corr > 0.85, height_corr
    travel = np.linalg.norm(a[-1, 0, :2] - a[0, 0, :2])
    assert travel > 200  # cm: a walk
    drift = np.linalg.norm((a[:, 0, :2] - a[0, 0, :2]) - (b[:, 0, :2] - b[0, 0, :2]), axis=-1).max()
    assert drift < 0.05 * travel, drift

    def mean_cos(x, y, i, j):
        u, v = x[:, j] - x[:, i], y[:, j] - y[:, i]
        return float(np.mean((u * v).sum(1) / np.linalg.norm(u, axis=1) / np.linalg.norm(v, axis=1)))

    for (s, e), need in SEGMENTS.items():
        i, j = names.index(s), names.index(e)
        assert mean_cos(a, b, i, j) > need, (s, e, mean_cos(a, b, i, j))
    # negative control: the legs of the BVH played backwards do not match
    i, j = names.index("lfemur"), names.index("ltibia")
    assert mean_cos(a, b[::-1], i, j) < 0.97


def test_core_clip_mapped_onto_the_armature_equals_the_imported_action(empty_file):
    """clip_to_pose(core clip) = what the importer wrote (so core-computed clips, e.g. blends, can be written
    onto an imported armature), and reading the imported action gives the same pose rotations."""
    from blender_shapesig.actions import action_io
    from blender_shapesig.core.io.acclaim import load_acclaim
    from blender_shapesig.readers.acclaim import clip_to_pose

    obj = _import(ACC / "09_02.amc", ACC / "09-run.asf", scale=2.0)
    core = load_acclaim(ACC / "09_02.amc", ACC / "09-run.asf")
    mapped = clip_to_pose(core, obj)
    read = action_io.read_action(obj.animation_data.action, armature=obj)
    assert read.bones == mapped.bones
    np.testing.assert_allclose(read.rotations, mapped.rotations, atol=2e-6)
    np.testing.assert_allclose(read.root_translation, mapped.root_translation, atol=1e-5)
    # and the two clips differ (the conversion is not the identity): per bone a constant conjugation
    assert np.abs(core.rotations - mapped.rotations).max() > 0.1


def test_native_euler_root_takes_amc_angles_directly(empty_file):
    obj = _import(ACC / "16_15.amc", ACC / "16.asf", rotation_mode="NATIVE")
    assert obj.pose.bones["root"].rotation_mode == "XYZ"
    assert obj.pose.bones["lclavicle"].rotation_mode == "YZX"  # dof ry rz
    sk = parse_asf(ACC / "16.asf")
    motion = parse_amc(ACC / "16_15.amc", sk)
    bpy.context.scene.frame_set(10)
    np.testing.assert_allclose(np.array(obj.pose.bones["root"].rotation_euler), motion.values["root"][9, 3:6],
                               atol=1e-6)


def test_several_amcs_one_armature(empty_file):
    before = _data_counts()
    r = bpy.ops.shapesig.import_acclaim(
        filepath=str(ACC / "07_01.amc"), directory=str(ACC), asf_path=str(ACC / "07-walk.asf"),
        files=[{"name": "07_01.amc"}, {"name": "07_02.amc"}], frame_step=2, fps=120.0)
    assert r == {"FINISHED"}
    assert _data_counts() == (before[0] + 1, before[1] + 1, before[2] + 2)
    obj = bpy.data.objects["07-walk"]
    a1, a2 = bpy.data.actions["07_01"], bpy.data.actions["07_02"]
    assert obj.animation_data.action == a1 and a1.use_fake_user and a2.use_fake_user
    assert tuple(a1.frame_range) == (1.0, 158.0) and tuple(a2.frame_range) == (1.0, 165.0)  # 316 / 2, 329 / 2
    assert a1["shapesig_fps"] == 60.0


def test_skeleton_beside_the_amc(empty_file, tmp_path):
    shutil.copy(ACC / "09-run.asf", tmp_path / "09-run.asf")
    shutil.copy(ACC / "09_02.amc", tmp_path / "09_02.amc")
    r = bpy.ops.shapesig.import_acclaim(filepath=str(tmp_path / "09_02.amc"))
    assert r == {"FINISHED"} and "09_02" in bpy.data.actions
    r = bpy.ops.shapesig.import_acclaim(filepath=str(tmp_path / "09-run.asf"))  # skeleton only
    assert r == {"FINISHED"}


def _expect_error(match, **kw):
    before = _data_counts()
    with pytest.raises(RuntimeError) as info:
        bpy.ops.shapesig.import_acclaim(**kw)
    msg = str(info.value)
    assert match in msg, msg
    assert "Traceback" not in msg and msg.strip().count("\n") == 0, msg
    assert _data_counts() == before


def test_bad_input_creates_nothing(empty_file, tmp_path):
    amc = (ACC / "16_15.amc").read_text()
    asf = str(ACC / "16.asf")
    cases = {
        "unknown_bone.amc": (amc.replace("rtibia 18.8225", "rtibiaX 18.8225", 1), "bone 'rtibiaX' is not in"),
        "count.amc": (amc.replace("rtibia 18.8225", "rtibia 18.8225 1", 1), "needs 1 values"),
        "nan.amc": (amc.replace("rtibia 18.8225", "rtibia nan", 1), "not a finite number"),
        "text.amc": (amc.replace("rtibia 18.8225", "rtibia x1", 1), "'x1' is not a number"),
        "empty.amc": ("", "empty AMC file"),
        "truncated.amc": (amc[: len(amc) // 2].rsplit("\n", 3)[0] + "\n", "truncated"),
    }
    for name, (text, match) in cases.items():
        (tmp_path / name).write_text(text)
        _expect_error(match, filepath=str(tmp_path / name), asf_path=asf)
    bad_asf = tmp_path / "bad.asf"
    bad_asf.write_text((ACC / "16.asf").read_text().split(":hierarchy")[0])
    _expect_error("missing :hierarchy", filepath=str(ACC / "16_15.amc"), asf_path=str(bad_asf))
    # a second AMC that fails: the first must not be left behind either
    shutil.copy(ACC / "16_15.amc", tmp_path / "good.amc")
    _expect_error("bone 'rtibiaX'", filepath=str(ACC / "16_15.amc"), directory=str(tmp_path), asf_path=asf,
                  files=[{"name": "good.amc"}, {"name": "unknown_bone.amc"}])
    # a failure after the armature was built (a bone name longer than Blender allows) is rolled back
    long = "l" + "f" * 70 + "emur"
    (tmp_path / "long.asf").write_text((ACC / "16.asf").read_text().replace("lfemur", long))
    (tmp_path / "long.amc").write_text(amc.replace("lfemur", long))
    _expect_error("too long", filepath=str(tmp_path / "long.amc"), asf_path=str(tmp_path / "long.asf"))
    assert not any(a.name.startswith("long") for a in bpy.data.actions)
    _expect_error("3 .asf files beside", filepath=str(ACC / "07_01.amc"))
    _expect_error("no such file", filepath=str(tmp_path / "missing.amc"), asf_path=asf)
    _expect_error("not an .asf or .amc", filepath=str(DATA / "bvh" / "07_01.bvh"))
