#!/usr/bin/env python
"""The rig data set (issue 41): leave-one-out 1-NN by label over its humanoid clips, the local search's variants
(two stages, no twin rule: the set has no same-take pairs) beside 1-NN DTW on joint positions (tslearn).

  .venv/bin/python experiments/local_search/rigs.py --data PATH/TO/rigs [--variants default,...] [--tslearn]

Reads every non-``nonhuman`` row of ``index.csv`` as the command line would (``sources.read_one``: trim "auto", bone
map "auto"); a clip the readers refuse is left out, a label no other clip shares is no query (``rank_rigs.py``'s
rule). Prints per variant 1-NN (first stage -> two stages) and the classes' counts.
"""

import argparse
import csv
import os
import sys
from collections import Counter, defaultdict

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common as cm  # noqa: E402
import variants as vs  # noqa: E402
from blender_shapesig.core.io import sources  # noqa: E402


def load(data):
    items, feats = [], []
    with open(os.path.join(data, "index.csv"), newline="", encoding="utf-8") as fh:
        rows = [r for r in csv.DictReader(fh) if r["family"] != "nonhuman"]
    for r in rows:
        try:
            clip = sources.read_one(sources.ClipSpec.parse(os.path.join(data, r["file"])))
            f = cm.clip_features(clip)
        except Exception as exc:  # noqa: BLE001 - a refused clip is left out, as rank_rigs.py does
            print(f"left out {r['file']}: {exc}", file=sys.stderr)
            continue
        items.append(cm.Item(r["file"], r["label"], r["family"], None))
        feats.append(f)
    return items, feats


def window_weights(feat, settings, floor=0.05):
    """(windows,) each window's energy over the largest of its scale (at least ``floor``), in the rows' order of
    ``local.window_vectors`` (without ``settings.active``)."""
    from blender_shapesig.core.search.local import action as la
    out = []
    for window in settings.windows:
        starts, w = vs.ls._windows(len(feat["pose"]), float(feat["rate"]), window, settings.hop * window,
                                   settings.max_windows)
        e = la.window_energy(feat, starts, w)
        out.append(np.maximum(e / max(float(e.max()), 1e-9), floor))
    return np.concatenate(out)


def weighted_matrix(E, feats, settings, floor):
    """The first stage with each side's mean weighted by its windows' energy (``local_action.window_weights``)."""
    W = [np.asarray(e.windows, np.float32) for e in E]
    wt = [window_weights(f, settings, floor) for f in feats]
    n = len(E)
    D = np.zeros((n, n))
    for i in range(n):
        for j in range(n):
            d = np.sqrt(vs.ls._sq_dist(W[i], W[j]))
            D[i, j] = 0.5 * (np.average(d.min(1), weights=wt[i]) + np.average(d.min(0), weights=wt[j]))
    return D


def per_class(orders, items, queries):
    per = defaultdict(lambda: [0, 0])
    for q, order in zip(queries, orders):
        per[items[q].label][0] += items[order[0]].label == items[q].label
        per[items[q].label][1] += 1
    return per


def fmt(per):
    hit, n = sum(v[0] for v in per.values()), sum(v[1] for v in per.values())
    cls = ", ".join(f"{k} {v[0]}/{v[1]}" for k, v in sorted(per.items(), key=lambda kv: (-kv[1][1], kv[0])))
    return f"{hit}/{n} ({hit / n:.3f}) [{cls}]"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", required=True)
    ap.add_argument("--out", default=os.path.join("out", "local_search"))
    ap.add_argument("--variants", default="default")
    ap.add_argument("--tslearn", action="store_true")
    ap.add_argument("--misses", action="store_true", help="print every wrong first match")
    ap.add_argument("--mirror", action="store_true", help="each query also as its mirror image (the nearer counts)")
    args = ap.parse_args(argv)
    items, feats = cm.cached(os.path.join(args.out, f"rigset_features_{cm.FEATURES}.pkl"), lambda: load(args.data))
    counts = Counter(it.label for it in items)
    queries = [q for q, it in enumerate(items) if counts[it.label] >= 2]
    cands = [[j for j in range(len(items)) if j != q] for q in queries]
    print(f"{len(items)} clips, {len(queries)} queries", file=sys.stderr)
    if args.tslearn:
        from tslearn.metrics import dtw as ts_dtw
        # the rigs have other joints: the 11 key points every mapped humanoid has (``local.features``' pose)
        seqs = [f["pose"] for f in feats]
        orders = []
        for q, c in zip(queries, cands):
            d = np.array([ts_dtw(seqs[q], seqs[j]) for j in c])
            orders.append(np.asarray(c)[np.argsort(d, kind="stable")])
        print(f"rigs DTW on the 11 key points' positions (tslearn, 30 Hz, no band): "
              f"{fmt(per_class(orders, items, queries))}")
    for name in args.variants.split(","):
        settings, k, band, free, mix = vs.VARIANTS[name]
        E = vs.entries(feats, settings)
        D1 = weighted_matrix(E, feats, settings, float(name.split("wchamfer")[1])) if "wchamfer" in name \
            else vs.first_matrix(E, E)
        if args.mirror:
            M = vs.entries([cm.mirrored(f) for f in feats], settings)
            D1 = np.minimum(D1, vs.first_matrix(M, E))
        o1, o2 = [], []
        for q, c in zip(queries, cands):
            c = np.asarray(c)
            o1.append(c[np.argsort(D1[q, c], kind="stable")])
            if args.mirror:
                d2 = lambda j, q=q: min(vs.ls.rerank(E[q], [E[j]], band, free)[0], vs.ls.rerank(M[q], [E[j]], band, free)[0])  # noqa: E731
            else:
                d2 = lambda j, q=q: vs.ls.rerank(E[q], [E[j]], band, free)[0]  # noqa: E731
            o2.append(cm.two_stage_order(D1[q], c, k, d2, mix))
        p1, p2 = per_class(o1, items, queries), per_class(o2, items, queries)
        print(f"rigs {name:24s} stage1 {fmt(p1)}\n     {'':24s} 2 stages {fmt(p2)}")
        if args.misses:
            for q, o in zip(queries, o2):
                if items[o[0]].label != items[q].label:
                    print(f"   - {items[q].name} ({items[q].label}) -> {items[o[0]].name} ({items[o[0]].label})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
