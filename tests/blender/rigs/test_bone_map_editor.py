"""The Bone Map editor and the search's read options, on
real CMU clips imported with Blender's BVH importer: the map is stored on the armature and survives save ->
reopen in a fresh process; export -> import round-trips and is what core reads with --bone-map FILE; a hand-edited
map raises a result's coverage; bad JSON is refused with nothing changed; the search and the Blend operator read
through the stored map; Trim none vs auto changes the frames compared on a clip with a rest-pose head."""

import json
import os
import shutil
import subprocess
import sys
from types import SimpleNamespace

import bpy
import numpy as np
import pytest

from blender_shapesig.rigs import rigmap
from blender_shapesig.search import library
from blender_shapesig.core import rigs
from blender_shapesig.core.io import sources
from blender_shapesig.readers.bvh import import_armature

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))


@pytest.fixture
def daz(empty_file, data_dir):
    """The Daz-friendly 09_03 run: active armature with its action."""
    arm, _ = import_armature(data_dir / "bvh" / "09_03.bvh")
    bpy.context.view_layer.objects.active = arm
    return arm


def _refused(op, match, **props):
    """Run an operator that must fail: one ERROR line (RuntimeError headless), matching ``match``."""
    with pytest.raises(RuntimeError, match=match) as info:
        op(**props)
    assert "\n" not in str(info.value).strip()


def test_editor_registered_and_drawn(daz):
    for op in ("bone_map_detect", "bone_map_clear", "bone_map_set", "bone_map_export", "bone_map_import",
               "bone_map_import_saved", "bone_map_pick"):
        getattr(bpy.ops.shapesig, op).get_rna_type()
    for cls in ("SHAPESIG_PT_bone_map_view3d", "SHAPESIG_PT_bone_map_dopesheet", "SHAPESIG_PT_bone_map_nla",
                "SHAPESIG_UL_bone_map", "SHAPESIG_MT_saved_maps"):
        assert hasattr(bpy.types, cls)
    assert bpy.types.SHAPESIG_PT_bone_map_view3d.bl_parent_id == "SHAPESIG_PT_search_view3d"
    from tests.helpers.fake_layout import FakeLayout

    from blender_shapesig.panels import rigmap as panel

    rows, kind = panel.bone_rows(daz)
    assert kind == "auto" and rows["lThigh"] == ("thigh.L", "thigh.L") and rows["lThumb1"] == ("", "")
    lay = FakeLayout()
    panel.SHAPESIG_PT_bone_map_view3d.draw(SimpleNamespace(layout=lay), bpy.context)
    assert "Automatic: 19 of" in lay.labels() and any(e[0] == "template_list" for e in lay.log)
    assert {"shapesig.bone_map_detect", "shapesig.bone_map_import", "shapesig.bone_map_export"} <= \
        set(lay.operators())
    bpy.ops.shapesig.bone_map_set(bone="lThumb1", joint="hand.L")
    row = FakeLayout()
    panel.SHAPESIG_UL_bone_map.draw_item(None, bpy.context, row, daz.data, daz.data.bones["lHand"], 0, None, "")
    assert "lHand" in row.labels() and "auto: hand.L" in row.labels()  # the joint moved to lThumb1
    menu = [e for e in row.log if e[0] == "operator_menu_enum"]
    assert menu[0][1][:2] == ("shapesig.bone_map_set", "joint")
    lay = FakeLayout()
    panel.SHAPESIG_PT_bone_map_view3d.draw(SimpleNamespace(layout=lay), bpy.context)
    assert "Stored map: 19 of" in lay.labels()
    lay = FakeLayout()
    panel.SHAPESIG_MT_saved_maps.draw(SimpleNamespace(layout=lay), bpy.context)
    assert "No maps" in lay.labels()
    bpy.context.view_layer.objects.active = None
    lay = FakeLayout()
    panel.draw_bone_map(lay, bpy.context)
    assert "Select an armature" in lay.labels()


def test_poll_needs_an_armature(empty_file):
    assert not bpy.ops.shapesig.bone_map_detect.poll()
    with pytest.raises(RuntimeError, match="Select an armature"):
        bpy.ops.shapesig.bone_map_detect()


def test_map_survives_save_and_reopen_in_a_fresh_process(daz, tmp_path):
    assert bpy.ops.shapesig.bone_map_detect() == {"FINISHED"}
    assert bpy.ops.shapesig.bone_map_set(bone="lThumb1", joint="hand.L") == {"FINISHED"}
    assert bpy.ops.shapesig.bone_map_set(bone="rFoot", joint="NONE") == {"FINISHED"}
    mine = rigmap.stored_map(daz)
    assert mine["lThumb1"] == "hand.L" and "lHand" not in mine and "rFoot" not in mine  # a joint is used once
    path = tmp_path / "mapped.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    code = ("import bpy, json, sys; bpy.ops.wm.open_mainfile(filepath=sys.argv[1]); "
            "from blender_shapesig.rigs import rigmap; "
            "arm = next(o for o in bpy.data.objects if o.type == 'ARMATURE'); "
            "print('MAP=' + json.dumps(rigmap.stored_map(arm)))")
    out = subprocess.run([sys.executable, "-c", code, str(path)], capture_output=True, text=True, cwd=ROOT,
                         timeout=300, check=True).stdout
    line = next(x for x in out.splitlines() if x.startswith("MAP="))
    assert json.loads(line[4:]) == mine


def test_export_import_round_trip_is_what_core_reads(daz, tmp_path, data_dir):
    bpy.ops.shapesig.bone_map_set(bone="lThumb1", joint="hand.L")
    mine = rigmap.stored_map(daz)
    path = tmp_path / "daz.json"
    assert bpy.ops.shapesig.bone_map_export(filepath=str(path)) == {"FINISHED"}
    assert rigs.load_map(path) == mine  # the --bone-map FILE.json format
    assert bpy.ops.shapesig.bone_map_clear() == {"FINISHED"}
    assert rigmap.stored_map(daz) is None
    assert bpy.ops.shapesig.bone_map_import(filepath=str(path)) == {"FINISHED"}
    assert rigmap.stored_map(daz) == mine
    # the command line's reading of a clip of this rig through the exported file maps the same bones
    clip = sources.read_one(data_dir / "bvh" / "09_03.bvh", bone_map=str(path))
    assert clip.meta["bone_map"] == {j: b for b, j in mine.items() if j in clip.bones}
    assert clip.meta["bone_map"]["hand.L"] == "lThumb1"
    # by name from the preferences' maps folder
    folder = tmp_path / "maps"
    folder.mkdir()
    shutil.copy(path, folder / "daz.json")
    bpy.ops.shapesig.bone_map_clear()
    assert rigmap.import_saved(daz, "daz", str(folder)) == mine
    assert rigmap.bone_map_of(daz) == mine


def test_bad_json_is_refused_and_nothing_changes(daz, tmp_path):
    bpy.ops.shapesig.bone_map_detect()
    before = daz.data[rigmap.PROP]
    bad = {"broken.json": "{\"hip\": ", "joint.json": json.dumps({"hip": "pelvis_bone"}),
           "twice.json": json.dumps({"hip": "hips", "abdomen": "hips"}), "list.json": "[1, 2]",
           "other.json": json.dumps({"mixamorig:Hips": "hips"})}
    for name, text in bad.items():
        (tmp_path / name).write_text(text)
    _refused(bpy.ops.shapesig.bone_map_import, "not valid JSON", filepath=str(tmp_path / "broken.json"))
    _refused(bpy.ops.shapesig.bone_map_import, "unknown joint", filepath=str(tmp_path / "joint.json"))
    _refused(bpy.ops.shapesig.bone_map_import, "given to two bones", filepath=str(tmp_path / "twice.json"))
    _refused(bpy.ops.shapesig.bone_map_import, "JSON object", filepath=str(tmp_path / "list.json"))
    _refused(bpy.ops.shapesig.bone_map_import, "none of its bones", filepath=str(tmp_path / "other.json"))
    _refused(bpy.ops.shapesig.bone_map_set, "no bone", bone="nope", joint="hips")
    assert daz.data[rigmap.PROP] == before
    # a corrupt stored map (a script wrote it) is one line from the search too, not a traceback
    daz.data[rigmap.PROP] = "{"
    with pytest.raises(Exception, match="not valid JSON"):
        rigmap.bone_map_of(daz)
    from blender_shapesig.panels import rigmap as panel

    assert "not valid JSON; Clear it" in panel._status(daz)[0]
    assert bpy.ops.shapesig.bone_map_clear() == {"FINISHED"} and rigmap.bone_map_of(daz) == "auto"


def _rank(settings):
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    return {r.name: r for r in bpy.context.window_manager.shapesig_results.results}


def test_a_hand_mapped_bone_raises_coverage(daz, data_dir):
    # a library action of another armature whose stored map leaves its left thigh out (detection finds it by the
    # hierarchy and rest pose even when renamed: a hand-made map is what misses it)
    other, _ = import_armature(data_dir / "bvh" / "09_02.bvh")
    other.data.bones["lThigh"].name = "legA"
    detected = rigmap.detect_armature_map(other)
    assert detected["legA"] == "thigh.L"
    rigmap.store_map(other, {b: j for b, j in detected.items() if b != "legA"})
    bpy.context.view_layer.objects.active = daz
    s = bpy.context.scene.shapesig
    s.rerank = 0
    s.similarity = "sim"  # bones compared: the signature search's coverage
    name = other.animation_data.action.name
    row = _rank(s)[name]
    before = (row.shared, row.coverage)
    assert before == (18, pytest.approx(18 / 19))
    bpy.context.view_layer.objects.active = other  # the map editor edits the active armature
    assert bpy.ops.shapesig.bone_map_set(bone="legA", joint="thigh.L") == {"FINISHED"}
    bpy.context.view_layer.objects.active = daz
    row = _rank(s)[name]
    assert (row.shared, row.coverage) == (19, 1.0)


def test_trim_toggle_changes_the_frames_compared(empty_file, data_dir, tmp_path):
    walk, _ = import_armature(data_dir / "bvh" / "07_01.bvh")
    other, _ = import_armature(data_dir / "bvh" / "07_02.bvh")
    other.animation_data.action.use_fake_user = True
    bpy.data.objects.remove(other)
    bpy.context.view_layer.objects.active = walk
    s = bpy.context.scene.shapesig
    s.rerank = 0
    assert s.trim == "auto" and s.fps == 0.0
    # Blender's BVH importer records no rate: the actions play at the scene's 24 fps, where the trim's window
    # (0.1 s) is 2 frames; read at the files' 120 fps (the FPS field) the whole ramp goes
    _obj, _act, q = library.query_item(bpy.context, s)
    assert (q.clips()[0].fps, q.clips()[0].frame_start) == (24.0, 3)
    s.fps = 120.0
    _obj, _act, q = library.query_item(bpy.context, s)
    clip = q.clips()[0]
    assert (clip.frame_start, clip.frame_end) == (9, 317)  # the rest pose and ramp dropped (core/clip/trim.py)
    row = next(iter(_rank(s).values()))
    assert (row.kept_first, row.kept_last, row.read_first, row.read_last) == (6, 330, 1, 330)
    assert row.frame_last == 0  # not a moment: Assign and Preview give the whole action
    assert row.frames == 325
    from tests.helpers.fake_layout import FakeLayout

    from blender_shapesig.panels.search import draw_search

    lay = FakeLayout()
    draw_search(lay, bpy.context)
    assert "trimmed: frames 6-330 compared of 1-330 read" in lay.labels()
    assert ("prop", (s, "trim"), {"expand": True}) in lay.log
    library.CACHES.clear()  # a new session: the rows come from the index files, the trimmed range with them
    row = next(iter(_rank(s).values()))
    assert (row.kept_first, row.kept_last, row.read_first, row.read_last) == (6, 330, 1, 330)
    assert row.frame_last == 0  # not a moment: Assign and Preview give the whole action
    assert "0 newly indexed" in bpy.context.window_manager.shapesig_results.message

    s.trim = "none"
    _obj, _act, q2 = library.query_item(bpy.context, s)
    assert q2.key != q.key and (q2.clips()[0].frame_start, q2.clips()[0].frame_end) == (1, 317)
    row = next(iter(_rank(s).values()))
    assert (row.kept_last, row.read_last, row.frames) == (0, 0, 330)  # nothing trimmed: the whole clip

    # an explicit frame range is exact: nothing trimmed from it even with Trim auto
    s.trim, s.use_frame_range, s.frame_start, s.frame_end = "auto", True, 2, 300
    _obj, _act, q3 = library.query_item(bpy.context, s)
    assert (q3.clips()[0].frame_start, q3.clips()[0].frame_end) == (2, 300)
    s.use_frame_range = False

    # the FPS field is part of the key; an implausible rate is refused in poll
    s.fps = 30.0
    _obj, _act, q4 = library.query_item(bpy.context, s)
    assert q4.key != q.key and q4.clips()[0].fps == 30.0
    s.fps = 0.5
    assert "plausible" in library.search_problem(bpy.context, s)
    assert not bpy.ops.shapesig.rank.poll()


def test_blend_across_rigs_reads_through_the_stored_map(empty_file, data_dir):
    cc, _ = import_armature(data_dir / "cross_rig" / "002_03.bvh")
    daz, _ = import_armature(data_dir / "cross_rig" / "02_03.bvh")
    a, b = daz.animation_data.action, cc.animation_data.action
    bpy.context.view_layer.objects.active = daz
    assert rigmap.across_rigs(daz, cc) and not rigmap.across_rigs(daz, daz)
    # the same rig imported again is one rig; with its left forearm's rest turned 45 degrees (an A-pose arm) it
    # is another rig (core.rigs.rests_differ), blended through the maps and rest_retarget
    twin, _ = import_armature(data_dir / "cross_rig" / "02_03.bvh")
    assert not rigmap.across_rigs(daz, twin)
    import math

    import mathutils

    bpy.context.view_layer.objects.active = twin
    bpy.ops.object.mode_set(mode="EDIT")
    eb = twin.data.edit_bones
    shoulder, forearm = eb["lShldr"].head.copy(), eb["lForeArm"]
    forearm.use_connect = False
    forearm.head = shoulder + mathutils.Matrix.Rotation(math.radians(45.0), 3, "Y") @ (forearm.head - shoulder)
    bpy.ops.object.mode_set(mode="OBJECT")
    assert rigmap.across_rigs(daz, twin) and rigmap.across_rigs(twin, daz)
    bpy.context.view_layer.objects.active = daz
    before = set(bpy.data.actions)
    assert bpy.ops.shapesig.blend_actions(action_a=a.name, action_b=b.name, weight=0.5, assign=False) \
        == {"FINISHED"}
    made = [x for x in bpy.data.actions if x not in before]
    assert len(made) == 1
    # written onto A's (Daz) rig: its bones, the mapped joints blended
    from blender_shapesig.actions import action_io
    from blender_shapesig.blend.blend_actions import blend_actions

    out = action_io.read_action(made[0], armature=daz, exclude_unkeyed=True)
    assert {"lThigh", "rShin", "hip"} <= set(out.bones)
    # its hips between the sources' in height, each in leg lengths of its own rig (the CC rig translates a
    # floor-level root bone in centimetres, with longer legs): rigs.hips_path and its inverse in rigs.onto_rig
    heights = []
    for act, arm in ((a, daz), (b, cc), (made[0], daz)):
        clip = action_io.read_action(act, armature=arm, space="armature")
        by_joint = {j: x for x, j in rigs.resolve_map("auto", clip).items()}
        heights.append(float(np.median(rigs.hips_path(clip, by_joint, rigs.world_rotations(clip))[0][:, 2])))
    assert min(heights[:2]) - 0.03 <= heights[2] <= max(heights[:2]) + 0.03, heights
    auto = blend_actions(daz, a, b, [0.5])
    assert "rShin" not in auto.unmatched and "lThumb1" in auto.unmatched  # kept: no counterpart in B
    # a stored map of three bones: only those are blended, every other bone keeps A's motion
    rigmap.store_map(daz, {"hip": "hips", "lThigh": "thigh.L", "rThigh": "thigh.R"})
    before = set(bpy.data.actions)
    with pytest.raises(Exception, match="coverage 0.16 < 0.5"):  # 3 of the joints both rigs have: asked for only
        blend_actions(daz, a, b, [0.5])
    assert set(bpy.data.actions) == before
    mine = blend_actions(daz, a, b, [0.5], allow_partial=True)
    assert "rShin" in mine.unmatched and "lThigh" not in mine.unmatched
    assert len(mine.unmatched) > len(auto.unmatched)
    # a bone subset is given in A's bone names; one without a joint is refused, nothing created
    before = set(bpy.data.actions)
    with pytest.raises(Exception, match="map to no joint"):
        blend_actions(daz, a, b, [0.5], bones=["rShin"], allow_partial=True)
    assert set(bpy.data.actions) == before


def test_auto_pick_from_the_maps_folder(daz, tmp_path, monkeypatch):
    from blender_shapesig import preferences

    folder = tmp_path / "maps"
    folder.mkdir()
    rigs.save_map(folder / "mine.json", {"hip": "hips", "lThigh": "thigh.L", "rThigh": "thigh.R", "x": "head"})
    rigs.save_map(folder / "two.json", {"hip": "hips", "abdomen": "spine"})
    (folder / "broken.json").write_text("{")
    auto_digest = library.armature_digest(daz)
    prefs = SimpleNamespace(maps_folder=str(folder), auto_pick_map=False)
    monkeypatch.setattr(preferences, "get_preferences", lambda context=None: prefs)
    assert rigmap.bone_map_of(daz) == "auto"  # Auto-Pick off: the folder is only offered in the menu
    assert rigmap.import_saved(daz, "two", rigmap.maps_folder()) == {"hip": "hips", "abdomen": "spine"}
    rigmap.clear_map(daz)
    prefs.auto_pick_map = True
    picked = {"hip": "hips", "lThigh": "thigh.L", "rThigh": "thigh.R"}  # its entries for this armature's bones
    assert rigmap.bone_map_of(daz) == picked and rigmap.armature_map(daz) == picked
    assert library.armature_digest(daz) != auto_digest  # a picked map gives the actions new index keys
    from blender_shapesig.panels import rigmap as panel

    assert panel._status(daz)[0].startswith("Auto-picked saved map (not stored): 3 of ")
    rigmap.store_map(daz, {"hip": "hips"})
    assert rigmap.bone_map_of(daz) == {"hip": "hips"}  # a stored map wins


def test_an_unknown_rig_detects_nothing_and_exports_nothing(empty_file, line_armature, tmp_path):
    obj = line_armature(["bone0", "bone1", "bone2"])
    _refused(bpy.ops.shapesig.bone_map_detect, "matches a known rig")
    _refused(bpy.ops.shapesig.bone_map_export, "nothing to export", filepath=str(tmp_path / "x.json"))
    assert not (tmp_path / "x.json").exists() and rigmap.PROP not in obj.data
    assert bpy.ops.shapesig.bone_map_set(bone="bone1", joint="hips") == {"FINISHED"}
    assert bpy.ops.shapesig.bone_map_export(filepath=str(tmp_path / "x.json")) == {"FINISHED"}
    assert rigs.load_map(tmp_path / "x.json") == {"bone1": "hips"}
