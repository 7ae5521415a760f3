"""``so3.align``, ``heading``, ``turn`` and ``twist`` (the rotation toolkit's directions and "up") against
closed forms and scipy's ``Rotation``."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from blender_shapesig.core.geometry import so3

RNG = np.random.default_rng(7)


def test_align_turns_u_into_v_by_the_angle_between_them():
    u, v = RNG.normal(size=(200, 3)), RNG.normal(size=(200, 3))
    R = so3.align(u, v)
    un, vn = u / np.linalg.norm(u, axis=1)[:, None], v / np.linalg.norm(v, axis=1)[:, None]
    np.testing.assert_allclose(np.einsum("nij,nj->ni", R, un), vn, atol=1e-12)
    # the smallest such rotation: its angle is the angle between u and v, its axis is normal to both
    np.testing.assert_allclose(Rotation.from_matrix(R).magnitude(), np.arccos(np.sum(un * vn, axis=1)), atol=1e-7)
    np.testing.assert_allclose(np.sum(Rotation.from_matrix(R).as_rotvec() * un, axis=1), 0.0, atol=1e-12)


@pytest.mark.parametrize("u", [[1.0, 0, 0], [0, 0, 2.0], [0.3, -0.4, 0.5]])
def test_align_of_opposite_directions_is_a_half_turn_and_of_equal_ones_the_identity(u):
    u = np.asarray(u)
    R = so3.align(u, -3 * u)
    np.testing.assert_allclose(R @ (u / np.linalg.norm(u)), -u / np.linalg.norm(u), atol=1e-12)
    assert abs(Rotation.from_matrix(R).magnitude() - np.pi) < 1e-12
    np.testing.assert_allclose(so3.align(u, 2 * u), np.eye(3), atol=1e-12)


@pytest.mark.parametrize("up", [[0, 0, 1.0], [0, 1.0, 0], [0.6, 0.0, 0.8]])
def test_heading_is_the_angle_of_a_rotation_about_up_and_ignores_tilt(up):
    up = np.asarray(up)
    angles = RNG.uniform(-3.1, 3.1, 50)
    R = Rotation.from_rotvec(angles[:, None] * up).as_matrix()
    np.testing.assert_allclose(so3.heading(R, up), angles, atol=1e-12)
    # a small tilt about a horizontal axis applied first does not change the heading much; a turn about up adds
    tilt = Rotation.from_rotvec(0.05 * np.cross(up, [1.0, 0.0, 0.0]) / max(np.linalg.norm(np.cross(up, [1, 0, 0])), 1e-9))
    assert np.max(np.abs(np.angle(np.exp(1j * (so3.heading(R @ tilt.as_matrix(), up) - angles))))) < 0.06


def test_turn_is_rodrigues_and_agrees_with_exp():
    up = np.array([0.0, 0.6, 0.8])
    v, a = RNG.normal(size=(100, 3)), RNG.uniform(-4, 4, 100)
    expected = np.einsum("nij,nj->ni", so3.exp(a[:, None] * up), v)
    np.testing.assert_allclose(so3.turn(v, up, a), expected, atol=1e-12)
    np.testing.assert_allclose(so3.turn(v[0], up, 0.3), so3.exp(0.3 * up) @ v[0], atol=1e-12)


def test_twist_is_the_swing_twist_angle():
    axis = np.array([0.0, 0.0, 1.0])
    t = RNG.uniform(-3.1, 3.1, 100)
    swing_axes = np.cross(axis, RNG.normal(size=(100, 3)))
    swing_axes /= np.linalg.norm(swing_axes, axis=1)[:, None]
    swing = Rotation.from_rotvec(RNG.uniform(0, 1.2, 100)[:, None] * swing_axes)
    R = (swing * Rotation.from_rotvec(t[:, None] * axis)).as_matrix()
    np.testing.assert_allclose(np.angle(np.exp(1j * (so3.twist(R, axis) - t))), 0.0, atol=1e-9)
