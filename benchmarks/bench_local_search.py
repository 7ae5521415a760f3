"""The default search (``local``) over 1,000 indexed clips: one query, warm, through ``core.search.rank_clips`` (what
``rank`` and Find Similar run), against a 1-NN DTW on joint positions over the same clips (tslearn, the usual
baseline); the index's bytes per clip on disk.

    .venv/bin/python benchmarks/bench_local_search.py --hdm05 PATH/TO/hdm05 --cmu PATH/TO/cmu [--n 1000]
        [--queries 20] [--json OUT]

The library: the HDM05 set (tools/eval_sets/hdm05.csv) and the CMU set (tools/eval_sets/cmu_large.csv), read
through ``evaluation.entry_loader`` (the comparison space), repeated to ``--n`` clips, each copy with a small
random rotation of every joint in every frame (0.01 rad: other data, another cache key). The index is built
once into a fresh cache folder (``build_index``, timed per clip); the query time is the median over ``--queries``
queries of ``rank_clips(query, library, cache=...)`` with every entry in the store's memory (a warm Blender
session or a second ``rank`` over the same library in one process). The baseline: ``tslearn.metrics.dtw`` of the
query's joint positions (the heads of the canonical joints every clip's rig has, relative to the hips, leg
lengths, 30 samples/s) to each library clip's, timed over all ``--n`` clips for 3 queries. tslearn is a benchmark-only
requirement (benchmarks/requirements.txt).
"""

import argparse
import json
import os
import sys
import tempfile
import time

import numpy as np

from _common import ROOT, timed, write_json

from blender_shapesig import evaluation as ev  # noqa: E402
from blender_shapesig.core import search as index  # noqa: E402
from blender_shapesig.core.clip.clip import Clip  # noqa: E402
from blender_shapesig.core.search.local import features as local  # noqa: E402

SETS = (("hdm05", "hdm05.csv"), ("cmu", "cmu_large.csv"))


def load(paths):
    clips = []
    for name, csv in SETS:
        rows = ev.read_index(os.path.join(ROOT, "tools", "eval_sets", csv))
        clips += ev.load_entries(rows, ev.entry_loader(paths[name]))
    return clips


def perturbed(clips, n, seed=0):
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(seed)
    out = []
    for k in range(n):
        c = clips[k % len(clips)]
        if k >= len(clips):
            F, J = c.rotations.shape[:2]
            noise = Rotation.from_rotvec(rng.normal(scale=0.01, size=(F * J, 3))).as_matrix().reshape(F, J, 3, 3)
            c = Clip(name=f"{c.name}~{k}", bones=c.bones, rotations=noise @ c.rotations, fps=c.fps,
                     root_translation=c.root_translation, meta=dict(c.meta), source=c.source)
        out.append(c)
    return out


def joint_positions(heads, fps, names):
    """The baseline's sequence: the heads of ``names`` relative to the hips, at 30 samples/s."""
    P = np.stack([heads[j] for j in names], axis=1) - heads["hips"][:, None]
    P = local._resample(P, fps, local.RATE)
    return P.reshape(len(P), -1)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--hdm05", required=True, help="the HDM05 folder (its index.csv's paths are relative to it)")
    ap.add_argument("--cmu", required=True, help="the CMU folder (tools/eval_sets' paths are relative to it)")
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--queries", type=int, default=20)
    ap.add_argument("--json", metavar="OUT")
    args = ap.parse_args(argv)

    t0 = time.perf_counter()
    base = load({"hdm05": args.hdm05, "cmu": args.cmu})
    clips = perturbed(base, args.n)
    t_read = time.perf_counter() - t0
    items = index.clip_items(clips)
    rng = np.random.default_rng(1)
    queries = [clips[i] for i in rng.choice(len(clips), size=args.queries, replace=False)]

    with tempfile.TemporaryDirectory() as folder:
        cache = index.SignatureCache(folder)
        t0 = time.perf_counter()
        built = index.build_index(items, cache=cache)
        t_build = time.perf_counter() - t0
        skey = local.settings_key()
        local_bytes = [os.path.getsize(cache.local.file_for(it.key, skey)) for it in items]
        sig_bytes = [os.path.getsize(cache.file_for(it.key, index.DEFAULT_LEVEL)) for it in items]
        ranked = {}

        def one(q):
            ranked[q.name] = index.rank_clips(q, items, cache=cache, top=10)

        for q in queries[:2]:
            one(q)  # warm: the query entries, numba, the stacked windows
        per_query = [timed(lambda q=q: one(q), repeat=3, warmup=0).wall_min for q in queries]
        sim = [timed(lambda q=q: index.rank_clips(q, items, cache=cache, metric="sim", top=10), repeat=3,
                     warmup=1).wall_min for q in queries[:5]]

    from tslearn.metrics import dtw as ts_dtw

    heads = [local.rig_positions(c)[0] for c in clips]
    shared = sorted(set.intersection(*(set(h) for h in heads)) - {"hips"})  # the joints every rig has
    seqs = [joint_positions(h, c.fps, shared) for h, c in zip(heads, clips)]
    ts_dtw(seqs[0], seqs[1])
    by_name = {c.name: i for i, c in enumerate(clips)}

    def dtw_1nn(q):
        a = seqs[by_name[q.name]]
        return int(np.argmin([ts_dtw(a, b) for b in seqs]))

    dtw = timed(lambda: dtw_1nn(queries[0]), repeat=3, warmup=0)
    t_query = float(np.median(per_query))
    out = {
        "library": {"clips": len(clips), "distinct_sources": len(base), "seconds_read": round(t_read, 2),
                    "mean_seconds": float(np.mean([c.frames / c.fps for c in base]))},
        "index": {"build_seconds_per_clip": t_build / len(clips), "errors": len(built["errors"]),
                  "local_bytes_per_clip_mean": float(np.mean(local_bytes)),
                  "local_bytes_per_clip_max": int(np.max(local_bytes)),
                  "signature_bytes_per_clip_mean": float(np.mean(sig_bytes))},
        "query": {"local_ms_median": 1000 * t_query, "local_ms_max": 1000 * float(np.max(per_query)),
                  "sim3_ms_median": 1000 * float(np.median(sim)), "queries": len(queries),
                  "top1_is_itself": sum(ranked[q.name][0].name == q.name for q in queries)},
        "baseline": {"tslearn_dtw_1nn_ms": 1000 * dtw.wall_min, "tslearn": __import__("tslearn").__version__,
                     "joints": len(shared)},
        "ratio_dtw_over_local": dtw.wall_min / t_query,
    }
    if args.json:
        out = write_json(args.json, out)
    print(json.dumps(out, indent=2, default=float))
    return 0


if __name__ == "__main__":
    sys.exit(main())
