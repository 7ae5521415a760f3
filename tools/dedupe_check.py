"""Check ``dedupe`` on a real library with planted near-duplicates.

    .venv/bin/python tools/dedupe_check.py --data ../shared/data/cmu [--out DIR] [--scheduler ADDRESS]
        [--cache DIR | --no-cache] [--threshold X]

Plants three copies in a temporary folder (``blender_shapesig.dedupe.planted``): the walk 07_01 renamed, the run
09_02 at half its frame rate (60 fps) and the forward jump 13_32 trimmed by 10 % at each end and re-timed
non-uniformly (the cgspeed "Daz-friendly" BVH files under ``Przestr_motion-capture/data/``), runs ``dedupe`` over
``--data`` plus that folder and checks that each copy lands in its original's cluster and that no cluster holds
more than 30 % of the library. Prints the clusters and the timings; exit code 1 when a check fails.
"""

import argparse
import json
import os
import pathlib
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from blender_shapesig.dedupe import dedupe_library, planted  # noqa: E402

ORIGINALS = ("Przestr_motion-capture/data/07/07_01.bvh", "Przestr_motion-capture/data/09/09_02.bvh",
             "Przestr_motion-capture/data/13/13_32.bvh")
MAX_SHARE = 0.3


def check(result, copies):
    """One line per check: (ok, text)."""
    out = []
    for copy, original in copies.items():
        home = next((c for c in result["clusters"] if original in map(os.path.abspath, c)), [])
        out.append((copy in map(os.path.abspath, home),
                    f"{os.path.basename(copy)} with {os.path.relpath(original)}: cluster of {len(home)}"))
    share = result["largest_cluster_share"]
    out.append((share <= MAX_SHARE, f"largest cluster {share:.1%} of {result['clips']} clips (<= {MAX_SHARE:.0%})"))
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", required=True, help="the shared CMU folder")
    ap.add_argument("--out", help="report folder (default: a temporary folder, kept)")
    ap.add_argument("--scheduler", help="Dask scheduler: threads (default), processes, sync or an address")
    ap.add_argument("--cache", help="signature cache folder (default: memory only)")
    ap.add_argument("--threshold", type=float, help="relative d_S* gate (default: relative to the library)")
    args = ap.parse_args(argv)
    data = pathlib.Path(args.data)
    originals = [data / p for p in ORIGINALS]
    missing = [str(p) for p in originals if not p.is_file()]
    if missing:
        ap.error(f"not found: {', '.join(missing)}")
    tmp = tempfile.mkdtemp(prefix="dedupe_check_")
    copies = planted.plant(os.path.join(tmp, "planted"), *originals)
    out = args.out or os.path.join(tmp, "report")
    result = dedupe_library([str(data), os.path.join(tmp, "planted")], out, args.threshold, args.scheduler,
                            cache_dir=args.cache)
    print(f"{result['clips']} clips ({len(result['skipped'])} sources skipped), {len(result['clusters'])} clusters;"
          f" {result['rule']}")
    for members in result["clusters"]:
        print("  cluster:", "  ".join(os.path.relpath(m, data) if str(data) in m else m for m in members))
    print("  seconds:", json.dumps({k: round(v, 2) for k, v in result["seconds"].items()}),
          "scheduler:", result["scheduler"])
    results = check(result, copies)
    for ok, text in results:
        print(("PASS " if ok else "FAIL ") + text)
    print("report:", result["report"])
    return 0 if all(ok for ok, _ in results) else 1


if __name__ == "__main__":
    sys.exit(main())
