#!/usr/bin/env python
"""Foot trajectories of a walk x run blend before and after ``core.blend.feet.lock_feet`` (docs/blending.md, "Planted
feet"):

  .venv/bin/python experiments/plot_feet.py --data ../shared/data/cmu [--pair 07_01,09_02] [--weight 0.25]
      [--out docs/img/feet_trajectories.png]

The strides and the blend are the benchmark's (benchmarks/bench_foot_drift.py). Per foot (rows L, R): the ball's
(foot tail's) position along the direction of travel and its height over the blend's seconds, before (dashed) and
after (solid) locking, the blend's contact runs of the ball shaded. A planted ball is a flat stretch of the
along-travel curve.
"""

import argparse
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
for path in (ROOT, os.path.join(ROOT, "benchmarks")):
    if path not in sys.path:
        sys.path.insert(0, path)

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from bench_foot_drift import blend_pair, load  # noqa: E402
from blender_shapesig.core.blend import contacts, feet  # noqa: E402


def trajectories(data, pair, weight):
    """(blend, locked, report, unit): the benchmark's blend of ``pair`` at ``weight`` and its locked version."""
    a, b = (load(data, label) for label in pair)
    blend = blend_pair(a, b, weight)
    locked, report = feet.lock_feet(blend, [a, b])
    legs = contacts.legs_of(a)
    unit = feet.unit_meters(a, [(t, f) for t, _s, f in legs.values()])
    return blend, locked, report, unit


def plot(data, pair, weight, out):
    blend, locked, report, unit = trajectories(data, pair, weight)
    src = [load(data, label) for label in pair]
    work_b, work_l = (feet._working_clip(c, src) for c in (blend, locked))
    before, after = contacts.feet_positions(work_b), contacts.feet_positions(work_l)
    up = feet.up_vector(work_b)
    root = blend.root_translation
    travel = root[-1] - root[0]
    travel = travel - (travel @ up) * up
    travel /= np.linalg.norm(travel)
    t = np.arange(blend.frames) / blend.fps
    fig, axes = plt.subplots(2, 2, figsize=(10, 5.5), sharex=True)
    for row, side in enumerate(("L", "R")):
        runs = [iv["seconds"] for r in report["contacts"] if r["clip"] == blend.name and r["side"] == side
                and r["point"] == "ball" for iv in r["intervals"]]
        for col, (what, axis) in enumerate((("along travel (m)", travel), ("height (m)", up))):
            ax = axes[row, col]
            for s0, s1 in runs:
                ax.axvspan(s0, s1, color="0.9")
            ax.plot(t, before[side]["ball"] @ axis * unit, "--", color="tab:red", label="blend")
            ax.plot(t, after[side]["ball"] @ axis * unit, "-", color="tab:blue", label="planted (lock_feet)")
            ax.set_ylabel(f"{side} ball {what}")
            if row == 1:
                ax.set_xlabel("seconds")
    axes[0, 0].legend(loc="upper left", fontsize=8)
    fig.suptitle(f"{pair[0]} x {pair[1]}, w = {weight:g}: ball of each foot (grey: contacts in the blend)")
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    return out


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", required=True, help="the CMU data folder (the one with INDEX.md)")
    parser.add_argument("--pair", default="07_01,09_02", help="two labels of bench_foot_drift.CLIPS")
    parser.add_argument("--weight", type=float, default=0.25)
    parser.add_argument("--out", default=os.path.join(ROOT, "docs", "img", "feet_trajectories.png"))
    args = parser.parse_args(argv)
    print(plot(args.data, tuple(args.pair.split(",")), args.weight, args.out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
