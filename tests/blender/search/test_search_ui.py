"""Signature search in Blender on real CMU clips (BVH walks 07_01, 07_02, 08_01; runs 09_02, 09_03; forward
jump 13_32, all imported with Blender's BVH importer): the file library and a folder library rank walks
first, distances equal metrics.clip_distance on the actions read independently, the index cache hits,
misses after a keyframe edit and rebuilds a corrupt file; assign / preview / blend; clean errors; the panel
and list draw (fake layout) in every state."""

import os
import pathlib
from types import SimpleNamespace

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from blender_shapesig import compat  # noqa: E402
from blender_shapesig.actions import action_changes, action_io  # noqa: E402
from blender_shapesig.core import search as search, rigs  # noqa: E402
from blender_shapesig.core.metrics import clip_distance  # noqa: E402
from tests.helpers.blender_clips import BVH, CLIPS, import_bvh  # noqa: E402
from tests.helpers.fake_layout import FakeLayout, draw_search_panel  # noqa: E402
from tests.helpers.stand_in import stand_in  # noqa: E402

LABEL = {"07_01": "walk", "07_02": "walk", "08_01": "walk", "09_02": "run", "09_03": "run", "13_32": "jump"}


@pytest.fixture
def cache_env(monkeypatch, tmp_path):
    path = tmp_path / "index"
    monkeypatch.setenv(search.CACHE_ENV, str(path))
    return path


@pytest.fixture
def rig(empty_file, cache_env):
    """The first walk's armature (active, action 'walk1') and the other five actions (fake users)."""
    arm = import_bvh(f"{CLIPS['walk1']}.bvh", "walk1", fake_user=True)
    for action_name, clip in CLIPS.items():
        if action_name != "walk1":
            other = import_bvh(f"{clip}.bvh", action_name, fake_user=True)
            bpy.data.objects.remove(other)
    bpy.context.view_layer.objects.active = arm
    arm.select_set(True)
    s = bpy.context.scene.shapesig
    s.crop_start = 2  # frame 1 of these files is a rest pose
    return arm


def _cache():
    from blender_shapesig.search import library

    return library.get_cache(bpy.context)


def _read(name, arm):
    act = bpy.data.actions[name]
    first, last = (int(round(v)) for v in act.frame_range)
    # as the library reads actions: armature space, then the comparison space across rigs (core.rigs)
    return rigs.apply_bone_map(action_io.read_action(act, armature=arm, frame_range=(2, last), space="armature"))


def _results():
    s = bpy.context.scene.shapesig
    return [(r.name, r.distance) for r in bpy.context.window_manager.shapesig_results.results]


def test_registered(addon):
    for op in ("build_index", "rank", "assign_result", "preview_result", "clear_index"):
        assert hasattr(bpy.ops.shapesig, op)
        getattr(bpy.ops.shapesig, op).get_rna_type()
    for cls in ("SHAPESIG_PT_search_view3d", "SHAPESIG_PT_search_dopesheet", "SHAPESIG_PT_search_nla",
                "SHAPESIG_UL_results"):
        assert hasattr(bpy.types, cls)
    assert {bpy.types.SHAPESIG_PT_search_view3d.bl_category, bpy.types.SHAPESIG_PT_search_nla.bl_category} == {"ShapeSig"}
    assert hasattr(bpy.types.Scene, "shapesig")
    from blender_shapesig import preferences
    from blender_shapesig.search import library

    # the add-on's module name as imported (bl_ext.<repo>.blender_shapesig when installed as an extension)
    assert preferences.ShapeSigPreferences.bl_idname == addon.__name__ == library.ADDON_ID


def test_file_library_ranks_walks_first_and_caches(rig):
    # the index compares on the comparison time base (core.clip.prepare), as clip_distance does by default
    hashes = {a.name: action_io.action_hash(a) for a in bpy.data.actions}
    s = bpy.context.scene.shapesig
    s.similarity = "sim"  # Similarity: Motion only (the signature index, its cache and the d_S* re-rank)
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    got = _results()
    assert [n for n, _ in got][:2] in (["walk2", "walk3"], ["walk3", "walk2"])
    assert {n for n, _ in got[2:]} == {"run1", "run2", "jump"}
    assert bpy.context.window_manager.shapesig_results.query_name == "walk1" and "walk1" not in dict(got)
    q = _read("walk1", rig)
    for name, d in got:
        assert d == pytest.approx(clip_distance(q, _read(name, rig), "sim", 3), rel=1e-5)
    assert [r.frames for r in bpy.context.window_manager.shapesig_results.results] == [_read(n, rig).frames for n, _ in got]
    assert {a.name: action_io.action_hash(a) for a in bpy.data.actions} == hashes  # sources untouched
    assert os.listdir(os.environ[search.CACHE_ENV])  # the index is on disk, not in the .blend

    cache = _cache()
    before = dict(cache.stats)
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    # nothing computed again: the 6 clips are found by the ranking, then the query and each of the 5 re-ranked
    # clips once more by its d_S* step, and the query once for its bone count
    assert cache.stats["misses"] == before["misses"] and cache.stats["writes"] == before["writes"]
    assert cache.stats["hits"] == before["hits"] + 6 + 2 * 5 + 1
    assert _results() == got

    # edit one keyframe of 'run1': its hash changes, it alone is recomputed, its distance follows the edit
    run = bpy.data.actions["run1"]
    fc = next(f for f in compat.all_action_fcurves(run) if "rotation" in f.data_path and f.keyframe_points[5].co[1] != 0)
    fc.keyframe_points[40].co[1] += 0.5
    fc.update()
    # no object plays 'run1', so Blender reports the edit nowhere: a script tells the change detector
    action_changes.forget_fingerprints(run)
    before = dict(cache.stats)
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    assert cache.stats["misses"] == before["misses"] + 1
    new = dict(_results())
    assert new["run1"] != pytest.approx(dict(got)["run1"], rel=1e-6)
    assert new["run1"] == pytest.approx(clip_distance(q, _read("run1", rig), "sim", 3), rel=1e-5)

    # name filter and assets only
    s.name_filter = "walk*"
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    assert {r.name for r in bpy.context.window_manager.shapesig_results.results} == {"walk2", "walk3"}
    s.name_filter = ""
    bpy.data.actions["jump"].asset_mark()
    s.assets_only = True
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    assert [r.name for r in bpy.context.window_manager.shapesig_results.results] == ["jump"]
    s.catalog = "Nothing*"
    with pytest.raises(RuntimeError, match="library is empty"):
        bpy.ops.shapesig.rank()
    s.assets_only, s.catalog = False, ""

    # re-rank the best three by elastic distance: the head is ordered by it
    s.rerank, s.top = 3, 3
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    assert len(bpy.context.window_manager.shapesig_results.results) == 3 and all(r.has_elastic for r in bpy.context.window_manager.shapesig_results.results)
    el = [r.elastic for r in bpy.context.window_manager.shapesig_results.results]
    assert el == sorted(el)
    best = bpy.context.window_manager.shapesig_results.results[0]
    # the index low-passes its 30 fps samples, clip_distance the curve at its own rate first: close, not equal
    # (entry.curve_from_increments); 24 fps actions here
    assert best.elastic == pytest.approx(clip_distance(q, _read(best.name, rig), "elastic"), rel=2e-3)


def test_find_similar_defaults_to_motion_and_pose(rig):
    """The default click runs the local search: the rows are the core's ``rank_clips`` (metric local) of the same
    clips read as the library reads them, sorted by its score; a second click computes nothing."""
    s = bpy.context.scene.shapesig
    assert s.similarity == "local"
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    res = bpy.context.window_manager.shapesig_results
    got = [(r.name, r.distance) for r in res.results]
    assert res.order_by == "local" and [n for n, _ in got][:2] in (["walk2", "walk3"], ["walk3", "walk2"])
    q = _read("walk1", rig)
    truth = search.rank_clips(q, [_read(n, rig) for n, _ in got])  # the default metric
    assert [(r.name, pytest.approx(r.distance, rel=1e-5)) for r in truth] == got
    assert res.query_bones == len(q.bones)  # from the query's stored entry, as read
    cache = _cache()
    before = dict(cache.stats)
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    assert cache.stats["misses"] == before["misses"] and _results() == got and res.query_bones == len(q.bones)


def test_build_index_runs_synchronously_and_rebuilds_corrupt_files(rig, cache_env):
    s = bpy.context.scene.shapesig
    assert bpy.ops.shapesig.build_index("INVOKE_DEFAULT") == {"FINISHED"}
    assert "6 computed" in bpy.context.window_manager.shapesig_results.message and not s.index_running
    files = sorted(p for p in (cache_env / search.CACHE_SUBDIR).iterdir() if p.suffix == ".npz")
    assert len(files) == 12  # each clip: its signature entry and its local-search entry
    assert bpy.ops.shapesig.build_index() == {"FINISHED"}
    assert "0 computed" in bpy.context.window_manager.shapesig_results.message
    # corrupt one entry file on disk, and forget the session's memory layer: it is detected and rebuilt
    files[0].write_bytes(b"garbage")
    from blender_shapesig.search import library

    library.CACHES.clear()
    assert bpy.ops.shapesig.build_index() == {"FINISHED"}
    assert "1 computed" in bpy.context.window_manager.shapesig_results.message
    assert _cache().stats["invalid"] == 1
    assert np.load(files[0])["meta"].size


def test_folder_library(empty_file, cache_env):
    arm = import_bvh("07_01.bvh", "walk1", fake_user=True)
    s = bpy.context.scene.shapesig
    s.use_file_actions, s.use_folders, s.folders, s.crop_start = False, True, str(BVH), 2
    s.similarity = "sim"  # the query's own file at sim 0 (the local search's float16 windows: about 5e-4)
    s.fps = 120.0  # Blender's BVH importer records no rate: the action is read at the files' (Frame Time 1/120 s)
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    names = [r.name for r in bpy.context.window_manager.shapesig_results.results]
    assert len(names) == 6 and all(not r.is_action for r in bpy.context.window_manager.shapesig_results.results)
    assert names[0] == "07_01" and bpy.context.window_manager.shapesig_results.results[0].distance < 1e-5  # the query's own file
    assert {LABEL[n] for n in names[:3]} == {"walk"}
    assert all(r.source.endswith(".bvh") for r in bpy.context.window_manager.shapesig_results.results)
    cache = _cache()
    before = dict(cache.stats)
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    assert cache.stats["misses"] == before["misses"]
    # assign a folder result: written as a new action on the armature, then usable by Blend
    bpy.context.window_manager.shapesig_results.results_index = 1
    n_actions = len(bpy.data.actions)
    assert bpy.ops.shapesig.assign_result() == {"FINISHED"}
    assert len(bpy.data.actions) == n_actions + 1
    assert arm.animation_data.action.name.startswith(names[1])
    assert bpy.context.window_manager.shapesig_results.results[1].is_action


def test_assign_preview_and_blend(rig):
    s = bpy.context.scene.shapesig
    bpy.ops.shapesig.rank()
    bpy.context.window_manager.shapesig_results.results_index = 2
    target = bpy.context.window_manager.shapesig_results.results[2].name
    assert bpy.ops.shapesig.preview_result() == {"FINISHED"}
    assert rig.animation_data.action.name == target and s.preview_object == rig.name
    assert bpy.ops.shapesig.preview_result() == {"FINISHED"}  # again: stop and restore
    assert rig.animation_data.action.name == "walk1" and not s.preview_object
    assert bpy.ops.shapesig.assign_result() == {"FINISHED"}
    assert rig.animation_data.action.name == target
    compat.assign_action(rig, bpy.data.actions["walk1"])
    n = len(bpy.data.actions)
    assert bpy.ops.shapesig.blend_actions(action_a=bpy.context.window_manager.shapesig_results.query_name, action_b=bpy.context.window_manager.shapesig_results.results[0].source, weight=0.5,
                                          assign=False) == {"FINISHED"}
    assert len(bpy.data.actions) == n + 1


def test_errors_are_clear(empty_file, cache_env):
    with pytest.raises(RuntimeError, match="select an armature"):
        bpy.ops.shapesig.rank()
    with pytest.raises(RuntimeError, match="select an armature"):
        bpy.ops.shapesig.build_index()
    with pytest.raises(RuntimeError, match="select an armature"):
        bpy.ops.shapesig.assign_result()
    arm = import_bvh("09_02.bvh", "only", fake_user=True)
    with pytest.raises(RuntimeError, match="no results"):
        bpy.ops.shapesig.assign_result()
    with pytest.raises(RuntimeError, match="no results"):
        bpy.ops.shapesig.preview_result()
    with pytest.raises(RuntimeError, match="library is empty"):
        bpy.ops.shapesig.rank()
    s = bpy.context.scene.shapesig
    s.query_action = "missing"
    with pytest.raises(RuntimeError, match="no action 'missing'"):
        bpy.ops.shapesig.rank()
    s.query_action = ""
    s.use_file_actions, s.use_folders, s.folders = False, True, str(cache_env / "nowhere")
    with pytest.raises(RuntimeError, match="does not exist"):
        bpy.ops.shapesig.rank()
    arm.animation_data.action = None
    with pytest.raises(RuntimeError, match="has no action"):
        bpy.ops.shapesig.rank()


# ------------------------------------------------------------------------------------ panel drawing

def test_panel_draws_every_state(rig):
    from blender_shapesig.panels.search import SHAPESIG_UL_results

    bpy.context.view_layer.objects.active = None
    assert "Select an armature" in draw_search_panel().labels()
    bpy.context.view_layer.objects.active = rig
    lay = draw_search_panel()
    assert "No results yet" in lay.labels() and {"shapesig.build_index", "shapesig.rank"} <= set(lay.operators())
    s = bpy.context.scene.shapesig
    s.use_file_actions = False
    assert "library is empty" in draw_search_panel().labels()
    s.use_file_actions = True
    s.index_running, s.index_progress = True, 0.5
    assert "Indexing 50%" in str(draw_search_panel().log)
    s.index_running = False
    bpy.ops.shapesig.rank()
    lay = draw_search_panel()
    assert any(e[0] == "template_list" for e in lay.log)
    assert {"shapesig.assign_result", "shapesig.preview_result", "shapesig.blend_actions"} <= set(lay.operators())
    i = lay.operators().index("shapesig.blend_actions")
    props = [e[1] for e in lay.log if e[0] == "props"][i]
    assert (props.action_a, props.action_b) == ("walk1", bpy.context.window_manager.shapesig_results.results[0].source)
    row = FakeLayout()
    SHAPESIG_UL_results.draw_item(SimpleNamespace(layout_type="DEFAULT"), bpy.context, row, s, bpy.context.window_manager.shapesig_results.results[0], 0, s,
                                  "results_index")
    assert bpy.context.window_manager.shapesig_results.results[0].name in row.labels() and f"{bpy.context.window_manager.shapesig_results.results[0].distance:.4f}" in row.labels()
    bpy.context.window_manager.shapesig_results.results_index = 99
    assert "Select a result" in draw_search_panel().labels()
    s.query_action = "nope"
    assert "no action 'nope'" in draw_search_panel().labels()


def test_build_index_modal_steps_and_escape(rig):
    """The modal path (a window is needed to start it for real): its timer steps and Esc, driven directly
    on a stand-in instance that borrows the operator's methods."""
    from blender_shapesig.operators.search import SHAPESIG_OT_build_index as Op

    ctx = bpy.context
    s = ctx.scene.shapesig
    op = stand_in(Op)
    op._start(ctx)
    s.index_running = True
    timer = SimpleNamespace(type="TIMER")
    assert op.modal(ctx, SimpleNamespace(type="MOUSEMOVE")) == {"PASS_THROUGH"}
    assert op.modal(ctx, timer) == {"RUNNING_MODAL"}
    assert op.modal(ctx, timer) == {"RUNNING_MODAL"}
    assert s.index_progress == pytest.approx(2 / 6)
    assert op.modal(ctx, SimpleNamespace(type="ESC")) == {"CANCELLED"}
    assert not s.index_running and bpy.context.window_manager.shapesig_results.message.startswith("cancelled; index: 2 of 6")
    assert op.reports[-1][0] == {"WARNING"}
    # what was done stays indexed: a second, complete run computes only the other four, then ranks
    from blender_shapesig.search.library import missing_count

    assert missing_count(ctx, s) == 4
    op = stand_in(Op)
    op.then_rank = True
    op._start(ctx)
    while (res := op.modal(ctx, timer)) == {"RUNNING_MODAL"}:
        pass
    assert res == {"FINISHED"} and s.index_progress == 1.0
    assert [r for r in op.reports if "4 computed, 2 already indexed" in r[1]]
    assert missing_count(ctx, s) == 0
    assert len(bpy.context.window_manager.shapesig_results.results) == 5 and bpy.context.window_manager.shapesig_results.query_name == "walk1"  # ranked when the index was complete


def test_actions_of_another_rig_are_read_with_it_and_mapped(rig):
    """An ASF/AMC walk on its own armature shares almost no bone names with the BVH rig: read with its own armature
    (not the query's, which would make its unkeyed BVH bones look like rest poses) and mapped onto the canonical
    joints (core.rigs), it is compared on all of them (coverage 1, not a partial match) and ranks among the walks,
    before the runs and the jump (before, it was a second-tier match on the one shared bone)."""
    acc = BVH.parent / "acclaim"
    bpy.ops.shapesig.import_acclaim(filepath=str(acc / "07_02.amc"), asf_path=str(acc / "07-walk.asf"))
    amc_rig = bpy.context.view_layer.objects.active
    amc_action = amc_rig.animation_data.action.name
    bpy.context.view_layer.objects.active = rig
    s = bpy.context.scene.shapesig
    s.rerank, s.top = 10, 0
    for similarity in ("local", "sim"):  # the default search and the signature search
        s.similarity = similarity
        assert bpy.ops.shapesig.rank() == {"FINISHED"}
        rows = bpy.context.window_manager.shapesig_results.results
        names = [r.name for r in rows]
        assert len(names) == 6 and not any(r.partial for r in rows), names
        assert names.index(amc_action) < min(names.index(n) for n in ("run1", "run2", "jump")), names
        assert "shares only" not in bpy.context.window_manager.shapesig_results.message
    row = rows[names.index(amc_action)]
    assert row.shared == rows[0].shared >= 19  # sim: the canonical joints both rigs have
    from blender_shapesig.search.library import owner_armature

    assert owner_armature(bpy.data.actions[amc_action], rig) == amc_rig
    assert owner_armature(bpy.data.actions["walk2"], rig) == rig  # no armature plays it: the query's


def test_query_with_only_location_keys_is_a_clear_error(rig):
    """A query action that keys no rotation has no curve in SO(3)^d: one clear message, nothing ranked."""
    act = bpy.data.actions.new("slide")
    bag, _slot = compat.ensure_channelbag(act, "OBJECT", name=rig.name)
    fc = compat.new_fcurve(bag, 'pose.bones["hip"].location', 0, "hip")
    fc.keyframe_points.add(3)
    fc.keyframe_points.foreach_set("co", np.array([1, 0, 2, 1, 3, 0], dtype=np.float32))
    compat.assign_action(rig, act)
    s = bpy.context.scene.shapesig
    with pytest.raises(RuntimeError, match="no rotation channels"):
        bpy.ops.shapesig.rank()
    assert len(bpy.context.window_manager.shapesig_results.results) == 0


def test_action_items_have_typed_keys_and_poll_owns_preconditions(rig):
    """An action's cache key is the text of its ActionKey (hash, armature digest, frame range); a result is an
    action because its item is an ActionItem. Preconditions are refused by poll, with the reason."""
    from blender_shapesig.search import library

    s = bpy.context.scene.shapesig
    _obj, action, q = library.query_item(bpy.context, s)
    last = int(round(action.frame_range[1]))
    assert isinstance(q, library.ActionItem) and q.key == q.action_key.text and q.action == "walk1"
    assert (q.action_key.read_hash, q.action_key.frame_range) == (action_io.read_hash(action), (2, last))
    assert q.action_key.armature_digest == library.armature_digest(rig)
    assert bpy.ops.shapesig.rank.poll() and not bpy.ops.shapesig.assign_result.poll()
    assert library.result_problem(bpy.context, s) == "no results: run Find Similar first"
    s.use_frame_range, s.frame_start, s.frame_end = True, 10, 10
    assert not bpy.ops.shapesig.rank.poll() and not bpy.ops.shapesig.build_index.poll()
    with pytest.raises(RuntimeError, match="must end after it starts"):
        bpy.ops.shapesig.rank()
    s.use_frame_range = False
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    assert bpy.ops.shapesig.assign_result.poll() and bpy.context.window_manager.shapesig_results.results[0].is_action


def _stored_kinds(folder):
    """{"local": n, "signature": n} of the entry files of a store's folder (their meta: a local entry names its
    feature settings, a signature entry its level)."""
    import json
    from collections import Counter

    kinds = Counter()
    for name in os.listdir(folder):
        if name.endswith(".npz"):
            with np.load(os.path.join(folder, name), allow_pickle=False) as z:
                meta = json.loads(bytes(z["meta"]).decode("utf-8"))
            kinds["local" if "settings" in meta else "signature" if "level" in meta else "other"] += 1
    return dict(kinds)


def test_find_similar_stores_what_the_command_lines_rank_stores(empty_file, cache_env, tmp_path):
    """The default search (Motion and pose) indexes a folder as ``rank`` on the command line does: the local
    search's entries of every clip and no signature entry (the panel used to store both); the panel's one more
    entry is its query action's."""
    import subprocess
    import sys

    folder = tmp_path / "lib"
    folder.mkdir()
    for name in ("07_01", "07_02", "09_02"):
        (folder / f"{name}.bvh").write_bytes((BVH / f"{name}.bvh").read_bytes())
    import_bvh("08_01.bvh", "walk3", fake_user=True)
    s = bpy.context.scene.shapesig
    s.use_file_actions, s.use_folders, s.folders, s.fps = False, True, str(folder), 120.0
    assert s.similarity == "local"
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    panel = _stored_kinds(_cache().path)
    cli_cache = tmp_path / "cli_index"
    root = pathlib.Path(__file__).resolve().parents[3]
    run = subprocess.run([sys.executable, "-m", "blender_shapesig", "rank", str(folder / "07_01.bvh"), str(folder),
                          "--json"], capture_output=True, text=True, cwd=root, timeout=600,
                         env=dict(os.environ, **{search.CACHE_ENV: str(cli_cache)}))
    assert run.returncode == 0, run.stderr
    cli = _stored_kinds(next(p for p in cli_cache.iterdir() if p.is_dir()))
    assert cli == {"local": 3}
    assert panel == {"local": 4}
