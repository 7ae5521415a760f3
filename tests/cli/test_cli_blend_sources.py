"""The command line's ``blend`` with a .blend source: the source is read in the child process (never
opened in the command line's process), only the armature that owns A's action is rebuilt in the output (no text
blocks, drivers, other objects or source actions), an action no armature plays is given the armature its slot
names or refused in one line when two rigs fit it, and a damaged source is one line (exit 2), never a crash."""

import json
import random
import struct
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("bpy", reason="writing a .blend needs the bpy module")

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "tests" / "data"
BVH = DATA / "bvh" / "09_02.bvh"

_MAKE = r"""
import json, sys
import bpy
sys.path.insert(0, {root!r})
import blender_shapesig
blender_shapesig.register()
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.shapesig.import_acclaim(filepath={amc!r}, asf_path={asf!r})
arm = [o for o in bpy.data.objects if o.type == "ARMATURE"][0]
action = arm.animation_data.action
action.use_fake_user = True
kind = {kind!r}
if kind == "extras":
    text = bpy.data.texts.new("notes.py")
    text.write("print('a script of the source file')\n")
    fc = arm.driver_add("location", 0)
    fc.driver.type = "SCRIPTED"
    fc.driver.expression = "frame * 0.0"
    mesh = bpy.data.meshes.new("Prop")
    bpy.context.scene.collection.objects.link(bpy.data.objects.new("Prop", mesh))
else:  # two rigs with the same bones, the action played by neither
    arm.name = "RigA"
    other = arm.copy()
    other.data = arm.data.copy()
    other.name = "RigB"
    other.location = (5.0, 0.0, 0.0)
    bpy.context.scene.collection.objects.link(other)
    for ob in (arm, other):
        ob.animation_data.action = None
    if kind == "hinted":
        slots = [s for s in action.slots if s.target_id_type == "OBJECT"]
        slots[0].name_display = "RigB"  # what Blender names a slot made for RigB
bpy.ops.wm.save_as_mainfile(filepath={out!r}, compress=False)
"""

_INSPECT = r"""
import json, sys
import bpy
bpy.ops.wm.open_mainfile(filepath={path!r})
ids = [i for coll in (bpy.data.objects, bpy.data.armatures, bpy.data.scenes, bpy.data.meshes) for i in coll]
drivers = sum(len(i.animation_data.drivers) for i in ids if getattr(i, "animation_data", None) is not None)
arms = [o for o in bpy.data.objects if o.type == "ARMATURE"]
print("JSON" + json.dumps({{"texts": [t.name for t in bpy.data.texts], "drivers": drivers,
    "objects": sorted(o.name for o in bpy.data.objects), "meshes": len(bpy.data.meshes),
    "actions": sorted(a.name for a in bpy.data.actions),
    "location": [list(o.matrix_world.translation) for o in arms]}}))
"""


def _run_bpy(code):
    p = subprocess.run([sys.executable, "-c", code], cwd=str(ROOT), stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert p.returncode == 0, p.stderr.decode(errors="replace")[-2000:]
    return p.stdout.decode(errors="replace")


def _make(tmp_path, kind):
    out = tmp_path / f"{kind}.blend"
    _run_bpy(_MAKE.format(root=str(ROOT), amc=str(DATA / "acclaim" / "09_02.amc"),
                          asf=str(DATA / "acclaim" / "09-run.asf"), kind=kind, out=str(out)))
    return out


def _inspect(path):
    line = next(ln for ln in _run_bpy(_INSPECT.format(path=str(path))).splitlines() if ln.startswith("JSON"))
    return json.loads(line[4:])


def _blend(a, out, *extra):
    return subprocess.run([sys.executable, "-m", "blender_shapesig", "blend", str(a), str(BVH), "--weight", "0.5",
                           "--out", str(out), "--no-progress", "--json", *extra], cwd=str(ROOT),
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, timeout=600)


def _one_line_error(p):
    lines = p.stderr.decode(errors="replace").strip().splitlines()
    assert p.returncode == 2 and p.stdout == b"", (p.returncode, lines[-3:])
    ours = [ln for ln in lines if ln.startswith("blender_shapesig: error: ")]  # Blender's own log lines aside
    assert len(ours) == 1 and lines[-1] == ours[0] and not any("Traceback" in ln for ln in lines), lines
    return ours[0]


def test_output_holds_only_the_rebuilt_armature_and_the_blend(tmp_path):
    src = _make(tmp_path, "extras")
    before = _inspect(src)
    assert before["texts"] == ["notes.py"] and before["drivers"] == 1 and before["meshes"] == 1
    out = tmp_path / "out.blend"
    p = _blend(f"{src}#09_02", out)
    assert p.returncode == 0, p.stderr.decode(errors="replace")[-2000:]
    report = json.loads(p.stdout)
    after = _inspect(out)
    assert after["texts"] == [] and after["drivers"] == 0 and after["meshes"] == 0
    assert after["objects"] == ["09-run"] and after["actions"] == sorted(report["actions"])  # no source action


def test_an_unplayed_action_fitting_two_rigs_is_refused_in_one_line(tmp_path):
    src = _make(tmp_path, "two")
    out = tmp_path / "out.blend"
    line = _one_line_error(_blend(f"{src}#09_02", out))
    assert "played by no armature and fits 2 armatures (RigA, RigB)" in line
    assert not out.exists()


def test_the_slot_named_after_a_rig_decides_its_owner(tmp_path):
    src = _make(tmp_path, "hinted")
    out = tmp_path / "out.blend"
    p = _blend(f"{src}#09_02", out)
    assert p.returncode == 0, p.stderr.decode(errors="replace")[-2000:]
    after = _inspect(out)
    assert after["objects"] == ["RigB"] and after["location"][0] == pytest.approx([5.0, 0.0, 0.0])


def _block(data, code):
    """(start, length) of the data of the first block ``code`` of an uncompressed 4.3+ .blend."""
    assert data[:9] == b"BLENDER17", data[:17]
    pos = 17
    while True:
        name, _sdna, _old, length, _count = struct.unpack("<4siQqq", data[pos:pos + 32])
        if name.rstrip(b"\0") == code:
            return pos + 32, length
        assert name != b"ENDB", code
        pos += 32 + length


def test_damaged_sources_are_one_line_never_a_crash(tmp_path):
    """Bytes of the window manager (what opening the whole file reads: these four crashed the in-process reader
    of blend with SIGSEGV) and of the object block (what the child reads) overwritten: blend succeeds without
    reading the damage or says one line with exit 2."""
    data = _make(tmp_path, "extras").read_bytes()
    cases = []
    start, length = _block(data, b"WM")
    buf = bytearray(data)
    for offset, value in ((405, 250), (685, 122), (1286, 252), (1354, 229)):
        if offset < length:
            buf[start + offset] = value
    cases.append(bytes(buf))
    start, length = _block(data, b"OB")
    for seed in range(3):
        rng, buf = random.Random(seed), bytearray(data)
        for _ in range(64):
            buf[start + rng.randrange(length)] = rng.randrange(256)
        cases.append(bytes(buf))
    codes = []
    for i, case in enumerate(cases):
        src, out = tmp_path / f"bad{i}.blend", tmp_path / f"out{i}.blend"
        src.write_bytes(case)
        p = _blend(src, out)
        codes.append(p.returncode)
        if p.returncode != 0:
            _one_line_error(p)
            assert not out.exists()
    assert codes[0] == 0  # the window manager is never read
    assert 2 in codes[1:]  # a damaged object is one line
