"""Tests of the elastic distance d_S* (reference secs. 4.3, 6.2).

The truths used here are independent of the DP's overlap table: a brute-force search over all
monotone grid paths with an energy integrated on explicitly merged breakpoints (``path_energy``),
exact reparametrizations, the definition of d_P*, and real CMU clips.
"""

import importlib
import importlib.util
import itertools
import math
import sys

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from scipy.spatial.transform import Rotation

from blender_shapesig.core.elastic import _dp_kernels, _dp_threads, elastic
from blender_shapesig.core.geometry.curves import l2_distance, move_to_identity, srvt
from blender_shapesig.core.elastic.elastic import (
    elastic_align,
    elastic_distance,
    elastic_distance_matrix,
    reparametrize,
    required_depth,
    warp_grid,
)
from blender_shapesig.core.errors import CurveError, ShapeSigError

METHODS = ["numpy"] + (["numba"] if _dp_kernels.HAVE_NUMBA else [])


# ---------------------------------------------------------------------------------------------
# helpers


def random_curve(frames, joints=2, seed=0, scale=0.3):
    """A random curve with increments of about ``scale`` radians per frame."""
    rng = np.random.default_rng(seed)
    steps = rng.normal(size=(frames, joints, 3)) * scale
    R = np.empty((frames, joints, 3, 3))
    R[0] = Rotation.from_rotvec(rng.normal(size=(joints, 3))).as_matrix()
    for k in range(1, frames):
        R[k] = Rotation.from_rotvec(steps[k]).as_matrix() @ R[k - 1]
    return R


def smooth_curve(times, joints=3):
    """An analytic curve: per joint exp(f(t) w1) exp(g(t) w2), sampled at ``times``."""
    t = np.asarray(times)[:, None]
    out = np.empty((len(times), joints, 3, 3))
    for j in range(joints):
        w1 = np.array([1.0, 0.3 * j, -0.2])
        w2 = np.array([0.1, -0.5, 0.4 + 0.1 * j])
        a = Rotation.from_rotvec((np.sin(2.0 * t + j) * 1.2) * w1).as_matrix()
        b = Rotation.from_rotvec((t ** 2 * (1.5 + j) + 0.3 * np.cos(5 * t)) * w2).as_matrix()
        out[:, j] = a @ b
    return out


def path_energy(R0, R1, warp, penalty=0.0):
    """Energy of a piecewise-linear warp, integrated on explicitly merged breakpoints.

    int |q0(t) - q1(phi(t)) sqrt(phi'(t))|^2 dt + penalty * sum_{m>=1} (phi(t0_m) - t0_m)^2,
    with q0, q1 the piecewise-constant SRVTs on uniform grids; phi through the warp nodes.
    """
    q0 = srvt(move_to_identity(R0))
    q1 = srvt(move_to_identity(R1))
    n0, n1 = len(q0), len(q1)
    t0 = np.linspace(0, 1, n0 + 1)
    t1 = np.linspace(0, 1, n1 + 1)
    x, y = warp[:, 0], warp[:, 1]
    cuts = np.union1d(np.union1d(t0, x), np.interp(t1, y, x))
    total = 0.0
    for u, v in zip(cuts[:-1], cuts[1:]):
        if v - u <= 0:
            continue
        mid = 0.5 * (u + v)
        a = min(int(np.searchsorted(t0, mid, side="right")) - 1, n0 - 1)
        seg = min(int(np.searchsorted(x, mid, side="right")) - 1, len(x) - 2)
        slope = (y[seg + 1] - y[seg]) / (x[seg + 1] - x[seg])
        phi = y[seg] + slope * (mid - x[seg])
        b = min(int(np.searchsorted(t1, phi, side="right")) - 1, n1 - 1)
        diff = q0[a] - q1[b] * math.sqrt(slope)
        total += float(np.sum(diff * diff)) * (v - u)
    if penalty:
        total += penalty * float(np.sum((np.interp(t0[1:], x, y) - t0[1:]) ** 2))
    return total


def all_paths(n0, n1, depth, depth1=None):
    """Every chain of grid nodes (0, 0) < ... < (n0, n1) with steps of 1..depth rows and
    1..depth1 (default depth) columns."""
    out = []
    depth1 = depth if depth1 is None else depth1

    def walk(i, j, acc):
        if (i, j) == (n0, n1):
            out.append(list(acc))
            return
        for di in range(1, min(depth, n0 - i) + 1):
            for dj in range(1, min(depth1, n1 - j) + 1):
                acc.append((i + di, j + dj))
                walk(i + di, j + dj, acc)
                acc.pop()

    walk(0, 0, [(0, 0)])
    return out


def brute_force(R0, R1, depth, penalty=0.0, depth1=None):
    n0, n1 = len(R0) - 1, len(R1) - 1
    best = math.inf
    for nodes in all_paths(n0, n1, depth, depth1):
        nodes = np.array(nodes, dtype=float)
        warp = np.column_stack([nodes[:, 0] / n0, nodes[:, 1] / n1])
        best = min(best, path_energy(R0, R1, warp, penalty))
    return best


# ---------------------------------------------------------------------------------------------
# the DP against a brute-force search


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize(
    "f0, f1, depth, penalty, seed",
    [(6, 6, 3, 0.0, 1), (5, 7, 3, 0.0, 2), (7, 5, 2, 0.0, 3), (6, 7, 6, 0.0, 4),
     (6, 6, 3, 2.0, 5), (5, 7, 4, 10.0, 6), (4, 8, 3, 0.0, 7)],
)
def test_dp_equals_brute_force(f0, f1, depth, penalty, seed, method):
    R0 = random_curve(f0, seed=seed)
    R1 = random_curve(f1, seed=seed + 100)
    truth = brute_force(R0, R1, depth, penalty)
    for prune in (True, False):
        warp, d = elastic_align(R0, R1, depth=depth, penalty=penalty, method=method, prune=prune)
        assert d * d == pytest.approx(truth, rel=1e-10, abs=1e-12)
        # The returned warp attains the minimum.
        assert path_energy(R0, R1, warp, penalty) == pytest.approx(truth, rel=1e-10, abs=1e-12)


@settings(max_examples=25, deadline=None)
@given(
    f0=st.integers(2, 6), f1=st.integers(2, 6), depth=st.integers(1, 6),
    penalty=st.sampled_from([0.0, 0.5, 20.0]), seed=st.integers(0, 10_000),
)
def test_dp_equals_brute_force_random(f0, f1, depth, penalty, seed):
    R0 = random_curve(f0, seed=seed)
    R1 = random_curve(f1, seed=seed + 1)
    # Beyond the slope limit the long axis gets longer steps, the short one keeps the depth.
    need = required_depth(f0, f1)
    mi = need if need > depth and f0 > f1 else depth
    mj = need if need > depth and f1 > f0 else depth
    truth = brute_force(R0, R1, mi, penalty, depth1=mj)
    warp, d, info = elastic_align(R0, R1, depth=depth, penalty=penalty, return_info=True)
    assert info["max_step"] == (min(mi, f0 - 1), min(mj, f1 - 1))
    assert d * d == pytest.approx(truth, rel=1e-10, abs=1e-12)


# ---------------------------------------------------------------------------------------------
# properties


@pytest.mark.parametrize("f0, f1", [(40, 40), (35, 52)])
def test_warp_energy_evaluated_independently(f0, f1):
    R0 = random_curve(f0, joints=4, seed=21, scale=0.2)
    R1 = random_curve(f1, joints=4, seed=22, scale=0.2)
    warp, d = elastic_align(R0, R1)
    assert warp[0].tolist() == [0.0, 0.0] and warp[-1].tolist() == [1.0, 1.0]
    assert np.all(np.diff(warp, axis=0) > 0)
    assert path_energy(R0, R1, warp) == pytest.approx(d * d, rel=1e-9)
    # Steps 3 and 4 of sec. 6.2: reparametrize R1 on the exact grid, then d_P*.
    s = warp_grid(warp, f1)
    R1w = reparametrize(R1, None, warp, t_new=s)
    assert l2_distance(R0, R1w, t1=s) == pytest.approx(d, rel=1e-7)
    # And elastic_distance is the same number.
    assert elastic_distance(R0, R1) == d


def test_bounded_by_l2_for_equal_frames():
    for seed in range(4):
        R0 = random_curve(30, joints=3, seed=seed, scale=0.25)
        R1 = random_curve(30, joints=3, seed=seed + 50, scale=0.25)
        d = elastic_distance(R0, R1)
        l2 = l2_distance(R0, R1)
        assert d <= l2 + 1e-12
        assert d < 0.99 * l2  # random curves: the warp really helps
        # The diagonal warp (depth 1) is the L2 distance itself.
        assert elastic_distance(R0, R1, depth=1) == pytest.approx(l2, rel=1e-10)


@pytest.mark.parametrize("f0, f1", [(30, 30), (30, 47), (61, 25)])
def test_symmetric(f0, f1):
    R0 = random_curve(f0, joints=3, seed=31, scale=0.2)
    R1 = random_curve(f1, joints=3, seed=32, scale=0.2)
    for method in METHODS:
        assert abs(elastic_distance(R0, R1, method=method) - elastic_distance(R1, R0, method=method)) < 1e-10
    # The warps are each other's inverse.
    w01, _ = elastic_align(R0, R1)
    w10, _ = elastic_align(R1, R0)
    np.testing.assert_allclose(w01, w10[:, ::-1], atol=1e-14)


def test_right_invariant():
    R0 = random_curve(25, joints=2, seed=41)
    R1 = random_curve(31, joints=2, seed=42)
    g = Rotation.random(2, random_state=1).as_matrix()
    h = Rotation.random(2, random_state=2).as_matrix()
    assert elastic_distance(R0 @ g, R1 @ h) == pytest.approx(elastic_distance(R0, R1), rel=1e-9)


def test_quaternions_accepted():
    R0 = random_curve(20, joints=2, seed=43)
    R1 = random_curve(22, joints=2, seed=44)
    q0 = Rotation.from_matrix(R0.reshape(-1, 3, 3)).as_quat().reshape(20, 2, 4)
    assert elastic_distance(q0, R1) == pytest.approx(elastic_distance(R0, R1), rel=1e-9)


def _grid_step_pair(seed, steps):
    """R1 random on len(steps)+1 frames; R0 = R1 o phi on the grid of sum(steps)+1 frames,
    where phi maps ``steps[m]`` intervals of R0 onto interval m of R1. Exact: R1 o phi is
    geodesic between consecutive R0 samples."""
    R1 = random_curve(len(steps) + 1, joints=3, seed=seed, scale=0.4)
    n0 = sum(steps)
    nodes0 = np.concatenate([[0], np.cumsum(steps)]) / n0
    nodes1 = np.linspace(0, 1, len(steps) + 1)
    warp = np.column_stack([nodes0, nodes1])
    R0 = reparametrize(R1, None, warp, t_new=np.linspace(0, 1, n0 + 1))
    return R0, R1, warp


def test_zero_for_grid_step_reparametrization():
    rng = np.random.default_rng(7)
    steps = rng.integers(1, 4, size=30).tolist()  # di in 1..3, dj = 1
    R0, R1, true_warp = _grid_step_pair(51, steps)
    scale = l2_distance(R0, R1[np.linspace(0, len(R1) - 1, len(R0)).astype(int)])
    assert scale > 1.0
    warp, d = elastic_align(R0, R1, depth=4)
    assert d < 1e-6
    np.testing.assert_allclose(warp, true_warp, atol=1e-12)
    # And the other way round (steps (1, dj)).
    warp10, d10 = elastic_align(R1, R0, depth=4)
    assert d10 < 1e-6
    np.testing.assert_allclose(warp10, true_warp[:, ::-1], atol=1e-12)


def test_small_for_smooth_warp_and_shrinks():
    phi = lambda s: s + 0.15 * np.sin(np.pi * s) ** 2 * np.cos(np.pi * s)  # noqa: E731
    ds = []
    for frames in (31, 121):
        s = np.linspace(0, 1, frames)
        assert np.all(np.diff(phi(s)) > 0)
        c = smooth_curve(s)
        cphi = smooth_curve(phi(s))
        d = elastic_distance(c, cphi)
        l2 = l2_distance(c, cphi)
        assert d < 0.4 * l2
        ds.append((d, l2))
    # Measured: 0.164 / 0.507 at 31 frames, 0.060 / 0.506 at 121 (|q| is about 2.9).
    assert ds[1][0] < 0.15 * ds[1][1]
    assert ds[1][0] < 0.5 * ds[0][0]


def test_penalty_increases_distance_and_pulls_to_diagonal():
    R0 = random_curve(30, joints=2, seed=61, scale=0.2)
    R1 = random_curve(30, joints=2, seed=62, scale=0.2)
    w0, d0 = elastic_align(R0, R1)
    w1, d1 = elastic_align(R0, R1, penalty=1e6)
    assert d1 > d0
    # A huge penalty forces phi(t0_m) = t0_m at every node: the diagonal, d = d_P*.
    np.testing.assert_allclose(w1[:, 0], w1[:, 1], atol=1e-12)
    assert d1 == pytest.approx(l2_distance(R0, R1), rel=1e-10)


def test_pruning_changes_nothing():
    R0 = random_curve(40, joints=3, seed=71, scale=0.2)
    R1 = random_curve(33, joints=3, seed=72, scale=0.2)
    for penalty in (0.0, 0.3):
        a = elastic_distance(R0, R1, depth=6, penalty=penalty, prune=True)
        b = elastic_distance(R0, R1, depth=6, penalty=penalty, prune=False)
        assert a == pytest.approx(b, rel=1e-12)


def test_slope_limit_raises_depth():
    R0 = random_curve(5, joints=2, seed=81)
    R1 = random_curve(41, joints=2, seed=82)
    assert required_depth(5, 41) == 10
    warp, d, info = elastic_align(R0, R1, depth=3, return_info=True)
    assert info["depth"] == 10 and info["max_step"] == (3, 10)
    # Only one path is possible: four steps of (1, 10).
    np.testing.assert_allclose(warp, np.column_stack([np.linspace(0, 1, 5)] * 2))
    assert d * d == pytest.approx(path_energy(R0, R1, warp), rel=1e-10)
    _, _, info = elastic_align(R0, R1, depth=12, return_info=True)
    assert info["depth"] == 12
    # Extreme ratios: one interval against many (a single step), and a huge requested depth,
    # which is cut to the frame counts (same result as depth = frames).
    R2 = random_curve(2, joints=2, seed=83)
    R3 = random_curve(301, joints=2, seed=84)
    warp, d = elastic_align(R2, R3)
    assert warp.tolist() == [[0.0, 0.0], [1.0, 1.0]]
    assert d * d == pytest.approx(path_energy(R2, R3, warp), rel=1e-10)
    assert elastic_distance(R0, R1, depth=10**6) == elastic_distance(R0, R1, depth=40)
    # Absurd ratios: a clear error instead of a gigantic step table.
    with pytest.raises(CurveError, match="too different"):
        elastic_distance(random_curve(3, joints=1), random_curve(20001, joints=1, scale=0.01))


# ---------------------------------------------------------------------------------------------
# kernels


@pytest.mark.skipif(not _dp_kernels.HAVE_NUMBA, reason="numba not installed")
@pytest.mark.parametrize("penalty", [0.0, 0.7])
@pytest.mark.parametrize("f0, f1", [(50, 50), (64, 41)])
def test_kernels_identical(f0, f1, penalty):
    R0 = random_curve(f0, joints=5, seed=91, scale=0.15)
    R1 = random_curve(f1, joints=5, seed=92, scale=0.15)
    wa, da, ia = elastic_align(R0, R1, penalty=penalty, method="numba", return_info=True)
    wb, db, ib = elastic_align(R0, R1, penalty=penalty, method="numpy", return_info=True)
    assert ia["energy"] == ib["energy"]
    assert da == db
    assert np.array_equal(wa, wb)


@pytest.mark.skipif(not _dp_kernels.HAVE_NUMBA, reason="numba not installed")
@pytest.mark.parametrize("penalty", [0.0, 0.7])
@pytest.mark.parametrize("f0, f1", [(180, 180), (230, 150), (100, 500)])
def test_two_threads_identical(f0, f1, penalty):
    """The numba DP on two threads (column halves of each row block) gives the serial values and warps bit for bit."""
    R0 = random_curve(f0, joints=2, seed=93, scale=0.15)
    R1 = random_curve(f1, joints=2, seed=94, scale=0.15)
    band = elastic._band(f0 - 1, f1 - 1, *elastic._max_steps(f0 - 1, f1 - 1, 9))
    assert int(np.sum(band[1] - band[0] + 1)) >= _dp_kernels.PARALLEL_MIN_NODES  # the two-thread path runs
    wa, da, ia = elastic_align(R0, R1, penalty=penalty, method="numba", return_info=True, threads=1)
    wb, db, ib = elastic_align(R0, R1, penalty=penalty, method="numba", return_info=True, threads=2)
    assert ia["energy"] == ib["energy"] and da == db
    assert np.array_equal(wa, wb)
    assert elastic_distance(R0, R1, penalty=penalty, threads=2) == da
    with pytest.raises(ShapeSigError):
        elastic_distance(R0, R1, threads=0)


@pytest.mark.skipif(not _dp_kernels.HAVE_NUMBA, reason="numba not installed")
@pytest.mark.parametrize("penalty", [0.0, 0.7])
def test_two_threads_identical_dp_table_large_pair(penalty):
    """On the benchmark's size (300 x 300 frames, 31 joints), the whole DP value table filled on two threads equals
    the one-thread table bit for bit (not only its last entry), and elastic_align's warps are identical."""
    R0 = random_curve(300, joints=31, seed=95, scale=0.05)
    R1 = random_curve(300, joints=31, seed=96, scale=0.05)
    Q0, _ = elastic._srvt_matrix(R0, "R0")
    Q1, _ = elastic._srvt_matrix(R1, "R1")
    prob = elastic._Problem(Q0, Q1, elastic.DEFAULT_DEPTH, penalty)
    t = prob.table
    r, P1, P2 = _dp_kernels._penalty_terms(t["di"], t["dj"], prob.h0, prob.h1)
    args = (prob.G, prob.B0, prob.B1, prob.h0, prob.h1, float(penalty), t["di"], t["dj"], t["start"], t["ea"],
            t["eb"], prob.coef, prob.lo, prob.hi, r, P1, P2) + _dp_kernels._thin_index(t["di"], t["dj"])
    n0, n1 = prob.G.shape
    assert int(np.sum(prob.hi - prob.lo + 1)) >= _dp_kernels.PARALLEL_MIN_NODES
    split = _dp_threads.column_split(prob.lo, prob.hi, n1)
    assert 0 < split <= n1
    one = np.full((n0 + 1, n1 + 1), np.inf)
    one[0, 0] = 0.0
    two = one.copy()
    _dp_kernels._dp_rows(one, *args, 1, n0 + 1, 0, n1)
    _dp_threads.dp_two_threads(_dp_kernels._dp_rows, two, args, n0, n1, split)
    assert np.isfinite(one[-1, -1])
    assert np.array_equal(one, two)  # inf where unreachable in both, every finite value bit for bit
    wa, da, ia = elastic_align(R0, R1, penalty=penalty, method="numba", return_info=True, threads=1)
    wb, db, ib = elastic_align(R0, R1, penalty=penalty, method="numba", return_info=True, threads=2)
    assert ia["energy"] == ib["energy"] and da == db
    assert np.array_equal(wa, wb)
    assert elastic_distance(R0, R1, penalty=penalty, threads=2) == elastic_distance(R0, R1, penalty=penalty,
                                                                                  threads=1) == da


@pytest.mark.skipif(not _dp_kernels.HAVE_NUMBA, reason="numba not installed")
@settings(max_examples=15, deadline=None)
@given(
    f0=st.integers(2, 40), f1=st.integers(2, 40), depth=st.integers(1, 10),
    penalty=st.sampled_from([0.0, 0.01, 3.0]), seed=st.integers(0, 10_000),
)
def test_kernels_identical_random(f0, f1, depth, penalty, seed):
    R0 = random_curve(f0, joints=3, seed=seed, scale=0.2)
    R1 = random_curve(f1, joints=3, seed=seed + 1, scale=0.2)
    wa, da, ia = elastic_align(R0, R1, depth=depth, penalty=penalty, method="numba", return_info=True)
    wb, db, ib = elastic_align(R0, R1, depth=depth, penalty=penalty, method="numpy", return_info=True)
    assert ia["energy"] == ib["energy"]
    assert np.array_equal(wa, wb)


@pytest.fixture
def without_numba(monkeypatch):
    monkeypatch.setitem(sys.modules, "numba", None)  # "import numba" now raises ImportError
    importlib.reload(_dp_kernels)
    yield
    monkeypatch.undo()
    importlib.reload(_dp_kernels)


def test_numpy_fallback_without_numba(without_numba):
    assert not _dp_kernels.HAVE_NUMBA
    R0 = random_curve(6, seed=101)
    R1 = random_curve(7, seed=102)
    warp, d, info = elastic_align(R0, R1, depth=3, return_info=True)
    assert info["method"] == "numpy"
    assert d * d == pytest.approx(brute_force(R0, R1, 3), rel=1e-10)
    with pytest.raises(ShapeSigError, match="numba"):
        elastic_distance(R0, R1, method="numba")
    M = elastic_distance_matrix([R0, R1, R0], depth=3)
    assert M[0, 1] == pytest.approx(d, rel=1e-12)


def test_numba_back_after_fallback_test():
    assert _dp_kernels.HAVE_NUMBA == (importlib.util.find_spec("numba") is not None)


def test_distance_matrix():
    curves = [random_curve(n, joints=3, seed=110 + n, scale=0.2) for n in (20, 33, 27, 41)]
    M1 = elastic_distance_matrix(curves, workers=1)
    M2 = elastic_distance_matrix(curves, workers=2)
    assert np.array_equal(M1, M2)
    assert np.array_equal(M1, M1.T) and np.all(np.diag(M1) == 0)
    for a, b in itertools.combinations(range(len(curves)), 2):
        assert M1[a, b] == elastic_distance(curves[a], curves[b])
    with pytest.raises(CurveError):
        elastic_distance_matrix([curves[0], random_curve(20, joints=2)])
    calls = []
    elastic_distance_matrix(curves, progress=lambda done, total: calls.append((done, total)))
    assert calls == [(k, 6) for k in range(1, 7)]


# ---------------------------------------------------------------------------------------------
# reparametrize


def test_reparametrize_identity_and_composition():
    R = random_curve(12, joints=2, seed=121)
    ident = np.array([[0.0, 0.0], [1.0, 1.0]])
    np.testing.assert_array_equal(reparametrize(R, None, ident), R)
    warp = np.array([[0.0, 0.0], [0.5, 0.25], [1.0, 1.0]])
    s = np.array([0.0, 0.2, 0.5, 0.6, 1.0])
    out = reparametrize(R, None, warp, t_new=s)
    assert out.shape == (5, 2, 3, 3)
    # phi(0.2) = 0.1, phi(0.5) = 0.25, phi(0.6) = 0.4; check against the geodesic formula.
    t = np.linspace(0, 1, 12)
    for si, u in zip(s, [0.0, 0.1, 0.25, 0.4, 1.0]):
        k = min(int(np.searchsorted(t, u, side="right")) - 1, 10)
        frac = (u - t[k]) / (t[k + 1] - t[k])
        rel = Rotation.from_matrix(R[k + 1] @ np.swapaxes(R[k], -1, -2)).as_rotvec()
        expect = Rotation.from_rotvec(rel * frac).as_matrix() @ R[k]
        np.testing.assert_allclose(out[list(s).index(si)], expect, atol=1e-12)
    # Default grid: the curve's own.
    assert reparametrize(R, None, warp).shape == R.shape


def test_reparametrize_bad_warp():
    R = random_curve(5)
    for bad in ([[0, 0], [1, 0.9]], [[0, 0], [0.5, 0.5], [0.5, 0.7], [1, 1]],
                [[0, 0], [0.5, 0.6], [0.7, 0.4], [1, 1]], [[0, 0]], [[0, 0], [np.nan, 1], [1, 1]]):
        with pytest.raises(CurveError):
            reparametrize(R, None, np.array(bad, dtype=float))
    with pytest.raises(CurveError):
        reparametrize(R, None, [[0, 0], [1, 1]], t_new=[0.5, 1.5])


# ---------------------------------------------------------------------------------------------
# errors


def test_bad_input():
    R = random_curve(10, joints=2)
    with pytest.raises(CurveError, match="joints"):
        elastic_distance(R, random_curve(10, joints=3))
    with pytest.raises(CurveError, match="two frames"):
        elastic_distance(R[:1], R)
    for kwargs in ({"depth": 0}, {"depth": 2.5}, {"penalty": -1.0}, {"penalty": float("nan")},
                   {"method": "cuda"}):
        with pytest.raises(ShapeSigError):
            elastic_distance(R, R, **kwargs)
    with pytest.raises(CurveError):
        elastic_distance(np.zeros((10, 2, 3)), R)
    # Same curve: zero up to the rounding of the expanded square (about sqrt(eps) |q|).
    assert elastic_distance(R, R) < 1e-7


# ---------------------------------------------------------------------------------------------
# real clips


def _acclaim_curves(data_dir, names):
    from blender_shapesig.core.io.acclaim import load_acclaim
    from blender_shapesig.core.clip.clip import restrict_to_shared

    asf = {"07": "07-walk.asf", "09": "09-run.asf"}
    clips = [load_acclaim(data_dir / "acclaim" / f"{n}.amc", data_dir / "acclaim" / asf[n[:2]])
             for n in names]
    return [c.rotations for c in restrict_to_shared(*clips)]


def test_real_clips_walks_closer_than_run(data_dir):
    w1, w2, r1, r2 = _acclaim_curves(data_dir, ["07_01", "07_02", "09_02", "09_03"])
    assert w1.shape[1] == r1.shape[1] >= 20
    M = elastic_distance_matrix([w1, w2, r1, r2])
    walk_walk, run_run = M[0, 1], M[2, 3]
    walk_run = M[:2, 2:]
    assert walk_walk < walk_run.min()
    assert run_run < walk_run.min()
    # Elastic alignment helps the two walks (same frame rate, different timing).
    assert walk_walk < l2_distance(w1, w2)


def test_memory_guard_refuses_grids_beyond_the_limit(monkeypatch):
    from blender_shapesig.core.elastic import elastic as el

    R0 = np.repeat(np.eye(3)[None, None], 60, axis=0)
    R1 = np.repeat(np.eye(3)[None, None], 50, axis=0)
    monkeypatch.setattr(el, "MAX_DP_BYTES", el.DP_BYTES_PER_NODE * 59 * 49 - 1)
    with pytest.raises(CurveError, match="crop or resample"):
        el.elastic_distance(R0, R1)
    monkeypatch.setattr(el, "MAX_DP_BYTES", el.DP_BYTES_PER_NODE * 59 * 49)
    assert el.elastic_distance(R0, R1) == 0.0
