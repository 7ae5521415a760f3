"""Benchmark of action_io.read_action / write_action (31 bones x 400 frames).

Usage (from the repository root, with any of the bpy environments):

    .venv/bin/python benchmarks/bench_action_io.py [--repeat 15] [--json OUT.json]
    .venv-bpy-4.2/bin/python benchmarks/bench_action_io.py

Data: the first 400 frames of the real CMU walk 16_15 (tests/data/acclaim, 31 ASF bones) with its root
translation. Timed (each the median over ``--repeat`` runs after one warm-up; process CPU time, robust when
other processes share the cores, and wall time):

* ``write_quaternion`` / ``write_euler_zxy`` / ``write_axis_angle``: ``write_action`` of the clip
  (31 x 4 or 3 rotation F-curves + 3 location F-curves, 400 keys each) — target < 20 ms;
* ``read_keyed``: ``read_action`` of the quaternion action (keys on every frame: ``foreach_get`` path,
  including ``action_hash`` and the still-bone test) — target < 50 ms;
* ``read_keyed_armature``: the same with the armature given;
* ``read_sparse``: an action keyed on every 2nd frame (Bezier), sampled with ``FCurve.evaluate``;
* baselines, in the same run: ``baseline_copy`` = ``Action.copy()`` of the quaternion action (Blender's C
  duplicate of the same F-curves: a floor for making an action of this size) and ``baseline_foreach_get`` =
  one ``foreach_get('co')`` per F-curve of that action (the raw key transfer a reader cannot avoid).

Ratios are printed against the baselines so they do not depend on the machine. Nothing is asserted.
"""

import argparse
import json
import pathlib
import platform
import sys

import numpy as np

import _common as harness  # noqa: E402  (puts the repository on sys.path)

ROOT = harness.ROOT

import bpy  # noqa: E402

from blender_shapesig import compat  # noqa: E402
from blender_shapesig.actions import action_io  # noqa: E402
from blender_shapesig.core.io.acclaim import load_acclaim  # noqa: E402

ACC = ROOT / "tests" / "data" / "acclaim"


def timed(fn, repeat, cleanup=None):
    """(median CPU, median wall) seconds after one warm-up run."""
    t = harness.timed(fn, repeat, cleanup=cleanup)
    return t.cpu_median, t.wall_median


def build_armature(names):
    data = bpy.data.armatures.new("BenchArm")
    obj = bpy.data.objects.new("BenchArm", data)
    bpy.context.collection.objects.link(obj)
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.mode_set(mode="EDIT")
    for i, n in enumerate(names):
        eb = data.edit_bones.new(n)
        eb.head, eb.tail = (i, 0, 0), (i, 0, 1)
    bpy.ops.object.mode_set(mode="OBJECT")
    for pb in obj.pose.bones:
        pb.rotation_mode = "QUATERNION"
    return obj


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=15)
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)

    bpy.ops.wm.read_factory_settings(use_empty=True)
    clip = load_acclaim(ACC / "16_15.amc", ACC / "16.asf").crop(1, 400)
    assert clip.frames == 400 and len(clip.bones) == 31
    arm = build_armature(clip.bones)

    def remove(action=None):
        if action is not None:
            bpy.data.actions.remove(action)

    results = {}
    for key, mode in (("write_quaternion", "QUATERNION"), ("write_euler_zxy", "ZXY"),
                      ("write_axis_angle", "AXIS_ANGLE")):
        results[key] = timed(lambda m=mode: action_io.write_action(clip, rotation_modes=m), args.repeat, remove)

    quat = action_io.write_action(clip, rotation_modes="QUATERNION", name="bench_quat")
    results["read_keyed"] = timed(lambda: action_io.read_action(quat), args.repeat)
    results["read_keyed_armature"] = timed(lambda: action_io.read_action(quat, armature=arm), args.repeat)

    sparse = quat.copy()
    sparse.name = "bench_sparse"
    for fc in compat.action_fcurves(sparse):
        kp = fc.keyframe_points
        for i in range(len(kp) - 2, 0, -2):  # keep frames 1, 3, 5, ..., 399 and 400
            kp.remove(kp[i], fast=True)
        kp.foreach_set("interpolation", np.full(len(kp), 2, dtype=np.int32))  # BEZIER
        fc.update()
    results["read_sparse"] = timed(lambda: action_io.read_action(sparse, frame_range=(1, 400)), args.repeat)

    results["baseline_copy"] = timed(lambda: quat.copy(), args.repeat, remove)
    fcurves = compat.action_fcurves(quat)

    def transfer():
        buf = np.empty(800, dtype=np.float32)
        for fc in fcurves:
            fc.keyframe_points.foreach_get("co", buf)

    results["baseline_foreach_get"] = timed(transfer, args.repeat)

    base_w = results["baseline_copy"][0]
    base_r = results["baseline_foreach_get"][0]
    print(f"bpy {bpy.app.version_string}, python {platform.python_version()}, {len(fcurves)} F-curves x 400 keys, "
          f"median of {args.repeat}")
    print(f"{'case':24s} {'cpu ms':>8s} {'wall ms':>8s} {'/copy':>7s} {'/foreach_get':>12s}")
    for k, (c, w) in results.items():
        print(f"{k:24s} {c * 1e3:8.1f} {w * 1e3:8.1f} {c / base_w:7.2f} {c / base_r:12.2f}")
    if args.json:
        pathlib.Path(args.json).write_text(json.dumps({
            "bpy": bpy.app.version_string,
            "results_ms": {k: {"cpu": c * 1e3, "wall": w * 1e3} for k, (c, w) in results.items()},
        }, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
