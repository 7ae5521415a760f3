"""A glTF of a scene written by Blender's exporter in a child process (``export_glb``): the open file is saved to a
.blend, the child opens it, exports and leaves without interpreter teardown. In the process that goes on testing no
exporter state is left (Blender 4.2's bpy module crashes at teardown after a glTF export, and crashed later tests)."""

import os
import pathlib
import subprocess
import sys

import bpy

ROOT = pathlib.Path(__file__).resolve().parents[2]

_CHILD = r"""
import os, sys
import bpy
blend, out = sys.argv[-2:]
bpy.ops.wm.open_mainfile(filepath=blend)
bpy.ops.export_scene.gltf(filepath=out, export_format="GLB", export_animations=True)
sys.stdout.flush()
sys.stderr.flush()
os._exit(0 if os.path.isfile(out) else 1)
"""


def export_glb(path):
    """The open file's scene as a GLB at ``path`` (animations included), by Blender's exporter in a child."""
    path = pathlib.Path(path)
    blend = path.with_suffix(".export.blend")
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), copy=True)
    p = subprocess.run([sys.executable, "-c", _CHILD, str(blend), str(path)], cwd=str(ROOT), capture_output=True,
                       text=True, timeout=600)
    assert p.returncode == 0 and path.is_file(), p.stderr[-2000:]
    os.remove(blend)
    return path
