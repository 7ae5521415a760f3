"""Tests for core.signatures and core.signatures.tensor (reference secs. 7-9).

Independent truths used here: a plain Chen-product signature written in this file (nested levels,
one segment at a time), the tensor exponential of a straight path (eq. 7.3), closed forms (Levy
area, level-1 distances, Proposition 1's equal-slope case), iisignature (when installed), the
bracket expansions of iisignature's own basis strings, and real CMU clips.
"""

import math
import pathlib

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from hypothesis.extra.numpy import arrays
from scipy.spatial.transform import Rotation

from blender_shapesig.core.geometry import curves
from blender_shapesig.core.signatures import signatures as sg, tensor
from blender_shapesig.core.errors import CurveError, ShapeSigError

DATA = pathlib.Path(__file__).resolve().parents[2] / "data"

try:
    import iisignature
except ImportError:  # pragma: no cover
    iisignature = None

needs_ii = pytest.mark.skipif(iisignature is None, reason="iisignature not installed")


# --- independent helpers (written here, not taken from the module under test) ----------------------

def plain_signature(points, level):
    """Signature as a list of ndarrays of shape (d,)*k, by multiplying exp(segment) one at a time."""
    x = np.asarray(points, dtype=float)
    d = x.shape[1]
    sig = [np.ones(())] + [np.zeros((d,) * k) for k in range(1, level + 1)]
    for delta in np.diff(x, axis=0):
        seg = [np.ones(())]
        for k in range(1, level + 1):
            seg.append(np.multiply.outer(seg[-1], delta) / k)
        new = []
        for k in range(level + 1):
            acc = np.zeros((d,) * k)
            for i in range(k + 1):
                acc = acc + np.multiply.outer(sig[i], seg[k - i])
            new.append(acc)
        sig = new
    return sig


def flat(levels):
    return np.concatenate([np.asarray(a).reshape(-1) for a in levels[1:]])


def levels_of(v, d, n):
    out, pos = [np.ones(())], 0
    for k in range(1, n + 1):
        out.append(np.asarray(v[pos:pos + d ** k]).reshape((d,) * k))
        pos += d ** k
    return out


def plain_mul(a, b):
    n = len(a) - 1
    return [sum(np.multiply.outer(a[i], b[k - i]) for i in range(k + 1)) for k in range(n + 1)]


def parse_bracket(s):
    """'[1,[1,2]]' -> nested tuples of 0-based letters."""
    pos = 0

    def parse():
        nonlocal pos
        if s[pos] == "[":
            pos += 1
            left = parse()
            assert s[pos] == ","
            pos += 1
            right = parse()
            assert s[pos] == "]"
            pos += 1
            return (left, right)
        start = pos
        while pos < len(s) and s[pos].isdigit():
            pos += 1
        return int(s[start:pos]) - 1

    return parse()


def expand_bracket(tree, d):
    """Tensor of a bracket expression: a letter is e_i, [a, b] = a⊗b - b⊗a."""
    if isinstance(tree, int):
        e = np.zeros(d)
        e[tree] = 1.0
        return e
    a, b = expand_bracket(tree[0], d), expand_bracket(tree[1], d)
    return np.multiply.outer(a, b) - np.multiply.outer(b, a)


def random_path(rng, points, d, scale=0.3):
    return np.vstack([np.zeros(d), np.cumsum(rng.normal(size=(points - 1, d)) * scale, axis=0)])


def random_curve(rng, frames, joints, scale=0.15):
    v = np.cumsum(rng.normal(size=(frames, joints, 3)) * scale, axis=0)
    return Rotation.from_rotvec(v.reshape(-1, 3)).as_matrix().reshape(frames, joints, 3, 3)


def load_clip(amc, asf):
    acclaim = pytest.importorskip("blender_shapesig.core.io.acclaim")
    if not hasattr(acclaim, "load_acclaim"):
        pytest.skip("core.io.acclaim.load_acclaim is not available yet")
    return acclaim.load_acclaim(DATA / "acclaim" / amc, DATA / "acclaim" / asf)


@pytest.fixture(scope="module")
def walk():
    return load_clip("07_01.amc", "07-walk.asf")


@pytest.fixture(scope="module")
def walk2():
    return load_clip("07_02.amc", "07-walk.asf")


@pytest.fixture(scope="module")
def run():
    return load_clip("09_02.amc", "09-run.asf")


# --- dimensions --------------------------------------------------------------------------------------

def test_log_signature_dim_witt_known_values():
    # Free Lie algebra on 2 letters: 2, 1, 2, 3, 6, 9 elements at levels 1..6.
    assert [tensor.log_signature_dim(2, n) for n in range(1, 7)] == [2, 3, 5, 8, 14, 23]
    # On 3 letters: 3, 3, 8, 18.
    assert [sg.log_signature_dim(3, n) for n in range(1, 5)] == [3, 6, 14, 32]
    assert sg.log_signature_dim(93, 3, basis="tensor") == 93 + 93 ** 2 + 93 ** 3
    assert sg.signature_dim(4, 3) == 4 + 16 + 64


@needs_ii
@pytest.mark.parametrize("d,n", [(2, 5), (3, 4), (5, 3), (93, 3)])
def test_log_signature_dim_matches_iisignature(d, n):
    assert sg.log_signature_dim(d, n) == iisignature.logsiglength(d, n)
    assert tensor.lyndon_words(d, n).size == sg.log_signature_dim(d, n) - (sg.log_signature_dim(d, n - 1) if n > 1 else 0)


# --- signatures --------------------------------------------------------------------------------------

@pytest.mark.parametrize("d,n", [(1, 3), (2, 4), (3, 3), (4, 2)])
def test_numpy_signature_equals_plain_chen_product(d, n):
    rng = np.random.default_rng(d * 10 + n)
    x = random_path(rng, 9, d)
    expected = flat(plain_signature(x, n))
    np.testing.assert_allclose(sg.path_signature(x, n, method="numpy"), expected, rtol=0, atol=1e-12)


@needs_ii
@pytest.mark.parametrize("d,n", [(2, 4), (3, 3), (5, 2)])
def test_iisignature_equals_plain_chen_product(d, n):
    rng = np.random.default_rng(100 + d)
    x = random_path(rng, 12, d)
    expected = flat(plain_signature(x, n))
    np.testing.assert_allclose(sg.path_signature(x, n, method="iisignature"), expected, rtol=0, atol=1e-12)


def test_straight_path_signature_is_tensor_exponential():
    a = np.array([0.3, -1.2, 0.7])
    x = np.array([[1.0, 2.0, 3.0], [1.0, 2.0, 3.0]]) + np.array([[0, 0, 0], a])  # base point plus slope
    sig = levels_of(sg.path_signature(x, 5, method="numpy"), 3, 5)
    power = np.ones(())
    for k in range(1, 6):
        power = np.multiply.outer(power, a)
        np.testing.assert_allclose(sig[k], power / math.factorial(k), rtol=0, atol=1e-14)
    np.testing.assert_allclose(tensor.flatten(tensor.exp(a, 5)), flat(sig), rtol=0, atol=1e-14)
    # The same straight path sampled at 7 collinear points (reparametrized) has the same signature.
    ts = np.array([0.0, 0.05, 0.1, 0.4, 0.41, 0.9, 1.0])
    np.testing.assert_allclose(sg.path_signature(x[0] + ts[:, None] * a, 5), flat(sig), atol=1e-14)


def test_chen_identity_reversal_and_concatenation():
    rng = np.random.default_rng(7)
    d, n = 3, 4
    x, y = random_path(rng, 8, d), random_path(rng, 6, d)
    sx = levels_of(sg.path_signature(x, n), d, n)
    srev = levels_of(sg.path_signature(x[::-1], n), d, n)
    prod = plain_mul(sx, srev)  # eq. 7.6: S(x) ⊗ S(reversed x) = 1
    assert abs(float(prod[0]) - 1.0) < 1e-15
    for k in range(1, n + 1):
        assert np.abs(prod[k]).max() < 1e-12
    # eq. 7.7: concatenation (y translated to start where x ends) has signature S(x) ⊗ S(y).
    xy = np.vstack([x, x[-1] + (y[1:] - y[0])])
    sy = levels_of(sg.path_signature(y, n), d, n)
    np.testing.assert_allclose(sg.path_signature(xy, n), flat(plain_mul(sx, sy)), rtol=0, atol=1e-12)


def test_signature_is_translation_invariant_and_needs_points_not_velocities():
    rng = np.random.default_rng(3)
    x = random_path(rng, 10, 2)
    np.testing.assert_allclose(sg.path_signature(x + 5.0, 3), sg.path_signature(x, 3), atol=1e-12)
    # The level-1 term is the increment x[-1] - x[0] (not the sum of the points).
    np.testing.assert_allclose(sg.path_signature(x, 1), x[-1] - x[0], atol=1e-14)


# --- log-signatures ---------------------------------------------------------------------------------

def test_levy_area_closed_form():
    # Right then up: log-signature (1, 1, area 1/2) in the Lyndon basis (1, 2, [1,2]).
    x = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])
    np.testing.assert_allclose(sg.path_log_signature(x, 2, method="numpy"), [1.0, 1.0, 0.5], atol=1e-15)
    # Up then right: the area changes sign.
    np.testing.assert_allclose(sg.path_log_signature(x[:, ::-1], 2), [1.0, 1.0, -0.5], atol=1e-15)
    # Tensor form: level 2 is the antisymmetric matrix [[0, 1/2], [-1/2, 0]].
    np.testing.assert_allclose(sg.path_log_signature(x, 2, basis="tensor"), [1, 1, 0, 0.5, -0.5, 0], atol=1e-15)


def test_tensor_log_is_inverse_of_exp_series():
    rng = np.random.default_rng(11)
    d, n = 3, 4
    x = random_path(rng, 7, d)
    logt = levels_of(sg.path_log_signature(x, n, basis="tensor"), d, n)
    logt[0] = np.zeros(())
    # exp(L) = sum_k L^k / k!, computed with this file's product.
    total = [np.ones(())] + [np.zeros((d,) * k) for k in range(1, n + 1)]
    power = [np.ones(())] + [np.zeros((d,) * k) for k in range(1, n + 1)]
    for k in range(1, n + 1):
        power = plain_mul(power, logt)
        total = [t + p / math.factorial(k) for t, p in zip(total, power)]
    np.testing.assert_allclose(flat(total), flat(plain_signature(x, n)), rtol=0, atol=1e-12)


@needs_ii
@pytest.mark.parametrize("d,n", [(2, 6), (3, 4), (4, 3), (6, 3), (5, 2), (4, 1)])
def test_lyndon_coordinates_equal_iisignature_default_logsig(d, n):
    rng = np.random.default_rng(20 + d)
    x = random_path(rng, 10, d, scale=0.5)
    ref = iisignature.logsig(x, iisignature.prepare(d, n))  # default method and basis
    np.testing.assert_allclose(sg.path_log_signature(x, n, method="numpy"), ref, rtol=0, atol=1e-12)
    np.testing.assert_allclose(sg.path_log_signature(x, n, method="iisignature"), ref, rtol=0, atol=1e-12)
    ref_x = iisignature.logsig(x, iisignature.prepare(d, n, "X"), "X")
    np.testing.assert_allclose(sg.path_log_signature(x, n, basis="tensor", method="numpy"), ref_x, atol=1e-12)


@needs_ii
@pytest.mark.parametrize("d,n", [(2, 5), (3, 4)])
def test_lyndon_coordinates_reassemble_the_tensor_log_with_iisignature_basis(d, n):
    """sum_w c_w P_w over iisignature's own basis strings equals the expanded log-signature."""
    rng = np.random.default_rng(5)
    x = random_path(rng, 9, d, scale=0.5)
    coords = sg.path_log_signature(x, n, method="numpy")
    names = iisignature.basis(iisignature.prepare(d, n))
    assert len(names) == coords.size
    total = [np.zeros(())] + [np.zeros((d,) * k) for k in range(1, n + 1)]
    for c, name in zip(coords, names):
        t = expand_bracket(parse_bracket(name), d)
        total[t.ndim] = total[t.ndim] + c * t
    np.testing.assert_allclose(flat(total), sg.path_log_signature(x, n, basis="tensor"), atol=1e-12)
    # and the module's own inverse map agrees
    np.testing.assert_allclose(tensor.flatten(tensor.lyndon_to_tensor(coords, d, n)), flat(total), atol=1e-12)


def test_one_dimensional_path():
    x = np.array([[0.0], [2.0], [1.5]])
    np.testing.assert_allclose(sg.path_log_signature(x, 3), [1.5], atol=1e-15)  # one Lyndon word
    np.testing.assert_allclose(sg.path_signature(x, 3), [1.5, 1.5 ** 2 / 2, 1.5 ** 3 / 6], atol=1e-15)


# --- the development of a curve --------------------------------------------------------------------

def test_development_is_cumulative_rotation_vectors_by_joint():
    rng = np.random.default_rng(2)
    R = random_curve(rng, 6, 2)
    dev = sg.development(R)
    assert dev.shape == (6, 6)
    np.testing.assert_array_equal(dev[0], 0.0)
    for k in range(5):
        for j in range(2):
            step = Rotation.from_matrix(R[k + 1, j] @ R[k, j].T).as_rotvec()
            np.testing.assert_allclose(dev[k + 1, 3 * j:3 * j + 3] - dev[k, 3 * j:3 * j + 3], step, atol=1e-14)
    np.testing.assert_allclose(sg.signature(R, 3), sg.path_signature(dev, 3), atol=1e-14)
    # Quaternions (x, y, z, w) give the same answer as matrices.
    q = Rotation.from_matrix(R.reshape(-1, 3, 3)).as_quat().reshape(6, 2, 4)
    np.testing.assert_allclose(sg.log_signature(q, 3), sg.log_signature(R, 3), atol=1e-12)
    # A right translation of the curve changes no increment.
    G = random_curve(rng, 1, 2)[0]
    np.testing.assert_allclose(sg.signature(R @ G[None], 3), sg.signature(R, 3), atol=1e-12)


@needs_ii
def test_iisignature_prepared_once_per_dimension_level_and_basis():
    a = sg.prepare(4, 3, "lyndon")
    assert sg.prepare(4, 3, "lyndon") is a
    assert sg.prepare(4, 3, "tensor") is not a


def test_joint_selection():
    rng = np.random.default_rng(4)
    R = random_curve(rng, 7, 4)
    np.testing.assert_allclose(sg.log_signature(R, 2, joints=[2, 0]), sg.log_signature(R[:, [2, 0]], 2), atol=0)
    mask = np.array([True, False, True, False])
    np.testing.assert_allclose(sg.signature(R, 2, joints=mask), sg.signature(R[:, [0, 2]], 2), atol=0)
    with pytest.raises(CurveError):
        sg.signature(R, 2, joints=[5])
    with pytest.raises(CurveError):
        sg.signature(R, 2, joints=[])


@pytest.mark.parametrize("which", ["walk", "run"])
def test_reparametrization_invariance_on_real_clips(which, request):
    """Inserting geodesic midpoints (the same piecewise-geodesic curve) leaves the signature unchanged,
    and so does a non-uniform resampling that keeps every original frame."""
    R = request.getfixturevalue(which).rotations[:120]
    f = R.shape[0]
    t = curves.uniform_times(f)
    t_new = np.union1d(t, 0.5 * (t[:-1] + t[1:]))
    R2 = curves.geodesic_interpolate(R, t, t_new)
    assert R2.shape[0] == 2 * f - 1
    extra = np.random.default_rng(0).uniform(0, 1, 300)
    R3 = curves.geodesic_interpolate(R, t, np.union1d(t, extra))
    for n in (2, 3):
        a = sg.signature(R, n, joints=range(0, 31, 3))
        for other in (R2, R3):
            b = sg.signature(other, n, joints=range(0, 31, 3))
            assert np.abs(a - b).max() < 1e-10 * max(1.0, np.abs(a).max())
    la = sg.log_signature(R, 2)
    lb = sg.log_signature(R2, 2)
    assert np.abs(la - lb).max() < 1e-10 * max(1.0, np.abs(la).max())
    # A different speed profile is not a reparametrization of the sampled curve unless the original
    # frames are kept: dropping every other frame changes the curve and the signature.
    assert np.abs(sg.signature(R[::2], 2) - sg.signature(R, 2)).max() > 1e-6


@needs_ii
def test_numpy_equals_iisignature_on_real_clips(walk, run):
    """Full skeleton (93 dims) at level 2 and a 10-joint subset at level 3."""
    for clip in (walk, run):
        R = clip.rotations
        for kw in ({"level": 2}, {"level": 3, "joints": list(range(0, 31, 3))}):
            s_np = sg.signature(R, method="numpy", **kw)
            s_ii = sg.signature(R, method="iisignature", **kw)
            scale = max(1.0, np.abs(s_ii).max())
            assert np.abs(s_np - s_ii).max() < 1e-12 * scale
            l_np = sg.log_signature(R, method="numpy", **kw)
            l_ii = sg.log_signature(R, method="iisignature", **kw)
            assert np.abs(l_np - l_ii).max() < 1e-12 * max(1.0, np.abs(l_ii).max())


def test_tensor_basis_norm_invariant_to_bone_order_and_frame_rotation(walk):
    rng = np.random.default_rng(9)
    joints = [2, 3, 8, 9, 18, 19, 25]
    R = walk.rotations[:200][:, joints]
    perm = rng.permutation(len(joints))
    Q = Rotation.from_rotvec([0.4, -1.1, 0.8]).as_matrix()
    R_rot = Q[None, None] @ R @ Q.T[None, None]  # the same motion seen in a rotated frame
    base_t = np.linalg.norm(sg.log_signature(R, 3, basis="tensor"))
    base_l = np.linalg.norm(sg.log_signature(R, 3))
    for other in (R[:, perm], R_rot):
        assert abs(np.linalg.norm(sg.log_signature(other, 3, basis="tensor")) - base_t) < 1e-12 * base_t
        # The Lyndon coordinates are not orthonormal: their norm does change.
        assert abs(np.linalg.norm(sg.log_signature(other, 3)) - base_l) > 1e-4 * base_l
    # The tensor-form measures inherit the invariance.
    R1 = walk.rotations[100:300][:, joints]
    R1_rot = Q[None, None] @ R1 @ Q.T[None, None]
    d0 = sg.normalized_distance(R, R1, 3, basis="tensor")
    assert abs(sg.normalized_distance(R_rot, R1_rot, 3, basis="tensor") - d0) < 1e-12
    assert abs(sg.normalized_distance(R[:, perm], R1[:, perm], 3, basis="tensor") - d0) < 1e-12


# --- the measures --------------------------------------------------------------------------------

def test_level_one_closed_forms():
    rng = np.random.default_rng(1)
    x, y = random_path(rng, 6, 3), random_path(rng, 9, 3)
    diff = np.linalg.norm((x[-1] - x[0]) - (y[-1] - y[0]))
    # rho^1: both terms of eq. 8.2 equal |dx - dy|; sigma_* adds two equal log norms; sigma_L one.
    assert abs(sg.path_group_distance(x, y, 1) - 2 * diff) < 1e-14
    assert abs(sg.path_concat_distance(x, y, 1) - 2 * diff) < 1e-14
    assert abs(sg.path_linear_distance(x, y, 1) - diff) < 1e-14
    a, b = x[-1] - x[0], y[-1] - y[0]
    expected = np.linalg.norm(a / np.linalg.norm(a) - b / np.linalg.norm(b))
    assert abs(sg.path_normalized_distance(x, y, 1) - expected) < 1e-14


def test_group_distance_matches_definition_with_general_inverse():
    rng = np.random.default_rng(8)
    d, n = 3, 3
    x, y = random_path(rng, 7, d), random_path(rng, 5, d)
    sx, sy = plain_signature(x, n), plain_signature(y, n)
    # S(y)^-1 = S(reversed y); g = S(y)^-1 ⊗ S(x) (eq. 8.1), g^-1 = S(x)^-1 ⊗ S(y).
    g = plain_mul(plain_signature(y[::-1], n), sx)
    g_inv = plain_mul(plain_signature(x[::-1], n), sy)

    def half(t):
        return max((math.factorial(i) * np.linalg.norm(t[i])) ** (1 / i) for i in range(1, n + 1))

    expected = half(g) + half(g_inv)
    for method in ("numpy",) + (("iisignature",) if iisignature else ()):
        assert abs(sg.path_group_distance(x, y, n, method=method) - expected) < 1e-12
    # group_norm builds g^-1 from the series (1 + X)^-1 itself.
    assert abs(sg.group_norm(flat(g), d, n) - expected) < 1e-12
    assert abs(sg.path_group_distance(y, x, n) - expected) < 1e-12  # symmetric


def test_concat_distance_uses_group_concatenation_of_curves():
    """eq. 8.5 with eq. 7.9 built literally in SO(3)^d equals the path-concatenation computation."""
    rng = np.random.default_rng(12)
    u, v = random_curve(rng, 9, 2), random_curve(rng, 7, 2)

    def concat(a, b):  # eq. 7.9: b right-translated by b(0)^-1 a(1), appended after a
        shift = np.swapaxes(b[0], -1, -2) @ a[-1]
        return np.concatenate([a, (b @ shift[None])[1:]])

    for n in (2, 3):
        expected = (np.linalg.norm(sg.log_signature(concat(u, v[::-1]), n))
                    + np.linalg.norm(sg.log_signature(concat(v, u[::-1]), n)))
        assert abs(sg.concat_distance(u, v, n) - expected) < 1e-12
        if iisignature is not None:
            assert abs(sg.concat_distance(u, v, n, method="iisignature") - expected) < 1e-12
        # and the group metric through eq. 8.3 (reversed v, then u)
        g = sg.signature(concat(v[::-1], u), n)
        h = sg.signature(concat(u[::-1], v), n)
        half = sg._half_group_norm
        exp_rho = half(tensor.unflatten(g, 6, n)) + half(tensor.unflatten(h, 6, n))
        assert abs(sg.group_distance(u, v, n) - exp_rho) < 1e-12


@needs_ii
def test_measures_numpy_equal_iisignature_on_real_clips(walk, run):
    joints = [1, 2, 3, 7, 8, 9, 12, 18, 19, 25, 26]
    A, B = walk.rotations[:, joints], run.rotations[:, joints]
    for fn in (sg.group_distance, sg.concat_distance, sg.linear_distance, sg.normalized_distance):
        for n in (2, 3):
            a = fn(A, B, n, method="numpy")
            b = fn(A, B, n, method="iisignature")
            assert abs(a - b) <= 1e-12 * max(1.0, abs(b)), (fn.__name__, n, a, b)
    for fn in (sg.concat_distance, sg.linear_distance, sg.normalized_distance):
        a = fn(A, B, 3, basis="tensor", method="numpy")
        b = fn(A, B, 3, basis="tensor", method="iisignature")
        assert abs(a - b) <= 1e-12 * max(1.0, abs(b))


def test_still_joints_change_nothing():
    rng = np.random.default_rng(6)
    A, B = random_curve(rng, 10, 2), random_curve(rng, 13, 2)
    still = Rotation.from_rotvec([0.3, 0.2, -0.5]).as_matrix()
    A3 = np.concatenate([A, np.broadcast_to(still, (10, 1, 3, 3))], axis=1)
    B3 = np.concatenate([B, np.broadcast_to(still, (13, 1, 3, 3))], axis=1)
    for fn in (sg.group_distance, sg.concat_distance, sg.linear_distance, sg.normalized_distance):
        ref = fn(A, B, 3)
        assert abs(fn(A3, B3, 3) - ref) < 1e-12
        assert abs(fn(A3, B3, 3, drop_still=False) - ref) < 1e-12
        assert abs(fn(A3, B3, 3, joints=[0, 1]) - ref) < 1e-15


def test_still_mask_is_the_one_stillness_rule(walk, run):
    """The signature measures drop joints by the package's one stillness rule (so3.still_joints, re-exported
    by clip): the angle from the first frame, checked here against scipy."""
    from blender_shapesig.core.clip.clip import STILL_TOLERANCE, still_joints

    assert sg.still_joints is still_joints
    for clip in (walk, run):
        R = clip.rotations
        rel = R @ np.swapaxes(R[0], -1, -2)[None]
        angle = np.linalg.norm(Rotation.from_matrix(rel.reshape(-1, 3, 3)).as_rotvec(), axis=-1)
        mask = still_joints(R)
        np.testing.assert_array_equal(mask, angle.reshape(R.shape[:2]).max(axis=0) <= STILL_TOLERANCE)
        assert mask.any() and not mask.all()  # CMU skeletons have still bones (hip joints, clavicles)
    one = np.broadcast_to(np.eye(3), (1, 3, 3, 3))
    assert still_joints(one).all()


def test_still_in_one_curve_only_is_kept():
    rng = np.random.default_rng(16)
    A = random_curve(rng, 10, 2)
    B = random_curve(rng, 10, 2)
    B[:, 1] = B[0, 1]  # joint 1 still in B only: it must stay (it moves in A)
    with_joint = sg.linear_distance(A, B, 2)
    assert abs(with_joint - sg.linear_distance(A, B, 2, drop_still=False)) < 1e-15
    assert abs(with_joint - sg.linear_distance(A[:, :1], B[:, :1], 2)) > 1e-3


def test_normalized_distance_zero_case_and_range():
    rng = np.random.default_rng(13)
    moving = random_curve(rng, 8, 2)
    still = np.broadcast_to(np.eye(3), (8, 2, 3, 3)).copy()
    assert sg.normalized_distance(still, still, 3) == 0.0
    assert sg.normalized_distance(moving, still, 3) == 1.0
    assert sg.normalized_distance(still, moving, 2) == 1.0
    assert sg.normalized_difference([0, 0], [1e-13, 0]) == 0.0
    assert abs(sg.normalized_difference([2.0, 0.0], [0.0, 5.0]) - math.sqrt(2)) < 1e-15
    assert abs(sg.normalized_difference([1.0, 2.0], [-3.0, -6.0]) - 2.0) < 1e-15
    # Scale-free at level 1: a clip against itself played at another speed-independent amplitude.
    x = random_path(rng, 6, 3)
    assert sg.path_normalized_distance(x, 3 * x, 1) < 1e-15
    with pytest.raises(ShapeSigError):
        sg.normalized_difference([1, 2], [1, 2, 3])


def test_identical_curves():
    rng = np.random.default_rng(14)
    R = random_curve(rng, 30, 3)
    for fn in (sg.concat_distance, sg.linear_distance, sg.normalized_distance):
        assert fn(R, R, 3) < 1e-13
    # rho^n is Hoelder-1/n in the rounding error: (n! * 1e-16)^(1/n)-sized, not exactly 0.
    assert sg.group_distance(R, R, 3) < 1e-4
    assert sg.group_distance(R, R, 1) < 1e-14


# --- Proposition 1 and sec. 8.4: rates on linear paths in R^4 ----------------------------------------

def _slope(eps, values):
    return float(np.polyfit(np.log(eps), np.log(values), 1)[0])


A_SLOPE = np.array([0.1, 0.5, 0.0, -0.2])


@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_proposition_1_group_metric_rate(n):
    """rho^n(x, x_eps) = O(eps^(1/n)) for unequal slopes: fitted exponent within 0.005 of 1/n."""
    eps = np.logspace(-9, -6, 7)
    x = np.vstack([np.zeros(4), A_SLOPE])
    rho = [sg.path_group_distance(x, np.vstack([np.zeros(4), A_SLOPE + e]), n) for e in eps]
    assert abs(_slope(eps, rho) - 1.0 / n) < 0.005


@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_proposition_1_equal_slopes_linear(n):
    """Equal slopes: S(x)^-1 ⊗ S(x_eps) = exp(eps 1), so rho^n = 2 |eps 1| = 4 eps exactly."""
    eps = np.logspace(-3, -1, 5)
    a = np.full(4, 0.1)
    x = np.vstack([np.zeros(4), a])
    rho = np.array([sg.path_group_distance(x, np.vstack([np.zeros(4), a + e]), n) for e in eps])
    np.testing.assert_allclose(rho, 4 * eps, rtol=1e-8)
    assert abs(_slope(eps, rho) - 1.0) < 1e-6


@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_log_metrics_linear_rate(n):
    """sigma_*^n and sigma_L^n are O(eps): fitted exponent within 0.02 of 1 (sec. 8.4)."""
    eps = np.logspace(-6, -3, 7)
    x = np.vstack([np.zeros(4), A_SLOPE])
    ys = [np.vstack([np.zeros(4), A_SLOPE + e]) for e in eps]
    conc = [sg.path_concat_distance(x, y, n) for y in ys]
    lin = [sg.path_linear_distance(x, y, n) for y in ys]
    assert abs(_slope(eps, conc) - 1.0) < 0.02
    assert abs(_slope(eps, lin) - 1.0) < 0.02
    # A straight path's log-signature is its increment alone, so sigma_L = |eps 1| = 2 eps exactly.
    np.testing.assert_allclose(lin, 2 * eps, rtol=1e-9)


# --- methods, errors, registry -------------------------------------------------------------------

def test_numpy_used_when_iisignature_missing(monkeypatch):
    rng = np.random.default_rng(15)
    R0, R1 = random_curve(rng, 9, 2), random_curve(rng, 11, 2)
    expected = sg.normalized_distance(R0, R1, 3, method="numpy")
    monkeypatch.setattr(sg, "_iisig", None)
    assert sg.resolve_method("auto") == "numpy"
    assert sg.normalized_distance(R0, R1, 3) == expected
    with pytest.raises(ShapeSigError, match="iisignature"):
        sg.log_signature(R0, 2, method="iisignature")


def test_bad_arguments():
    rng = np.random.default_rng(17)
    R = random_curve(rng, 5, 2)
    with pytest.raises(ShapeSigError):
        sg.signature(R, 0)
    with pytest.raises(ShapeSigError):
        sg.log_signature(R, 2, basis="hall")
    with pytest.raises(ShapeSigError):
        sg.log_signature(R, 2, method="fast")
    with pytest.raises(CurveError):
        sg.linear_distance(R, random_curve(rng, 5, 3), 2)
    with pytest.raises(ShapeSigError):
        sg.path_linear_distance(np.zeros((3, 2)), np.zeros((3, 3)), 2)
    with pytest.raises(ShapeSigError, match="coefficients"):
        sg.path_signature(np.zeros((3, 93)), 4)  # 93^4 coefficients: refused, not an out-of-memory


def test_metric_registry_calls_these_functions():
    from blender_shapesig.core import metrics

    rng = np.random.default_rng(18)
    R0, R1 = random_curve(rng, 9, 2), random_curve(rng, 12, 2)
    assert metrics.curve_distance(R0, R1, "sim2") == sg.normalized_distance(R0, R1, 2)
    assert metrics.curve_distance(R0, R1, "group", level=3) == sg.group_distance(R0, R1, 3)
    assert metrics.curve_distance(R0, R1, "concat3") == sg.concat_distance(R0, R1, 3)
    assert metrics.curve_distance(R0, R1, "linear1") == sg.linear_distance(R0, R1, 1)


def test_walks_closer_than_walk_and_run(walk, walk2, run):
    """A sanity check of sim^2 on real clips (shared bones, still bones dropped)."""
    from blender_shapesig.core.clip.clip import restrict_to_shared

    a, b = restrict_to_shared(walk, walk2)
    a2, c = restrict_to_shared(walk, run)
    assert sg.normalized_distance(a.rotations, b.rotations, 2) < sg.normalized_distance(a2.rotations, c.rotations, 2)


def test_long_paths_are_chunked_with_the_same_answer(monkeypatch):
    rng = np.random.default_rng(19)
    x = random_path(rng, 300, 3, scale=0.1)
    expected = flat(plain_signature(x, 3))
    monkeypatch.setattr(tensor, "CHUNK_ENTRIES", 1)  # chunks of 64 steps joined by Chen's identity
    np.testing.assert_allclose(sg.path_signature(x, 3, method="numpy"), expected, rtol=0, atol=1e-12)


def test_distances_from_stored_signatures():
    rng = np.random.default_rng(21)
    R0, R1 = random_curve(rng, 12, 2), random_curve(rng, 15, 2)
    for n in (1, 2, 3):
        s0, s1 = sg.signature(R0, n), sg.signature(R1, n)
        assert abs(sg.group_distance_from_signatures(s0, s1, 6, n) - sg.group_distance(R0, R1, n)) < 1e-12
        for basis in sg.BASES:
            assert abs(sg.concat_distance_from_signatures(s0, s1, 6, n, basis=basis)
                       - sg.concat_distance(R0, R1, n, basis=basis)) < 1e-12
        a, b = sg.log_signature(R0, n), sg.log_signature(R1, n)
        assert sg.normalized_difference(a, b) == sg.normalized_distance(R0, R1, n)
    with pytest.raises(ShapeSigError):
        sg.group_distance_from_signatures(s0[:-1], s1, 6, 3)


def test_single_frame_curve_has_trivial_signature():
    one = np.broadcast_to(np.eye(3), (1, 2, 3, 3))
    rng = np.random.default_rng(22)
    moving = random_curve(rng, 6, 2)
    methods = ("numpy",) + (("iisignature",) if iisignature else ())
    for m in methods:
        assert sg.signature(one, 2, method=m).shape == (6 + 36,)
        assert not sg.log_signature(one, 3, method=m).any()
        assert sg.normalized_distance(one, moving, 3, method=m) == 1.0
        # rho^1 against a path that does not move is 2 |x(1) - x(0)|
        inc = sg.development(moving)[-1]
        assert abs(sg.group_distance(one, moving, 1, method=m) - 2 * np.linalg.norm(inc)) < 1e-14


@settings(max_examples=30, deadline=None)
@given(
    d=st.integers(1, 3),
    n=st.integers(1, 4),
    pts=st.integers(1, 6).flatmap(
        lambda k: arrays(np.float64, (k, 3), elements=st.floats(-2, 2, allow_nan=False, width=64))
    ),
)
def test_property_signature_log_and_inverse(d, n, pts):
    x = pts[:, :d]
    sig = tensor.signature_from_increments(np.diff(x, axis=0), n)
    np.testing.assert_allclose(tensor.flatten(sig), flat(plain_signature(x, n)), rtol=0, atol=1e-10)
    # the antipode (word reversal with sign) is the inverse of a signature: equals the series inverse
    np.testing.assert_allclose(tensor.flatten(tensor.antipode(sig, d)), tensor.flatten(tensor.inverse(sig)),
                               rtol=0, atol=1e-10)
    # Lyndon coordinates are coordinates: mapping back gives the tensor log-signature again
    log_t = tensor.log(sig)
    back = tensor.lyndon_to_tensor(tensor.lyndon_coordinates(log_t, d), d, n)
    np.testing.assert_allclose(tensor.flatten(back), tensor.flatten(log_t), rtol=0, atol=1e-10)


@pytest.mark.parametrize("d,m", [(1, 4), (2, 1), (3, 30), (7, 50), (51, 40)])
def test_lyndon_log_signature_by_products_equals_the_tensor_route_and_iisignature(d, m):
    """tensor.lyndon_log_signature (levels <= 3 from the increments by matrix products) gives the coordinates of
    the general route (signature, tensor log, Lyndon projection) and of iisignature, to 1e-12."""
    rng = np.random.default_rng(40 + d + m)
    dx = rng.normal(size=(m, d)) * 0.3
    x = np.vstack([np.zeros((1, d)), np.cumsum(dx, axis=0)])
    for n in (1, 2, 3):
        fast = tensor.lyndon_log_signature(dx, n)
        general = tensor.lyndon_coordinates(tensor.log(tensor.signature_from_increments(dx, n)), d)
        scale = max(1.0, float(np.abs(general).max()))
        np.testing.assert_allclose(fast, general, rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(sg.increments_log_signature(dx, n), general, rtol=0, atol=1e-12 * scale)
        if iisignature is not None and d >= 2:
            ref = iisignature.logsig(x, iisignature.prepare(d, n, "S"), "S")
            np.testing.assert_allclose(fast, ref, rtol=0, atol=1e-12 * scale)
    with pytest.raises(ShapeSigError):
        tensor.lyndon_log_signature(dx, 4)
