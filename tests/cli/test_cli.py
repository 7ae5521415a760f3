"""The command line on the bundled CMU clips: arguments, JSON shapes, one-line errors (exit 2), clean
stdout with --json, --help. In-process (cli.main with capsys) except the subprocess tests at the end."""

import csv
import json
import os
import pathlib
import shutil
import subprocess
import sys

import numpy as np
import pytest

from blender_shapesig import cli
from blender_shapesig.core.geometry import curves
from blender_shapesig.core.signatures import signatures
from blender_shapesig.core.io import sources
from blender_shapesig.core.io.acclaim import load_acclaim
from blender_shapesig.core.clip.clip import restrict_to_shared
from blender_shapesig.core.metrics import time_base_smoothing
from blender_shapesig.core.clip.prepare import prepare_clip

ROOT = pathlib.Path(__file__).resolve().parents[2]
ACC = ROOT / "tests" / "data" / "acclaim"


@pytest.fixture(scope="module")
def amc(tmp_path_factory):
    """Walks and runs in two folders, each with its one .asf (so the skeleton is found automatically)."""
    base = tmp_path_factory.mktemp("amc")
    (base / "walk").mkdir()
    (base / "run").mkdir()
    for f in ("07-walk.asf", "07_01.amc", "07_02.amc"):
        shutil.copy(ACC / f, base / "walk" / f)
    for f in ("09-run.asf", "09_02.amc", "09_03.amc"):
        shutil.copy(ACC / f, base / "run" / f)
    return {
        "base": base,
        "w1": str(base / "walk" / "07_01.amc"),
        "w2": str(base / "walk" / "07_02.amc"),
        "r1": str(base / "run" / "09_02.amc"),
        "r2": str(base / "run" / "09_03.amc"),
    }


def _clip(path, bone_map="auto", start=None, end=None):
    """The clip as the command line reads it by default: the front door, through the automatic bone map
    (the comparison space across rigs, core.rigs); ``bone_map="none"``: Blender's armature axes as before."""
    folder = os.path.dirname(path)
    asf = [f for f in os.listdir(folder) if f.endswith(".asf")][0]
    if bone_map == "none":
        return load_acclaim(path, os.path.join(folder, asf), axes="blender")
    return sources.read_one(sources.ClipSpec(path, asf=os.path.join(folder, asf), start=start, end=end,
                                             bone_map=bone_map))


def _compared(a, b, base):
    """Both clips on their shared bones and on the comparison time base of the measure (what the CLI compares)."""
    a, b = restrict_to_shared(a, b)
    smooth = time_base_smoothing(base)
    return prepare_clip(a, smooth=smooth), prepare_clip(b, smooth=smooth)


def run_json(capsys, args):
    code = cli.main(args + ["--json"])
    out, err = capsys.readouterr()
    assert code == 0, err
    return json.loads(out), err


def run_error(capsys, args):
    code = cli.main(args)
    out, err = capsys.readouterr()
    assert code == 2
    assert out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("blender_shapesig: error:")
    return lines[0]


# --- distance -----------------------------------------------------------------------------------


def test_distance_l2_matches_core(capsys, amc):
    out, _ = run_json(capsys, ["distance", amc["w1"], amc["r1"], "--metric", "l2"])
    assert set(out) >= {"distance", "metric"} and out["metric"] == "l2"
    a, b = _compared(_clip(amc["w1"]), _clip(amc["r1"]), "l2")
    assert out["distance"] == pytest.approx(curves.l2_distance(a.rotations, b.rotations), rel=1e-12)


def test_distance_bone_map_none_is_the_armature_space(capsys, amc):
    out, _ = run_json(capsys, ["distance", amc["w1"], amc["r1"], "--metric", "l2", "--bone-map", "none"])
    a, b = _compared(_clip(amc["w1"], "none"), _clip(amc["r1"], "none"), "l2")  # on the time base
    assert out["distance"] == pytest.approx(curves.l2_distance(a.rotations, b.rotations), rel=1e-12)
    assert out["bones"] == len(a.bones) and out["coverage"] == 1.0


@pytest.mark.parametrize("args, label, fn", [
    ([], "sim3", lambda a, b: signatures.normalized_distance(a, b, 3)),
    (["--metric", "sim", "--level", "2"], "sim2", lambda a, b: signatures.normalized_distance(a, b, 2)),
    (["--metric", "group2"], "group2", lambda a, b: signatures.group_distance(a, b, 2)),
    (["--metric", "linear", "--level", "2"], "linear2", lambda a, b: signatures.linear_distance(a, b, 2)),
])
def test_distance_signature_metrics(capsys, amc, args, label, fn):
    out, _ = run_json(capsys, ["distance", amc["w1"], amc["w2"]] + args)
    assert out["metric"] == label
    a, b = _compared(_clip(amc["w1"]), _clip(amc["w2"]), "sim")
    assert out["distance"] == pytest.approx(fn(a.rotations, b.rotations), rel=1e-10)


def test_fps_and_trim_options(capsys, amc):
    base, _ = run_json(capsys, ["distance", amc["w1"], amc["r1"], "--metric", "elastic"])
    # the AMC takes have nothing to trim; the same rate for both clips at 60 fps means twice their durations
    same, _ = run_json(capsys, ["distance", amc["w1"], amc["r1"], "--metric", "elastic", "--trim", "none"])
    assert same["distance"] == base["distance"]
    slow, _ = run_json(capsys, ["distance", amc["w1"], amc["r1"], "--metric", "elastic", "--fps", "60"])
    assert slow["distance"] != base["distance"]
    line = run_error(capsys, ["distance", amc["w1"], amc["r1"], "--fps", "0.001"])
    assert "plausible" in line
    line = run_error(capsys, ["distance", amc["w1"], amc["r1"], "--trim", "maybe"])
    assert "--trim" in line


def test_distance_elastic_depth(capsys, amc):
    from blender_shapesig.core.elastic.elastic import elastic_distance

    out, _ = run_json(capsys, ["distance", amc["r1"], amc["r2"], "--metric", "elastic", "--depth", "3"])
    a, b = _compared(_clip(amc["r1"]), _clip(amc["r2"]), "elastic")
    assert out["metric"] == "elastic"
    assert out["distance"] == pytest.approx(elastic_distance(a.rotations, b.rotations, depth=3), rel=1e-12)
    # The elastic distance never exceeds d_P* (the identity warp is one candidate).
    assert out["distance"] <= curves.l2_distance(a.rotations, b.rotations) + 1e-9


def test_distance_plain_text(capsys, amc):
    assert cli.main(["distance", amc["w1"], amc["w1"], "--metric", "l2"]) == 0
    out, _ = capsys.readouterr()
    assert out.strip().startswith("l2(07_01, 07_01) = 0")


def test_explicit_asf(capsys, amc):
    # In tests/data/acclaim there are three .asf files: --asf chooses.
    out, _ = run_json(capsys, ["distance", str(ACC / "07_01.amc"), str(ACC / "07_02.amc"), "--metric", "l2",
                               "--asf", str(ACC / "07-walk.asf")])
    ref, _ = run_json(capsys, ["distance", amc["w1"], amc["w2"], "--metric", "l2"])
    assert out["distance"] == pytest.approx(ref["distance"], rel=1e-12)


# --- errors -------------------------------------------------------------------------------------


@pytest.mark.parametrize("args, needle", [
    (["distance", "nowhere.amc", "nowhere2.amc"], "file not found"),
    (["distance", str(ACC / "07_01.amc"), str(ACC / "07_02.amc")], "--asf"),
    (["distance", "W1", "W2", "--metric", "banana"], "unknown metric"),
    (["distance", "W1", "W2", "--metric", "elastic2"], "takes no level"),
    (["distance", "W1"], "required"),
    (["distance", "W1", str(ROOT / "tests" / "data" / "labels.csv")], "unsupported file type"),
    (["frobnicate"], "invalid choice"),
    ([], "no command"),
    (["rank", "W1", "W2", "--top", "0"], "--top"),
    (["blend", "W1", "W2", "--weight", "1.5", "--out", "x.blend"], "--weight"),
    (["blend", "W1", "W2", "--weight", "inf", "--out", "x.blend"], "--weight: expected a finite number in [0, 1]"),
    (["blend", "W1", "W2", "--weight", "nan", "--out", "x.blend"], "--weight: expected a finite number in [0, 1]"),
    (["blend", "W1", "W2", "--weight", "0.5", "--out", "x.txt"], ".blend"),
    (["matrix", "W1", "--out", "OUT"], "at least two"),
    (["evaluate", "--index", "missing.csv", "--data", ".", "--out", "OUT"], "index file not found"),
    (["distance", "W1", "W2", "--depth", "many"], "invalid int"),
])
def test_errors_one_line_exit_2(capsys, amc, tmp_path, args, needle):
    args = [a.replace("W1", amc["w1"]).replace("W2", amc["w2"]).replace("OUT", str(tmp_path / "o")) for a in args]
    line = run_error(capsys, args)
    assert needle in line


def test_error_with_json_keeps_stdout_empty(capsys, amc):
    run_error(capsys, ["distance", amc["w1"], "missing.amc", "--json"])


def test_debug_shows_traceback(capsys, amc):
    assert cli.main(["distance", amc["w1"], "missing.amc", "--debug"]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert "Traceback" in err and err.strip().splitlines()[-1].startswith("blender_shapesig: error:")


@pytest.mark.parametrize("command", [[], ["distance"], ["rank"], ["blend"], ["matrix"], ["evaluate"]])
def test_help(capsys, command):
    assert cli.main(command + ["--help"]) == 0
    out, _ = capsys.readouterr()
    assert out.startswith("usage: blender_shapesig")
    for word in {"distance": ["--metric", "--level", "--depth"], "rank": ["--rerank", "--top", "--cache"],
                 "blend": ["--weight", "--align", "--frames", "--inbetweens", "--out"],
                 "matrix": ["--metric", "--out"], "evaluate": ["--index", "--data", "--out"]}.get(
                     command[0] if command else "", ["distance", "rank", "blend", "matrix", "evaluate"]):
        assert word in out


# --- matrix and evaluate ------------------------------------------------------------------------


def test_matrix_sim2(capsys, amc, tmp_path):
    paths = [amc["w1"], amc["w2"], amc["r1"], amc["r2"]]
    out, _ = run_json(capsys, ["matrix", *paths, "--metric", "sim2", "--out", str(tmp_path), "--workers", "1"])
    assert out["matrix"] == os.path.join(str(tmp_path), "matrix.csv")
    assert len(out["figures"]) == 2 and all(open(f, "rb").read(4) == b"\x89PNG" for f in out["figures"])
    with open(out["matrix"], newline="") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["clip", "07_01", "07_02", "09_02", "09_03"]
    D = np.array([[float(v) for v in r[1:]] for r in rows[1:]])
    np.testing.assert_allclose(D, np.load(tmp_path / "matrix.npy"))
    assert np.allclose(D, D.T) and np.all(np.diag(D) == 0)
    # Entry (walk 07_01, run 09_02) against the pairwise function on the same clips.
    a, b = _compared(_clip(paths[0]), _clip(paths[2]), "sim")
    assert D[0, 2] == pytest.approx(signatures.normalized_distance(a.rotations, b.rotations, 2), rel=1e-9)


def test_evaluate_amc(capsys, amc, tmp_path):
    index = tmp_path / "index.csv"
    index.write_text(
        "file,label,skeleton,start,end\n"
        "walk/07_01.amc,walk,walk/07-walk.asf,1,200\n"
        "walk/07_02.amc,walk,walk/07-walk.asf,,\n"
        "run/09_02.amc,run,run/09-run.asf,,\n"
        "run/09_03.amc,run,,10,\n"
    )
    out_dir = tmp_path / "eval"
    out, _ = run_json(capsys, ["evaluate", "--index", str(index), "--data", str(amc["base"]), "--out", str(out_dir),
                               "--metrics", "l2,sim2", "--workers", "1", "--no-figures"])
    summary = json.loads((out_dir / "summary.json").read_text())
    assert summary["clips"] == 4 and out["clips"] == 4
    assert set(summary["metrics"]) == {"l2", "sim2"}
    for row in summary["metrics"].values():
        assert 0.0 <= row["accuracy"] <= 1.0 and row["seconds"] >= 0.0
    # The crop (frames 1..200 of 07_01, 10.. of 09_03) is applied before the distances.
    M = np.load(out_dir / "matrices" / "l2.npy")
    # cropped before the comparison space (whose heading depends on the frames kept), as the front door does
    a = _clip(amc["w1"], start=1, end=200)
    d = _clip(amc["r2"], start=10)
    assert a.frames == 200
    a, d = _compared(a, d, "l2")
    assert M[0, 3] == pytest.approx(curves.l2_distance(a.rotations, d.rotations), rel=1e-9)


# --- rank ------------------------------------------------------------------------------------------------------


def test_rank_json_and_cache(capsys, amc, tmp_path):
    cache = tmp_path / "cache"
    args = ["rank", amc["w1"], amc["w2"], amc["r1"], amc["r2"], "--metric", "sim2", "--cache", str(cache)]
    out, _ = run_json(capsys, args)
    assert out["query"] == "07_01"
    names = [r["clip"] for r in out["results"]]
    assert sorted(names) == ["07_02", "09_02", "09_03"]
    dists = [r["distance"] for r in out["results"]]
    assert dists == sorted(dists)
    # The walk is nearer to the other walk than to the runs.
    assert names[0] == "07_02"
    a, b = _compared(_clip(amc["w1"]), _clip(amc["w2"]), "sim")  # the index signs the compared curves
    # The index stores float32 directions: agreement to ~1e-7 relative.
    assert dists[0] == pytest.approx(signatures.normalized_distance(a.rotations, b.rotations, 2), rel=1e-6)
    assert any(cache.iterdir()), "the cache folder stays empty"
    assert out["cache"]["misses"] >= 3
    again, _ = run_json(capsys, args)
    assert again["results"] == out["results"]
    # The second query finds every signature in the cache: nothing is recomputed.
    assert again["cache"]["misses"] == 0 and again["cache"]["hits"] >= 3


def test_rank_sim_equals_distance_for_every_clip(capsys, amc, tmp_path):
    """rank's sim3 of each library clip is ``distance --metric sim3`` of the same pair: the index signs the curve
    the distance compares (the comparison time base), also for a BVH at another frame rate (60 fps, 120 fps
    query) and across rigs (shared bones)."""
    rig = ROOT / "tests" / "data" / "cross_rig"
    lib = [amc["w2"], amc["r1"], str(rig / "002_03.bvh"), str(rig / "02_03.bvh")]
    out, _ = run_json(capsys, ["rank", amc["w1"], *lib, "--metric", "sim3", "--cache", str(tmp_path / "c")])
    ranked = {r["clip"]: r["distance"] for r in out["results"]}
    assert set(ranked) == {"07_02", "09_02", "002_03", "02_03"}
    for path in lib:
        name = os.path.splitext(os.path.basename(path))[0]
        pair, _ = run_json(capsys, ["distance", amc["w1"], path, "--metric", "sim3"])
        # float32 directions in the index: ~1e-7 relative (before: up to 1e-2 apart for the 60 fps file)
        assert ranked[name] == pytest.approx(pair["distance"], rel=2e-6, abs=1e-7), name


def test_rank_default_cache_env_and_no_cache(capsys, amc, tmp_path, monkeypatch):
    """Without --cache, rank caches in $SHAPESIG_CACHE_DIR (else the per-user folder, core.search.default_cache_dir);
    --no-cache reads and writes no cache; both options at once are an error."""
    env_dir = tmp_path / "user_cache"
    monkeypatch.setenv("SHAPESIG_CACHE_DIR", str(env_dir))
    args = ["rank", amc["w1"], amc["w2"], amc["r1"], "--metric", "sim2"]
    first, _ = run_json(capsys, args)
    assert first["cache"]["misses"] >= 2 and any(env_dir.iterdir())
    again, _ = run_json(capsys, args)
    assert again["cache"]["misses"] == 0 and again["results"] == first["results"]
    files = sorted(p.name for p in env_dir.iterdir())
    off, _ = run_json(capsys, args + ["--no-cache"])
    assert off["cache"]["misses"] >= 2 and off["results"] == first["results"]
    assert sorted(p.name for p in env_dir.iterdir()) == files
    monkeypatch.delenv("SHAPESIG_CACHE_DIR")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    run_json(capsys, args)
    assert any((tmp_path / "xdg" / "blender_shapesig-cache").glob("*.npz"))
    assert cli.main(args + ["--no-cache", "--cache", str(tmp_path / "c")]) == 2
    assert "contradict" in capsys.readouterr().err


def test_rank_rerank_and_top(capsys, amc):
    out, _ = run_json(capsys, ["rank", amc["r1"], amc["w1"], amc["w2"], amc["r2"], "--metric", "sim3",
                               "--rerank", "2", "--top", "2"])
    assert len(out["results"]) == 2
    el = [r["elastic"] for r in out["results"]]
    assert all(e is not None for e in el) and el == sorted(el)
    from blender_shapesig.core.elastic.elastic import elastic_distance

    names = {"07_01": amc["w1"], "07_02": amc["w2"], "09_03": amc["r2"]}
    first = out["results"][0]
    a, b = _compared(_clip(amc["r1"]), _clip(names[first["clip"]]), "elastic")
    # The index keeps float32 increments on the 30 fps time base and low-passes them there; `distance` low-passes
    # the 120 fps curve before resampling: close, not equal (equal at 30 fps: tests/core/search/test_rank.py).
    assert first["elastic"] == pytest.approx(elastic_distance(a.rotations, b.rotations), rel=1e-2)


def test_rank_results_carry_path_and_action(capsys, tmp_path):
    """two files with the same display name (two copies of 16_15.bvh) are told apart by "path", the
    argument as given; "action" is null for files that are not .blend."""
    paths = []
    for sub in ("a", "b"):
        (tmp_path / sub).mkdir()
        shutil.copy(ACC / "16_15.bvh", tmp_path / sub / "16_15.bvh")
        paths.append(str(tmp_path / sub / "16_15.bvh"))
        os.utime(paths[-1], ns=(10 ** 18 + len(paths), 10 ** 18 + len(paths)))
    walk = str(ACC / "07_02.amc")
    out, _ = run_json(capsys, ["rank", str(ACC / "07_01.amc"), walk, *paths, "--asf", str(ACC / "07-walk.asf")])
    rows = out["results"]
    assert sorted(r["clip"] for r in rows) == ["07_02", "16_15", "16_15"]
    assert sorted(r["path"] for r in rows) == sorted([walk] + paths)
    assert all(r["action"] is None for r in rows)
    assert next(r for r in rows if r["clip"] == "07_02")["path"] == walk


def test_blend_inbetweens_above_the_maximum_is_refused(capsys, amc, tmp_path):
    from blender_shapesig.core.errors import MAX_INBETWEENS

    line = run_error(capsys, ["blend", amc["w1"], amc["w2"], "--inbetweens", str(MAX_INBETWEENS + 1),
                              "--out", str(tmp_path / "x.blend")])
    assert f"--inbetweens: expected an integer in 1..{MAX_INBETWEENS}" in line
    assert not (tmp_path / "x.blend").exists()


# --- subprocess: the real entry point, stdout hygiene --------------------------------------------


def _env():
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    return env


def test_subprocess_json_stdout_is_one_object(amc):
    p = subprocess.run([sys.executable, "-m", "blender_shapesig", "distance", amc["w1"], amc["r1"], "--metric", "l2",
                        "--json"], capture_output=True, text=True, env=_env(), cwd=str(ROOT), timeout=300)
    assert p.returncode == 0, p.stderr
    assert json.loads(p.stdout)["metric"] == "l2"
    assert p.stdout.count("\n") == 1


def test_subprocess_error_exit_2(tmp_path):
    p = subprocess.run([sys.executable, "-m", "blender_shapesig", "distance", str(tmp_path / "a.bvh"),
                        str(tmp_path / "b.bvh"), "--json"], capture_output=True, text=True, env=_env(),
                       cwd=str(ROOT), timeout=300)
    assert p.returncode == 2
    assert p.stdout == ""
    assert len(p.stderr.strip().splitlines()) == 1 and "file not found" in p.stderr


def test_subprocess_blend_bvh_writes_armature_and_action(tmp_path):
    """blend of two BVH clips: the .blend holds an armature and the new action, whose keys are the blend
    computed here independently with core.blend (read back with the clip loader)."""
    bpy = pytest.importorskip("bpy")
    from blender_shapesig.core.io.sources import read as load_clips
    from blender_shapesig.core.blend import blend_clips
    from blender_shapesig.core.blend.feet import lock_feet

    bvh = ROOT / "tests" / "data" / "bvh"
    out = tmp_path / "walk_run.blend"
    p = subprocess.run([sys.executable, "-m", "blender_shapesig", "blend", str(bvh / "07_01.bvh"), str(bvh / "09_02.bvh"),
                        "--weight", "0.25", "--start", "2", "--frames", "120", "--out", str(out), "--json",
                        "--no-progress"], capture_output=True, text=True, env=_env(), cwd=str(ROOT), timeout=600)
    assert p.returncode == 0, p.stderr
    report = report_json = json.loads(p.stdout)  # Blender's importer output went to stderr, not here
    assert report["out"] == str(out) and report["frames"] == [120]
    assert report["actions"] == ["07_01_x_09_02_0.25"]
    assert out.exists()
    # clips of one rig blend in the rig's own space (armature axes; core.rigs only maps across rigs); read back
    # as written (the blend starts with the sources' ramps, which --start 2 kept: no trimming here)
    got = load_clips(f"{out}#{report['actions'][0]}", bone_map="none", trim="none")[0]
    a = load_clips(str(bvh / "07_01.bvh"), start=2, bone_map="none")[0]  # an explicit start wins over --trim
    b = load_clips(str(bvh / "09_02.bvh"), start=2, bone_map="none")[0]
    assert (a.frame_start, b.frame_start) == (2, 2)
    # planted feet by default (--feet lock): the blend's legs through core.blend.feet.lock_feet on the sources
    want, report = lock_feet(blend_clips(a, b, 0.25, align=False, frames=120), [a, b])
    assert report["feet"] and report_json["feet"][0]["feet"] == report["feet"]
    assert got.frames == 120
    idx = [want.bones.index(n) for n in got.bones]
    # Keys are stored as float32 channels: agreement to ~1e-5 per matrix entry.
    np.testing.assert_allclose(got.rotations, want.rotations[:, idx], atol=2e-5)
    # The file carries an armature with the clip's bones.
    with bpy.data.libraries.load(str(out)) as (src, dst):
        assert "07_01_x_09_02_0.25" in src.actions and src.armatures


def test_subprocess_blend_amc_inbetweens(amc, tmp_path):
    """--inbetweens 2 from .amc clips: the armature comes from the add-on's Acclaim importer; two actions at
    weights 1/3, 2/3 with the default length round((1-w)(N0-1) + w(N1-1)) + 1 (N0 = 316, N1 = 329)."""
    pytest.importorskip("bpy")
    out = tmp_path / "inb.blend"
    p = subprocess.run([sys.executable, "-m", "blender_shapesig", "blend", amc["w1"], amc["w2"], "--inbetweens", "2",
                        "--out", str(out), "--json", "--no-progress"], capture_output=True, text=True, env=_env(),
                       cwd=str(ROOT), timeout=600)
    assert p.returncode == 0, p.stderr
    report = json.loads(p.stdout)
    assert report["weights"] == pytest.approx([1 / 3, 2 / 3])
    assert report["actions"] == ["07_01_x_07_02_0.33", "07_01_x_07_02_0.67"]
    assert report["frames"] == [320, 325]
    assert report["seconds"] == pytest.approx([319 / 120, 324 / 120]) and report["fps"] == [120.0, 120.0]
    assert out.exists()


def _cli_json(*args):
    """Run the command line in a fresh process with --json --no-progress; its JSON report."""
    p = subprocess.run([sys.executable, "-m", "blender_shapesig", *map(str, args), "--json", "--no-progress"],
                       capture_output=True, text=True, env=_env(), cwd=str(ROOT), timeout=600)
    assert p.returncode == 0, p.stderr
    return json.loads(p.stdout)


def test_subprocess_rank_blend_results_name_their_action(amc, tmp_path):
    """a .blend in the library yields one result per action, each with "path" (the file as given)
    and "action" (the action's name), so a script can load exactly that action again."""
    pytest.importorskip("bpy")
    out = tmp_path / "two.blend"
    actions = _cli_json("blend", amc["w1"], amc["r1"], "--inbetweens", "2", "--out", out)["actions"]
    rows = _cli_json("rank", amc["w2"], out, amc["w1"], f"{out}#{actions[1]}", "--metric", "sim2")["results"]
    got = sorted((r["path"], r["action"]) for r in rows)
    assert got == sorted([(str(out), actions[0]), (str(out), actions[1]), (str(out), actions[1]),
                          (amc["w1"], None)])


def test_rank_thumbnails_writes_a_picture_per_row_and_the_query(capsys, tmp_path):
    """``rank --thumbnails DIR``: one PNG per result and the query's, named in the JSON, the same bytes as the
    pictures kept in the cache folder; a walk's differs from the jump's."""
    from blender_shapesig.core.search import thumbnails
    from tests.helpers.png import read_png

    bvh = ROOT / "tests" / "data" / "bvh"
    out_dir, cache = tmp_path / "pics", tmp_path / "cache"
    args = ["rank", str(bvh / "07_01.bvh"), str(bvh / "07_02.bvh"), str(bvh / "13_32.bvh"), "--thumbnails",
            str(out_dir), "--cache", str(cache)]
    out, _ = run_json(capsys, args)
    files = [r["thumbnail"] for r in out["results"]] + [out["query_thumbnail"]]
    assert all(os.path.dirname(f) == str(out_dir) for f in files) and sorted(os.listdir(out_dir)) == sorted(
        os.path.basename(f) for f in files)
    kept = {p.read_bytes() for p in (cache / "blender_shapesig-cache").glob("*.png")}
    assert {pathlib.Path(f).read_bytes() for f in files} == kept
    pics = {r["clip"]: read_png(r["thumbnail"]) for r in out["results"]}
    walk, jump = thumbnails.figure_mask(pics["07_02"]), thumbnails.figure_mask(pics["13_32"])
    assert (walk & jump).sum() < 0.5 * (walk | jump).sum()
