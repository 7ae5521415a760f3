"""``dedupe`` at library scale: each stage timed on simulated libraries of several sizes, extrapolated to 2,600 clips
with the stage's complexity.

    .venv/bin/python benchmarks/bench_dedupe.py --data ../shared/data/cmu [--sizes 100,200,400] [--target 2600]
        [--scheduler NAME] [--json OUT]

The simulated library: ``max(--sizes)`` BVH files, each a ``planted.variant`` of one of the shared BVH clips (all
rigs; round robin, so every prefix of the list has the same mix): a random window of 50-100 % of the take (2 s at least),
played 0.8-1.25 x as fast, every rotation channel's swing scaled by 0.7-1.3. Variants of one source are like
takes of one actor (about ``size / sources`` per source: at 2,600 that is 43, the "50 almost identical walks").
Every 20th file is a planted copy (renamed, half the rate, trimmed and re-timed, in turn) of an earlier file, so
the checks and the linkage see real clusters (5 % duplicates); the run counts how many land with their original,
in all and per kind of copy (the kind is the suffix of the copy's file name).
Each size runs ``dedupe_library`` on the first n files (no signature cache, no plots), the command's own code.

The stages and the model each is extrapolated with (n clips, k = 8 neighbours):

* signing (read + log-signature, one per clip): c + a n;
* graph (sketch distances n x n in one matrix product, exact sim^n on 4 k candidates per clip): c + a n + b n^2;
* checks (elastic d_S* of the candidate pairs under the gate plus a sample of 100): (c0 + c1 n) pairs
  (least squares over the sizes) x the seconds per pair of the largest size;
* linkage (complete linkage; pairs outside the graph checked on demand): c + a n;

non-negative least squares over the sizes (a quadratic term the data cannot see stays 0).

Memory: the graph keeps every clip's entry loaded (the log-signature direction and the increments). The peak
resident size after each size (it only grows: sizes run smallest first) gives the bytes per added clip (the
slope between the two largest sizes), extrapolated linearly plus the n x n sketch distances (8 n^2 bytes).
"""

import argparse
import json
import os
import pathlib
import resource
import sys
import tempfile
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from blender_shapesig.dedupe import dedupe_library  # noqa: E402
from tests.helpers import planted  # noqa: E402


COPY_EVERY = 20
COPIES = (planted.renamed, planted.rate, planted.trimmed_retimed)


def simulate(sources, n, folder, seed=0):
    """``(files, copies)``: ``n`` files in ``folder``, made in order (every prefix is a smaller library of the
    same mix): every ``COPY_EVERY``-th a planted copy (renamed, half rate, trimmed and re-timed in turn) of an
    earlier file, the others variants of ``sources`` (round robin); ``copies``: {copy: original}."""
    rng = np.random.default_rng(seed)
    os.makedirs(folder, exist_ok=True)
    files, copies = [], {}
    for i in range(n):
        path = os.path.join(folder, f"sim_{i:05d}.bvh")
        if i % COPY_EVERY == COPY_EVERY - 1:
            original = files[int(rng.integers(0, len(files)))]
            while original in copies:
                original = copies[original]
            make = COPIES[(i // COPY_EVERY) % len(COPIES)]
            path = path[:-4] + f"_{make.__name__}.bvh"  # the kind of copy in its name
            copies[make(original, path)] = original
        else:
            planted.variant(str(sources[i % len(sources)]), path, rng)
        files.append(path)
    return files, copies


def found(result, copies):
    """``(found, present, {kind: [found, present]})``: how many planted copies (among those in this library)
    share a cluster with their original, in all and per kind of copy (the suffix of the copy's name)."""
    where = {m: n for n, c in enumerate(result["clusters"]) for m in c}
    present = [(c, o) for c, o in copies.items() if c in result["_files"]]
    kinds = {}
    for c, o in present:
        tally = kinds.setdefault(os.path.basename(c)[10:-4], [0, 0])
        tally[0] += c in where and where.get(o) == where[c]
        tally[1] += 1
    return sum(t[0] for t in kinds.values()), len(present), kinds


def fit(sizes, seconds, powers):
    """Non-negative least-squares coefficients of seconds ~ sum_p c_p n^p (scipy's nnls)."""
    from scipy.optimize import nnls

    A = np.array([[float(n) ** p for p in powers] for n in sizes])
    return nnls(A, np.asarray(seconds, float))[0]


def extrapolate(runs, target):
    sizes = [r["clips"] for r in runs]
    sec = {s: [r["seconds"][s] for r in runs] for s in ("signing", "graph", "checks", "linkage")}
    big = runs[-1]
    per_pair = big["seconds"]["checks"] / max(big["checked_pairs"], 1)
    c0, c1 = fit(sizes, [r["checked_pairs"] for r in runs], (0, 1))
    pairs = c0 + c1 * target
    out = {
        "signing": float(np.dot(fit(sizes, sec["signing"], (0, 1)), [1, target])),
        "graph": float(np.dot(fit(sizes, sec["graph"], (0, 1, 2)), [1, target, target ** 2])),
        "checks": pairs * per_pair,
        "linkage": float(np.dot(fit(sizes, sec["linkage"], (0, 1)), [1, target])),
    }
    out["total"] = sum(out.values())
    a, b = runs[-2] if len(runs) > 1 else runs[-1], runs[-1]
    per_clip_mb = (b["peak_rss_mb"] - a["peak_rss_mb"]) / max(b["clips"] - a["clips"], 1)
    memory = b["peak_rss_mb"] + per_clip_mb * (target - b["clips"]) + 8.0 * (target ** 2 - b["clips"] ** 2) / 2 ** 20
    return out, {"seconds_per_pair": per_pair, "checked_pairs": pairs, "mb_per_clip": per_clip_mb,
                 "peak_rss_mb": memory}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", required=True, type=pathlib.Path, help="the shared CMU folder (its BVH files)")
    ap.add_argument("--sizes", default="100,200,400")
    ap.add_argument("--target", type=int, default=2600)
    ap.add_argument("--scheduler", help="as dedupe --scheduler (default: the thread pool, no Dask)")
    ap.add_argument("--json", type=pathlib.Path)
    ap.add_argument("--refit", type=pathlib.Path, help="only extrapolate the runs of an earlier --json file")
    args = ap.parse_args(argv)
    if args.refit:
        out = json.loads(args.refit.read_text())
        est, model = extrapolate(out["runs"], args.target)
        print(json.dumps({"seconds": est, **model}, indent=1))
        return 0
    sizes = sorted(int(s) for s in args.sizes.split(","))
    sources = sorted(args.data.rglob("*.bvh"))
    out = {"sources": len(sources), "load_average_1min_start": os.getloadavg()[0], "runs": []}
    with tempfile.TemporaryDirectory() as tmp:
        t = time.perf_counter()
        files, copies = simulate(sources, sizes[-1], os.path.join(tmp, "lib"))
        out["simulate_seconds"] = time.perf_counter() - t
        for n in sizes:
            res = dedupe_library(files[:n], os.path.join(tmp, f"report_{n}"), None, args.scheduler, plots=False)
            res["_files"] = set(files[:n])
            run = {"clips": res["clips"], "seconds": res["seconds"], "graph_edges": res["graph_edges"],
                   "checked_pairs": res["checked_pairs"], "linkage_checks": res["linkage_checks"],
                   "clusters": len(res["clusters"]), "largest_cluster_share": res["largest_cluster_share"],
                   "copies_found": found(res, copies),
                   "load_average_1min": os.getloadavg()[0],
                   "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0}
            out["runs"].append(run)
            s = run["seconds"]
            print(f"n={n:5d}: signing {s['signing']:6.1f} s, graph {s['graph']:5.2f} s, checks {s['checks']:6.1f} s "
                  f"({run['checked_pairs']} pairs), linkage {s['linkage']:5.2f} s ({run['linkage_checks']} on demand), "
                  f"total {s['total']:6.1f} s; {run['clusters']} clusters, copies found "
                  f"{run['copies_found'][0]}/{run['copies_found'][1]} {run['copies_found'][2]}, largest "
                  f"{run['largest_cluster_share']:.1%}; peak {run['peak_rss_mb']:.0f} MB; load "
                  f"{run['load_average_1min']:.1f}", flush=True)
    est, model = extrapolate(out["runs"], args.target)
    out["extrapolated"] = {"clips": args.target, "seconds": est, **model}
    print(f"extrapolated to {args.target} clips: " + ", ".join(f"{k} {v:.0f} s" for k, v in est.items())
          + f" ({model['checked_pairs']:.0f} checked pairs, {model['seconds_per_pair'] * 1e3:.0f} ms per pair);"
          f" peak memory {model['peak_rss_mb']:.0f} MB ({model['mb_per_clip']:.2f} MB per clip)")
    if args.json:
        args.json.write_text(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
