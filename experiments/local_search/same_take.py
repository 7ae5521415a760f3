#!/usr/bin/env python
"""Same take across formats (issue 29): can the default search's shortlist tell the same take from other takes of
the same subject? Two "take" measures on the local features, tried on ``experiments/rank_across_rigs.py``'s 20
clips (library of those 20 and of all readable shared clips):

* ``term``: the take distance added to the shortlist's score (``local.combine``'s global term) with weight w;
* ``gate``: the shortlist candidate with the smallest take distance among those lasting within ``--dur`` (log
  ratio) of the query moves first when its take distance is below rho x that of the current first.

The take distance: the pose channels minus their clip mean, resampled to 32 samples over the clip's own duration
(no time warp: the same take matches sample by sample, another take of a cyclic motion does not keep its phase),
RMS in leg lengths, times (1 + |log duration ratio|).

  .venv/bin/python experiments/local_search/same_take.py --data PATH/TO/cmu [--out out/local_search]
"""

import argparse
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import common as cm  # noqa: E402
import variants as vs  # noqa: E402
from blender_shapesig.core.search.local import features as ls  # noqa: E402

N = 32


def take_sig(f):
    X = f["pose"] - f["pose"].mean(0)
    t = np.linspace(0, len(X) - 1, N)
    Y = np.stack([np.interp(t, np.arange(len(X)), X[:, k]) for k in range(X.shape[1])], 1)
    return Y, len(X) / float(f["rate"])


def rms(a, b):
    return float(np.sqrt(((a[0] - b[0]) ** 2).sum(1).mean()))


def take_distance(a, b):
    return rms(a, b) * (1 + abs(np.log(a[1] / b[1])))


def same(everyone, q, j):
    """j is q's take (in the 20) or another copy of it among the other shared clips (e.g. 02_01.amc)."""
    a, b = everyone[q], everyone[j]
    return b.label == a.label or b.name.split(":")[1].startswith(a.label)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", required=True)
    ap.add_argument("--out", default=os.path.join("out", "local_search"))
    ap.add_argument("--weights", default="0,0.5,1,2,4")
    ap.add_argument("--rhos", default="0.5,0.7,0.85,1.0")
    ap.add_argument("--dur", type=float, default=0.05)
    args = ap.parse_args(argv)
    sys.path.insert(0, os.path.join(cm.ROOT, "experiments"))
    import cmu

    rig, others = cm.cached(os.path.join(args.out, "rigs_items.pkl"), lambda: cmu.rig_items(args.data))
    everyone = rig + others
    feats = cm.cached(os.path.join(args.out, f"rigs_features_{cm.FEATURES}.pkl"),
                      lambda: [cm.clip_features(it.mapped()) for it in everyone])
    settings, k, band, free, mix = vs.VARIANTS["default"]
    E, T = vs.entries(feats, settings), [take_sig(f) for f in feats]
    for n_lib in (20, len(everyone)):
        term = {float(w): 0 for w in args.weights.split(",")}
        gate = {float(r): 0 for r in args.rhos.split(",")}
        for q in range(20):
            cand = [j for j in range(n_lib) if j != q]
            d1 = ls.first_stage(E[q], ls.stack([E[j] for j in cand]))
            order = [cand[i] for i in np.argsort(d1, kind="stable")]
            head = order[:k]
            d2 = ls.rerank(E[q], [E[j] for j in head], band, free)
            dt = np.array([take_distance(T[q], T[j]) for j in head])
            for w in term:
                s = ls.combine(np.sort(d1)[:k], d2, mix, dt, w)
                term[w] += same(everyone, q, head[int(np.argmin(s))])
            s = ls.combine(np.sort(d1)[:k], d2, mix)
            first = head[int(np.argmin(s))]
            near = [j for j in head if abs(np.log(T[j][1] / T[q][1])) <= args.dur]
            for r in gate:
                pick = first
                if near:
                    dn = [rms(T[q], T[j]) for j in near]
                    c = near[int(np.argmin(dn))]
                    if min(dn) < r * rms(T[q], T[first]):
                        pick = c
                gate[r] += same(everyone, q, pick)
        print(f"library {n_lib}: same take first, take term by weight {term}; gate by rho {gate}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
