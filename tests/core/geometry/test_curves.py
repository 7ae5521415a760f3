"""Curve core: right logarithmic derivative, SRVT and inverse, geodesic interpolation, d_P*.

Truth comes from closed forms (constant-speed rotations), another library (scipy's Slerp), exact
invariances (right translation, piecewise-linear reparametrization, eq. 4.6) and a fine Riemann sum.
"""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp

from blender_shapesig.core import (
    CurveError,
    geodesic_interpolate,
    inverse_srvt,
    l2_distance,
    move_to_identity,
    right_log_derivative,
    srvt,
)
from blender_shapesig.core.geometry.curves import as_curve, relative_rotvecs


def random_walk_curve(frames=60, joints=4, step=0.2, seed=0):
    """A curve whose consecutive steps are random rotations of angle < step (well below pi)."""
    rng = np.random.default_rng(seed)
    R = np.empty((frames, joints, 3, 3))
    R[0] = Rotation.random(joints, random_state=seed).as_matrix()
    for k in range(1, frames):
        v = rng.normal(size=(joints, 3))
        v *= (step * rng.uniform(0.1, 1.0, size=(joints, 1))) / np.linalg.norm(v, axis=1, keepdims=True)
        R[k] = Rotation.from_rotvec(v).as_matrix() @ R[k - 1]
    return R


def random_times(frames, seed=1):
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.2, 1.0, size=frames - 1))
    return np.concatenate([[0.0], t / t[-1]])


def constant_speed(axis, angle_total, frames, start=None):
    """exp(s * angle_total * axis) R0 for s on the uniform grid: one joint at constant speed."""
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    s = np.linspace(0.0, 1.0, frames)
    R = Rotation.from_rotvec(s[:, None] * angle_total * axis).as_matrix()
    if start is not None:
        R = R @ start
    return R[:, None]


class TestClosedForms:
    def test_constant_speed_derivative_and_srvt(self):
        axis = np.array([1.0, 2.0, -0.5])
        theta = 2.5
        R = constant_speed(axis, theta, 51, start=Rotation.from_euler("xyz", [0.3, -1, 2]).as_matrix())
        eta = right_log_derivative(R)
        a = axis / np.linalg.norm(axis)
        np.testing.assert_allclose(eta, np.broadcast_to(theta * a, eta.shape), atol=1e-12)
        # q = eta / sqrt(|eta|) = sqrt(theta) a
        np.testing.assert_allclose(srvt(R), np.broadcast_to(np.sqrt(theta) * a, eta.shape), atol=1e-12)

    def test_l2_between_constant_speed_curves(self):
        a0, a1 = np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0])
        th0, th1 = 1.7, 0.6
        R0 = constant_speed(a0, th0, 31)
        R1 = constant_speed(a1, th1, 47)  # different frame count: merged grid
        expected = np.linalg.norm(np.sqrt(th0) * a0 - np.sqrt(th1) * a1)
        assert l2_distance(R0, R1) == pytest.approx(expected, abs=1e-12)

    def test_non_uniform_times_scale_the_derivative(self):
        R = random_walk_curve(20, 2)
        t = random_times(20)
        eta = right_log_derivative(R, t)
        np.testing.assert_allclose(eta * np.diff(t)[:, None, None], relative_rotvecs(R), atol=1e-14)


class TestRoundTripsAndInvariances:
    @pytest.mark.parametrize("uniform", [True, False])
    def test_inverse_srvt_round_trip(self, uniform):
        R = random_walk_curve(80, 5, step=0.5)
        t = None if uniform else random_times(80)
        back = inverse_srvt(srvt(R, t), t, start=R[0])
        assert np.max(np.abs(back - R)) < 1e-10

    def test_round_trip_near_pi(self):
        # Steps of angle just below pi, the hardest case for the logarithm.
        axis = np.array([0.2, -0.7, 0.4])
        axis /= np.linalg.norm(axis)
        steps = [np.pi - 1e-7, np.pi - 1e-3, 0.5, np.pi - 1e-9]
        R = [np.eye(3)]
        for ang in steps:
            R.append(Rotation.from_rotvec(ang * axis).as_matrix() @ R[-1])
        R = np.array(R)[:, None]
        back = inverse_srvt(srvt(R), start=R[0])
        assert np.max(np.abs(back - R)) < 1e-9

    def test_zero_velocity_gives_zero_not_nan(self):
        R = np.repeat(Rotation.from_euler("z", 0.4).as_matrix()[None, None], 10, axis=0)
        q = srvt(R)
        assert np.all(np.isfinite(q)) and np.all(q == 0.0)
        np.testing.assert_allclose(inverse_srvt(q, start=R[0]), R, atol=1e-15)

    def test_rounding_noise_is_zero_velocity_but_small_motion_is_not(self):
        from blender_shapesig.core.geometry.curves import ZERO_STEP

        angles = [0.0, 0.1 * ZERO_STEP, 1e3 * ZERO_STEP]
        R = np.stack([np.eye(3)] + [Rotation.from_rotvec([0, 0, a]).as_matrix() for a in np.cumsum(angles)])
        q = srvt(R[:, None])
        assert np.all(q[:2] == 0.0)
        # |q| = sqrt(|eta|) with eta = step / dt and dt = 1/3
        assert np.linalg.norm(q[2]) == pytest.approx(np.sqrt(3e3 * ZERO_STEP), rel=1e-6)

    def test_right_translation_invariance(self):
        R = random_walk_curve(40, 3)
        g = Rotation.random(3, random_state=7).as_matrix()
        np.testing.assert_allclose(srvt(R @ g[None]), srvt(R), atol=1e-12)
        np.testing.assert_allclose(move_to_identity(R @ g[None]), move_to_identity(R), atol=1e-12)
        assert l2_distance(R, R @ g[None]) < 1e-10

    def test_move_to_identity_starts_at_identity(self):
        P = move_to_identity(random_walk_curve(10, 3))
        np.testing.assert_allclose(P[0], np.broadcast_to(np.eye(3), (3, 3, 3)), atol=1e-14)

    def test_equivariance_under_piecewise_linear_reparametrization(self):
        """Eq. 4.6: R(c o phi) = (R(c) o phi) * sqrt(phi'), exactly, for piecewise-linear phi.

        c o phi is again piecewise geodesic on the grid that merges phi's breakpoints with the
        preimages of c's knots, so both sides are piecewise constant there and must agree exactly.
        """
        R = random_walk_curve(25, 3, step=0.4)
        t = random_times(25, seed=3)
        xs = np.array([0.0, 0.3, 0.55, 1.0])  # phi's breakpoints
        ys = np.array([0.0, 0.1, 0.7, 1.0])   # phi(xs), increasing
        phi = lambda u: np.interp(u, xs, ys)
        phi_inv = lambda s: np.interp(s, ys, xs)
        u = np.unique(np.concatenate([xs, phi_inv(t)]))
        u = u[np.concatenate([[True], np.diff(u) > 1e-12])]
        Rc = geodesic_interpolate(R, t, phi(u))
        lhs = srvt(Rc, u)
        mids = 0.5 * (u[:-1] + u[1:])
        k = np.clip(np.searchsorted(t, phi(mids), side="right") - 1, 0, len(t) - 2)
        slope = np.diff(phi(u)) / np.diff(u)
        rhs = srvt(R, t)[k] * np.sqrt(slope)[:, None, None]
        np.testing.assert_allclose(lhs, rhs, atol=1e-9)

    def test_quaternion_input_equals_matrix_input(self):
        R = random_walk_curve(15, 2)
        quat = Rotation.from_matrix(R.reshape(-1, 3, 3)).as_quat().reshape(15, 2, 4)
        quat[::2] *= -1.0  # sign flips must not matter
        np.testing.assert_allclose(srvt(quat), srvt(R), atol=1e-12)


class TestGeodesicInterpolation:
    def test_agrees_with_scipy_slerp(self):
        R = random_walk_curve(12, 3, step=1.0)
        t = random_times(12, seed=5)
        t_new = np.sort(np.random.default_rng(2).uniform(0, 1, 200))
        ours = geodesic_interpolate(R, t, t_new)
        for j in range(3):
            ref = Slerp(t, Rotation.from_matrix(R[:, j]))(t_new).as_matrix()
            np.testing.assert_allclose(ours[:, j], ref, atol=1e-10)

    def test_knots_and_end_points_are_exact(self):
        R = random_walk_curve(9, 2)
        t = random_times(9)
        out = geodesic_interpolate(R, t, t)
        assert np.array_equal(out, R)

    def test_inserting_geodesic_midpoints_keeps_the_shape(self):
        R = random_walk_curve(30, 4)
        t = np.linspace(0, 1, 30)
        t_fine = np.linspace(0, 1, 59)  # adds every midpoint
        R_fine = geodesic_interpolate(R, t, t_fine)
        assert l2_distance(R, R_fine) < 1e-10

    def test_out_of_range_is_an_error(self):
        with pytest.raises(CurveError):
            geodesic_interpolate(random_walk_curve(5, 1), None, [1.5])


class TestL2Distance:
    def test_merged_grid_matches_fine_riemann_sum(self):
        R0 = random_walk_curve(23, 3, seed=1)
        R1 = random_walk_curve(37, 3, seed=2)
        q0, q1 = srvt(R0), srvt(R1)
        n = 200_000
        s = (np.arange(n) + 0.5) / n
        k0 = np.minimum((s * 22).astype(int), 21)
        k1 = np.minimum((s * 36).astype(int), 35)
        riemann = np.sqrt(np.mean(np.sum((q0[k0] - q1[k1]) ** 2, axis=(1, 2))))
        assert l2_distance(R0, R1) == pytest.approx(riemann, rel=1e-4)

    def test_symmetric_and_zero_on_itself(self):
        R0, R1 = random_walk_curve(20, 2, seed=3), random_walk_curve(26, 2, seed=4)
        assert l2_distance(R0, R1) == pytest.approx(l2_distance(R1, R0), abs=1e-14)
        assert l2_distance(R0, R0) == 0.0

    def test_triangle_inequality(self):
        a, b, c = (random_walk_curve(20, 2, seed=s) for s in (5, 6, 7))
        assert l2_distance(a, c) <= l2_distance(a, b) + l2_distance(b, c) + 1e-12


class TestBadInput:
    @pytest.mark.parametrize(
        "bad",
        [np.zeros((5, 2, 3)), np.zeros((5, 2, 3, 4)), np.zeros((0, 2, 3, 3)), np.full((3, 1, 3, 3), np.nan)],
    )
    def test_bad_curves(self, bad):
        with pytest.raises(CurveError):
            srvt(bad)

    def test_bad_times(self):
        R = random_walk_curve(5, 1)
        for t in ([0, 0.5, 0.4, 0.9, 1], [0, 0.2, 0.4, 0.6], [0.1, 0.2, 0.4, 0.6, 1.0]):
            with pytest.raises(CurveError):
                srvt(R, t)

    def test_joint_count_mismatch(self):
        with pytest.raises(CurveError):
            l2_distance(random_walk_curve(5, 2), random_walk_curve(5, 3))

    def test_zero_quaternion(self):
        with pytest.raises(CurveError):
            as_curve(np.zeros((3, 1, 4)))
