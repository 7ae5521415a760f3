#!/usr/bin/env python
"""Pictures of docs/transitions.md, drawn by the package's rasterizer (``core.raster``) and pose strips
(``core.search.thumbnails.draw_strip``), no Blender needed:

  .venv/bin/python experiments/plot_transition.py [--out docs/img]

* ``transition_costs.png``: the best-cuts cost of the CMU walk 07_01 (rows, A frames) against the run 09_02
  (columns, B frames) from tests/data, dark = low, the five ranked cuts marked (the first in orange);
* ``transition_sheet.png``: the joined clip 07_01 -> 09_02 at its best cut with 36 generated frames, key poses of
  the canonical body seen from its right, the generated frames in orange; top row the velocity-carrying geodesic
  (generator 1), bottom row the bridge from the library tests/data/bvh (generator 2).
"""

import argparse
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

import numpy as np  # noqa: E402

from blender_shapesig.core.blend.body import Body  # noqa: E402
from blender_shapesig.core.blend.cuts import CUT_FPS, cut_costs  # noqa: E402
from blender_shapesig.core.blend.transition import best_cuts, transition  # noqa: E402
from blender_shapesig.core.search.local import features as local  # noqa: E402
from blender_shapesig.core.search.thumbnails import draw_strip  # noqa: E402
from blender_shapesig.core.io.sources import read_one  # noqa: E402
from blender_shapesig.core.raster import write_png  # noqa: E402
from blender_shapesig.core.rigs import apply_bone_map  # noqa: E402

DATA = os.path.join(ROOT, "tests", "data")


def costs_picture(a, b, cuts, scale=3):
    cost, ca, cb = cut_costs(Body(a), Body(b))
    lo, hi = np.percentile(cost, 1), np.percentile(cost, 99)
    v = np.clip((cost - lo) / max(hi - lo, 1e-12), 0, 1)
    rgb = np.stack([0.15 + 0.8 * v, 0.2 + 0.75 * v, 0.35 + 0.6 * v], axis=-1)
    img = np.kron(rgb, np.ones((scale, scale, 1)))
    for k, c in enumerate(cuts):
        i = int(np.argmin(np.abs(ca - c.a_frame))) * scale
        j = int(np.argmin(np.abs(cb - c.b_frame))) * scale
        color = (0.95, 0.45, 0.1) if k == 0 else (0.95, 0.95, 0.2)
        img[max(i - 3, 0):i + 4 + scale, max(j - 3, 0):j + 4 + scale] = color
    rgba = np.concatenate([img, np.ones(img.shape[:2] + (1,))], axis=-1)
    return (rgba * 255).astype(np.uint8)


def strip(joined, count=12):
    mapped = apply_bone_map(joined)
    P = local.features(mapped)["pose"]
    P = P.reshape(len(P), -1, 3)
    info = joined.meta["transition"]
    n = joined.frames - 1
    g0, g1 = info["a_frames"] / n, (info["a_frames"] + info["frames"] - 1) / n
    times = np.linspace(0.0, 1.0, count)
    times = np.unique(np.concatenate([times, np.linspace(g0, g1, 4)]))
    return draw_strip(P, times, window=(g0, g1))


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--out", default=os.path.join(ROOT, "docs", "img"))
    args = p.parse_args()
    a = read_one(os.path.join(DATA, "bvh", "07_01.bvh"), bone_map="none")
    b = read_one(os.path.join(DATA, "bvh", "09_02.bvh"), bone_map="none")
    cuts = best_cuts(a, b)
    write_png(os.path.join(args.out, "transition_costs.png"), costs_picture(a, b, cuts))
    lib = [os.path.join(DATA, "bvh", n) for n in ("08_01.bvh", "07_02.bvh", "09_03.bvh", "13_32.bvh")]
    one = transition(a, b, frames=36)
    two = transition(a, b, frames=36, library=lib)
    rows = [strip(one), strip(two)]
    width = max(r.shape[1] for r in rows)
    sheet = np.concatenate([np.pad(r, ((0, 0), (0, width - r.shape[1]), (0, 0)), constant_values=255) for r in rows])
    write_png(os.path.join(args.out, "transition_sheet.png"), sheet)
    print("cuts:", [c.as_dict() for c in cuts], "grid fps", CUT_FPS)
    print("bridge:", two.meta["transition"]["inbetween"])


if __name__ == "__main__":
    main()
