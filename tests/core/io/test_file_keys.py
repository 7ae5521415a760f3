"""File keys remembered between processes (``file_keys.load_file_keys`` / ``file_keys_record``, kept by the command
line in the cache folder): a file whose size, mtime, inode and change time are the recorded ones is keyed without
being read; an edit that restores size and mtime (its change time moves) is read again, as is a file recorded while
it could still be changing (git's racy rule); the command line's second ``rank`` reads no library file to key it
and prints what the first printed."""

import hashlib
import json
import os
import pathlib
import subprocess
import sys
import time

import pytest

from blender_shapesig.core.io import file_keys, sources

ROOT = pathlib.Path(__file__).resolve().parents[3]
BVH = ROOT / "tests" / "data" / "bvh"


@pytest.fixture
def fresh(monkeypatch):
    """An empty memory of file keys (a new process), and a count of the files hashed."""
    monkeypatch.setattr(file_keys, "_FILE_KEYS", {})
    monkeypatch.setattr(file_keys, "_RECORDED", {})
    monkeypatch.setattr(file_keys, "_HASHED", {})
    hashed = []
    real = hashlib.sha1

    def counting(*a):
        hashed.append(1)
        return real(*a)

    monkeypatch.setattr(file_keys.hashlib, "sha1", counting)
    return hashed


def _new_process(monkeypatch, record):
    monkeypatch.setattr(file_keys, "_FILE_KEYS", {})
    monkeypatch.setattr(file_keys, "_RECORDED", {})
    monkeypatch.setattr(file_keys, "_HASHED", {})
    return sources.load_file_keys(json.loads(json.dumps(record)))  # as stored: through JSON


def test_a_recorded_file_is_keyed_without_reading_it(tmp_path, fresh, monkeypatch):
    paths = [tmp_path / f"{i}.bvh" for i in range(3)]
    for i, p in enumerate(paths):
        p.write_bytes(f"clip {i}\n".encode())
    time.sleep(file_keys.RACY_NS / 1e9 + 0.1)  # the files settle before they are hashed
    keys = [sources.file_key(p, "x") for p in paths]
    assert len(fresh) == 3
    record = sources.file_keys_record()
    assert _new_process(monkeypatch, record) == 3
    fresh.clear()
    assert [sources.file_key(p, "x") for p in paths] == keys and not fresh
    # the keys are the files' SHA-1s (an independent hash of the bytes)
    assert keys[0].split(":")[1] == hashlib.new("sha1", paths[0].read_bytes()).hexdigest()
    assert sources.file_keys_record() is None  # nothing hashed: nothing to record again


def test_an_edit_that_restores_size_and_mtime_is_read_again(tmp_path, fresh, monkeypatch):
    p = tmp_path / "a.bvh"
    p.write_bytes(b"clip A\n")
    time.sleep(file_keys.RACY_NS / 1e9 + 0.1)
    before = sources.file_key(p)
    record = sources.file_keys_record()
    st = p.stat()
    p.write_bytes(b"clip B\n")  # same size
    os.utime(p, ns=(st.st_atime_ns, st.st_mtime_ns))  # mtime put back: only the change time tells
    _new_process(monkeypatch, record)
    fresh.clear()
    after = sources.file_key(p)
    assert fresh and after != before
    assert after.split(":")[1] == hashlib.new("sha1", b"clip B\n").hexdigest()


def test_a_file_recorded_while_it_could_change_is_read_again(tmp_path, fresh, monkeypatch):
    p = tmp_path / "a.bvh"
    p.write_bytes(b"clip A\n")
    key = sources.file_key(p)  # hashed at once: within the racy window of its change
    _new_process(monkeypatch, sources.file_keys_record())
    fresh.clear()
    assert sources.file_key(p) == key and len(fresh) == 1


def test_malformed_records_are_ignored(tmp_path, fresh, monkeypatch):
    p = tmp_path / "a.bvh"
    p.write_bytes(b"clip A\n")
    st = p.stat()
    bad = {"files": {str(p): [st.st_size, st.st_mtime_ns, st.st_ino, st.st_ctime_ns, "0" * 40, "soon"],
                     str(tmp_path / "b"): "row", 3: [1]}}
    assert _new_process(monkeypatch, bad) == 0
    assert _new_process(monkeypatch, None) == 0 and _new_process(monkeypatch, {"files": []}) == 0
    assert sources.file_key(p).split(":")[1] == hashlib.new("sha1", b"clip A\n").hexdigest()


def test_the_second_rank_reads_no_library_file_to_key_it(tmp_path):
    lib = tmp_path / "lib"
    lib.mkdir()
    for name in ("07_01", "07_02", "09_02"):
        (lib / f"{name}.bvh").write_bytes((BVH / f"{name}.bvh").read_bytes())
    time.sleep(file_keys.RACY_NS / 1e9 + 0.1)
    cmd = ["rank", str(lib / "07_01.bvh"), str(lib), "--json", "--no-progress", "--cache", str(tmp_path / "cache")]
    # the command line in a fresh process, counting the files it hashes to key them
    probe = ("import runpy, sys, hashlib\n"
             "from blender_shapesig.core.io import file_keys\n"
             "seen = []\n"
             "real = hashlib.sha1\n"
             "file_keys.hashlib = type('H', (), {'sha1': staticmethod(lambda *a: (seen.append(1), real(*a))[1])})\n"
             "sys.argv = ['blender_shapesig'] + sys.argv[1:]\n"
             "try:\n"
             "    runpy.run_module('blender_shapesig', run_name='__main__')\n"
             "finally:\n"
             "    sys.stderr.write(f'hashed {len(seen)}\\n')\n")
    runs = [subprocess.run([sys.executable, "-c", probe] + cmd, capture_output=True, text=True, cwd=ROOT,
                           timeout=600) for _ in range(2)]
    assert all(r.returncode == 0 for r in runs), runs[0].stderr + runs[1].stderr
    assert "hashed 3" in runs[0].stderr and "hashed 0" in runs[1].stderr  # the query is one of the three
    assert json.loads(runs[1].stdout)["results"] == json.loads(runs[0].stdout)["results"]
