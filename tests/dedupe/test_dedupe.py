"""``dedupe`` on the bundled CMU clips: planted copies (renamed, half the frame rate, trimmed and re-timed) land in
their original's cluster, no cluster swallows more than 30 % of the library, the same results on a Dask
LocalCluster through ``--scheduler``; the pure parts of ``core.search.dedupe`` (common bone tuple, linkage)."""

import json
import os
import pathlib
import shutil
import subprocess
import sys

import numpy as np
import pytest

from blender_shapesig import cli
from blender_shapesig.core.search import dedupe
from blender_shapesig.core.io import sources
from blender_shapesig.core.clip.clip import Clip
from blender_shapesig.core.search import entry_distance, make_entry
from blender_shapesig.core.rigs import JOINTS
from tests.helpers import planted

ROOT = pathlib.Path(__file__).resolve().parents[2]
DATA = ROOT / "tests" / "data"


@pytest.fixture(scope="module")
def library(tmp_path_factory):
    """tests/data's BVH clips (two rigs), 16_15 as AMC (its .asf alone beside it) and the three planted copies."""
    base = tmp_path_factory.mktemp("library")
    shutil.copytree(DATA / "bvh", base / "bvh")
    shutil.copytree(DATA / "cross_rig", base / "cross_rig")
    (base / "acclaim").mkdir()
    for f in ("16.asf", "16_15.amc", "16_15.bvh"):
        shutil.copy(DATA / "acclaim" / f, base / "acclaim" / f)
    copies = planted.plant(base / "planted", base / "bvh" / "07_01.bvh", base / "bvh" / "09_02.bvh",
                           base / "bvh" / "13_32.bvh")
    return base, copies


def run_json(capsys, args):
    code = cli.main(args + ["--json", "--no-progress", "--no-cache"])
    out, err = capsys.readouterr()
    assert code == 0, err
    return json.loads(out)


def cluster_of(result, path):
    path = os.path.abspath(path)
    return next((set(map(os.path.abspath, c)) for c in result["clusters"] if path in map(os.path.abspath, c)),
                set())


def check_planted(result, library):
    base, copies = library
    for copy, original in copies.items():
        assert copy in cluster_of(result, original), (copy, result["clusters"], result["near_misses"][:5])
    n = result["clips"]
    assert n == len(list(base.rglob("*.bvh"))) + 1
    assert max(len(c) for c in result["clusters"]) <= 0.3 * n
    # the same take in another format (AMC and its BVH conversion) is found too
    assert str(base / "acclaim" / "16_15.bvh") in cluster_of(result, base / "acclaim" / "16_15.amc")


def test_planted_copies_join_their_originals(capsys, library, tmp_path):
    base, _ = library
    out = run_json(capsys, ["dedupe", str(base), "--out", str(tmp_path / "report")])
    check_planted(out, library)
    assert out["report"] == str(tmp_path / "report" / "report.html")
    page = (tmp_path / "report" / "report.html").read_text(encoding="utf-8")
    # self-contained: the plots and each clip's strip of key poses inline
    assert page.count("data:image/png;base64,") == len(out["clusters"]) + sum(map(len, out["clusters"]))
    saved = json.loads((tmp_path / "report" / "report.json").read_text(encoding="utf-8"))
    assert saved["clusters"] == out["clusters"]
    for pairs in saved["cluster_pairs"]:  # complete linkage: every pair inside a cluster passed both gates
        assert pairs and all(p["confirmed"] and p["relative"] <= out["threshold"] for p in pairs)
    assert out["scheduler"] == "threads" and out["dask"] is False


def test_dask_local_cluster_gives_the_same_clusters(capsys, library, tmp_path):
    distributed = pytest.importorskip("distributed")
    base, _ = library
    plain = run_json(capsys, ["dedupe", str(base), "--out", str(tmp_path / "a"), "--no-plots",
                              "--scheduler", "sync"])
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  dashboard_address=None) as cluster:
        out = run_json(capsys, ["dedupe", str(base), "--out", str(tmp_path / "b"), "--no-plots",
                                "--scheduler", cluster.scheduler_address])
    assert out["scheduler"].startswith(("tcp://", "inproc://"))
    assert out["clusters"] == plain["clusters"]
    assert out["threshold"] == pytest.approx(plain["threshold"])
    check_planted(out, library)


def test_threshold_zero_keeps_exact_copies_only(capsys, library, tmp_path):
    base, copies = library
    out = run_json(capsys, ["dedupe", str(base), "--out", str(tmp_path), "--threshold", "0", "--no-plots"])
    renamed = next(c for c in copies if c.endswith("planted_renamed.bvh"))
    assert out["threshold"] == 0.0
    assert [sorted(map(os.path.abspath, c)) for c in out["clusters"]] == [sorted([renamed, copies[renamed]])]


def test_bad_scheduler_is_one_line(capsys, library, tmp_path):
    code = cli.main(["dedupe", str(library[0]), "--out", str(tmp_path), "--scheduler", "nonsense"])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "--scheduler" in err


def test_dask_is_imported_only_by_a_dedupe_run():
    code = ("import sys, blender_shapesig.cli, blender_shapesig.dedupe, blender_shapesig.core.search.dedupe; "
            "sys.exit('dask' in sys.modules or 'distributed' in sys.modules)")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    assert subprocess.run([sys.executable, "-c", code], env=env).returncode == 0


def test_without_dask_the_default_runs_and_a_scheduler_is_one_line(tmp_path):
    """Dask is optional: with it made unimportable, a run without --scheduler works (thread pool) and
    --scheduler (a local name or an address) stops with one line, before any clip is read."""
    lib = tmp_path / "lib"
    lib.mkdir()
    for f in ("07_01.bvh", "09_02.bvh"):
        shutil.copy(DATA / "bvh" / f, lib / f)
    planted.renamed(lib / "07_01.bvh", lib / "copy.bvh")
    code = ("import sys; sys.modules['dask'] = sys.modules['distributed'] = None; "
            "from blender_shapesig import cli; sys.exit(cli.main(sys.argv[1:]))")
    env = dict(os.environ, PYTHONPATH=str(ROOT))

    def run(*extra):
        return subprocess.run([sys.executable, "-c", code, "dedupe", str(lib), "--out", str(tmp_path / "out"),
                               "--no-plots", "--no-cache", "--no-progress", "--json", *extra],
                              env=env, capture_output=True, text=True)

    plain = run()
    assert plain.returncode == 0, plain.stderr
    out = json.loads(plain.stdout)
    assert out["scheduler"] == "threads" and out["dask"] is False
    assert [sorted(map(os.path.basename, c)) for c in out["clusters"]] == [["07_01.bvh", "copy.bvh"]]
    for sched in ("threads", "tcp://127.0.0.1:8786"):
        p = run("--scheduler", sched)
        assert p.returncode == 2 and p.stderr.count("\n") == 1, p.stderr
        assert "--scheduler" in p.stderr and "dask" in p.stderr and "Traceback" not in p.stderr


# ------------------------------------------------------------------------------------------ core

def test_common_entry_is_the_same_direction_on_all_joints():
    """An entry on a subset of the canonical joints, moved to rigs.JOINTS, compares exactly like the clip
    with the missing joints held still (their letters have zero coordinates)."""
    a = sources.read_one(str(DATA / "acclaim" / "16_15.bvh"))  # MotionBuilder rig (spine_mid present)
    b = sources.read_one(str(DATA / "bvh" / "07_01.bvh"))      # Daz rig (no spine_mid)
    assert a.bones != b.bones and set(b.bones) < set(JOINTS)

    def on_all_joints(c):
        R = np.broadcast_to(np.eye(3), (c.frames, len(JOINTS), 3, 3)).copy()
        for k, bone in enumerate(c.bones):
            R[:, JOINTS.index(bone)] = c.rotations[:, k]
        return make_entry(Clip(c.name, JOINTS, R, fps=c.fps))

    ea, eb = make_entry(a), make_entry(b)
    ca, cb = dedupe.common_entry(ea), dedupe.common_entry(eb)
    assert ca.bones == cb.bones == JOINTS
    assert entry_distance(ca, cb) == pytest.approx(entry_distance(on_all_joints(a), on_all_joints(b)), abs=1e-5)
    assert ca.moving != cb.moving  # pair_sim's scatter into all joints' coordinates is the same sim
    assert dedupe.pair_sim(ca, cb) == pytest.approx(entry_distance(ca, cb), abs=1e-5)
    assert dedupe.pair_sim(ca, cb) == pytest.approx(dedupe.pair_sim(cb, ca), abs=1e-7)
    assert dedupe.pair_sim(ca, ca) == 0.0
    np.testing.assert_allclose(cb.sketch, on_all_joints(b).sketch, atol=1e-5)


def test_complete_linkage_does_not_chain():
    """A ~ B ~ C ~ D in a row, but only neighbours are close: components chain all four, linkage does not."""
    pairs = [(0, 1), (1, 2), (2, 3)]
    close = set(pairs)
    assert dedupe.chain_components(5, pairs) == [[0, 1, 2, 3]]
    assert dedupe.complete_linkage(5, pairs, lambda i, j: (min(i, j), max(i, j)) in close) == [[0, 1], [2, 3]]
    assert dedupe.complete_linkage(5, pairs, lambda i, j: True) == [[0, 1, 2, 3]]


def test_relative_threshold_and_sample():
    assert dedupe.relative_threshold([1.0, 2.0, 3.0, float("inf"), None], 0.5) == 1.0
    assert dedupe.relative_threshold([], 0.5) == 0.0
    edges = [dedupe.Edge(i, i + 1, float(i)) for i in range(300)]
    s1, s2 = dedupe.sample_edges(edges, 50), dedupe.sample_edges(edges, 50)
    assert s1 == s2 and len(s1) == 50 and len(set(s1)) == 50


def test_report_paths_relative_to_the_shared_folder_never_to_the_filesystem_root():
    from blender_shapesig.dedupe.report import _shortener

    root, short = _shortener(["/d/a/x.bvh", "/d/b/y.bvh#3"])
    assert root == "/d" and short("/d/a/x.bvh") == "a/x.bvh" and short("/d/b/y.bvh#3") == "b/y.bvh#3"
    root, short = _shortener(["/srv/x.bvh", "/home/y.bvh"])  # only "/" in common: full paths
    assert root == "" and short("/srv/x.bvh") == "/srv/x.bvh"


def test_report_says_which_copy_to_keep_and_shows_each_clip(capsys, library, tmp_path):
    """The half-rate run's cluster keeps the 120 fps original (same length, higher rate), the renamed walk's is a
    tie on every rule (the first is kept, said so), the trimmed jump's keeps the longer original; each member's
    length, rate and strip of key poses are in the HTML."""
    base, copies = library
    out = run_json(capsys, ["dedupe", str(base), "--out", str(tmp_path), "--no-plots"])
    keep = {frozenset(map(os.path.abspath, c)): k for c, k in zip(out["clusters"], out["keep"])}
    by_copy = {copy: next(k for c, k in keep.items() if copy in c) for copy in copies}
    half = next(c for c in copies if c.endswith("planted_half_rate.bvh"))
    assert os.path.abspath(by_copy[half]["clip"]) == copies[half]
    assert by_copy[half]["reasons"][0].startswith("same length") and "highest frame rate: 120 fps (others 60 fps)" \
        in by_copy[half]["reasons"][1]
    renamed = next(c for c in copies if c.endswith("planted_renamed.bvh"))
    assert by_copy[renamed]["reasons"][-1] == "otherwise alike: the first in the library"
    jump = next(c for c in copies if c.endswith("planted_trimmed_retimed.bvh"))
    assert os.path.abspath(by_copy[jump]["clip"]) == copies[jump] and by_copy[jump]["reasons"][0].startswith("longest")
    page = (tmp_path / "report.html").read_text(encoding="utf-8")
    assert page.count("alt='key poses of") == sum(map(len, out["clusters"])) and page.count("(keep)") == len(keep)


def test_choose_keeper_rules_in_order():
    from types import SimpleNamespace as E

    def entry(seconds, fps, cut=0):
        frames = int(round(seconds * fps)) + 1
        return E(frames=int(round(seconds * 30)) + 1, fps=30.0, clip_frames=frames,
                 trimmed=(1 + cut, frames + cut, 1, frames + cut) if cut else ())

    assert dedupe.choose_keeper([entry(2.0, 120), entry(3.0, 60)])[0] == 1  # longest first
    i, why = dedupe.choose_keeper([entry(3.0, 60), entry(3.0, 120)])
    assert i == 1 and why == ["same length (3.00 s)", "highest frame rate: 120 fps (others 60 fps)"]
    i, why = dedupe.choose_keeper([entry(3.0, 120, cut=8), entry(3.0, 120)])
    assert i == 1 and why[-1] == "least trimmed: 0 frames cut (others 8 frames cut)"
