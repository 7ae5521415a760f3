"""Enabling the add-on compiles numba's DP kernels into numba's on-disk cache in a child process (never a thread
of Blender: LLVM compiling beside Blender's own work crashed a headless session), and disabling it stops a warm-up
still running, so nothing writes into a folder being uninstalled."""

import os
import sys

import pytest

bpy = pytest.importorskip("bpy")
pytest.importorskip("numba")


def test_enable_fills_numba_cache_from_a_child_process(addon, tmp_path, monkeypatch):
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))  # the child inherits it: a cold cache of its own
    before = len(addon._WARM_UP)
    addon._warm_up_kernels()
    assert len(addon._WARM_UP) == before + 1
    thread = addon._WARM_UP[-1]
    assert thread.proc.pid != os.getpid()
    thread.join(timeout=600)
    assert not thread.is_alive() and thread.proc.returncode == 0
    cached = {p.name.split("-")[0] for p in tmp_path.rglob("*.nbi")}
    assert any(name.startswith("_dp_kernels.") for name in cached), cached
    addon._WARM_UP.remove(thread)


def test_disable_stops_a_warm_up_still_running(addon, tmp_path, monkeypatch):
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))  # a cold cache: the compile takes seconds
    addon.unregister()
    addon.register()
    thread = addon._WARM_UP[-1]
    proc = thread.proc
    assert proc.args[0] == sys.executable
    addon.unregister()  # right after enabling
    try:
        assert not addon._WARM_UP and not thread.is_alive()
        assert proc.poll() is not None  # stopped (or finished), never left writing
    finally:
        addon.register()  # the session's add-on, as the other tests expect it
