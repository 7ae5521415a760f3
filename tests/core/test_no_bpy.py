"""core never imports Blender: every module under blender_shapesig/core imports in a process where bpy,
mathutils and bpy_extras cannot be imported (a sys.meta_path finder refuses them)."""

import pathlib
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]

BLOCKED = ("bpy", "mathutils", "bpy_extras")

SCRIPT = r"""
import importlib, pkgutil, sys

BLOCKED = %r


class NoBlender:
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in BLOCKED:
            raise ImportError(f"{name} is blocked: core must not import Blender")
        return None


sys.meta_path.insert(0, NoBlender())
for name in BLOCKED:
    sys.modules.pop(name, None)

import blender_shapesig.core as core

names = [core.__name__]
for info in pkgutil.walk_packages(core.__path__, core.__name__ + "."):
    names.append(info.name)
failed = []
for name in names:
    try:
        importlib.import_module(name)
    except Exception as exc:  # noqa: BLE001 - reported below
        failed.append(f"{name}: {type(exc).__name__}: {exc}")
leaked = sorted(m for m in sys.modules if m.split(".")[0] in BLOCKED)
print(len(names))
if failed or leaked:
    print("\n".join(failed + [f"imported {m}" for m in leaked]), file=sys.stderr)
    sys.exit(1)
"""


def test_every_core_module_imports_without_blender():
    proc = subprocess.run([sys.executable, "-c", SCRIPT % (BLOCKED,)], cwd=str(ROOT), capture_output=True,
                          text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    # the walk found the package and its sub-packages (formats), not an empty tree
    assert int(proc.stdout.split()[-1]) >= 15, proc.stdout
