"""Pictures of the result rows in Blender, on real CMU clips imported by Blender's BVH importer and the add-on's
Acclaim importer: after Find Similar every row and the query get a strip of key poses within seconds of polling
the job (the click itself makes none), Blender's own PNG loader reads them as written, a walk's and a jump's
differ, the same take from AMC and from the Daz BVH agrees, a fresh Blender session reuses the cached pictures
without drawing them again, Why Different draws both clips' strips aligned by the warp, the list and the panel
show the icons, and unregistering frees the previews."""

import json
import os
import pathlib
import subprocess
import sys
import time
from types import SimpleNamespace

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from blender_shapesig.search import thumbnails  # noqa: E402
from blender_shapesig.core import search as search  # noqa: E402
from blender_shapesig.core.search import thumbnails as core_thumbs  # noqa: E402
from tests.helpers.png import read_png  # noqa: E402
from tests.helpers.blender_clips import CLIPS, import_bvh  # noqa: E402
from tests.helpers.fake_layout import FakeLayout  # noqa: E402

DATA = pathlib.Path(__file__).resolve().parents[2] / "data"
ROOT = str(pathlib.Path(__file__).resolve().parents[3])


@pytest.fixture
def demo(empty_file, monkeypatch, tmp_path):
    """The six demo clips (walks 07_01 07_02 08_01, runs 09_02 09_03, jump 13_32) as actions; 'walk1' active."""
    monkeypatch.setenv(search.CACHE_ENV, str(tmp_path / "index"))
    from blender_shapesig.search import library

    library.CACHES.clear()
    arm = import_bvh(f"{CLIPS['walk1']}.bvh", "walk1", fake_user=True)
    for name, clip in CLIPS.items():
        if name != "walk1":
            bpy.data.objects.remove(import_bvh(f"{clip}.bvh", name, fake_user=True))
    bpy.context.view_layer.objects.active = arm
    arm.select_set(True)
    return tmp_path / "index" / search.CACHE_SUBDIR


def _rows():
    return bpy.context.window_manager.shapesig_results.results


def _poll(seconds=20.0):
    """Step the running job until it is done (a timer does this in the UI); the seconds it took."""
    job, t0 = thumbnails.current_job(), time.perf_counter()
    assert job is not None
    while not job.finished:
        assert time.perf_counter() - t0 < seconds, "the pictures took too long"
        job.step()
    return time.perf_counter() - t0


def _iou(a, b):
    ma, mb = core_thumbs.figure_mask(a, 2), core_thumbs.figure_mask(b, 2)
    return (ma & mb).sum() / (ma | mb).sum()


def test_every_row_gets_a_picture_after_the_click(demo):
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    res = bpy.context.window_manager.shapesig_results
    assert len(_rows()) == 5 and all(r.preview_path == "" and r.preview_icon == 0 for r in _rows())  # not yet
    assert _poll() < 10.0
    assert thumbnails.current_job() is None or thumbnails.current_job().finished
    paths = [r.preview_path for r in _rows()] + [res.query_preview_path]
    assert all(os.path.isfile(p) and os.path.dirname(p) == str(demo) for p in paths) and len(set(paths)) == 6
    for r in _rows():  # the icon of the picture (Blender makes no icons in background mode: 0 there)
        assert r.preview_icon == thumbnails.previews()[r.preview_path].icon_id
    # Blender's PNG loader reads what the rasterizer wrote
    img = bpy.data.images.load(paths[0])
    try:
        w, h = img.size
        px = np.array(img.pixels[:]).reshape(h, w, 4)[::-1]  # Blender's rows run bottom-up
        assert np.abs(px * 255 - read_png(paths[0])).max() < 0.51
    finally:
        bpy.data.images.remove(img)
    by_name = {r.name: read_png(r.preview_path) for r in _rows()}
    walk, jump = by_name["walk2"], by_name["jump"]
    assert _iou(walk, jump) < 0.45 and _iou(walk, by_name["walk3"]) > _iou(walk, jump) + 0.2


_FRESH = """
import json, os, sys, time
sys.path.insert(0, sys.argv[1])
import bpy, addon_utils
import blender_shapesig
from blender_shapesig.search import thumbnails
blender_shapesig.register()
bpy.ops.wm.read_factory_settings(use_empty=True)
addon_utils.enable("io_anim_bvh", default_set=False)
names = json.loads(sys.argv[2])
arm = None
for name, clip in names.items():
    bpy.ops.import_anim.bvh(filepath=os.path.join(sys.argv[3], clip + ".bvh"), rotate_mode="NATIVE", frame_start=1,
                            use_fps_scale=False, update_scene_fps=False, update_scene_duration=False)
    obj = bpy.context.view_layer.objects.active
    obj.animation_data.action.name = name
    obj.animation_data.action.use_fake_user = True
    if arm is None:
        arm = obj
    else:
        bpy.data.objects.remove(obj)
bpy.context.view_layer.objects.active = arm
bpy.ops.shapesig.rank()
job = thumbnails.current_job()
while not job.finished:
    job.step()
res = bpy.context.window_manager.shapesig_results
print("RESULT" + json.dumps([res.query_preview_path] + [r.preview_path for r in res.results]))
"""


def test_a_fresh_session_reuses_the_pictures(demo):
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    _poll()
    made = {p: os.stat(p).st_mtime_ns for p in [r.preview_path for r in _rows()]}
    env = dict(os.environ, **{search.CACHE_ENV: str(demo.parent)})
    out = subprocess.run([sys.executable, "-c", _FRESH, ROOT, json.dumps(CLIPS), str(DATA / "bvh")], env=env,
                         capture_output=True, text=True, timeout=600)
    line = [ln for ln in out.stdout.splitlines() if ln.startswith("RESULT")]
    assert line, out.stderr[-2000:]
    again = json.loads(line[-1][len("RESULT"):])
    assert set(made) <= set(again[1:])
    assert {p: os.stat(p).st_mtime_ns for p in made} == made  # read, not drawn again


def test_same_take_from_amc_and_daz_bvh_looks_alike(empty_file, monkeypatch, tmp_path):
    monkeypatch.setenv(search.CACHE_ENV, str(tmp_path / "index"))
    bpy.ops.shapesig.import_acclaim("EXEC_DEFAULT", filepath=str(DATA / "acclaim" / "07_01.amc"),
                                    asf_path=str(DATA / "acclaim" / "07-walk.asf"))
    amc = bpy.context.view_layer.objects.active.animation_data.action
    amc.use_fake_user = True
    bpy.data.objects.remove(import_bvh("09_02.bvh", "run", fake_user=True))
    arm = import_bvh("07_01.bvh", "walk_bvh", fake_user=True)
    bpy.context.view_layer.objects.active = arm
    bpy.context.scene.shapesig.fps = 120.0  # Blender's BVH importer records no rate
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    _poll()
    res = bpy.context.window_manager.shapesig_results
    row = next(r for r in _rows() if r.name == amc.name)
    assert _iou(read_png(res.query_preview_path), read_png(row.preview_path)) >= 0.7


def test_why_different_and_the_panel_show_the_pictures(demo):
    from blender_shapesig.panels.search import SHAPESIG_PT_search_view3d, SHAPESIG_UL_results

    s = bpy.context.scene.shapesig
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    _poll()
    assert bpy.ops.shapesig.explain_result() == {"FINISHED"}
    row = _rows()[0]
    warp = json.loads(row.explain)["warp"]
    assert warp[0] == [0.0, 0.0] and warp[-1] == [1.0, 1.0]
    q, r = read_png(row.why_query_path), read_png(row.why_result_path)
    assert q.shape == r.shape == (core_thumbs.HEIGHT, core_thumbs.SLOT * core_thumbs.POSES, 4)
    assert _iou(q, r) > 0.5  # two walks at matched times
    # the list shows the icon and the panel the larger picture (icons exist only with a UI: one is set here)
    row.preview_icon = 7
    line = FakeLayout()
    SHAPESIG_UL_results.draw_item(SimpleNamespace(layout_type="DEFAULT"), bpy.context, line, s, row, 0, s,
                                  "results_index")
    assert any(e[0] == "label" and e[2].get("icon_value") == 7 for e in line.log)
    lay = FakeLayout()
    SHAPESIG_PT_search_view3d.draw(SimpleNamespace(layout=lay), bpy.context)
    assert any(e[0] == "template_icon" and e[2].get("icon_value") == 7 for e in lay.log)


def test_unregister_frees_the_previews(demo):
    import blender_shapesig

    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    _poll()
    pcoll = thumbnails.previews()
    assert all(r.preview_path in pcoll for r in _rows())
    blender_shapesig.unregister()
    try:
        assert thumbnails._STATE["previews"] is None and thumbnails.current_job() is None
        assert not bpy.app.timers.is_registered(thumbnails._tick)
    finally:
        blender_shapesig.register()
