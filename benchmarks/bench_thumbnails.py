"""Pictures of the result rows: a warm Find Similar click with pictures against the same click without them (the
baseline, timed in the same run), and what the pictures cost after the click (in the timer's steps).

    .venv/bin/python benchmarks/bench_thumbnails.py [--actions 60] [--repeat 9] [--json OUT]

The file: an armature imported from tests/data/bvh/07_01.bvh and ``--actions`` actions written from the six test
BVH clips (``core.io.bvh``, every 4th frame: 30 fps), each cropped differently; Show 25. A warm click is
``bpy.ops.shapesig.rank()`` once the index is built and the pictures are in the index folder: with pictures it
starts the picture job (``thumbnails.start_job``), without them that call is replaced by nothing. The two are
interleaved and the best of ``--repeat`` compared (ratio: with / without). Then: the job run to the end after a
click whose pictures are not cached (drawn and written) and after one whose pictures are (read from the folder),
in ms per row.
"""

import argparse
import dataclasses
import os
import pathlib
import shutil
import sys
import tempfile
import time

from _common import machine, write_json

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import bpy  # noqa: E402

import blender_shapesig  # noqa: E402
from blender_shapesig.actions import action_io  # noqa: E402
from blender_shapesig.search import library, thumbnails  # noqa: E402
from blender_shapesig.core import search as index  # noqa: E402
from blender_shapesig.core.io.bvh import load_bvh  # noqa: E402
from blender_shapesig.readers.bvh import import_armature  # noqa: E402

BVH = ROOT / "tests" / "data" / "bvh"


def build(n_actions):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    arm, _ = import_armature(str(BVH / "07_01.bvh"))
    bpy.data.actions.remove(arm.animation_data.action)
    clips = [load_bvh(p) for p in sorted(BVH.glob("*.bvh"))]
    clips = [dataclasses.replace(c, rotations=c.rotations[::4], root_translation=c.root_translation[::4], fps=30.0)
             for c in clips]
    for n in range(n_actions):
        clip = clips[n % len(clips)]
        k = n // len(clips)
        a = action_io.write_action(clip.crop(2 + k % 10, clip.frame_end - k // 10), armature=arm,
                                   name=f"{clip.name}_{n:03d}")
        a.use_fake_user = True
        if n == 0:
            action_io.assign_action(arm, a)
    bpy.context.view_layer.objects.active = arm
    s = bpy.context.scene.shapesig
    s.top, s.crop_start = 25, 0
    return arm


def finish_job():
    t0 = time.perf_counter()
    job = thumbnails.current_job()
    while job is not None and not job.finished:
        job.step()
    return time.perf_counter() - t0


def best_click(repeat, with_pictures):
    real = thumbnails.start_job
    times = []
    for _ in range(repeat):
        if not with_pictures:
            thumbnails.start_job = lambda *a, **k: None
        try:
            t0 = time.perf_counter()
            bpy.ops.shapesig.rank()
            times.append(time.perf_counter() - t0)
        finally:
            thumbnails.start_job = real
        finish_job()  # outside the click: the timer's work
    return min(times)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--actions", type=int, default=60)
    ap.add_argument("--repeat", type=int, default=9)
    ap.add_argument("--json")
    args = ap.parse_args()
    folder = tempfile.mkdtemp(prefix="shapesig-thumbs-")
    os.environ[index.CACHE_ENV] = folder
    blender_shapesig.register()
    try:
        build(args.actions)
        library.CACHES.clear()
        bpy.ops.shapesig.rank()  # the index built; the pictures drawn now:
        rows = len(bpy.context.window_manager.shapesig_results.results) + 1
        drawn = finish_job()
        bpy.ops.shapesig.rank()
        cached = finish_job()
        pairs = [(best_click(1, False), best_click(1, True)) for _ in range(args.repeat)]
        without, with_ = min(p[0] for p in pairs), min(p[1] for p in pairs)
        out = {"machine": machine(), "actions": args.actions, "rows": rows,
               "warm_click_ms_without_pictures": without * 1e3, "warm_click_ms_with_pictures": with_ * 1e3,
               "ratio_with_over_without": with_ / without,
               "pictures_drawn_ms_per_row": drawn * 1e3 / rows, "pictures_cached_ms_per_row": cached * 1e3 / rows}
    finally:
        blender_shapesig.unregister()
        shutil.rmtree(folder, ignore_errors=True)
    for k, v in out.items():
        if k != "machine":
            print(f"{k}: {v:.3f}" if isinstance(v, float) else f"{k}: {v}")
    if args.json:
        write_json(args.json, out)


if __name__ == "__main__":
    main()
