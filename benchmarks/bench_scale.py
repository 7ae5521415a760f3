"""The default search at library scale: a library file (``core/index/local_library.py``) of N synthetic-but-realistic
clips, queried warm through the CLI's core path, opened in a fresh process, against the exact first stage.

    .venv/bin/python benchmarks/bench_scale.py --clips N [--data FOLDER] [--queries Q] [--recall-queries R] [--json]

The clips: the local entries (``local.index_entry``) of real clips (``tests/data``' BVH files, plus the BVH files of
``--data`` when given), each copy a random contiguous crop (60-100 % of its windows and of its pose sequence) with
Gaussian noise (a random level, 0.01-0.15 of the windows' RMS), so copies are distinct; they are written straight
into one library file (``write_library``, streamed: each copy regenerated from its seed, never all in memory).
Prints JSON: ``clips``; ``query_ms`` (median over Q queries: the first stage with the prefilter, ``keep`` =
``local.PREFILTER``, over the memory-mapped file, plus the DTW re-rank of the shortlist, what ``rank_local`` runs);
``exact_query_ms`` (the same without the prefilter: the baseline, same run) and ``speedup``; ``open_s``
(``open_library`` + its stack in a fresh process); ``bytes_per_clip_disk``; ``bytes_per_clip_memory`` (the fresh
process' RSS growth after opening and one query, per clip); ``peak_rss_mb`` (this process); ``recall_at_10``: the
share of the exact search's top 10 (the two stages, no prefilter) found in the top 10 with the prefilter, over R
queries (each a new noisy crop of a random clip).
"""

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time

import numpy as np

from _common import ROOT

from blender_shapesig.core.index import local  # noqa: E402
from blender_shapesig.core.index.local_library import open_library, write_library  # noqa: E402
from blender_shapesig.core.io import sources  # noqa: E402


def base_entries(folders):
    out = []
    for folder in folders:
        for dirpath, _, files in os.walk(folder):
            for f in sorted(files):
                if not f.lower().endswith(".bvh"):
                    continue
                try:
                    clip = sources.read_one(sources.ClipSpec(os.path.join(dirpath, f)))
                    out.append(local.index_entry(clip))
                except Exception:  # noqa: BLE001 - clips the local features refuse are left out
                    pass
    return out


def copy(bases, seed):
    """One synthetic clip: a noisy random crop of a base entry (deterministic in ``seed``)."""
    rng = np.random.default_rng(seed)
    b = bases[rng.integers(len(bases))]
    W, Q = np.asarray(b["windows"], np.float32), np.asarray(b["sequence"], np.float32)
    f = rng.uniform(0.6, 1.0)
    nw, nq = max(2, int(len(W) * f)), max(4, int(len(Q) * f))
    w0, q0 = rng.integers(len(W) - nw + 1), rng.integers(len(Q) - nq + 1)
    s = rng.uniform(0.01, 0.15)
    W = W[w0:w0 + nw] + s * np.sqrt((W ** 2).mean()) * rng.standard_normal((nw, W.shape[1]))
    Q = Q[q0:q0 + nq] + s * np.sqrt((Q ** 2).mean()) * rng.standard_normal((nq, Q.shape[1]))
    return {"name": f"c{seed}", "windows": W.astype(np.float16), "sequence": Q.astype(np.float16),
            "path": np.asarray(b["path"], np.float32)}


class Lazy:
    """A file's entries regenerated on each iteration (the writer reads them in several passes)."""

    def __init__(self, bases, seeds):
        self.bases, self.seeds = bases, seeds

    def __iter__(self):
        return (copy(self.bases, s) for s in self.seeds)


def build(fn, bases, n, per_file=100):
    files = []
    for f0 in range(0, n, per_file):
        seeds = range(f0, min(n, f0 + per_file))
        meta = {"clips": [{"name": f"c{s}", "frames": 0, "bones": 0, "trimmed": []} for s in seeds]}
        files.append((f"file{f0}", 0, 0, meta, Lazy(bases, seeds)))
    with open(fn, "wb") as f:
        write_library(f, files, "bench")


def ranked(q, lib, block, entries_of, keep, top=10):
    d1 = local.first_stage(q, block, keep=keep)
    head = np.argsort(d1, kind="stable")[:local.SHORTLIST]
    d2 = local.rerank(q, [entries_of(i) for i in head])
    score = local.combine(d1[head], d2)
    return [int(head[k]) for k in np.argsort(score, kind="stable")[:top]]


def open_and_query(fn):
    """In a fresh process: open the file, its stack, one query; print seconds and RSS growth."""
    code = f"""
import json, time, resource, sys
sys.path.insert(0, {str(ROOT)!r})
def rss():
    return int(open('/proc/self/statm').read().split()[1]) * 4096
import numpy as np
from blender_shapesig.core.index import local
from blender_shapesig.core.index.local_library import open_library
r0 = rss()
t0 = time.perf_counter()
lib = open_library({fn!r}); block = lib.stack()
t1 = time.perf_counter() - t0
e = lib.entry(lib.files[0][3]["clips"][0], lib.files[0][4][0])
local.first_stage(e, block, keep=local.PREFILTER)
print(json.dumps({{"open_s": t1, "rss": rss() - r0}}))
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--clips", type=int, default=1000)
    ap.add_argument("--data", help="a folder of BVH clips for more base motions (e.g. the CMU set)")
    ap.add_argument("--queries", type=int, default=20)
    ap.add_argument("--recall-queries", type=int, default=200)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    bases = base_entries([ROOT / "tests" / "data"] + ([args.data] if args.data else []))
    with tempfile.TemporaryDirectory() as tmp:
        fn = os.path.join(tmp, "local_pack.bin")
        t0 = time.perf_counter()
        build(fn, bases, args.clips)
        build_s = time.perf_counter() - t0
        lib = open_library(fn)
        block = lib.stack()
        rows = [(m, r) for *_, meta, rs in lib.files for m, r in zip(meta["clips"], rs)]
        entries_of = lambda i: lib.entry(*rows[i])  # noqa: E731
        rng = np.random.default_rng(12345)
        queries = [copy(bases, int(s)) for s in rng.integers(10 ** 9, 2 * 10 ** 9, max(args.queries,
                                                                                        args.recall_queries))]
        ranked(queries[0], lib, block, entries_of, local.PREFILTER)  # warm: page cache, DTW kernel
        fast, exact = [], []
        for q in queries[:args.queries]:
            t = time.perf_counter()
            ranked(q, lib, block, entries_of, local.PREFILTER)
            fast.append(time.perf_counter() - t)
        for q in queries[:min(3, args.queries)]:
            t = time.perf_counter()
            ranked(q, lib, block, entries_of, None)
            exact.append(time.perf_counter() - t)
        hits = []
        for q in queries[:args.recall_queries]:
            a = set(ranked(q, lib, block, entries_of, None))
            b = set(ranked(q, lib, block, entries_of, local.PREFILTER))
            hits.append(len(a & b) / len(a))
        fresh = open_and_query(fn)
        size = os.path.getsize(fn)
    out = {"clips": args.clips, "query_ms": 1000 * float(np.median(fast)),
           "exact_query_ms": 1000 * float(np.median(exact)), "speedup": float(np.median(exact) / np.median(fast)),
           "open_s": fresh["open_s"], "bytes_per_clip_disk": size / args.clips,
           "bytes_per_clip_memory": fresh["rss"] / args.clips,
           "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
           "recall_at_10": float(np.mean(hits)), "recall_queries": len(hits), "base_clips": len(bases),
           "build_s": build_s}
    print(json.dumps(out) if args.json else "\n".join(f"{k}: {v}" for k, v in out.items()))


if __name__ == "__main__":
    main()
