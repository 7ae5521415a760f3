"""The command line at library scale: indexing BVH clips (our bpy-free reader) and a query over 1,000 cached clips,
wall time of whole ``python -m blender_shapesig rank`` processes (start-up included).

    .venv/bin/python benchmarks/bench_cli.py [--clips 1000] [--baseline] [--json OUT]

The library: ``--clips`` copies of the six tests/data BVH clips (131-337 frames, 43 bones), each made a distinct
file (trailing blank lines: a new SHA-1, the same motion). Runs, each a fresh process with ``--cache`` a new folder:
1. cold: every clip read and signed (indexing rate = clips / wall seconds, start-up included; also per CPU second
   of the process, user + system, which the other jobs of a shared machine do not inflate);
2. warm: the same query again, every signature a cache hit (the target: < 1 s);
3. for reference, ``python -c "import numpy"`` (the floor of any start-up) and the CLI's ``--help``;
Every run has the package's bytecode cached after the first, as an installed package has.
4. with ``--baseline``: the cold run again with OpenBLAS's threads (one per core; the CLI now sets one thread).
"""

import argparse
import json
import os
import pathlib
import resource
import shutil
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parent.parent
BVH = ROOT / "tests" / "data" / "bvh"


CPU = {}  # the CPU seconds (user + system) of the last run: robust to the other jobs on a shared machine


def run(args, env):
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, *args], env=env, capture_output=True, text=True, cwd=str(ROOT))
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    CPU["last"] = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    if p.returncode != 0:
        raise SystemExit(p.stderr)
    return wall, p.stdout


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--clips", type=int, default=1000)
    ap.add_argument("--json", type=pathlib.Path)
    ap.add_argument("--baseline", action="store_true",
                    help="also index cold with one BLAS thread per core (the CLI's default before: the baseline)")
    args = ap.parse_args(argv)
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    env.pop("SHAPESIG_CACHE_DIR", None)
    sources = sorted(BVH.glob("*.bvh"))
    out = {"clips": args.clips, "load_average_1min": os.getloadavg()[0]}
    with tempfile.TemporaryDirectory() as tmp:
        # as an installed package runs: its modules' bytecode cached after the first call (a machine with
        # PYTHONDONTWRITEBYTECODE compiles the package's ~70 modules again on every call: 0.3 s measured)
        env.pop("PYTHONDONTWRITEBYTECODE", None)
        env["PYTHONPYCACHEPREFIX"] = str(pathlib.Path(tmp) / "pycache")
        lib = pathlib.Path(tmp) / "lib"
        lib.mkdir()
        paths = []
        for n in range(args.clips):
            src = sources[n % len(sources)]
            dst = lib / f"{src.stem}_{n:04d}.bvh"
            shutil.copyfile(src, dst)
            with open(dst, "a") as fh:
                fh.write("\n" * (1 + n // len(sources)))
            paths.append(str(dst))
        cache = str(pathlib.Path(tmp) / "cache")
        query = str(BVH / "07_01.bvh")
        rank = ["-m", "blender_shapesig", "rank", query, *paths, "--cache", cache, "--top", "10", "--json",
                "--no-progress"]
        cold, _ = run(rank, env)
        cold_cpu = CPU["last"]
        if args.baseline:
            # the same cold indexing with OpenBLAS's own threads (one per core: the default before the CLI set one),
            # in a fresh cache folder: the baseline of the same run
            threads = str(os.cpu_count())
            benv = dict(env, OPENBLAS_NUM_THREADS=threads, OMP_NUM_THREADS=threads, MKL_NUM_THREADS=threads)
            base_rank = [x if x != cache else cache + "_baseline" for x in rank]
            base, _ = run(base_rank, benv)
            out["baseline_blas_threads_index_wall_s"] = round(base, 2)
            out["baseline_indexing_clips_per_s"] = round(args.clips / base, 1)
        warm, warm_cpu = [], []
        for _ in range(3):
            warm.append(run(rank, env)[0])
            warm_cpu.append(CPU["last"])
        _, text = run(rank, env)
        res = json.loads(text)
        out["cold_index_wall_s"] = round(cold, 2)
        out["indexing_clips_per_s"] = round(args.clips / cold, 1)
        out["cold_index_cpu_s"] = round(cold_cpu, 2)
        out["indexing_clips_per_cpu_s"] = round(args.clips / cold_cpu, 1)
        out["warm_query_wall_s"] = round(min(warm), 3)
        out["warm_query_cpu_s"] = round(min(warm_cpu), 3)
        out["warm_cache"] = res["cache"]
        out["top3"] = [r["clip"] for r in res["results"][:3]]
    out["python_import_numpy_s"] = round(min(run(["-c", "import numpy"], env)[0] for _ in range(3)), 3)
    out["cli_help_s"] = round(min(run(["-m", "blender_shapesig", "--help"], env)[0] for _ in range(3)), 3)
    print(json.dumps(out, indent=2))
    if args.json:
        args.json.write_text(json.dumps(out, indent=2) + "\n")


if __name__ == "__main__":
    main()
