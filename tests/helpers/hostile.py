"""A clip library folder with hostile entries beside real takes, for the tests of which files are opened."""

import os
import pathlib
import shutil

BVH = pathlib.Path(__file__).resolve().parents[1] / "data" / "bvh"
HOSTILE = ("x.bvh", "z.bvh", "d.bvh", "l.bvh")


def hostile_library(folder, real):
    """``folder`` (made) with the CMU takes ``real`` (names in tests/data/bvh), a FIFO x.bvh, a link to /dev/zero
    z.bvh, a dangling link d.bvh and a link to itself l.bvh; returns the folder."""
    folder = pathlib.Path(folder)
    folder.mkdir()
    for name in real:
        shutil.copy(BVH / f"{name}.bvh", folder / f"{name}.bvh")
    os.mkfifo(folder / "x.bvh")
    os.symlink("/dev/zero", folder / "z.bvh")
    os.symlink(folder / "nowhere.bvh", folder / "d.bvh")
    os.symlink("l.bvh", folder / "l.bvh")
    return folder


ROOT = pathlib.Path(__file__).resolve().parents[2]

# runs the command line in a process of its own and prints, last, the largest resident size (KiB) that process or
# any of its waited-for descendants reached (getrusage of the children of this wrapper)
_MEASURED = (
    "import resource, subprocess, sys; p = subprocess.run(sys.argv[1:]); "
    "print('\\nMAXRSS', resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss, p.returncode)"
)


def run_cli(args, tmpdir, env=None, timeout=600, **kw):
    """``python -m blender_shapesig ARGS`` with ``TMPDIR=tmpdir`` (so every temp folder it or its children make is
    seen); returns (returncode, stdout, stderr, max_rss_mb) where max_rss_mb is the largest resident size of the
    command line or any of its children (MB)."""
    import subprocess
    import sys

    environ = dict(os.environ, TMPDIR=str(tmpdir), PYTHONPATH=str(ROOT), **(env or {}))
    p = subprocess.run([sys.executable, "-c", _MEASURED, sys.executable, "-m", "blender_shapesig", *map(str, args)],
                       cwd=str(ROOT), env=environ, capture_output=True, timeout=timeout, **kw)
    out = p.stdout.decode("utf-8", "surrogateescape")
    body, _, last = out.rstrip("\n").rpartition("\nMAXRSS ")
    rss_kib, code = last.split()
    return int(code), body.lstrip("\n"), p.stderr.decode("utf-8", "surrogateescape"), int(rss_kib) / 1024.0


def left_in(tmpdir):
    """What a run left in its temp folder (names)."""
    return sorted(os.listdir(tmpdir))


MAKE_BLEND = r"""
import sys
import bpy
sys.path.insert(0, sys.argv[-4])
import blender_shapesig
blender_shapesig.register()
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.shapesig.import_acclaim(filepath=sys.argv[-3], asf_path=sys.argv[-2])
arm = [o for o in bpy.data.objects if o.type == "ARMATURE"][0]
arm.animation_data.action.use_fake_user = True
bpy.ops.wm.save_as_mainfile(filepath=sys.argv[-1], compress=False)
"""


def make_blend(path, take="09_02", skeleton="09-run"):
    """A .blend holding the CMU take ``take`` (tests/data/acclaim) on its armature, written by Blender."""
    import subprocess
    import sys

    acc = ROOT / "tests" / "data" / "acclaim"
    p = subprocess.run([sys.executable, "-c", MAKE_BLEND, str(ROOT), str(acc / f"{take}.amc"),
                        str(acc / f"{skeleton}.asf"), str(path)], cwd=str(ROOT), capture_output=True)
    assert p.returncode == 0 and os.path.isfile(path), p.stderr.decode(errors="replace")[-2000:]
    return pathlib.Path(path)


MAKE_GLTF = r"""
import sys
import bpy
bvh, out, fmt = sys.argv[-3:]
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_anim.bvh(filepath=bvh, rotate_mode="NATIVE", frame_start=1, use_fps_scale=False,
                        update_scene_fps=True, update_scene_duration=True)
scene = bpy.context.scene
scene.frame_start, scene.frame_end = 1, 40
bpy.ops.export_scene.gltf(filepath=out, export_format=fmt, export_animation_mode="ACTIONS",
                          export_force_sampling=True, export_frame_range=True)
"""


def make_gltf(path, fmt="GLTF_SEPARATE", take="09_02"):
    """A glTF of the first 40 frames of the CMU take ``take`` written by Blender's exporter (``fmt``:
    GLTF_SEPARATE, a .gltf with its .bin beside it, or GLB)."""
    import subprocess
    import sys

    p = subprocess.run([sys.executable, "-c", MAKE_GLTF, str(BVH / f"{take}.bvh"), str(path), fmt], cwd=str(ROOT),
                       capture_output=True)
    assert p.returncode == 0 and os.path.isfile(path), p.stderr.decode(errors="replace")[-2000:]
    return pathlib.Path(path)


def fbx_bomb(path, values=60_000_000, version=7400):
    """A binary FBX whose one node holds a zlib-compressed array of ``values`` zero doubles (480 MB unpacked for
    the default, under 1 MB on disk): every record's lengths are right, so only a budget refuses it."""
    import struct
    import zlib

    comp = zlib.compressobj(9)
    chunk = bytes(1 << 20)
    packed = []
    left = values * 8
    while left:
        n = min(left, len(chunk))
        packed.append(comp.compress(chunk[:n]))
        left -= n
    packed.append(comp.flush())
    packed = b"".join(packed)
    prop = b"d" + struct.pack("<III", values, 1, len(packed)) + packed
    name = b"KeyValueFloat"
    head = 27
    rec_end = head + 13 + len(name) + len(prop)
    record = struct.pack("<IIIB", rec_end, 1, len(prop), len(name)) + name + prop
    data = b"Kaydara FBX Binary  \x00\x1a\x00" + struct.pack("<I", version) + record + bytes(13) + bytes(160)
    pathlib.Path(path).write_bytes(data)
    return pathlib.Path(path)
