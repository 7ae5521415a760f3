#!/usr/bin/env python
"""Moments: re-timed excerpts of long takes are found in their take, ranked first, window IoU >= 0.5.

  .venv/bin/python benchmarks/bench_moments.py --data ../shared/data/cmu [--rerank K] [--json FILE]

The library: every BVH under --data (the shared BVH library, 60 files on three skeletons, which holds the long
takes 13_10 (2,397 frames), 131_02 (1,247) and the iClone 001_01 (1,376, 60 fps)) plus the long AMC takes 09_12
(1,918 frames) and 135_06 (3,261). Each excerpt (``core.search.moments.windows.retimed_excerpt``: frames S..E of a long take
played 0.8x, 1.0x or 1.25x as fast, resampled at the take's rate) queries the library with
``core.search.moments.windows.rank_windows``; the script prints the rank of the source take, the IoU of its window with
S..E, and seconds. Baseline in the same run: the whole-clip ranking (``core.search.rank_clips``, sim3, signatures
already in memory) of the same query, its rank of the source take and its seconds.
"""

import argparse
import json
import os
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

from blender_shapesig.core import search as index
from blender_shapesig.core.io import sources  # noqa: E402
from blender_shapesig.core.search.moments.windows import rank_windows, retimed_excerpt  # noqa: E402

_AMC_TAKES = [("keenon_nimblephysics@d560120b1/data/mocap/09_12.amc", "keenon_nimblephysics@d560120b1/data/mocap/09.asf"),
              ("Jiaqi-Zuo_CSCI520-Motion-Capture-Interpolation/mocapPlayer-starter/135_06-martialArts.amc",
               "Jiaqi-Zuo_CSCI520-Motion-Capture-Interpolation/mocapPlayer-starter/135-martialArts.asf")]

# (take name, first frame as a fraction of the take, seconds of the take, speed)
EXCERPTS = [("13_10", 0.15, 3.0, 0.8), ("13_10", 0.45, 4.0, 1.25), ("13_10", 0.75, 2.5, 1.0),
            ("131_02", 0.2, 3.0, 1.25), ("131_02", 0.55, 3.0, 0.8),
            ("001_01", 0.3, 3.0, 0.8), ("001_01", 0.6, 4.0, 1.25),
            ("09_12", 0.25, 3.0, 1.25), ("09_12", 0.6, 3.0, 0.8),
            ("135_06-martialArts", 0.4, 4.0, 1.0)]


def load_library(data):
    specs = [sources.ClipSpec.parse(p) for p in sources.discover(data) if p.lower().endswith(".bvh")]
    specs += [sources.ClipSpec.parse(os.path.join(data, a), asf=os.path.join(data, s)) for a, s in _AMC_TAKES]
    return [c for spec in specs for c in sources.read(spec)]


def iou(a, b):
    inter = max(0, min(a[1], b[1]) - max(a[0], b[0]) + 1)
    return inter / (max(a[1], b[1]) - min(a[0], b[0]) + 1)


def run_excerpt(clips, by_name, cache, spec, rerank):
    name, where, seconds, speed = spec
    take = by_name[name]
    first = take.frame_start + int(where * take.frames)
    last = min(take.frame_end, first + int(round(seconds * take.fps)))
    query = retimed_excerpt(take, first, last, speed)
    t0 = time.perf_counter()
    res = rank_windows(query, clips, rerank=rerank)
    sec = time.perf_counter() - t0
    rank = next((i for i, r in enumerate(res, 1) if r.name == name), None)
    got = res[rank - 1] if rank else None
    t0 = time.perf_counter()
    whole = index.rank_clips(query, index.clip_items(clips), cache=cache, metric="sim")
    base_sec = time.perf_counter() - t0
    base_rank = next((i for i, r in enumerate(whole, 1) if r.name == name), None)
    return {"take": name, "excerpt": [first, last], "speed": speed, "query_frames": query.frames,
            "rank": rank, "window": [got.start, got.end] if got else None,
            "iou": iou((got.start, got.end), (first, last)) if got else 0.0, "elastic": got.elastic if got else None,
            "first": res[0].name, "seconds": sec, "whole_clip_rank": base_rank, "whole_clip_seconds": base_sec}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    p.add_argument("--data", required=True, help="the shared CMU folder (../shared/data/cmu)")
    p.add_argument("--rerank", type=int, default=10, help="clips refined by the free-window DP (default 10)")
    p.add_argument("--json", help="also write the rows to this JSON file")
    args = p.parse_args(argv)
    t0 = time.perf_counter()
    clips = load_library(args.data)
    load_sec = time.perf_counter() - t0
    by_name = {c.name: c for c in clips}
    cache = index.SignatureCache()
    t0 = time.perf_counter()
    index.build_index(index.clip_items(clips), cache=cache)
    index_sec = time.perf_counter() - t0
    print(f"library: {len(clips)} clips, {sum(c.frames for c in clips)} frames; read {load_sec:.1f} s, "
          f"whole-clip sim3 index {index_sec:.1f} s")
    rows = []
    print("take                 excerpt       speed  rank  window        IoU   elastic  s (moments)  "
          "whole-clip rank  s (whole)")
    for spec in EXCERPTS:
        r = run_excerpt(clips, by_name, cache, spec, args.rerank)
        rows.append(r)
        win = "-" if r["window"] is None else f"{r['window'][0]}-{r['window'][1]}"
        print(f"{r['take']:<20} {r['excerpt'][0]:>5}-{r['excerpt'][1]:<6} {r['speed']:>5}  {r['rank']!s:>4}  "
              f"{win:<12} {r['iou']:.2f}  {r['elastic'] or float('nan'):7.3f}  {r['seconds']:10.2f}  "
              f"{r['whole_clip_rank']!s:>15}  {r['whole_clip_seconds']:9.2f}")
    found = sum(r["rank"] == 1 and r["iou"] >= 0.5 for r in rows)
    mean = sum(r["seconds"] for r in rows) / len(rows)
    base = sum(r["whole_clip_seconds"] for r in rows) / len(rows)
    print(f"found first with IoU >= 0.5: {found} of {len(rows)}; mean IoU {sum(r['iou'] for r in rows) / len(rows):.2f}; "
          f"mean seconds per query {mean:.2f} (whole-clip rank {base:.2f}, ratio {mean / base:.1f})")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"clips": len(clips), "rows": rows}, f, indent=1)
    return 0 if found == len(rows) else 1


if __name__ == "__main__":
    sys.exit(main())
