"""The bridge's offsets (core.blend.bridge._meet) against closed forms: a library segment is put on both ends of the
gap exactly, and a segment that already joins them (a turned and moved copy of the truth) is left as it is."""

import pathlib

import numpy as np

from blender_shapesig.core.blend.body import aligned_and_root
from blender_shapesig.core.blend.bridge import _meet
from blender_shapesig.core.clip.skeleton import rest_of
from blender_shapesig.core.geometry import so3
from blender_shapesig.core.io.sources import read_one

DATA = pathlib.Path(__file__).resolve().parents[2] / "data"


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
