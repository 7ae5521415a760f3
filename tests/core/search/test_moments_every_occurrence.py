"""Moments list every occurrence in a take (non-maximum suppression within a take, not one window per take): a long
take built from 14 CMU clips of tests/data (walks, runs and five copies of the forward jump 13_32 at other speeds;
``tests/helpers/long_take.py``), its jumps labelled from the feet's height; a jump of 13_32 finds all five first, each
with its frames. Also: the free-window DTW (``local_dtw.subsequence_dtw``) against brute force."""

import numpy as np
import pytest

from blender_shapesig.core.search.local.dtw import dtw, subsequence_dtw
from blender_shapesig.core.search.moments.windows import rank_windows
from blender_shapesig.core.io import sources
from blender_shapesig.core.io.bvh import load_bvh
from tests.helpers.long_take import airborne, build_take

JUMP = "13_32.bvh"
SEGMENTS = [("07_01.bvh", 1.0), (JUMP, 1.0), ("09_02.bvh", 1.0), ("08_01.bvh", 0.9), (JUMP, 0.8),
            ("09_03.bvh", 1.1), ("07_02.bvh", 1.0), (JUMP, 1.25), ("09_02.bvh", 0.9), ("08_01.bvh", 1.2),
            (JUMP, 1.1), ("07_01.bvh", 0.9), (JUMP, 0.9), ("09_03.bvh", 1.0)]


def _legs(clip):
    rest = clip.meta["rest_heads"]
    return float(np.mean([np.linalg.norm(np.subtract(rest[f"{s}Thigh"], rest[f"{s}Foot"])) for s in "lr"]))


@pytest.fixture(scope="module")
def take(data_dir, tmp_path_factory):
    path = tmp_path_factory.mktemp("long_take") / "long_take.bvh"
    spans = build_take([(data_dir / "bvh" / name, speed) for name, speed in SEGMENTS], path)
    raw = load_bvh(path)
    jumps = airborne(raw, ("lFoot", "rFoot"), _legs(raw))
    return path, spans, jumps


def test_the_jumps_are_labelled_in_the_jump_segments(take, data_dir):
    _path, spans, jumps = take
    jump_spans = [span for span, (name, _) in zip(spans, SEGMENTS) if name == JUMP]
    assert len(jumps) == len(jump_spans) == 5  # the runs' flight phases are too short, the walks never leave
    for (a, b), (first, last) in zip(jumps, jump_spans):
        assert first <= a <= b <= last
    raw = load_bvh(data_dir / "bvh" / JUMP)
    assert airborne(raw, ("lFoot", "rFoot"), _legs(raw)) == [(181, 227)]  # the query's own flight


@pytest.mark.parametrize("rerank", [0, None])  # signatures only, and the default refinement
def test_a_jump_finds_every_jump_of_the_long_take(take, data_dir, rerank):
    path, _spans, jumps = take
    query = sources.read_one(sources.ClipSpec(str(data_dir / "bvh" / JUMP), bone_map="auto", start=151, end=257))
    library = [sources.read_one(sources.ClipSpec(str(path), bone_map="auto")),
               sources.read_one(sources.ClipSpec(str(data_dir / "bvh" / "09_03.bvh"), bone_map="auto"))]
    got = rank_windows(query, library, rerank=rerank, top=15)
    assert got.stats["metric"] == "pose windows" and got.stats["moments"] > 15
    rows = [r for r in got if r.name == "long_take"]
    assert len(rows) >= 12  # every window of the take the suppression keeps, not one
    found = [[k for k, (a, b) in enumerate(jumps) if r.start <= (a + b) / 2 <= r.end] for r in rows[:len(jumps)]]
    assert sorted(k for hit in found for k in hit) == list(range(len(jumps)))  # the first five: the five jumps
    spans = sorted((r.start, r.end) for r in rows)  # no window holds another's centre
    assert all(e0 < (s1 + e1) / 2 and (s0 + e0) / 2 < s1 for (s0, e0), (s1, e1) in zip(spans, spans[1:]))
    if rerank is None:  # the refinement fills elastic on the first 10 and keeps their windows and order
        plain = rank_windows(query, library, rerank=0, top=15)
        assert [(r.name, r.start, r.end) for r in got] == [(r.name, r.start, r.end) for r in plain]
        assert all(r.elastic is not None for r in got[:10]) and all(r.elastic is None for r in got[10:])


@pytest.mark.parametrize("seed", range(6))
def test_subsequence_dtw_equals_brute_force(seed):
    rng = np.random.default_rng(seed)
    a, b = rng.normal(size=(rng.integers(1, 7), 3)), rng.normal(size=(rng.integers(1, 16), 3))
    cost, start = subsequence_dtw(a, b)
    for j in range(len(b)):
        best = min(dtw(a, b[s:j + 1]) ** 2 for s in range(j + 1))
        assert cost[j] == pytest.approx(best, rel=1e-12, abs=1e-12)
        assert dtw(a, b[start[j]:j + 1]) ** 2 == pytest.approx(cost[j], rel=1e-12, abs=1e-12)
