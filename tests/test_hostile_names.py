"""File names are data: a name with mathtext (``$...$``), a newline, an escape sequence or bytes that are not UTF-8
makes no command fail, print a line of its own or draw mathtext, and ``FILE#NAME`` is split only when no clip file
of that whole name exists (a file named ``walk.glb#copy.glb`` is that file)."""

import json
import os
import shutil

import pytest

from blender_shapesig.core.io.sources import ClipSpec
from blender_shapesig.core.io.text import plot_name, shown_name
from tests.helpers.hostile import BVH, left_in, make_gltf, run_cli

MATHTEXT = "take $\\nope{x}$ one.bvh"  # matplotlib's mathtext cannot parse it: drawn literally or it fails
NEWLINE = "walk\nblender_shapesig: error: fake.bvh"
ESCAPE = "run\x1b[2J.bvh"
NOT_UTF8 = b"caf\xe9.bvh"


@pytest.fixture
def named_library(tmp_path):
    lib = tmp_path / "lib"
    lib.mkdir()
    shutil.copy(BVH / "07_01.bvh", lib / "07_01.bvh")
    shutil.copy(BVH / "07_01.bvh", lib / MATHTEXT)  # an exact copy: a cluster, so its plot is drawn
    shutil.copy(BVH / "09_02.bvh", lib / NEWLINE)
    shutil.copy(BVH / "09_03.bvh", lib / ESCAPE)
    shutil.copy(BVH / "07_02.bvh", os.path.join(os.fsencode(lib), NOT_UTF8))
    return lib


def _no_fake_lines(text):
    lines = text.splitlines()
    assert not any(ln.startswith("blender_shapesig: error") for ln in lines), text
    assert "\x1b" not in text and "Traceback" not in text, text


@pytest.mark.parametrize("command", ["dedupe", "matrix", "rank"])
def test_hostile_names_fail_no_command(named_library, tmp_path, command):
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    clips = sorted(os.listdir(os.fsencode(named_library)))
    args = {"dedupe": ["dedupe", named_library, "--out", tmp_path / "report", "--no-cache"],
            "matrix": ["matrix", *[os.path.join(os.fsencode(named_library), n) for n in clips], "--out",
                       tmp_path / "m", "--metric", "sim2"],
            "rank": ["rank", BVH / "09_02.bvh", named_library, "--thumbnails", tmp_path / "pics", "--cache",
                     tmp_path / "c"]}[command]
    args = [os.fsdecode(a) if isinstance(a, bytes) else a for a in args]
    for extra in ([], ["--json"]):  # a strict UTF-8 terminal: no traceback for the name that is not UTF-8
        if command != "rank" and not extra:
            continue
        out_dir = tmp_path / ("report" if command == "dedupe" else "m")
        code, out, err, _rss = run_cli(args + ["--no-progress", "--overwrite"] + extra, tmp,
                                       env={"PYTHONIOENCODING": "utf-8:strict"})
        assert code == 0, err
        _no_fake_lines(out + err)
    if command == "dedupe":
        report = json.loads((tmp_path / "report" / "report.json").read_text())
        assert report["clusters"] and (tmp_path / "report" / "report.html").stat().st_size > 0
    elif command == "matrix":
        assert sorted(os.listdir(tmp_path / "m")) == ["dendrogram.png", "matrix.csv", "matrix.npy", "mds.png"]
    else:
        assert len(json.loads(out)["results"]) == 5 and len(os.listdir(tmp_path / "pics")) == 6
        assert "\\n" in run_cli(args + ["--no-progress", "--overwrite"], tmp)[1]  # the newline shown as \n
    assert left_in(tmp) == []


def test_names_are_shown_escaped():
    assert shown_name(NEWLINE) == "walk\\nblender_shapesig: error: fake.bvh"
    assert shown_name(ESCAPE) == "run\\x1b[2J.bvh"
    assert shown_name(os.fsdecode(NOT_UTF8)) == "caf\\xe9.bvh"
    assert plot_name(MATHTEXT) == "take \\$\\nope{x}\\$ one.bvh"


def test_a_file_whose_name_holds_a_hash_is_that_file(tmp_path):
    pytest.importorskip("bpy", reason="Blender's glTF exporter writes the file")
    glb = make_gltf(tmp_path / "walk.glb", fmt="GLB")
    odd = tmp_path / "walk.glb#copy.glb"
    shutil.copy(glb, odd)
    spec = ClipSpec.parse(str(odd))
    assert spec.path == str(odd) and spec.action is None
    assert ClipSpec.parse(f"{glb}#09_02").action == "09_02"  # an animation of the file that exists
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    code, out, err, _ = run_cli(["rank", BVH / "09_02.bvh", odd, "--no-cache", "--json", "--no-progress",
                                 "--metric", "sim3"], tmp)
    assert code == 0, err
    assert [r["clip"] for r in json.loads(out)["results"]] == ["walk.glb#copy"]
