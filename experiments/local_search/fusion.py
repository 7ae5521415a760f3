#!/usr/bin/env python
"""Issue 41, third pass: the signature search (sim^3 on the comparison space, as ``rank --metric sim3`` computes it:
the same skeleton from the index's directions, another on the shared bones) fused with the local search, on the rig
set (leave-one-out 1-NN by label, ``rank_rigs.py``'s rule): sim^3 alone, its distance in the shortlist's score,
reciprocal-rank fusion of the two rankings, a shortlist of both engines' firsts.

  .venv/bin/python experiments/local_search/fusion.py --data PATH/TO/rigs

Caches the sim^3 matrix beside ``rigs.py``'s features (out/local_search/rigset_sig3.pkl).
"""

import argparse
import csv
import os
import pickle
import sys
from collections import Counter

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common as cm  # noqa: E402
import rigs as rg  # noqa: E402
import variants as vs  # noqa: E402
from blender_shapesig.core.io import sources  # noqa: E402
from blender_shapesig.core.search.local import features as ls  # noqa: E402
from blender_shapesig.core.search.signature.entry import entry_distance, make_entry, pair_increments, \
    sim_from_increments  # noqa: E402

OUT = os.path.join("out", "local_search")


def sig_distance(a, b, level=3):
    """sim^level of two signature entries: from the directions on one skeleton, else on the shared bones."""
    if a.bones == b.bones:
        return entry_distance(a, b)
    bones = set(b.bones)
    x, y = pair_increments(a, b, [j for j in a.bones if j in bones])
    return float(sim_from_increments(x, y, level))


def sig_matrix(data):
    """{"names", "D"}: the rig set's readable humanoid clips (``rigs.load``'s) and their sim^3 matrix."""
    with open(os.path.join(data, "index.csv"), newline="", encoding="utf-8") as fh:
        rows = [r for r in csv.DictReader(fh) if r["family"] != "nonhuman"]
    clips, names = [], []
    for r in rows:
        try:
            c = sources.read_one(sources.ClipSpec.parse(os.path.join(data, r["file"])))
            cm.clip_features(c)
        except Exception:  # noqa: BLE001 - a clip the local search cannot read is left out, as rigs.py does
            continue
        clips.append(c)
        names.append(r["file"])
    E = [make_entry(c, 3) for c in clips]
    D = np.zeros((len(E), len(E)))
    for i in range(len(E)):
        for j in range(i + 1, len(E)):
            D[i, j] = D[j, i] = sig_distance(E[i], E[j])
    return {"names": names, "D": D}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", required=True)
    args = ap.parse_args(argv)
    items, feats = cm.cached(os.path.join(OUT, f"rigset_features_{cm.FEATURES}.pkl"), lambda: rg.load(args.data))
    S = cm.cached(os.path.join(OUT, "rigset_sig3.pkl"), lambda: sig_matrix(args.data))
    assert S["names"] == [it.name for it in items]
    Ds = S["D"]
    counts = Counter(it.label for it in items)
    queries = [q for q, it in enumerate(items) if counts[it.label] >= 2]
    _, K, band, free, mix = vs.VARIANTS["default"]
    E = vs.entries(feats, vs.VARIANTS["default"][0])
    D1 = vs.first_matrix(E, E)
    n = len(items)
    D2 = np.full((n, n), np.nan)
    for q in queries:
        for j in range(n):
            if j != q:
                D2[q, j] = ls.rerank(E[q], [E[j]], band, free)[0]

    def rel(x):
        return x / max(np.mean(x), 1e-12)

    def ranks(x):
        return np.argsort(np.argsort(x, kind="stable"), kind="stable")

    def run(name, order_fn):
        orders = [order_fn(q, np.array([j for j in range(n) if j != q])) for q in queries]
        print(f"{name:40s} {rg.fmt(rg.per_class(orders, items, queries))}", flush=True)

    def local2(q, c, k=K, w=0.0):
        o = c[np.argsort(D1[q, c], kind="stable")]
        h = o[:k]
        s = rel(D2[q, h]) + mix * rel(D1[q, h]) + (w * rel(Ds[q, h]) if w else 0.0)
        return np.concatenate([h[np.argsort(s, kind="stable")], o[k:]])

    def rrf(q, c, k0, ws, two):
        if two:
            pos = {j: i for i, j in enumerate(local2(q, c))}
            r1 = np.array([pos[j] for j in c])
        else:
            r1 = ranks(D1[q, c])
        s = 1.0 / (k0 + r1) + ws / (k0 + ranks(Ds[q, c]))
        return c[np.argsort(-s, kind="stable")]

    def union(q, c, w, ks, k=K):
        o1 = c[np.argsort(D1[q, c], kind="stable")]
        h = np.array(list(dict.fromkeys(list(o1[:k]) + list(c[np.argsort(Ds[q, c], kind="stable")][:ks]))))
        s = rel(D2[q, h]) + mix * rel(D1[q, h]) + w * rel(Ds[q, h])
        return np.concatenate([h[np.argsort(s, kind="stable")], [j for j in o1 if j not in set(h)]])

    run("sim3 alone", lambda q, c: c[np.argsort(Ds[q, c], kind="stable")])
    run("local first stage", lambda q, c: c[np.argsort(D1[q, c], kind="stable")])
    run("local two stages", lambda q, c: local2(q, c))
    for k in (20, 50):
        for w in (0.5, 1.0, 2.0, 3.0):
            run(f"shortlist {k} + {w} sim3/mean", lambda q, c, k=k, w=w: local2(q, c, k, w))
    for k0 in (5, 20, 60):
        for ws in (0.5, 1.0):
            run(f"rrf two stages k0={k0} w={ws}", lambda q, c, k0=k0, ws=ws: rrf(q, c, k0, ws, True))
            run(f"rrf first stage k0={k0} w={ws}", lambda q, c, k0=k0, ws=ws: rrf(q, c, k0, ws, False))
    for w in (1.0, 2.0, 3.0):
        for ks in (10, 20):
            run(f"union 20 + sim3's {ks}, w {w}", lambda q, c, w=w, ks=ks: union(q, c, w, ks))
    return 0


if __name__ == "__main__":
    sys.exit(main())
