"""action_io on the real bpy module: read/write in every rotation mode checked against Blender's own pose
evaluation (``frame_set`` + ``pose_bone.matrix_basis``), library actions, unkeyed and still bones, hashes,
slots/groups per Blender version."""

import pathlib

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from blender_shapesig import compat  # noqa: E402
from blender_shapesig.actions import action_hashes, action_io  # noqa: E402
from blender_shapesig.core.io.acclaim import load_acclaim  # noqa: E402
from blender_shapesig.core.errors import ShapeSigError  # noqa: E402

DATA = pathlib.Path(__file__).resolve().parents[2] / "data" / "acclaim"
MODES = ("QUATERNION", "XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX", "AXIS_ANGLE")


@pytest.fixture(scope="module")
def walk():
    """60 frames of a real CMU walk (16_15), 31 bones."""
    return load_acclaim(DATA / "16_15.amc", DATA / "16.asf").crop(100, 159)


def make_armature(bone_names, parent_of=None, name="Arm"):
    """An armature with one bone per name (each 1 unit along a different tilted axis, for non-trivial rest
    frames), linked to the scene and left in object mode."""
    ctx = bpy.context
    data = bpy.data.armatures.new(name)
    obj = bpy.data.objects.new(name, data)
    ctx.collection.objects.link(obj)
    ctx.view_layer.objects.active = obj
    bpy.ops.object.mode_set(mode="EDIT")
    rng = np.random.default_rng(7)
    for i, b in enumerate(bone_names):
        eb = data.edit_bones.new(b)
        eb.head = (float(i), 0.0, 0.0)
        d = rng.normal(size=3)
        eb.tail = tuple((np.array(eb.head) + d / np.linalg.norm(d)).tolist())
        eb.roll = float(rng.uniform(-3, 3))
        if parent_of and parent_of.get(b):
            eb.parent = data.edit_bones[parent_of[b]]
    bpy.ops.object.mode_set(mode="OBJECT")
    return obj


def pose_basis_rotations(obj, action, frames, bones):
    """Blender's own evaluation: rotation part of matrix_basis per frame and bone."""
    compat.assign_action(obj, action)
    out = np.empty((len(frames), len(bones), 3, 3))
    scene = bpy.context.scene
    for k, f in enumerate(frames):
        scene.frame_set(int(f))
        for j, b in enumerate(bones):
            out[k, j] = np.array(obj.pose.bones[b].matrix_basis.to_3x3())
    return out


@pytest.mark.parametrize("mode", MODES)
def test_write_then_blender_evaluates_the_clip(empty_file, walk, mode):
    obj = make_armature(walk.bones)
    for pb in obj.pose.bones:
        pb.rotation_mode = mode
    action = action_io.write_action(walk, armature=obj)
    assert action.use_fake_user and action.name == walk.name
    frames = range(walk.frame_start, walk.frame_end + 1)
    got = pose_basis_rotations(obj, action, frames, walk.bones)
    np.testing.assert_allclose(got, walk.rotations, atol=2e-6)  # float32 keys
    # root translation = the root bone's location
    bpy.context.scene.frame_set(walk.frame_start + 5)
    np.testing.assert_allclose(np.array(obj.pose.bones["root"].location), walk.root_translation[5], rtol=1e-6)
    # and read back: with the armature and without (modes stored on the action)
    for arm in (obj, None):
        back = action_io.read_action(action, armature=arm)
        assert back.bones == walk.bones and back.frame_start == walk.frame_start and back.frames == walk.frames
        assert back.rotation_modes == (mode,) * len(walk.bones)
        np.testing.assert_allclose(back.rotations, walk.rotations, atol=2e-6)
        np.testing.assert_allclose(back.root_translation, walk.root_translation, rtol=1e-6, atol=1e-5)
        assert back.root_bone == "root" and back.fps == walk.fps


def _key(obj, bone, prop, values, frame, interpolation=None):
    pb = obj.pose.bones[bone]
    setattr(pb, prop, values)
    pb.keyframe_insert(prop, frame=frame)


@pytest.mark.parametrize("mode", ["QUATERNION", "ZXY", "YXZ", "AXIS_ANGLE"])
def test_read_sparse_keys_matches_blender(empty_file, mode):
    """Keys every few frames with Bezier interpolation and a non-normalized quaternion: read_action samples
    through FCurve.evaluate and must match Blender's pose on every frame."""
    obj = make_armature(["a", "b"], {"b": "a"})
    rng = np.random.default_rng(3)
    prop = {"QUATERNION": "rotation_quaternion", "AXIS_ANGLE": "rotation_axis_angle"}.get(mode, "rotation_euler")
    for pb in obj.pose.bones:
        pb.rotation_mode = mode
    for f in (1, 4, 9, 13, 20):
        for b in ("a", "b"):
            if mode == "QUATERNION":
                v = rng.normal(size=4) * 1.7  # not unit: Blender normalizes
            elif mode == "AXIS_ANGLE":
                v = np.concatenate([[rng.uniform(-3, 3)], rng.normal(size=3)])
            else:
                v = rng.uniform(-2.5, 2.5, size=3)
            _key(obj, b, prop, v.tolist(), f)
    action = obj.animation_data.action
    clip = action_io.read_action(action, armature=obj)
    assert (clip.frame_start, clip.frame_end) == (1, 20)
    got = pose_basis_rotations(obj, action, range(1, 21), ["a", "b"])
    np.testing.assert_allclose(clip.rotations, got, atol=2e-6)


def test_mode_inference_without_armature(empty_file):
    obj = make_armature(["q", "e", "aa"])
    obj.pose.bones["e"].rotation_mode = "XYZ"
    obj.pose.bones["aa"].rotation_mode = "AXIS_ANGLE"
    for f in (1, 5):
        _key(obj, "q", "rotation_quaternion", (1.0, 0.1 * f, 0.0, 0.0), f)
        _key(obj, "e", "rotation_euler", (0.1 * f, 0.2, 0.3), f)
        _key(obj, "aa", "rotation_axis_angle", (0.2 * f, 0.0, 0.0, 1.0), f)
    action = obj.animation_data.action
    clip = action_io.read_action(action)  # no armature, no stored modes (keyframe_insert-made action)
    assert dict(zip(clip.bones, clip.rotation_modes)) == {"q": "QUATERNION", "e": "XYZ", "aa": "AXIS_ANGLE"}
    got = pose_basis_rotations(obj, action, range(1, 6), list(clip.bones))
    np.testing.assert_allclose(clip.rotations, got, atol=2e-6)
    # an explicit order overrides the XYZ default
    zxy = action_io.read_action(action, rotation_modes={"e": "ZXY"})
    assert zxy.rotation_modes[zxy.bones.index("e")] == "ZXY"
    assert not np.allclose(zxy.rotations[:, zxy.bones.index("e")], clip.rotations[:, clip.bones.index("e")])


def test_unkeyed_still_and_library_actions(empty_file, walk):
    clip = walk.select(["root", "lfemur", "ltibia", "lhipjoint"])  # lhipjoint never moves
    action = action_io.write_action(clip, name="lib")
    assert action.users == 1 and action.use_fake_user  # a library action: no object uses it
    obj = make_armature(["root", "lfemur", "ltibia", "lhipjoint", "extra"])
    got = action_io.read_action(action, armature=obj)
    assert got.bones == ("root", "lfemur", "ltibia", "lhipjoint", "extra")
    assert got.meta["missing_rotation_bones"] == ("extra",)
    np.testing.assert_allclose(got.rotations[:, 4], np.broadcast_to(np.eye(3), (clip.frames, 3, 3)))
    # the pose bones are QUATERNION but the action keys Euler: the Euler channels are read
    assert got.rotation_modes[:4] == clip.rotation_modes
    np.testing.assert_allclose(got.rotations[:, :4], clip.rotations, atol=2e-6)
    assert set(got.meta["still_bones"]) == {"lhipjoint", "extra"}
    assert got.meta["still_bones"] == got.still_bones()
    dropped = action_io.read_action(action, armature=obj, exclude_unkeyed=True)
    assert dropped.bones == ("root", "lfemur", "ltibia", "lhipjoint")
    sub = action_io.read_action(action, bones=["ltibia"], frame_range=(110, 119))
    assert sub.bones == ("ltibia",) and sub.frames == 10 and sub.frame_start == 110
    np.testing.assert_allclose(sub.rotations[:, 0], clip.crop(110, 119).rotations[:, 2], atol=2e-6)
    assert got.meta["rest_rotations"].shape == (5, 3, 3)


def test_write_never_touches_existing_actions(empty_file, walk):
    first = action_io.write_action(walk, name="take")
    h = action_io.action_hash(first)
    second = action_io.write_action(walk, name="take")
    assert second.name == "take.001" and first.name == "take"
    assert action_io.action_hash(first) == h
    assert action_io.action_hash(second) == h  # same data, same hash


def test_hash_changes_with_any_edit(empty_file, walk):
    action = action_io.write_action(walk.select(["root", "ltibia"]), name="h")
    h0 = action_io.action_hash(action)
    assert action_io.action_hash(action) == h0
    fc = compat.action_fcurves(action)[5]
    kp = fc.keyframe_points[10]
    edits = [
        lambda: setattr(kp, "co", (kp.co[0], kp.co[1] + 1e-3)),
        lambda: setattr(kp, "handle_left", (kp.handle_left[0], kp.handle_left[1] + 0.5)),
        lambda: setattr(kp, "interpolation", "BEZIER"),
        lambda: setattr(fc, "mute", True),
    ]
    seen = {h0}
    for edit in edits:
        edit()
        h = action_io.action_hash(action)
        assert h not in seen
        seen.add(h)


def _set_key(fc, i, **values):
    kp = fc.keyframe_points[i]
    for k, v in values.items():
        setattr(kp, k, v)


# (edit, True when the clip read must change): each applied on top of the ones before it
READ_EDITS = [
    ("handle moved (keys on every frame)", lambda fc, a: _set_key(fc, 10, handle_left=(109.5, 3.0)), False),
    ("Bezier key (keys on every frame)", lambda fc, a: _set_key(fc, 10, interpolation="BEZIER"), False),
    ("key value", lambda fc, a: _set_key(fc, 12, co=(fc.keyframe_points[12].co[0], 0.3)), True),
    ("linear extrapolation", lambda fc, a: setattr(fc, "extrapolation", "LINEAR"), True),
    ("last key Bezier, linear extrapolation", lambda fc, a: _set_key(fc, -1, interpolation="BEZIER"), True),
    ("last key's handle", lambda fc, a: _set_key(fc, -1, handle_right=(fc.keyframe_points[-1].co[0] + 1, 2.0)),
     True),
    ("constant extrapolation", lambda fc, a: setattr(fc, "extrapolation", "CONSTANT"), True),
    ("key removed", lambda fc, a: fc.keyframe_points.remove(fc.keyframe_points[20]), True),
    ("Bezier next to the gap", lambda fc, a: _set_key(fc, 19, interpolation="BEZIER"), True),
    ("handle next to the gap", lambda fc, a: _set_key(fc, 19, handle_right=(fc.keyframe_points[19].co[0] + 0.6, 1.0)),
     True),
    ("back easing next to the gap", lambda fc, a: _set_key(fc, 19, interpolation="BACK"), True),
    ("easing type", lambda fc, a: _set_key(fc, 19, easing="EASE_IN"), True),
    ("back amount", lambda fc, a: _set_key(fc, 19, back=4.0), True),
    ("noise modifier", lambda fc, a: fc.modifiers.new("NOISE"), True),
    ("noise strength", lambda fc, a: setattr(fc.modifiers[0], "strength", 3.0), True),
    ("envelope", lambda fc, a: fc.modifiers.new("ENVELOPE").control_points.add(120), True),
    # foreach_set writes the point without its RNA update, which reads the point as a whole F-Modifier (a Blender
    # bug: rna_FModifier_update on FCM_EnvelopeData reads past the point and crashed CI's 5.2 run once)
    ("envelope point", lambda fc, a: fc.modifiers[1].control_points.foreach_set("min", [-3.0]), True),
    ("manual frame range", lambda fc, a: (setattr(a, "use_frame_range", True), setattr(a, "frame_end", 130)), True),
]


def test_read_hash_changes_exactly_when_it_must(empty_file, walk):
    """read_hash against the truth it stands for, the clip read_action reads (frames beyond the keys included,
    where extrapolation acts): every edit that changes the clip changes the hash; handles and interpolation of
    keys on every frame, which the clip cannot see, do not (action_hash, the record of every edit, does)."""
    action = action_io.write_action(walk.select(["root", "ltibia"]), name="r")
    fc = next(f for f in compat.action_fcurves(action) if 'ltibia' in f.data_path and f.array_index == 1)

    def state():  # the clip over the keys' (or manual) range, and 5 frames beyond the keys at both ends
        R = [action_io.read_action(action, frame_range=rng).rotations for rng in (None, (95, 164))]
        return action_io.read_hash(action), action_io.action_hash(action), R

    h, full, R = state()
    assert action_io.read_action(action).meta["fcurve_hash"] == h
    for name, edit, clip_changes in READ_EDITS:
        edit(fc, action)
        h2, full2, R2 = state()
        assert clip_changes or full2 != full, name  # an edit the clip cannot see, but an edit
        changed = any(a.shape != b.shape or not np.array_equal(a, b) for a, b in zip(R2, R))
        assert changed == clip_changes, name
        assert (h2 != h) == clip_changes, name
        h, full, R = h2, full2, R2


def test_keys_on_integer_frames():
    def co(xs):
        return np.ravel(np.column_stack([xs, np.zeros(len(xs))])).astype(np.float32)

    curves = [co([3, 4, 5]), co([]), co([7]), co([7.5]), co([1.5, 2.5]), co([1, 2, 4]), co([1, 3, 4, 5]),
              co([-2, -1, 0]), co([0, 1, 1, 2])]
    assert action_hashes._keys_on_integer_frames(curves).tolist() == [True, True, True, False, False, False, False,
                                                                  True, False]
    assert action_hashes._keys_on_integer_frames([co([])]).tolist() == [True]


def test_euler_and_quaternion_continuity(empty_file):
    """A bone spinning 4 turns about Z: Euler Z is unwrapped (no 2 pi jumps), quaternions keep their sign."""
    from scipy.spatial.transform import Rotation

    n = 200
    angles = np.linspace(0, 8 * np.pi, n)
    R = Rotation.from_rotvec(np.outer(angles, [0.1, 0.2, 1.0]) / np.linalg.norm([0.1, 0.2, 1.0])).as_matrix()
    from blender_shapesig.core.clip.clip import Clip

    clip = Clip(name="spin", bones=("b",), rotations=R[:, None])
    for mode in ("XYZ", "ZYX", "QUATERNION", "AXIS_ANGLE"):
        action = action_io.write_action(clip, rotation_modes=mode)
        fcurves = compat.action_fcurves(action)
        vals = np.array([[k.co[1] for k in fc.keyframe_points] for fc in fcurves]).T
        steps = np.abs(np.diff(vals, axis=0)).max()
        assert steps < 0.5, (mode, steps)
        if mode == "QUATERNION":
            assert np.all(np.einsum("ij,ij->i", vals[1:], vals[:-1]) > 0)
        back = action_io.read_action(action)
        np.testing.assert_allclose(back.rotations, clip.rotations, atol=2e-6)


def test_groups_slots_and_fcurve_count(empty_file, walk):
    obj = make_armature(walk.bones)
    action = action_io.write_action(walk, armature=obj, rotation_modes="QUATERNION", assign=True)
    fcurves = compat.action_fcurves(action)
    assert len(fcurves) == 4 * len(walk.bones) + 3
    for fc in fcurves:
        assert fc.group is not None and f'pose.bones["{fc.group.name}"]' in fc.data_path
        assert len(fc.keyframe_points) == walk.frames
        assert fc.keyframe_points[0].interpolation == "LINEAR"
    groups = action.groups if not compat.is_layered(action) else compat._channelbag(action, action.slots[0]).groups
    assert sorted(g.name for g in groups) == sorted(walk.bones)
    assert obj.animation_data.action == action
    if compat.is_layered(action):
        assert len(action.slots) == 1 and obj.animation_data.action_slot == action.slots[0]
    else:
        assert not hasattr(action, "slots")


def test_armature_actions_filter(empty_file, walk):
    a = action_io.write_action(walk.select(["root", "lfemur"]), name="legs")
    b = action_io.write_action(walk.select(["head"]), name="head")
    bpy.data.actions.new("empty")
    obj = make_armature(["root", "lfemur"])
    assert {x.name for x in action_io.armature_actions()} == {"legs", "head"}
    assert [x.name for x in action_io.armature_actions(obj)] == [a.name]
    assert b.name == "head"


def test_bad_arguments(empty_file, walk):
    with pytest.raises(ShapeSigError, match="no action"):
        action_io.read_action(None)
    empty = bpy.data.actions.new("nothing")
    with pytest.raises(ShapeSigError, match="animates no pose bones"):
        action_io.read_action(empty)
    with pytest.raises(ShapeSigError, match="unknown rotation mode"):
        action_io.write_action(walk, rotation_modes="XYZW")
    n = len(bpy.data.actions)
    with pytest.raises(ShapeSigError):
        action_io.write_action(walk, rotation_modes=["XYZ"] * 3)
    assert len(bpy.data.actions) == n
    obj = make_armature(["root"])
    with pytest.raises(ShapeSigError, match="has no bone"):
        action_io.read_action(action_io.write_action(walk), armature=obj, bones=["nope"])


def test_channel_conversions_round_trip_including_gimbal_lock():
    """matrices -> channels -> matrices is the identity for every mode, for random rotations and for the
    gimbal-locked ones of each Euler order (middle angle +-90 degrees), and Euler channels match scipy's
    independent decomposition up to the Euler ambiguity (same matrix)."""
    from hypothesis import given, settings
    from hypothesis import strategies as st
    from scipy.spatial.transform import Rotation

    angle = st.floats(-np.pi, np.pi, allow_nan=False)

    @settings(max_examples=60, deadline=None)
    @given(st.lists(st.tuples(angle, angle, angle), min_size=1, max_size=6), st.sampled_from(MODES),
           st.booleans())
    def check(triples, mode, lock):
        xyz = np.array(triples)
        if lock and mode in action_io.EULER_MODES:
            xyz[:, "XYZ".index(mode[1])] = np.pi / 2 * np.sign(xyz[:, 0] + 1e-9)
            R = Rotation.from_euler(mode.lower(), xyz[:, ["XYZ".index(a) for a in mode]]).as_matrix()
        else:
            R = Rotation.from_rotvec(xyz).as_matrix()
        ch = action_io.channels_from_matrices(mode, R)
        back = action_io.matrices_from_channels(mode, ch)
        np.testing.assert_allclose(back, R, atol=1e-9)
        if mode in action_io.EULER_MODES:
            ref = Rotation.from_euler(mode.lower(), ch[:, ["XYZ".index(a) for a in mode]]).as_matrix()
            np.testing.assert_allclose(ref, R, atol=1e-9)

    check()


def test_bone_names_needing_escapes(empty_file, walk):
    from dataclasses import replace

    names = ('upper arm.L', 'we"ird\\name', "ünï cødé") + walk.bones[3:]
    clip = replace(walk, bones=names, root_bone=names[0], rotation_modes=())
    action = action_io.write_action(clip)
    back = action_io.read_action(action)
    assert back.bones == names and back.root_bone == names[0]
    np.testing.assert_allclose(back.rotations, clip.rotations, atol=2e-6)
    obj = make_armature(list(names[:3]))
    assert [a.name for a in action_io.armature_actions(obj)] == [action.name]


def test_multiple_slots(empty_file, walk):
    """4.4+: an action with two object slots; read_action reads the armature's slot, or the one asked for."""
    action = action_io.write_action(walk.select(["root", "lfemur"]), name="two")
    if not compat.is_layered(action):
        pytest.skip("slots exist from Blender 4.4")
    second = action.slots.new(id_type="OBJECT", name="Other")
    bag = compat._channelbag(action, action.slots[0])
    layer_strip = action.layers[0].strips[0]
    other = layer_strip.channelbag(second, ensure=True)
    fc = other.fcurves.new('pose.bones["ltibia"].rotation_euler', index=0)
    fc.keyframe_points.insert(1, 0.5)
    fc.keyframe_points.insert(3, 1.0)
    assert len(bag.fcurves) == 3 + 3 + 3  # root: Euler XYZ + location, lfemur: Euler XYZ
    first = action_io.read_action(action)
    assert first.bones == ("root", "lfemur")
    got = action_io.read_action(action, slot=second)
    assert got.bones == ("ltibia",) and (got.frame_start, got.frames) == (1, 3)
    np.testing.assert_allclose(got.rotations[0, 0], [[1, 0, 0], [0, np.cos(0.5), -np.sin(0.5)],
                                                     [0, np.sin(0.5), np.cos(0.5)]], atol=1e-6)
    obj = make_armature(["root", "lfemur", "ltibia"])
    obj.animation_data_create().action = action
    obj.animation_data.action_slot = second
    assert action_io.read_action(action, armature=obj, exclude_unkeyed=True).bones == ("ltibia",)


def test_compat_branches_match_the_blender_line(empty_file, walk):
    """compat detects features, never versions; this pins which branch each Blender line takes on a real clip,
    so an API change in a new Blender (5.1 and 5.2 LTS take 5.0's branches) fails here first."""
    v = bpy.app.version
    obj = make_armature(walk.bones)
    action = action_io.write_action(walk, armature=obj, rotation_modes="QUATERNION", assign=True)
    assert compat.is_layered(action) == (v >= (4, 4))
    assert hasattr(action, "fcurves") == (v < (5, 0))  # the legacy proxy is gone from 5.0 on
    bag, slot = compat.ensure_channelbag(action, "OBJECT")
    assert compat.is_layered_bag(bag) == (v >= (4, 4))
    if v < (4, 4):
        assert bag == action and slot is None
        return
    assert slot == action.slots[0] == compat.object_action_slot(obj)
    assert (slot.target_id_type, slot.identifier) == ("OBJECT", "OB" + obj.name)
    from bpy_extras import anim_utils

    assert anim_utils.action_get_channelbag_for_slot(action, slot) == bag == compat._channelbag(action, slot)
    assert compat.action_fcurves(action) == list(bag.fcurves) == compat.all_action_fcurves(action)
    assert len(bag.fcurves) == 4 * len(walk.bones) + 3
    # Reading back through the slot the armature uses gives the clip.
    back = action_io.read_action(action, armature=obj)
    np.testing.assert_allclose(back.rotations, walk.rotations, atol=2e-6)
    # 5.0+: F-curves are made with their group in one call; 4.4/4.5: made, then grouped.
    fc = compat.new_fcurve(bag, 'pose.bones["extra"].rotation_quaternion', 0, "extra")
    assert fc.group is not None and fc.group.name == "extra"
    try:
        bag.fcurves.new('pose.bones["extra"].rotation_quaternion', index=1, group_name="extra")
        takes_group_name = True
    except TypeError:
        takes_group_name = False
    assert takes_group_name == (v >= (5, 0))
