"""Reading clips through ``core.io.sources.read`` and the Blender readers (``readers.bvh``, ``readers.blend_file``):
.amc, .bvh (Blender's importer, nothing left behind, rotations checked against an independent reading of the
BVH channels), .blend and FILE.blend#ACTION, and clear errors."""

import pathlib

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from blender_shapesig.actions import action_io  # noqa: E402
from blender_shapesig.core.io.sources import read  # noqa: E402
from blender_shapesig.readers.blend_file import read_blend_file  # noqa: E402
from blender_shapesig.readers.bvh import import_bvh  # noqa: E402
from blender_shapesig.core.io.acclaim import load_acclaim  # noqa: E402
from blender_shapesig.core.errors import ParseError  # noqa: E402

DATA = pathlib.Path(__file__).resolve().parents[2] / "data"
ACC = DATA / "acclaim"
A = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])  # BVH Y up -> Blender Z up


def _all_ids():
    colls = [p.identifier for p in bpy.data.bl_rna.properties
             if p.type == "COLLECTION" and p.identifier not in ("window_managers", "screens", "workspaces")]
    return {(c, i.as_pointer()) for c in colls for i in getattr(bpy.data, c)}


def test_amc_equals_core(empty_file):
    core = load_acclaim(ACC / "09_02.amc", ACC / "09-run.asf")  # ASF axes
    # the front door: Blender armature axes, A L A^T and s A T
    (clip,) = read(ACC / "09_02.amc", asf=ACC / "09-run.asf", bone_map="none")  # the reader's space
    assert clip.meta["rotation_space"] == "armature"
    np.testing.assert_allclose(clip.rotations, A[None, None] @ core.rotations @ A.T[None, None], atol=1e-14)
    s = core.meta["meters_per_unit"]
    np.testing.assert_allclose(clip.root_translation, s * core.root_translation @ A.T, atol=1e-12)
    (c60,) = read(str(ACC / "09_02.amc"), asf=str(ACC / "09-run.asf"), fps=60)
    assert c60.fps == 60.0


def test_bvh_through_blender_importer(empty_file, capsys, bvh_channels):
    scene = bpy.context.scene
    before = _all_ids()
    clip = import_bvh(DATA / "bvh" / "09_02.bvh", space="native")
    assert _all_ids() == before and bpy.context.scene == scene  # nothing left behind
    assert capsys.readouterr().out == ""  # the importer's progress prints are swallowed (CLI --json)
    assert clip.name == "09_02" and clip.frames == 131 and clip.fps == 120.0 and clip.frame_start == 1
    assert len(clip.bones) == 43 and clip.bones[0] == "hip" and clip.root_bone == "hip"
    assert clip.rotation_modes[0] == "ZYX" and clip.rotation_modes[1] == "ZXY"  # NATIVE: channel order
    # independent check: B R B^T (armature-aligned) = A R_bvh A^T for every joint and frame
    truth = dict(zip(*bvh_channels(DATA / "bvh" / "09_02.bvh")[:2]))
    B = clip.meta["rest_rotations"]
    aligned = B[None] @ clip.rotations @ np.swapaxes(B, -1, -2)[None]
    for j, name in enumerate(clip.bones):
        np.testing.assert_allclose(aligned[:, j], A @ truth[name] @ A.T, atol=1e-5, err_msg=name)
    # the first (rest) frame can be cropped off
    assert clip.crop(2).frames == 130
    # the default, armature space, is exactly that aligned form: the file's rotations in Blender axes
    arm = import_bvh(DATA / "bvh" / "09_02.bvh")
    assert arm.meta["rotation_space"] == "armature" and arm.meta["up_axis"] == "Z"
    np.testing.assert_allclose(arm.rotations, aligned, atol=1e-12)
    # the front door reads .bvh with our bpy-free reader: the same clip (the importer keys 32-bit floats)
    (ours,) = read(DATA / "bvh" / "09_02.bvh", bone_map="none", trim="none")  # the reader's space (core.rigs maps after it)
    assert ours.meta["rotation_space"] == "armature" and ours.meta["up_axis"] == "Z"
    np.testing.assert_allclose(ours.rotations, aligned, atol=1e-6)


def _save_blend(path, walk, line_armature):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    obj = line_armature(walk.bones)
    for pb in obj.pose.bones:
        pb.rotation_mode = "ZXY"
    a = action_io.write_action(walk, armature=obj, name="walk_a", assign=True)
    b = action_io.write_action(walk.crop(1, 50), armature=obj, name="walk_b")
    # an action made by Blender itself (keyframe_insert): its modes come from the armature in the file
    obj.pose.bones["lfemur"].rotation_euler = (0.1, 0.2, 0.3)
    obj.animation_data.action = None
    obj.pose.bones["lfemur"].keyframe_insert("rotation_euler", frame=1)
    obj.pose.bones["lfemur"].rotation_euler = (0.4, 0.2, 0.3)
    obj.pose.bones["lfemur"].keyframe_insert("rotation_euler", frame=5)
    blender_made = obj.animation_data.action
    blender_made.name = "keyed"
    blender_made.use_fake_user = True
    obj.animation_data.action = a
    bpy.data.actions.new("not_armature").use_fake_user = True
    # a mesh object with a material: appended along with the objects, must be removed again
    mesh = bpy.data.meshes.new("Body")
    mesh.from_pydata([(0, 0, 0), (1, 0, 0), (0, 1, 0)], [], [(0, 1, 2)])
    mesh.materials.append(bpy.data.materials.new("Skin"))
    body = bpy.data.objects.new("Body", mesh)
    bpy.context.collection.objects.link(body)
    body.parent = obj
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    return a.name, b.name


def test_blend_file_and_single_action(empty_file, line_armature, tmp_path, capsys):
    walk = load_acclaim(ACC / "16_15.amc", ACC / "16.asf").crop(1, 120)
    path = tmp_path / "lib.blend"
    _save_blend(path, walk, line_armature)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    before = _all_ids()
    got = read_blend_file(path, space="native")
    assert _all_ids() == before
    assert sorted(c.name for c in got) == ["keyed", "walk_a", "walk_b"]
    by_name = {c.name: c for c in got}
    np.testing.assert_allclose(by_name["walk_a"].rotations, walk.rotations, atol=2e-6)
    assert by_name["walk_b"].frames == 50 and by_name["walk_a"].source == f"{path}#walk_a"
    keyed = by_name["keyed"]
    assert keyed.bones == ("lfemur",) and keyed.rotation_modes == ("ZXY",)
    from scipy.spatial.transform import Rotation

    np.testing.assert_allclose(keyed.rotations[0, 0], Rotation.from_euler("zxy", [0.3, 0.1, 0.2]).as_matrix(),
                               atol=1e-6)
    (one,) = read(f"{path}#walk_b", bone_map="none")
    assert one.name == "walk_b" and one.frames == 50
    # armature space (the default) with the file's armature: B P B^T, back to pose by write_action
    assert one.meta["rotation_space"] == "armature"
    B = by_name["walk_b"].meta["rest_rotations"]
    np.testing.assert_allclose(one.rotations, B[None] @ by_name["walk_b"].rotations @ np.swapaxes(B, -1, -2)[None],
                               atol=1e-12)
    assert _all_ids() == before
    with pytest.raises(ParseError, match="no action 'nope' in the file"):
        read(f"{path}#nope")
    with pytest.raises(ParseError, match="animates no pose bones"):
        read(f"{path}#not_armature")
    assert _all_ids() == before


def test_errors(empty_file, tmp_path):
    def err(spec, match, **kw):
        with pytest.raises(ParseError) as info:
            read(spec, **kw)
        assert match in str(info.value) and "\n" not in str(info.value), str(info.value)

    err(tmp_path / "x.bvh", "file not found")
    (tmp_path / "x.c3d").write_text("")
    err(tmp_path / "x.c3d", "unsupported file type .c3d")
    (tmp_path / "x.fbx").write_text("")
    err(tmp_path / "x.fbx", "not an FBX file")  # a reader for .fbx exists (tests/blender/readers/test_interchange.py)
    (tmp_path / "x").write_text("")
    err(tmp_path / "x", "unsupported file type (none)")
    err(ACC / "07_01.amc", "3 .asf files beside the .amc")
    (tmp_path / "junk.blend").write_bytes(b"not a blend file at all")
    err(tmp_path / "junk.blend", ".blend file")  # "cannot read .blend file" or "not a .blend file"
    (tmp_path / "bad.bvh").write_text("HIERARCHY\nROOT hip\n{\n OFFSET 0 0\n")
    err(tmp_path / "bad.bvh", "bad.bvh:4: OFFSET needs 3 numbers")
    good = (DATA / "bvh" / "09_02.bvh").read_text()
    lines = good.splitlines()
    motion = lines.index("MOTION")
    bvh_cases = {
        "empty": ("", "empty BVH file"),
        "text": ("hello\n", "expected HIERARCHY"),
        "nomotion": ("\n".join(lines[:motion]), "no MOTION section"),
        "truncated": (good[: len(good) // 2], "frames of motion data for 'Frames: 131' (truncated file?)"),
        "cutline": ("\n".join(lines[:-1] + [lines[-1][:40]]), "values for 132 channels"),
        "nan": ("\n".join(lines[:-1] + [" ".join(["nan"] * 132)]), "'nan' is not a finite number"),
        "word": ("\n".join(lines[:-1] + [" ".join(["1x"] * 132)]), "'1x' is not a number"),
        "frametime": (good.replace("Frame Time:", "Frame Tim:"), "expected 'Frame Time: seconds'"),
    }
    before = _all_ids()
    for name, (text, match) in bvh_cases.items():
        (tmp_path / f"{name}.bvh").write_text(text)
        err(tmp_path / f"{name}.bvh", match)
    assert _all_ids() == before


def test_importer_failure_is_one_line_and_silent(empty_file, tmp_path, capfd):
    """Input that passes our BVH check but makes Blender's importer fail: one line, nothing on the process's
    stdout/stderr (Blender prints operator tracebacks there), nothing left in the file."""
    (tmp_path / "rot.bvh").write_text(
        "HIERARCHY\nROOT hip\nOFFSET 0 0 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n"  # no braces
        "MOTION\nFrames: 2\nFrame Time: 0.1\n1 2 3\n1 2 3\n")
    before = _all_ids()
    capfd.readouterr()
    with pytest.raises(ParseError) as info:
        import_bvh(tmp_path / "rot.bvh")  # the Blender path (read() uses our reader, which reads this file)
    out, errout = capfd.readouterr()
    msg = str(info.value)
    assert "\n" not in msg and "rot.bvh" in msg and "BVH importer failed" in msg, msg
    assert out == "" and "Traceback" not in errout, (out, errout)
    assert _all_ids() == before


def test_imported_and_folder_amc_agree_in_armature_space(empty_file):
    """The same take through the importer (read back from the action) and through sources.read: one space."""
    bpy.ops.shapesig.import_acclaim(filepath=str(ACC / "09_02.amc"), asf_path=str(ACC / "09-run.asf"))
    obj = bpy.context.view_layer.objects.active
    action = obj.animation_data.action
    from_file = action_io.read_action(action, armature=obj, space="armature")
    (from_folder,) = read(ACC / "09_02.amc", asf=ACC / "09-run.asf", bone_map="none")
    assert from_file.bones == from_folder.bones
    # through the bone map (the front door's default): the hierarchy of the armature and of the .asf agree too
    from blender_shapesig.core import rigs

    (mapped,) = read(ACC / "09_02.amc", asf=ACC / "09-run.asf")
    via_armature = rigs.apply_bone_map(from_file)
    assert via_armature.bones == mapped.bones and len(mapped.bones) == len(rigs.JOINTS)
    np.testing.assert_allclose(via_armature.rotations, mapped.rotations, atol=5e-5)
    np.testing.assert_allclose(from_file.rotations, from_folder.rotations, atol=5e-6)  # float32 keys
    np.testing.assert_allclose(from_file.root_translation, from_folder.root_translation, atol=1e-5)
    # while their pose-space rotations differ by each bone's rest orientation (the defect this prevents)
    pose = action_io.read_action(action, armature=obj)
    assert np.max(np.abs(pose.rotations - from_folder.rotations)) > 0.1
    # and the signature distance between the two readings is ~0
    from blender_shapesig.core.metrics import clip_distance

    assert clip_distance(from_file, from_folder, "sim", level=3) < 1e-4
    # write back: an armature-space clip is converted to this armature's pose space
    again = action_io.write_action(from_folder, armature=obj, name="again")
    np.testing.assert_allclose(action_io.read_action(again, armature=obj).rotations, pose.rotations, atol=5e-6)
