"""Signature search: index build per clip, first and repeated query, ranking speed on 1,000 cached clips,
memory per clip and recall@10 of compact representations against the exact ranking.

    .venv/bin/python benchmarks/bench_search.py [--data DIR] [--limit N] [--synthetic 1000] [--level 3]
                                                [--json OUT.json]

Clips: every .bvh under ``--data`` (default: $SHAPESIG_CMU_DATA, e.g. the Przestr CMU BVH set, one skeleton,
43 bones; else the test clips), read with Blender's importer (``core.io.sources.read``), frame 1 (rest pose) cropped.

Reference ranking: sim^n from float64 log-signatures on the moving joints (exact: still joints add only
zero coordinates, see core/search/signature/entry.py), every clip against every other. Compared by recall@10 (mean over
queries of |true top 10 ∩ top 10| / 10):
  * float32 directions (what the index stores);
  * count sketches of K buckets (the index's first stage), alone;
  * sketch candidates (pool P) re-compared exactly (what rank_clips does with ``top``);
  * level 2 instead of level 3 (a smaller, different measure).

Speed (ratios against a baseline measured in the same run, so they do not depend on the machine):
  * ranking one query against N synthetic cached clips with ``rank_clips(top=10)`` (entries in the memory
    layer of a SignatureCache), against the baseline of one float32 matrix-vector product over all N
    exact directions;
  * the index build per clip (BVH import + log-signature) and the first / repeated query over the real
    clips through a folder library (the repeated one with a new SignatureCache on the same folder, as a
    second command-line run would).
"""

import argparse
import json
import os
import pathlib
import statistics
import sys
import tempfile
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from blender_shapesig.core import search as index
from blender_shapesig.core.signatures import signatures
from blender_shapesig.core.io import sources  # noqa: E402

# a folder of CMU .bvh files (``--data`` or $SHAPESIG_CMU_DATA); the test clips by default
DEFAULT_DATA = os.environ.get("SHAPESIG_CMU_DATA", str(ROOT / "tests" / "data" / "bvh"))


def _load(path, asf=None):
    return sources.read(path, asf=asf)


def recall_at(true_order, approx_order, k=10):
    return len(set(true_order[:k]) & set(approx_order[:k])) / float(k)


def exact_directions(clips, level):
    """float64 unit log-signatures on the union of moving joints (all clips share one skeleton)."""
    from blender_shapesig.core.clip.clip import still_joints

    moving = np.zeros(clips[0].rotations.shape[1], bool)
    for c in clips:
        moving |= ~still_joints(c.rotations)
    out = []
    for c in clips:
        a = signatures.log_signature(c.rotations, level, joints=moving)
        out.append(a / np.linalg.norm(a))
    return np.array(out), int(moving.sum())


def rankings(D):
    n = D.shape[0]
    out = []
    for i in range(n):
        order = [j for j in np.argsort(D[i], kind="stable") if j != i]
        out.append(order)
    return out


def pairwise(X):
    X = np.asarray(X, np.float64)
    sq = np.sum(X * X, axis=1)
    return np.sqrt(np.maximum(sq[:, None] + sq[None, :] - 2 * X @ X.T, 0.0))


def mean_recall(ref, other, k=10):
    return float(np.mean([recall_at(r, o, k) for r, o in zip(ref, other)]))


def bench_recall(clips, level, sketch_dims, pools):
    t0 = time.perf_counter()
    U, n_moving = exact_directions(clips, level)
    t_exact = time.perf_counter() - t0
    ref = rankings(pairwise(U))
    out = {"clips": len(clips), "moving_joints": n_moving, "level": level, "coordinates": int(U.shape[1]),
           "exact_seconds": t_exact}
    out["float32"] = mean_recall(ref, rankings(pairwise(U.astype(np.float32))))
    moving = tuple(range(n_moving))
    sk = {}
    for K in sketch_dims:
        S = np.array([index.sketch(u, n_moving, moving, level, dim=K) for u in U])
        order = rankings(pairwise(S))
        sk[K] = {"recall@10": mean_recall(ref, order), "bytes_per_clip": 4 * K}
        D_exact = pairwise(U.astype(np.float32))
        for P in pools:
            two = []
            for i, o in enumerate(order):
                cand = o[:P]
                two.append(sorted(cand, key=lambda j: D_exact[i, j]))
            sk[K][f"pool{P}_recall@10"] = mean_recall(ref, two)
    out["sketch"] = sk
    if level > 2:
        U2, _ = exact_directions(clips, 2)
        out["level2_recall@10"] = mean_recall(ref, rankings(pairwise(U2)))
        out["level2_coordinates"] = int(U2.shape[1])
    return out


def bench_synthetic(n, level, moving_joints, repeat=5):
    """rank_clips(top=10) against n cached entries of one skeleton (memory layer) vs a plain matvec."""
    rng = np.random.default_rng(0)
    bones = tuple(f"b{i}" for i in range(moving_joints))
    moving = tuple(range(moving_joints))
    dim = signatures.log_signature_dim(3 * moving_joints, level)
    cache = index.SignatureCache()
    items = []
    dirs = []
    for i in range(n + 1):
        u = rng.standard_normal(dim).astype(np.float32)
        u /= np.linalg.norm(u)
        dirs.append(u)
        e = index.IndexEntry(name=f"c{i}", bones=bones, moving=moving, frames=300, level=level, norm=1.0,
                              direction=u, increments=np.zeros((299, moving_joints, 3), np.float32),
                              sketch=index.sketch(u, moving_joints, moving, level), key=f"k{i}")
        cache.put(f"k{i}", level, [e])
        items.append(index.LibraryItem(f"c{i}", f"k{i}", lambda: None))
    q, lib = items[0], items[1:]
    M = np.stack(dirs[1:])
    index.rank_clips(q, lib, level=level, top=10, cache=cache, metric="sim")  # warm-up
    t_rank, t_base, t_all = [], [], []
    for _ in range(repeat):
        t0 = time.perf_counter()
        res = index.rank_clips(q, lib, level=level, top=10, cache=cache, metric="sim")
        t_rank.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        d = np.sqrt(np.maximum(2.0 - 2.0 * (M @ dirs[0]), 0))
        np.argpartition(d, 10)[:10]
        t_base.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        index.rank_clips(q, lib, level=level, cache=cache, metric="sim")  # no top: every clip exactly
        t_all.append(time.perf_counter() - t0)
    assert len(res) == 10
    return {"clips": n, "coordinates": dim, "rank_top10_ms": 1e3 * min(t_rank),
            "exact_all_ms": 1e3 * min(t_all), "baseline_matvec_ms": 1e3 * min(t_base),
            "ratio_top10_vs_baseline": min(t_rank) / min(t_base),
            "ratio_exact_all_vs_baseline": min(t_all) / min(t_base), "compared_exactly": res.stats["compared"]}


def bench_real(files, level):
    """First (cold) and repeated (warm, new cache object on the same folder) queries over the files."""
    with tempfile.TemporaryDirectory() as tmp:
        lib = index.folder_library(files, start=2)
        query = lib[0]
        cache = index.SignatureCache(tmp)
        per = []

        def progress(i, n, last=[time.perf_counter()]):
            now = time.perf_counter()
            if i:
                per.append(now - last[0])
            last[0] = now

        t0 = time.perf_counter()
        first = index.rank_clips(query, lib[1:], level=level, top=10, cache=cache, progress=progress, metric="sim")
        t_first = time.perf_counter() - t0
        t0 = time.perf_counter()
        second = index.rank_clips(query, index.folder_library(files, start=2)[1:], level=level,
                                   top=10, cache=index.SignatureCache(tmp), metric="sim")
        t_second = time.perf_counter() - t0
        t0 = time.perf_counter()
        third = index.rank_clips(query, lib[1:], level=level, top=10, cache=cache, metric="sim")
        t_third = time.perf_counter() - t0
        files_n, size = cache.disk_usage()
        assert [r.name for r in first] == [r.name for r in second] == [r.name for r in third]
        return {"clips": len(lib), "first_query_s": t_first, "repeated_query_new_cache_s": t_second,
                "repeated_query_same_cache_s": t_third, "index_s_per_clip_median": statistics.median(per),
                "index_s_per_clip_mean": statistics.mean(per), "disk_bytes_per_clip": size / max(files_n, 1),
                "second_query_misses": second.stats["misses"], "second_query_disk_hits": second.stats["disk_hits"],
                "top10": [(r.name, round(r.distance, 4)) for r in first]}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=DEFAULT_DATA)
    ap.add_argument("--limit", type=int, default=0, help="use the first N files only (0: all)")
    ap.add_argument("--synthetic", type=int, default=1000)
    ap.add_argument("--level", type=int, default=index.DEFAULT_LEVEL)
    ap.add_argument("--sketch-dims", type=int, nargs="+", default=[512, 1024, 2048, 4096, 8192, 16384])
    ap.add_argument("--pools", type=int, nargs="+", default=[20, 30])
    ap.add_argument("--json")
    args = ap.parse_args(argv)

    report = {"level": args.level, "sketch_dim": index.SKETCH_DIM, "exact_pool": index.EXACT_POOL}
    files = sorted(str(p) for p in pathlib.Path(args.data).rglob("*.bvh"))
    if args.limit:
        files = files[: args.limit]
    if files:
        report["real"] = bench_real(files, args.level)
        print(json.dumps(report["real"], indent=1), flush=True)
        clips = [c.crop(start=2) for f in files for c in _load(f)]
        report["recall"] = bench_recall(clips, args.level, args.sketch_dims, args.pools)
        print(json.dumps(report["recall"], indent=1), flush=True)
        moving = report["recall"]["moving_joints"]
    else:
        print(f"no .bvh files under {args.data}: skipping the real-clip parts", file=sys.stderr)
        moving = 17
    report["synthetic"] = bench_synthetic(args.synthetic, args.level, moving)
    print(json.dumps(report["synthetic"], indent=1), flush=True)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(report, f, indent=1)


if __name__ == "__main__":
    main()
