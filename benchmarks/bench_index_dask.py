"""Indexing a library on Dask: the ``index`` command over N clip files with a ``LocalCluster`` of one worker (one
thread) and then of two workers (one thread each), in the same run, each with a fresh cache; prints the ratio.

    .venv/bin/python benchmarks/bench_index_dask.py --data DIR --clips N [--json] [--out FILE]

The clips: the BVH files under ``--data`` (e.g. the shared CMU folder), each copied N / (number of files) times into
a temporary folder, every copy re-timed (its ``Frame Time`` scaled by a factor drawn in 0.8-1.25, so every file has
its own content, key and clip: nothing is served from a cache or a hash memo). Each run is a fresh
``python -m blender_shapesig index FOLDER --cache FRESH --scheduler ADDRESS --json`` process (the client: it lists
and hashes the files, the workers read and compute each clip, the client stores every entry), timed from its start
to its exit; the cluster (worker processes, each with one thread) is started before and is not in the time.
Prints JSON: ``clips``, ``files_mb`` (bytes the workers read), per run ``seconds`` (wall), ``client_cpu_s`` (the
client process' CPU time) and ``computed``; ``ratio`` = one worker's seconds / two workers' seconds; the machine
(with the load average before the runs) and ``load_after``.
"""

import argparse
import json
import os
import pathlib
import re
import resource
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

from _common import ROOT, machine, write_json

FRAME_TIME = re.compile(rb"^(\s*Frame Time:\s*)([0-9.eE+-]+)", re.MULTILINE)


def make_library(data, n, out, seed=0):
    """N re-timed copies of the BVH files under ``data`` in ``out``; returns their total size in bytes."""
    bases = sorted(p for p in pathlib.Path(data).rglob("*") if p.suffix.lower() == ".bvh" and p.is_file())
    if not bases:
        raise SystemExit(f"no .bvh files under {data}")
    rng = np.random.default_rng(seed)
    texts = [b.read_bytes() for b in bases]
    total = 0
    for i in range(n):
        text = texts[i % len(texts)]
        m = FRAME_TIME.search(text)
        if m is None:
            raise SystemExit(f"{bases[i % len(bases)]}: no Frame Time line")
        dt = float(m.group(2)) * float(np.exp(rng.uniform(np.log(0.8), np.log(1.25))))
        new = text[:m.start(2)] + f"{dt:.9f}".encode() + text[m.end(2):]
        (out / f"c{i:06d}_{bases[i % len(bases)].name}").write_bytes(new)
        total += len(new)
    return total, len(bases)


def run_index(folder, cache, address):
    """One ``index`` process on the cluster at ``address``: (wall seconds, client CPU seconds, its JSON)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-m", "blender_shapesig", "index", str(folder), "--cache", str(cache),
                        "--scheduler", address, "--json", "--no-progress"],
                       cwd=ROOT, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode != 0:
        raise SystemExit(f"index failed: {p.stderr.strip()}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, json.loads(p.stdout)


def timed_on_cluster(folder, cache, workers):
    import distributed

    with distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        wall, cpu, out = run_index(folder, cache, cluster.scheduler_address)
    return {"workers": workers, "seconds": wall, "client_cpu_s": cpu, "computed": out["computed"],
            "clips": out["clips"], "index_seconds": out["seconds"]}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", required=True, help="folder of BVH files (searched recursively)")
    ap.add_argument("--clips", type=int, default=1000)
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--out", help="also write the JSON (with the machine) to this file")
    args = ap.parse_args()
    # the worker processes import the package from this checkout
    os.environ["PYTHONPATH"] = os.pathsep.join([str(ROOT)] + [p for p in [os.environ.get("PYTHONPATH")] if p])
    where = machine()
    tmp = pathlib.Path(tempfile.mkdtemp(prefix="bench_index_dask_"))
    try:
        lib = tmp / "lib"
        lib.mkdir()
        size, nbases = make_library(args.data, args.clips, lib)
        runs = [timed_on_cluster(lib, tmp / f"cache{w}", w) for w in (1, 2)]
        out = {"clips": args.clips, "base_files": nbases, "files_mb": size / 1e6, "runs": runs,
               "ratio": runs[0]["seconds"] / runs[1]["seconds"], "machine": where,
               "load_after": [round(x, 2) for x in os.getloadavg()]}
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    if args.out:
        write_json(args.out, out)
    if args.json:
        print(json.dumps(out, default=float))
    else:
        for r in runs:
            print(f"{r['workers']} worker(s): {r['seconds']:.1f} s ({r['computed']} computed, "
                  f"client CPU {r['client_cpu_s']:.1f} s)")
        print(f"{args.clips} clips, ratio {out['ratio']:.2f}")


if __name__ == "__main__":
    main()
