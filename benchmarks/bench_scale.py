"""The default search at library scale: a library file (``core/search/local/library.py``) of N synthetic-but-realistic
clips, queried warm through the CLI's core path, opened in a fresh process, against the exact first stage.

    .venv/bin/python benchmarks/bench_scale.py --clips N [--data FOLDER] [--queries Q] [--recall-queries R] [--json]

The clips: the local entries (``local.index_entry``) of real clips (``tests/data``' BVH files, plus the BVH files of
``--data`` when given), each copy a random contiguous crop (60-100 % of its windows and of its pose sequence) with
Gaussian noise (a random level, 0.01-0.15 of the windows' RMS), so copies are distinct, with their base clip's joint
lists (as the cache stores them); they are written straight into one library file (``write_library``, streamed: each
copy regenerated from its seed, never all in memory); a copy's whole-take signature is its base's with the same
noise level. Prints JSON: ``clips``; ``query_ms`` and ``query_cpu_ms``
(median wall and CPU time over Q queries: the first stage with the prefilter, ``keep`` = ``local.PREFILTER`` (or
``PREFILTER_SHARE`` of the clips), over the memory-mapped file, plus the DTW re-rank of the shortlist and the twin
rule (``local.shortlisted``, ``local.shortlist_scores``), what ``rank_local`` runs; numba not loaded, as in a
command-line ``rank``); the baselines of the same run:
``previous_query_ms`` / ``_cpu_ms`` (the query as it ran before, kept here: run by run, one DTW at a time;
``vs_previous_cpu`` the ratio, ``same_top10_as_previous``) and ``exact_query_ms`` / ``_cpu_ms`` (no prefilter;
``speedup_cpu``); ``open_s`` (``open_library`` + its stack in a fresh process); ``bytes_per_clip_disk``;
``bytes_per_clip_memory`` (the fresh process' RSS growth after opening and one query, per clip); ``peak_rss_mb`` (this
process); ``recall_at_10``: the share of the exact search's top 10 (the two stages, no prefilter) found in the top 10
with the prefilter, over R queries (each a new noisy crop of a random clip).
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

from blender_shapesig.core.blas import one_blas_thread  # noqa: E402
from blender_shapesig.core.search.local import description, features as local, dtw as local_dtw, take  # noqa: E402
from blender_shapesig.core.search.local.entry import JOINT_LISTS, LocalEntry  # noqa: E402
from blender_shapesig.core.search.local.library import open_library, write_library  # noqa: E402
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
                    e = local.index_entry(clip)
                    # the joint lists the cache keeps with each clip (local_rank's entries): the header's size
                    e.joints, e.still = tuple(clip.bones), tuple(clip.still_bones())
                    e.rig_joints = tuple(clip.meta.get("rig_joints") or ())
                    out.append(e)
                except Exception:  # noqa: BLE001 - clips the local features refuse are left out
                    pass
    return out


def base_of(seed, n):
    return int(np.random.default_rng(seed).integers(n))


def copy(bases, seed):
    """One synthetic clip: a noisy random crop of a base entry (deterministic in ``seed``)."""
    rng = np.random.default_rng(seed)
    b = bases[base_of(seed, len(bases))]
    rng.integers(len(bases))  # (the draw that picked the base; the same copies as before)
    W, Q = np.asarray(b.windows, np.float32), np.asarray(b.sequence, np.float32)
    f = rng.uniform(0.6, 1.0)
    nw, nq = max(2, int(len(W) * f)), max(4, int(len(Q) * f))
    w0, q0 = rng.integers(len(W) - nw + 1), rng.integers(len(Q) - nq + 1)
    s = rng.uniform(0.01, 0.15)
    W = W[w0:w0 + nw] + s * np.sqrt((W ** 2).mean()) * rng.standard_normal((nw, W.shape[1]))
    Q = Q[q0:q0 + nq] + s * np.sqrt((Q ** 2).mean()) * rng.standard_normal((nq, Q.shape[1]))
    T = np.asarray(b.take, np.float32)
    T = T + s * np.sqrt((T ** 2).mean()) * rng.standard_normal(T.shape)
    what = None if b.describe is None else (b.describe * rng.uniform(1 - s, 1 + s, b.describe.shape)).astype(np.float32)
    return LocalEntry(W.astype(np.float16), Q.astype(np.float16), np.asarray(b.path, np.float32), describe=what,
                      take=T, take_mask=b.take_mask, seconds=np.float32(b.seconds * f), name=f"c{seed}")


def copy_seconds(bases, seed):
    """``copy(bases, seed).seconds`` without making the copy (the same draws)."""
    rng = np.random.default_rng(seed)
    b = bases[base_of(seed, len(bases))]
    rng.integers(len(bases))
    return float(b.seconds * rng.uniform(0.6, 1.0))


class Lazy:
    """A file's entries regenerated on each iteration (the writer reads them in several passes)."""

    def __init__(self, bases, seeds):
        self.bases, self.seeds = bases, seeds

    def __iter__(self):
        return (copy(self.bases, s) for s in self.seeds)


def _lists(e):
    return {k: list(getattr(e, k)) for k in JOINT_LISTS}


def build(fn, bases, n, per_file=100):
    files = []
    for f0 in range(0, n, per_file):
        seeds = range(f0, min(n, f0 + per_file))
        meta = {"clips": [dict(name=f"c{s}", frames=0, bones=0, trimmed=[], seconds=copy_seconds(bases, s),
                               **_lists(bases[base_of(s, len(bases))])) for s in seeds]}
        files.append((f"file{f0}", 0, 0, meta, Lazy(bases, seeds)))
    with open(fn, "wb") as f:
        write_library(f, files, "bench")


def ranked(q, lib, block, entries_of, keep, top=10, previous=False, share=local.PREFILTER_SHARE):
    d1 = previous_first_stage(q, block, keep=keep) if previous else local.first_stage(q, block, keep=keep, share=share)
    head = (np.argsort(d1, kind="stable")[:local.SHORTLIST] if previous else  # as rank_local: a striking query's
            local.shortlisted(q, None, d1, local.SHORTLIST, block["descriptions"]))  # nearest by the arms join
    cands = [entries_of(i) for i in head]
    if previous:
        # the same rule as shortlist_scores (what happens in the clips, the twin) on the DTW as it ran before
        score = local.combine(d1[head], previous_rerank(q, cands)) + description.WEIGHT * \
            description.description_distances(q, cands)
        score = take.twin_first(q, cands, score, lambda picked: local.held_distances(q, picked))
    else:
        score, _ = local.shortlist_scores(q, cands, d1[head])
    return [int(head[k]) for k in np.argsort(score, kind="stable")[:top]]


# ---- the baseline: the query as it ran before (26 Nov, commit 8d9f6a0; the same keep), the same numbers by other
# means: the exact pass run by run of the kept entries' contiguous rows (one product per run), the prefilter
# recomputing its norms and taking the nearest of k by a reduction over the short axis, one numpy DTW per candidate
def _runs(starts, ends, idx):
    cuts = np.flatnonzero(starts[idx][1:] != ends[idx][:-1]) + 1
    return np.split(idx, cuts)


def previous_first_stage(query, lib, keep=None):
    q = np.asarray(query.windows, np.float32)
    qn = (q * q).sum(1)[:, None]
    starts, ends = lib["starts"], lib["ends"]
    out, idx, coarse = np.full(len(starts), np.inf), np.arange(len(starts)), None
    with one_blas_thread():
        keep = None if keep is None else max(keep, int(np.ceil(local.PREFILTER_SHARE * len(starts))))
        if keep is not None and len(starts) > keep:
            C = np.asarray(lib["coarse"], np.float32)
            k = C.shape[1]
            c = local.coarse_windows(query.windows, 4 * k)
            C = C.reshape(-1, C.shape[2])
            D = (c * c).sum(1)[:, None] + (C * C).sum(1)[None] - 2.0 * (c @ C.T)
            D = np.sqrt(np.maximum(D, 0.0)).reshape(len(c), -1, k)
            coarse = 0.5 * (D.min(axis=2).mean(axis=0) + D.min(axis=0).mean(axis=1))
            idx = np.argpartition(coarse, keep)[:keep]
        idx = idx[np.argsort(starts[idx], kind="stable")]
        for run in _runs(starts, ends, idx):
            r0, r1 = int(starts[run[0]]), int(ends[run[-1]])
            D = qn + np.asarray(lib["norms"][r0:r1], np.float32)[None] \
                - 2.0 * (q @ np.asarray(lib["windows"][r0:r1], np.float32).T)
            np.sqrt(np.maximum(D, 0.0, out=D), out=D)
            rel = starts[run] - r0
            out[run] = 0.5 * (np.minimum.reduceat(D, rel, axis=1).mean(axis=0)
                              + np.add.reduceat(D.min(axis=0), rel) / (ends[run] - starts[run]))
    if coarse is not None:
        rest = np.isinf(out)
        out[rest] = out[~rest].max() + coarse[rest]
    return out


def previous_rerank(query, cands):
    a = np.asarray(query.sequence, np.float64)
    out = []
    for c in cands:
        b = np.asarray(c.sequence, np.float64)
        d = local_dtw._dtw_numpy(a, b, max(local._band(len(a), len(b)), 1), min(int(local.FREE * len(a)), len(a) - 1),
                             min(int(local.FREE * len(b)), len(b) - 1))
        out.append(d / np.sqrt(len(a) + len(b)))
    return np.array(out)


def timed(fn, queries):
    """(median wall ms, median CPU ms) of fn(q) over the queries."""
    wall, cpu = [], []
    for q in queries:
        t, c = time.perf_counter(), time.process_time()
        fn(q)
        wall.append(time.perf_counter() - t)
        cpu.append(time.process_time() - c)
    return 1000 * float(np.median(wall)), 1000 * float(np.median(cpu))


def open_and_query(fn):
    """In a fresh process: open the file, its stack, one query; print seconds and RSS growth."""
    code = f"""
import json, time, resource, sys
sys.path.insert(0, {str(ROOT)!r})
def rss():
    return int(open('/proc/self/statm').read().split()[1]) * 4096
import numpy as np
from blender_shapesig.core.search.local import features as local
from blender_shapesig.core.search.local.library import open_library
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
    ap.add_argument("--keeps", help="also recall@10 and CPU ms a query when the prefilter keeps exactly these "
                    "numbers of clips (comma-separated), over the recall queries")
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
        ranked(queries[0], lib, block, entries_of, local.PREFILTER)  # warm: page cache, the library's norms
        fast = timed(lambda q: ranked(q, lib, block, entries_of, local.PREFILTER), queries[:args.queries])
        before = timed(lambda q: ranked(q, lib, block, entries_of, local.PREFILTER, previous=True),
                       queries[:args.queries])
        exact = timed(lambda q: ranked(q, lib, block, entries_of, None), queries[:min(3, args.queries)])
        same = all(ranked(q, lib, block, entries_of, local.PREFILTER)
                   == ranked(q, lib, block, entries_of, local.PREFILTER, previous=True) for q in queries[:args.queries])
        truth = [set(ranked(q, lib, block, entries_of, None)) for q in queries[:args.recall_queries]]
        hits = [len(a & set(ranked(q, lib, block, entries_of, local.PREFILTER))) / len(a)
                for q, a in zip(queries, truth)]
        keeps = {}
        for k in [int(x) for x in args.keeps.split(",")] if args.keeps else []:
            recall, cpu = [], []
            for q, a in zip(queries, truth):
                c = time.process_time()
                got = set(ranked(q, lib, block, entries_of, k, share=0.0))
                cpu.append(time.process_time() - c)
                recall.append(len(got & a) / len(a))
            keeps[k] = {"recall_at_10": float(np.mean(recall)), "query_cpu_ms": 1000 * float(np.median(cpu))}
        fresh = open_and_query(fn)
        size = os.path.getsize(fn)
    out = {"clips": args.clips, "query_ms": fast[0], "query_cpu_ms": fast[1],
           "previous_query_ms": before[0], "previous_query_cpu_ms": before[1], "vs_previous_cpu": before[1] / fast[1],
           "same_top10_as_previous": same,
           "exact_query_ms": exact[0], "exact_query_cpu_ms": exact[1], "speedup_cpu": exact[1] / fast[1],
           "open_s": fresh["open_s"], "bytes_per_clip_disk": size / args.clips,
           "bytes_per_clip_memory": fresh["rss"] / args.clips,
           "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
           "recall_at_10": float(np.mean(hits)), "recall_queries": len(hits), "base_clips": len(bases),
           "build_s": build_s, **({"keeps": keeps} if keeps else {})}
    print(json.dumps(out) if args.json else "\n".join(f"{k}: {v}" for k, v in out.items()))


if __name__ == "__main__":
    main()
