#!/usr/bin/env python
"""The twin rule (issue 29, ``core/search/local/take.py``) measured on every set: for each query (whole clips under the
set's protocol, and the crop probes), the shortlist's candidate of the query's length (``--length``) with the nearest
whole take, its take distance over the shortlist's median, whether the current first is longer than the query, and
how well each holds the query's windows; then what the rule would do for a grid of ratios, set by set (how many
queries keep or gain a right first), and the margins: the right promotions' ratios against the wrong ones'.

  .venv/bin/python experiments/local_search/twin_rule.py --data-cmu PATH/TO/cmu --data-hdm05 PATH/TO/hdm05 \
      [--out out/local_search] [--ratios 0.4,0.45,0.5,0.55,0.6] [--length 1.08]

"Right": the same label (whole clips; the rigs' 20: the same take), the source (crops).
"""

import argparse
import dataclasses
import collections
import math
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import common as cm  # noqa: E402
import variants as vs  # noqa: E402
from blender_shapesig.core.search.local import features as ls, take  # noqa: E402

CROPS = (("start", 0.1), ("end", 0.1))
SETS = ("cmu27", "cmu27_mixed", "cmu_large", "cmu_mixed_format", "hdm05")


def _with_take(e, t):
    return dataclasses.replace(e, take=t.take, take_mask=t.take_mask, seconds=t.seconds)


def takes(items, path):
    def make():
        out = {"full": [take.take_entry(it.mapped()) for it in items]}
        for c in CROPS:
            out[c] = [take.take_entry(it.mapped(c)) for it in items]
        return out
    return cm.cached(path, make)


def rows_of(name, items, feats, T, kind, length, only=None):
    settings, K, band, free, mix = vs.VARIANTS["default"]
    E = [_with_take(e, t) for e, t in zip(vs.entries(feats["full"], settings), T["full"])]
    lib = ls.stack(E)
    out = []
    tags = [("full", E)] + [(c[0], [_with_take(e, t) for e, t in zip(vs.entries(feats[c], settings), T[c])])
                            for c in CROPS if c in feats]
    for tag, QE in tags:
        for q, cand in cm.protocol(items, kind):
            if only is not None and q >= only:
                continue
            cand = np.asarray(range(len(items)) if tag != "full" else cand)
            d1 = ls.first_stage(QE[q], lib)
            head = cand[np.argsort(d1[cand], kind="stable")][:K]
            cands = [E[j] for j in head]
            score = ls.combine(d1[head], ls.rerank(QE[q], cands, band, free), mix)
            f = int(np.argmin(score))
            g = take.take_distances(QE[q], cands)
            lengths = np.log([float(c.seconds) / float(QE[q].seconds) for c in cands])
            same = np.flatnonzero(np.abs(lengths) <= math.log(length))
            right = (lambda j: items[j].label == items[q].label) if tag == "full" else (lambda j: j == q)
            r = {"set": name, "tag": tag, "q": items[q].name, "right_first": bool(right(head[f])), "ratio": np.inf,
                 "longer": lengths[f] > math.log(length), "held_ratio": np.nan, "right_twin": None}
            if len(same):
                e = int(same[np.argmin(g[same])])
                h = ls.held_distances(QE[q], [cands[e], cands[f]])
                r.update(ratio=g[e] / np.median(g), right_twin=bool(right(head[e])), is_first=e == f,
                         held_ratio=h[0] / max(h[1], 1e-12), twin=items[head[e]].name, first=items[head[f]].name)
            out.append(r)
    return out


def rule(r, ratio):
    """Would the rule move the twin first?"""
    if r["right_twin"] is None or r.get("is_first") or not r["ratio"] < ratio:
        return False
    return not r["longer"] or r["held_ratio"] < 1.0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data-cmu", required=True)
    ap.add_argument("--data-hdm05", required=True)
    ap.add_argument("--out", default=os.path.join("out", "local_search"))
    ap.add_argument("--ratios", default="0.4,0.45,0.5,0.55,0.6")
    ap.add_argument("--length", type=float, default=math.exp(take.SAME_LENGTH))
    args = ap.parse_args(argv)
    sys.path.insert(0, os.path.join(cm.ROOT, "experiments"))
    import cmu

    rows = []
    rig, others = cm.cached(os.path.join(args.out, "rigs_items.pkl"), lambda: cmu.rig_items(args.data_cmu))
    everyone = rig + others
    rf = cm.cached(os.path.join(args.out, f"rigs_features_{cm.FEATURES}.pkl"),
                   lambda: [cm.clip_features(it.mapped()) for it in everyone])
    rT = cm.cached(os.path.join(args.out, "rigs_takes_v2.pkl"), lambda: [take.take_entry(it.mapped()) for it in everyone])
    for n in (20, len(everyone)):
        items = everyone[:n]
        for it in items:  # the same take: the label is the take; a third copy among the others counts too
            if it.label == "other":
                it.label = it.name.split(":")[1].split(".")[0]
        rows += rows_of(f"rigs{n}", items, {"full": rf[:n]}, {"full": rT[:n]}, "loo", args.length, only=20)
    for name in SETS:
        if name == "hdm05":
            items, kind = cm.load_hdm05(args.data_hdm05), "loao"
        else:
            items, kind = cm.load_eval_set(os.path.join(cm.ROOT, "tools", "eval_sets", name + ".csv"), args.data_cmu), "loo"
        feats = cm.set_features(items, os.path.join(args.out, f"{name}_features_{cm.FEATURES}.pkl"))
        rows += rows_of(name, items, feats, takes(items, os.path.join(args.out, f"{name}_takes_v2.pkl")), kind,
                        args.length)
    for ratio in (float(x) for x in args.ratios.split(",")):
        out = collections.OrderedDict()
        for r in rows:
            o = out.setdefault(f"{r['set']}/{r['tag']}", [0, 0, 0])
            o[0] += r["right_first"]
            o[1] += r["right_twin"] if rule(r, ratio) else r["right_first"]
            o[2] += 1
        print(f"ratio {ratio}: " + "  ".join(f"{k} {a}->{b}/{n}" for k, (a, b, n) in out.items()))
    fixes = sorted(r["ratio"] for r in rows if r["right_twin"] and not r["right_first"] and r["set"] == "rigs20")
    wrong = sorted(r["ratio"] for r in rows if r["right_twin"] is False and r["right_first"] and r["tag"] == "full")
    wrong_cut = sorted(r["held_ratio"] for r in rows if r["right_twin"] is False and r["right_first"]
                       and r["tag"] != "full" and r["longer"] and r["ratio"] < 0.5)
    print("same take (rigs20) moved first, take distance / median:", np.round(fixes, 3).tolist())
    print("wrong twins of whole clips, the nearest ratios:", np.round(wrong[:5], 3).tolist())
    print("crops below the ratio 0.5 whose source is first and longer: held(twin) / held(source), the lowest:",
          np.round(wrong_cut[:5], 3).tolist())
    return 0


if __name__ == "__main__":
    sys.exit(main())
