#!/usr/bin/env python
"""The same motion at 120 / 60 / 30 fps (issue 15, docs/evaluation.md "Time base"):

  .venv/bin/python tools/measure_time_base.py --data ../shared/data/cmu [--metrics sim3,elastic] [--raw]

For every walk of the shared sets (the Daz BVH walks of tools/eval_sets/cmu_large.csv against its runs, the AMC
walks of tools/eval_sets/cmu_amc.csv against its runs): the distance between the clip and its copy decimated to
60 and 30 fps (every 2nd / 4th frame; the clip is first cut to a multiple of 4 frame intervals so that all three
cover the same seconds; ``--whole``: not cut), divided by the distance from the clip to the nearest run. Distances are
``core.metrics.clip_distance`` (the package's comparison, on the time base of ``core.prepare``; ``--raw``: on
the curves as read). Prints one row per walk and the largest ratio per metric and rate; ``--json FILE`` saves
them.
"""

import argparse
import json
import os
import sys
from dataclasses import replace

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

from blender_shapesig import evaluation as ev  # noqa: E402
from blender_shapesig.core.metrics import clip_distance  # noqa: E402
from blender_shapesig.core.prepare import decimate_clip  # noqa: E402

SETS = ("cmu_large.csv", "cmu_amc.csv")


def same_span(clip, step=4):
    """The clip cut to a multiple of ``step`` frame intervals (its decimated copies then end on its last frame)."""
    n = (clip.frames - 1) // step * step + 1
    root = None if clip.root_translation is None else clip.root_translation[:n]
    return replace(clip, rotations=clip.rotations[:n], root_translation=root)


def measure(data, metrics, time_base=True, say=print, whole=False):
    rows = []
    for set_name in SETS:
        entries = ev.read_index(os.path.join(ROOT, "tools", "eval_sets", set_name))
        load = ev.entry_loader(data)
        clips = [(e.label, load(e)) for e in entries]
        runs = [c for label, c in clips if label == "run"]
        for label, clip in clips:
            if label != "walk":
                continue
            clip = clip if whole else same_span(clip)
            row = {"set": set_name, "clip": clip.name, "fps": clip.fps, "frames": clip.frames}
            for m in metrics:
                near = min(clip_distance(clip, r, m, time_base=time_base) for r in runs)
                row[m] = {"nearest_run": near}
                for step in (2, 4):
                    d = clip_distance(clip, decimate_clip(clip, step), m, time_base=time_base)
                    row[m][f"{int(round(clip.fps / step))}fps"] = d / near
            rows.append(row)
            say(f"{set_name:14s} {clip.name:8s} " + "  ".join(
                f"{m}: run {row[m]['nearest_run']:.3f} 60 fps {row[m]['60fps']:.3f} 30 fps {row[m]['30fps']:.3f}"
                for m in metrics))
    worst = {m: {r: max(row[m][r] for row in rows) for r in ("60fps", "30fps")} for m in metrics}
    return rows, worst


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", required=True, help="the shared CMU folder")
    p.add_argument("--metrics", default="sim3,elastic")
    p.add_argument("--raw", action="store_true", help="compare the curves as read (no time base)")
    p.add_argument("--whole", action="store_true",
                   help="keep every clip whole: its copies then lose up to 3 trailing frames (12-25 ms)")
    p.add_argument("--json", help="write the rows and the largest ratios to this file")
    args = p.parse_args(argv)
    metrics = [m.strip() for m in args.metrics.split(",") if m.strip()]
    rows, worst = measure(args.data, metrics, time_base=not args.raw, whole=args.whole)
    for m, w in worst.items():
        print(f"largest ratio {m}: 60 fps {w['60fps']:.3f}, 30 fps {w['30fps']:.3f} ({len(rows)} walks)")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"rows": rows, "largest": worst, "time_base": not args.raw}, fh, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
