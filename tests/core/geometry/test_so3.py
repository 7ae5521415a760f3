"""core.geometry.so3: log/exp against high-precision references and scipy, conversions, increments, stillness."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from blender_shapesig.core.geometry import so3
from blender_shapesig.core.errors import ShapeSigError

LD = np.longdouble
PI_LD = np.arctan2(LD(0.0), LD(-1.0))  # pi to longdouble precision (float64 pi is 1.2e-16 short)
ANGLES = [LD(0.0), LD(1e-12), LD(1e-8), LD(1e-4), LD(0.5), LD(1.0), PI_LD / 2 - LD(1e-9), PI_LD / 2,
          LD(2.0), LD(3.0), PI_LD - LD(1e-4), PI_LD - LD(1e-8), PI_LD - LD(1e-12), PI_LD]


def _axes(n, seed):
    """Unit axes in longdouble: the coordinate axes, near-axis directions and random ones."""
    rng = np.random.default_rng(seed)
    a = np.concatenate([np.eye(3), -np.eye(3), np.eye(3) + 1e-7 * rng.normal(size=(3, 3)),
                        rng.normal(size=(n, 3))]).astype(LD)
    return a / np.sqrt(np.sum(a * a, axis=1))[:, None]


def _reference(axes, theta):
    """R = cos I + sin [a]x + (1 - cos) a a^T in longdouble (exact axis-angle pairs)."""
    c, s = np.cos(theta), np.sin(theta)
    x, y, z = axes.T
    K = np.zeros((len(axes), 3, 3), dtype=LD)
    K[:, 0, 1], K[:, 0, 2], K[:, 1, 2] = -z, y, -x
    K[:, 1, 0], K[:, 2, 0], K[:, 2, 1] = z, -y, x
    return c * np.eye(3, dtype=LD) + s * K + (1 - c) * axes[:, :, None] * axes[:, None, :]


@pytest.mark.parametrize("theta", ANGLES, ids=[f"{float(t):.17g}" for t in ANGLES])
def test_log_and_exp_match_longdouble_references(theta):
    axes = _axes(40, seed=int(float(theta) * 1e6) % 1000)
    R = _reference(axes, theta)
    v_ref = axes * theta
    v = so3.log(R.astype(np.float64))
    err = np.linalg.norm(v - v_ref.astype(np.float64), axis=1)
    if theta == PI_LD:  # log(R) = +-pi a: the same rotation, either sign is right
        err = np.minimum(err, np.linalg.norm(v + v_ref.astype(np.float64), axis=1))
    assert err.max() <= 1e-14 * max(1.0, float(theta)), err.max()
    # exp: from the exact rotation vector rounded once to float64, against the reference matrix
    E = so3.exp(v_ref.astype(np.float64))
    assert np.abs(E - R.astype(np.float64)).max() <= 1e-14 * max(1.0, float(theta))
    assert so3.angle(R.astype(np.float64)) == pytest.approx(float(theta), rel=1e-15, abs=1e-15)


def test_log_exp_agree_with_scipy_on_random_and_edge_rotations():
    rng = np.random.default_rng(3)
    v = np.concatenate([Rotation.random(2000, random_state=1).as_rotvec(),
                        rng.normal(size=(200, 3)) * 1e-9,
                        _axes(50, 4).astype(np.float64) * (np.pi - 1e-7)])
    R = Rotation.from_rotvec(v).as_matrix()
    np.testing.assert_allclose(so3.log(R), Rotation.from_matrix(R).as_rotvec(), rtol=0, atol=1e-12)
    np.testing.assert_allclose(so3.exp(v), R, rtol=0, atol=1e-12)
    np.testing.assert_allclose(so3.log(so3.exp(v)), v, rtol=0, atol=1e-12)


def test_any_leading_shape():
    rng = np.random.default_rng(5)
    for lead in [(), (0,), (7,), (2, 3, 4)]:
        v = rng.normal(size=lead + (3,))
        R = so3.exp(v)
        assert R.shape == lead + (3, 3)
        assert so3.log(R).shape == lead + (3,)
        assert so3.angle(R).shape == lead
        q = so3.quat_from_matrix(R, scalar_first=True)
        assert q.shape == lead + (4,)
        np.testing.assert_allclose(so3.matrix_from_quat(q, scalar_first=True), R, atol=1e-14)
    with pytest.raises(ShapeSigError):
        so3.log(np.eye(4))
    with pytest.raises(ShapeSigError):
        so3.exp(np.zeros(4))


def test_relative_rotvecs_and_integrate_are_inverse():
    rng = np.random.default_rng(6)
    steps = rng.normal(size=(50, 4, 3)) * 0.3
    start = Rotation.random(4, random_state=2).as_matrix()
    R = so3.integrate(steps, start)
    assert R.shape == (51, 4, 3, 3)
    np.testing.assert_array_equal(R[0], start)
    np.testing.assert_allclose(so3.relative_rotvecs(R), steps, atol=1e-12)
    ref = Rotation.from_matrix((R[1:] @ np.swapaxes(R[:-1], -1, -2)).reshape(-1, 3, 3)).as_rotvec()
    np.testing.assert_allclose(so3.relative_rotvecs(R).reshape(-1, 3), ref, atol=1e-14)
    np.testing.assert_allclose(so3.integrate(steps)[0], np.broadcast_to(np.eye(3), (4, 3, 3)))
    assert so3.relative_rotvecs(R[:1]).shape == (0, 4, 3)
    assert so3.integrate(np.zeros((0, 2, 3))).shape == (1, 2, 3, 3)


def test_quaternions_in_both_orders_match_scipy():
    rot = Rotation.random(500, random_state=7)
    R = rot.as_matrix()
    xyzw = rot.as_quat()
    wxyz = xyzw[:, [3, 0, 1, 2]]
    np.testing.assert_allclose(so3.matrix_from_quat(xyzw, scalar_first=False), R, atol=1e-15)
    np.testing.assert_allclose(so3.matrix_from_quat(wxyz, scalar_first=True), R, atol=1e-15)
    np.testing.assert_allclose(so3.matrix_from_quat(3.0 * wxyz, scalar_first=True), R, atol=1e-15)  # normalized
    canon = np.where(xyzw[:, 3:] < 0, -xyzw, xyzw)
    np.testing.assert_allclose(so3.quat_from_matrix(R, scalar_first=False), canon, atol=1e-15)
    np.testing.assert_allclose(so3.quat_from_matrix(R, scalar_first=True), canon[:, [3, 0, 1, 2]], atol=1e-15)
    with pytest.raises(TypeError):
        so3.matrix_from_quat(xyzw)  # the order is never implicit


def test_continuous_quats():
    q = so3.quat_from_matrix(so3.exp(np.outer(np.linspace(0, 6, 40), [0, 0, 1.0])), scalar_first=True)
    assert np.any(np.einsum("ij,ij->i", q[1:], q[:-1]) < 0)  # w >= 0 jumps at pi
    c = so3.continuous_quats(q)
    assert np.all(np.einsum("ij,ij->i", c[1:], c[:-1]) > 0)
    np.testing.assert_allclose(np.abs(c), np.abs(q))


@pytest.mark.parametrize("mode", so3.EULER_MODES)
def test_euler_modes_match_scipy_and_invert(mode):
    rng = np.random.default_rng(8)
    angles = rng.uniform(-np.pi, np.pi, size=(300, 3))
    angles[:, 1] /= 2.0
    angles[:3, 1] = [np.pi / 2, -np.pi / 2, np.pi / 2 - 1e-9]  # gimbal lock and near it
    R = so3.matrix_from_euler(angles, mode)
    np.testing.assert_allclose(R, Rotation.from_euler(mode.lower(), angles).as_matrix(), atol=1e-15)
    back = so3.euler_from_matrix(R, mode)
    assert np.all(np.abs(back[:, 1]) <= np.pi / 2)
    np.testing.assert_allclose(so3.matrix_from_euler(back, mode), R, atol=1e-14)
    np.testing.assert_allclose(back[3:], angles[3:], atol=1e-12)


def test_euler_orders_of_any_length():
    np.testing.assert_allclose(so3.matrix_from_euler([[0.3, -0.2]], "xz"),
                               Rotation.from_euler("xz", [[0.3, -0.2]]).as_matrix(), atol=1e-15)
    with pytest.raises(ShapeSigError):
        so3.matrix_from_euler([0.1, 0.2], "XYZ")
    with pytest.raises(ShapeSigError):
        so3.euler_from_matrix(np.eye(3), "XYX")


@pytest.mark.parametrize("mode", so3.ROTATION_MODES)
def test_blender_channels_round_trip(mode):
    rng = np.random.default_rng(9)
    R = so3.exp(np.cumsum(rng.normal(size=(60, 3)) * 0.05, axis=0))
    ch = so3.channels_from_matrices(mode, R)
    assert ch.shape == (60, 4 if mode in ("QUATERNION", "AXIS_ANGLE") else 3)
    np.testing.assert_allclose(so3.matrices_from_channels(mode, ch), R, atol=1e-13)
    # continuous: no sign flips or 2 pi jumps (an axis near angle 0 may turn fast: the angle only)
    cols = [0] if mode == "AXIS_ANGLE" else slice(None)
    assert np.abs(np.diff(ch[:, cols], axis=0)).max() < 0.5
    if mode in so3.EULER_MODES:
        x = ch[:, ["XYZ".index(a) for a in mode]]
        np.testing.assert_allclose(Rotation.from_euler(mode.lower(), x).as_matrix(), R, atol=1e-13)
    with pytest.raises(ShapeSigError):
        so3.matrices_from_channels("XYY", ch)


def test_blender_channel_rest_values():
    np.testing.assert_array_equal(so3.matrices_from_channels("QUATERNION", np.zeros((2, 4))),
                                  np.broadcast_to(np.eye(3), (2, 3, 3)))
    np.testing.assert_array_equal(so3.matrices_from_channels("AXIS_ANGLE", [[1.0, 0, 0, 0]]), [np.eye(3)])
    np.testing.assert_allclose(so3.matrices_from_channels("AXIS_ANGLE", [[0.5, 0, 0, 2.0]]),
                               Rotation.from_rotvec([[0, 0, 0.5]]).as_matrix(), atol=1e-15)


def test_nearest_rotation():
    rng = np.random.default_rng(10)
    R = Rotation.random(20, random_state=3).as_matrix()
    M = R + 1e-5 * rng.normal(size=R.shape)
    N = so3.nearest_rotation(M)
    np.testing.assert_allclose(N @ np.swapaxes(N, -1, -2), np.broadcast_to(np.eye(3), N.shape), atol=1e-14)
    np.testing.assert_allclose(np.linalg.det(N), 1.0, atol=1e-14)
    assert np.abs(N - R).max() < 1e-4
    flipped = so3.nearest_rotation(np.diag([1.0, 1.0, -1.0])[None])
    np.testing.assert_allclose(np.linalg.det(flipped), 1.0)


def test_still_joints_is_the_angle_from_the_first_frame():
    tol = so3.STILL_TOLERANCE
    drift = np.linspace(0.0, 1.0, 30)[:, None]
    base = Rotation.random(1, random_state=4).as_matrix()[0]
    joints = [0.0, 0.9 * tol, 1.1 * tol, 0.5]
    R = np.stack([so3.exp(drift * [0.0, a, 0.0]) @ base for a in joints], axis=1)
    np.testing.assert_array_equal(so3.still_joints(R), [True, True, False, False])
    # an oscillation within the tolerance is still even though its steps are up to twice as big
    osc = so3.exp(np.outer(np.r_[0.0, (-1.0) ** np.arange(9)], [0.0, 0.0, 0.9 * tol]))
    assert so3.still_joints(osc[:, None])[0]
    assert so3.still_joints(R[:1]).all()
    assert so3.still_joints(R, tolerance=0.6).all()
    # accurate where arccos of the trace is not (its round-off floor is ~1e-8 rad)
    tiny = np.stack([np.eye(3), so3.exp([0.0, 0.0, 3e-9])])[:, None]
    assert not so3.still_joints(tiny, tolerance=2e-9)[0]
