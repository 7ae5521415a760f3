"""The panel's folder library with hostile files (a FIFO, a link to /dev/zero, a dangling and a looping link named
*.bvh beside real CMU takes): Build Index and Find Similar finish, rank the real clips and warn once about the four
files skipped; the folder files are hashed inside the progress loop (one per step), never before it.

An alarm turns a hang on the FIFO into a failure; the assertions are on the outcome."""

import contextlib
import io
import pathlib
import signal

import pytest

bpy = pytest.importorskip("bpy")

from blender_shapesig.search import library, rank_job  # noqa: E402
from blender_shapesig.core import search as search
from blender_shapesig.core.io import sources  # noqa: E402
from tests.helpers.hostile import hostile_library  # noqa: E402

BVH = pathlib.Path(__file__).resolve().parents[2] / "data" / "bvh"
REAL = ("07_02", "08_01", "09_02")
SKIP_LINE = "skipped 4 files that are not regular files or cannot be read: d.bvh, l.bvh, x.bvh, z.bvh"


@pytest.fixture
def alarm():
    def ring(_sig, _frame):
        raise TimeoutError("hung on a hostile file")

    old = signal.signal(signal.SIGALRM, ring)
    signal.alarm(300)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, old)


@pytest.fixture
def folder_search(empty_file, monkeypatch, tmp_path, alarm):
    """A walk's armature (its action the query) and a folder library of three takes and four hostile files."""
    monkeypatch.setenv(search.CACHE_ENV, str(tmp_path / "index"))
    library.CACHES.clear()
    lib = hostile_library(tmp_path / "lib", REAL)
    try:
        bpy.ops.import_anim.bvh.get_rna_type()
    except (AttributeError, KeyError):
        import addon_utils

        addon_utils.enable("io_anim_bvh", default_set=False)
    with contextlib.redirect_stdout(io.StringIO()):
        bpy.ops.import_anim.bvh(filepath=str(BVH / "07_01.bvh"), rotate_mode="NATIVE", frame_start=1,
                                use_fps_scale=False, update_scene_fps=False, update_scene_duration=False)
    s = bpy.context.scene.shapesig
    s.use_file_actions, s.use_folders, s.folders, s.crop_start, s.fps = False, True, str(lib), 2, 120.0
    yield s
    library.CACHES.clear()


def _message():
    return bpy.context.window_manager.shapesig_results.message


def test_build_index_and_find_similar_finish_with_one_warning(folder_search):
    assert bpy.ops.shapesig.build_index() == {"FINISHED"}
    assert _message().startswith("index: 4 of 4 clips, 4 computed, 0 already indexed") and SKIP_LINE in _message()
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    rows = bpy.context.window_manager.shapesig_results.results
    assert sorted(r.name for r in rows) == sorted(REAL)
    assert rows[0].name in ("07_02", "08_01")  # walks first
    assert _message().count("skipped 4 files") == 1 and SKIP_LINE in _message()


def test_folder_files_are_hashed_inside_the_progress_loop(folder_search, monkeypatch):
    hashed = []
    real_key = sources.file_key
    monkeypatch.setattr(sources, "file_key", lambda path, extra="": hashed.append(path) or real_key(path, extra))
    job = rank_job.RankJob(bpy.context, folder_search)
    assert hashed == [] and len(job.skipped) == 4  # the hostile files are skipped unopened at discovery
    job.step()  # the query
    assert hashed == []
    job.step()
    assert [pathlib.Path(p).stem for p in hashed] == [REAL[0]]
    job.run()
    assert sorted(pathlib.Path(p).stem for p in hashed) == sorted(REAL)
    assert SKIP_LINE in job.store()


def test_a_library_of_hostile_files_only_is_a_clear_error(folder_search):
    folder = pathlib.Path(folder_search.folders)
    for name in REAL:
        (folder / f"{name}.bvh").unlink()
    with pytest.raises(RuntimeError, match="the library is empty.*skipped 4 files"):
        bpy.ops.shapesig.rank()
