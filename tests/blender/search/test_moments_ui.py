"""Moments and "Why different" in Blender on real CMU clips: with the panel's Moments toggle, a re-timed
excerpt of the 16_15 walk (a 471-frame take, imported with Blender's BVH importer) is found in its take with the
right window; Assign, Preview and Blend use the window; the explanation is stored on the row and drawn (bars and
a strip); Why Different explains a whole-clip result."""

import json

import pytest

bpy = pytest.importorskip("bpy")

from blender_shapesig import compat  # noqa: E402
from blender_shapesig.actions import action_io  # noqa: E402
from blender_shapesig.core import search as search  # noqa: E402
from blender_shapesig.core.search.moments.windows import retimed_excerpt  # noqa: E402
from tests.helpers.blender_clips import import_bvh  # noqa: E402
from tests.helpers.fake_layout import FakeLayout  # noqa: E402

FIRST, LAST, SPEED = 101, 340, 1.25


@pytest.fixture
def take(empty_file, monkeypatch, tmp_path):
    """The 16_15 armature with its take ('take'); the query 'query' is frames 101-340 of the take played 1.25x as
    fast, and 'other' its first half second played at half speed, both written as actions of the same armature
    (the query active)."""
    monkeypatch.setenv(search.CACHE_ENV, str(tmp_path / "index"))
    arm = import_bvh("../acclaim/16_15.bvh", "take", fake_user=True)  # tests/data/acclaim/16_15.bvh
    clip = action_io.read_action(bpy.data.actions["take"], armature=arm)
    query = action_io.write_action(retimed_excerpt(clip, FIRST, LAST, SPEED), armature=arm, name="query")
    query.use_fake_user = True
    other = action_io.write_action(retimed_excerpt(clip, 1, 60, 0.5), armature=arm, name="other")
    other.use_fake_user = True
    compat.assign_action(arm, query)
    bpy.context.view_layer.objects.active = arm
    arm.select_set(True)
    return arm


def _rows():
    return bpy.context.window_manager.shapesig_results.results


def _iou(a, b):
    inter = max(0, min(a[1], b[1]) - max(a[0], b[0]) + 1)
    return inter / (max(a[1], b[1]) - min(a[0], b[0]) + 1)


def test_moments_find_the_window_and_assign_preview_blend_use_it(take):
    s = bpy.context.scene.shapesig
    s.use_windows = True
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    best = _rows()[0]
    assert best.name == "take" and best.has_elastic
    assert _iou((best.frame_first, best.frame_last), (FIRST, LAST)) >= 0.5
    ex = json.loads(best.explain)
    assert sum(ex["joints"].values()) == pytest.approx(1.0) and ex["cost_over_time"]
    # Preview plays the window (an action written for it, removed at Stop)
    n = len(bpy.data.actions)
    assert bpy.ops.shapesig.preview_result() == {"FINISHED"}
    playing = take.animation_data.action
    assert playing.name.startswith("take[") and tuple(round(v) for v in playing.frame_range) == (
        best.frame_first, best.frame_last)
    assert bpy.ops.shapesig.preview_result() == {"FINISHED"}
    assert take.animation_data.action.name == "query" and len(bpy.data.actions) == n and not best.window_action
    # Assign keeps the window action; Blend uses it
    assert bpy.ops.shapesig.assign_result() == {"FINISHED"}
    assigned = take.animation_data.action
    assert assigned.name == _rows()[0].window_action and bpy.data.actions["take"].users >= 1
    from blender_shapesig.panels.search import SHAPESIG_PT_search_view3d

    lay = FakeLayout()
    SHAPESIG_PT_search_view3d.draw(type("P", (), {"layout": lay})(), bpy.context)
    i = lay.operators().index("shapesig.blend_actions")
    props = [e[1] for e in lay.log if e[0] == "props"][i]
    assert props.action_b == assigned.name
    assert "Why different" in lay.labels() and sum(e[0] == "progress" for e in lay.log) >= 5
    compat.assign_action(take, bpy.data.actions["query"])
    assert bpy.ops.shapesig.blend_actions(action_a="query", action_b=assigned.name, weight=0.5,
                                          assign=False) == {"FINISHED"}


def test_why_different_on_a_whole_clip_result(take):
    s = bpy.context.scene.shapesig
    s.use_windows, s.rerank = False, 2
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    row = _rows()[0]
    assert row.frame_last == 0 and not row.explain
    assert bpy.ops.shapesig.explain_result() == {"FINISHED"}
    ex = json.loads(_rows()[0].explain)
    assert sum(ex["joints"].values()) == pytest.approx(1.0) and len(ex["cost_over_time"]) > 10


def test_moments_with_a_one_frame_pose_in_the_file(take):
    """A pose-library-like action (one key per bone, one frame) beside the takes: Moments ranks the takes and names
    the pose once as skipped; no traceback."""
    clip = action_io.read_action(bpy.data.actions["take"], armature=take)
    pose = action_io.write_action(clip.crop(clip.frame_start + 30, clip.frame_start + 30), armature=take, name="pose")
    pose.use_fake_user = True
    s = bpy.context.scene.shapesig
    s.use_windows = True
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    names = [r.name for r in _rows()]
    assert names[0] == "take" and "pose" not in names
    assert "pose" in bpy.context.window_manager.shapesig_results.message


def test_why_different_resamples_a_long_take(take):
    """A 20,000-frame take (the 16_15 walk repeated) against a 12-frame query: the alignment needs steps the DP
    cannot take at the comparison rate (it refused before); Why Different resamples, explains (shares summing to
    1, the cost along the query summing to the energy) and says so in one line in the box and the report."""
    import dataclasses

    import numpy as np

    from blender_shapesig.panels.search import SHAPESIG_PT_search_view3d

    clip = action_io.read_action(bpy.data.actions["take"], armature=take)
    reps = -(-20000 // clip.frames)
    rt = None if clip.root_translation is None else np.concatenate([clip.root_translation] * reps)[:20000]
    long = dataclasses.replace(clip, rotations=np.concatenate([clip.rotations] * reps)[:20000], root_translation=rt)
    action_io.write_action(long, armature=take, name="long").use_fake_user = True
    short = action_io.write_action(clip.crop(clip.frame_start + 100, clip.frame_start + 111), armature=take,
                                   name="short")
    short.use_fake_user = True
    compat.assign_action(take, short)
    s = bpy.context.scene.shapesig
    s.use_windows, s.rerank = False, 0
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    names = [r.name for r in _rows()]
    assert "long" in names
    results = bpy.context.window_manager.shapesig_results
    results.results_index = names.index("long")
    assert bpy.ops.shapesig.explain_result() == {"FINISHED"}
    ex = json.loads(_rows()[names.index("long")].explain)
    assert sum(ex["joints"].values()) == pytest.approx(1.0)
    assert sum(ex["cost_over_time"]) == pytest.approx(ex["energy"])
    line = ex["resampled"]
    assert "\n" not in line and "samples per second" in line and "--" not in line
    lay = FakeLayout()
    SHAPESIG_PT_search_view3d.draw(type("P", (), {"layout": lay})(), bpy.context)
    assert line in lay.labels()


def test_find_similar_after_assigning_a_moment(take):
    """Moments search with a part of the query (its frame range), Assign the first row (the window written as a new
    action on the armature, frames 101-340 of the take), then Find Similar from the armature: the range set for the
    old query no longer applies (it lay outside the new action's frames, which greyed the search out), so Assign
    resets it and says so; the new action is the query and the take it came from is found."""
    s = bpy.context.scene.shapesig
    s.use_windows = True
    first, last = (int(v) for v in bpy.data.actions["query"].frame_range)
    s.use_frame_range, s.frame_start, s.frame_end = True, first + 5, first + 60
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    names = [r.name for r in _rows()]
    bpy.context.window_manager.shapesig_results.results_index = names.index("take")
    assert bpy.ops.shapesig.assign_result() == {"FINISHED"}
    assigned = take.animation_data.action
    assert assigned.name.startswith("take[") and assigned.frame_range[0] > first + 60
    assert not s.use_frame_range and s.frame_start == 0 and s.frame_end == 0
    for windows in (False, True):
        s.use_windows = windows
        assert bpy.ops.shapesig.rank.poll()
        assert bpy.ops.shapesig.rank() == {"FINISHED"}
        names = [r.name for r in _rows()]
        assert assigned.name not in names and names[0] == "take"
    window = tuple(int(v) for v in assigned.frame_range)  # the moment found again where it came from
    assert _iou((_rows()[0].frame_first, _rows()[0].frame_last), window) >= 0.8


def test_every_moment_of_the_take_is_listed_and_stepped_through(take):
    """Moments lists every occurrence in a take (non-overlapping windows); the panel says which of them the
    selected one is and steps along the take's timeline, previewing each when a preview plays."""
    from blender_shapesig.panels.search import SHAPESIG_PT_search_view3d

    s = bpy.context.scene.shapesig
    s.use_windows = True
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    res = bpy.context.window_manager.shapesig_results
    mine = sorted((r.frame_first, r.frame_last, i) for i, r in enumerate(_rows()) if r.name == "take")
    assert len(mine) >= 2 and res.order_by == "local"
    assert all(e0 < (a1 + e1) / 2 for (_, e0, _), (a1, e1, _) in zip(mine, mine[1:]))  # none holds another's centre
    res.results_index = mine[0][2]
    lay = FakeLayout()
    SHAPESIG_PT_search_view3d.draw(type("P", (), {"layout": lay})(), bpy.context)
    assert f"Moment 1 of {len(mine)} in this take" in lay.labels()
    assert lay.operators().count("shapesig.step_moment") == 2
    assert bpy.ops.shapesig.step_moment(step=1) == {"FINISHED"}
    assert res.results_index == mine[1][2]
    assert bpy.ops.shapesig.step_moment(step=-1) == {"FINISHED"} and res.results_index == mine[0][2]
    assert bpy.ops.shapesig.step_moment(step=-1) == {"FINISHED"} and res.results_index == mine[-1][2]  # round
    assert bpy.ops.shapesig.preview_result() == {"FINISHED"}  # while a preview plays, a step plays the next one
    assert bpy.ops.shapesig.step_moment(step=1) == {"FINISHED"} and res.results_index == mine[0][2]
    playing = take.animation_data.action
    assert tuple(round(v) for v in playing.frame_range) == mine[0][:2] and playing.name.startswith("take[")
    assert bpy.ops.shapesig.preview_result() == {"FINISHED"}
    assert take.animation_data.action.name == "query"
    other = next(i for i, r in enumerate(_rows()) if r.name == "other")
    res.results_index = other  # a clip with one moment: nothing to step to, said in one line
    assert not bpy.ops.shapesig.step_moment.poll()
