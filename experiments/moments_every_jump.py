#!/usr/bin/env python
"""Every occurrence in Moments, on a real long take: the iClone conversion of CMU 01_01 (``001_01.bvh``, 1,376 frames
at 60 fps, a playground take of ten forward jumps with walks and runs between them).

  .venv/bin/python experiments/moments_every_jump.py --data ../shared/data/cmu [--pad 20] [--rerank K] [--library]

The jumps are labelled automatically from the feet's height (``tests/helpers/long_take.py``'s ``airborne``: the lowest of
the feet and toe bones' heads and tails more than 0.1 leg lengths above the ground, the take's 5th percentile of
that lowest point, for at least 0.2 s). Each jump in turn (its flight with ``--pad`` frames either side) queries
Moments (``rank_windows``) over the take; printed: how many of the labelled jumps lie in its first 15 windows (a
window finds a jump when it holds the middle of its flight), and the windows' frames. ``--library``: the take among
every BVH file under ``--data`` (the 60 shared BVH files, read with automatic bone maps): the take's jumps among the
first windows of the whole library (other takes' windows, jumps among them, come between).
"""

import argparse
import os
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

import numpy as np  # noqa: E402

from blender_shapesig.core.search.moments.windows import rank_windows  # noqa: E402
from blender_shapesig.core.io import sources  # noqa: E402
from blender_shapesig.core.io.bvh import load_bvh  # noqa: E402
from tests.helpers.long_take import airborne  # noqa: E402

TAKE = os.path.join("DragonForgedTheArtist_IClone-CMU-Mocap", "All_BVH", "subjects", "001", "001_01.bvh")
FEET = ("CC_Base_L_Foot", "CC_Base_R_Foot", "CC_Base_L_ToeBase", "CC_Base_R_ToeBase")


def _read(path):
    try:
        return sources.read(sources.ClipSpec(path, bone_map="auto"))
    except Exception as exc:  # noqa: BLE001 - a file the readers refuse is left out, said in one line
        print(f"skipped {path}: {exc}")
        return []


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", required=True, help="the CMU data folder (../shared/data/cmu)")
    ap.add_argument("--pad", type=int, default=20, help="frames of the query either side of the flight")
    ap.add_argument("--rerank", type=int, default=None, help="moments refined by the elastic DP (default: Moments')")
    ap.add_argument("--first", type=int, default=15, help="windows looked at")
    ap.add_argument("--library", action="store_true", help="the take among every BVH file under --data")
    args = ap.parse_args(argv)
    path = os.path.join(args.data, TAKE)
    raw = load_bvh(path)
    rest = raw.meta["rest_heads"]
    leg = float(np.mean([np.linalg.norm(np.subtract(rest[f"CC_Base_{s}_Thigh"], rest[f"CC_Base_{s}_Foot"]))
                         for s in "LR"]))
    jumps = airborne(raw, FEET, leg)
    print(f"{len(jumps)} jumps labelled: {jumps}")
    take = sources.read_one(sources.ClipSpec(path, bone_map="auto"))
    library = [take]
    if args.library:
        others = [p for p in sources.discover(args.data) if p.lower().endswith(".bvh")
                  and os.path.realpath(p) != os.path.realpath(path)]
        library += [c for p in others for c in _read(p)]
        print(f"library: the take and {len(library) - 1} other clips")
    totals = []
    for k, (a, b) in enumerate(jumps):
        query = take.crop(max(a - args.pad, take.frame_start), min(b + args.pad, take.frame_start + take.frames - 1))
        t0 = time.perf_counter()
        rows = rank_windows(query, library, rerank=args.rerank, top=args.first)
        seconds = time.perf_counter() - t0
        hits = [[j for j, (x, y) in enumerate(jumps) if r.name == take.name and r.start <= (x + y) / 2 <= r.end]
                for r in rows]
        found = sorted({j for h in hits for j in h})
        first_miss = next((i for i, h in enumerate(hits) if not h), len(hits))
        totals.append(len(found))
        print(f"query jump {k} ({a - args.pad}-{b + args.pad}): {len(found)} of {len(jumps)} jumps in the first "
              f"{len(rows)} windows; the first {first_miss} windows are all jumps; {seconds:.2f} s")
        print("   " + ", ".join(("" if r.name == take.name else r.name + " ") + f"{r.start}-{r.end}"
                                + ("*" if h else "") for r, h in zip(rows, hits)))
    print(f"jumps found per query: min {min(totals)}, mean {np.mean(totals):.1f} of {len(jumps)}")


if __name__ == "__main__":
    main()
