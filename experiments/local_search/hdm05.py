#!/usr/bin/env python
"""HDM05 leave-one-actor-out (issue 29): the DTW baseline on joint positions (tslearn), the package's sim3 and
elastic, and the local search's variants, plus the crop probes (10 % cut at either end: the source must rank first).

  .venv/bin/python experiments/local_search/hdm05.py --data PATH/TO/hdm05 [--out out/local_search] [--package]
      [--variants default,...] [--tslearn]

Prints one line per measure: 1-NN accuracy, mAP, crop probes (start / end).
"""

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common as cm  # noqa: E402
import variants as vs  # noqa: E402


def dtw_baseline(feats, items, use_tslearn):
    seqs = [f["all"] for f in feats]
    t0 = time.perf_counter()
    if use_tslearn:
        from tslearn.metrics import dtw as ts_dtw
        n = len(seqs)
        D = np.zeros((n, n))
        for i in range(n):
            for j in range(i + 1, n):
                D[i, j] = D[j, i] = ts_dtw(seqs[i], seqs[j])
    else:
        D = cm.dtw_matrix(seqs)
    secs = time.perf_counter() - t0
    labels = [it.label for it in items]
    orders = [np.asarray(c)[np.argsort(D[q, c], kind="stable")] for q, c in cm.protocol(items, "loao")]
    acc, mAP = cm.scores(orders, labels, [q for q, _ in cm.protocol(items, "loao")])
    return acc, mAP, secs, D


def package_metrics(items, names=("sim3", "elastic")):
    from blender_shapesig.core.pairwise import clip_distance_matrix

    clips = [it.mapped() for it in items]
    labels = [it.label for it in items]
    out = {}
    for name in names:
        D, secs = clip_distance_matrix(clips, name, workers=2)
        orders = [np.asarray(c)[np.argsort(D[q, c], kind="stable")] for q, c in cm.protocol(items, "loao")]
        out[name] = cm.scores(orders, labels, [q for q, _ in cm.protocol(items, "loao")]) + (secs,)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", required=True)
    ap.add_argument("--out", default=os.path.join("out", "local_search"))
    ap.add_argument("--package", action="store_true", help="also the package's sim3 and elastic")
    ap.add_argument("--tslearn", action="store_true", help="the DTW baseline with tslearn (else our kernel)")
    ap.add_argument("--variants", default="default")
    args = ap.parse_args(argv)
    items = cm.load_hdm05(args.data)
    print(f"{len(items)} clips", file=sys.stderr)
    feats = cm.set_features(items, os.path.join(args.out, f"hdm05_features_{cm.FEATURES}.pkl"))
    acc, mAP, secs, _ = dtw_baseline(feats["full"], items, args.tslearn)
    print(f"DTW positions ({'tslearn' if args.tslearn else 'ours'}, 30 Hz, all joints): 1-NN {acc:.3f} mAP {mAP:.3f}"
          f" ({secs:.1f} s)")
    if args.package:
        for name, (a, m, s) in package_metrics(items).items():
            print(f"package {name}: 1-NN {a:.3f} mAP {m:.3f} ({s:.1f} s)")
    for v in args.variants.split(","):
        r = vs.evaluate(items, feats, vs.VARIANTS[v], "loao")
        print(vs.format_row("hdm05", v, r))
    return 0


if __name__ == "__main__":
    sys.exit(main())
