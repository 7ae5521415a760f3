"""rigmap: bone maps of armatures (detect, store on the armature, export / import, a maps folder) and the scene's
search library reading actions through the stored map."""

import json

import bpy
import pytest

from blender_shapesig.rigs import rigmap
from blender_shapesig.search import library
from blender_shapesig.core import rigs
from blender_shapesig.core.errors import ShapeSigError
from blender_shapesig.readers.bvh import import_armature


@pytest.fixture
def daz(empty_file, data_dir):
    arm, _ = import_armature(data_dir / "bvh" / "09_03.bvh")
    return arm


def test_detect_rows_store_and_clear(daz):
    detected = rigmap.detect_armature_map(daz)
    assert detected["lThigh"] == "thigh.L" and detected["hip"] == "hips" and "lThumb1" not in detected
    rows = rigmap.rows(daz)
    assert [r[0] for r in rows] == [b.name for b in daz.data.bones]
    assert ("rShin", "shin.R", "shin.R") in rows and ("lThumb1", "", "") in rows
    assert rigmap.stored_map(daz) is None and rigmap.armature_map(daz) == detected
    mine = dict(detected, lThumb1="hand.L")
    del mine["lHand"]
    rigmap.store_map(daz, mine)
    assert rigmap.stored_map(daz) == mine and rigmap.armature_map(daz) == mine
    assert json.loads(daz.data[rigmap.PROP])["lThumb1"] == "hand.L"  # on the armature data, saved with the file
    assert ("lThumb1", "hand.L", "") in rigmap.rows(daz)
    with pytest.raises(ShapeSigError, match="has no bone"):
        rigmap.store_map(daz, {"nope": "hips"})
    with pytest.raises(ShapeSigError, match="unknown joint"):
        rigmap.store_map(daz, {"hip": "pelvis_bone"})
    rigmap.clear_map(daz)
    assert rigmap.stored_map(daz) is None


def test_export_import_and_maps_folder(daz, tmp_path):
    folder = tmp_path / "maps"
    folder.mkdir()
    path = rigmap.export_map(daz, folder / "daz.json")
    assert rigs.load_map(path) == rigmap.detect_armature_map(daz)
    (folder / "other.json").write_text(json.dumps({"mixamorig:Hips": "hips"}))
    (folder / "broken.json").write_text("{")
    best, mapping = rigmap.best_saved_map(daz, folder)
    assert best == str(folder / "daz.json") and mapping["rFoot"] == "foot.R"
    small = tmp_path / "small.json"
    rigs.save_map(small, {"hip": "hips", "lThigh": "thigh.L", "elsewhere": "toe.L"})
    assert rigmap.import_map(daz, small) == {"hip": "hips", "lThigh": "thigh.L"}
    with pytest.raises(ShapeSigError, match="none of its bones"):
        rigmap.import_map(daz, folder / "other.json")


def test_scene_actions_are_read_through_the_stored_map(daz):
    action = daz.animation_data.action
    item = library.action_item(action, daz)
    clip = item.clips()[0]
    assert clip.meta["rotation_space"] == "comparison" and "thigh.L" in clip.bones
    rigmap.store_map(daz, {"hip": "hips", "lThigh": "thigh.L", "rThigh": "thigh.R"})
    again = library.action_item(action, daz)
    assert again.key != item.key  # the stored map is part of the armature's digest
    assert again.clips()[0].bones == ("hips", "thigh.L", "thigh.R")
