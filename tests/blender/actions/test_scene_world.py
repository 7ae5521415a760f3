"""The characters animators have (issue 38): an armature whose object is turned and scaled as Blender's FBX importer
leaves a Mixamo character (rotation 90 degrees about X, scale 0.01, bones in Y-up centimetres), one parented to a
turned empty, and a scaled one are read in the world's axes: Find Similar lists what it lists for the same motion
on an armature at the identity and what the command line lists for the file; Assign of another rig's walk keeps the
character upright; a blend across rigs keeps its toes above the floor and its joints without jumps; the key-pose
pictures stand. Written actions play at their true speed in 24 and 30 fps scenes.

The turned characters are made from Blender's own BVH import of a CMU take by Blender's own operators (the inverse
turn applied to the armature data with Apply Transform, the object then turned back), so the world motion Blender
evaluates is the same as the untouched import's: that equality, checked first, is the truth the rest relies on."""

import json
import math
import pathlib
import shutil
import subprocess
import sys

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from blender_shapesig import compat  # noqa: E402
from blender_shapesig.actions import frame_rates  # noqa: E402
from blender_shapesig.search import library  # noqa: E402
from blender_shapesig.core import search as search  # noqa: E402
from tests.helpers.turned_characters import (import_bvh, quiet, scale_location_keys, select_only,  # noqa: E402
                                             turned, world_heads)

ROOT = pathlib.Path(__file__).resolve().parents[3]
DATA = ROOT / "tests" / "data"
WALK = DATA / "bvh" / "07_01.bvh"


@pytest.fixture
def scene24(empty_file, monkeypatch, tmp_path):
    monkeypatch.setenv(search.CACHE_ENV, str(tmp_path / "index"))
    library.CACHES.clear()
    frame_rates.forget()
    bpy.context.scene.render.fps, bpy.context.scene.render.fps_base = 24, 1.0
    yield bpy.context.scene
    library.CACHES.clear()


@pytest.mark.parametrize("how", ["fbx", "empty", "scaled"])
def test_the_turned_character_moves_as_the_import_in_the_world(scene24, how):
    plain = import_bvh(WALK, "plain")
    arm = turned(WALK, "lying", how)
    assert not np.allclose(np.array(arm.matrix_world), np.eye(4))
    frames = [1, 40, 120, 250]
    np.testing.assert_allclose(world_heads(arm, frames), world_heads(plain, frames), atol=2e-4)


def _find_similar(arm, folder):
    s = bpy.context.scene.shapesig
    s.use_file_actions, s.use_folders, s.folders = False, True, str(folder)
    select_only(arm)
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    return [(pathlib.Path(r.spec or r.source).name, r.distance) for r in
            bpy.context.window_manager.shapesig_results.results]


@pytest.fixture
def folder(tmp_path):
    lib = tmp_path / "lib"
    lib.mkdir()
    for rel in ("bvh/07_02.bvh", "bvh/08_01.bvh", "bvh/09_02.bvh", "bvh/09_03.bvh", "bvh/13_32.bvh",
                "acclaim/16_15.bvh", "cross_rig/02_03.bvh", "cross_rig/002_03.bvh"):
        shutil.copy(DATA / rel, lib / pathlib.Path(rel).name)
    return lib


@pytest.mark.parametrize("how", ["fbx", "empty", "scaled"])
def test_find_similar_from_a_turned_character_lists_what_the_command_line_lists(scene24, folder, how):
    plain = import_bvh(WALK, "plain")
    arm = turned(WALK, "lying", how)
    want = _find_similar(plain, folder)
    got = _find_similar(arm, folder)
    assert [n for n, _d in got[:5]] == [n for n, _d in want[:5]], (got, want)
    np.testing.assert_allclose([d for _n, d in got], [d for _n, d in want], rtol=1e-4)
    # the command line on the file, as a user runs it
    run = subprocess.run([sys.executable, "-m", "blender_shapesig", "rank", str(WALK), str(folder), "--top", "5",
                          "--json", "--no-cache"], capture_output=True, text=True, cwd=ROOT, timeout=600)
    assert run.returncode == 0, run.stderr
    out = json.loads(run.stdout)
    assert [pathlib.Path(r["path"]).name for r in out["results"][:5]] == [n for n, _d in got[:5]]
    # the saved file's turned character on the command line (read in a child, its object's transform applied)
    saved = folder.parent / "turned.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(saved), copy=True)
    run = subprocess.run([sys.executable, "-m", "blender_shapesig", "rank", f"{saved}#lying", str(folder), "--top",
                          "5", "--json", "--no-cache"], capture_output=True, text=True, cwd=ROOT, timeout=600)
    assert run.returncode == 0, run.stderr
    assert [pathlib.Path(r["path"]).name for r in json.loads(run.stdout)["results"]] == [n for n, _d in got[:5]]


def _world_pose(arm, frames, tails=False):
    """(heads or tails (frames, bones, 3), world rotations (frames, bones, 3, 3)) as Blender evaluates the pose."""
    pts, rots = [], []
    scene = bpy.context.scene
    for f in frames:
        scene.frame_set(int(f))
        M = np.array(arm.matrix_world)
        A = M[:3, :3] / np.cbrt(np.linalg.det(M[:3, :3]))
        pts.append([(M @ np.append(np.array(pb.tail if tails else pb.head), 1.0))[:3] for pb in arm.pose.bones])
        rots.append([A @ np.array(pb.matrix)[:3, :3] / np.linalg.norm(np.array(pb.matrix)[:3, 0]) for pb in arm.pose.bones])
    return np.array(pts), np.array(rots)


def _frames(action, step=1):
    first, last = (int(round(x)) for x in action.frame_range)
    return list(range(first, last + 1, step))


def _largest_step_deg(rots):
    rel = np.einsum("fbij,fbkj->fbik", rots[1:], rots[:-1])
    cos = np.clip((np.trace(rel, axis1=-2, axis2=-1) - 1.0) / 2.0, -1.0, 1.0)
    return float(np.degrees(np.arccos(cos)).max())


def _bone_index(arm, names):
    return [i for i, pb in enumerate(arm.pose.bones) if pb.name in names]


@pytest.mark.parametrize("how", ["fbx", "empty", "scaled"])
def test_assign_of_another_rigs_walk_keeps_the_turned_character_upright(scene24, folder, how):
    arm = turned(WALK, "lying", how)
    hip, head = _bone_index(arm, {"hip"})[0], _bone_index(arm, {"head"})[0]
    own, _rots = _world_pose(arm, _frames(arm.animation_data.action, 5))
    stance = float(np.median(own[:, hip, 2]))  # the character's own hips height when it walks (its rest is 0)
    _find_similar(arm, folder)
    res = bpy.context.window_manager.shapesig_results
    res.results_index = next(i for i, r in enumerate(res.results) if (r.spec or r.source).endswith("16_15.bvh"))
    assert bpy.ops.shapesig.assign_result() == {"FINISHED"}
    new = arm.animation_data.action
    assert new.name != "lying"
    heads, _rots = _world_pose(arm, _frames(new))
    assert (heads[:, head, 2] > heads[:, hip, 2]).all()
    assert np.abs(heads[:, hip, 2] / stance - 1.0).max() <= 0.25, (heads[:, hip, 2].min(), heads[:, hip, 2].max(),
                                                                   stance)


FEET = {"lFoot", "rFoot", "lfoot", "rfoot", "ltoes", "rtoes"}


def _lowest_and_step(arm, frames):
    heads, rots = _world_pose(arm, frames)
    tails, _ = _world_pose(arm, frames, tails=True)
    feet = _bone_index(arm, FEET)
    return min(heads[:, feet, 2].min(), tails[:, feet, 2].min()), _largest_step_deg(rots)


@pytest.mark.parametrize("how", ["fbx", "empty", "scaled"])
def test_a_blend_of_the_turned_character_with_another_rigs_walk_stays_on_the_floor(scene24, how):
    arm = turned(WALK, "lying", how)
    other = import_bvh(DATA / "acclaim" / "16_15.bvh", "16_15")
    # the sources at 24 samples a second (their keys are 120 a second, one a scene frame): every 5th frame
    low_a, step_a = _lowest_and_step(arm, _frames(arm.animation_data.action, 5))
    low_b, step_b = _lowest_and_step(other, _frames(other.animation_data.action, 5))
    select_only(arm)
    assert bpy.ops.shapesig.blend_actions(action_a="lying", action_b="16_15", weight=0.5, fps_a=120.0, fps_b=120.0,
                                          assign=True) == {"FINISHED"}
    new = arm.animation_data.action
    assert new.name.startswith("lying_x_16_15")
    low, step = _lowest_and_step(arm, _frames(new))
    assert low >= min(low_a, low_b) - 0.02, (low, low_a, low_b)
    assert step <= max(step_a, step_b) + 5.0, (step, step_a, step_b)


def test_the_key_pose_pictures_of_a_turned_character_stand(scene24):
    """The pictures draw the canonical body the local search poses from the clip (``local.body_positions``,
    Z up): on a turned character its head is above its pelvis and its ankles below, as on the plain import."""
    from blender_shapesig.core.search.local import features as local

    for how in ("fbx", "empty"):
        arm = turned(WALK, f"lying_{how}", how)
        clip = library.action_item(arm.animation_data.action, arm).clips()[0]
        pelvis, P, _side = local.body_positions(clip)
        head, ankles = local.POINTS.index("head"), [local.POINTS.index(f"ankle.{s}") for s in "LR"]
        assert (P[:, head, 2] - pelvis[:, 2] > 0.5).all(), how
        assert (P[:, ankles, 2] - pelvis[:, 2, None] < -0.5).all(), how


def _bvh_at(src, rate, out):
    """``src`` with its Frame Time set to 1 / ``rate``: a clip of the same frames at that rate."""
    lines = src.read_text().splitlines()
    i = next(k for k, ln in enumerate(lines) if ln.strip().startswith("Frame Time"))
    lines[i] = f"Frame Time: {1.0 / rate:.8f}"
    out.write_text("\n".join(lines) + "\n")
    return out


def _scene_seconds(action):
    first, last = action.frame_range
    return (last - first) / frame_rates.scene_rate()


@pytest.mark.parametrize("scene_fps", [24, 30])
def test_assigned_clips_play_at_their_true_speed(scene24, tmp_path, scene_fps):
    from blender_shapesig.core.io import sources
    from blender_shapesig.actions.scene_motion import timing_text

    bpy.context.scene.render.fps = scene_fps
    lib = tmp_path / "rates"
    lib.mkdir()
    for rate in (30, 60, 100, 120):
        _bvh_at(DATA / "acclaim" / "16_15.bvh", rate, lib / f"walk_{rate}.bvh")
    arm = import_bvh(WALK, "walker")
    _find_similar(arm, lib)
    res = bpy.context.window_manager.shapesig_results
    assert len(res.results) == 4
    for i, row in enumerate(res.results):
        res.results_index = i
        assert bpy.ops.shapesig.assign_result() == {"FINISHED"}
        got = _scene_seconds(arm.animation_data.action)
        clip = sources.read_one(sources.ClipSpec(row.spec or row.source))
        true = (clip.frames - 1) / clip.fps
        assert abs(got / true - 1.0) <= 0.05, (row.source, got, true)
        # the report line says it (Assign's and Preview's)
        said = timing_text(arm.animation_data.action)
        assert f"at the scene's {scene_fps} fps" in said, said
        assert (f"resampled from {int(clip.fps)} fps" in said) == (int(clip.fps) != scene_fps), said


@pytest.mark.parametrize("scene_fps", [24, 30])
def test_blends_play_for_the_weight_average_of_their_sources(scene24, scene_fps):
    bpy.context.scene.render.fps = scene_fps
    arm = import_bvh(WALK, "walk")
    other = import_bvh(DATA / "bvh" / "07_02.bvh", "walk2")
    seconds = {}
    for act, rate in ((arm.animation_data.action, 120.0), (other.animation_data.action, 60.0)):
        first, last = act.frame_range
        seconds[act.name] = (last - first) / rate
    select_only(arm)
    assert bpy.ops.shapesig.blend_actions(action_a="walk", action_b="walk2", weight=0.25, fps_a=120.0, fps_b=60.0,
                                          feet="NONE", assign=True) == {"FINISHED"}
    got = _scene_seconds(arm.animation_data.action)
    want = 0.75 * seconds["walk"] + 0.25 * seconds["walk2"]
    assert abs(got / want - 1.0) <= 0.05, (got, want, seconds)


def test_a_blend_with_editable_timing_plays_its_true_duration_in_a_24_fps_scene(scene24):
    from blender_shapesig.blend.blend_actions import timed_strips

    arm = import_bvh(WALK, "walk")
    other = import_bvh(DATA / "bvh" / "07_02.bvh", "walk2")
    want = 0.5 * sum((a.frame_range[1] - a.frame_range[0]) / 120.0
                     for a in (arm.animation_data.action, other.animation_data.action))
    select_only(arm)
    assert bpy.ops.shapesig.blend_actions(action_a="walk", action_b="walk2", weight=0.5, fps_a=120.0, fps_b=120.0,
                                          feet="NONE", timing="NLA") == {"FINISHED"}
    strip = timed_strips(arm)[0]
    keys = strip.fcurves.find("strip_time").keyframe_points
    clock = (keys[-1].co.x - keys[0].co.x) / 24.0
    assert abs(clock / want - 1.0) <= 0.05, (clock, want)
    assert strip.frame_end >= keys[-1].co.x - 1e-3  # the strip lasts as long as its clock
    assert bpy.ops.shapesig.bake_blend_timing() == {"FINISHED"}
    assert abs(_scene_seconds(arm.animation_data.action if arm.animation_data.action else
                              bpy.data.actions["walk_x_walk2_0.50_baked"]) / want - 1.0) <= 0.05


SHARED_MIXAMO = ROOT.parent / "shared" / "data" / "rigs" / "mixamo_fbx" / "Walking.fbx"
MIXAMO_FEET = {f"mixamorig:{s}{b}" for s in ("Left", "Right") for b in ("Foot", "ToeBase", "Toe_End")}


@pytest.mark.skipif(not SHARED_MIXAMO.exists(), reason="the Mixamo FBX of ../shared/data/rigs (not redistributable)")
def test_a_real_mixamo_character_imported_by_blender(scene24, folder):
    """The real thing, when ../shared is beside the repository (CI): Mixamo's Walking.fbx through Blender's FBX
    importer at its default options (object turned 90 degrees, scale 0.01). Find Similar lists what the command
    line lists for the file (top 5, same distances); Assign of another rig's walk stays upright; a blend with a
    CMU walk keeps the toes on the floor and the joints without jumps."""
    quiet(bpy.ops.import_scene.fbx, filepath=str(SHARED_MIXAMO))
    arm = next(o for o in bpy.data.objects if o.type == "ARMATURE")
    assert abs(arm.rotation_euler[0] - math.pi / 2) < 1e-4 and abs(arm.scale[0] - 0.01) < 1e-6
    arm.animation_data.action.name = "mixamo_walk"
    got = _find_similar(arm, folder)
    run = subprocess.run([sys.executable, "-m", "blender_shapesig", "rank", str(SHARED_MIXAMO), str(folder),
                          "--top", "5", "--json", "--no-cache"], capture_output=True, text=True, cwd=ROOT, timeout=600)
    assert run.returncode == 0, run.stderr
    cli_rows = json.loads(run.stdout)["results"]
    assert [pathlib.Path(r["path"]).name for r in cli_rows] == [n for n, _d in got[:5]]
    np.testing.assert_allclose([r["distance"] for r in cli_rows], [d for _n, d in got[:5]], rtol=1e-4)
    # Assign of the MotionBuilder walk (another rig) keeps the character upright at its own walking height
    hip, head = _bone_index(arm, {"mixamorig:Hips"})[0], _bone_index(arm, {"mixamorig:Head"})[0]
    own, _rots = _world_pose(arm, _frames(arm.animation_data.action))
    stance = float(np.median(own[:, hip, 2]))
    res = bpy.context.window_manager.shapesig_results
    res.results_index = next(i for i, r in enumerate(res.results) if (r.spec or r.source).endswith("16_15.bvh"))
    assert bpy.ops.shapesig.assign_result() == {"FINISHED"}
    heads, _rots = _world_pose(arm, _frames(arm.animation_data.action))
    assert (heads[:, head, 2] > heads[:, hip, 2]).all()
    assert np.abs(heads[:, hip, 2] / stance - 1.0).max() <= 0.25, (heads[:, hip, 2].min(), stance)
    rest = (np.array(arm.matrix_world) @ np.append(np.array(arm.data.bones["mixamorig:Hips"].head_local), 1.0))[2]
    assert np.abs(heads[:, hip, 2] / rest - 1.0).max() <= 0.25, (heads[:, hip, 2].min(), rest)  # its rest height
    # a blend with a CMU walk (Blender's BVH import, another rig), its first frame (the converter's rest pose) and
    # ramp left out; the CMU walk in metres (the BVH is in centimetres: the importer scales by 0.01), so heights of
    # both sources and the blend compare in one unit
    bpy.context.scene.frame_set(1)
    quiet(bpy.ops.import_anim.bvh, filepath=str(WALK), global_scale=0.01)
    cmu = bpy.context.view_layer.objects.active
    cmu.animation_data.action.name = "cmu_walk"
    # every foot joint: ankles, balls (ToeBase) and toe tips (Toe_End's head; its tail is made up by the importer)
    feet = MIXAMO_FEET | {"lFoot", "rFoot"}
    low_a, step_a = _lowest_and_step_of(arm, bpy.data.actions["mixamo_walk"], feet, 1, with_tails=False)
    low_b, step_b = _lowest_and_step_of(cmu, cmu.animation_data.action, feet, 5, with_tails=False)
    select_only(arm)
    assert bpy.ops.shapesig.blend_actions(action_a="mixamo_walk", action_b="cmu_walk", weight=0.5, fps_a=24.0,
                                          fps_b=120.0, range_b=(7, 317), assign=True) == {"FINISHED"}
    blend = arm.animation_data.action
    low, step = _lowest_and_step_of(arm, blend, feet, 1, with_tails=False)
    assert -0.1 < min(low_a, low_b) < 0.2, (low_a, low_b)  # both on the floor, in metres
    assert low >= min(low_a, low_b) - 0.02, (low, low_a, low_b)
    assert step <= max(step_a, step_b) + 5.0, (step, step_a, step_b)
    # the same blend after Apply Rotation & Scale (what an animator had to do before): the same world motion
    turned_heads, _r = _world_pose(arm, _frames(blend))
    select_only(arm)
    compat.assign_action(arm, bpy.data.actions["mixamo_walk"])
    quiet(bpy.ops.object.transform_apply, location=False, rotation=True, scale=True)
    scale_location_keys(bpy.data.actions["mixamo_walk"], 0.01)
    assert bpy.ops.shapesig.blend_actions(action_a="mixamo_walk", action_b="cmu_walk", weight=0.5, fps_a=24.0,
                                          fps_b=120.0, range_b=(7, 317), assign=True) == {"FINISHED"}
    applied_heads, _r = _world_pose(arm, _frames(arm.animation_data.action))
    np.testing.assert_allclose(turned_heads, applied_heads, atol=1e-3)


def _lowest_and_step_of(arm, action, feet, step, with_tails=True):
    """The lowest foot joint (heads of the foot bones; a bone's tail only where it is the end of the file's
    skeleton: a BVH End Site, not the tail Blender's FBX importer makes up for a leaf such as Toe_End) and the
    largest joint step."""
    compat.assign_action(arm, action)
    heads, rots = _world_pose(arm, _frames(action, step))
    tails = _world_pose(arm, _frames(action, step), tails=True)[0] if with_tails else heads
    idx = _bone_index(arm, feet)
    ends = [i for i in idx if not arm.pose.bones[i].name.endswith("_End")] if with_tails else []
    return min(heads[:, idx, 2].min(), tails[:, ends, 2].min(initial=np.inf)), _largest_step_deg(rots)


@pytest.mark.parametrize("how", ["fbx", "empty"])
def test_a_blend_of_two_walks_of_one_turned_rig_plants_its_feet_on_the_floor(scene24, how):
    """One rig (blended in its pose space): planted feet are found and kept with the world's up, not the
    armature's own Z (which is the world's -Y on a character the FBX importer turned): the same contacts as the
    same blend of the plain imports, toes on the floor, no joint jumps."""
    from blender_shapesig.blend.blend_actions import blend_actions

    def contacts(result):
        report = result.info["feet"][0]
        return [(r["clip"].split("_")[-1], r["side"], r["point"], len(r["intervals"])) for r in report["contacts"]]

    plain = import_bvh(WALK, "plain_walk")
    plain2 = import_bvh(DATA / "bvh" / "07_02.bvh", "plain_walk2")
    want = contacts(blend_actions(plain, plain.animation_data.action, plain2.animation_data.action, [0.5],
                                  feet="lock", rates=[120.0, 120.0]))
    assert want
    arm = turned(WALK, "walk", how)
    other = turned(DATA / "bvh" / "07_02.bvh", "walk2", how)
    low_a, step_a = _lowest_and_step(arm, _frames(arm.animation_data.action, 5))
    low_b, step_b = _lowest_and_step(other, _frames(other.animation_data.action, 5))
    result = blend_actions(arm, arm.animation_data.action, other.animation_data.action, [0.5], feet="lock",
                           rates=[120.0, 120.0])
    assert contacts(result) == want
    from blender_shapesig.actions import action_io

    action_io.assign_action(arm, result.actions[0])
    low, step = _lowest_and_step(arm, _frames(arm.animation_data.action))
    assert low >= min(low_a, low_b) - 0.02, (low, low_a, low_b)
    assert step <= max(step_a, step_b) + 5.0, (step, step_a, step_b)
