#!/usr/bin/env python
"""Speed of the local search (issue 29): one query over a library of N indexed clips (HDM05's entries repeated),
warm, against the 1-NN DTW baseline (tslearn) on the same clips' joint positions; the index's size per clip.

  .venv/bin/python experiments/local_search/timing.py --data PATH/TO/hdm05 [--out out/local_search] [--n 1000]
      [--variant default] [--queries 20] [--dtw-sample 100]

The DTW baseline is timed on ``--dtw-sample`` library clips per query and scaled to N (it is linear in N).
"""

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common as cm  # noqa: E402
import variants as vs  # noqa: E402
from blender_shapesig.core.search.local import features as ls  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", required=True)
    ap.add_argument("--out", default=os.path.join("out", "local_search"))
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--variant", default="default")
    ap.add_argument("--queries", type=int, default=20)
    ap.add_argument("--dtw-sample", type=int, default=100)
    args = ap.parse_args(argv)
    items = cm.load_hdm05(args.data)
    feats = cm.set_features(items, os.path.join(args.out, f"hdm05_features_{cm.FEATURES}.pkl"))["full"]
    settings, k, band, free, mix = vs.VARIANTS[args.variant]
    t0 = time.perf_counter()
    E = vs.entries(feats, settings)
    t_index = (time.perf_counter() - t0) / len(E)
    lib = [E[i % len(E)] for i in range(args.n)]
    stacked = ls.stack(lib)
    seqs = [feats[i % len(feats)]["all"] for i in range(args.n)]
    rng = np.random.default_rng(0)
    queries = rng.choice(len(E), size=args.queries, replace=False)

    def one(q):
        d1 = ls.first_stage(E[q], stacked)
        head = np.argsort(d1, kind="stable")[:k]
        d2 = ls.rerank(E[q], [lib[j] for j in head], band, free)
        return head[np.argsort(ls.combine(d1[head], d2, mix), kind="stable")]

    one(queries[0])  # warm: numba compilation, the projection
    t0 = time.perf_counter()
    for q in queries:
        one(q)
    t_query = (time.perf_counter() - t0) / len(queries)
    t0 = time.perf_counter()
    for q in queries:
        ls.first_stage(E[q], stacked)
    t_first = (time.perf_counter() - t0) / len(queries)

    from tslearn.metrics import dtw as ts_dtw
    ts_dtw(seqs[0], seqs[1])
    t0 = time.perf_counter()
    for q in queries[:5]:
        for j in range(args.dtw_sample):
            ts_dtw(feats[q]["all"], seqs[j])
    t_dtw = (time.perf_counter() - t0) / 5 * args.n / args.dtw_sample
    sizes = np.array([ls.entry_bytes(e) for e in E])
    print(f"variant {args.variant}: query over {args.n} clips {1000 * t_query:.1f} ms warm "
          f"(first stage {1000 * t_first:.1f} ms, shortlist {k}); tslearn DTW 1-NN over {args.n} clips "
          f"{1000 * t_dtw:.0f} ms ({t_dtw / t_query:.0f}x); indexing {1000 * t_index:.1f} ms per clip from features; "
          f"index per clip mean {sizes.mean() / 1024:.1f} KB, max {sizes.max() / 1024:.1f} KB "
          f"(windows {np.mean([e['windows'].nbytes for e in E]) / 1024:.1f} KB, "
          f"sequence {np.mean([e['sequence'].nbytes for e in E]) / 1024:.1f} KB); mean clip "
          f"{np.mean([len(f['pose']) for f in feats]) / settings.rate:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
