"""The preparation of the elastic DP. The compiled SRVT pass (core.elastic._srvt_kernel) against the numpy route
(curves.srvt): the same values to ~1e-14 relative, including steps near 0, at the ZERO_STEP threshold, near and at
pi, and still joints; the numpy route for norm="group" and without numba. The Gram matrix: its summation contract
(groups of four columns, then the rest), bit for bit, for any row count."""

import pathlib

import numpy as np
import pytest

from blender_shapesig.core.elastic import _dp_kernels, _srvt_kernel, elastic
from blender_shapesig.core.geometry import curves, so3
from blender_shapesig.core.io.acclaim import load_acclaim

needs_numba = pytest.mark.skipif(not _srvt_kernel.HAVE_NUMBA, reason="numba not installed")
DATA = pathlib.Path(__file__).resolve().parents[2] / "data" / "acclaim"


def numpy_route(R, norm="joint"):
    q = curves.srvt(R, norm=norm)
    return q.reshape(q.shape[0], -1)


def assert_close(R):
    want = numpy_route(R)
    got, joints = elastic._srvt_matrix(R, "R")
    assert joints == R.shape[1] and got.shape == want.shape and got.flags.c_contiguous
    scale = max(float(np.abs(want).max()), 1e-300)
    assert np.abs(got - want).max() <= 1e-14 * scale
    assert np.array_equal(got == 0.0, want == 0.0)  # the zero rule acts on the same entries


def steps_of_angles(angles, joints=4, frames=40, seed=0):
    """A curve whose every step has one of ``angles`` (radians) about a random axis, random start pose."""
    rng = np.random.default_rng(seed)
    axes = rng.normal(size=(frames - 1, joints, 3))
    axes /= np.linalg.norm(axes, axis=-1, keepdims=True)
    ang = rng.choice(np.asarray(angles, dtype=np.float64), size=(frames - 1, joints, 1))
    start = so3.exp(rng.normal(size=(joints, 3)))
    return so3.integrate(axes * ang, start)


@needs_numba
def test_real_curve():
    R = load_acclaim(DATA / "07_01.amc", DATA / "07-walk.asf").rotations[:300]
    assert_close(R)


@needs_numba
@pytest.mark.parametrize("angles", [
    [0.0, 1e-13, 0.999e-12, 1.001e-12, 1e-9, 1e-6],           # still joints and the ZERO_STEP threshold
    [0.3, np.pi / 2 - 1e-9, np.pi / 2, np.pi / 2 + 1e-9, 2.0],  # around the branch at pi/2
    [np.pi - 1e-3, np.pi - 1e-7, np.pi - 1e-12, np.pi],        # near and at pi
])
def test_small_and_large_steps(angles):
    for seed in range(3):
        assert_close(steps_of_angles(angles, seed=seed))


@needs_numba
def test_still_joint_and_exact_identity_steps():
    R = steps_of_angles([0.2, 2.5], joints=3, frames=25, seed=4)
    R[:, 1] = R[0, 1]  # a joint that never moves: q = 0 exactly
    R[10:13, 2] = R[10, 2]  # a pause
    assert_close(R)
    assert not np.any(elastic._srvt_matrix(R, "R")[0][:, 3:6])


@needs_numba
def test_quaternion_input_and_two_frames():
    R = steps_of_angles([0.4], joints=2, frames=2, seed=5)
    assert_close(R)
    quats = so3.quat_from_matrix(steps_of_angles([0.1, 1.0], joints=2, frames=9, seed=6), scalar_first=False)
    np.testing.assert_allclose(elastic._srvt_matrix(quats, "R")[0], numpy_route(curves.as_curve(quats)),
                               rtol=0, atol=1e-14)


def test_group_norm_takes_the_numpy_route():
    R = steps_of_angles([0.0, 0.3, 1.2], joints=3, frames=12, seed=7)
    with curves.use_srvt_norm("group"):
        got, _ = elastic._srvt_matrix(R, "R")
    assert np.array_equal(got, numpy_route(R, "group"))


def test_numpy_route_without_numba(monkeypatch):
    R = steps_of_angles([0.3, 3.0], joints=2, frames=10, seed=8)
    monkeypatch.setattr(_dp_kernels, "HAVE_NUMBA", False)
    got, _ = elastic._srvt_matrix(R, "R")
    assert np.array_equal(got, numpy_route(R))


def gram_contract(Q0, Q1):
    """G = Q0 Q1^T summed as _dp_kernels.gram documents: ((x0 q0 + x1 q1) + (x2 q2 + x3 q3)) per group of four
    columns, added left to right, then the remaining columns one by one."""
    c = Q0.shape[1]
    c4 = c - c % 4
    G = np.zeros((Q0.shape[0], Q1.shape[0]))
    o = [np.outer(Q0[:, r], Q1[:, r]) for r in range(c)]
    for r in range(0, c4, 4):
        G += (o[r] + o[r + 1]) + (o[r + 2] + o[r + 3])
    for r in range(c4, c):
        G += o[r]
    return G


@pytest.mark.parametrize("n0, n1, c", [(1, 1, 3), (2, 5, 6), (3, 7, 9), (5, 4, 93), (8, 9, 4), (301, 17, 11)])
def test_gram_contract_bit_for_bit(n0, n1, c):
    rng = np.random.default_rng(n0 * 1000 + n1)
    Q0, Q1 = rng.normal(size=(n0, c)), rng.normal(size=(n1, c))
    G = _dp_kernels.gram(Q0, Q1)
    if _dp_kernels.HAVE_NUMBA:
        assert np.array_equal(G, gram_contract(Q0, Q1))
    else:  # numpy's matmul: the same to rounding
        np.testing.assert_allclose(G, gram_contract(Q0, Q1), rtol=1e-12, atol=1e-12)


# ------------------------------------------------------------------------------------ reused work arrays


def fresh_distance(R0, R1, **kw):
    """elastic_distance without the reused work arrays (the distance matrix's route)."""
    return float(elastic.elastic_distance_matrix([R0, R1], workers=1, **kw)[0, 1])


def test_reused_work_arrays_give_the_same_values_across_sizes(monkeypatch):
    """Successive calls of different sizes (the arrays grow, then serve smaller problems) equal fresh arrays bit
    for bit, also with every array above MAX_BYTES (allocated per call) and after release()."""
    from blender_shapesig.core.elastic import _workspace

    pairs = [(steps_of_angles([0.1, 0.4, 2.0], joints=j, frames=f, seed=f) for f in (f0, f1)) for j, f0, f1 in
             ((3, 40, 37), (5, 61, 64), (2, 9, 12), (5, 61, 64), (1, 2, 3))]
    pairs = [tuple(p) for p in pairs]
    want = [fresh_distance(R0, R1) for R0, R1 in pairs]
    assert [elastic.elastic_distance(R0, R1) for R0, R1 in pairs] == want
    _workspace.release()
    monkeypatch.setattr(_workspace, "MAX_BYTES", 64)
    assert [elastic.elastic_distance(R0, R1) for R0, R1 in pairs] == want
    warp, d = elastic.elastic_align(*pairs[1])
    assert d == want[1] and warp[0].tolist() == [0.0, 0.0]


def test_reused_work_arrays_are_per_thread():
    from concurrent.futures import ThreadPoolExecutor

    pairs = [(steps_of_angles([0.2, 1.0], joints=4, frames=30 + n, seed=n),
              steps_of_angles([0.3, 0.6], joints=4, frames=35 - n, seed=50 + n)) for n in range(6)]
    want = [elastic.elastic_distance(R0, R1) for R0, R1 in pairs]
    with ThreadPoolExecutor(max_workers=3) as pool:
        for _ in range(3):
            assert list(pool.map(lambda p: elastic.elastic_distance(*p), pairs)) == want
