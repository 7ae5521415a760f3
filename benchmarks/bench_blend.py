"""Benchmark of time-aligned SRVT geodesic blends (core.blend and the shapesig.blend_actions operator).

Usage (from the repository root, with the bpy module):

    .venv/bin/python benchmarks/bench_blend.py [--repeat 7] [--json OUT.json]

Data: two real CMU clips from tests/data with the 31 ASF bones: A = 16_15 (walk, subject 16), its
first 400 frames; B = 07_01 (walk, subject 7, 316 frames) geodesically resampled to 400 frames. Both
are written as actions (one key per frame per channel, quaternions, root location) on a 31-bone
armature built for the run; that set-up is not timed.

Timed, each the median over ``--repeat`` runs after one warm-up, as the process CPU time
(``time.process_time``, all threads; robust when other processes share the cores) and the wall time:

* ``baseline``: read action A and write it back as a new action (``action_io`` read + write: the I/O
  floor of any operator that turns an action into a new one);
* ``operator_aligned``: ``bpy.ops.shapesig.blend_actions`` at weight 0.5 with alignment (depth 9),
  i.e. read A and B, elastic warp, blend, write the new action (the target: < 0.3 s);
* ``operator_unaligned``: the same without alignment;
* ``core_blend_aligned``: ``core.blend.blend_clips`` on the clips already read (warp included);
* ``elastic_align``: the warp alone (core.elastic).

The blend options (the operator entries above are timed with Feet: None, as before the option existed):

* ``operator_feet_lock``: the aligned operator with planted feet (the bench armature is a line of bones, so
  its rest skeleton is not a body: the figure to read is ``core_lock_feet``);
* ``operator_three``: three actions (A, B and C = 07_02 resampled to 400 frames, weights 0.5, 0.25, 0.25);
* ``operator_loop``: ``loop=True`` (cycle detection in both, one stride each, closed loop);
* ``operator_editable``: ``timing="NLA"``: the pose curve and an NLA strip with animated Strip Time;
* ``core_lock_feet``: ``core.blend.feet.lock_feet`` on the aligned core blend (ASF rest skeletons);
* ``core_three_aligned``: ``core.blend.blend_many`` of the three clips (two warps).

Ratios are against ``baseline`` in the same run, so they do not depend on the machine. Nothing is
asserted.
"""

import argparse
import json
import pathlib
import platform
import sys
import time

import numpy as np

import _common as harness  # noqa: E402  (puts the repository on sys.path)

ROOT = harness.ROOT

import bpy  # noqa: E402

import blender_shapesig  # noqa: E402
from blender_shapesig.actions import action_io  # noqa: E402
from blender_shapesig.core.io.acclaim import load_acclaim  # noqa: E402
from blender_shapesig.core.blend import blend_clips, blend_many  # noqa: E402
from blender_shapesig.core.blend.feet import lock_feet  # noqa: E402
from blender_shapesig.core.clip.clip import Clip  # noqa: E402
from blender_shapesig.core.geometry.curves import geodesic_interpolate, uniform_times  # noqa: E402
from blender_shapesig.core.elastic.elastic import elastic_align  # noqa: E402

ACC = ROOT / "tests" / "data" / "acclaim"
FRAMES = 400


def _clips():
    a = load_acclaim(str(ACC / "16_15.amc"), str(ACC / "16.asf"))
    a = a.crop(a.frame_start, a.frame_start + FRAMES - 1)
    b0 = load_acclaim(str(ACC / "07_01.amc"), str(ACC / "07-walk.asf"))
    t = uniform_times(FRAMES)
    rot = geodesic_interpolate(b0.rotations, None, t)
    src = uniform_times(b0.frames)
    root = np.stack([np.interp(t, src, b0.root_translation[:, i]) for i in range(3)], axis=1)
    b = Clip(name="walk07", bones=b0.bones, rotations=rot, fps=b0.fps, root_translation=root,
             root_bone=b0.root_bone, meta=dict(b0.meta))
    a.name = "walk16"
    c0 = load_acclaim(str(ACC / "07_02.amc"), str(ACC / "07-walk.asf"))
    src = uniform_times(c0.frames)
    c = Clip(name="walk07b", bones=c0.bones, rotations=geodesic_interpolate(c0.rotations, None, t), fps=c0.fps,
             root_translation=np.stack([np.interp(t, src, c0.root_translation[:, i]) for i in range(3)], axis=1),
             root_bone=c0.root_bone, meta=dict(c0.meta))
    return a, b, c


def _armature(bones):
    arm_data = bpy.data.armatures.new("bench")
    obj = bpy.data.objects.new("bench", arm_data)
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.view_layer.objects.active = obj
    obj.select_set(True)
    bpy.ops.object.mode_set(mode="EDIT")
    for i, name in enumerate(bones):
        eb = arm_data.edit_bones.new(name)
        eb.head = (0.1 * i, 0.0, 0.0)
        eb.tail = (0.1 * i, 0.0, 0.1)
    bpy.ops.object.mode_set(mode="OBJECT")
    for pb in obj.pose.bones:
        pb.rotation_mode = "QUATERNION"
    return obj


def _time(fn, repeat, cleanup=None):
    """Median CPU and wall seconds after one warm-up run (numba compile, caches)."""
    t = harness.timed(fn, repeat, cleanup=None if cleanup is None else (lambda _out: cleanup()))
    return {"cpu_s": t.cpu_median, "wall_s": t.wall_median}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)

    blender_shapesig.register()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    a, b, c = _clips()
    obj = _armature(a.bones)
    act_a = action_io.write_action(a, armature=obj, name="walk16")
    act_b = action_io.write_action(b, armature=obj, name="walk07")
    act_c = action_io.write_action(c, armature=obj, name="walk07b")
    keep = {act_a.name, act_b.name, act_c.name}

    def cleanup():
        ad = obj.animation_data
        for track in list(ad.nla_tracks) if ad is not None else ():
            ad.nla_tracks.remove(track)
        for act in [x for x in bpy.data.actions if x.name not in keep]:
            bpy.data.actions.remove(act)

    def baseline():
        clip = action_io.read_action(act_a, armature=obj, exclude_unkeyed=True)
        action_io.write_action(clip, armature=obj, name="copy")

    def op(align, **kw):
        kw.setdefault("feet", "NONE")
        kw.setdefault("weight", 0.5)

        def run():
            r = bpy.ops.shapesig.blend_actions(action_a="walk16", action_b="walk07", align=align, assign=False, **kw)
            assert r == {"FINISHED"}
        return run

    blended = blend_clips(a, b, 0.5)
    ra = action_io.read_action(act_a, armature=obj, exclude_unkeyed=True)
    rb = action_io.read_action(act_b, armature=obj, exclude_unkeyed=True)
    results = {
        "baseline": _time(baseline, args.repeat, cleanup),
        "operator_aligned": _time(op(True), args.repeat, cleanup),
        "operator_unaligned": _time(op(False), args.repeat, cleanup),
        "core_blend_aligned": _time(lambda: blend_clips(ra, rb, 0.5), args.repeat),
        "elastic_align": _time(lambda: elastic_align(ra.rotations, rb.rotations), args.repeat),
        "operator_feet_lock": _time(op(True, feet="LOCK"), args.repeat, cleanup),
        "operator_three": _time(op(True, weight=0.25, extra="walk07b=0.25"), args.repeat, cleanup),
        "operator_loop": _time(op(True, loop=True), args.repeat, cleanup),
        "operator_editable": _time(op(True, timing="NLA"), args.repeat, cleanup),
        "core_lock_feet": _time(lambda: lock_feet(blended, [a, b]), args.repeat),
        "core_three_aligned": _time(lambda: blend_many([a, b, c], (0.5, 0.25, 0.25)), args.repeat),
    }
    base = results["baseline"]["cpu_s"]
    for r in results.values():
        r["ratio_cpu"] = r["cpu_s"] / base
    out = {
        "frames": FRAMES,
        "bones": len(a.bones),
        "repeat": args.repeat,
        "blender": bpy.app.version_string,
        "machine": platform.machine(),
        "results": results,
        "target_s": 0.3,
        "operator_aligned_meets_target_cpu": results["operator_aligned"]["cpu_s"] < 0.3,
    }
    print(f"blend of two {FRAMES}-frame {len(a.bones)}-bone actions, Blender {bpy.app.version_string}, "
          f"median of {args.repeat}")
    print(f"{'':22s} {'cpu s':>8s} {'wall s':>8s} {'x baseline':>11s}")
    for name, r in results.items():
        print(f"{name:22s} {r['cpu_s']:8.4f} {r['wall_s']:8.4f} {r['ratio_cpu']:11.2f}")
    print(f"operator with alignment under 0.3 s (CPU): {out['operator_aligned_meets_target_cpu']}")
    if args.json:
        pathlib.Path(args.json).write_text(json.dumps(out, indent=2))
    return out


if __name__ == "__main__":
    main()
