"""The bridge's parts (core.blend.bridge) against closed forms: the per-frame average of k identical candidates is
the candidate, of two rotations with equal weights their geodesic midpoint, of root heads their weighted mean; a
segment's cost over the gap is linear in time, its whole cost at mid-gap and twice its start's (end's) match plus
the rest at the last known pose (the target); the offsets put a segment on both ends exactly, and leave a segment
that already joins them (a turned and moved copy of the truth) as it is."""

import pathlib

import numpy as np

from blender_shapesig.core.blend.body import aligned_and_root
from blender_shapesig.core.blend.bridge import Segment, _meet, average, gap_costs
from blender_shapesig.core.clip.skeleton import rest_of
from blender_shapesig.core.geometry import so3
from blender_shapesig.core.io.sources import read_one

DATA = pathlib.Path(__file__).resolve().parents[2] / "data"


def _rotations(rng, shape):
    return so3.exp(rng.normal(size=shape + (3,)))


def test_average_of_identical_candidates_is_the_candidate():
    rng = np.random.default_rng(3)
    X = _rotations(rng, (7, 5))
    root = rng.normal(size=(7, 3))
    w = rng.uniform(0.1, 2.0, size=(4, 7))
    got_X, got_root = average(np.repeat(X[None], 4, axis=0), np.repeat(root[None], 4, axis=0), w)
    np.testing.assert_allclose(got_X, X, atol=1e-12)
    np.testing.assert_allclose(got_root, root, atol=1e-12)


def test_average_of_two_rotations_is_their_geodesic_midpoint_and_roots_their_weighted_mean():
    rng = np.random.default_rng(4)
    A, B = _rotations(rng, (6, 3)), _rotations(rng, (6, 3))
    mid = A @ so3.exp(0.5 * so3.log(np.swapaxes(A, -1, -2) @ B))
    pa, pb = rng.normal(size=(6, 3)), rng.normal(size=(6, 3))
    w = np.array([np.full(6, 2.0), np.full(6, 2.0)])
    got_X, _ = average(np.array([A, B]), np.array([pa, pb]), w)
    np.testing.assert_allclose(got_X, mid, atol=1e-9)
    t = np.linspace(0.1, 0.9, 6)  # frame by frame: weight t on the first
    _, got_root = average(np.array([A, B]), np.array([pa, pb]), np.array([3 * t, 3 * (1 - t)]))
    np.testing.assert_allclose(got_root, t[:, None] * pa + (1 - t)[:, None] * pb, atol=1e-12)


def test_gap_costs_weigh_the_start_near_the_start_and_the_end_near_the_target():
    frames = 9
    segs = [Segment(0, 0, 10, 1.0 + 3.0 + 0.5, 1.0, 3.0), Segment(1, 4, 12, 0.2 + 0.0 + 0.1, 0.2, 0.0)]
    c = gap_costs(segs, frames)
    s = np.arange(1, frames + 1) / (frames + 1.0)
    for seg, row in zip(segs, c):
        rest = seg.cost - seg.start_cost - seg.end_cost
        np.testing.assert_allclose(row, 2 * (1 - s) * seg.start_cost + 2 * s * seg.end_cost + rest, atol=1e-12)
        assert abs(row[frames // 2] - seg.cost) < 1e-12  # mid-gap (s = 1/2): the whole cost
        assert np.all(np.diff(row, 2) < 1e-12) and np.all(np.diff(row, 2) > -1e-12)  # linear in time


def test_offsets_meet_both_ends_exactly_and_keep_a_segment_that_joins_them():
    clip = read_one(str(DATA / "bvh" / "07_01.bvh"), bone_map="none")
    X, root = aligned_and_root(clip)
    seg_X, seg_root = X[40:62], root[40:62]
    # another stretch of the take as the segment: it is put on the first ends exactly
    other_X, other_root = X[100:122], root[100:122]
    got_X, got_root = _meet(clip, other_X, other_root, seg_X[0], seg_root[0], seg_X[-1], seg_root[-1])
    np.testing.assert_allclose(got_X[0], seg_X[0], atol=1e-9)
    np.testing.assert_allclose(got_X[-1], seg_X[-1], atol=1e-9)
    np.testing.assert_allclose(got_root[[0, -1]], seg_root[[0, -1]], atol=1e-9)
    # the segment itself, turned about up and moved on the ground, comes back as it was
    rest = rest_of(clip)
    tops = np.flatnonzero(rest.ancestor < 0)
    T = so3.exp(np.array([0.0, 0.0, 0.7]))
    turned_X = seg_X.copy()
    turned_X[:, tops] = T[None, None] @ turned_X[:, tops]
    turned_root = seg_root @ T.T + np.array([30.0, -12.0, 0.0])
    got_X, got_root = _meet(clip, turned_X, turned_root, seg_X[0], seg_root[0], seg_X[-1], seg_root[-1])
    np.testing.assert_allclose(got_X, seg_X, atol=1e-9)
    np.testing.assert_allclose(got_root, seg_root, atol=1e-9)
