"""A BVH in the Unity / MotionBuilder layout (a static reference ROOT above the hips, six channels on every joint,
the walk in the hips' position channels; built from the CMU walk 07_01 by ``tests/helpers/reference_root.py``): the
bpy-free reader's forward kinematics puts every joint below the ROOT, the hips' world path among them, where Blender's BVH
importer (``bpy.ops.import_anim.bvh``, default options) plays them, to 1e-5 leg lengths in every frame."""

import pathlib
import sys

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from blender_shapesig.core.clip.skeleton import REST_HEADS, forward_kinematics  # noqa: E402
from blender_shapesig.core.io.bvh import load_bvh  # noqa: E402

from tests.helpers.reference_root import reference_root_layout  # noqa: E402


def _blender_heads(path, names, frames):
    import addon_utils

    addon_utils.enable("io_anim_bvh", default_set=False)
    before = set(bpy.data.objects)
    assert bpy.ops.import_anim.bvh(filepath=str(path)) == {"FINISHED"}  # the default options
    (obj,) = set(bpy.data.objects) - before
    scene = bpy.context.scene
    M = np.array(obj.matrix_world)
    out = np.empty((frames, len(names), 3))
    for f in range(frames):
        scene.frame_set(1 + f)  # default frame_start 1, one frame a file frame
        for j, n in enumerate(names):
            out[f, j] = M[:3, :3] @ np.array(obj.pose.bones[n].head) + M[:3, 3]
    return out


# a static reference turned 30 degrees about the vertical and moved: the hips' channels are in its frame
@pytest.mark.parametrize("reference", [(0, 0, 0, 0, 0, 0), (12.5, 0, -7.0, 0, 0, 30.0)])
def test_hips_world_path_equals_blender_importer(empty_file, tmp_path, data_dir, reference):
    path = tmp_path / "reference_root.bvh"
    path.write_text(reference_root_layout((data_dir / "bvh" / "07_01.bvh").read_text(), reference=reference))
    clip = load_bvh(path)
    assert clip.bones[:2] == ("Reference", "hip") and clip.meta["root_motion_bone"] == "hip"
    heads = forward_kinematics(clip)[0]
    got = _blender_heads(path, clip.bones, clip.frames)
    rest = clip.meta[REST_HEADS]
    leg = np.mean([np.linalg.norm(np.subtract(rest[f"{s}Thigh"], rest[f"{s}Foot"])) for s in "lr"])
    hips = clip.bones.index("hip")
    travel = np.linalg.norm(got[-1, hips, :2] - got[0, hips, :2]) / leg
    assert travel > 3  # the walk goes somewhere (Blender's hips cross several leg lengths)
    err = np.abs(heads[:, 1:] - got[:, 1:]).max() / leg  # every joint below the static ROOT
    assert err < 1e-5, err


def test_the_imported_action_reads_the_same_root_motion(empty_file, tmp_path, data_dir):
    """The action Blender's importer made (read by ``action_io.read_action``, as Find Similar reads the file's
    actions) carries the hips' walk too: forward kinematics of the read clip equals Blender's pose heads below the
    static ROOT, and its root path equals the bpy-free reader's."""
    from blender_shapesig.actions import action_io

    path = tmp_path / "reference_root.bvh"
    path.write_text(reference_root_layout((data_dir / "bvh" / "07_01.bvh").read_text(),
                                          reference=(12.5, 0, -7.0, 0, 0, 30.0)))
    ours = load_bvh(path)
    got = _blender_heads(path, ours.bones, ours.frames)
    obj = next(o for o in bpy.data.objects if o.type == "ARMATURE")
    for space in ("armature", "pose"):
        clip = action_io.read_action(obj.animation_data.action, armature=obj, space=space)
        assert clip.meta["root_motion_bone"] == "hip"
        heads = forward_kinematics(clip)[0]
        leg = np.mean([np.linalg.norm(np.subtract(ours.meta[REST_HEADS][f"{s}Thigh"], ours.meta[REST_HEADS][f"{s}Foot"]))
                       for s in "lr"])
        idx = [clip.bones.index(b) for b in ours.bones[1:]]
        assert np.abs(heads[:, idx] - got[:, 1:]).max() / leg < 1e-5
    armature = action_io.read_action(obj.animation_data.action, armature=obj, space="armature")
    assert np.abs(armature.root_translation - ours.root_translation).max() / leg < 1e-5
