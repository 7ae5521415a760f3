"""The panel's index folder: Build Index, Find Similar and Clear Index touch only the cache's own
subfolder and its own files (a user's ``keep.npz`` and other files in the folder named, $SHAPESIG_CACHE_DIR or the
Index Folder preference ``//``, survive), and an index folder that cannot be used gives the same results as a
working one, with one WARNING line."""

import os
import pathlib
from types import SimpleNamespace

import pytest

bpy = pytest.importorskip("bpy")

from blender_shapesig.search import library  # noqa: E402
from blender_shapesig.core import search as index  # noqa: E402
from tests.helpers.blender_clips import walk_with_run  # noqa: E402

DATA = pathlib.Path(__file__).resolve().parents[2] / "data"


def _user_files(folder):
    folder.mkdir(parents=True, exist_ok=True)
    files = {"keep.npz": b"PK\x05\x06" + bytes(18), "notes.txt": b"mine\n", "light_pack.bin": b"my own pack"}
    for name, data in files.items():
        (folder / name).write_bytes(data)
    return files


def _untouched(folder, files):
    return {n: (folder / n).read_bytes() for n in files} == files


@pytest.fixture
def scene(empty_file):
    """The walk 07_01 active (action 'walk') and 'run' (09_02) as a library action; no session caches."""
    arm = walk_with_run()
    library.CACHES.clear()
    yield arm
    library.CACHES.clear()


def _rows():
    return {r.name: r.distance for r in bpy.context.window_manager.shapesig_results.results}


def _message():
    return library.results_of(bpy.context).message


def test_env_index_folder_keeps_user_files_through_build_rank_and_clear(scene, tmp_path, monkeypatch):
    named = tmp_path / "index"
    files = _user_files(named)
    monkeypatch.setenv(index.CACHE_ENV, str(named))
    assert bpy.ops.shapesig.build_index("EXEC_DEFAULT") == {"FINISHED"}
    own = named / index.CACHE_SUBDIR
    # two clips: a signature entry and a local-search entry each
    assert len(list(own.glob("*.npz"))) == 4 and "signature cache" not in _message()
    assert bpy.ops.shapesig.rank("EXEC_DEFAULT") == {"FINISHED"}
    assert _rows()
    assert bpy.ops.shapesig.clear_index("EXEC_DEFAULT") == {"FINISHED"}
    assert list(own.glob("*.npz")) == []
    assert _untouched(named, files) and sorted(os.listdir(named)) == sorted([*files, index.CACHE_SUBDIR])


def test_index_folder_preference_blend_folder_keeps_its_files(scene, tmp_path, monkeypatch):
    """The Index Folder preference '//' is the .blend's own folder: its other files stay."""
    blend = tmp_path / "shot.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    files = _user_files(tmp_path)
    saved = blend.read_bytes()
    prefs = SimpleNamespace(cache_dir="//", compact_index=False)
    monkeypatch.setattr(library, "get_preferences", lambda context=None: prefs)
    assert os.path.abspath(library.cache_dir(bpy.context)) == str(tmp_path)
    assert bpy.ops.shapesig.build_index("EXEC_DEFAULT") == {"FINISHED"}
    assert bpy.ops.shapesig.rank("EXEC_DEFAULT") == {"FINISHED"}
    assert len(list((tmp_path / index.CACHE_SUBDIR).glob("*.npz"))) == 4  # signature and local entries
    assert bpy.ops.shapesig.clear_index("EXEC_DEFAULT") == {"FINISHED"}
    assert _untouched(tmp_path, files) and blend.read_bytes() == saved
    assert list((tmp_path / index.CACHE_SUBDIR).glob("*.npz")) == []


def test_unusable_index_folder_ranks_the_same_with_one_warning(scene, tmp_path, monkeypatch):
    monkeypatch.setenv(index.CACHE_ENV, str(tmp_path / "good"))
    assert bpy.ops.shapesig.rank("EXEC_DEFAULT") == {"FINISHED"}
    truth = _rows()
    library.CACHES.clear()
    a_file = tmp_path / "index_is_a_file"
    a_file.write_bytes(b"not a folder")
    monkeypatch.setenv(index.CACHE_ENV, str(a_file))
    assert bpy.ops.shapesig.build_index("EXEC_DEFAULT") == {"FINISHED"}
    msg = _message()
    assert msg.count("signature cache off") == 1 and "\n" not in msg, msg
    library.CACHES.clear()
    assert bpy.ops.shapesig.rank("EXEC_DEFAULT") == {"FINISHED"}
    assert _rows() == truth
    msg = _message()
    assert "1 warning(s): signature cache off" in msg and msg.count("signature cache off") == 1, msg
    assert bpy.ops.shapesig.clear_index("EXEC_DEFAULT") == {"FINISHED"}
    assert a_file.read_bytes() == b"not a folder"
