"""Moments: the free-window elastic DP against brute force, windowed ranking of re-timed excerpts of a
real clip (tests/data), and the explanations (per-joint shares, cost over time), in the core and the CLI."""

import json
import pathlib
import shutil

import numpy as np

import pytest

from blender_shapesig import cli
from blender_shapesig.core.geometry import so3
from blender_shapesig.core.io import sources
from blender_shapesig.core.elastic.elastic import elastic_align, elastic_distance, required_depth
from blender_shapesig.core.clip.prepare import lattice_frames
from blender_shapesig.core.elastic.explain import explain_clips, explain_path, joint_group
from blender_shapesig.core.search.moments.windows import (clip_windows, prefix_signatures, rank_windows, retimed_excerpt,
                                                 window_log_signatures)
from blender_shapesig.core.elastic.subsequence import (path_costs, subsequence_align, subsequence_dp_numba,
                                               subsequence_dp_numpy)
from blender_shapesig.core.elastic import _dp_kernels, subsequence
from blender_shapesig.core.signatures import tensor

ACC = pathlib.Path(__file__).resolve().parents[2] / "data" / "acclaim"
ASF = {"07": "07-walk.asf", "09": "09-run.asf", "16": "16.asf"}


def _read(name, **kw):
    return sources.read_one(sources.ClipSpec(str(ACC / f"{name}.amc"), asf=str(ACC / ASF[name[:2]]), **kw))


@pytest.fixture(scope="module")
def library():
    return {n: _read(n) for n in ("07_01", "07_02", "09_02", "09_03", "16_15")}


def _iou(a, b):
    inter = max(0, min(a[1], b[1]) - max(a[0], b[0]) + 1)
    return inter / (max(a[1], b[1]) - min(a[0], b[0]) + 1)


def _random_curves(seed, n0, n1, joints=2):
    rng = np.random.default_rng(seed)
    return (so3.integrate(rng.normal(0, 0.1, (n0 - 1, joints, 3))),
            so3.integrate(rng.normal(0, 0.1, (n1 - 1, joints, 3))))


# --------------------------------------------------------------------------------------- the subsequence DP

@pytest.mark.parametrize("seed,n0,n1,depth", [(1, 8, 30, 3), (2, 6, 25, 4), (3, 10, 22, 2)])
def test_subsequence_dp_equals_brute_force_over_all_windows(seed, n0, n1, depth):
    R0, R1 = _random_curves(seed, n0, n1)
    got = subsequence_align(R0, R1, depth=depth, method="numpy")
    best, where = np.inf, None
    for s in range(n1):
        for e in range(s + 1, n1):
            if required_depth(n0, e - s + 1) > depth:
                continue  # beyond the slope limit: no path of the fixed step set reaches it
            d = elastic_distance(R0, R1[s:e + 1], depth=depth)
            if d < best:
                best, where = d, (s, e)
    assert got.distance == pytest.approx(best, rel=1e-9, abs=1e-12)
    assert (got.start, got.end) == where
    assert tuple(got.nodes[0]) == (0, got.start) and tuple(got.nodes[-1]) == (n0 - 1, got.end)


def test_subsequence_finds_a_planted_piece_with_zero_cost():
    _, R1 = _random_curves(4, 5, 40)
    R0 = R1[12:25] @ np.swapaxes(R1[12], -1, -2)  # the piece, right-translated: the SRVT does not see it
    got = subsequence_align(R0, R1, depth=3)
    assert (got.start, got.end) == (12, 24)
    assert got.distance < 1e-6


@pytest.mark.skipif(not _dp_kernels.HAVE_NUMBA, reason="numba missing")
def test_numba_and_numpy_kernels_are_identical():
    R0, R1 = _random_curves(5, 12, 50, joints=3)
    Q0, Q1, h, t, coef, B0, B1 = subsequence._problem(R0, R1, 5)
    G = _dp_kernels.gram(Q0, Q1)
    args = (G, B0, B1, t["di"], t["dj"], t["start"], t["ea"], t["eb"], coef)
    A1, b1 = subsequence_dp_numpy(*args)
    A2, b2 = subsequence_dp_numba(*args)
    assert np.array_equal(A1, A2) and np.array_equal(b1, b2)
    a, b = subsequence_align(R0, R1, 5, method="numpy"), subsequence_align(R0, R1, 5, method="numba")
    assert (a.start, a.end, a.energy) == (b.start, b.end, b.energy)


def test_path_costs_split_the_energy_exactly():
    R0, R1 = _random_curves(6, 9, 31, joints=3)
    got = subsequence_align(R0, R1, depth=4)
    costs = path_costs(R0, R1, got.nodes)
    assert costs.shape == (8, 3) and costs.min() >= -1e-15
    assert costs.sum() == pytest.approx(got.energy, rel=1e-9)
    _, dist, info = elastic_align(R0, R1[:12], depth=4, return_info=True)
    pinned = path_costs(R0, R1[:12], info["nodes"], same_spacing=False)
    assert pinned.sum() == pytest.approx(dist ** 2, rel=1e-9)


# --------------------------------------------------------------------------------------- windows

def test_window_signatures_are_chen_products_of_prefixes():
    rng = np.random.default_rng(7)
    dx = rng.normal(0, 0.1, (40, 4))
    wins, grid = clip_windows(11, 41, scales=(0.8, 1.25), stride=0.3)
    where = {p: i for i, p in enumerate(grid)}
    logs = window_log_signatures(prefix_signatures(dx, grid, 2), [(where[s], where[e]) for s, e in wins], 4, 2)
    for (s, e), got in zip(wins, logs):
        want = tensor.flatten(tensor.log(tensor.signature_from_increments(dx[s:e], 2)))
        assert np.allclose(got, want, atol=1e-12)
    assert wins[-1][1] == 40  # the last window ends on the last frame


@pytest.mark.parametrize("first,last,speed", [(101, 340, 0.8), (201, 380, 1.25), (31, 190, 1.0)])
def test_retimed_excerpt_is_found_first_in_its_take(library, first, last, speed):
    take = library["16_15"]
    query = retimed_excerpt(take, first, last, speed)
    assert query.frames == round((last - first) / speed) + 1
    results = rank_windows(query, list(library.values()), rerank=3)
    best = results[0]
    assert best.name == "16_15" and best.elastic is not None
    assert _iou((best.start, best.end), (first, last)) >= 0.5
    assert all(r.elastic is None or r.elastic > best.elastic for r in results[1:])


def test_windows_are_named_in_the_clips_own_frame_numbers(library):
    take = library["16_15"]
    query = retimed_excerpt(take, 251, 420, 1.25)
    cropped = _read("16_15", start=200)  # frames 200..471 of the take, numbered as in the take
    assert cropped.frame_start == 200
    best = rank_windows(query, [cropped, library["07_01"]], rerank=2)[0]
    assert best.name == "16_15"
    assert _iou((best.start, best.end), (251, 420)) >= 0.5
    signature_only = rank_windows(query, [cropped], rerank=0)[0]
    assert signature_only.elastic is None and 200 <= signature_only.start < signature_only.end <= 471


# --------------------------------------------------------------------------------------- explanations

def test_one_perturbed_bone_gets_the_largest_share(library):
    clip = library["07_01"]
    j = clip.bones.index("forearm.L")
    R = clip.rotations.copy()
    wobble = np.zeros((clip.frames, 3))
    wobble[:, 0] = 0.4 * np.sin(np.linspace(0, 6 * np.pi, clip.frames))
    R[:, j] = so3.exp(wobble) @ R[:, j]
    from dataclasses import replace

    out = explain_clips(clip, replace(clip, rotations=R, name="wobbly"))
    shares = out["joints"]
    assert sum(shares.values()) == pytest.approx(1.0, abs=1e-12)
    assert min(shares.values()) >= 0.0
    assert max(shares, key=shares.get) == "forearm.L"
    assert max(out["groups"], key=out["groups"].get) == "left arm"
    assert sum(out["groups"].values()) == pytest.approx(1.0, abs=1e-12)
    assert len(out["cost_over_time"]) > 10 and sum(out["cost_over_time"]) == pytest.approx(out["energy"])


def test_explanation_of_a_moment(library):
    take = library["16_15"]
    query = retimed_excerpt(take, 101, 340, 1.25)
    best = rank_windows(query, [take, library["07_02"]], rerank=2, explain=True)[0]
    ex = best.explain
    assert sum(ex["joints"].values()) == pytest.approx(1.0, abs=1e-12)
    # one cost per interval of the query on the comparison lattice (core.clip.prepare: floor, anchored at frame 1)
    assert len(ex["cost_over_time"]) == lattice_frames(query.frames, query.fps, ex["fps"]) - 1
    assert joint_group("thigh.R") == "right leg" and joint_group("Hips") is None
    with pytest.raises(Exception):
        explain_path(query.rotations, query.rotations, np.array([[0, 0], [1, 0]]), ["a"], same_spacing=True)


# --------------------------------------------------------------------------------------- the command line

@pytest.fixture(scope="module")
def folders(tmp_path_factory):
    base = tmp_path_factory.mktemp("moments")
    for sub, files in {"walk": ("07-walk.asf", "07_01.amc", "07_02.amc"), "long": ("16.asf", "16_15.amc")}.items():
        (base / sub).mkdir()
        for f in files:
            shutil.copy(ACC / f, base / sub / f)
    return base


def test_cli_rank_windows_json(folders, capsys):
    code = cli.main(["rank", str(folders / "walk" / "07_01.amc"), str(folders / "long" / "16_15.amc"),
                     str(folders / "walk" / "07_02.amc"), "--windows", "--explain", "1", "--json", "--no-cache"])
    assert code == 0
    out = json.loads(capsys.readouterr().out)
    rows = out["results"]
    assert {r["clip"] for r in rows} == {"07_02", "16_15"} and out["metric"] == "pose windows"
    assert len(rows) == 2  # a whole walk as the query: one walk's length fits each take once
    for r in rows:
        assert isinstance(r["start"], int) and r["start"] <= r["end"] and r["elastic"] is not None
    assert rows[0]["path"].endswith(".amc")
    ex = rows[0]["explain"]
    assert sum(ex["joints"].values()) == pytest.approx(1.0) and ex["cost_over_time"]
    assert "explain" not in rows[1]
    code = cli.main(["rank", str(folders / "walk" / "07_01.amc"), str(folders / "walk" / "07_02.amc"),
                     "--windows", "--metric", "elastic", "--no-cache"])
    assert code == 2


def test_a_one_frame_pose_in_the_library_is_skipped_with_a_warning(library):
    """A pose (one frame, as a pose-library action) cannot hold a moment: it is left out with one warning naming it,
    and the takes are still ranked."""
    take = library["16_15"]
    pose = take.crop(take.frame_start + 40, take.frame_start + 40)
    pose = pose.__class__(**{**pose.__dict__, "name": "a_pose"})
    query = retimed_excerpt(take, 101, 340, 1.0)
    results = rank_windows(query, [pose] + list(library.values()), rerank=2)
    assert results[0].name == "16_15" and "a_pose" not in [r.name for r in results]
    assert [w for w in results.warnings if "a_pose" in w] == [w for w in results.warnings if "a_pose" in w][:1]
    assert any("a_pose" in w and "frame" in w for w in results.warnings)
