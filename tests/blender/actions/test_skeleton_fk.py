"""core.clip.skeleton forward kinematics against Blender's own pose evaluation: bone heads in armature space on real
clips, for the three readers that carry the rest skeleton (an action read with its armature in armature and pose
space, the bpy-free BVH reader on the BVH importer's armature, the Acclaim reader on the Acclaim importer's)."""

import pathlib

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from blender_shapesig.actions import action_io  # noqa: E402
from blender_shapesig.core.io.acclaim import load_acclaim  # noqa: E402
from blender_shapesig.core.io.bvh import load_bvh  # noqa: E402
from blender_shapesig.core.clip.skeleton import forward_kinematics  # noqa: E402

DATA = pathlib.Path(__file__).resolve().parents[2] / "data"
FRAMES = (1, 7, 23, 60, 101)


def _pose_heads(obj, names, frames):
    """Blender's evaluated pose-bone heads (frames, bones, 3) in armature space."""
    scene = bpy.context.scene
    out = np.empty((len(frames), len(names), 3))
    for k, f in enumerate(frames):
        scene.frame_set(f)
        for j, n in enumerate(names):
            out[k, j] = np.array(obj.pose.bones[n].head)
    return out


def _import_bvh(path):
    import addon_utils

    addon_utils.enable("io_anim_bvh", default_set=False)
    before = set(bpy.data.objects)
    bpy.ops.import_anim.bvh(filepath=str(path), rotate_mode="NATIVE", global_scale=1.0)
    (obj,) = set(bpy.data.objects) - before
    return obj


@pytest.mark.parametrize("space", ["armature", "pose"])
def test_fk_of_an_action_read_with_its_armature(empty_file, space):
    """read_action(..., space) + core FK = Blender's pose heads (Acclaim import of 07_01, metres) to 1e-5 m."""
    r = bpy.ops.shapesig.import_acclaim(filepath=str(DATA / "acclaim" / "07_01.amc"),
                                        asf_path=str(DATA / "acclaim" / "07-walk.asf"))
    assert r == {"FINISHED"}
    obj = bpy.context.view_layer.objects.active
    clip = action_io.read_action(obj.animation_data.action, armature=obj, space=space)
    heads, _tails, _W = forward_kinematics(clip)
    idx = [f - clip.frame_start for f in FRAMES]
    got = _pose_heads(obj, clip.bones, FRAMES)
    assert np.abs(heads[idx] - got).max() < 1e-5


def test_fk_of_the_bpy_free_readers_on_blender_armatures(empty_file):
    """load_bvh (Daz BVH, file units) and load_acclaim (metres) FK = the importers' armatures posed by Blender."""
    obj = _import_bvh(DATA / "bvh" / "07_01.bvh")
    clip = load_bvh(DATA / "bvh" / "07_01.bvh")
    heads = forward_kinematics(clip)[0]
    got = _pose_heads(obj, clip.bones, FRAMES)
    scale = np.abs(heads).max()
    assert np.abs(heads[[f - 1 for f in FRAMES]] - got).max() < 1e-5 * scale  # float32 keys
    bpy.ops.shapesig.import_acclaim(filepath=str(DATA / "acclaim" / "09_02.amc"),
                                    asf_path=str(DATA / "acclaim" / "09-run.asf"))
    obj = bpy.context.view_layer.objects.active
    clip = load_acclaim(DATA / "acclaim" / "09_02.amc", DATA / "acclaim" / "09-run.asf", axes="blender")
    heads = forward_kinematics(clip)[0]
    got = _pose_heads(obj, clip.bones, FRAMES)
    assert np.abs(heads[[f - clip.frame_start for f in FRAMES]] - got).max() < 1e-5
