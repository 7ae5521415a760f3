"""The session's action fingerprints (``action_changes``): every kind of edit is seen (the fingerprint is then
the action's new ``action_hash``), unchanged actions are not re-read, undo/load forget everything."""

import pathlib

import pytest

bpy = pytest.importorskip("bpy")

from blender_shapesig import compat  # noqa: E402
from blender_shapesig.actions import action_changes, action_io  # noqa: E402
from blender_shapesig.core.io.acclaim import load_acclaim  # noqa: E402

DATA = pathlib.Path(__file__).resolve().parents[2] / "data" / "acclaim"


@pytest.fixture
def rig(empty_file, line_armature):
    """An armature playing action ``played``; ``free`` is an action no object plays."""
    walk = load_acclaim(DATA / "16_15.amc", DATA / "16.asf").crop(100, 139).select(["root", "lfemur", "ltibia"])
    obj = line_armature(walk.bones)
    played = action_io.write_action(walk, armature=obj, name="played", assign=True)
    free = action_io.write_action(walk.crop(101, 130), armature=obj, name="free")
    action_changes.forget_fingerprints()
    return obj, played, free


def _count_hashes(monkeypatch):
    calls = []
    real = action_changes.read_hash

    def counting(action, *a, **k):
        calls.append(action.name)
        return real(action, *a, **k)

    monkeypatch.setattr(action_changes, "read_hash", counting)
    return calls


def _bone_curve(action, prop="rotation_quaternion", index=1):
    return next(fc for fc in compat.action_fcurves(action) if fc.data_path.endswith(prop) and fc.array_index == index)


EDITS = {
    "keyframe value": lambda a: setattr(_bone_curve(a).keyframe_points[7], "co",
                                        (_bone_curve(a).keyframe_points[7].co[0], 0.25)),
    "insert key": lambda a: _bone_curve(a).keyframe_points.insert(110.5, 0.1),
    "delete key": lambda a: _bone_curve(a).keyframe_points.remove(_bone_curve(a).keyframe_points[5]),
    "new F-curve": lambda a: compat.ensure_channelbag(a)[0].fcurves.new('pose.bones["ltibia"].scale', index=0),
    "rename bone path": lambda a: setattr(_bone_curve(a), "data_path", 'pose.bones["nobody"].rotation_quaternion'),
    "mute": lambda a: setattr(_bone_curve(a), "mute", True),
}


@pytest.mark.parametrize("edit", sorted(EDITS))
def test_every_edit_of_a_played_action_is_seen(rig, monkeypatch, edit):
    obj, played, free = rig
    before = action_changes.action_fingerprint(played)
    free_fp = action_changes.action_fingerprint(free)
    calls = _count_hashes(monkeypatch)
    assert action_changes.action_fingerprint(played) == before and calls == []  # remembered: not re-read
    EDITS[edit](played)
    action_changes.refresh_fingerprints()
    now = action_changes.action_fingerprint(played)
    assert now != before and now == action_io.read_hash(played)
    assert calls.count("played") == 1
    assert action_changes.action_fingerprint(free) == free_fp and "free" not in calls  # others not re-read
    assert "played" in [a.name for a in action_io.armature_actions(obj)] or edit == "rename bone path"


def test_new_fcurve_in_an_action_no_object_plays(rig):
    _obj, _played, free = rig
    before = action_changes.action_fingerprint(free)
    EDITS["new F-curve"](free)
    action_changes.refresh_fingerprints()  # a new click
    now = action_changes.action_fingerprint(free)
    assert now != before and now == action_io.read_hash(free)


@pytest.mark.parametrize("edit", ["keyframe value", "mute", "insert key"])
def test_other_edits_of_unplayed_actions_need_forget(rig, edit):
    _obj, _played, free = rig
    before = action_changes.action_fingerprint(free)
    EDITS[edit](free)  # Blender reports this nowhere: scripts call forget_fingerprints
    action_changes.forget_fingerprints(free)
    assert action_changes.action_fingerprint(free) == action_io.read_hash(free) != before


def test_bones_follow_the_fingerprint(rig):
    obj, played, _free = rig
    assert action_changes.action_bones(played) == {"root", "lfemur", "ltibia"}
    EDITS["rename bone path"](played)
    action_changes.refresh_fingerprints()
    assert "nobody" in action_changes.action_bones(played)


def test_load_forgets_everything(rig):
    _obj, played, _free = rig
    action_changes.action_fingerprint(played)
    assert action_changes._FINGERPRINTS
    bpy.ops.wm.read_factory_settings(use_empty=True)
    assert not action_changes._FINGERPRINTS
