"""The local search's action part (issue 41, ``core.search.local.action``): what it measures on features built here
with known answers (a body rising off the ground, a walk forward and the same walk backward), and that the default
recipe's key does not change while it is off."""

from dataclasses import replace

import numpy as np

from blender_shapesig.core.search.local import features as local, action as local_action

RATE = 30.0


def _features(T=61, speed=0.0, lift=0.0):
    """A still standing pose (ankles 1 leg length below the pelvis) travelling ``speed`` leg lengths per second
    along the body frame's second axis, the pelvis rising ``lift`` leg lengths in a half sine in the middle third
    (feet with it)."""
    pose = np.zeros((T, len(local.POINTS), 3))
    pose[:, local.POINTS.index("ankle.L")] = (0.2, 0.0, -1.0)
    pose[:, local.POINTS.index("ankle.R")] = (-0.2, 0.0, -1.0)
    pose[:, local.POINTS.index("shoulder.L")] = (0.26, 0.0, 0.59)
    pose[:, local.POINTS.index("shoulder.R")] = (-0.26, 0.0, 0.59)
    pose[:, local.POINTS.index("wrist.L")] = (0.26, 0.0, 0.0)
    pose[:, local.POINTS.index("wrist.R")] = (-0.26, 0.0, 0.0)
    t = np.arange(T) / RATE
    motion = np.zeros((T, 4))
    motion[:, 1] = speed * t
    third = T // 3  # standing, then a half sine up and down, then standing
    motion[third:T - third, 2] = lift * np.sin(np.pi * np.arange(T - 2 * third) / (T - 2 * third - 1))
    return {"pose": pose.reshape(T, -1), "motion": motion, "rate": np.float64(RATE)}


def test_channels_measure_travel_height_and_reach():
    c = local_action.action_channels(_features(speed=-1.5, lift=0.4))
    assert np.allclose(c[:, 1], -1.5)  # velocity in the body's frame, leg lengths per second
    assert np.allclose(c[:, :3][:, [0]], 0.0)
    assert np.isclose(c[:, 3].max(), 0.4) and np.isclose(c[:, 3].min(), 0.0)  # both feet leave the ground
    assert np.allclose(c[:, 3], c[:, 5] - c[:, 5].min())  # the pelvis rises with them
    assert np.allclose(c[:, 6], 0.0) and np.allclose(c[:, 7], -0.59)  # hands straight below the shoulders
    assert np.allclose(c[:, 8:], 0.0)  # a still pose: arms and legs do not move relative to the pelvis


def test_energy_keeps_the_windows_where_something_happens():
    f = _features(T=90)
    f["pose"][30:60] += np.sin(np.linspace(0, 6 * np.pi, 30))[:, None] * 0.2  # the action in the middle second
    starts, w = local._windows(90, RATE, 0.5, 0.125, None)
    e = local_action.window_energy(f, starts, w)
    keep = local_action.active_rows(e, 0.35)
    assert keep.any() and not keep.all()
    assert all(30 - w < s < 60 for s in starts[keep])
    assert local_action.active_rows(np.zeros(3), 0.35).all()  # a still clip keeps its windows


def test_backward_walk_is_far_from_forward_walk_only_with_the_action_part():
    fwd, back = _features(speed=-1.5), _features(speed=1.5)
    base = [local.entry_from_features(f, local.Settings(action_weight=0.0)) for f in (fwd, back)]
    act = local.Settings(action_weight=8.0)
    with_act = [local.entry_from_features(f, act) for f in (fwd, back)]
    d0 = local.first_stage(base[0], [base[1]])[0]
    d1 = local.first_stage(with_act[0], [with_act[1]])[0]
    assert d1 > d0 + 1.0  # 3 leg lengths per second apart, times TIME and the weight (projected)


def test_the_action_part_is_appended_to_the_windows():
    f = _features(speed=-1.0, lift=0.1)
    base = local.window_vectors(f, local.Settings(action_weight=0.0))
    act = local.window_vectors(f, local.Settings(action_weight=2.0))
    assert act.shape == (len(base), base.shape[1] + local_action.ACTION_PARTS)
    assert np.array_equal(act[:, :base.shape[1]], base)
    assert local.Settings(action_weight=2.0).key() != local.Settings(action_weight=0.0).key()  # stored apart
    assert local.Settings(action_weight=0.0).key() == local.DEFAULT.key()  # off by default: stored entries kept


def test_a_library_file_keeps_each_entrys_sequence_width(tmp_path):
    from blender_shapesig.core.search.local.library import open_library, write_library
    from blender_shapesig.core.search.local.store import _meta

    f = _features(speed=-1.0, lift=0.2)
    narrow = replace(local.entry_from_features(f, local.Settings(action_weight=0.0)), name="narrow")
    wide = replace(local.entry_from_features(f, local.Settings(action_weight=2.0)), name="wide")
    width = 3 * len(local.POINTS)
    assert narrow.sequence.shape[1] == width and wide.sequence.shape[1] == width + 6
    fn = tmp_path / "pack.bin"
    files = [(n, 1, 1, {"clips": [_meta(e)]}, [e]) for n, e in (("a.bvh", narrow), ("b.bvh", wide))]
    with open(fn, "wb") as fh:
        write_library(fh, files, "F")
    lib = open_library(str(fn))
    for (name, size, mtime, meta, rows), e in zip(lib.files, (narrow, wide)):
        got = lib.entry(meta["clips"][0], rows[0])
        assert np.array_equal(np.asarray(got.sequence), e.sequence)
