"""Assign, Preview and Blend of another rig's motion (issue 31) on the mixed file saved and reopened: the Daz 09_02
run found from the AMC walk's armature is retargeted through the bone maps onto the AMC armature (a new action, the
source untouched): every mapped bone moves, each joint's angular velocity in the comparison space (world
rotations relative to rest, heading removed; invariant to the rest-pose correction) correlates >= 0.9 with the
source's, the hips travel at the AMC rig's size, unmapped bones keep rest and are listed; Preview/Stop restores
exactly; save -> reopen keeps the assigned action."""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from blender_shapesig.actions import action_io, frame_rates  # noqa: E402
from blender_shapesig.rigs import rigmap  # noqa: E402
from blender_shapesig.search import library  # noqa: E402
from blender_shapesig.actions.action_hashes import read_hash  # noqa: E402
from blender_shapesig.core import search as search  # noqa: E402
from blender_shapesig.core import rigs  # noqa: E402
from blender_shapesig.core.geometry import so3  # noqa: E402
from tests.helpers.mixed_scene import activate, build, save_reopen  # noqa: E402


@pytest.fixture
def mixed(empty_file, tmp_path, monkeypatch):
    monkeypatch.setenv(search.CACHE_ENV, str(tmp_path / "index"))
    frame_rates.forget()
    build(names=("09_02",))
    save_reopen(tmp_path / "mixed.blend")
    activate(bpy.data.objects["07-walk"])
    yield tmp_path
    frame_rates.forget()


def _comparison(action, arm):
    clip = action_io.read_action(action, armature=arm, exclude_unkeyed=True, space="armature")
    return rigs.apply_bone_map(clip, rigmap.bone_map_of(arm))


def _velocity(R):
    """(frames-1, 3): spatial angular velocity log(W(t+1) W(t)^T) of one joint."""
    return so3.log(R[1:] @ np.swapaxes(R[:-1], -1, -2))


def _select_row(source):
    res = bpy.context.window_manager.shapesig_results
    names = [r.source for r in res.results]
    assert source in names, names
    res.results_index = names.index(source)
    return res.results[res.results_index]


def test_assign_preview_of_another_rigs_result(mixed):
    s = bpy.context.scene.shapesig
    s.similarity, s.rerank = "sim", 0
    src = bpy.data.actions["09_02"]
    src_hash, amc = read_hash(src), bpy.data.objects["07-walk"]
    walk = amc.animation_data.action
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    _select_row("09_02")
    # Preview, then Stop: exactly what was there
    modes = {pb.name: pb.rotation_mode for pb in amc.pose.bones}
    n_actions = len(bpy.data.actions)
    assert bpy.ops.shapesig.preview_result() == {"FINISHED"}
    assert amc.animation_data.action not in (walk, src)
    assert bpy.ops.shapesig.preview_result() == {"FINISHED"}
    assert amc.animation_data.action == walk and len(bpy.data.actions) == n_actions
    assert {pb.name: pb.rotation_mode for pb in amc.pose.bones} == modes
    # Assign: a new action on the AMC armature, the source untouched
    assert bpy.ops.shapesig.assign_result() == {"FINISHED"}
    new = amc.animation_data.action
    assert new not in (walk, src) and "09_02" in new.name and read_hash(src) == src_hash
    row = _select_row("09_02")
    owner = bpy.data.objects["09_02"]
    a, b = _comparison(new, amc), _comparison(src, owner)
    assert a.frames == b.frames
    shared = [j for j in b.bones if j in a.bones]
    assert len(shared) >= 15, shared
    mapped = {a.meta["bone_map"][j] for j in shared}  # the AMC bones whose joint the Daz rig has too
    for j in shared:
        va, vb = _velocity(a.rotations[:, a.bones.index(j)]), _velocity(b.rotations[:, b.bones.index(j)])
        assert np.abs(va).max() > 1e-3, j  # every mapped bone moves
        r = np.corrcoef(va.ravel(), vb.ravel())[0, 1]
        assert r >= 0.9, (j, r)
    # bones with no counterpart keep their rest and are listed on the row
    kept = [x for x in row.kept.split(", ") if x]
    # the Daz rig has no spine_mid and one neck bone: the AMC's upperback (between lowerback and thorax) and
    # upperneck (between lowerneck and head) share their chain's rotation (core.rigs.chains) and are not kept
    chain = {"upperback", "upperneck"}
    assert set(kept) == {x.name for x in amc.data.bones} - mapped - chain
    clip = action_io.read_action(new, armature=amc, exclude_unkeyed=True)
    for x in chain:
        assert np.ptp(so3.angle(clip.rotations[:, clip.bones.index(x)])) > np.radians(1.0), x
    for x in kept:
        assert np.allclose(clip.rotations[:, clip.bones.index(x)], np.eye(3), atol=1e-6), x
    # the hips travel as far in the AMC rig's leg lengths as the run's hips in the Daz rig's
    def stride(c):
        return np.linalg.norm(c.root_translation[-1, :2] - c.root_translation[0, :2])
    assert abs(stride(a) - stride(b)) <= 0.05 * stride(b), (stride(a), stride(b))
    # saved and reopened in a fresh file: still there, still assigned
    name = new.name
    save_reopen(mixed / "assigned.blend")
    amc = bpy.data.objects["07-walk"]
    assert amc.animation_data.action.name == name
    assert bpy.data.actions["07_01"].users >= 1  # the replaced walk is kept (NLA stash)
