#!/usr/bin/env python
"""Issue 41, third pass: the signature search (sim^3 on the comparison space, as ``rank --metric sim3`` computes it:
the same skeleton from the index's directions, another on the shared bones) fused with the local search.

  .venv/bin/python experiments/local_search/fusion.py --data PATH/TO/rigs [--variants ...]

Caches per set the sim3 matrix (queries x library) beside the local features; prints 1-NN by label per variant.
"""

import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common as cm  # noqa: E402
import variants as vs  # noqa: E402
from blender_shapesig.core.search.signature.entry import make_entry, entry_distance, pair_increments, \
    sim_from_increments  # noqa: E402


def sig_entries(clips, level=3):
    return [make_entry(c, level) for c in clips]


def sig_distance(a, b, level=3):
    if a.bones == b.bones:
        return entry_distance(a, b)
    bones = set(b.bones)
    shared = [x for x in a.bones if x in bones]
    x, y = pair_increments(a, b, shared)
    return float(sim_from_increments(x, y, level))


def sig_matrix(QE, LE, symmetric=False):
    D = np.zeros((len(QE), len(LE)))
    for i, a in enumerate(QE):
        for j, b in enumerate(LE):
            if symmetric and j < i:
                D[i, j] = D[j, i]
            elif symmetric and j == i:
                D[i, j] = 0.0
            else:
                D[i, j] = sig_distance(a, b)
    return D
