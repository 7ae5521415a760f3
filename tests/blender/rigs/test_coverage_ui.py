"""Issue 30 in the panel: result rows show partial matches and the joints left out (from a real ranking of rigs
written by the test), and the Bone Map panel lists the canonical joints of the active armature's rig that its map
in use leaves out; the armature's automatic map comes from its names, hierarchy and rest pose."""

import json
from types import SimpleNamespace

import bpy

from blender_shapesig.rigs import rigmap
from blender_shapesig.search import library, result_rows
from blender_shapesig.core import rigs
from blender_shapesig.core.search import rank_clips
from blender_shapesig.core.io import sources
from blender_shapesig.readers.bvh import import_armature
from tests.helpers.fake_layout import FakeLayout
from tests.helpers.rig_skeletons import BIOVISION, UNITY, write_bvh

UNITY_HAS = [j for j in rigs.JOINTS if j != "spine_mid"]
TORSO = ("hips", "spine", "neck", "head")


def _read(path, **kw):
    return sources.read_one(sources.ClipSpec(str(path), trim="none", **kw))


def test_result_rows_show_partial_matches_and_unmapped_joints(empty_file, tmp_path):
    from blender_shapesig.panels.search import SHAPESIG_UL_results, _draw_results

    query = _read(write_bvh(tmp_path / "query.bvh", UNITY, root="joint_Root", frames=40))
    bio = _read(write_bvh(tmp_path / "bio.bvh", BIOVISION, frames=44))
    (tmp_path / "torso.json").write_text(json.dumps({UNITY[j]: j for j in TORSO}))
    torso = _read(write_bvh(tmp_path / "torso.bvh", UNITY, root="joint_Root", frames=48),
                  bone_map=str(tmp_path / "torso.json"))
    ranked = rank_clips(query, [bio, torso], metric="sim3", allow_partial=True)
    s = bpy.context.scene.shapesig
    result_rows.store_results(s, ranked, "query", query_bones=len(query.bones))
    res = library.results_of()
    rows = {r.clip_name: r for r in res.results}
    assert not rows["bio"].partial and rows["bio"].unmapped == "" and rows["bio"].coverage == 1.0
    assert rows["torso"].partial and abs(rows["torso"].coverage - 4 / 21) < 1e-6
    assert rows["torso"].unmapped == ", ".join(j for j in UNITY_HAS if j not in TORSO)
    line = FakeLayout()
    SHAPESIG_UL_results.draw_item(SimpleNamespace(layout_type="DEFAULT"), bpy.context, line, s, rows["torso"], 0, s,
                                  "results_index")
    assert "torso.bvh (partial, 19%)" in line.labels()
    res.results_index = list(res.results).index(rows["torso"])
    lay = FakeLayout()
    _draw_results(lay, s, res)
    text = lay.labels()
    assert "19% of the joints both rigs have" in text and "Partial match" in text
    assert "Unmapped: chest, clavicle.L, upper_arm.L" in text


def test_bone_map_panel_lists_unmapped_joints_and_detection_uses_the_rest_pose(empty_file, tmp_path):
    from blender_shapesig.panels import rigmap as panel

    # sides named against the rest pose: the bones called *_L stand at the character's right
    swapped = {j.replace(".L", ".X").replace(".R", ".L").replace(".X", ".R"): b for j, b in UNITY.items()}
    arm, _ = import_armature(write_bvh(tmp_path / "unity.bvh", swapped, root="joint_Root"))
    bpy.context.view_layer.objects.active = arm
    got = rigmap.detect_armature_map(arm)
    assert got == {b: j for j, b in swapped.items()}  # left and right from where the bones stand, not their names
    assert rigmap.unmapped_joints(arm) == []
    lay = FakeLayout()
    panel.SHAPESIG_PT_bone_map_view3d.draw(SimpleNamespace(layout=lay), bpy.context)
    assert "Unmapped" not in lay.labels()
    rigmap.store_map(arm, {b: j for b, j in got.items() if j in TORSO})
    lay = FakeLayout()
    panel.SHAPESIG_PT_bone_map_view3d.draw(SimpleNamespace(layout=lay), bpy.context)
    labels = lay.labels()
    head = f"Unmapped: {len(UNITY_HAS) - 4} joint(s) of this rig"
    assert head in labels
    listed = labels[labels.index(head) + len(head):]
    assert all(j in listed for j in UNITY_HAS if j not in TORSO)
    assert listed.index("chest") < listed.index("clavicle.L") < listed.index("toe.R")
