"""Check ``dedupe`` on the shared CMU library (every clip of every format the package reads) with planted copies.

    .venv/bin/python experiments/dedupe_check.py --data ../shared/data/cmu [--bvh-only] [--out DIR]
        [--scheduler ADDRESS] [--cache DIR] [--threshold X]

Plants three copies in a temporary folder (``blender_shapesig.dedupe.planted``): the walk 07_01 renamed, the run
09_02 at half its frame rate (60 fps) and the forward jump 13_32 trimmed by 10 % at each end and re-timed
non-uniformly (the cgspeed "Daz-friendly" BVH files under ``Przestr_motion-capture/data/``), runs ``dedupe`` over
``--data`` plus that folder and checks that each copy lands in its original's cluster and that no cluster holds
more than 30 % of the library. Prints the clusters and the timings; exit code 1 when a check fails.

Every .bvh is read, and every .amc whose subject has a skeleton in the data (``skeleton_for``: the pairing of
INDEX.md, "Skeleton (ASF) pairing"); the others (subjects 08, 02 and 141 in humanoid-gail: no ASF in the data)
are listed as skipped. ``--bvh-only``: the BVH files alone.
"""

import argparse
import json
import os
import pathlib
import re
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from blender_shapesig.core.io.sources import ClipSpec  # noqa: E402
from blender_shapesig.dedupe import dedupe_library  # noqa: E402
from tests.helpers import planted  # noqa: E402

ORIGINALS = ("Przestr_motion-capture/data/07/07_01.bvh", "Przestr_motion-capture/data/09/09_02.bvh",
             "Przestr_motion-capture/data/13/13_32.bvh")
MAX_SHARE = 0.3


def skeleton_for(amc, asfs):
    """The .asf of an .amc among ``asfs`` (all .asf files of the data), or None: in the same folder the one
    with the .amc's name (trailing digits dropped: charleston1 -> charleston), else the folder's only one
    (humanoid-gail examples/02_01 -> 12.asf, the pairing of that repository), else the subject's skeleton
    (the name's leading number: ``07.asf`` or ``07-walk.asf``), in the same folder first."""
    folder, stem = amc.parent, amc.stem
    here = [a for a in asfs if a.parent == folder]
    for a in here:
        if a.stem in (stem, stem.rstrip("0123456789")):
            return a
    if len(here) == 1:
        return here[0]
    subject = re.match(r"(\d+)_", stem)
    if not subject:
        return None
    own = [a for a in asfs if a.stem == subject.group(1) or a.stem.startswith(subject.group(1) + "-")]
    own.sort(key=lambda a: (a.parent != folder, str(a)))
    return own[0] if own else None


def library(data, bvh_only=False):
    """``(paths, skipped)``: what to deduplicate (BVH paths; ClipSpecs of .amc files with their skeleton) and a
    line per .amc without one."""
    paths = sorted(str(p) for p in data.rglob("*.bvh"))
    if bvh_only:
        return paths, []
    asfs = sorted(data.rglob("*.asf"))
    skipped = []
    for amc in sorted(data.rglob("*.amc")):
        asf = skeleton_for(amc, asfs)
        if asf is None:
            skipped.append(f"{amc.relative_to(data)}: no skeleton of its subject in the data")
        else:
            paths.append(ClipSpec(str(amc), asf=str(asf)))
    return paths, skipped


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


def same_take_pairs(result):
    """``(found, pairs)``: pairs of files of one CMU trial (the name's ``SS_TT``, leading zeros dropped: the same
    take in another format, rig or source) and how many of them share a cluster. Not a check: copies on
    different rigs (retargeted, converted) differ by more than a copy (docs/search.md)."""
    take = {}
    for label in [m for c in result["clusters"] for m in c] + result.get("all_clips", []):
        m = re.match(r"0*(\d+)_0*(\d+)", os.path.basename(label))
        if m:
            take[label] = m.groups()
    cluster = {m: n for n, c in enumerate(result["clusters"]) for m in c}
    labels = sorted(take)
    pairs = [(a, b) for x, a in enumerate(labels) for b in labels[x + 1:] if take[a] == take[b]]
    return [p for p in pairs if p[0] in cluster and cluster[p[0]] == cluster.get(p[1])], pairs


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", required=True, type=pathlib.Path, help="the shared CMU folder")
    ap.add_argument("--out", help="report folder (default: a temporary folder, kept)")
    ap.add_argument("--scheduler", help="Dask scheduler: threads (default), processes, sync or an address")
    ap.add_argument("--cache", help="signature cache folder (default: memory only)")
    ap.add_argument("--threshold", type=float, help="relative d_S* gate (default: relative to the library)")
    ap.add_argument("--bvh-only", action="store_true", help="the BVH files only (no ASF/AMC)")
    args = ap.parse_args(argv)
    data = args.data.resolve()
    originals = [data / p for p in ORIGINALS]
    missing = [str(p) for p in originals if not p.is_file()]
    if missing:
        ap.error(f"not found: {', '.join(missing)}")
    tmp = tempfile.mkdtemp(prefix="dedupe_check_")
    copies = planted.plant(os.path.join(tmp, "planted"), *originals)
    out = args.out or os.path.join(tmp, "report")
    paths, no_skeleton = library(data, args.bvh_only)
    result = dedupe_library(paths + [os.path.join(tmp, "planted")], out, args.threshold, args.scheduler,
                            cache_dir=args.cache)
    skipped = no_skeleton + result["skipped"]
    print(f"{result['clips']} clips ({len(skipped)} sources skipped), {len(result['clusters'])} clusters;"
          f" {result['rule']}")
    for line in skipped:
        print("  skipped:", line)
    for members in result["clusters"]:
        print("  cluster:", "  ".join(os.path.relpath(m, data) if str(data) in m else m for m in members))
    print("  seconds:", json.dumps({k: round(v, 2) for k, v in result["seconds"].items()}),
          "scheduler:", result["scheduler"])
    hit, pairs = same_take_pairs(result)
    print(f"INFO same CMU take in two files (another format, rig or source): {len(hit)} of {len(pairs)} pairs "
          "clustered")
    for a, b in pairs:
        print(("  found  " if (a, b) in hit else "  missed ") + f"{os.path.relpath(a, data)}  {os.path.relpath(b, data)}")
    results = check(result, copies)
    for ok, text in results:
        print(("PASS " if ok else "FAIL ") + text)
    print("report:", result["report"])
    return 0 if all(ok for ok, _ in results) else 1


if __name__ == "__main__":
    sys.exit(main())
