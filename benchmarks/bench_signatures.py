"""Speed and memory of signatures, log-signatures and the four signature measures.

    .venv/bin/python benchmarks/bench_signatures.py [--frames 400] [--levels 2 3] [--repeat 3]
                                                    [--ii-methods S X] [--json OUT.json]

The clip: CMU 16_15 (walk, 31 bones, so a path in R^93), its first ``--frames`` frames, read with
``core.io.acclaim``. Every timing is the best of ``--repeat`` runs after one warm-up run (the minimum is
the least disturbed by other processes on a shared machine); one-off preparation (iisignature's
``prepare``, the numpy Lyndon projection) is timed separately, cold, once. Ratios
are against a baseline measured in the same run, ``iisignature.sig`` of the same path at the same level
(the numpy signature when iisignature is missing), so they do not depend on the machine's speed.
Bytes per clip: the float64 vector stored per clip for each representation; and the peak memory of
one numpy log-signature computation (tracemalloc).

iisignature's ``logsig`` methods: 'S' (signature, then log, then projection onto the Lyndon basis) and
'X' (tensor form) prepare in seconds at 93 dimensions, level 3; 'A' (areas, levels <= 2) is timed at
level 2; 'C' compiles BCH code on the fly and 'O' evaluates BCH formulas stored in an object; pass
``--ii-methods S C O X`` to time them too (at level 3 and 93 dimensions the 'C' prepare did not finish
in 5 minutes).
"""

import argparse
import json
import pathlib
import sys
import time
import tracemalloc

import numpy as np

import _common as harness  # noqa: E402  (puts the repository on sys.path)

ROOT = harness.ROOT

from blender_shapesig.core.signatures import lyndon, signatures as sg, tensor  # noqa: E402
from blender_shapesig.core.io.acclaim import load_acclaim  # noqa: E402

try:
    import iisignature
except ImportError:  # pragma: no cover
    iisignature = None


def timed(fn, repeat):
    """The minimum wall seconds of ``repeat`` runs after one warm-up run."""
    return harness.timed(fn, repeat).wall_min


def once(fn):
    t0 = time.perf_counter()
    out = fn()
    return time.perf_counter() - t0, out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frames", type=int, default=400)
    ap.add_argument("--levels", type=int, nargs="+", default=[2, 3])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--ii-methods", nargs="+", default=["S", "X"])
    ap.add_argument("--json", type=pathlib.Path)
    args = ap.parse_args(argv)

    data = ROOT / "tests" / "data" / "acclaim"
    clip = load_acclaim(data / "16_15.amc", data / "16.asf")
    other = load_acclaim(data / "07_01.amc", data / "07-walk.asf")
    R0 = clip.rotations[: args.frames]
    R1 = other.rotations[: args.frames]
    if R1.shape[1] != R0.shape[1]:
        raise SystemExit("the two benchmark clips must have the same number of bones")
    dx = sg.development_increments(R0)
    dy = sg.development_increments(R1)
    path = sg.development(R0)
    d = dx.shape[1]
    rows = []
    print(f"clip 16_15: {R0.shape[0]} frames, {R0.shape[1]} bones -> path in R^{d}; "
          f"pair partner 07_01 ({R1.shape[0]} frames)")
    print(f"iisignature {'%s' % iisignature.version() if iisignature else 'not installed'}, numpy {np.__version__}")

    for n in args.levels:
        print(f"\n## level {n}")
        res = {"level": n, "dim": d, "frames": int(R0.shape[0])}
        # --- baseline
        if iisignature is not None:
            base = timed(lambda: iisignature.sig(path, n), args.repeat)
            base_name = "iisignature.sig"
        else:
            base = timed(lambda: sg.path_signature(path, n, method="numpy"), args.repeat)
            base_name = "numpy signature"
        res["baseline"] = {"name": base_name, "seconds": base}
        table = []

        def row(name, seconds, note=""):
            table.append((name, seconds, note))

        row(f"baseline: {base_name}", base)
        row("development: rotation vectors log(R[k+1] R[k]^T) (in every curve-level call)",
            timed(lambda: sg.development_increments(R0), args.repeat))
        # --- numpy: one-off Lyndon projection (cold: clear the caches first)
        for fn in (lyndon._is_lyndon, lyndon.lyndon_words, lyndon._factorization, lyndon._bracket_matrix,
                   lyndon._projection_level):
            fn.cache_clear()
        t_proj, _ = once(lambda: tensor.lyndon_projection(d, n))
        row("numpy prepare (Lyndon projection, once per dim/level)", t_proj)
        row("numpy path_signature (points given: no rotation vectors)",
            timed(lambda: sg.path_signature(path, n, method="numpy"), args.repeat))
        row("numpy path_log_signature (Lyndon, points given)",
            timed(lambda: sg.path_log_signature(path, n, method="numpy"), args.repeat))
        if n <= 3:  # the general route the matrix-product one (tensor.lyndon_log_signature) replaces at n <= 3
            row("numpy Lyndon log-signature by the general route (signature, tensor log, projection)",
                timed(lambda: tensor.lyndon_coordinates(tensor.log(tensor.signature_from_increments(dx, n)), d),
                      args.repeat))
            row("numpy Lyndon log-signature by matrix products (tensor.lyndon_log_signature)",
                timed(lambda: tensor.lyndon_log_signature(dx, n), args.repeat))
        row("numpy signature", timed(lambda: sg.signature(R0, n, method="numpy"), args.repeat))
        row("numpy log_signature (Lyndon)", timed(lambda: sg.log_signature(R0, n, method="numpy"), args.repeat))
        row("numpy log_signature (tensor)",
            timed(lambda: sg.log_signature(R0, n, basis="tensor", method="numpy"), args.repeat))
        # --- iisignature
        if iisignature is not None:
            row("iisignature signature", timed(lambda: sg.signature(R0, n, method="iisignature"), args.repeat))
            for meth in args.ii_methods + (["A"] if n <= 2 and "A" not in args.ii_methods else []):
                if meth == "A" and n > 2:
                    continue  # the area method exists for levels <= 2 only
                t_prep, s = once(lambda: iisignature.prepare(d, n, meth))
                row(f"iisignature prepare('{meth}')", t_prep)
                row(f"iisignature logsig '{meth}'", timed(lambda: iisignature.logsig(path, s, meth), args.repeat),
                    "tensor form" if meth == "X" else "Lyndon basis")
            # the module's own path (prepares 'S' / 'X' once, cached)
            sg.prepare(d, n, "lyndon")
            sg.prepare(d, n, "tensor")
            row("iisignature log_signature (Lyndon, via module)",
                timed(lambda: sg.log_signature(R0, n, method="iisignature"), args.repeat))
            agree = {}
            for basis in sg.BASES:
                a_np = sg.log_signature(R0, n, basis=basis, method="numpy")
                a_ii = sg.log_signature(R0, n, basis=basis, method="iisignature")
                agree[basis] = float(np.abs(a_np - a_ii).max() / np.abs(a_ii).max())
            s_np, s_ii = sg.signature(R0, n, method="numpy"), sg.signature(R0, n, method="iisignature")
            agree["signature"] = float(np.abs(s_np - s_ii).max() / np.abs(s_ii).max())
            res["agreement"] = agree
            print("numpy vs iisignature, max |difference| / max |value|: "
                  + ", ".join(f"{k} {v:.1e}" for k, v in agree.items()))
        # --- measures for one pair (both signatures computed inside)
        methods = ["numpy"] + (["iisignature"] if iisignature is not None else [])
        for fn in (sg.group_distance, sg.concat_distance, sg.linear_distance, sg.normalized_distance):
            for m in methods:
                row(f"{fn.__name__} ({m}), one pair from curves", timed(lambda: fn(R0, R1, n, method=m), args.repeat))
        a = sg.log_signature(R0, n)
        b = sg.log_signature(R1, n)
        row("normalized_difference from two stored log-signatures",
            timed(lambda: sg.normalized_difference(a, b), max(args.repeat, 20)))
        # --- peak memory of one numpy log-signature (numpy allocations are traced by tracemalloc)
        tracemalloc.start()
        sg.log_signature(R0, n, method="numpy")
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        res["peak_bytes_numpy_log_signature"] = peak
        # --- bytes per clip
        res["bytes"] = {
            "log_signature lyndon": sg.log_signature_dim(d, n) * 8,
            "log_signature tensor": sg.log_signature_dim(d, n, basis="tensor") * 8,
            "signature": sg.signature_dim(d, n) * 8,
        }
        res["rows"] = [{"name": nm, "seconds": s, "ratio": s / base, "note": note} for nm, s, note in table]
        print("| operation | ms | ratio to baseline | note |")
        print("|---|---:|---:|---|")
        for nm, s, note in table:
            print(f"| {nm} | {1000 * s:.1f} | {s / base:.3g} | {note} |")
        print("\n| stored per clip | float64 values | bytes |")
        print("|---|---:|---:|")
        for k, v in res["bytes"].items():
            print(f"| {k} | {v // 8:,} | {v:,} |")
        print(f"\npeak memory of one numpy log_signature: {peak / 2 ** 20:.1f} MiB")
        rows.append(res)
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
