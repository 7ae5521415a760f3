"""FBX and glTF clips through Blender's importers in the reading child: files written here by Blender's own FBX
and glTF exporters from a real CMU walk (tests/data/bvh/07_01.bvh imported with its BVH importer) read back as the
BVH reads (the comparison space, rate, frames), every animation of a GLB a clip addressed ``FILE#ANIMATION``,
nested scaled and turned nodes above the armature change nothing, bad files are one line, a folder costs one
child start-up and a crashing importer is a ParseError."""

import json
import os
import pathlib
import shutil
import struct
import sys

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from blender_shapesig import cli  # noqa: E402
from blender_shapesig.core.errors import ParseError  # noqa: E402
from blender_shapesig.core.io import sources  # noqa: E402
from blender_shapesig.readers import child  # noqa: E402

BVH = pathlib.Path(__file__).resolve().parents[2] / "data" / "bvh" / "07_01.bvh"
FRAMES = 90  # the first 90 frames (0.75 s at 120 fps) of the walk are exported


@pytest.fixture(scope="module")
def files(addon, tmp_path_factory):
    """walk.fbx, walk.glb and tiny.glb (``tests.helpers.interchange_files``), made in a child process."""
    import subprocess

    out = tmp_path_factory.mktemp("interchange")
    root = pathlib.Path(__file__).resolve().parents[3]
    p = subprocess.run([sys.executable, "-m", "tests.helpers.interchange_files", str(out)], cwd=root,
                       capture_output=True, text=True, timeout=600)
    assert p.returncode == 0 and (out / "tiny.glb").is_file(), p.stderr[-2000:]
    return out


def _bvh_walk(frames=FRAMES):
    return sources.read_one(sources.ClipSpec(str(BVH), end=frames, trim="none"))


def _assert_same_poses(clip, ref, atol=1e-4):
    assert clip.bones == ref.bones and clip.frames == ref.frames and clip.fps == ref.fps
    np.testing.assert_allclose(clip.rotations, ref.rotations, atol=atol)
    assert clip.meta.get("root_path") == ref.meta.get("root_path") == "hips_legs"  # in leg lengths
    np.testing.assert_allclose(clip.root_translation - clip.root_translation[0],
                               ref.root_translation - ref.root_translation[0], atol=atol)


def test_fbx_and_glb_read_as_the_bvh_they_were_written_from(files):
    ref = _bvh_walk()
    (fbx,) = sources.read(sources.ClipSpec(str(files / "walk.fbx"), trim="none"))
    assert fbx.name == "walk" and fbx.meta["format"] == "fbx" and fbx.fps == 120.0  # FBX TimeMode 120
    _assert_same_poses(fbx, ref)
    glb = sources.read_one(sources.ClipSpec(str(files / "walk.glb"), action="07_01", trim="none"))
    assert glb.meta["format"] == "gltf" and glb.fps == 120.0  # glTF: the key spacing, 1/120 s
    _assert_same_poses(glb, ref)


def test_every_animation_of_a_glb_is_a_clip_addressed_by_its_name(files):
    path = str(files / "walk.glb")
    clips = sources.read(sources.ClipSpec(path, trim="none"))
    assert sorted(c.name for c in clips) == ["07_01", "walk_short"]
    short = sources.read_one(sources.ClipSpec.parse(f"{path}#walk_short", trim="none"))
    assert short.frames == 40
    _assert_same_poses(short, _bvh_walk(40))
    assert sources.clip_address(path, "walk_short", short.source) == (f"{path}#walk_short", "walk_short")
    assert sources.clip_address(str(files / "walk.fbx"), "walk", str(files / "walk.fbx"))[1] is None


def test_a_wrong_animation_name_lists_the_ones_the_file_has(files):
    with pytest.raises(ParseError) as info:
        sources.read(sources.ClipSpec.parse(f"{files / 'walk.glb'}#Walking"))
    text = str(info.value)
    assert "no animation 'Walking'" in text and "07_01, walk_short" in text and "not found" not in text
    assert "\n" not in text


def test_nodes_above_the_armature_change_no_pose(files):
    """A 0.001-scale walk under two nested nodes turned +90 and -90 degrees about X (Michelle's layout) compares
    equal: the clip is in the world's axes, the comparison space in leg lengths."""
    tiny = sources.read_one(sources.ClipSpec(str(files / "tiny.glb"), action="07_01", trim="none"))
    raw = sources.read_one(sources.ClipSpec(str(files / "tiny.glb"), action="07_01", trim="none", bone_map="none"))
    height = np.ptp(np.array(list(raw.meta["rest_heads"].values()))[:, 2])
    full = sources.read_one(sources.ClipSpec(str(files / "walk.fbx"), trim="none", bone_map="none"))
    full_height = np.ptp(np.array(list(full.meta["rest_heads"].values()))[:, 2])
    assert height == pytest.approx(full_height * 0.001, rel=1e-3)
    _assert_same_poses(tiny, _bvh_walk(), atol=2e-4)


def test_a_folder_of_files_costs_one_child(files, tmp_path, capsys):
    folder = tmp_path / "lib"
    folder.mkdir()
    for i in range(3):
        shutil.copy(files / "walk.fbx", folder / f"walk_{i}.fbx")
    shutil.copy(files / "walk.glb", folder / "walk.glb")
    child.close()
    before = child.starts()
    code = cli.main(["rank", str(files / "walk.fbx"), str(folder), "--json", "--no-cache", "--no-progress"])
    out = capsys.readouterr()
    assert code == 0, out.err
    assert child.starts() - before == 1  # the query and 4 library files: one start-up
    rows = json.loads(out.out)["results"]
    assert len(rows) == 5 and {r["clip"] for r in rows[:4]} == {"walk_0", "walk_1", "walk_2", "07_01"}
    by_clip = {r["clip"]: r for r in rows}
    assert by_clip["walk_short"]["action"] == "walk_short" and by_clip["walk_0"]["action"] is None


def _ascii_fbx(path):
    path.write_text('; FBX 7.4.0 project file\n; ----------------------------------------------------\n\n'
                    'FBXHeaderExtension:  {\n\tFBXHeaderVersion: 1003\n\tFBXVersion: 7400\n}\n')


def _vrma(path):
    doc = {"asset": {"version": "2.0"}, "extensionsUsed": ["VRMC_vrm_animation"], "nodes": [{"name": "hips"}]}
    data = json.dumps(doc).encode()
    data += b" " * (-len(data) % 4)
    path.write_bytes(b"glTF" + struct.pack("<II", 2, 20 + len(data)) + struct.pack("<II", len(data), 0x4E4F534A)
                     + data)


def _glb_with(path, source, edit):
    """A copy of the GLB ``source`` whose JSON is changed by ``edit(doc)`` (the binary chunk kept)."""
    raw = source.read_bytes()
    n = struct.unpack("<I", raw[12:16])[0]
    doc = json.loads(raw[20:20 + n])
    edit(doc)
    data = json.dumps(doc).encode()
    data += b" " * (-len(data) % 4)
    rest = raw[20 + n:]
    path.write_bytes(b"glTF" + struct.pack("<II", 2, 20 + len(data) + len(rest))
                     + struct.pack("<II", len(data), 0x4E4F534A) + data + rest)


def _huge_count(doc):
    doc["accessors"][doc["animations"][0]["samplers"][0]["input"]].update(count=2 ** 31, min=None, max=None)


@pytest.mark.parametrize("case, expected", [
    ("ascii.fbx", "ASCII FBX file.*re-save it as binary FBX"),
    ("test.vrma", "VRM animation"),
    ("truncated.fbx", "FBX"),
    ("magic.fbx", "not an FBX file"),
    ("magic.glb", "not a GLB file"),
    ("truncated.glb", "truncated GLB file"),
    ("count.glb", "reaches past its buffer"),
    ("count.fbx", "damaged FBX file: a record's lengths do not fit"),
    ("json.gltf", "its JSON cannot be read"),
])
def test_bad_files_are_one_line(files, tmp_path, case, expected):
    path = tmp_path / case
    fbx, glb = (files / "walk.fbx").read_bytes(), (files / "walk.glb").read_bytes()
    makers = {
        "ascii.fbx": lambda: _ascii_fbx(path), "test.vrma": lambda: _vrma(path),
        "truncated.fbx": lambda: path.write_bytes(fbx[:len(fbx) // 2]),
        "magic.fbx": lambda: path.write_bytes(b"\x00\xffnot fbx" + fbx[9:]),
        "magic.glb": lambda: path.write_bytes(b"gltf" + glb[4:]),
        "truncated.glb": lambda: path.write_bytes(glb[:len(glb) // 3]),
        "count.glb": lambda: _glb_with(path, files / "walk.glb", _huge_count),
        # the first record's property count made huge: Blender's parser would allocate it before reading
        "count.fbx": lambda: path.write_bytes(fbx[:31] + struct.pack("<I", 2 ** 31) + fbx[35:]),
        "json.gltf": lambda: path.write_text('{"asset": {"version": "2.0"}, "animations": ['),
    }
    makers[case]()
    with pytest.raises(ParseError, match=expected) as info:
        sources.read(str(path))
    assert "\n" not in str(info.value) and str(path) in str(info.value)


def test_a_crashing_importer_is_one_line_and_the_next_file_reads(files, monkeypatch):
    crash = "import os, signal; os.kill(os.getpid(), signal.SIGSEGV)"
    child.close()
    with monkeypatch.context() as m:
        m.setattr(child, "child_command", lambda script, args: [sys.executable, "-c", crash])
        with pytest.raises(ParseError, match="Blender crashed reading it") as info:
            sources.read(str(files / "walk.fbx"))
    assert "\n" not in str(info.value) and "walk.fbx" in str(info.value)
    assert sources.read(str(files / "walk.fbx"))[0].name == "walk"  # a new child for the next file
    child.close()


def test_reading_leaves_the_open_file_as_it_was(files):
    """In this process (what the child runs): the import's objects, actions and scene rate are gone after. The glTF
    file from Blender 4.4 on; on 4.2 the FBX file: there the glTF importer's in-process read crashes the bpy module
    now and then (in Python's garbage collection after the import, CI and this stop's runs), and the product reads
    glTF files in its reading child, where a crash is one line for that file."""
    from blender_shapesig.readers.interchange import read_interchange_here

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    before = ({o.name for o in bpy.data.objects}, {a.name for a in bpy.data.actions}, scene.render.fps)
    gltf = bpy.app.version >= (4, 4)
    clips = read_interchange_here(str(files / ("walk.glb" if gltf else "walk.fbx")))
    assert sorted(c.meta["animation"] for c in clips) == (["07_01", "walk_short"] if gltf else ["Scene"])
    assert ({o.name for o in bpy.data.objects}, {a.name for a in bpy.data.actions}, scene.render.fps) == before
    assert os.path.isfile(files / "walk.glb")


def test_reading_into_a_users_scene_reads_the_same_and_restores_it(files):
    """In the background (the bpy module, a script) the readers import into the open scene, not a new one (a
    scene switch per file queues a window notifier Blender never processes there; 4.2 crashed after hundreds):
    no scene is made, the scene's rate, frame range, current frame, selection and active object are as they were,
    and the clips equal those read in a fresh file (the importers see a new scene's rate and first frame). FBX and
    BVH: the glTF importer switches the window's scene itself, which crashes Blender 4.2's bpy module now and then
    (in the product glTF files are read in the reading child; one in-process glTF read is checked above)."""
    from blender_shapesig.readers.bvh import import_bvh
    from blender_shapesig.readers.interchange import read_interchange_here

    bpy.ops.wm.read_factory_settings(use_empty=True)
    fresh = read_interchange_here(str(files / "walk.fbx"))
    fresh.append(import_bvh(BVH))
    scene = bpy.context.scene
    scene.render.fps, scene.render.fps_base, scene.frame_start, scene.frame_end = 30, 1.001, 10, 50
    scene.frame_set(17)
    users = [bpy.data.objects.new(n, None) for n in ("Picked", "Other")]
    for o in users:
        scene.collection.objects.link(o)
    users[0].select_set(True)
    bpy.context.view_layer.objects.active = users[0]
    scenes = len(bpy.data.scenes)
    seen = []
    bpy.app.handlers.depsgraph_update_post.append(lambda sc, _dg: seen.append(len(bpy.data.scenes)))
    try:
        got = read_interchange_here(str(files / "walk.fbx"))
        got.append(import_bvh(BVH))
    finally:
        bpy.app.handlers.depsgraph_update_post.clear()
    assert max(seen, default=scenes) == scenes == len(bpy.data.scenes)
    assert (scene.render.fps, scene.render.fps_base, scene.frame_start, scene.frame_end, scene.frame_current) == \
        (30, pytest.approx(1.001), 10, 50, 17)
    assert [o.name for o in scene.objects if o.select_get()] == ["Picked"]
    assert bpy.context.view_layer.objects.active.name == "Picked" and len(bpy.data.objects) == 2
    assert [c.name for c in got] == [c.name for c in fresh]
    for a, b in zip(got, fresh):
        assert a.fps == b.fps and a.bones == b.bones
        np.testing.assert_allclose(a.rotations, b.rotations, atol=1e-9)
        np.testing.assert_allclose(a.root_translation, b.root_translation, atol=1e-9)


def test_the_panel_folder_library_ranks_fbx_and_glb_clips_with_one_child(files, empty_file, tmp_path, monkeypatch):
    """Find Similar with a clip folder of an FBX and a GLB (three clips): indexed step by step (the modal job's
    progress), every clip ranked, one child start-up for the folder."""
    from blender_shapesig.search import library, rank_job
    from blender_shapesig.core import search as search

    monkeypatch.setenv(search.CACHE_ENV, str(tmp_path / "index"))
    library.CACHES.clear()
    folder = tmp_path / "lib"
    folder.mkdir()
    shutil.copy(files / "walk.fbx", folder / "walk.fbx")
    shutil.copy(files / "walk.glb", folder / "walk.glb")
    bpy.ops.import_anim.bvh(filepath=str(BVH), rotate_mode="NATIVE", frame_start=1, use_fps_scale=False,
                            update_scene_fps=False, update_scene_duration=False)
    s = bpy.context.scene.shapesig
    s.use_file_actions, s.use_folders, s.folders, s.fps = False, True, str(folder), 120.0
    child.close()
    before = child.starts()
    job = rank_job.RankJob(bpy.context, s)
    steps = 0
    while not job.step():
        steps += 1
    job.store()
    assert steps >= 2 and child.starts() - before == 1
    rows = bpy.context.window_manager.shapesig_results.results
    assert sorted(r.name for r in rows) == ["07_01", "walk", "walk_short"]
    library.CACHES.clear()


def test_assign_of_an_fbx_result_retargets_it_onto_the_active_armature(files, empty_file, tmp_path, monkeypatch):
    """Find Similar from an iClone (Character Creator) armature with a clip folder of the exporters' FBX and GLB
    and an AMASS .npz ranks their clips; Assign of the FBX walk makes a new action on the CC armature through both bone maps: every
    joint both rigs have moves with the FBX clip's angular velocity in the comparison space (correlation >= 0.9);
    the FBX file is not changed."""
    from blender_shapesig.actions import action_io
    from blender_shapesig.rigs import rigmap
    from blender_shapesig.search import library
    from blender_shapesig.core import search as search
    from blender_shapesig.core import rigs
    from blender_shapesig.actions import frame_rates
    from blender_shapesig.core.clip.prepare import retime
    from blender_shapesig.core.geometry import so3

    monkeypatch.setenv(search.CACHE_ENV, str(tmp_path / "index"))
    library.CACHES.clear()
    folder = tmp_path / "lib"
    folder.mkdir()
    for name in ("walk.fbx", "walk.glb"):
        shutil.copy(files / name, folder / name)
    t = np.linspace(0.0, 2.0, 60)[:, None]  # an SMPL-H body swinging its legs and arms, written as AMASS does
    poses = np.zeros((60, 156))
    poses[:, 3:6] = poses[:, 12:15] = 0.4 * np.sin(2 * np.pi * t) * np.array([1.0, 0.0, 0.0])
    poses[:, 48:51] = 0.5 * np.sin(2 * np.pi * t) * np.array([0.0, 0.0, 1.0])
    np.savez(folder / "amass.npz", poses=poses, trans=np.zeros((60, 3)), mocap_framerate=np.array(30.0))
    stamp = (folder / "walk.fbx").read_bytes()
    cc = BVH.parent.parent / "cross_rig" / "002_03.bvh"
    bpy.ops.import_anim.bvh(filepath=str(cc), rotate_mode="NATIVE", frame_start=1, use_fps_scale=False,
                            update_scene_fps=True, update_scene_duration=True)
    arm = bpy.context.object
    own = arm.animation_data.action
    s = bpy.context.scene.shapesig
    s.use_file_actions, s.use_folders, s.folders = False, True, str(folder)
    s.similarity, s.rerank = "sim", 0
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    res = bpy.context.window_manager.shapesig_results
    names = [r.name for r in res.results]
    # the FBX take, the GLB's two animations and the SMPL-H body
    assert sorted(names) == ["07_01", "amass", "walk", "walk_short"], names
    res.results_index = next(i for i, r in enumerate(res.results) if "walk.fbx" in (r.spec or r.source))
    assert bpy.ops.shapesig.assign_result() == {"FINISHED"}
    new = arm.animation_data.action
    assert new != own and "walk" in new.name
    got = rigs.apply_bone_map(action_io.read_action(new, armature=arm, exclude_unkeyed=True, space="armature"),
                              rigmap.bone_map_of(arm))
    src = sources.read_one(sources.ClipSpec(str(folder / "walk.fbx")))
    # written at the scene's rate (60 fps, the iClone file's): the same duration, the source resampled to it
    assert got.fps == pytest.approx(frame_rates.scene_rate()) and abs(got.fps - 60.0) < 0.01
    assert abs((got.frames - 1) / got.fps - (src.frames - 1) / src.fps) <= 0.5 / got.fps
    src = retime(src, got.fps)
    shared = [j for j in src.bones if j in got.bones]
    assert len(shared) >= 15, shared
    assert got.frames == src.frames, (got.frames, src.frames)
    for j in shared:
        va, vb = (so3.log(R[1:] @ np.swapaxes(R[:-1], -1, -2))
                  for R in (got.rotations[:, got.bones.index(j)], src.rotations[:, src.bones.index(j)]))
        if np.abs(vb).max() < 1e-3:
            continue  # a joint the walk holds still
        assert np.corrcoef(va.ravel(), vb.ravel())[0, 1] >= 0.9, j
    assert (folder / "walk.fbx").read_bytes() == stamp
    library.CACHES.clear()
