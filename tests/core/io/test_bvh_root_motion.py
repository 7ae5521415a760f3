"""The walk of a BVH in the Unity / MotionBuilder layout (a static reference ROOT, six channels on every joint, the
walk in the hips' channels; ``tests/helpers/reference_root.py``) reaches the comparison space and the search: the
same take with the walk on its ROOT reads as the same clip (hips path, rotations), and a walk turned to the side or
backward finds the same-direction walk first, far ahead of the others. Equality with Blender's importer:
tests/blender/readers/test_bvh_reference_root.py."""

import numpy as np
import pytest

from blender_shapesig.core import search as index
from blender_shapesig.core.io import sources
from blender_shapesig.core.io.bvh import load_bvh
from tests.helpers.reference_root import reference_root_layout, turned_walk

TURNS = (0, 90, 180)  # forward, to the side, backward: the body's facing unchanged


def _read(path):
    return sources.read_one(sources.ClipSpec(str(path), bone_map="auto"))


@pytest.fixture(scope="module")
def walks(data_dir, tmp_path_factory):
    text = (data_dir / "bvh" / "07_01.bvh").read_text()
    folder = tmp_path_factory.mktemp("reference_root")
    out = {}
    for turn in TURNS:
        (folder / f"root{turn}.bvh").write_text(turned_walk(text, turn))
        (folder / f"reference{turn}.bvh").write_text(reference_root_layout(text, turn=turn))
        out[turn] = (_read(folder / f"root{turn}.bvh"), _read(folder / f"reference{turn}.bvh"))
    out["path"] = folder / "reference90.bvh"
    return out


def test_the_hips_carry_the_root_motion(walks):
    clip = load_bvh(walks["path"])
    assert clip.root_bone == "Reference" and clip.meta["root_motion_bone"] == "hip"
    assert np.ptp(clip.root_translation, axis=0).max() > 100  # not walking in place (file units, ~17 a leg)


@pytest.mark.parametrize("turn", TURNS)
def test_reads_as_the_walk_on_its_root(walks, turn):
    on_root, below = walks[turn]
    assert on_root.bones == below.bones and below.meta["root_path"] == "hips_legs"
    np.testing.assert_allclose(below.root_translation, on_root.root_translation, rtol=0, atol=1e-9)
    np.testing.assert_allclose(below.rotations, on_root.rotations, rtol=0, atol=1e-9)


@pytest.mark.parametrize("turn", TURNS)
def test_the_search_sees_the_direction_of_travel(walks, turn):
    library = [walks[t][0] for t in TURNS]
    rows = index.rank_clips(walks[turn][1], library)
    want = index.clip_items([walks[turn][0]])[0].key
    assert rows[0].key == want and rows[0].distance < 0.01
    assert min(r.distance for r in rows[1:]) > 100 * rows[0].distance


def test_only_a_bone_holding_most_of_the_skeleton_carries_the_motion():
    """``skeleton.fold_root_motion`` on a chain root - hips - (spine, leg, leg, arm): a moving hand (a small subtree)
    is never the carrier, the hips are, and their displacement enters the root's path turned by the root's pose."""
    from blender_shapesig.core.clip.skeleton import fold_root_motion
    from blender_shapesig.core.geometry import so3

    parents = [-1, 0, 1, 1, 1, 4]  # root, hips, leg.L, leg.R, spine, hand
    frames = 5
    X = np.tile(np.eye(3), (frames, len(parents), 1, 1))
    X[:, 0] = so3.exp(np.array([0.0, 0.0, np.pi / 2]))  # the root turned a quarter about Z
    root = np.zeros((frames, 3))
    walk = np.outer(np.arange(frames), [1.0, 0.0, 0.0])
    path, carrier = fold_root_motion(parents, X, root, {5: 10 * walk})
    assert carrier is None and path is root
    path, carrier = fold_root_motion(parents, X, root, {1: walk, 5: 10 * walk})
    assert carrier == 1
    np.testing.assert_allclose(path, np.outer(np.arange(frames), [0.0, 1.0, 0.0]), atol=1e-12)
