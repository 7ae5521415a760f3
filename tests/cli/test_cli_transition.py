"""The command line's ``transition`` on real CMU clips across rigs and rates (a Daz BVH walk at 120 fps into a
Character Creator BVH run at 60 fps, an ASF/AMC run, a bridge folder): the JSON of interfaces.md, the joined clip
written as BVH and as .blend read back in a fresh process as the same motion (A's skeleton, the reported cut and
frames), ``blend --out FILE.bvh``, and the one-line refusals that create nothing and never replace a file."""

import json
import os
import pathlib
import subprocess
import sys

import numpy as np
import pytest

from blender_shapesig import cli
from blender_shapesig.core.clip.skeleton import aligned_rotations
from blender_shapesig.core.io.bvh import load_bvh

ROOT = pathlib.Path(__file__).resolve().parents[2]
DATA = ROOT / "tests" / "data"
WALK, CC_RUN = DATA / "bvh" / "07_01.bvh", DATA / "cross_rig" / "002_03.bvh"
AMC_RUN, RUN_ASF = DATA / "acclaim" / "09_02.amc", DATA / "acclaim" / "09-run.asf"


def _run(*args):
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.run([sys.executable, "-m", "blender_shapesig", *map(str, args)], capture_output=True,
                          text=True, env=env, cwd=str(ROOT), timeout=600)


def test_bvh_out_across_rigs_and_rates(tmp_path, capsys):
    out = tmp_path / "walk_run.bvh"
    assert cli.main(["transition", str(WALK), str(CC_RUN), "--frames", "15", "--out", str(out), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert set(report) >= {"cut", "cuts", "frames", "seconds", "out"}
    assert report["frames"] == 15 and report["out"] == str(out)
    assert report["cut"] == report["cuts"][0] and len(report["cuts"]) == 5
    assert [c["cost"] for c in report["cuts"]] == sorted(c["cost"] for c in report["cuts"])
    back = load_bvh(out)
    walk = load_bvh(WALK)
    assert set(back.bones) == set(walk.bones) and back.fps == 120.0
    assert report["seconds"] == pytest.approx((back.frames - 1) / 120.0)
    # A as it is (after the reader's trim of the first frames) up to its cut
    from blender_shapesig.core.io.sources import read_one

    a = read_one(str(WALK), bone_map="none")
    i = report["cut"]["a_frame"]
    idx = [back.bones.index(b) for b in a.bones]
    np.testing.assert_allclose(back.rotations[:i + 1, idx], a.rotations[:i + 1], atol=1e-5)


def test_blend_out_reopens_as_the_bvh_out(tmp_path):
    pytest.importorskip("bpy")
    args = [WALK, AMC_RUN, "--asf", RUN_ASF, "--cut", "150:30", "--frames", "12", "--json", "--no-progress"]
    p1 = _run("transition", *args, "--out", tmp_path / "j.bvh")
    p2 = _run("transition", *args, "--out", tmp_path / "j.blend", "--name", "walk_into_run")
    assert p1.returncode == 0 and p2.returncode == 0, p1.stderr + p2.stderr
    r1, r2 = json.loads(p1.stdout), json.loads(p2.stdout)
    assert r1["cut"]["a_frame"] == 150 and r1["cut"]["b_frame"] == 30 and r1["cut"] == r2["cut"]
    from blender_shapesig.core.io.sources import read

    blend = read(f"{tmp_path / 'j.blend'}#walk_into_run", bone_map="none", trim="none")[0]
    bvh = load_bvh(tmp_path / "j.bvh")
    assert blend.frames == bvh.frames == r2["total_frames"]
    idx = [bvh.bones.index(b) for b in blend.bones]
    err = np.abs(aligned_rotations(blend) - bvh.rotations[:, idx]).max()
    assert err < 1e-4


def test_bridge_folder_makes_the_frames(tmp_path, capsys):
    out = tmp_path / "b.bvh"
    assert cli.main(["transition", str(WALK), str(DATA / "bvh" / "09_03.bvh"), "--frames", "20", "--bridge",
                     str(DATA / "bvh"), "--out", str(out), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["generator"]["generator"] == "bridge" and report["generator"]["frames"] > 0
    assert load_bvh(out).frames == report["total_frames"]


def test_blend_writes_bvh(tmp_path, capsys):
    out = tmp_path / "half.bvh"
    assert cli.main(["blend", str(WALK), str(DATA / "bvh" / "07_02.bvh"), "--weight", "0.5", "--feet", "none",
                     "--out", str(out), "--json", "--no-progress"]) == 0
    report = json.loads(capsys.readouterr().out)
    back = load_bvh(out)
    assert back.frames == report["frames"][0] and set(back.bones) == set(load_bvh(WALK).bones)


@pytest.mark.parametrize("extra,message", [
    (["--cut", "5:999"], "outside clip"),
    (["--cut", "a:b"], "--cut: expected I:J"),
    (["--frames", "0"], "--frames"),
    (["--out-exists"], "exists: give --overwrite to replace it"),
    (["--out-source"], "is one of the source files"),
    (["--out-txt"], "must be a .blend or .bvh"),
])
def test_refusals_are_one_line_and_create_nothing(tmp_path, capsys, extra, message):
    out = tmp_path / "x.bvh"
    if extra == ["--out-exists"]:
        out.write_text("mine")
        extra = []
    elif extra == ["--out-source"]:
        out = WALK
        extra = []
    elif extra == ["--out-txt"]:
        out = tmp_path / "x.txt"
        extra = []
    before = sorted(os.listdir(tmp_path))
    code = cli.main(["transition", str(WALK), str(CC_RUN), *extra, "--out", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and message in err[0] and "Traceback" not in err[0]
    assert sorted(os.listdir(tmp_path)) == before
    if out.name == "x.bvh" and out.exists():
        assert out.read_text() == "mine"


def test_blend_never_replaces_a_bvh(tmp_path, capsys):
    out = tmp_path / "mine.bvh"
    out.write_text("mine")
    code = cli.main(["blend", str(WALK), str(CC_RUN), "--weight", "0.5", "--out", str(out), "--no-progress"])
    assert code == 2 and "give --overwrite" in capsys.readouterr().err and out.read_text() == "mine"
