"""Auto-Pick with saved-map files that are not bone maps in the maps folder: a non-UTF-8, a
200,000-deep, a too-large and a not-an-object JSON file beside a good map. Find Similar still ranks (with the
good map picked), and each bad file is skipped with one warning naming it."""

from types import SimpleNamespace

import pytest

bpy = pytest.importorskip("bpy")

from blender_shapesig import preferences  # noqa: E402
from blender_shapesig.rigs import rigmap  # noqa: E402
from blender_shapesig.search import library, rank_job  # noqa: E402
from blender_shapesig.core import search as index, rigs  # noqa: E402
from blender_shapesig.readers.bvh import import_armature  # noqa: E402

BAD = {"latin1.json": '{"hip": "hips", "t\xeate": "head"}'.encode("latin-1"),
       "deep.json": b"[" * 200_000,
       "huge.json": b'{"#pad": "' + b"x" * (rigs.MAX_MAP_BYTES + 1) + b'"}',
       "list.json": b'["hip", "hips"]'}


@pytest.fixture
def two_runs(empty_file, data_dir, tmp_path, monkeypatch):
    monkeypatch.setenv(index.CACHE_ENV, str(tmp_path / "index"))
    library.CACHES.clear()
    other, _ = import_armature(data_dir / "bvh" / "09_02.bvh")
    query, _ = import_armature(data_dir / "bvh" / "09_03.bvh")
    bpy.context.view_layer.objects.active = query
    bpy.context.scene.shapesig.rerank = 0
    bpy.context.scene.shapesig.similarity = "sim"  # the map names no feet: the local search would refuse the query
    folder = tmp_path / "maps"
    folder.mkdir()
    for name, data in BAD.items():
        (folder / name).write_bytes(data)
    good = {"hip": "hips", "abdomen": "spine", "chest": "chest", "neck": "neck", "head": "head",
            "lThigh": "thigh.L", "rThigh": "thigh.R", "lShin": "shin.L", "rShin": "shin.R"}
    rigs.save_map(folder / "good.json", good)
    prefs = SimpleNamespace(maps_folder=str(folder), auto_pick_map=True, cache_dir="", compact_index=False)
    monkeypatch.setattr(preferences, "get_preferences", lambda context=None: prefs)
    yield query, other, folder, good
    library.CACHES.clear()


def test_find_similar_ranks_and_names_each_bad_map_once(two_runs):
    query, other, folder, good = two_runs
    assert rigmap.bone_map_of(query) == good  # the good map is picked; the bad ones are skipped
    skipped = rigmap.skipped_maps(str(folder))
    assert len(skipped) == len(BAD)
    for name in BAD:
        lines = [w for w in skipped if str(folder / name) in w]
        assert len(lines) == 1 and "\n" not in lines[0], (name, skipped)
    ranked = rank_job.rank_into_settings(bpy.context, bpy.context.scene.shapesig)
    assert other.animation_data.action.name in [r.name for r in ranked]
    assert [w for w in ranked.warnings if w.startswith("saved bone map skipped")] == skipped
    assert bpy.ops.shapesig.rank("EXEC_DEFAULT") == {"FINISHED"}
    msg = library.results_of(bpy.context).message
    assert "warning(s): " in msg and "\n" not in msg
    rows = bpy.context.window_manager.shapesig_results.results
    assert other.animation_data.action.name in [r.name for r in rows]
