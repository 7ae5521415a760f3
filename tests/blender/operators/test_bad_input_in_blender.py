"""Bad input in Blender: fuzzed BVH and .blend readers, degenerate actions through the operators,
no data loss (source F-curve buffers bit-identical, nothing created on errors, one undo step), corrupt caches.

The BVH and .blend fuzz here is small (a few hypothesis examples); ``tools/fuzz_readers.py`` runs the long
one in worker processes that survive a crash of Blender.
"""

import hashlib
import importlib.util
import os
import pathlib
import random
import re
import struct

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

bpy = pytest.importorskip("bpy")

from blender_shapesig import compat  # noqa: E402
from blender_shapesig.actions import action_io  # noqa: E402
from blender_shapesig.search import library as search_library  # noqa: E402
from blender_shapesig.core.io.sources import read  # noqa: E402
from blender_shapesig.readers.bvh import import_bvh  # noqa: E402
from blender_shapesig.core.clip.clip import Clip  # noqa: E402
from blender_shapesig.core.errors import ParseError  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[3]
DATA = ROOT / "tests" / "data"
ACC = DATA / "acclaim"

_spec = importlib.util.spec_from_file_location("fuzz_readers", ROOT / "tools" / "fuzz_readers.py")
fz = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(fz)

COLLECTIONS = ("actions", "objects", "armatures", "meshes", "collections", "scenes", "materials", "libraries")


def snapshot():
    """Every data-block of the collections above, by pointer (catches a new block with a reused name)."""
    return {c: {i.as_pointer() for i in getattr(bpy.data, c)} for c in COLLECTIONS}


def buffer_hash(action):
    """SHA-1 of the action's F-curves: path, index, and the co / handle buffers read with foreach_get."""
    h = hashlib.sha1()
    for fc in sorted(compat.all_action_fcurves(action), key=lambda f: (f.data_path, f.array_index)):
        kp = fc.keyframe_points
        h.update(f"{fc.data_path}[{fc.array_index}]:{len(kp)}".encode())
        for attr in ("co", "handle_left", "handle_right"):
            buf = np.empty(2 * len(kp), dtype=np.float32)
            kp.foreach_get(attr, buf)
            h.update(buf.tobytes())
    return h.hexdigest()


def all_hashes():
    return {a.name: buffer_hash(a) for a in bpy.data.actions}


def op_error(op, **kw):
    """Run the operator (EXEC_DEFAULT); it must fail with one ERROR report, or be refused by its poll with a
    message (``poll_message_set``, never Blender's generic "context is incorrect"): returns the message."""
    with pytest.raises(RuntimeError) as info:
        op("EXEC_DEFAULT", **kw)
    msg = str(info.value).strip()
    refused = msg.startswith("Operator bpy.ops.") and ".poll() " in msg and "context is incorrect" not in msg
    assert (msg.startswith("Error:") or refused) and "\n" not in msg, msg
    assert "Traceback" not in msg
    return msg


# ------------------------------------------------------------------------------------------- BVH fuzz


def _short_bvh(path, frames):
    text = path.read_text()
    lines = text.split("\n")
    m = lines.index("MOTION")
    head = lines[:m + 1] + [f"Frames: {frames}", lines[m + 2]]
    return ("\n".join(head + lines[m + 3:m + 3 + frames]) + "\n").encode()


BVH = _short_bvh(DATA / "bvh" / "09_03.bvh", 12)


@pytest.fixture(scope="module")
def bvh_original(tmp_path_factory):
    path = tmp_path_factory.mktemp("bvh") / "short.bvh"
    path.write_bytes(BVH)
    return import_bvh(path)


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture,
                                                                  HealthCheck.too_slow])
@given(kind=st.sampled_from(fz.KINDS), seed=st.integers(0, 2 ** 32 - 1))
def test_bvh_fuzz_few_cases(empty_file, tmp_path, bvh_original, kind, seed):
    path = tmp_path / f"case_{kind}.bvh"
    path.write_bytes(fz.mutate(BVH, kind, random.Random(seed), "bvh"))
    before = snapshot()
    expected = bvh_original.rotations if kind in fz.PRESERVING else None
    outcome, detail = fz.run_case(lambda: import_bvh(path), expected, timeout=60)
    assert outcome in ("ok", "error"), f"{kind}: {detail}"
    assert snapshot() == before  # the importer's armature, action and scene are removed either way


@pytest.mark.parametrize("encoding", ["bom", "utf16", "utf16_be", "latin1_name", "crlf", "tabs"])
def test_bvh_encodings_and_layouts(empty_file, tmp_path, bvh_original, encoding):
    path = tmp_path / "enc.bvh"
    path.write_bytes(fz.mutate(BVH, encoding, random.Random(3), "bvh"))
    clip = import_bvh(path)
    assert clip.source == str(path) and clip.name == "enc"
    np.testing.assert_allclose(clip.rotations, bvh_original.rotations, atol=1e-12)
    if encoding == "latin1_name":
        assert any(b.endswith("éß") for b in clip.bones)
    else:
        assert clip.bones == bvh_original.bones


def _motion_value(data, value):
    """The BVH with the first number of its first motion line replaced by ``value``."""
    head, _, rest = data.partition(b"Frame Time:")
    time_line, _, frames = rest.partition(b"\n")
    first = frames.split(b" ", 1)
    return head + b"Frame Time:" + time_line + b"\n" + value + b" " + first[1]


def test_bvh_structural_errors_are_one_line(empty_file, tmp_path):
    cases = {
        "nan_offset": (BVH.replace(b"OFFSET 0 0 0", b"OFFSET nan 0 0", 1), None),
        "no_end_site_name": (BVH.replace(b"End Site", b"End", 1), None),
        # the frame cap (core.io.files), read from the header before the motion is parsed
        "huge_frames": (BVH.replace(b"Frames: 12", b"Frames: 99999999999"), "over the 1,000,000-frame limit"),
        "zero_time": (BVH.replace(b"Frame Time:", b"Frame Time: 0 #"), "Frame Time"),
        "utf16_no_bom": (BVH.decode().encode("utf-16-le"), None),
        "inf_offset": (BVH.replace(b"OFFSET 0 0 0", b"OFFSET 0 Infinity 0", 1), "is not a finite number"),
        "huge_position": (_motion_value(BVH, b"1e300"), "too large for Blender"),
        "huge_float32": (_motion_value(BVH, b"3.5e38"), "too large for Blender"),
    }
    before = snapshot()
    for name, (data, needle) in cases.items():
        path = tmp_path / f"{name}.bvh"
        path.write_bytes(data)
        outcome, detail = fz.run_case(lambda: import_bvh(path))
        assert outcome in ("ok", "error"), f"{name}: {detail}"
        if needle:
            assert outcome == "error" and needle in detail, (name, detail)
    assert snapshot() == before


# ------------------------------------------------------------------------------------- .blend readers


@pytest.fixture
def rig(empty_file):
    """The 09_02 run imported by the add-on: armature '09-run' (active) with action '09_02'."""
    bpy.ops.shapesig.import_acclaim("EXEC_DEFAULT", filepath=str(ACC / "09_02.amc"),
                                    asf_path=str(ACC / "09-run.asf"))
    arm = bpy.context.view_layer.objects.active
    assert arm.type == "ARMATURE" and arm.animation_data.action.name == "09_02"
    return arm


def _blocks(data):
    """(offset, code, offset of the size field, size format, offset of the struct index, offset of the count,
    struct index) of each block of an uncompressed .blend with
    8-byte pointers: 4.3+ (BLENDER17-01v0500, 32-byte headers, int64 sizes) or older (BLENDER-v402, 24 bytes,
    int32 sizes)."""
    if data.startswith(b"BLENDER17-01v"):
        pos, fmt, size_at, size_fmt, sdna_at, nr_at = 17, "<4siQqq", 16, "<q", 4, 24
    else:
        assert data.startswith(b"BLENDER-v")
        pos, fmt, size_at, size_fmt, sdna_at, nr_at = 12, "<4siQii", 4, "<i", 16, 20
    hsize, out = struct.calcsize(fmt), []
    while True:
        fields = struct.unpack(fmt, data[pos:pos + hsize])
        code, length = fields[0], fields[3] if size_at == 16 else fields[1]
        sdna = fields[1] if size_at == 16 else fields[3]
        out.append((pos, code, pos + size_at, size_fmt, pos + sdna_at, pos + nr_at, sdna))
        if code == b"ENDB":
            return out
        pos += hsize + length


def test_corrupt_blend_files_are_parse_errors_not_crashes(rig, tmp_path):
    good = tmp_path / "good.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(good), copy=True, compress=False)
    data = good.read_bytes()
    assert [c.name for c in read(good)] == ["09_02"]
    compressed = tmp_path / "z.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(compressed), copy=True, compress=True)
    cases = {"truncated": data[: len(data) // 2], "empty": b"", "magic": b"NOTBLEND" + data[8:],
             "garbage": bytes(random.Random(1).randrange(256) for _ in range(5000)),
             "zstd_truncated": compressed.read_bytes()[:20000], "amc": (ACC / "09_02.amc").read_bytes()}
    # a block whose size field is absurd: Blender's reader would abort the process (failed allocation)
    _pos, _code, at, size_fmt, _s, _n, _i = next(b for b in _blocks(data) if b[1] == b"DATA")
    n = struct.calcsize(size_fmt)
    huge = (1 << 60) if n == 8 else (1 << 31) - 1
    cases["huge_block"] = data[:at] + struct.pack(size_fmt, huge) + data[at + n:]
    cases["negative_block"] = data[:at] + struct.pack(size_fmt, -5) + data[at + n:]
    # a struct definition in the DNA block pointing at a type that does not exist: Blender would crash
    strc = data.index(b"STRC", next(b[0] for b in _blocks(data) if b[1] == b"DNA1"))
    cases["damaged_dna"] = data[:strc + 12] + struct.pack("<h", 32000) + data[strc + 14:]
    # a block of structs naming a struct definition that does not exist, or holding fewer bytes than its count
    typed = next(b for b in _blocks(data) if b[6] > 0 and b[1] == b"DATA")
    cases["bad_struct_index"] = data[:typed[4]] + struct.pack("<i", -2 ** 31 + 51) + data[typed[4] + 4:]
    cnt_fmt = "<q" if typed[3] == "<q" else "<i"
    cases["short_struct_block"] = (data[:typed[5]] + struct.pack(cnt_fmt, 10 ** 6)
                                   + data[typed[5] + struct.calcsize(cnt_fmt):])
    # invalid UTF-8 in names (bone, pose channel, F-curve paths): bpy raises UnicodeDecodeError on them
    cases["bad_utf8_names"] = data.replace(b"lfemur", b"lfem\xbar")
    before = snapshot()
    for name, blob in cases.items():
        path = tmp_path / f"{name}.blend"
        path.write_bytes(blob)
        with pytest.raises(ParseError) as info:
            read(path)
        assert str(info.value).startswith(str(path)) and "\n" not in str(info.value), name
        assert ".blend" in str(info.value) or "compressed" in str(info.value), (name, str(info.value))
        expected = {"damaged_dna": "damaged DNA block", "bad_utf8_names": "not valid UTF-8",
                    "bad_struct_index": "names struct definition", "short_struct_block": "structs of"}
        if name in expected:
            assert expected[name] in str(info.value), (name, str(info.value))
    assert snapshot() == before
    assert snapshot() == before and [c.name for c in read(compressed)] == ["09_02"]


def test_damaged_mode_property_is_ignored(rig):
    action = rig.animation_data.action
    clip = action_io.read_action(action, armature=None)
    for junk in (42, "XYZ", [1, 2]):
        action["shapesig_rotation_modes"] = junk
        again = action_io.read_action(action, armature=None)
        np.testing.assert_array_equal(again.rotations, clip.rotations)


# ----------------------------------------------------------------------------- degenerate actions: blend


def _write(arm, clip, name):
    return action_io.write_action(clip, armature=arm, name=name, fake_user=True)


def _source(arm):
    return action_io.read_action(bpy.data.actions["09_02"], armature=arm, exclude_unkeyed=True)


def _make_degenerate(arm, case):
    """Add the case's action 'B' (and set up the scene); returns the expected message fragment."""
    src = _source(arm)
    if case == "one_frame":
        _write(arm, src.crop(src.frame_start, src.frame_start), "B")
        return "needs at least two frames"
    if case == "nan_keys":
        act = _write(arm, src, "B")
        fc = next(f for f in compat.all_action_fcurves(act) if "rotation" in f.data_path)
        co = np.empty(2 * len(fc.keyframe_points), dtype=np.float32)
        fc.keyframe_points.foreach_get("co", co)
        co[11] = np.nan
        fc.keyframe_points.foreach_set("co", co)
        return "NaN"
    if case == "inf_keys":
        act = _write(arm, src, "B")
        fc = next(f for f in compat.all_action_fcurves(act) if "rotation" in f.data_path)
        co = np.empty(2 * len(fc.keyframe_points), dtype=np.float32)
        fc.keyframe_points.foreach_get("co", co)
        co[1::2] = np.inf
        fc.keyframe_points.foreach_set("co", co)
        return "infinite"
    if case == "no_rotation_channels":
        act = bpy.data.actions.new("B")
        act.use_fake_user = True
        bag, _slot = compat.ensure_channelbag(act, "OBJECT", name=arm.name)
        fc = compat.new_fcurve(bag, 'pose.bones["root"].location', 0, "root")
        fc.keyframe_points.add(3)
        fc.keyframe_points.foreach_set("co", np.array([1, 0, 2, 1, 3, 0], dtype=np.float32))
        return "no rotation channels"
    if case == "no_shared_bones":
        half = len(src.bones) // 2
        _write(arm, src.select(src.bones[half:]), "B")
        act_a = _write(arm, src.select(src.bones[:half]), "A")
        act_a.name = "A"
        return "share no bones"
    if case == "object_action":
        # an action of a non-armature object (object location keys): no pose bones
        mesh = bpy.data.objects.new("Empty", None)
        bpy.context.collection.objects.link(mesh)
        mesh.keyframe_insert("location", frame=1)
        mesh.location.x = 2.0
        mesh.keyframe_insert("location", frame=10)
        mesh.animation_data.action.name = "B"
        return "no rotation channels"
    raise AssertionError(case)


DEGENERATE = ("one_frame", "nan_keys", "inf_keys", "no_rotation_channels", "no_shared_bones", "object_action")


@pytest.mark.parametrize("case", DEGENERATE)
def test_blend_actions_degenerate_input_reports_and_creates_nothing(rig, case):
    needle = _make_degenerate(rig, case)
    a = "A" if case == "no_shared_bones" else "09_02"
    bpy.context.view_layer.objects.active = rig
    before, hashes = snapshot(), all_hashes()
    msg = op_error(bpy.ops.shapesig.blend_actions, action_a=a, action_b="B", inbetweens=3)
    assert needle in msg, msg
    assert snapshot() == before and all_hashes() == hashes
    assert rig.animation_data.action.name == "09_02"


def test_blend_actions_bad_arguments(rig):
    mesh = bpy.data.objects.new("Empty", None)
    bpy.context.collection.objects.link(mesh)
    _write(rig, _source(rig).crop(1, 40), "B")
    before, hashes = snapshot(), all_hashes()
    op = bpy.ops.shapesig.blend_actions
    assert "same action" in op_error(op, action_a="09_02", action_b="09_02")
    assert "no action named 'nope'" in op_error(op, action_a="09_02", action_b="nope")
    assert "choose two actions" in op_error(op, action_a="", action_b="B")
    assert "bone list is empty" in op_error(op, action_a="09_02", action_b="B", bone_subset="LIST",
                                            bone_list=" , ")
    assert "not animated in both" in op_error(op, action_a="09_02", action_b="B", bone_subset="LIST",
                                              bone_list="root, nosuchbone")
    bpy.context.view_layer.objects.active = mesh
    assert "must be an armature" in op_error(op, action_a="09_02", action_b="B").lower()
    bpy.context.view_layer.objects.active = None
    assert "must be an armature" in op_error(op, action_a="09_02", action_b="B").lower()
    assert snapshot() == before and all_hashes() == hashes


@pytest.mark.parametrize("case", ["two_frames", "constant", "long_10000"])
def test_blend_actions_degenerate_but_valid_input(rig, case):
    src = _source(rig)
    if case == "two_frames":
        clip = src.crop(src.frame_start, src.frame_start + 1)
    elif case == "constant":
        clip = Clip(name="B", bones=src.bones, rotations=np.repeat(src.rotations[7:8], 60, axis=0),
                    root_translation=np.repeat(src.root_translation[7:8], 60, axis=0), root_bone=src.root_bone,
                    rotation_modes=src.rotation_modes)
    else:
        # a 10,000-frame action (the 130-frame run repeated): blended without the DP alignment
        reps = -(-10000 // src.frames)
        clip = Clip(name="B", bones=src.bones, rotations=np.concatenate([src.rotations] * reps)[:10000],
                    root_bone=src.root_bone, rotation_modes=src.rotation_modes)
    _write(rig, clip, "B")
    bpy.context.view_layer.objects.active = rig
    hashes = all_hashes()
    names_before = {a.name for a in bpy.data.actions}
    bpy.ops.ed.undo_push(message="before blend")
    long = case != "constant"  # B lasts under 1/8 (two frames) or over 8 times (10,000 frames) as long as A
    if long:  # refused in one line unless asked (Allow Long), creating nothing
        assert "more than 8" in op_error(bpy.ops.shapesig.blend_actions, action_a="09_02", action_b="B",
                                         weight=0.5, align=(case != "long_10000"), assign=True)
        assert {a.name for a in bpy.data.actions} == names_before and all_hashes() == hashes
    result = bpy.ops.shapesig.blend_actions("EXEC_DEFAULT", True, action_a="09_02", action_b="B",
                                            weight=0.5, align=(case != "long_10000"), assign=True, allow_long=long)
    assert result == {"FINISHED"}
    new = {a.name for a in bpy.data.actions} - names_before
    assert len(new) == 1
    out = action_io.read_action(bpy.data.actions[new.pop()], armature=rig)
    assert fz.check_clip(out) is None
    assert {a: h for a, h in all_hashes().items() if a in hashes} == hashes
    bpy.ops.ed.undo()
    assert {a.name for a in bpy.data.actions} == names_before
    assert all_hashes() == hashes
    arm = bpy.data.objects["09-run"]
    assert arm.animation_data.action.name == "09_02"  # the assignment is undone in the same step


# ------------------------------------------------------------------------------- import_acclaim operator


def test_import_acclaim_bad_files_create_nothing(empty_file, tmp_path):
    asf = (ACC / "09-run.asf").read_bytes()
    amc = (ACC / "09_02.amc").read_bytes()
    lines = amc.split(b"\n")
    cases = {
        "truncated_amc": (asf, amc[: len(amc) // 3], "truncated file?"),
        "nan_amc": (asf, re.sub(rb"\nlfemur \S+", b"\nlfemur nan", amc, count=1), "not a finite number"),
        "empty_asf": (b"", amc, "empty ASF file"),
        "binary_asf": (bytes(range(256)), amc, "skel.asf"),
        "no_frames": (asf, b"\n".join(lines[:3]), "no frames"),
        "tiny_unit": (asf.replace(b"length 0.45", b"length 1e-320"), amc, "units length must be a positive number"),
        "huge_bone": (asf[:asf.index(b":bonedata")] + re.sub(rb"length [0-9.]+", b"length 1e300",
                                                              asf[asf.index(b":bonedata"):], count=3),
                      amc, "too large for Blender"),
        "huge_root_motion": (asf, re.sub(rb"\nroot \S+", b"\nroot 1e300", amc, count=1), "too large for keyframes"),
    }
    for name, (a, m, needle) in cases.items():
        folder = tmp_path / name
        folder.mkdir()
        (folder / "skel.asf").write_bytes(a)
        (folder / "take.amc").write_bytes(m)
        before = snapshot()
        if needle is None:  # may be refused or imported, but never with non-finite keys
            try:
                bpy.ops.shapesig.import_acclaim("EXEC_DEFAULT", filepath=str(folder / "take.amc"))
            except RuntimeError as exc:
                assert "\n" not in str(exc).strip() and snapshot() == before
                continue
            for act in bpy.data.actions:
                for fc in compat.all_action_fcurves(act):
                    co = np.empty(2 * len(fc.keyframe_points), dtype=np.float32)
                    fc.keyframe_points.foreach_get("co", co)
                    assert np.all(np.isfinite(co)), (name, fc.data_path)
            for b in bpy.data.armatures[0].bones:
                assert np.all(np.isfinite(np.array(b.matrix_local))), (name, b.name)
            continue
        msg = op_error(bpy.ops.shapesig.import_acclaim, filepath=str(folder / "take.amc"))
        assert needle in msg, (name, msg)
        assert snapshot() == before, name
    before = snapshot()
    assert "no such file" in op_error(bpy.ops.shapesig.import_acclaim, filepath=str(tmp_path / "nope.amc"))
    assert "not an .asf or .amc" in op_error(bpy.ops.shapesig.import_acclaim, filepath=str(tmp_path / "x.bvh"))
    assert snapshot() == before


def test_import_acclaim_undoes_in_one_step(empty_file):
    bpy.ops.ed.undo_push(message="empty")
    before = {c: {i.name for i in getattr(bpy.data, c)} for c in COLLECTIONS}
    bpy.ops.shapesig.import_acclaim("EXEC_DEFAULT", True, filepath=str(ACC / "09_02.amc"),
                                    asf_path=str(ACC / "09-run.asf"))
    assert "09_02" in bpy.data.actions and "09-run" in bpy.data.objects
    bpy.ops.ed.undo()
    assert {c: {i.name for i in getattr(bpy.data, c)} for c in COLLECTIONS} == before


# ---------------------------------------------------------------------------- build_index / rank, cache


@pytest.fixture
def library(rig, tmp_path, monkeypatch):
    """The run '09_02' as query plus three cropped / constant / two-frame actions; cache in tmp_path."""
    monkeypatch.setenv("SHAPESIG_CACHE_DIR", str(tmp_path / "cache"))
    src = _source(rig)
    _write(rig, src.crop(20, 90), "part")
    _write(rig, src.crop(src.frame_start, src.frame_start + 1), "two")
    _write(rig, Clip(name="const", bones=src.bones, rotations=np.repeat(src.rotations[3:4], 30, axis=0),
                     rotation_modes=src.rotation_modes), "const")
    bpy.context.view_layer.objects.active = rig
    return tmp_path / "cache"


def test_rank_with_degenerate_library_actions(library, rig):
    before, hashes = snapshot(), all_hashes()
    assert bpy.ops.shapesig.build_index("EXEC_DEFAULT") == {"FINISHED"}
    assert bpy.ops.shapesig.rank("EXEC_DEFAULT") == {"FINISHED"}
    s = bpy.context.scene.shapesig
    rows = {r.name: r.distance for r in bpy.context.window_manager.shapesig_results.results}
    assert {"part", "two", "const"} <= set(rows)
    assert all(np.isfinite(d) for d in rows.values()), rows
    assert rows["part"] < rows["const"]
    assert snapshot() == before and all_hashes() == hashes


def test_rank_with_a_one_frame_query_reports(library, rig):
    src = _source(rig)
    _write(rig, src.crop(src.frame_start, src.frame_start), "single")
    s = bpy.context.scene.shapesig
    s.query_action = "single"
    before, hashes = snapshot(), all_hashes()
    msg = op_error(bpy.ops.shapesig.rank)
    assert "frame" in msg, msg
    s.query_action = "nope"
    assert "nope" in op_error(bpy.ops.shapesig.rank)
    assert snapshot() == before and all_hashes() == hashes


def test_rank_skips_bad_library_actions_and_refuses_a_bad_query(library, rig):
    src = _source(rig)
    _write(rig, src.crop(src.frame_start, src.frame_start), "single")
    _make_degenerate(rig, "nan_keys")  # action 'B' with a NaN key
    bpy.context.view_layer.objects.active = rig
    s = bpy.context.scene.shapesig
    before, hashes = snapshot(), all_hashes()
    assert bpy.ops.shapesig.build_index("EXEC_DEFAULT") == {"FINISHED"}
    assert "could not be read" in bpy.context.window_manager.shapesig_results.message and "\n" not in bpy.context.window_manager.shapesig_results.message
    assert bpy.ops.shapesig.rank("EXEC_DEFAULT") == {"FINISHED"}
    names = {r.name for r in bpy.context.window_manager.shapesig_results.results}
    assert "part" in names and not names & {"single", "B"}
    assert "warning" in bpy.context.window_manager.shapesig_results.message and "NaN" in bpy.context.window_manager.shapesig_results.message
    s.query_action = "B"
    assert "NaN or infinite" in op_error(bpy.ops.shapesig.rank)
    s.query_action = ""
    empty = bpy.data.objects.new("E", None)
    bpy.context.collection.objects.link(empty)
    bpy.context.view_layer.objects.active = empty
    assert "select an armature" in op_error(bpy.ops.shapesig.rank)
    assert "select an armature" in op_error(bpy.ops.shapesig.build_index)
    bpy.data.objects.remove(empty)
    assert snapshot() == before and all_hashes() == hashes


def test_corrupt_or_outdated_cache_is_discarded_and_rebuilt(library, rig):
    from blender_shapesig.core import search as search

    assert bpy.ops.shapesig.rank("EXEC_DEFAULT") == {"FINISHED"}
    first = {r.name: r.distance for r in bpy.context.window_manager.shapesig_results.results}
    files = sorted((library / "blender_shapesig-cache").glob("*.npz"))
    assert files
    for i, f in enumerate(files):  # truncate one, garbage in one, empty one ...
        blob = f.read_bytes()
        f.write_bytes([blob[: len(blob) // 2], b"garbage" * 10, b""][i % 3])
    search_library.CACHES.clear()  # a fresh session reads the damaged files
    assert bpy.ops.shapesig.rank("EXEC_DEFAULT") == {"FINISHED"}
    cache = search_library.get_cache(bpy.context)
    # the local search reads its own entries (half the files: every one damaged is discarded and rebuilt); the
    # signature entries only where it needs them
    local_files = [f for f in files if any(f == pathlib.Path(cache.local.file_for(k, key)) for k, key in cache.local._local)]
    assert local_files and cache.stats["invalid"] >= len(local_files)
    again = {r.name: r.distance for r in bpy.context.window_manager.shapesig_results.results}
    assert again.keys() == first.keys()
    for k in first:
        assert again[k] == pytest.approx(first[k], rel=1e-6, abs=1e-9)
    # an outdated format: the manifest of another version empties the cache's own folder
    (library / "blender_shapesig-cache" / "manifest.json").write_text('{"format": -1}')
    search_library.CACHES.clear()
    assert bpy.ops.shapesig.rank("EXEC_DEFAULT") == {"FINISHED"}
    manifest = (library / "blender_shapesig-cache" / "manifest.json").read_text()
    assert f'"format": {search.CACHE_FORMAT}' in manifest.replace(" ", "").replace(":", ": ")


def test_bvh_tiny_bones_still_give_rotation_matrices(empty_file, tmp_path):
    """End sites 1e-5 long: Blender's float32 rest matrices of such bones are orthogonal only to ~1e-5;
    the clip (rotations in armature axes, B P B^T) must still hold rotation matrices."""
    text = re.sub(rb"(End Site\s*\{\s*OFFSET) [^\n]*", rb"\1 0 0.00001 0.00001", BVH)
    path = tmp_path / "tiny.bvh"
    path.write_bytes(text)
    clip = import_bvh(path)
    R = clip.rotations
    assert np.abs(R @ np.swapaxes(R, -1, -2) - np.eye(3)).max() < 1e-9
    assert np.linalg.det(R).min() > 1 - 1e-9
    B = clip.meta["rest_rotations"]
    assert np.abs(B @ np.swapaxes(B, -1, -2) - np.eye(3)).max() < 1e-12


def test_import_acclaim_several_takes_one_bad_creates_nothing(empty_file, tmp_path):
    """Several AMC takes at once: a bad second take cancels the whole import (no armature, no first action)."""
    (tmp_path / "09-run.asf").write_bytes((ACC / "09-run.asf").read_bytes())
    (tmp_path / "a.amc").write_bytes((ACC / "09_02.amc").read_bytes())
    good_b = (ACC / "09_03.amc").read_bytes()
    (tmp_path / "b.amc").write_bytes(good_b[: len(good_b) // 2])
    before = snapshot()
    msg = op_error(bpy.ops.shapesig.import_acclaim, directory=str(tmp_path), filepath=str(tmp_path / "a.amc"),
                   files=[{"name": "a.amc"}, {"name": "b.amc"}])
    assert "b.amc" in msg and "truncated file?" in msg
    assert snapshot() == before
    (tmp_path / "b.amc").write_bytes(good_b)
    assert bpy.ops.shapesig.import_acclaim("EXEC_DEFAULT", directory=str(tmp_path), filepath=str(tmp_path / "a.amc"),
                                           files=[{"name": "a.amc"}, {"name": "b.amc"}]) == {"FINISHED"}
    assert {"a", "b"} <= {a.name for a in bpy.data.actions}
