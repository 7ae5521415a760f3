"""The local search's still windows (issue 41, ``local.STILL``): each window's normalized motion parts (level 1 and
level 2, length <= 1) get a stillness coordinate sqrt(1 - length^2), so every window's motion lies on the unit
sphere and a still window sits at sqrt(2) from every moving one, the distance of two unrelated (orthogonal) motions.
Without it a still window is at distance 1 from every moving window, nearer than any motion but a similar one, and a
clip that stands still was the nearest clip of every short action (docs/search.md, "Short actions"). Checked in
closed form on a real clip's windows and on the bundled jump: its own standing pose held still is not its nearest
clip, clips that move are."""

import numpy as np
import pytest

from blender_shapesig.core import rigs
from blender_shapesig.core.search.local import features as local
from blender_shapesig.core.io import sources


def _features(path):
    raw = sources.read_one(sources.ClipSpec(str(path), bone_map="none"))
    return local.features(rigs.apply_bone_map(raw, "auto"))


def _held(feat, frame=0):
    """The clip's pose at ``frame`` held for the clip's duration: a body standing still."""
    return {k: (np.repeat(np.asarray(v)[frame:frame + 1], len(v), axis=0) if k != "rate" else v)
            for k, v in feat.items()}


def _motion_blocks(feat, settings):
    """(lvl1, lvl2, stillness) columns of ``local.window_vectors`` (unprojected), from the parts' sizes."""
    V = local.window_vectors(feat, settings)
    d = feat["pose"].shape[1] + feat["motion"].shape[1]
    a = feat["pose"].shape[1]
    lvl1, lvl2 = V[:, a:a + d], V[:, a + d:a + d + d * (d - 1) // 2]
    return lvl1, lvl2, V[:, -2:]


@pytest.fixture(scope="module")
def jump(data_dir):
    return _features(data_dir / "bvh" / "13_32.bvh")


def test_every_window_motion_lies_on_the_unit_sphere(jump):
    s = local.Settings()
    assert s.still == local.STILL == 1.0
    lvl1, lvl2, still = _motion_blocks(jump, s)
    assert np.allclose(np.linalg.norm(np.column_stack([lvl1, still[:, 0]]), axis=1), 1.0)
    assert np.allclose(np.linalg.norm(np.column_stack([lvl2, still[:, 1]]), axis=1), 1.0)
    assert np.allclose(still, 0.0, atol=1e-6)  # every window of the jump moves (beyond the parts' floor)
    h1, h2, hs = _motion_blocks(_held(jump), s)
    assert np.allclose(h1, 0.0) and np.allclose(h2, 0.0) and np.allclose(hs, 1.0)


def test_a_still_window_is_as_far_from_a_motion_as_an_unrelated_motion(jump):
    lvl1, _, still = _motion_blocks(jump, local.Settings())
    moving = still[:, 0] < 1e-6
    h1, _, hs = _motion_blocks(_held(jump), local.Settings())
    gap = np.linalg.norm(np.column_stack([lvl1, still[:, 0]])[moving] - np.append(h1[0], hs[0, 0]), axis=1)
    assert moving.all() and np.allclose(gap, np.sqrt(2.0))  # unit vectors: orthogonal to the stillness axis
    # without the coordinate the still window is at distance 1: nearer than any motion with cosine < 1/2
    off1, _, _ = _motion_blocks(jump, local.Settings(still=0.0))
    assert np.allclose(np.linalg.norm(off1[moving], axis=1), 1.0)


def test_a_clip_that_moves_is_not_nearest_to_a_body_standing_still(jump, data_dir):
    others = {"own first frame held": _held(jump), "walk's first frame held": _held(_features(data_dir / "bvh" / "07_01.bvh")),
              "walk 07_01": _features(data_dir / "bvh" / "07_01.bvh"), "walk 08_01": _features(data_dir / "bvh" / "08_01.bvh"),
              "run 09_02": _features(data_dir / "bvh" / "09_02.bvh")}
    names = list(others)

    def nearest(settings):
        q = local.entry_from_features(jump, settings)
        d = local.first_stage(q, [local.entry_from_features(f, settings) for f in others.values()])
        return names[int(np.argmin(d))]

    assert nearest(local.Settings(still=0.0)) == "own first frame held"  # the defect: still clips were hubs
    assert "held" not in nearest(local.Settings())
