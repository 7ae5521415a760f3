"""Planted feet in generated frames (core.blend.plant) against independent truth: a standing pose held through a
gap in which the motion turns and rolls one foot about its heel, or sinks the whole body into the floor: after
``plant_gap`` the heel and the ball are where they were at the last known frame (forward kinematics, to 1e-6 of
the leg) and the known frames are untouched; a body raised instead is left as it is (a heel may leave the
floor)."""

import pathlib

import numpy as np
import pytest

from blender_shapesig.core.blend.body import aligned_and_root
from blender_shapesig.core.blend.contacts import legs_of
from blender_shapesig.core.blend.plant import plant_gap
from blender_shapesig.core.clip.skeleton import forward_kinematics, rest_of, up_vector
from blender_shapesig.core.geometry import so3
from blender_shapesig.core.io.sources import read_one

DATA = pathlib.Path(__file__).resolve().parents[2] / "data"
KNOWN, GAP = 30, 20  # frames at 120 fps: known frames on each side of the gap


@pytest.fixture(scope="module")
def standing():
    """13_32's last frame (standing on both feet) held for KNOWN + GAP + KNOWN frames: (clip, X, root)."""
    clip = read_one(str(DATA / "bvh" / "13_32.bvh"), bone_map="none")
    X, root = aligned_and_root(clip)
    n = 2 * KNOWN + GAP
    return clip, np.repeat(X[-1:], n, axis=0), np.repeat(root[-1:], n, axis=0)


def _feet(clip, X, root, leg):
    heads, tails, _W = forward_kinematics(clip, rest_of(clip), X, root)
    return heads[:, leg[2]], tails[:, leg[2]]


def _bump(n):
    """0 at the known frames, rising to 1 and back over the gap (sin^2)."""
    t = np.zeros(n)
    t[KNOWN:KNOWN + GAP] = np.sin(np.pi * (np.arange(GAP) + 1) / (GAP + 1)) ** 2
    return t


def test_a_planted_foot_turning_about_its_heel_keeps_its_ball(standing):
    clip, X, root = standing
    side, leg = next(iter(legs_of(clip).items()))
    up = up_vector(clip)
    heel0, ball0 = _feet(clip, X, root, leg)
    rest = rest_of(clip)
    # the motion turns the foot about up by up to 12 degrees and rolls it by 2 about its own heel (world rotation
    # of the foot, its parent kept): the ball swings over the floor by about 3 cm
    t = _bump(len(X))
    axis = np.cross(ball0[0] - heel0[0], up)
    axis /= np.linalg.norm(axis)
    turn = so3.exp(t[:, None] * (np.radians(12.0) * up + np.radians(2.0) * axis)[None])
    W = forward_kinematics(clip, rest, X, root)[2]
    parent = rest.ancestor[leg[2]]
    moved = X.copy()
    moved[:, leg[2]] = np.swapaxes(W[:, parent], -1, -2) @ turn @ W[:, leg[2]]
    heel, ball = _feet(clip, moved, root, leg)
    leg_length = np.linalg.norm(rest.heads[leg[2]] - rest.heads[leg[0]])
    assert np.linalg.norm(ball - ball0, axis=1).max() > 0.15 * np.linalg.norm(ball0[0] - heel0[0])
    got = plant_gap(clip, moved, root, KNOWN, KNOWN + GAP - 1, steps=True)
    heel, ball = _feet(clip, got, root, leg)
    assert np.linalg.norm(heel - heel0, axis=1).max() < 1e-6 * leg_length
    assert np.linalg.norm(ball - ball0, axis=1).max() < 1e-6 * leg_length
    np.testing.assert_array_equal(got[:KNOWN], moved[:KNOWN])
    np.testing.assert_array_equal(got[KNOWN + GAP:], moved[KNOWN + GAP:])
    # a bridge's frames (no steps) roll their feet as the library does: the ball goes where the motion turns it
    got = plant_gap(clip, moved, root, KNOWN, KNOWN + GAP - 1, steps=False)
    np.testing.assert_allclose(_feet(clip, got, root, leg)[1], _feet(clip, moved, root, leg)[1], atol=1e-6 * leg_length)
    # so does a foot already rolling at the last known frame: the turn starts a frame before the gap
    early = moved.copy()
    early[KNOWN - 1, leg[2]] = moved[KNOWN + 3, leg[2]]  # the ball moving (faster than STILL_BALL)
    got = plant_gap(clip, early, root, KNOWN, KNOWN + GAP - 1, steps=True)
    np.testing.assert_allclose(_feet(clip, got, root, leg)[1], _feet(clip, early, root, leg)[1], atol=1e-6 * leg_length)


def test_a_planted_heel_is_held_no_lower_than_where_it_stands(standing):
    clip, X, root = standing
    legs = legs_of(clip)
    up = up_vector(clip)
    rest = rest_of(clip)
    leg_length = np.linalg.norm(rest.heads[legs["L"][2]] - rest.heads[legs["L"][0]])
    t = _bump(len(X))
    feet0 = {s: _feet(clip, X, root, leg) for s, leg in legs.items()}
    # the root sinks by 1 % of the leg in the gap with the pose kept: every foot point would go down into the floor
    sunk = root - 0.01 * leg_length * t[:, None] * up[None]
    got = plant_gap(clip, X, sunk, KNOWN, KNOWN + GAP - 1, steps=False)  # the foot keeps its rotation
    for side, leg in legs.items():
        heel, ball = _feet(clip, got, sunk, leg)
        assert np.linalg.norm(heel - feet0[side][0], axis=1).max() < 1e-6 * leg_length
        assert np.linalg.norm(ball - feet0[side][1], axis=1).max() < 1e-6 * leg_length
    # raised by as much, nothing changes: a heel may leave the floor (held on the ground plane only), and the foot
    # keeps its rotation (a bridge's frames: no ball held)
    raised = root + 0.01 * leg_length * t[:, None] * up[None]
    got = plant_gap(clip, X, raised, KNOWN, KNOWN + GAP - 1, steps=False)
    np.testing.assert_allclose(got, X, atol=1e-9)
