"""Animator-safe operators on real CMU clips (BVH walks 07_01, 07_02, run 09_02, jump 13_32; the
Acclaim walks): no action is ever lost (Assign, Preview/Stop, blends; save -> reopen in a fresh process keeps
every pre-existing action bit-identical), Stop restores exactly, values out of range are refused (one-line
error, file unchanged), the results list is readable (one sort column named in its header, unique labels,
honest counts), a level-4 cost estimate, the AMC skeleton field, and the Find Similar click (no UNDO push,
results on the window manager, progress + Esc, its measured time in the panel)."""

import math
import os
import pathlib
import shutil
import time
from types import SimpleNamespace

import pytest

bpy = pytest.importorskip("bpy")

from blender_shapesig import compat  # noqa: E402
from blender_shapesig.search import library, results  # noqa: E402
from blender_shapesig.core import search as index
from blender_shapesig.core.io import sources  # noqa: E402
from blender_shapesig.core.errors import MAX_INBETWEENS  # noqa: E402
from tests.helpers.stand_in import stand_in  # noqa: E402
from tests.helpers.blender_clips import buffer_hash, import_bvh, reopen_hashes  # noqa: E402
from tests.helpers.fake_layout import FakeLayout, draw_search_panel  # noqa: E402
from tests.helpers.operator_scene import cache_env, operator_error, rig  # noqa: E402,F401 - fixtures

DATA = pathlib.Path(__file__).resolve().parents[2] / "data"
BVH, ACC = DATA / "bvh", DATA / "acclaim"


def _hashes():
    return {a.name: buffer_hash(a) for a in bpy.data.actions}


def _state(obj):
    """Everything Stop must give back: action, slot, rotation modes, frame, the users / fake user of every
    action, the NLA, and the actions that exist."""
    ad = obj.animation_data
    slot = compat.object_action_slot(obj)
    return {"action": ad.action.name if ad and ad.action else None,
            "slot": getattr(slot, "identifier", None),
            "modes": {pb.name: pb.rotation_mode for pb in obj.pose.bones},
            "frame": bpy.context.scene.frame_current,
            "actions": {a.name: (a.users, a.use_fake_user) for a in bpy.data.actions},
            "nla": [(t.name, [s.action.name for s in t.strips]) for t in ad.nla_tracks] if ad else []}


# ----------------------------------------------------------------------------- never lose an action

def test_preview_and_stop_of_a_file_action_restore_exactly(rig):
    s = bpy.context.scene.shapesig
    s.rerank = 0
    bpy.context.scene.frame_set(17)
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    bpy.context.window_manager.shapesig_results.results_index = [r.name for r in bpy.context.window_manager.shapesig_results.results].index("jump")
    before, hashes = _state(rig), _hashes()
    assert bpy.ops.shapesig.preview_result() == {"FINISHED"}
    assert rig.animation_data.action.name == "jump" and s.preview_object == rig.name
    assert library.query_item(bpy.context, s)[1].name == "walk"  # the query stays the previewed-over action
    # the previous action is kept alive while previewing (a save now would keep it)
    assert bpy.data.actions["walk"].use_fake_user and bpy.data.actions["walk"].users >= 1
    assert bpy.ops.shapesig.preview_result() == {"FINISHED"}  # Stop
    assert _state(rig) == before and _hashes() == hashes
    assert not s.preview_object and not s.preview_written


def test_preview_of_a_folder_result_leaves_nothing_after_stop(rig):
    s = bpy.context.scene.shapesig
    s.use_file_actions, s.use_folders, s.folders, s.rerank = False, True, str(BVH), 0
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    i = [r.name for r in bpy.context.window_manager.shapesig_results.results].index("09_03")
    bpy.context.window_manager.shapesig_results.results_index = i
    before, n = _state(rig), len(bpy.data.actions)
    assert bpy.ops.shapesig.preview_result() == {"FINISHED"}
    assert len(bpy.data.actions) == n + 1 and rig.animation_data.action.name.startswith("09_03")
    assert s.preview_written == rig.animation_data.action.name
    assert bpy.ops.shapesig.preview_result(stop=True) == {"FINISHED"}
    assert _state(rig) == before  # no leftover action, same action, slot, modes, frame
    row = bpy.context.window_manager.shapesig_results.results[i]
    assert not row.is_action and row.source == row.spec and row.spec.endswith("09_03.bvh")
    # a row whose written action disappeared (e.g. undone) reads its file again
    row.is_action, row.source = True, "gone"
    assert results.result_action(s, rig, row).name.startswith("09_03")
    compat.remove_action(bpy.data.actions[row.source])
    row.is_action, row.source = False, row.spec
    # preview, then Assign the previewed folder result: it is kept (assigned), the walk is stashed
    assert bpy.ops.shapesig.preview_result() == {"FINISHED"}
    written = s.preview_written
    assert bpy.ops.shapesig.assign_result() == {"FINISHED"}
    assert not s.preview_object and rig.animation_data.action.name == written
    assert not bpy.data.actions["walk"].use_fake_user  # the preview's fake user was taken back ...
    stash = [st.action.name for t in rig.animation_data.nla_tracks for st in t.strips]
    assert stash == ["walk"]  # ... and the assign stashed it instead


def test_assign_preview_stop_and_blends_survive_save_and_reopen(rig, tmp_path):
    s = bpy.context.scene.shapesig
    s.rerank = 0
    before = _hashes()
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    bpy.context.window_manager.shapesig_results.results_index = [r.name for r in bpy.context.window_manager.shapesig_results.results].index("run")
    assert bpy.ops.shapesig.preview_result() == {"FINISHED"}
    mid = tmp_path / "during_preview.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(mid), copy=True)
    assert bpy.ops.shapesig.preview_result() == {"FINISHED"}
    bpy.context.window_manager.shapesig_results.results_index = [r.name for r in bpy.context.window_manager.shapesig_results.results].index("walk2")
    assert bpy.ops.shapesig.assign_result() == {"FINISHED"}  # walk (its only user was the rig) is stashed
    assert bpy.ops.shapesig.blend_actions("EXEC_DEFAULT", action_a="walk2", action_b="run", weight=0.25,
                                          align=False, assign=True) == {"FINISHED"}
    assert bpy.ops.shapesig.blend_actions("EXEC_DEFAULT", action_a="walk2", action_b="jump", inbetweens=2,
                                          align=False, assign=True) == {"FINISHED"}
    path = tmp_path / "after.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    for saved in (mid, path):
        after = reopen_hashes(saved)
        for name, digest in before.items():
            assert after.get(name) == digest, (saved.name, name)
    assert len(reopen_hashes(path)) == len(before) + 3


# --------------------------------------------------------------------------------- refuse bad values

@pytest.mark.parametrize("kw, needle", [
    ({"weight": 5.0}, "weight"), ({"weight": -3.0}, "weight"), ({"weight": 1e30}, "weight"),
    ({"weight": math.inf}, "weight"), ({"weight": math.nan}, "weight"),
    ({"inbetweens": 500}, f"in-betweens: expected an integer in 1..{MAX_INBETWEENS}, got 500"),
    ({"inbetweens": MAX_INBETWEENS + 1}, f"1..{MAX_INBETWEENS}"),
    ({"inbetweens": 0}, "in-betweens"), ({"depth": 0}, "timing freedom"), ({"frames": 1}, "length"),
])
def test_blend_refuses_out_of_range_values_and_changes_nothing(rig, kw, needle):
    before, state = _hashes(), _state(rig)
    msg = operator_error(bpy.ops.shapesig.blend_actions, action_a="walk", action_b="run", align=False, **kw)
    assert needle in msg, msg
    assert _hashes() == before and _state(rig) == state


def test_blend_properties_have_soft_not_hard_limits(addon):
    props = bpy.ops.shapesig.blend_actions.get_rna_type().properties
    w, k = props["weight"], props["inbetweens"]
    assert (w.soft_min, w.soft_max) == (0.0, 1.0) and w.hard_max > 1e30 and w.hard_min < -1e30
    assert k.soft_max == MAX_INBETWEENS and k.hard_max > 10 ** 6


@pytest.mark.parametrize("prop, value, needle", [
    ("level", 7, "detail: expected an integer in 1..4, got 7"), ("level", 0, "detail"),
    ("rerank", -5, "timing check: expected an integer >= 0"), ("top", -1, "show"), ("depth", 0, "timing freedom"),
    ("crop_start", -2, "crop start"),
])
def test_search_settings_out_of_range_are_refused_not_clamped(rig, prop, value, needle):
    s = bpy.context.scene.shapesig
    setattr(s, prop, value)
    assert getattr(s, prop) == value  # soft limits: the value is kept as given ...
    assert not bpy.ops.shapesig.rank.poll()  # ... and refused, with the reason
    assert needle in operator_error(bpy.ops.shapesig.rank) and needle in operator_error(bpy.ops.shapesig.build_index)
    assert len(bpy.context.window_manager.shapesig_results.results) == 0


def test_frame_range_is_checked_inside_the_action(rig):
    s = bpy.context.scene.shapesig
    walk = bpy.data.actions["walk"]
    first, last = (int(round(v)) for v in walk.frame_range)
    s.use_frame_range = True  # 0..0 by default: the action's own range, not 1..250
    assert (s.frame_start, s.frame_end) == (0, 0)
    assert library._query_range(walk, s) == (first, last)
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    rows = [(r.name, r.distance) for r in bpy.context.window_manager.shapesig_results.results]
    hashes = _hashes()
    s.frame_start, s.frame_end = 2000, 2100
    assert not bpy.ops.shapesig.rank.poll() and not bpy.ops.shapesig.build_index.poll()
    msg = operator_error(bpy.ops.shapesig.rank)
    assert f"2000..2100 is outside action 'walk''s frames {first}..{last}" in msg
    s.frame_start, s.frame_end = first, last + 1
    assert "outside" in operator_error(bpy.ops.shapesig.build_index)
    assert "outside" in draw_search_panel().labels()  # the panel says why
    assert [(r.name, r.distance) for r in bpy.context.window_manager.shapesig_results.results] == rows and _hashes() == hashes
    s.frame_start, s.frame_end = first + 10, first + 60
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    _obj, _act, q = library.query_item(bpy.context, s)
    assert q.action_key.frame_range == (first + 10, first + 60)


# --------------------------------------------------------------------------------- readable results

def test_rows_follow_one_named_sort_column(rig):
    s = bpy.context.scene.shapesig
    res = library.results_of(bpy.context)
    s.rerank, s.top = 0, 0
    assert bpy.ops.shapesig.rank() == {"FINISHED"}  # the default, Similarity: Motion and pose
    scores = [r.distance for r in bpy.context.window_manager.shapesig_results.results]
    assert res.order_by == "local" and scores == sorted(scores) and "sorted by score" in res.message
    assert "Score \u25b2" in draw_search_panel().labels()
    s.similarity = "sim"
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    sims = [r.distance for r in bpy.context.window_manager.shapesig_results.results]
    assert res.order_by == "sim" and sims == sorted(sims) and "sorted by similarity;" in res.message
    # Show lists as many as it says: the re-ranked first, then the next by sim^3
    s.rerank, s.top = 2, 0
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    rows = bpy.context.window_manager.shapesig_results.results
    assert len(rows) == 3 and [r.has_elastic for r in rows] == [True, True, False]
    s.rerank, s.top = 2, 2
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    assert res.order_by == "elastic" and "sorted by timing-aligned difference;" in res.message
    assert ("the best 2 by similarity re-ranked by timing-aligned difference; 1 more not listed (raise Show)"
            in res.message)
    el = [r.elastic for r in bpy.context.window_manager.shapesig_results.results]
    assert len(el) == 2 and all(r.has_elastic for r in bpy.context.window_manager.shapesig_results.results) and el == sorted(el)
    # the same d_S* and order as the core's own re-rank of the best two
    _obj, _act, q = library.query_item(bpy.context, s)
    items = [it for it in library.library_items(bpy.context, s, rig) if it.key != q.key]
    core = index.rank_clips(q, items, rerank=2, top=2, cache=library.get_cache(bpy.context), metric="sim")
    # (the rows keep float32)
    assert [(r.name, pytest.approx(r.elastic, rel=1e-6)) for r in core] == [(r.name, r.elastic) for r in bpy.context.window_manager.shapesig_results.results]
    lay = draw_search_panel()
    assert "Timing-aligned \u25b2" in lay.labels() and "sorted by timing-aligned" in lay.labels()


def test_labels_are_unique_and_counts_honest(empty_file, cache_env, tmp_path):
    arm = import_bvh("07_01.bvh", "walk")
    lib = tmp_path / "lib"
    for sub in ("a", "b"):
        (lib / sub).mkdir(parents=True)
        shutil.copy(ACC / "16_15.bvh", lib / sub / "16_15.bvh")
        stamp = 10 ** 18 + len(sub) + ord(sub)  # two copies, two keys
        os.utime(lib / sub / "16_15.bvh", ns=(stamp, stamp))
    shutil.copy(BVH / "07_02.bvh", lib / "07_02.bvh")
    (lib / "broken.bvh").write_text("HIERARCHY\nROOT hip\n{\n")  # fails to read
    s = bpy.context.scene.shapesig
    s.use_file_actions, s.use_folders, s.folders, s.rerank, s.crop_start = False, True, str(lib), 0, 2
    bpy.context.view_layer.objects.active = arm
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    labels = sorted(r.label for r in bpy.context.window_manager.shapesig_results.results)
    assert labels == ["07_02.bvh", "a/16_15.bvh", "b/16_15.bvh"]
    msg = library.results_of(bpy.context).message
    # the query + 3 readable files were indexed; the broken one is counted apart, not as indexed
    assert "4 newly indexed, 1 could not be read" in msg and "broken" in msg
    row = next(r for r in bpy.context.window_manager.shapesig_results.results if r.label == "07_02.bvh")
    assert row.coverage == pytest.approx(1.0) and row.shared == library.results_of().query_bones
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    assert "0 newly indexed, 1 could not be read" in library.results_of().message
    library.CACHES.clear()
    shutil.rmtree(cache_env)
    assert bpy.ops.shapesig.build_index() == {"FINISHED"}
    assert "index: 5 of 5 clips, 4 computed, 0 already indexed; 1 could not be read" in bpy.context.window_manager.shapesig_results.message
    assert sources.unique_labels(["/x/a/w.blend#run", "/x/b/w.blend#run", "/x/c.bvh"]) == \
        ["a/w.blend#run", "b/w.blend#run", "c.bvh"]


# -------------------------------------------------------------------------------- the rank click

def test_rank_click_pushes_no_undo_and_keeps_results_on_the_window_manager(rig, tmp_path):
    assert "UNDO" not in bpy.types.SHAPESIG_OT_rank.bl_options
    s = bpy.context.scene.shapesig
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    wm = bpy.context.window_manager.shapesig_results
    assert len(wm.results) == len(bpy.context.window_manager.shapesig_results.results) > 0 and wm.results[0].name == bpy.context.window_manager.shapesig_results.results[0].name
    assert "results" not in s.bl_rna.properties  # nothing of them in the scene, so nothing in undo steps
    # the scene does not change: a click leaves no difference an undo step would have to record
    path = tmp_path / "a.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path), copy=True)
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    path2 = tmp_path / "b.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path2), copy=True)
    assert reopen_hashes(path) == reopen_hashes(path2)


def test_rank_modal_progress_escape_and_measured_time(rig):
    """The modal path, stepped on a stand-in that borrows the operator's methods (a window is needed to start
    it for real): progress grows, Esc cancels keeping what was indexed, a full run stores rows and the time
    of the whole click (from its start, not only the ranking)."""
    from blender_shapesig.operators.search import SHAPESIG_OT_rank as Op

    def stand():
        return stand_in(Op)

    ctx = bpy.context
    res = library.results_of(ctx)
    timer = SimpleNamespace(type="TIMER")
    op = stand()
    op.t0 = time.perf_counter()
    op._start(ctx)
    # the library, the query and no d_S* step (the local search re-scores its shortlist inside the ranking)
    assert op.job.total == 4 + 1 and op.modal(ctx, SimpleNamespace(type="MOUSEMOVE")) == {"PASS_THROUGH"}
    op.job.step()
    assert 0 < op.job.progress < 1 and op.job.indexed == 1
    assert op.modal(ctx, SimpleNamespace(type="ESC")) == {"CANCELLED"}
    assert "cancelled" in res.message and op.reports[-1][0] == {"WARNING"}
    assert len(res.results) == 0  # nothing ranked
    assert library.missing_count(ctx, ctx.scene.shapesig) == 3  # the one indexed clip stays indexed
    op = stand()
    op.t0 = time.perf_counter() - 5.0  # a click that started 5 s ago
    op._start(ctx)
    seen = []
    while (got := op.modal(ctx, timer)) == {"RUNNING_MODAL"}:
        seen.append(op.job.progress)
    assert got == {"FINISHED"} and seen == sorted(seen) and len(res.results) == 3
    assert res.seconds >= 5.0 and f"{res.seconds:.2f} s" in res.message
    assert f"click took {res.seconds:.2f} s" in draw_search_panel().labels()


# --------------------------------------------------------------------------- cost and skeleton field

def test_level_four_cost_estimate_and_confirmation(rig, monkeypatch):
    from blender_shapesig.core.signatures.signatures import log_signature_dim
    from blender_shapesig.operators import search as ops

    s = bpy.context.scene.shapesig
    s.level = 4
    assert "costly" not in draw_search_panel().labels()  # the local search (the default) indexes at the default level
    s.similarity = "sim"
    clips, seconds, nbytes = library.index_cost(bpy.context, s)
    _o, _a, q = library.query_item(bpy.context, s)
    clip = q.clips()[0]
    moving = len(clip.bones) - len(clip.still_bones())
    ref = library.COST_REFERENCE
    per = log_signature_dim(3 * moving, 4) / log_signature_dim(3 * ref["moving"], 4) / ref["clips"]
    assert clips == 4 and seconds == pytest.approx(4 * ref["seconds"] * per)
    assert nbytes == pytest.approx(4 * ref["bytes"] * per) and nbytes > 4 * 4 * log_signature_dim(3 * moving, 4) * 0.9
    assert "costly" in draw_search_panel().labels()
    # in the UI, the click asks first with the estimate (OK runs it again, confirmed)
    asked = []
    fake_wm = SimpleNamespace(invoke_confirm=lambda op, event, **kw: asked.append(kw) or {"RUNNING_MODAL"})
    ctx = SimpleNamespace(window=object(), window_manager=fake_wm, scene=bpy.context.scene,
                          active_object=rig, preferences=bpy.context.preferences)
    monkeypatch.setattr(ops, "bpy", SimpleNamespace(app=SimpleNamespace(background=False)))
    op = SimpleNamespace(confirmed=False, bl_label="Find Similar")
    assert ops._confirm_cost(op, ctx, None, s) == {"RUNNING_MODAL"} and op.confirmed
    assert asked and library.cost_text(clips, seconds, nbytes) in asked[0]["message"]
    s.level = 3
    assert ops._confirm_cost(SimpleNamespace(confirmed=False, bl_label="x"), ctx, None, s) is None


def test_skeleton_field_for_amc_folders_shares_keys_with_the_cli(empty_file, cache_env, tmp_path):
    lib = tmp_path / "amc"
    lib.mkdir()
    for f in ("07_02.amc", "09_02.amc", "07-walk.asf", "09-run.asf"):  # two skeletons: ambiguous without one
        shutil.copy(ACC / f, lib / f)
    bpy.ops.shapesig.import_acclaim(filepath=str(ACC / "07_01.amc"), asf_path=str(ACC / "07-walk.asf"))
    s = bpy.context.scene.shapesig
    s.use_file_actions, s.use_folders, s.folders, s.rerank = False, True, str(lib), 0
    assert bpy.ops.shapesig.rank.poll()
    with pytest.raises(RuntimeError, match="2 .asf files beside the .amc"):
        bpy.ops.shapesig.rank()
    s.asf = str(lib / "07-walk.asf")
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    assert sorted(r.name for r in bpy.context.window_manager.shapesig_results.results) == ["07_02", "09_02"]
    items = library.library_items(bpy.context, s, bpy.context.active_object)
    spec = sources.ClipSpec.parse(str(lib / "07_02.amc"), asf=str(lib / "07-walk.asf"))
    assert spec.key() in {it.key for it in items}
    s.asf = str(lib / "missing.asf")
    with pytest.raises(RuntimeError, match="missing.asf does not exist"):
        bpy.ops.shapesig.rank()
    labels = FakeLayout()
    from blender_shapesig.panels.search import _draw_library

    _draw_library(labels, s)
    assert any(e[0] == "prop" and e[1][1] == "asf" for e in labels.log)


def test_results_views_on_the_settings_are_the_window_managers(rig):
    s = bpy.context.scene.shapesig
    res = library.results_of(bpy.context)
    bpy.context.window_manager.shapesig_results.message = "x"
    bpy.context.window_manager.shapesig_results.results_index = 3
    assert res.message == "x" and res.results_index == 3
    bpy.context.window_manager.shapesig_results.query_name = "q"
    assert res.query_name == "q"
