"""Control rigs (issue 38): a Rigify rig generated from Blender's bundled Human metarig. A found walk (the CMU 07_01
AMC walk, retargeted through the bone maps) assigned onto it keys its FK controls and sets its limbs to FK, and its
deform bones walk (each leg joint's angular velocity in the comparison space correlates >= 0.8 with the source's);
an action keyed on its controls with IK feet (made by the test from a CMU walk) reads, through the evaluated pose,
as the walk its deform bones make and finds walks first among the tests/data walks, runs and jump."""

import pathlib

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from blender_shapesig import compat  # noqa: E402
from blender_shapesig.actions import action_io, control_rigs, frame_rates  # noqa: E402
from blender_shapesig.rigs import retarget  # noqa: E402
from blender_shapesig.core.clip.prepare import retime  # noqa: E402
from blender_shapesig.actions.bone_channels import bone_channels  # noqa: E402
from blender_shapesig.core import search as index, rigs  # noqa: E402
from blender_shapesig.core.geometry import so3  # noqa: E402
from tests.helpers.walks_runs_idles import library, read, walks_first  # noqa: E402

LEGS = ("thigh.L", "thigh.R", "shin.L", "shin.R")
DATA = pathlib.Path(__file__).resolve().parents[2] / "data"


@pytest.fixture(scope="module")
def rigify(addon):
    import addon_utils

    bpy.ops.wm.read_factory_settings(use_empty=True)
    addon_utils.enable("rigify", default_set=True)
    bpy.ops.object.armature_human_metarig_add()
    bpy.ops.pose.rigify_generate()
    rig = bpy.context.object
    bpy.ops.object.mode_set(mode="OBJECT")
    yield rig
    # leave the process as the other tests expect it: Rigify off, an empty file (Blender 4.2's bpy module crashed
    # in later glTF imports and exports of a long run with Rigify left enabled)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    addon_utils.disable("rigify", default_set=True)


def _velocity(R):
    return so3.log(R[1:] @ np.swapaxes(R[:-1], -1, -2))


def _legs_agree(a, b, least=0.8):
    """Each leg joint's angular velocity (comparison space: invariant to the rigs' rest poses) correlates with
    the other clip's; returns the correlations."""
    n = min(a.frames, b.frames)
    out = {}
    for j in LEGS:
        va = _velocity(a.rotations[:n, a.bones.index(j)])
        vb = _velocity(b.rotations[:n, b.bones.index(j)])
        out[j] = float(np.corrcoef(va.ravel(), vb.ravel())[0, 1])
    assert min(out.values()) >= least, out
    return out


def _keyed_bones(action):
    return set(bone_channels(compat.all_action_fcurves(action)))


def test_a_found_walk_assigned_onto_rigify_keys_its_fk_controls_and_its_deform_bones_walk(rigify):
    rig = rigify
    assert control_rigs.is_control_rig(rig) and control_rigs.is_rigify(rig)
    walk = read("acclaim/07_01.amc", step=4)  # 120 -> 30 fps: fewer frames to solve
    frame, before = bpy.context.scene.frame_current, rig.animation_data.action if rig.animation_data else None
    action, kept = retarget.action_on_armature(walk, "auto", rig, "07_01 on rigify")
    keyed = _keyed_bones(action)
    assert {"torso", "hips", "chest", "thigh_fk.L", "shin_fk.R", "foot_fk.L", "upper_arm_fk.R", "head"} <= keyed
    assert not any(b.startswith(("DEF-", "ORG-", "MCH-")) for b in keyed), sorted(keyed)
    switches = [fc for fc in compat.all_action_fcurves(action) if fc.data_path.endswith('["IK_FK"]')]
    assert len(switches) == 4 and all(k.co[1] == 1.0 for fc in switches for k in fc.keyframe_points)  # FK
    # the rig is as it was: no action assigned, same frame, switches at IK
    assert (rig.animation_data.action if rig.animation_data else None) == before
    assert bpy.context.scene.frame_current == frame and rig.pose.bones["thigh_parent.L"]["IK_FK"] == 0.0
    # its deform bones make the walk
    got = rigs.apply_bone_map(control_rigs.evaluated_clip(rig, action), "auto")
    walk = retime(walk, frame_rates.scene_rate())  # keyed at the scene's rate (scene_motion.write_motion)
    assert got.frames == walk.frames and len(got.bones) == 22
    assert (rig.animation_data.action if rig.animation_data else None) == before  # reading restores them too
    assert bpy.context.scene.frame_current == frame
    _legs_agree(got, walk)
    # reading its F-curves is not reading the motion: no deform bone is keyed
    fcurves = action_io.read_action(action, armature=rig, exclude_unkeyed=True)
    assert not any(b.startswith("DEF-") for b in fcurves.bones)


def _ik_action(rig, fk, name):
    """A copy of the FK action ``fk`` with the legs switched to IK and the IK feet keyed where the FK feet were
    (each frame: ``foot_ik`` takes the evaluated ``ORG-foot``'s turn and position), as an animator keys a walk."""
    act = fk.copy()
    act.name = name
    start, end = (int(round(x)) for x in fk.frame_range)
    mats = {s: [] for s in "LR"}
    ad = rig.animation_data or rig.animation_data_create()
    ad.action = None
    compat.assign_action(rig, fk)
    for f in range(start, end + 1):
        bpy.context.scene.frame_set(f)
        for s in "LR":
            org, ik = rig.pose.bones[f"ORG-foot.{s}"], rig.data.bones[f"foot_ik.{s}"]
            delta = np.array(org.matrix) @ np.linalg.inv(np.array(rig.data.bones[f"ORG-foot.{s}"].matrix_local))
            mats[s].append(delta @ np.array(ik.matrix_local))
    ad.action = None
    compat.assign_action(rig, act)
    for fc in list(compat.all_action_fcurves(act)):
        if fc.data_path.endswith('["IK_FK"]') and "thigh" in fc.data_path:
            for k in fc.keyframe_points:
                k.co[1] = 0.0  # the legs in IK
    from mathutils import Matrix

    for s in "LR":
        rig.pose.bones[f"thigh_parent.{s}"]["IK_FK"] = 0.0
    for i, f in enumerate(range(start, end + 1)):
        bpy.context.scene.frame_set(f)
        for s in "LR":
            pb = rig.pose.bones[f"foot_ik.{s}"]
            pb.matrix = Matrix(mats[s][i].tolist())
            bpy.context.view_layer.update()
            pb.keyframe_insert("location", frame=f)
            pb.keyframe_insert("rotation_quaternion", frame=f)
    ad.action = None
    return act


def test_rigify_action_keyed_on_controls_with_ik_feet_reads_as_its_deform_motion_and_finds_walks(rigify):
    rig = rigify
    source = read("bvh/08_01.bvh", step=4)  # a walk of another subject; its files are left out of the library
    fk, _kept = retarget.action_on_armature(source, "auto", rig, "08_01 fk")
    ik = _ik_action(rig, fk, "08_01 ik feet")
    assert {"foot_ik.L", "foot_ik.R"} <= _keyed_bones(ik)
    query = rigs.apply_bone_map(control_rigs.evaluated_clip(rig, ik), "auto")
    # the IK legs make the FK legs' motion (the feet where they were, the knees by the IK solve)
    _legs_agree(query, rigs.apply_bone_map(control_rigs.evaluated_clip(rig, fk), "auto"), least=0.8)
    labels, clips = library("08_01")
    walks_first(index.rank_clips(query, clips), labels)


def test_find_similar_and_assign_from_the_panel_on_a_rigify_rig(rigify, tmp_path, monkeypatch):
    """As an animator uses it: the Rigify rig playing its control-keyed action with IK feet, Find Similar over a
    folder of the tests/data BVH walks, runs and jump lists walks first (its action is read through the deform
    bones' evaluated pose: scene_motion.read_motion); Assign of a run keys the rig's FK controls and its deform
    thighs swing with the run."""
    import shutil

    from blender_shapesig.search import library
    from blender_shapesig.core import search as search

    monkeypatch.setenv(search.CACHE_ENV, str(tmp_path / "index"))
    library.CACHES.clear()
    rig = rigify
    source = read("bvh/07_02.bvh", step=4)
    fk, _kept = retarget.action_on_armature(source, "auto", rig, "07_02 fk panel")
    ik = _ik_action(rig, fk, "07_02 ik panel")
    compat.assign_action(rig, ik)
    folder = tmp_path / "lib"
    folder.mkdir()
    labels = {"07_01.bvh": "walk", "08_01.bvh": "walk", "09_02.bvh": "run", "09_03.bvh": "run", "13_32.bvh": "jump"}
    for name in labels:
        shutil.copy(DATA / "bvh" / name, folder / name)
    s = bpy.context.scene.shapesig
    s.use_file_actions, s.use_folders, s.folders = False, True, str(folder)
    bpy.context.view_layer.objects.active = rig
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    rows = list(bpy.context.window_manager.shapesig_results.results)
    got = [labels[pathlib.Path(r.spec or r.source).name] for r in rows]
    assert got[:2] == ["walk", "walk"], [(r.source, round(r.distance, 3)) for r in rows]
    res = bpy.context.window_manager.shapesig_results
    res.results_index = next(i for i, r in enumerate(rows) if (r.spec or r.source).endswith("09_02.bvh"))
    assert bpy.ops.shapesig.assign_result() == {"FINISHED"}
    new = rig.animation_data.action
    assert new != ik and "torso" in _keyed_bones(new) and not any(b.startswith("DEF-") for b in _keyed_bones(new))
    run = rigs.apply_bone_map(control_rigs.evaluated_clip(rig, new), "auto")
    assert abs(run.fps - 24.0) < 1e-9  # keyed at the scene's rate
    _legs_agree(run, retime(read("bvh/09_02.bvh"), run.fps), least=0.8)
    library.CACHES.clear()
