"""The two SRVT norms of curves.srvt: per joint (q_j = eta_j / sqrt|eta_j|) and the thesis' product-group norm
(q = eta / sqrt|eta|, |eta| over all joints; eq. 4.5 with the so(3)^d norm of sec. 5.1)."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from blender_shapesig.core.elastic import elastic
from blender_shapesig.core import pairwise
from blender_shapesig.core.geometry import curves
from blender_shapesig.core.geometry.curves import inverse_srvt, l2_distance, srvt, use_srvt_norm
from blender_shapesig.core.errors import CurveError
from blender_shapesig.core.metrics import parse_metric_spec


def constant_speed_joints(axes, thetas, frames, start=None):
    """Joint j turns at constant speed theta_j about axes[j] over [0, 1] (from ``start``, identity default)."""
    t = np.linspace(0.0, 1.0, frames)
    axes = np.asarray(axes, dtype=float)
    axes = axes / np.linalg.norm(axes, axis=1, keepdims=True)
    rv = t[:, None, None] * (np.asarray(thetas)[:, None] * axes)[None]
    R = Rotation.from_rotvec(rv.reshape(-1, 3)).as_matrix().reshape(frames, len(thetas), 3, 3)
    return R if start is None else R @ start[None]


AXES = [[1.0, 2.0, -0.5], [0.0, 0.0, 1.0], [-1.0, 0.3, 0.2]]
THETAS = [2.5, 0.4, 1.1]


def test_closed_forms_of_both_norms_on_a_constant_speed_rotation():
    start = Rotation.random(3, random_state=1).as_matrix()
    R = constant_speed_joints(AXES, THETAS, 41, start)
    a = np.asarray(AXES) / np.linalg.norm(AXES, axis=1, keepdims=True)
    eta = np.asarray(THETAS)[:, None] * a  # the constant velocity, (joints, 3)
    joint = np.sqrt(THETAS)[:, None] * a  # eta_j / sqrt(theta_j)
    group = eta / np.sqrt(np.linalg.norm(eta))  # eta / sqrt(|eta|), |eta|^2 = sum theta_j^2
    np.testing.assert_allclose(srvt(R, norm="joint"), np.broadcast_to(joint, (40, 3, 3)), atol=1e-12)
    np.testing.assert_allclose(srvt(R, norm="group"), np.broadcast_to(group, (40, 3, 3)), atol=1e-12)
    # the norms differ on several joints (and agree on one)
    assert np.max(np.abs(joint - group)) > 0.3
    one = constant_speed_joints(AXES[:1], THETAS[:1], 11)
    np.testing.assert_allclose(srvt(one, norm="group"), srvt(one, norm="joint"), atol=1e-14)


def test_closed_form_d_p_star_with_the_group_norm():
    R0 = constant_speed_joints(AXES, THETAS, 31)
    R1 = constant_speed_joints(AXES[::-1], [0.7, 1.9, 0.2], 47)  # another frame count: the merged grid
    with use_srvt_norm("group"):
        d = l2_distance(R0, R1)
    q0, q1 = srvt(R0, norm="group")[0], srvt(R1, norm="group")[0]
    assert d == pytest.approx(np.linalg.norm(q0 - q1), abs=1e-12)
    assert abs(d - l2_distance(R0, R1)) > 1e-3  # the joint norm gives another number


@pytest.mark.parametrize("norm", ["joint", "group"])
def test_inverse_round_trip_for_both_norms(norm):
    rng = np.random.default_rng(4)
    steps = rng.normal(scale=0.2, size=(60, 4, 3))
    steps[10:14, 2] = 0.0  # a joint at rest for a while: q = 0 there under both norms
    from blender_shapesig.core.geometry import so3

    R = so3.integrate(steps, Rotation.random(4, random_state=2).as_matrix())
    t = np.sort(np.concatenate([[0.0, 1.0], rng.uniform(0.01, 0.99, 59)]))
    back = inverse_srvt(srvt(R, t, norm=norm), t, start=R[0], norm=norm)
    assert np.max(np.abs(back - R)) < 1e-10


def test_elastic_uses_the_chosen_norm_and_unknown_norms_fail():
    R0 = constant_speed_joints(AXES, THETAS, 21)
    R1 = constant_speed_joints(AXES, [0.5, 2.0, 1.0], 25)
    with use_srvt_norm("group"):
        dg = elastic.elastic_distance(R0, R1)
        assert curves.DEFAULT_SRVT_NORM == "group"
    with use_srvt_norm("joint"):
        dj = elastic.elastic_distance(R0, R1)
    assert abs(dg - dj) > 1e-3
    # constant speeds: the best warp is the identity for both, so d_S* = d_P*
    with use_srvt_norm("group"):
        assert dg == pytest.approx(l2_distance(R0, R1), rel=1e-6)
    M = pairwise.distance_matrix([R0, R1], parse_metric_spec("elastic_group"), workers=1)
    assert M[0, 1] == pytest.approx(dg, rel=1e-12)
    with pytest.raises(CurveError, match="norm"):
        srvt(R0, norm="thesis")
