#!/usr/bin/env python
"""The same motion at 120 / 60 / 30 fps (issue 15, docs/model.md "Time base", docs/evaluation.md "Time base"):

  .venv/bin/python experiments/measure_time_base.py --data ../shared/data/cmu [--metrics sim3,elastic] [--raw]
      [--span] [--trim-each] [--no-rank] [--smooth SECONDS] [--json FILE]

For every walk of the shared sets (the Daz BVH walks of tools/eval_sets/cmu_large.csv against its runs, the AMC
walks of tools/eval_sets/cmu_amc.csv against its runs): the distance between the clip and its copy decimated to
60 and 30 fps (every 2nd / 4th frame from the first: a clip of N frames at 120 fps loses its last (N - 1) mod 4
frames, up to 25 ms, at 30 fps), divided by the distance from the clip to the nearest run. The bounds:
below ``BOUNDS`` (0.05 for sim^3, 0.15 for d_S*) for every walk at both rates; and the 30 fps copy, as a query,
has a walk of its set (not itself) nearer than every run ("ranks walks first"). Prints one row per walk with
PASS / SAME / FAIL (SAME: within the bounds, and the 30 fps copy ranks a run first only where the 120 fps original
does too), the largest ratio per metric and rate, and the count of walks that pass.

Distances are ``core.metrics.clip_distance`` (the package's comparison, on the time base of ``core.clip.prepare``;
``--raw``: on the curves as read). The clips are read as the evaluation reads them (rest-pose ramps trimmed at
120 fps) and decimated after; ``--trim-each``: decimated as read and each copy trimmed at its own rate (the
ramp's end is then cut at a 1/30 s resolution: see docs/model.md); ``--span``: every clip first cut to a
multiple of 4 frame intervals (no frame lost; the measure before the lattice of core.clip.prepare).
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
from blender_shapesig.core.clip import prepare  # noqa: E402
from blender_shapesig.core.clip.prepare import decimate_clip  # noqa: E402
from blender_shapesig.core.clip.trim import trim_clip  # noqa: E402

SETS = ("cmu_large.csv", "cmu_amc.csv")
BOUNDS = {"sim3": 0.05, "elastic": 0.15}  # decimated copy / nearest other class
RATES = ("60fps", "30fps")


def same_span(clip, step=4):
    """The clip cut to a multiple of ``step`` frame intervals (its decimated copies then end on its last frame)."""
    n = (clip.frames - 1) // step * step + 1
    root = None if clip.root_translation is None else clip.root_translation[:n]
    return replace(clip, rotations=clip.rotations[:n], root_translation=root)


def copies(clip, raw, trim_each):
    """(reference, {rate: copy}): the clip and its 60 / 30 fps copies. ``trim_each``: ``raw`` (as read, not
    trimmed) decimated, and every clip trimmed at its own rate."""
    if not trim_each:
        return clip, {f"{int(round(clip.fps / s))}fps": decimate_clip(clip, s) for s in (2, 4)}
    return trim_clip(raw), {f"{int(round(raw.fps / s))}fps": trim_clip(decimate_clip(raw, s)) for s in (2, 4)}


def check(row, metrics, rank):
    """PASS when every ratio is below its bound and (``rank``) the 30 fps copy ranks a walk first. A walk whose
    120 fps original already ranks a run first (a 1-NN error of the measure, not of the rate) is SAME instead of
    PASS when the copy agrees with it: the rate changed nothing."""
    ok = all(row[m][r] < BOUNDS.get(m, float("inf")) for m in metrics for r in RATES)
    if not rank or not ok:
        return "PASS" if ok else "FAIL"
    if all(row[m]["ranks_walks_first"] for m in metrics):
        return "PASS"
    same = all(row[m]["ranks_walks_first"] == row[m]["original_ranks_walks_first"] for m in metrics)
    return "SAME" if same else "FAIL"


def measure(data, metrics, time_base=True, say=print, span=False, trim_each=False, rank=True):
    rows = []
    for set_name in SETS:
        entries = ev.read_index(os.path.join(ROOT, "tools", "eval_sets", set_name))
        load = ev.entry_loader(data)
        load_raw = ev.entry_loader(data, trim="none")
        clips = [(e.label, load(e), e) for e in entries]
        runs = [c for label, c, _ in clips if label == "run"]
        walks = [c for label, c, _ in clips if label == "walk"]
        for label, clip, entry in clips:
            if label != "walk":
                continue
            clip = same_span(clip) if span else clip
            ref, low = copies(clip, load_raw(entry) if trim_each else None, trim_each)
            row = {"set": set_name, "clip": ref.name, "fps": ref.fps, "frames": ref.frames,
                   "lost": {r: ref.frames - 1 - (c.frames - 1) * int(round(ref.fps / c.fps)) for r, c in low.items()}}
            for m in metrics:
                near = min(clip_distance(ref, r, m, time_base=time_base) for r in runs)
                row[m] = {"nearest_run": near}
                for rate, c in low.items():
                    row[m][rate] = clip_distance(ref, c, m, time_base=time_base) / near
                if rank:
                    for key, q in (("ranks_walks_first", low["30fps"]), ("original_ranks_walks_first", ref)):
                        to_walk = min(clip_distance(q, w, m, time_base=time_base) for w in walks if w.name != ref.name)
                        to_run = min(clip_distance(q, r, m, time_base=time_base) for r in runs)
                        row[m][key] = bool(to_walk < to_run)
            row["verdict"] = check(row, metrics, rank)
            row["pass"] = row["verdict"] == "PASS"
            rows.append(row)
            say(f"{set_name:14s} {ref.name:8s} lost {row['lost']['60fps']}/{row['lost']['30fps']}  " + "  ".join(
                f"{m}: run {row[m]['nearest_run']:.3f} 60 fps {row[m]['60fps']:.3f} 30 fps {row[m]['30fps']:.3f}"
                + ("" if not rank else f" walks first {'yes' if row[m]['ranks_walks_first'] else 'NO'}"
                   f" (120 fps {'yes' if row[m]['original_ranks_walks_first'] else 'NO'})")
                for m in metrics) + f"  {row['verdict']}")
    worst = {m: {r: max(row[m][r] for row in rows) for r in RATES} for m in metrics}
    return rows, worst


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", required=True, help="the shared CMU folder")
    p.add_argument("--metrics", default="sim3,elastic")
    p.add_argument("--raw", action="store_true", help="compare the curves as read (no time base)")
    p.add_argument("--span", action="store_true",
                   help="cut every clip to a multiple of 4 frame intervals first (its copies then lose no frame)")
    p.add_argument("--whole", action="store_true", help="(the default; kept for older command lines)")
    p.add_argument("--trim-each", action="store_true",
                   help="decimate the clips as read and trim every copy at its own rate")
    p.add_argument("--no-rank", action="store_true", help="skip the check that a 30 fps walk ranks walks first")
    p.add_argument("--json", help="write the rows and the largest ratios to this file")
    p.add_argument("--smooth", type=float,
                   help="the SRVT measures' low-pass in seconds (default core.clip.prepare.SMOOTH_SECONDS; the sweep)")
    args = p.parse_args(argv)
    if args.smooth is not None:
        prepare.SMOOTH_SECONDS = args.smooth  # read by metrics.time_base_smoothing at every comparison
    metrics = [m.strip() for m in args.metrics.split(",") if m.strip()]
    rows, worst = measure(args.data, metrics, time_base=not args.raw, span=args.span, trim_each=args.trim_each,
                          rank=not args.no_rank)
    for m, w in worst.items():
        bound = f" (bound {BOUNDS[m]:g})" if m in BOUNDS else ""
        print(f"largest ratio {m}: 60 fps {w['60fps']:.3f}, 30 fps {w['30fps']:.3f}{bound} ({len(rows)} walks)")
    passed = sum(row["pass"] for row in rows)
    same = sum(row["verdict"] == "SAME" for row in rows)
    print(f"{passed}/{len(rows)} walks pass" + (f"; {same} more rank a run first at 120 fps as at 30 fps (SAME: a "
                                                f"1-NN error of the measure, not of the rate)" if same else ""))
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"rows": rows, "largest": worst, "passed": passed, "same": same, "time_base": not args.raw,
                       "smooth": prepare.SMOOTH_SECONDS,
                       "span": args.span, "trim_each": args.trim_each}, fh, indent=1)
    return 0 if passed + same == len(rows) else 1


if __name__ == "__main__":
    sys.exit(main())
