"""Our bpy-free BVH reader (``core.io.bvh.load_bvh``) against Blender's importer (``readers.bvh.import_bvh``,
armature space) on every BVH file given: agreement and speed, measured in the same run.

    .venv/bin/python benchmarks/bench_bvh_reader.py [--data ../shared/data/cmu] [--json OUT]

Files: tests/data/bvh/*.bvh plus every .bvh under ``--data``. Per file: the largest rotation difference and the
largest root-position difference between the two readers, and both against a float64 reading of the Euler
channels (scipy; the test suite's independent reader). Times: wall seconds per file of each reader (best of 2).
"""

import argparse
import json
import pathlib
import sys
import time

import numpy as np

import _common as harness  # noqa: E402  (puts the repository on sys.path)

ROOT = harness.ROOT
sys.path.insert(0, str(ROOT / "tests"))

import bpy  # noqa: E402,F401

from blender_shapesig.core.io.bvh import BVH_TO_BLENDER as A, load_bvh  # noqa: E402
from blender_shapesig.readers.bvh import import_bvh  # noqa: E402
from conftest import bvh_channel_rotations  # noqa: E402  (the tests' independent BVH reading)


def best(fn, n=2):
    """(the result, the minimum wall seconds of ``n`` runs)."""
    out = []
    t = harness.timed(lambda: out.append(fn()), n, warmup=0)
    return out[-1], t.wall_min


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    default = ROOT.parent / "shared" / "data" / "cmu"
    ap.add_argument("--data", type=pathlib.Path, default=default if default.exists() else None)
    ap.add_argument("--json", type=pathlib.Path)
    args = ap.parse_args(argv)
    files = sorted((ROOT / "tests" / "data" / "bvh").glob("*.bvh"))
    if args.data is not None:
        files += sorted(args.data.rglob("*.bvh"))
    rows, t_ours, t_blender = [], 0.0, 0.0
    for f in files:
        ours, to = best(lambda: load_bvh(f))
        theirs, tb = best(lambda: import_bvh(f), 1)
        t_ours += to
        t_blender += tb
        truth = np.stack([A @ R @ A.T for R in bvh_channel_rotations(f)[1]], axis=1)
        same = (ours.bones == theirs.bones and ours.rotation_modes == theirs.rotation_modes
                and ours.frames == theirs.frames and ours.fps == theirs.fps)
        loc = 0.0 if ours.root_translation is None else float(np.abs(ours.root_translation
                                                                      - theirs.root_translation).max())
        rows.append({"file": str(f.relative_to(f.parents[2])), "same_structure": same,
                     "rot_vs_blender": float(np.abs(ours.rotations - theirs.rotations).max()),
                     "root_vs_blender": loc,
                     "ours_vs_float64": float(np.abs(ours.rotations - truth).max()),
                     "blender_vs_float64": float(np.abs(theirs.rotations - truth).max())})
    out = {"files": len(rows), "all_same_structure": all(r["same_structure"] for r in rows),
           "max_rot_vs_blender": max(r["rot_vs_blender"] for r in rows),
           "max_root_vs_blender": max(r["root_vs_blender"] for r in rows),
           "max_ours_vs_float64": max(r["ours_vs_float64"] for r in rows),
           "max_blender_vs_float64": max(r["blender_vs_float64"] for r in rows),
           "files_within_1e-6": sum(r["rot_vs_blender"] <= 1e-6 for r in rows),
           "seconds_per_file": {"ours": round(t_ours / len(rows), 4), "blender": round(t_blender / len(rows), 4)},
           "speedup": round(t_blender / t_ours, 1), "per_file": rows}
    print(json.dumps({k: v for k, v in out.items() if k != "per_file"}, indent=2))
    if args.json:
        args.json.write_text(json.dumps(out, indent=2) + "\n")


if __name__ == "__main__":
    main()
