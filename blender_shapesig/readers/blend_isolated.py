"""Reading a .blend clip file in a child process without bpy in this one: ``read_blend_isolated(path, action_name,
space, rig)`` runs ``_blend_file_child`` (one process per file, in its own process group, its temp folders inside
ours: ``guard.spawn``) and returns its clips, or a one-line ParseError when the child fails, crashes or takes longer
than ``BLEND_CHILD_TIMEOUT``. Imports no bpy, so a thread pool of the command line can read .blend files (bpy,
imported first in a worker thread, crashes the process at exit). See docs/dev/blender_layer.md."""

import json
import os
import subprocess
import sys

from ..core.clip.clip import Clip
from ..core.errors import ParseError
from . import _blend_file_child
from .child import child_command
from .guard import forget, guard_args, spawn, temp_folder

__all__ = ["read_blend_isolated", "BLEND_IN_PROCESS_ENV", "BLEND_CHILD_TIMEOUT"]

# "1": read .blend clip files in this process (faster by the start-up of a child; a damaged file can then crash
# this process). Default: a child process reads them (see readers._blend_file_child).
BLEND_IN_PROCESS_ENV = "SHAPESIG_BLEND_IN_PROCESS"
BLEND_CHILD_TIMEOUT = 600.0


def _child_command(args_json):
    """The command that runs _blend_file_child (``child.child_command``)."""
    return child_command(os.path.join(os.path.dirname(os.path.abspath(__file__)), "_blend_file_child.py"), args_json)


def read_blend_isolated(path, action_name=None, space="armature", rig=False):
    """``blend_file.read_blend_here`` in a child process: a .blend that crashes Blender gives a ParseError, not a
    crash (the file's structure is the caller's to check first: ``core.io.blend_file.check_blend``)."""
    package_root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    with temp_folder("blend") as tmp:
        out = os.path.join(tmp, "clips.npz")
        args = json.dumps({"path": os.path.abspath(path), "action": action_name, "space": space, "rig": rig, "out": out,
                           "package_dir": os.path.dirname(package_root),
                           "package": os.path.basename(package_root), "sys_path": [p for p in sys.path if p],
                           **guard_args()})
        try:
            proc = spawn(_child_command(args), tmp, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE)
        except OSError as exc:
            raise ParseError(f"cannot start a process to read the .blend file: {exc}", path) from None
        try:
            _out, err = proc.communicate(timeout=BLEND_CHILD_TIMEOUT)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.communicate()
            raise ParseError(f"reading the .blend file took more than {BLEND_CHILD_TIMEOUT:.0f} s", path) from None
        except BaseException:
            proc.kill()
            proc.wait()
            raise
        finally:
            forget(proc)
        if not os.path.isfile(out):
            if proc.returncode < 0 or proc.returncode > 128:
                raise ParseError("corrupt .blend file: Blender crashed reading it (damaged data)", path)
            last = [ln for ln in err.decode("utf-8", "replace").splitlines() if ln.strip()]
            raise ParseError(f"could not read the .blend file ({last[-1] if last else f'exit {proc.returncode}'})",
                             path)
        clips, error = _blend_file_child.read_result(out, Clip)
    if error is not None:
        raise ParseError(error)
    return clips
