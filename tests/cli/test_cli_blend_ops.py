"""The command line's ``blend`` for animators: three clips, ranges, planted feet (the stance
drift bounds through the command line), loops, masks and their one-line refusals, on real CMU clips."""

import json
import os
import pathlib
import shutil
import subprocess
import sys

import numpy as np
import pytest

from blender_shapesig import cli
from blender_shapesig.core.blend import feet
from blender_shapesig.core.blend import pose_steps
from blender_shapesig.core.io.acclaim import load_acclaim

ROOT = pathlib.Path(__file__).resolve().parents[2]
ACC = ROOT / "tests" / "data" / "acclaim"


@pytest.fixture(scope="module")
def amc(tmp_path_factory):
    """Walks and runs in two folders, each with its one .asf (the skeleton is found beside each clip)."""
    base = tmp_path_factory.mktemp("amc")
    for folder, files in (("walk", ("07-walk.asf", "07_01.amc", "07_02.amc")),
                          ("run", ("09-run.asf", "09_02.amc", "09_05.amc"))):
        (base / folder).mkdir()
        for f in files:
            shutil.copy(ACC / f, base / folder / f)
    return {"w1": str(base / "walk" / "07_01.amc"), "w2": str(base / "walk" / "07_02.amc"),
            "r1": str(base / "run" / "09_02.amc"), "r5": str(base / "run" / "09_05.amc")}


def _blend(*args):
    """The command line in a fresh process (it writes a .blend with bpy): its JSON report."""
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    p = subprocess.run([sys.executable, "-m", "blender_shapesig", "blend", *map(str, args), "--json", "--no-progress"],
                       capture_output=True, text=True, env=env, cwd=str(ROOT), timeout=600)
    assert p.returncode == 0, p.stderr
    return json.loads(p.stdout)


def _read_back(out, action):
    from blender_shapesig.core.io.sources import read

    return read(f"{out}#{action}", bone_map="none", trim="none")[0]


def _angle(Ra, Rb):
    fro = np.sqrt(np.sum((np.asarray(Ra) - np.asarray(Rb)) ** 2, axis=(-2, -1)))
    return float((2.0 * np.arcsin(np.clip(fro / (2.0 * np.sqrt(2.0)), 0.0, 1.0))).max())


def test_three_clips_weight_on_the_first_reproduces_it(amc, tmp_path):
    pytest.importorskip("bpy")
    out = tmp_path / "three.blend"
    report = _blend(amc["w1"], amc["r1"], amc["w2"], "--weight", "1,0,0", "--align", "--out", out)
    assert report["weights"] == [[1.0, 0.0, 0.0]] and report["actions"] == ["07_01_x_09_02_x_07_02_1.00_0.00_0.00"]
    a = load_acclaim(amc["w1"], str(ACC / "07-walk.asf"), axes="blender")
    assert report["frames"] == [a.frames] and report["seconds"] == [pytest.approx((a.frames - 1) / 120)]
    got = _read_back(out, report["actions"][0])
    idx = [a.bones.index(b) for b in got.bones]
    assert _angle(got.rotations, a.rotations[:, idx]) < 1e-3  # float32 keys of the first clip, feet untouched
    assert report["feet"][0]["root_lowered"] == 0.0


@pytest.mark.parametrize("weight", [0.25, 0.5])
def test_ranges_and_planted_feet_meet_the_issue_bounds(amc, tmp_path, weight):
    """07_01 x 09_02, one stride each through --range-a/--range-b, --feet lock by default: the median stance drift
    <= the larger source median + 2 cm and the max <= the larger source max + 5 cm (the issue's criterion)."""
    pytest.importorskip("bpy")
    out = tmp_path / "walk_run.blend"
    report = _blend(amc["w1"], amc["r1"], "--weight", weight, "--range-a", "125:253", "--range-b", "36:126",
                    "--align", "--out", out)
    assert [s["range"] for s in report["sources"]] == [[125, 253], [36, 126]]
    # the weighted average of the ranges' durations
    assert report["seconds"][0] == pytest.approx((1 - weight) * 128 / 120 + weight * 90 / 120, abs=0.5 / 120)
    a = load_acclaim(amc["w1"], str(ACC / "07-walk.asf"), axes="blender").crop(125, 253)
    b = load_acclaim(amc["r1"], str(ACC / "09-run.asf"), axes="blender").crop(36, 126)
    da, db = feet.source_drifts(a), feet.source_drifts(b)
    after = [d for f in report["feet"][0]["feet"] for d in f["drift_after"]]
    before = [d for f in report["feet"][0]["feet"] for d in f["drift_before"]]
    assert len(after) >= 4
    assert np.median(after) <= max(np.median(da), np.median(db)) + 0.02
    assert max(after) <= max(max(da), max(db)) + 0.05
    assert np.median(before) > max(np.median(da), np.median(db)) + 0.02  # unplanted it would fail
    clips = {r["clip"] for r in report["feet"][0]["contacts"]}
    assert clips == {"07_01", "09_02", report["actions"][0]}  # contacts of both sources and of the blend


def test_loop_closes_the_written_action(amc, tmp_path):
    pytest.importorskip("bpy")
    out = tmp_path / "loop.blend"
    report = _blend(amc["w1"], amc["r1"], "--weight", "0.5", "--loop", "--out", out)
    cycles = [s["cycle"] for s in report["sources"]]
    assert all(c is not None and 0.6 < c["seconds"] < 1.3 for c in cycles)
    assert report["loop"][0]["frames"] == report["frames"][0] - 1
    got = _read_back(out, report["actions"][0])
    R = got.rotations
    assert _angle(R[-1], R[0]) < 1e-4  # float32 keys
    steps = pose_steps(R[:-1])
    assert pose_steps(np.stack([R[-2], R[0]]))[0] <= np.median(steps)


def test_mask_writes_the_bone_weights(amc, tmp_path):
    pytest.importorskip("bpy")
    out = tmp_path / "mask.blend"
    report = _blend(amc["w1"], amc["r1"], "--weight", "0.5", "--mask", "legs=0,hands=1", "--group",
                    "hands=hand.L+hand.R", "--feet", "none", "--out", out)
    w = report["bone_weights"]
    assert w["lfemur"] == 0.0 and w["lhand"] == 1.0 and w["lhumerus"] == 0.5
    assert report["feet"] is None


@pytest.mark.parametrize("extra,message", [
    (["--weight", "0.5"], "3 clips need 3 weights"),
    (["--weight", "0.5,0.2,0.2"], "summing to 1"),
    (["--weight", "0.4,0.3,0.3", "--mask", "upper=1"], "mask needs exactly two clips"),
    (["--weight", "0.4,0.3,0.3", "--inbetweens", "2"], "--inbetweens needs exactly two clips"),
    (["--weight", "0.4,0.3,0.3", "--range-a", "300:400"], "outside"),
    (["--weight", "0.4,0.3,0.3", "--range-b", "9"], "START:END"),
    (["--weight", "a,b,c"], "expected a number"),
])
def test_bad_input_is_one_line_and_writes_nothing(amc, tmp_path, capsys, extra, message):
    out = tmp_path / "x.blend"
    code = cli.main(["blend", amc["w1"], amc["r1"], amc["w2"], *extra, "--out", str(out), "--no-progress"])
    _out, err = capsys.readouterr()
    assert code == 2 and len(err.strip().splitlines()) == 1 and message in err, err
    assert not out.exists()
