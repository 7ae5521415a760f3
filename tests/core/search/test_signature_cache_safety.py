"""The signature cache owns only what it wrote: its own marked subfolder of the folder a user names,
where it deletes only its own files; a safe per-user fallback folder; and a folder it cannot use (a full disk, a
read-only folder, a path that is a file, an unsafe fallback) gives the same ranking as no cache plus exactly one
warning. Rankings are compared with an in-memory cache (the truth: no disk at all)."""

import errno
import os
import subprocess
import sys

import pytest

from blender_shapesig.core import search as search
from blender_shapesig.core.io.acclaim import load_acclaim
from blender_shapesig.core.search import store as store_mod

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
ACC = os.path.join(ROOT, "tests", "data", "acclaim")
TAKES = ("07_01", "07_02", "09_02", "09_03")


@pytest.fixture(scope="module")
def clips():
    skel = {"07": "07-walk.asf", "09": "09-run.asf"}
    return [load_acclaim(os.path.join(ACC, f"{t}.amc"), os.path.join(ACC, skel[t[:2]])) for t in TAKES]


@pytest.fixture(scope="module")
def truth(clips):
    """The ranking with no disk cache at all."""
    return _ranked(search.rank_clips(clips[0], clips[1:], cache=search.SignatureCache(), metric="sim"))


def _ranked(results):
    return [(r.name, r.distance) for r in results]


def _user_files(folder):
    """A user's files in a folder the cache is pointed at: an .npz it did not write, a note, a sub-folder."""
    os.makedirs(os.path.join(folder, "mine"), exist_ok=True)
    files = {"keep.npz": b"PK\x05\x06" + bytes(18), "notes.txt": b"my notes\n",
             os.path.join("mine", "old.npz"): b"not the cache's"}
    for name, data in files.items():
        with open(os.path.join(folder, name), "wb") as f:
            f.write(data)
    return files


def _assert_untouched(folder, files):
    for name, data in files.items():
        with open(os.path.join(folder, name), "rb") as f:
            assert f.read() == data, name


# ------------------------------------------------------------------------- only its own folder, own files

def test_user_files_in_the_named_folder_survive_rank_outdated_format_and_clear(clips, truth, tmp_path):
    files = _user_files(tmp_path)
    cache = search.SignatureCache(tmp_path)
    assert cache.path == os.path.join(tmp_path, search.CACHE_SUBDIR) and cache.warning is None
    assert _ranked(search.rank_clips(clips[0], clips[1:], cache=cache, metric="sim")) == truth
    assert cache.disk_usage()[0] == 4
    # a user's file inside the cache's own folder too: not a name the cache writes
    own = tmp_path / search.CACHE_SUBDIR
    (own / "keep.npz").write_bytes(b"user data")
    (own / "ABCDEF0123456789ABCDEF0123456789ABCDEF01.npz").write_bytes(b"upper-case hex: not a name it writes")
    # an outdated format removes the cache's own files only
    (own / "manifest.json").write_text('{"format": -1}')
    reopened = search.SignatureCache(tmp_path)
    assert reopened.stats["invalid"] == 1 and reopened.disk_usage()[0] == 0
    assert (own / "keep.npz").read_bytes() == b"user data"
    assert (own / "ABCDEF0123456789ABCDEF0123456789ABCDEF01.npz").exists()
    assert _ranked(search.rank_clips(clips[0], clips[1:], cache=reopened, metric="sim")) == truth
    reopened.clear()
    assert reopened.disk_usage()[0] == 0
    assert sorted(os.listdir(own)) == ["ABCDEF0123456789ABCDEF0123456789ABCDEF01.npz", "CACHEDIR.TAG", "keep.npz",
                                       "manifest.json"]
    _assert_untouched(tmp_path, files)


def test_a_folder_of_its_name_that_it_did_not_mark_is_refused_untouched(clips, truth, tmp_path):
    own = tmp_path / search.CACHE_SUBDIR
    own.mkdir()
    files = _user_files(own)
    (own / ("0" * 40 + ".npz")).write_bytes(b"looks like an entry, but the folder is not the cache's")
    (own / "manifest.json").write_text('{"format": -1}')
    before = sorted(os.listdir(own))
    cache = search.SignatureCache(tmp_path)
    assert cache.path is None and "did not write" in cache.warning and "\n" not in cache.warning
    ranked = search.rank_clips(clips[0], clips[1:], cache=cache, metric="sim")
    assert _ranked(ranked) == truth and ranked.warnings == [cache.warning]
    cache.clear()
    assert sorted(os.listdir(own)) == before
    _assert_untouched(own, files)


def _cli_rank(args, env_extra=None):
    env = dict(os.environ, PYTHONPATH=ROOT, **(env_extra or {}))
    amc = [os.path.join(ACC, f"{t}.amc") for t in ("07_01", "07_02")]
    cmd = [sys.executable, "-m", "blender_shapesig", "rank", amc[0], *amc, "--asf", os.path.join(ACC, "07-walk.asf"),
           "--json", "--no-progress", *args]
    return subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, env=env, timeout=600)


def test_cli_rank_keeps_a_users_files_in_the_cache_folder(tmp_path):
    """``rank A B --cache DIR`` and ``$SHAPESIG_CACHE_DIR`` used to delete DIR/keep.npz; the ranking is the
    --no-cache one; a cache folder that is a file is an error with --cache, and with $SHAPESIG_CACHE_DIR gives the
    same ranking and one warning line."""
    import json

    named = tmp_path / "named"
    named.mkdir()
    files = _user_files(named)
    off = _cli_rank(["--no-cache"])
    assert off.returncode == 0, off.stderr
    first = _cli_rank(["--cache", str(named)])
    assert first.returncode == 0, first.stderr
    again = _cli_rank(["--cache", str(named)])
    assert json.loads(again.stdout)["cache"]["misses"] == 0  # the cache works: everything was a hit
    env_dir = tmp_path / "env"
    env_dir.mkdir()
    env_files = _user_files(env_dir)
    by_env = _cli_rank([], {"SHAPESIG_CACHE_DIR": str(env_dir)})
    assert by_env.returncode == 0, by_env.stderr
    _assert_untouched(named, files)
    _assert_untouched(env_dir, env_files)
    results = json.loads(off.stdout)["results"]
    for p in (first, again, by_env):
        assert json.loads(p.stdout)["results"] == results and "warning" not in p.stderr
    # the folder is a file: named by --cache, an error (docs/cli.md: exit 2, one line); named by
    # $SHAPESIG_CACHE_DIR, the ranking without a cache and one warning line; the file unchanged either way
    a_file = tmp_path / "cache_is_a_file"
    a_file.write_bytes(b"a user's file")
    p = _cli_rank(["--cache", str(a_file)])
    lines = [ln for ln in p.stderr.splitlines() if ln.strip()]
    assert p.returncode == 2 and len(lines) == 1 and lines[0].startswith("blender_shapesig: error: --cache"), p.stderr
    p = _cli_rank([], {"SHAPESIG_CACHE_DIR": str(a_file)})
    assert p.returncode == 0 and json.loads(p.stdout)["results"] == results
    lines = [ln for ln in p.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("blender_shapesig: warning: signature cache off"), p.stderr
    assert a_file.read_bytes() == b"a user's file"


# --------------------------------------------------------------------------------- the per-user fallback

@pytest.fixture
def no_home(monkeypatch, tmp_path):
    """No $SHAPESIG_CACHE_DIR, no XDG_CACHE_HOME, a home that does not exist, and a temporary folder of our own:
    ``default_cache_dir`` falls back to the per-user folder there."""
    monkeypatch.delenv(search.CACHE_ENV, raising=False)
    monkeypatch.delenv("XDG_CACHE_HOME", raising=False)
    monkeypatch.setenv("HOME", str(tmp_path / "no_such_home"))
    shared = tmp_path / "shared_tmp"
    shared.mkdir()
    monkeypatch.setattr("tempfile.tempdir", str(shared))
    assert search.default_cache_dir() == search.private_cache_dir()
    assert os.path.dirname(search.private_cache_dir()) == str(shared)
    return search.private_cache_dir()


def test_fallback_folder_is_private(no_home, clips, truth):
    cache = search.SignatureCache(search.default_cache_dir())
    assert cache.warning is None and cache.path == os.path.join(no_home, search.CACHE_SUBDIR)
    assert os.stat(no_home).st_mode & 0o777 == 0o700
    assert _ranked(search.rank_clips(clips[0], clips[1:], cache=cache, metric="sim")) == truth
    assert cache.disk_usage()[0] == 4


def test_fallback_folder_planted_as_a_symlink_is_refused(no_home, clips, truth, tmp_path):
    elsewhere = tmp_path / "attacker"
    elsewhere.mkdir()
    os.symlink(elsewhere, no_home)
    cache = search.SignatureCache(search.default_cache_dir())
    assert cache.path is None and "symbolic link" in cache.warning
    ranked = search.rank_clips(clips[0], clips[1:], cache=cache, metric="sim")
    assert _ranked(ranked) == truth and ranked.warnings == [cache.warning]
    assert os.listdir(elsewhere) == []  # nothing written through the link


def test_fallback_folder_writable_by_others_or_a_file_is_refused(no_home, tmp_path):
    os.mkdir(no_home)
    os.chmod(no_home, 0o777)
    cache = search.SignatureCache(no_home)
    assert cache.path is None and "writable by other users" in cache.warning
    assert os.listdir(no_home) == []
    os.rmdir(no_home)
    with open(no_home, "w") as f:
        f.write("a file")
    cache = search.SignatureCache(no_home)
    assert cache.path is None and "not a folder" in cache.warning


def test_fallback_folder_of_another_user_is_refused(no_home, monkeypatch):
    os.mkdir(no_home, 0o700)
    real = os.lstat

    def lstat(path, *args, **kwargs):  # the folder as another user's (chown would need root)
        st = real(path, *args, **kwargs)
        if os.fspath(path) != no_home:
            return st
        fields = list(st)
        fields[4] = os.getuid() + 1  # st_uid
        return os.stat_result(fields)

    monkeypatch.setattr(store_mod.os, "lstat", lstat)
    cache = search.SignatureCache(no_home)
    assert cache.path is None and "belongs to another user" in cache.warning
    assert os.listdir(no_home) == []


# ------------------------------------------------------------------- write errors: memory only, one warning

@pytest.mark.parametrize("error", [OSError(errno.ENOSPC, "No space left on device"),
                                   PermissionError(errno.EACCES, "Permission denied"),
                                   OSError(errno.EROFS, "Read-only file system")])
def test_unwritable_at_open_gives_the_memory_ranking_and_one_warning(clips, truth, tmp_path, monkeypatch, error):
    def fail(*args, **kwargs):
        raise error

    monkeypatch.setattr(store_mod.os, "replace", fail)
    cache = search.SignatureCache(tmp_path)
    assert cache.path is None and error.strerror in cache.warning
    ranked = search.rank_clips(clips[0], clips[1:], cache=cache, metric="sim")
    assert _ranked(ranked) == truth and ranked.warnings == [cache.warning]


@pytest.mark.parametrize("error", [OSError(errno.ENOSPC, "No space left on device"),
                                   PermissionError(errno.EACCES, "Permission denied")])
def test_unwritable_after_open_gives_the_memory_ranking_and_one_warning(clips, truth, tmp_path, monkeypatch, error):
    cache = search.SignatureCache(tmp_path, memory_limit=1)  # a tiny memory limit: nothing may be dropped
    assert cache.warning is None
    calls = []

    def fail(*args, **kwargs):
        calls.append(args)
        raise error

    monkeypatch.setattr("tempfile.mkstemp", fail)  # (the store imports tempfile when it writes)
    ranked = search.rank_clips(clips[0], clips[1:], cache=cache, metric="sim")
    assert _ranked(ranked) == truth
    assert len(calls) == 1  # one failed write, then memory only (not one attempt and warning per clip)
    assert ranked.warnings == [cache.warning] and error.strerror in cache.warning
    assert cache.disk_usage()[0] == 0
    again = search.rank_clips(clips[0], clips[1:], cache=cache, metric="sim")  # the memory layer still answers
    assert _ranked(again) == truth and again.stats["misses"] == 0


def test_pack_that_cannot_be_saved_gives_one_warning(clips, truth, tmp_path, monkeypatch):
    cache = search.SignatureCache(tmp_path)
    real = search.SignatureCache._atomic_write

    def no_pack(self, target, data):
        if os.path.basename(target) == store_mod._PACK:
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(self, target, data)

    monkeypatch.setattr(search.SignatureCache, "_atomic_write", no_pack)
    ranked = search.rank_clips(clips[0], clips[1:], cache=cache, metric="sim")
    assert _ranked(ranked) == truth and ranked.warnings == [cache.warning]
    assert "No space left" in cache.warning and cache.disk_usage()[0] == 4  # the entries were written before
    info = search.build_index(search.clip_items(clips), cache=cache)
    assert info["warnings"] == [cache.warning]


def test_read_only_cache_folder_still_reads_and_warns_once(clips, truth, tmp_path, monkeypatch):
    """A full index on a read-only folder (simulated: tests may run as root, where chmod does not stop writes):
    every lookup is a hit, nothing is written, one warning when the pack cannot be refreshed."""
    search.rank_clips(clips[0], clips[1:], cache=search.SignatureCache(tmp_path), metric="sim")
    own = tmp_path / search.CACHE_SUBDIR
    (own / store_mod._PACK).unlink()  # the pack must be written again: the write fails

    def read_only(*args, **kwargs):
        raise OSError(errno.EROFS, "Read-only file system")

    monkeypatch.setattr("tempfile.mkstemp", read_only)
    cache = search.SignatureCache(tmp_path)
    ranked = search.rank_clips(clips[0], clips[1:], cache=cache, metric="sim")
    assert _ranked(ranked) == truth and ranked.stats["misses"] == 0
    assert ranked.warnings == [cache.warning] and "Read-only" in cache.warning
