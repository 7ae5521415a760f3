"""A folder holding a .blend read by the threaded commands (``index``, ``dedupe``, ``rank --scheduler threads``):
each exits 0 with every clip ranked (no crash at exit: bpy is never imported by a worker thread of the command
line) and leaves no temp folder (no ``blender_*``, no ``shapesig_*``)."""

import json
import shutil

import pytest

from tests.helpers.hostile import BVH, left_in, make_blend, run_cli

pytest.importorskip("bpy", reason="writing a .blend needs the bpy module")


@pytest.fixture(scope="module")
def blend_library(tmp_path_factory):
    folder = tmp_path_factory.mktemp("lib")
    for name in ("07_01", "09_03"):
        shutil.copy(BVH / f"{name}.bvh", folder / f"{name}.bvh")
    make_blend(folder / "run.blend")
    return folder


@pytest.mark.parametrize("command", ["index", "dedupe", "rank"])
def test_threaded_runs_over_a_blend_exit_cleanly(blend_library, tmp_path, command):
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    args = {"index": ["index", blend_library],
            "dedupe": ["dedupe", blend_library, "--out", tmp_path / "report", "--no-plots"],
            "rank": ["rank", BVH / "09_02.bvh", blend_library, "--scheduler", "threads"]}[command]
    code, out, err, _rss = run_cli(args + ["--cache", tmp_path / "cache", "--json", "--no-progress"], tmp)
    assert code == 0, err
    got = json.loads(out)
    if command == "rank":  # every clip of the folder ranked: the two takes and the .blend's action
        assert len(got["results"]) == 3, got
    elif command == "index":
        assert got["clips"] == 3 and not got.get("skipped"), got
    assert left_in(tmp) == []
