"""CMU clips of tests/data imported with Blender's own BVH importer, and what the Blender tests measure on actions:
``import_bvh`` (one clip, its action renamed), ``walk_with_run`` (the walk active, the run a library action), ``buffer_hash`` (every F-curve's keyframe buffers hashed with
foreach_get), ``reopen_hashes`` (the same hashes of a saved file read in a fresh process), ``read_keyed`` (an action
read by the package, unkeyed bones left out) and ``angle`` (the largest rotation angle between two rotation arrays,
from the Frobenius distance)."""

import contextlib
import hashlib
import io
import json
import pathlib
import subprocess
import sys
import textwrap

import bpy
import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
BVH = ROOT / "tests" / "data" / "bvh"
# the six clips of the search tests: action name -> BVH file stem
CLIPS = {"walk1": "07_01", "walk2": "07_02", "walk3": "08_01", "run1": "09_02", "run2": "09_03", "jump": "13_32"}


def import_bvh(file_name, action_name, fake_user=False):
    """``file_name`` (relative to tests/data/bvh) imported at its own frames (rotation mode NATIVE, from frame 1,
    the scene's rate and length untouched); returns the new armature object, its action named ``action_name``."""
    try:
        bpy.ops.import_anim.bvh.get_rna_type()
    except (AttributeError, KeyError):
        import addon_utils

        addon_utils.enable("io_anim_bvh", default_set=False)
    with contextlib.redirect_stdout(io.StringIO()):
        bpy.ops.import_anim.bvh(filepath=str(BVH / file_name), rotate_mode="NATIVE", frame_start=1,
                                use_fps_scale=False, update_scene_fps=False, update_scene_duration=False)
    obj = bpy.context.view_layer.objects.active
    obj.animation_data.action.name = action_name
    if fake_user:
        obj.animation_data.action.use_fake_user = True
    return obj


def walk_with_run():
    """The walk 07_01's armature (active and selected, action 'walk') and the run 09_02's action 'run' (its armature
    deleted, the action kept by a fake user); returns the armature."""
    arm = import_bvh("07_01.bvh", "walk")
    other = import_bvh("09_02.bvh", "run")
    bpy.data.actions["run"].use_fake_user = True
    bpy.data.objects.remove(other)
    bpy.context.view_layer.objects.active = arm
    arm.select_set(True)
    return arm


def action_fcurves(action):
    from blender_shapesig import compat

    return list(compat.all_action_fcurves(action))


def buffer_hash(action):
    """SHA-1 over every F-curve's path, index and keyframe buffers read with foreach_get."""
    h = hashlib.sha1()
    for fc in sorted(action_fcurves(action), key=lambda f: (f.data_path, f.array_index)):
        h.update(f"{fc.data_path}[{fc.array_index}]".encode())
        kp = fc.keyframe_points
        n = len(kp)
        for attr in ("co", "handle_left", "handle_right"):
            buf = np.empty(2 * n, dtype=np.float32)
            kp.foreach_get(attr, buf)
            h.update(buf.tobytes())
        ibuf = np.empty(n, dtype=np.int32)
        kp.foreach_get("interpolation", ibuf)
        h.update(ibuf.tobytes())
    return h.hexdigest()


def angle(Ra, Rb):
    fro = np.sqrt(np.sum((Ra - Rb) ** 2, axis=(-2, -1)))
    return float((2.0 * np.arcsin(np.clip(fro / (2.0 * np.sqrt(2.0)), 0.0, 1.0))).max())


def read_keyed(name, arm, **kw):
    from blender_shapesig.actions import action_io

    return action_io.read_action(bpy.data.actions[name], armature=arm, exclude_unkeyed=True, **kw)


_REOPEN = textwrap.dedent("""
    import hashlib, json, sys
    import numpy as np
    import bpy
    sys.path.insert(0, sys.argv[2])
    bpy.ops.wm.open_mainfile(filepath=sys.argv[1])
""")


def reopen_hashes(path):
    """{action: buffer_hash} of the saved file, read in a fresh process (the same hash function)."""
    import inspect

    code = _REOPEN + inspect.getsource(action_fcurves) + inspect.getsource(buffer_hash) + \
        'print("RESULT" + json.dumps({a.name: buffer_hash(a) for a in bpy.data.actions}))\n'
    out = subprocess.run([sys.executable, "-c", code, str(path), str(ROOT)], capture_output=True, text=True,
                         timeout=300)
    line = [ln for ln in out.stdout.splitlines() if ln.startswith("RESULT")]
    assert line, out.stderr[-2000:]
    return json.loads(line[-1][len("RESULT"):])
