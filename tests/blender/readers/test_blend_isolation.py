"""Reading .blend clip files in a child process: a file that crashes Blender gives a one-line ParseError and
leaves this process (and its file) as they were."""

import os
import pathlib
import struct
import sys

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from blender_shapesig.actions import action_io  # noqa: E402
from blender_shapesig.core.io.sources import read  # noqa: E402
from blender_shapesig.readers import blend_file as blend_reader  # noqa: E402
from blender_shapesig.readers import blend_isolated  # noqa: E402
from blender_shapesig.core.io.acclaim import load_acclaim  # noqa: E402
from blender_shapesig.core.errors import ParseError  # noqa: E402

ACC = pathlib.Path(__file__).resolve().parents[2] / "data" / "acclaim"


@pytest.fixture
def small_blend(empty_file, line_armature, tmp_path):
    """A saved file with one armature and one 30-frame action of a real walk."""
    walk = load_acclaim(ACC / "07_01.amc", ACC / "07-walk.asf").crop(1, 30).select(("root", "lfemur", "ltibia"))
    obj = line_armature(walk.bones)
    action_io.write_action(walk, armature=obj, name="walk", assign=True)
    path = tmp_path / "small.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path), compress=False)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return path, walk


def test_child_result_equals_reading_in_process(small_blend, monkeypatch):
    path, walk = small_blend
    # the readers' own output (bone_map="none": before the front door's comparison space across rigs)
    (isolated,) = read(path, bone_map="none")
    monkeypatch.setenv(blend_reader.BLEND_IN_PROCESS_ENV, "1")
    (here,) = read(path, bone_map="none")
    assert isolated.name == here.name == "walk" and isolated.bones == here.bones
    np.testing.assert_array_equal(isolated.rotations, here.rotations)
    np.testing.assert_array_equal(isolated.root_translation, here.root_translation)
    np.testing.assert_array_equal(isolated.meta["rest_rotations"], here.meta["rest_rotations"])
    assert isolated.meta["rotation_space"] == here.meta["rotation_space"] == "armature"
    assert isolated.meta["fcurve_hash"] == here.meta["fcurve_hash"] and isolated.source == here.source
    assert isolated.meta["parents"] == here.meta["parents"] and set(here.meta["parents"]) >= set(here.bones)


def test_a_crashing_reader_is_a_parse_error(small_blend, monkeypatch):
    path, _ = small_blend
    crash = "import os, signal; os.kill(os.getpid(), signal.SIGSEGV)"
    monkeypatch.setattr(blend_isolated, "_child_command", lambda args: [sys.executable, "-c", crash])
    before = {a.name for a in bpy.data.actions}, {o.name for o in bpy.data.objects}
    with pytest.raises(ParseError, match="Blender crashed reading it") as info:
        read(path)
    assert "\n" not in str(info.value) and str(path) in str(info.value)
    assert ({a.name for a in bpy.data.actions}, {o.name for o in bpy.data.objects}) == before


def _blocks(data):
    """(code, SDNA index, body offset, body size) of every block of an uncompressed 64-bit little-endian .blend."""
    assert data[:7] == b"BLENDER", data[:12]
    if data[7:9] == b"17":  # 4.3+ "BLENDER17-01v0500": code(4) SDNAnr(i4) old(Q8) len(q8) nr(q8)
        pos, fmt, len_at, sdna_at = 17, "<4siQqq", 3, 1
    else:  # "BLENDER-v402": code(4) len(i4) old(Q8) SDNAnr(i4) nr(i4)
        pos, fmt, len_at, sdna_at = 12, "<4siQii", 1, 3
    hsize = struct.calcsize(fmt)
    out = []
    while pos + hsize <= len(data):
        fields = struct.unpack_from(fmt, data, pos)
        if fields[0] == b"ENDB":
            break
        out.append((fields[0], fields[sdna_at], pos + hsize, fields[len_at], fields[2]))
        pos += hsize + fields[len_at]
    return out


def test_damaged_block_addresses_crash_the_reader_not_this_process(small_blend, tmp_path):
    """Flip the top byte of the stored address of the action's data blocks (written last in the file): the
    pointers to them dangle and Blender's reader crashes on them (as it does opening such a file in its UI).
    Each file is a one-line ParseError here, and this process and its file are untouched."""
    path, _walk = small_blend
    data = path.read_bytes()
    tail = [b for b in _blocks(data) if b[0] == b"DATA"][-20::5]
    assert len(tail) == 4
    before = {a.name for a in bpy.data.actions}, {o.name for o in bpy.data.objects}
    outcomes = []
    for i, (_code, _sdna, body, _size, _addr) in enumerate(tail):
        damaged = bytearray(data)
        damaged[body - (32 if data[7:9] == b"17" else 24) + 15] ^= 0x20  # the address' most significant byte
        p = tmp_path / f"damaged{i}.blend"
        p.write_bytes(bytes(damaged))
        try:
            got = read(p)
            assert all(np.all(np.isfinite(c.rotations)) for c in got)
            outcomes.append("clip")
        except ParseError as exc:
            assert "\n" not in str(exc)
            outcomes.append("crashed" if "Blender crashed reading it" in str(exc) else "error")
    if bpy.app.version >= (5, 0, 0):
        # Blender 5.0's reader crashes on these (4.2's tolerates them): the real crash path was taken
        assert "crashed" in outcomes, outcomes
    assert ({a.name for a in bpy.data.actions}, {o.name for o in bpy.data.objects}) == before
