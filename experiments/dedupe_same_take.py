#!/usr/bin/env python
"""Does ``dedupe`` cluster the same take in two formats, and only it?

  .venv/bin/python experiments/dedupe_same_take.py --data ../shared/data/cmu [--all] [--out DIR]

The 20 clips of ``experiments/rank_across_rigs.py`` (10 CMU takes, each in two files: AMC and cgspeed Daz BVH,
iClone and Daz BVH, AMC and MotionBuilder BVH; bone maps automatic) go through ``dedupe_library`` (the command's
code). Printed: which same-take pairs share a cluster (and how many of the 20 clips are clustered with their twin),
every cluster holding two different takes (a file's take: the CMU trial in its name), and each near miss with the test it failed. ``--all``: the library is
every readable shared clip (``experiments/dedupe_check.py``'s), the same counts over the 20. ``--set CSV``: the
library is an evaluation set instead (``tools/eval_sets/*.csv``: file, label, skeleton), e.g. cmu_mixed_format
(its one take in two files: 16_15 as AMC and as MotionBuilder BVH).
"""

import argparse
import os
import re
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
for p in (ROOT, os.path.join(ROOT, "experiments")):
    if p not in sys.path:
        sys.path.insert(0, p)

from blender_shapesig.core.io.sources import ClipSpec  # noqa: E402
from blender_shapesig.dedupe import dedupe_library  # noqa: E402
from rank_across_rigs import takes  # noqa: E402


def trial(label):
    """The CMU trial a file holds, from its name ("07_05-walk.amc", "002_01.bvh": subject 2, trial 1), or None."""
    m = re.search(r"(\d+)_(\d+)", os.path.basename(label.split("#")[0]))
    return (int(m.group(1)), int(m.group(2))) if m else None


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", required=True)
    ap.add_argument("--all", action="store_true")
    ap.add_argument("--out", default=None)
    ap.add_argument("--set", help="an evaluation set's CSV instead of the 20 clips")
    args = ap.parse_args(argv)
    specs, take_of = [], {}
    rows = takes()
    if args.set:
        import csv

        with open(args.set, newline="", encoding="utf-8") as f:
            rows = [("set", None, r["file"], r.get("skeleton") or None) for r in csv.DictReader(f)]
    for fmt, take, path, asf in rows:
        full = os.path.realpath(os.path.join(args.data, path))
        specs.append(ClipSpec(full, asf=None if asf is None else os.path.join(args.data, asf), bone_map="auto"))
        take_of[full] = take or trial(full)
    if args.all:
        import pathlib

        from dedupe_check import library as shared_library

        have = set(take_of)
        for p in shared_library(pathlib.Path(args.data))[0]:
            spec = p if isinstance(p, ClipSpec) else ClipSpec(str(p))
            if os.path.realpath(spec.path) not in have:
                specs.append(ClipSpec(spec.path, asf=spec.asf, bone_map="auto"))
    out_dir = args.out or tempfile.mkdtemp(prefix="dedupe_same_take_")
    rep = dedupe_library(specs, out_dir, plots=False)
    label_take = {label: trial(label) for label in rep["all_clips"]}
    clustered, merged = set(), []
    for members in rep["clusters"]:
        tks = {label_take.get(m) or ("other:" + m) for m in members}
        if len(tks) > 1:
            merged.append(members)
        for m in members:
            if os.path.realpath(m) in take_of and sum(label_take.get(x) == label_take[m] for x in members) >= 2:
                clustered.add(m)
    print(f"rule: {rep['rule']}")
    twins = sum(sum(t == u for u in take_of.values()) == 2 for t in take_of.values())
    print(f"{len(clustered)} of {twins} clips with a twin clustered with it; clusters: {len(rep['clusters'])}")
    print(f"clusters: {len(rep['clusters'])}, of {rep['clips']} clips")
    for t in sorted({t for t in take_of.values() if list(take_of.values()).count(t) == 2}, key=str):
        both = [m for m in clustered if label_take[m] == (t if isinstance(t, tuple) else trial(t))]
        print(f"  {t}: {'clustered' if both else 'NOT clustered'}")
    print(f"clusters holding different takes: {len(merged)}")
    for m in merged:
        print("   ", m)
    print("near misses:")
    for row in rep["near_misses"]:
        print(f"   {row['a']} ~ {row['b']}: sim {row['sim']}, relative {row['relative']}, "
              f"failed: {row.get('failed', '?')}")
    print(f"report: {rep['json']}")


if __name__ == "__main__":
    main()
