#!/usr/bin/env python
"""Variants of sim³ tried against the cross-rig same-take criterion, and what each costs on the evaluation sets.

  .venv/bin/python experiments/cross_rig_variants.py --data ../shared/data/cmu [--variants none,channel,time3,...]

Each variant changes the developed path before its log-signature (level 3, then sim = |a/|a| - b/|b||, eq. 9.1):

* ``none``: the path as the package signs it (the clip on the 30 fps lattice, in the comparison space, the
  joints every clip of the set has): the reference, equal to the sim³ of ``rank_across_rigs.py`` /
  ``evaluate_cmu.py`` on these sets;
* ``channel``: every coordinate divided by its own RMS step (blind to a gain per joint and axis, such as the
  Daz conversion's larger torso lean);
* ``joint``: every joint's three coordinates divided by the joint's RMS step;
* ``timeC``: a time coordinate added, C radians per second (the time-augmented path of the signature
  literature; it makes the measure see speed, not only shape).

Printed per variant: the same take first among the 20 shared cross-format clips (in the library of those 20,
and of all 92 readable shared clips), and LOO 1-NN on cmu27, cmu27_mixed, cmu_large and cmu_amc. The clips are
compared on the joints every clip of a set has (the 20/92: 19 joints), so the counts can differ from the
pairwise comparisons of the package by a clip; ``none`` reproduces them here.
"""

import argparse
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
for p in (ROOT, os.path.join(ROOT, "experiments")):
    if p not in sys.path:
        sys.path.insert(0, p)

import numpy as np  # noqa: E402

from blender_shapesig.core.signatures import signatures  # noqa: E402
from blender_shapesig.core.clip.clip import restrict_to_shared  # noqa: E402
from blender_shapesig.core.clip.prepare import COMPARE_FPS, prepare_clip  # noqa: E402
from blender_shapesig.core.geometry.so3 import relative_rotvecs  # noqa: E402
from blender_shapesig.evaluation import index as eval_index  # noqa: E402
from blender_shapesig.evaluation.run import load_entries  # noqa: E402
from blender_shapesig.evaluation.scores import loo_1nn  # noqa: E402

SETS = ("cmu27", "cmu27_mixed", "cmu_large", "cmu_amc")
VARIANTS = "none,channel,joint,time1,time2,time3,time5,time10"


def increments(clips):
    """Each clip's steps (steps, joints, 3) on the sim time base, on the joints all have, still ones dropped."""
    steps = [relative_rotvecs(prepare_clip(c, smooth=0.0).rotations) for c in restrict_to_shared(*clips)]
    moving = np.zeros(steps[0].shape[1], bool)
    for x in steps:
        moving |= np.abs(x).max(axis=(0, 2)) > 1e-9
    return [x[:, moving] for x in steps]


def variant(x, name):
    """The steps ``x`` (steps, joints, 3) as the path the variant signs (steps, coordinates)."""
    if name == "channel":
        x = x / np.maximum(np.sqrt((x ** 2).mean(axis=0, keepdims=True)), 1e-6)
    elif name == "joint":
        x = x / np.maximum(np.sqrt((x ** 2).sum(axis=2, keepdims=True).mean(axis=0, keepdims=True)), 1e-6)
    elif name.startswith("time"):
        t = np.full((x.shape[0], 1), float(name[4:]) / COMPARE_FPS)
        return np.concatenate([x.reshape(x.shape[0], -1), t], axis=1)
    elif name != "none":
        raise SystemExit(f"unknown variant {name!r}")
    return x.reshape(x.shape[0], -1)


def sim_matrix(steps, name, level=3):
    units = []
    for x in steps:
        a = signatures.increments_log_signature(variant(x, name), level)
        units.append(a / np.linalg.norm(a))
    units = np.array(units)
    return np.sqrt(np.maximum(2.0 - 2.0 * (units @ units.T), 0.0))


def same_take_first(D, names, takes, queries):
    ok = 0
    for i in range(queries):
        d = D[i].copy()
        d[i] = np.inf
        j = int(np.argmin(d))
        ok += names[j].split(":")[1] == takes[i]
    return ok


def main(argv=None):
    import rank_across_rigs  # tools/

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", required=True, help="the shared CMU folder")
    ap.add_argument("--variants", default=VARIANTS)
    args = ap.parse_args(argv)
    names = args.variants.split(",")
    items, takes = rank_across_rigs.library(args.data)
    rows = {n: [] for n in names}
    for lib in (items, rank_across_rigs.all_shared(args.data, items)):
        steps = increments([it.clips()[0] for it in lib])
        for n in names:
            rows[n].append(f"{same_take_first(sim_matrix(steps, n), [it.name for it in lib], takes, len(items))}/20")
    loader = eval_index.entry_loader(args.data)
    for s in SETS:
        entries = eval_index.read_index(os.path.join(ROOT, "tools", "eval_sets", f"{s}.csv"))
        steps = increments(load_entries(entries, loader))
        labels = [e.label for e in entries]
        for n in names:
            acc = loo_1nn(sim_matrix(steps, n), labels)[0]
            rows[n].append(f"{round(acc * len(labels))}/{len(labels)}")
    print("| variant | same take first (20) | (92) | " + " | ".join(SETS) + " |")
    print("|---" * (3 + len(SETS)) + "|")
    for n in names:
        print(f"| {n} | " + " | ".join(rows[n]) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
