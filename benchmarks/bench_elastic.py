"""Benchmark of the elastic distance d_S* (blender_shapesig.core.elastic.elastic).

Usage (from the repository root):

    .venv/bin/python benchmarks/bench_elastic.py [--data ../shared/data/cmu] [--repeat 15] [--skip-matrix]
        [--pruning-bound] [--json FILE]

1. One pair: two 300-frame, 31-joint real CMU curves (07_01 and 07_02 from tests/data, first
   300 frames, every bone), depth 9, penalty 0. Times the DP kernel alone (numba and the
   row-vectorized numpy baseline, measured in the same run; their ratio is the speed-up) and the
   whole ``elastic_distance`` / ``elastic_align`` calls. Times are the minimum over repeats of
   the thread's CPU time (``time.thread_time``, robust when other processes share the cores)
   and, for reference, of the wall time.
   ``reads_per_node_depth_9``: the DP's G reads per node and the
   fewest a prefix-sum scheme could need; ``--pruning-bound``: the multiply-adds a branch-and-bound would still
   need at best (both measured to decide against them, docs/elastic.md).
   The numba DP and the whole call on two threads (``threads=2``: process CPU of both threads and wall time;
   the second core is often busy on the shared machine). Also the parts of the whole call (SRVT of both
   curves, Gram matrix) and the whole call's speed-up over the
   numpy DP alone (the target: >= 10x), and the first call in a fresh process (cache warm / cold).
2. The all-pairs matrix of 27 clips (9 walks of subject 07, 8 walks of subject 08, 10 runs of
   subject 09; ASF/AMC from ``--data``/uscresl_humanoid-gail, 128-417 frames, 31 bones) with
   ``elastic_distance_matrix`` at workers=1 and workers=2 (wall time). Without ``--data`` (or
   when the files are missing) synthetic curves of the same sizes are used.

Nothing is asserted: the numbers are printed (and written as JSON with ``--json FILE``).
"""

import argparse
import json
import os
import pathlib
import platform
import sys
import time

import numpy as np

import _common as harness  # noqa: E402  (puts the repository on sys.path)

ROOT = harness.ROOT

from blender_shapesig.core.elastic import _dp_kernels, elastic  # noqa: E402
from blender_shapesig.core.io.acclaim import load_acclaim  # noqa: E402

TESTS = ROOT / "tests" / "data" / "acclaim"
MATRIX_CLIPS = (
    [("uscresl_humanoid-gail/mocap/animations", f"07_{n:02d}", "07") for n in (1, 2, 3, 6, 7, 8, 9, 10, 11)]
    + [("uscresl_humanoid-gail/mocap/animations", f"08_{n:02d}", "07") for n in (1, 2, 3, 5, 6, 7, 8, 9)]
    + [("uscresl_humanoid-gail/mocap/animations/running", f"09_{n:02d}", "09") for n in (1, 2, 3, 4, 5, 6, 7, 8, 10, 11)]
)
# Subject 08 has no ASF here; every CMU ASF has the same 31 bones and DOF layout, so the AMC is
# read with subject 07's skeleton (see shared/data/cmu/INDEX.md).
ASF = {
    "07": "Jiaqi-Zuo_CSCI520-Motion-Capture-Interpolation/mocapPlayer-starter/07-walk.asf",
    "09": "Jiaqi-Zuo_CSCI520-Motion-Capture-Interpolation/mocapPlayer-starter/09-run.asf",
}


def best_of(fn, repeat):
    """(minimum CPU time of this thread, minimum wall time) over repeats."""
    t = harness.timed(fn, repeat, warmup=0, cpu="thread")
    return t.cpu_min, t.wall_min


def best_of_process(fn, repeat):
    """(minimum process CPU time, minimum wall time) over repeats: for work on two threads."""
    t = harness.timed(fn, repeat, warmup=0)
    return t.cpu_min, t.wall_min


def prefix_sum_reads(depth):
    """G reads per DP node: the step table's entries, and the fewest any row- (or column-) prefix-sum scheme
    needs (per row of the short axis: 2 reads of a primitive at each end, fractional ends 2 more; a whole-row
    run 2): the bound on what prefix sums could save at this depth."""
    table = elastic.step_table(depth)
    entries = int(len(table["ea"]))
    reads = 0
    for a, b in zip(table["di"], table["dj"]):
        short = min(int(a), int(b))
        reads += 1 if a == b == 1 else (2 if short == 1 else 2 * short)
    return {"entries": entries, "prefix_sum_reads_at_best": reads}


def pruning_bound(prob):
    """The fraction of the DP's multiply-adds a branch-and-bound could skip at best: a candidate (node, step)
    needs its cross sum unless A[k, l] + (sqrt B0 - sqrt B1)^2 (a lower bound of its energy, Cauchy-Schwarz)
    already reaches the node's final minimum. Computed with the numpy energies of every step (one pass)."""
    t, G = prob.table, prob.G
    n0, n1 = G.shape
    A = np.full((n0 + 1, n1 + 1), np.inf)
    A[0, 0] = 0.0
    sB0, sB1 = np.sqrt(np.maximum(prob.B0, 0.0)), np.sqrt(np.maximum(prob.B1, 0.0))
    E, LB = [], []
    for s in range(len(t["di"])):
        a, b = int(t["di"][s]), int(t["dj"][s])
        X = np.zeros((n0 + 1 - a, n1 + 1 - b))
        for e in range(int(t["start"][s]), int(t["start"][s + 1])):
            ra, cb = int(t["ea"][e]), int(t["eb"][e])
            X += prob.coef[e] * G[ra:ra + n0 + 1 - a, cb:cb + n1 + 1 - b]
        E.append((prob.B0[a, a:][:, None] + prob.B1[b, b:][None, :]) - X)
    for i in range(1, n0 + 1):
        for s in range(len(t["di"])):
            a, b = int(t["di"][s]), int(t["dj"][s])
            if a <= i:
                A[i, b:] = np.minimum(A[i, b:], A[i - a, :n1 + 1 - b] + E[s][i - a])
    need = total = 0
    for s in range(len(t["di"])):
        a, b = int(t["di"][s]), int(t["dj"][s])
        w = int(t["start"][s + 1] - t["start"][s])
        prev = A[:n0 + 1 - a, :n1 + 1 - b]
        lb = prev + (sB0[a, a:][:, None] - sB1[b, b:][None, :]) ** 2
        ok = np.isfinite(prev) & np.isfinite(A[a:, b:])
        total += w * int(ok.sum())
        need += w * int((ok & (lb < A[a:, b:])).sum())
    return {"multiply_adds_needed_fraction": round(need / total, 3)}


def prob_args(prob):
    t = prob.table
    return (prob.G, prob.B0, prob.B1, prob.h0, prob.h1, prob.penalty, t["di"], t["dj"], t["start"], t["ea"],
            t["eb"], prob.coef, prob.lo, prob.hi)


def pair_benchmark(repeat, pruning=False):
    R0 = load_acclaim(TESTS / "07_01.amc", TESTS / "07-walk.asf").rotations[:300]
    R1 = load_acclaim(TESTS / "07_02.amc", TESTS / "07-walk.asf").rotations[:300]
    Q0, _ = elastic._srvt_matrix(R0, "R0")
    Q1, _ = elastic._srvt_matrix(R1, "R1")
    prob = elastic._Problem(Q0, Q1, 9, 0.0)
    band = int(np.sum(prob.hi - prob.lo + 1))
    entries = int(len(prob.table["ea"]))
    out = {
        "frames": [int(R0.shape[0]), int(R1.shape[0])], "joints": int(R0.shape[1]), "depth": 9,
        "steps": int(len(prob.table["di"])), "entries_per_node": entries, "band_nodes": band,
        # Every (node, step) candidate reads one G value per entry: the multiply-adds of the DP.
        "multiply_adds": int(round(band * entries)),
    }
    results = {}
    if _dp_kernels.HAVE_NUMBA:
        t0 = time.perf_counter()
        prob.solve("numba", want_path=False)
        out["numba_first_call_s"] = time.perf_counter() - t0  # JIT or on-disk cache load
        results["numba_dp"] = best_of(lambda: prob.solve("numba", want_path=False), repeat)
        results["numba_dp_path"] = best_of(lambda: prob.solve("numba", want_path=True), repeat)
        results["elastic_distance"] = best_of(lambda: elastic.elastic_distance(R0, R1, threads=1), repeat)
        results["elastic_align"] = best_of(lambda: elastic.elastic_align(R0, R1, threads=1), repeat)
        # the same on two threads (column halves of row blocks): process CPU (both threads) and wall
        two = lambda: _dp_kernels.dp_numba(*prob_args(prob), want_path=False, threads=2)  # noqa: E731
        results["numba_dp_two_threads"] = best_of_process(two, repeat)
        results["elastic_distance_two_threads"] = best_of_process(
            lambda: elastic.elastic_distance(R0, R1, threads=2), repeat)
        out["two_threads_identical"] = bool(two()[0] == prob.solve("numba", want_path=False)[0])
    results["numpy_dp"] = best_of(lambda: prob.solve("numpy", want_path=False), max(2, repeat // 5))
    results["srvt_and_G"] = best_of(
        lambda: elastic._Problem(elastic._srvt_matrix(R0, "R0")[0], elastic._srvt_matrix(R1, "R1")[0], 9, 0.0),
        repeat,
    )
    # the parts of a whole call: validation + SRVT of both curves, the Gram matrix, the tables (band, sums)
    results["srvt_both"] = best_of(lambda: (elastic._srvt_matrix(R0, "R0"), elastic._srvt_matrix(R1, "R1")), repeat)
    results["gram"] = best_of(lambda: _dp_kernels.gram(Q0, Q1), repeat)
    out["load_average_1min"] = os.getloadavg()[0]
    out["times_ms"] = {k: {"cpu": round(v[0] * 1e3, 3), "wall": round(v[1] * 1e3, 3)} for k, v in results.items()}
    if "elastic_distance" in results:
        # the target: the whole call against the numpy DP alone, same run (CPU and wall)
        out["speedup_whole_call_vs_numpy_dp"] = {
            "cpu": round(results["numpy_dp"][0] / results["elastic_distance"][0], 1),
            "wall": round(results["numpy_dp"][1] / results["elastic_distance"][1], 1)}
        out["speedup_whole_call_two_threads_vs_numpy_dp_wall"] = round(
            results["numpy_dp"][1] / results["elastic_distance_two_threads"][1], 1)
    if _dp_kernels.HAVE_NUMBA:
        by_depth = {}
        for depth in (3, 6, 9, 12):
            p = elastic._Problem(Q0, Q1, depth, 0.0)
            p.solve("numba", want_path=False)
            cpu, _ = best_of(lambda: p.solve("numba", want_path=False), repeat)
            by_depth[str(depth)] = {"steps": int(len(p.table["di"])), "entries_per_node": int(len(p.table["ea"])),
                                    "numba_dp_cpu_ms": round(cpu * 1e3, 3)}
        out["numba_dp_by_depth"] = by_depth
    if "numba_dp" in results:
        out["speedup_numba_vs_numpy_dp"] = round(results["numpy_dp"][0] / results["numba_dp"][0], 1)
        out["numba_dp_ns_per_multiply_add"] = round(results["numba_dp"][0] / out["multiply_adds"] * 1e9, 4)
        vn = prob.solve("numba")[0]
        vp = prob.solve("numpy")[0]
        out["kernels_identical"] = bool(vn == vp)
    out["reads_per_node_depth_9"] = prefix_sum_reads(9)
    if pruning:
        out["pruning_bound"] = pruning_bound(prob)
    return out


FIRST_CALL = """
import time
t0 = time.perf_counter()
import numpy as np
from blender_shapesig.core.elastic import elastic
from blender_shapesig.core.geometry import so3
rng = np.random.default_rng(0)
R0 = so3.integrate(rng.normal(size=(299, 31, 3)) * 0.05)
R1 = so3.integrate(rng.normal(size=(299, 31, 3)) * 0.05)
t1 = time.perf_counter()
elastic.elastic_distance(R0, R1)
t2 = time.perf_counter()
print(t1 - t0, t2 - t1)
"""


def first_call_benchmark():
    """The first ``elastic_distance`` (300 x 300 x 31) in a fresh process, numba's on-disk cache warm (the
    usual case: ``elastic.warm_up`` or any earlier call wrote it) and cold (an empty cache folder: the JIT
    compiles). Wall seconds of the imports and of the call, each in its own subprocess."""
    import subprocess
    import tempfile

    env = dict(os.environ, PYTHONPATH=str(ROOT))
    subprocess.run([sys.executable, "-c", "from blender_shapesig.core.elastic import elastic; elastic.warm_up()"],
                   env=env, check=True)
    out = {}
    with tempfile.TemporaryDirectory() as empty:
        for label, extra in (("warm_cache", {}), ("cold_cache", {"NUMBA_CACHE_DIR": empty})):
            p = subprocess.run([sys.executable, "-c", FIRST_CALL], env=dict(env, **extra), capture_output=True,
                               text=True, check=True)
            imports, call = (float(x) for x in p.stdout.split())
            out[label] = {"imports_s": round(imports, 3), "first_call_s": round(call, 3)}
    return out


def matrix_curves(data):
    curves, names, source = [], [], "synthetic"
    if data is not None and all((data / d / f"{n}.amc").exists() for d, n, _ in MATRIX_CLIPS):
        for d, n, s in MATRIX_CLIPS:
            clip = load_acclaim(data / d / f"{n}.amc", data / ASF[s])
            curves.append(clip.rotations)
            names.append(n)
        source = str(data)
    else:
        rng = np.random.default_rng(0)
        from scipy.spatial.transform import Rotation

        frames = [316, 329, 415, 417, 379, 362, 306, 301, 315, 277, 309, 353, 298, 296, 302, 283, 293,
                  148, 130, 128, 137, 143, 141, 138, 128, 132, 165]
        for n, f in enumerate(frames):
            v = np.cumsum(rng.normal(size=(f, 31, 3)) * 0.03, axis=0)
            curves.append(Rotation.from_rotvec(v.reshape(-1, 3)).as_matrix().reshape(f, 31, 3, 3))
            names.append(f"synthetic_{n}")
    return curves, names, source


def matrix_benchmark(data, repeat):
    curves, names, source = matrix_curves(data)
    frames = [int(c.shape[0]) for c in curves]
    out = {"clips": len(curves), "source": source, "frames_min": min(frames), "frames_max": max(frames),
           "pairs": len(curves) * (len(curves) - 1) // 2}
    elastic.elastic_distance_matrix(curves[:2])  # warm-up (JIT cache load)
    walls, cpus, mats = {}, {}, {}
    for workers in (1, 2):
        ts, cs = [], []
        for _ in range(max(1, repeat // 5)):
            c0, t0 = time.process_time(), time.perf_counter()
            mats[workers] = elastic.elastic_distance_matrix(curves, workers=workers)
            ts.append(time.perf_counter() - t0)
            cs.append(time.process_time() - c0)
        walls[workers] = min(ts)
        cpus[workers] = min(cs)
    out["wall_s"] = {f"workers={w}": round(t, 3) for w, t in walls.items()}
    # CPU time of the whole process (all threads): the wall time on two otherwise idle cores is
    # about cpu / workers; on a shared machine the wall time is longer.
    out["process_cpu_s"] = {f"workers={w}": round(t, 3) for w, t in cpus.items()}
    out["load_average_1min"] = os.getloadavg()[0]
    out["same_matrix"] = bool(np.array_equal(mats[1], mats[2]))
    # Leave-one-out nearest neighbour on the three groups (walk 07, walk 08, run 09) as a sanity check.
    if source != "synthetic":
        labels = np.array(["walk" if n[:2] in ("07", "08") else "run" for n in names])
        M = mats[1] + np.diag(np.full(len(names), np.inf))
        nn = np.argmin(M, axis=1)
        out["walk_run_1nn_accuracy"] = float(np.mean(labels[nn] == labels))
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    default = ROOT.parent / "shared" / "data" / "cmu"  # ../shared/data/cmu beside the repository
    ap.add_argument("--data", type=pathlib.Path, default=default if default.exists() else None,
                    help="the shared CMU data folder (with uscresl_humanoid-gail/...)")
    ap.add_argument("--repeat", type=int, default=15)
    ap.add_argument("--skip-matrix", action="store_true")
    ap.add_argument("--pruning-bound", action="store_true",
                    help="also measure what a branch-and-bound on the DP could skip at best (numpy, ~10 s)")
    ap.add_argument("--json", type=pathlib.Path, help="also write the results to this file")
    args = ap.parse_args(argv)
    res = {
        "machine": {"python": platform.python_version(), "numpy": np.__version__, "cpu_count": os.cpu_count(),
                    "numba": _dp_kernels.HAVE_NUMBA and __import__("numba").__version__},
        "pair": pair_benchmark(args.repeat, args.pruning_bound),
    }
    if _dp_kernels.HAVE_NUMBA:
        res["first_call_fresh_process"] = first_call_benchmark()
    if not args.skip_matrix:
        res["matrix"] = matrix_benchmark(args.data, args.repeat)
    print(json.dumps(res, indent=2))
    if args.json:
        args.json.write_text(json.dumps(res, indent=2) + "\n")


if __name__ == "__main__":
    main()
