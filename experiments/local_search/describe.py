#!/usr/bin/env python
"""Issue 41, third pass: a clip-level "what happens" descriptor (the pelvis' speed and its direction relative to
the facing, how far the pelvis rises and falls, how high the lower foot gets, the pelvis' vertical speed; hands'
reach and limbs' speeds as options) as a term of the local search's scores, each number scaled to unit standard
deviation over the library. Scores every set from cached features (``common.set_features``'s caches and
``rigs.py``'s): the rig set's 1-NN by label, HDM05 leave-one-actor-out, the CMU sets leave-one-out, the crop probes.

  .venv/bin/python experiments/local_search/describe.py [--sets rigs,hdm05,cmu27,...] [--variants base,...]
      [--base default|act2.0|k30|...] [--misses] [--tslearn]

A variant is ``(columns, percentile, w1, w2)``: the descriptor's distance (root mean square of the scaled
differences) added with weight ``w1`` to the first stage (each relative to its mean over the library) and with
``w2`` to the shortlist's final score (``local.combine``'s terms, each relative to its mean over the shortlist).
"""

import argparse
import os
import pickle
import sys
from collections import Counter

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common as cm  # noqa: E402
import variants as vs  # noqa: E402
from blender_shapesig.core.search.local import action as la, features as ls  # noqa: E402

OUT = os.path.join("out", "local_search")
NAMES = ("speed", "forward", "sideways", "rise", "clearance", "vertical", "reach_forward", "reach_up", "arms",
         "legs", "ground_speed", "ground_forward", "ground_sideways", "turn", "extension")
BODY = (0, 1, 2, 3, 4, 5)


def extension_rate(pose, rate):
    """(T,) how fast the faster hand moves away from its shoulder (leg lengths per second)."""
    ext = np.linalg.norm(pose[:, [5, 6]] - pose[:, [1, 2]], axis=2)
    return np.gradient(ext, axis=0).max(axis=1) * rate if len(ext) > 1 else np.zeros(len(ext))


def describe(feat, P=95.0):
    """(10,) the clip's numbers (``NAMES``): leg lengths and leg lengths per second."""
    c = la.action_channels(feat)
    fwd, side, up = -c[:, 1], c[:, 0], c[:, 2]
    low, pz = c[:, 3:5].min(axis=1), c[:, 5]
    pc = lambda x, p=P: float(np.percentile(x, p))  # noqa: E731
    # the ground under the lower foot, seen from the body: it moves as the body travels, also in a clip that plays in
    # place (no root motion): minus the lower ankle's velocity relative to the pelvis, in the body's frame
    pose = np.asarray(feat["pose"], float).reshape(len(c), -1, 3)
    rate = float(feat["rate"])
    ank = pose[:, [9, 10]]
    v = np.gradient(ank, axis=0) * rate if len(c) > 1 else np.zeros_like(ank)
    lower = np.argmin(ank[..., 2], axis=1)
    g = -v[np.arange(len(c)), lower]
    gf, gs = -g[:, 1], g[:, 0]
    yaw = np.asarray(feat["motion"], float)[:, 3]
    turn = abs(yaw[-1] - yaw[0]) / max((len(c) - 1) / rate, 1e-9)
    return np.array([np.median(np.hypot(fwd, side)), np.mean(fwd), abs(np.mean(side)), pc(pz) - pc(pz, 100 - P),
                     pc(low), pc(np.abs(up)), pc(c[:, 6]), pc(c[:, 7]), pc(c[:, 8]), pc(c[:, 9]),
                     np.median(np.hypot(gf, gs)), np.mean(gf), abs(np.mean(gs)), turn,
                     pc(extension_rate(pose, rate))])


VARIANTS = {"base": (BODY, 95.0, 0.0, 0.0)}
for _cols, _cn in ((BODY, "body"), (tuple(range(10)), "all"), ((0, 1, 2, 3, 4, 5, 8, 9), "nohand"), ((3, 4, 5), "air"),
                   ((0, 1, 2), "travel"), ((1, 2, 3, 4, 5), "airdir"), ((3, 4), "lift"),
                   ((10, 11, 12, 3, 4, 5), "ground"), ((0, 1, 2, 3, 4, 5, 10, 11, 12), "bodyground"),
                   ((0, 1, 2, 3, 4, 5, 13), "bodyturn"), ((10, 11, 12, 3, 4, 5, 13), "groundturn"),
                   ((0, 1, 2, 3, 4, 5, 10, 11, 12, 13), "bodygroundturn"),
                   ((0, 1, 2, 3, 4, 5, 10, 11, 12, 14), "bodygroundext")):
    for _p in (80.0, 85.0, 90.0, 95.0, 100.0):
        for _w1 in (0.0, 0.1, 0.25, 0.5, 1.0):
            for _w2 in (0.5, 1.0, 2.0, 3.0):
                VARIANTS[f"{_cn}_p{int(_p)}_a{_w1}_b{_w2}"] = (_cols, _p, _w1, _w2)
            for _w2 in (0.1, 0.2, 0.35, 0.5, 1.0):  # the shortlist's term in library-std units, not relative
                VARIANTS[f"{_cn}_p{int(_p)}_a{_w1}_abs{_w2}"] = (_cols, _p, _w1, _w2, "abs")
            for _w2 in (0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 4.0):  # unscaled: leg lengths (speeds times la.TIME)
                VARIANTS[f"{_cn}_p{int(_p)}_a{_w1}_phys{_w2}"] = (_cols, _p, _w1, _w2, "phys")
                for _u in (3, 5, 10):  # the description's nearest _u added to the shortlist
                    VARIANTS[f"{_cn}_p{int(_p)}_a{_w1}_phys{_w2}_u{_u}"] = (_cols, _p, _w1, _w2, "phys", _u)


def load(name):
    """(items, {"full": feats, crop: feats}, protocol kind) of a cached set."""
    if name == "rigs":
        items, feats = pickle.load(open(os.path.join(OUT, f"rigset_features_{cm.FEATURES}.pkl"), "rb"))
        return items, {"full": feats}, "rigs"
    items = pickle.load(open(os.path.join(OUT, f"{name}_items.pkl"), "rb"))
    feats = pickle.load(open(os.path.join(OUT, f"{name}_features_{cm.FEATURES}.pkl"), "rb"))
    return items, feats, "loao" if name == "hdm05" else "loo"


class SetRun:
    """One set's first stage (full and crops) and memoized DTW, shared by every variant."""

    def __init__(self, name, base="default"):
        self.name = name
        self.items, self.feats, self.kind = load(name)
        settings, self.k, self.band, self.free, self.mix = vs.VARIANTS[base]
        self.E = vs.entries(self.feats["full"], settings)
        self.D1 = vs.first_matrix(self.E, self.E)
        self.crops = {}
        for crop in (("start", 0.1), ("end", 0.1)):
            if crop in self.feats:
                Q = vs.entries(self.feats[crop], settings)
                self.crops[crop[0]] = (Q, vs.first_matrix(Q, self.E), self.feats[crop])
        self._d2 = {}
        labels = [it.label for it in self.items]
        if self.kind == "rigs":
            cnt = Counter(labels)
            self.prot = [(q, [j for j in range(len(labels)) if j != q]) for q in range(len(labels))
                         if cnt[labels[q]] >= 2]
        else:
            self.prot = cm.protocol(self.items, self.kind)

    def d2(self, tag, q, j, Q):
        key = (tag, q, j)
        if key not in self._d2:
            self._d2[key] = ls.rerank(Q[q], [self.E[j]], self.band, self.free)[0]
        return self._d2[key]

    def order(self, tag, Q, D1row, q, cand, Dd_row, w1, w2):
        cand = np.asarray(cand)
        b = D1row[cand] / max(D1row[cand].mean(), 1e-12)
        if w1:
            b = b + w1 * Dd_row[cand] / max(Dd_row[cand].mean(), 1e-12)
        o = cand[np.argsort(b, kind="stable")]
        h = o[:self.k]
        if self.union:  # the description's nearest join the shortlist
            near = cand[np.argsort(Dd_row[cand], kind="stable")][:self.union]
            h = np.array(list(dict.fromkeys(list(h) + list(near))))
            o = np.concatenate([h, [j for j in o if j not in set(h)]])
        d2 = np.array([self.d2(tag, q, j, Q) for j in h])
        s = ls.combine(D1row[h], d2, self.mix)
        if w2:
            dd = Dd_row[h]
            s = s + w2 * (dd if self.absolute else dd / max(dd.mean(), 1e-12))
        return np.concatenate([h[np.argsort(s, kind="stable")], o[self.k:]])

    def evaluate(self, variant):
        cols, P, w1, w2 = variant[:4]
        self.absolute = len(variant) > 4 and variant[4] in ("abs", "phys")
        self.union = variant[5] if len(variant) > 5 else 0
        physical = len(variant) > 4 and variant[4] == "phys"
        cols = list(cols)
        X = np.array([describe(f, P) for f in self.feats["full"]])[:, cols]
        scale = np.maximum(X.std(axis=0), 1e-9)
        if physical:  # leg lengths; speeds as the distance in la.TIME (the action part's rule)
            scale = np.array([1.0 / la.TIME if c in (0, 1, 2, 5, 8, 9, 10, 11, 12, 13, 14) else 1.0 for c in cols])

        def dist(A):
            return np.sqrt((((A[:, None] - X[None]) / scale) ** 2).mean(-1))
        Dd = dist(X)
        labels = [it.label for it in self.items]
        orders = [self.order("full", self.E, self.D1[q], q, c, Dd[q], w1, w2) for q, c in self.prot]
        qs = [q for q, _ in self.prot]
        acc, mAP = cm.scores(orders, labels, qs)
        hits = sum(labels[o[0]] == labels[q] for q, o in zip(qs, orders))
        per, self.misses = cm.per_class(self.items, labels, qs, orders)
        crops = {}
        everyone = list(range(len(self.items)))
        for side, (Q, Dc, cf) in self.crops.items():
            Ddc = dist(np.array([describe(f, P) for f in cf])[:, cols])
            crops[side] = sum(self.order(side, Q, Dc[q], q, everyone, Ddc[q], w1, w2)[0] == q for q in everyone)
        return {"acc": acc, "mAP": mAP, "hits": hits, "n": len(qs), "per": per, "crops": crops}


def fmt(name, v, r):
    crops = " + ".join(str(r["crops"][s]) for s in ("start", "end") if s in r["crops"])
    per = ""
    if name == "rigs":
        per = " [" + ", ".join(f"{k} {a}/{b}" for k, (a, b) in sorted(r["per"].items(), key=lambda kv: -kv[1][1])) + "]"
    return f"{name:16s} {v:26s} {r['hits']}/{r['n']} 1-NN {r['acc']:.3f} mAP {r["mAP"]:.4f} crops {crops}{per}"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sets", default="rigs,hdm05,cmu27,cmu27_mixed,cmu_large,cmu_mixed_format")
    ap.add_argument("--variants", default="base,body_p95_a0.0_b2.0")
    ap.add_argument("--misses", action="store_true")
    ap.add_argument("--tslearn", action="store_true", help="the rig set's DTW peer (tslearn, benchmark-only)")
    ap.add_argument("--base", default="default", help="the local search's variant (variants.py) under the term")
    args = ap.parse_args(argv)
    names = [v for pat in args.variants.split(",") for v in VARIANTS
             if v == pat or (pat.endswith("*") and v.startswith(pat[:-1]))]
    for s in args.sets.split(","):
        run = SetRun(s, args.base)
        if args.tslearn and s == "rigs":  # the peer in the same run: 1-NN DTW on the 11 key points (``rigs.py``'s)
            from tslearn.metrics import dtw as ts_dtw
            seqs, labels = [f["pose"] for f in run.feats["full"]], [it.label for it in run.items]
            hits = sum(labels[min(c, key=lambda j: ts_dtw(seqs[q], seqs[j]))] == labels[q] for q, c in run.prot)
            print(f"{s:16s} DTW on the key points (tslearn, 30 Hz, no band) {hits}/{len(run.prot)}", flush=True)
        for v in names:
            print(fmt(s, args.base + ":" + v, run.evaluate(VARIANTS[v])), flush=True)
            if args.misses:
                print("\n".join("   - " + m for m in run.misses))
    return 0


if __name__ == "__main__":
    sys.exit(main())
