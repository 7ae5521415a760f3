"""A named cache folder is not trusted: entries replaced by FIFOs (or links) are never opened (a rank that would
hang on ``np.load`` ranks from recomputed entries), a cache folder that is a symbolic link, belongs to another user
or is writable by every user is refused, and the temporary files of a write that never finished are swept."""

import json
import os
import shutil
import time

import pytest

from blender_shapesig.core.search import store as store_module
from blender_shapesig.core.search.cache_folder import CACHE_SUBDIR
from blender_shapesig.core.search.store import SignatureCache
from tests.helpers.hostile import BVH, left_in, run_cli


@pytest.fixture
def indexed(tmp_path):
    lib = tmp_path / "lib"
    lib.mkdir()
    for name in ("07_01", "09_03", "13_32"):
        shutil.copy(BVH / f"{name}.bvh", lib / f"{name}.bvh")
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    code, _out, err, _ = run_cli(["index", lib, "--cache", tmp_path / "cache", "--no-progress"], tmp)
    assert code == 0, err
    return lib, tmp_path / "cache" / CACHE_SUBDIR, tmp


def test_fifo_entries_are_never_opened(indexed):
    lib, folder, tmp = indexed
    replaced = 0
    for name in os.listdir(folder):
        if name.endswith((".npz", ".bin", ".json")) and name != "manifest.json":
            os.remove(folder / name)
            os.mkfifo(folder / name)
            replaced += 1
    assert replaced >= 4
    code, out, err, _ = run_cli(["rank", BVH / "09_02.bvh", lib, "--cache", folder.parent, "--json",
                                 "--no-progress"], tmp, timeout=300)
    assert code == 0, err
    assert sorted(r["clip"] for r in json.loads(out)["results"]) == ["07_01", "09_03", "13_32"]
    assert not any(os.path.exists(folder / n) and not os.path.isfile(folder / n) for n in os.listdir(folder))
    assert left_in(tmp) == []


def test_a_linked_cache_folder_is_refused(tmp_path):
    (tmp_path / "named").mkdir()
    (tmp_path / "elsewhere").mkdir()
    os.symlink(tmp_path / "elsewhere", tmp_path / "named" / CACHE_SUBDIR)
    cache = SignatureCache(tmp_path / "named")
    assert cache.path is None and "symbolic link" in cache.warning
    assert os.listdir(tmp_path / "elsewhere") == []


def test_a_folder_of_another_user_or_writable_by_all_is_refused(tmp_path, monkeypatch):
    SignatureCache(tmp_path / "c")  # made by this user
    monkeypatch.setattr(store_module.os, "getuid", lambda: os.stat(tmp_path).st_uid + 4242)
    cache = SignatureCache(tmp_path / "c")
    assert cache.path is None and "another user" in cache.warning
    monkeypatch.undo()
    os.chmod(tmp_path / "c" / CACHE_SUBDIR, 0o777)
    cache = SignatureCache(tmp_path / "c")
    assert cache.path is None and "every user" in cache.warning


def test_stale_temporary_files_are_swept_at_open(tmp_path):
    folder = tmp_path / "c" / CACHE_SUBDIR
    SignatureCache(tmp_path / "c")
    stale, fresh, mine = folder / ".shapesig-abc123.tmp", folder / ".shapesig-def456.tmp", folder / "notes.txt"
    for f in (stale, fresh, mine):
        f.write_bytes(b"x" * 100)
    old = time.time() - 3600
    os.utime(stale, (old, old))
    os.utime(mine, (old, old))
    SignatureCache(tmp_path / "c")
    assert not stale.exists() and fresh.exists() and mine.exists()  # a write of another process may be under way
