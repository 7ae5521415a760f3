"""A clip library folder with hostile entries beside real takes, for the tests of which files are opened."""

import os
import pathlib
import shutil

BVH = pathlib.Path(__file__).resolve().parent / "data" / "bvh"
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


ROOT = pathlib.Path(__file__).resolve().parent.parent

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
