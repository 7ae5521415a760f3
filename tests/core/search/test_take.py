"""The whole take's signature (``core.search.local.take``) against independent computations: the Levy areas of the
development in closed form (a matrix product, not iisignature), the package's ``linear2`` on the joints two rigs
share; its invariance to a converter's constant bone offsets; and the twin rule on made-up shortlists."""

import dataclasses

import numpy as np
import pytest

from blender_shapesig.core import rigs
from blender_shapesig.core.clip.prepare import prepare_clip
from blender_shapesig.core.geometry import so3
from blender_shapesig.core.search.local import take
from blender_shapesig.core.search.local.entry import LocalEntry, Take
from blender_shapesig.core.io import sources
from blender_shapesig.core.signatures import signatures as sg


def _mapped(path, asf=None):
    raw = sources.read_one(sources.ClipSpec(str(path), asf=None if asf is None else str(asf), bone_map="none"))
    return rigs.apply_bone_map(raw, "auto")


@pytest.fixture(scope="module")
def walks(data_dir):
    a = data_dir / "acclaim"
    return {"amc": _mapped(a / "07_01.amc", a / "07-walk.asf"), "daz": _mapped(data_dir / "bvh" / "07_01.bvh"),
            "iclone": _mapped(data_dir / "cross_rig" / "002_03.bvh")}


def _areas_closed_form(clip, joints):
    """Level 1 and the Levy areas A_ij = 1/2 sum_k (X_k,i dX_k,j - X_k,j dX_k,i) of the development on ``joints``
    (a matrix product), X from 0."""
    c = prepare_clip(clip, smooth=0.0)
    R = c.rotations[:, [c.bones.index(j) for j in joints]]
    dX = np.stack([so3.log(R[k + 1] @ np.swapaxes(R[k], -1, -2)) for k in range(len(R) - 1)]).reshape(len(R) - 1, -1)
    X = np.vstack([np.zeros(dX.shape[1]), np.cumsum(dX, axis=0)])[:-1]
    A = 0.5 * (X.T @ dX - dX.T @ X)
    iu = np.triu_indices(dX.shape[1], 1)
    return np.concatenate([dX.sum(axis=0), A[iu]])


def _layout(joints):
    """The take's channels of ``joints`` (level 1, then level 2 in [i, j], i < j order)."""
    ch = np.zeros(take.CHANNELS, bool)
    for j in joints:
        k = take.JOINTS.index(j)
        ch[3 * k:3 * k + 3] = True
    iu = np.triu_indices(take.CHANNELS, 1)
    return np.concatenate([ch, ch[iu[0]] & ch[iu[1]]])


def test_take_is_the_level_2_log_signature_of_the_development(walks):
    clip = walks["amc"]
    e = take.take_entry(clip)
    assert e.take.shape == (take.DIM,) and e.take.dtype == np.float32
    have = [j for j in take.JOINTS if j in clip.bones]
    assert [take.JOINTS[k] for k in np.flatnonzero(e.take_mask)] == have
    got = e.take[_layout(have)]
    want = _areas_closed_form(clip, have)
    assert np.allclose(got, want, rtol=1e-5, atol=1e-5 * np.abs(want).max())
    # the channels of joints the rig lacks are zeros
    assert not np.any(e.take[~_layout(have)])
    assert e.seconds == pytest.approx((clip.frames - 1) / clip.fps)


def test_distance_is_linear2_on_the_joints_both_rigs_have(walks):
    a, full = walks["amc"], walks["iclone"]
    # a rig without toes and clavicles (the comparison space leaves out the joints a rig lacks)
    keep = [i for i, j in enumerate(full.bones) if not j.startswith(("toe", "clavicle"))]
    b = dataclasses.replace(full, bones=tuple(full.bones[i] for i in keep), rotations=full.rotations[:, keep])
    shared = [j for j in take.JOINTS if j in a.bones and j in b.bones]
    assert len(shared) == len(take.JOINTS) - 4
    got = take.take_distances(take.take_entry(a), [take.take_entry(b)])[0]
    pa, pb = prepare_clip(a, smooth=0.0), prepare_clip(b, smooth=0.0)
    want = sg.linear_distance(pa.rotations[:, [pa.bones.index(j) for j in shared]],
                              pb.rotations[:, [pb.bones.index(j) for j in shared]], 2, drop_still=False)
    assert got == pytest.approx(want, rel=1e-4)


def test_constant_bone_offsets_do_not_change_the_take(walks):
    """A converter that leaves every bone turned by a constant rotation (R -> R Q_j) changes no increment
    log(R[k+1] R[k]^T), so not the take."""
    clip = walks["daz"]
    rng = np.random.default_rng(3)
    Q = so3.exp(rng.normal(scale=0.6, size=(len(clip.bones), 3)))
    turned = dataclasses.replace(clip, rotations=clip.rotations @ Q[None])
    a, b = take.take_entry(clip).take, take.take_entry(turned).take
    assert np.allclose(a, b, atol=1e-4 * np.abs(a).max())
    assert take.take_distances(take.take_entry(clip), [take.take_entry(turned)])[0] < 1e-3 * np.linalg.norm(a)


def _entry(vec, seconds, mask=None):
    t = np.zeros(take.DIM, np.float32)
    t[:len(vec)] = vec
    m = np.ones(len(take.JOINTS), np.uint8) if mask is None else mask
    return Take(t, m, np.float32(seconds))


def _shortlist():
    """A query of 3 s; candidates: 0 another take (first by score), 1 the twin (3.05 s, its take near), 2-5 far."""
    q = _entry([1.0, 0.0], 3.0)
    c = [_entry([1.0, 2.0], 3.1), _entry([1.0, 0.3], 3.05)] + [_entry([1.0, 2.0 + k], 2.0 + k) for k in range(4)]
    score = np.array([1.0, 1.2, 1.5, 1.6, 1.7, 1.8])
    return q, c, score


def test_twin_in_the_shortlist_ranks_first():
    q, c, score = _shortlist()
    out = take.twin_first(q, c, score)
    assert int(np.argmin(out)) == 1
    g = take.take_distances(q, c)
    gate = take.TWIN_RATIO * np.median(g)
    assert out[1] == pytest.approx(score[0] * g[1] / gate)  # below the old first's score by the twin's margin
    assert np.array_equal(np.delete(out, 1), np.delete(score, 1))


def test_twin_rule_keeps_the_order_when_it_does_not_apply():
    q, c, score = _shortlist()
    # the first is longer than the query by more than "the same length" (8 %) and may hold the query (a cut): it
    # stays unless the twin holds the query's windows better
    longer = [_entry([1.0, 2.0], 3.0 * 1.09)] + c[1:]
    assert np.array_equal(take.twin_first(q, longer, score), score)
    asked = []

    def held(clips, values):
        asked.append([id(x) for x in clips])
        return values

    assert np.array_equal(take.twin_first(q, longer, score, lambda cl: held(cl, [0.5, 0.2])), score)
    assert asked == [[id(longer[1]), id(longer[0])]]  # the twin's, then the first's
    assert int(np.argmin(take.twin_first(q, longer, score, lambda cl: held(cl, [0.2, 0.5])))) == 1
    # the twin is not of the query's length
    off = [c[0], _entry([1.0, 0.3], 3.0 * 1.09)] + c[2:]
    assert np.array_equal(take.twin_first(q, off, score), score)
    # its take is not far enough below the shortlist's median
    near = [c[0], _entry([1.0, 1.5], 3.05)] + c[2:]
    assert np.array_equal(take.twin_first(q, near, score), score)
    # the first is the query's exact copy (score 0), entries without a take, a shortlist of one
    zero = score.copy()
    zero[0] = 0.0
    assert np.array_equal(take.twin_first(q, c, zero), zero)
    assert np.array_equal(take.twin_first(LocalEntry(np.zeros((1, 1)), np.zeros((1, 1)), np.zeros(10), name="q"), c,
                                          score), score)
    assert np.array_equal(take.twin_first(q, c[:1], score[:1]), score[:1])


def test_only_joints_both_have_count():
    """A joint one rig lacks (zeros in its take) does not add to the distance."""
    mask = np.ones(len(take.JOINTS), np.uint8)
    mask[0] = 0
    a = _entry([1.0, 2.0, 3.0, 5.0], 3.0)
    b = _entry([7.0, 8.0, 9.0, 5.0], 3.0, mask)  # joint 0's channels differ, but b has no joint 0
    assert take.take_distances(a, [b])[0] == pytest.approx(0.0)
    assert take.take_distances(a, [_entry([1.0, 2.0, 3.0, 6.0], 3.0)])[0] == pytest.approx(1.0)

