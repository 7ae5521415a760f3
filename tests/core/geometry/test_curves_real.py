"""The curve core on real CMU clips (ASF/AMC read by our own parser, no bpy)."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from blender_shapesig.core import geodesic_interpolate, inverse_srvt, l2_distance, srvt
from blender_shapesig.core.io.acclaim import load_acclaim
from blender_shapesig.core.clip.clip import restrict_to_shared


@pytest.fixture(scope="module")
def walk(data_dir):
    return load_acclaim(data_dir / "acclaim" / "07_01.amc", data_dir / "acclaim" / "07-walk.asf")


@pytest.fixture(scope="module")
def run(data_dir):
    return load_acclaim(data_dir / "acclaim" / "09_02.amc", data_dir / "acclaim" / "09-run.asf")


def test_srvt_round_trip_on_a_real_walk(walk):
    R = walk.rotations
    assert R.shape == (316, len(walk.bones), 3, 3)
    back = inverse_srvt(srvt(R), start=R[0])
    assert np.max(np.abs(back - R)) < 1e-10


def test_right_translation_invariance_on_a_real_clip(run):
    R = run.rotations
    g = Rotation.random(R.shape[1], random_state=3).as_matrix()
    np.testing.assert_allclose(srvt(R @ g[None]), srvt(R), atol=1e-10)


def test_d_p_star_ignores_geodesic_refinement_and_sees_timing(walk):
    R = walk.rotations
    n = R.shape[0]
    t = np.linspace(0, 1, n)
    refined = geodesic_interpolate(R, t, np.linspace(0, 1, 2 * n - 1))
    assert l2_distance(R, refined) < 1e-9
    # A time warp of the same motion is far in d_P* (that is what the elastic distance removes).
    warped = geodesic_interpolate(R, t, np.linspace(0, 1, n) ** 1.5)
    assert l2_distance(R, warped) > 0.1 * l2_distance(R, R[::-1])


def test_walk_and_run_distance_is_symmetric_on_shared_bones(walk, run):
    a, b = restrict_to_shared(walk, run)
    assert a.bones == b.bones and len(a.bones) >= 20
    d_ab, d_ba = l2_distance(a.rotations, b.rotations), l2_distance(b.rotations, a.rotations)
    assert d_ab == pytest.approx(d_ba, rel=1e-12) and d_ab > 0
