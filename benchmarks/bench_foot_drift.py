"""Benchmark of planted feet: stance drift of walk x run blends before and after ``core.blend.feet.lock_feet``.

Usage (from the repository root; no Blender needed, except for ``--cli``):

    .venv/bin/python benchmarks/bench_foot_drift.py --data ../shared/data/cmu [--json OUT.json] [--cli]

``--cli`` also runs every blend through the command line (``python -m blender_shapesig blend A B --range-a S:E
--range-b S:E --weight w --align --json``, feet locked by default; it writes a .blend with bpy) and checks the
criterion on the stance drifts its JSON reports.

Data: real CMU takes found through the data folder's INDEX.md, one stride each (right heel strike to the next,
frames picked by hand from the contacts ``core.blend.contacts.find_contacts`` reports on the whole take):

* 07_01 (walk, AMC + 07-walk.asf), frames 125-253  x  09_02 (run, AMC + 09-run.asf), frames 36-126: one rig,
  blended bone by bone;
* 08_01 (walk; the data has no ASF for subject 8, so its Daz BVH conversion), frames 147-269  x  09_05 (run, AMC),
  frames 42-132: two rigs, blended through the canonical joints (``rigs.apply_bone_map``) and written back on
  08_01's rig (``rigs.onto_rig``), as the CLI does.

Blends at w = 0.25 and 0.5 (aligned, ``core.blend.blend_clips``). The *stance drift* of a planted foot is, per
contact run of a foot point (heel = ankle, ball = foot tail) in the blend's frames, the largest distance between
two of its positions during the run (m); a source's drift is measured on its own contacts. Pass (the issue's
criterion): the median over every planted foot of the blend <= the larger source median + 2 cm, and the maximum
<= the larger source maximum + 5 cm. Times: ``lock_feet`` against the blend itself (``blend_clips``, warp included) in
the same run, wall seconds on a shared, loaded machine: the ratio is the figure to read.
"""

import argparse
import json
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

from blender_shapesig.core.blend import feet  # noqa: E402
from blender_shapesig.core.blend import blend_clips  # noqa: E402
from blender_shapesig.core.io.acclaim import load_acclaim  # noqa: E402
from blender_shapesig.core.io.bvh import load_bvh  # noqa: E402
from blender_shapesig.core.rigs import apply_bone_map, onto_rig  # noqa: E402

ANIM = "uscresl_humanoid-gail/mocap/animations"
ASF = "Jiaqi-Zuo_CSCI520-Motion-Capture-Interpolation/mocapPlayer-starter"
# (label, loader arguments, first frame, last frame): one stride, right heel strike to right heel strike
CLIPS = {
    "07_01": (f"{ANIM}/07_01.amc", f"{ASF}/07-walk.asf", 125, 253),
    "09_02": (f"{ANIM}/running/09_02.amc", f"{ASF}/09-run.asf", 36, 126),
    "08_01": ("Przestr_motion-capture/data/08/08_01.bvh", None, 147, 269),
    "09_05": (f"{ANIM}/running/09_05.amc", f"{ASF}/09-run.asf", 42, 132),
}
PAIRS = (("07_01", "09_02"), ("08_01", "09_05"))
WEIGHTS = (0.25, 0.5)


def load(data, label):
    path, asf, first, last = CLIPS[label]
    path = os.path.join(data, path)
    clip = load_bvh(path) if asf is None else load_acclaim(path, os.path.join(data, asf), axes="blender")
    return clip.crop(first, last)


def blend_pair(a, b, weight):
    """The blend on A's rig (through the canonical joints when the rigs differ), its timing in meta."""
    if a.bones == b.bones:
        return blend_clips(a, b, weight, align=True)
    ma, mb = apply_bone_map(a), apply_bone_map(b)
    return onto_rig(blend_clips(ma, mb, weight, align=True), a, ma)


def run(data):
    rows = []
    for la, lb in PAIRS:
        a, b = load(data, la), load(data, lb)
        da, db = feet.source_drifts(a), feet.source_drifts(b)
        med_limit = max(np.median(da), np.median(db)) + 0.02
        max_limit = max(max(da), max(db)) + 0.05
        feet.lock_feet(blend_pair(a, b, WEIGHTS[0]), [a, b])  # warm-up (numba compiles the DP once), not timed
        for w in WEIGHTS:
            t0 = time.perf_counter()
            blend = blend_pair(a, b, w)
            blend_seconds = time.perf_counter() - t0
            t0 = time.perf_counter()
            _locked, report = feet.lock_feet(blend, [a, b])
            seconds = time.perf_counter() - t0
            before = [d for f in report["feet"] for d in f["drift_before"]]
            after = [d for f in report["feet"] for d in f["drift_after"]]
            rows.append({
                "a": la, "b": lb, "weight": w, "frames": blend.frames, "planted": len(after),
                "source_median": [float(np.median(da)), float(np.median(db))],
                "source_max": [float(max(da)), float(max(db))],
                "before_median": float(np.median(before)), "before_max": float(max(before)),
                "after_median": float(np.median(after)), "after_max": float(max(after)),
                "root_lowered": report["root_lowered"], "seconds": seconds, "blend_seconds": blend_seconds,
                "pass": bool(np.median(after) <= med_limit + 1e-9 and max(after) <= max_limit + 1e-9),
            })
    return rows


def run_cli(data):
    """The same blends through the command line (each clip linked into a folder with its own skeleton, so the
    reader finds it): rows of the criterion on the JSON's feet report and the command's wall seconds."""
    import subprocess
    import tempfile

    rows = []
    root = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
    with tempfile.TemporaryDirectory() as tmp:
        paths = {}
        for label, (path, asf, first, last) in CLIPS.items():
            folder = os.path.join(tmp, label)
            os.makedirs(folder)
            for f in (path, asf) if asf else (path,):
                os.symlink(os.path.join(os.path.abspath(data), f), os.path.join(folder, os.path.basename(f)))
            paths[label] = (os.path.join(folder, os.path.basename(path)), f"{first}:{last}")
        for la, lb in PAIRS:
            a, b = load(data, la), load(data, lb)
            da, db = feet.source_drifts(a), feet.source_drifts(b)
            for w in WEIGHTS:
                cmd = [sys.executable, "-m", "blender_shapesig", "blend", paths[la][0], paths[lb][0], "--weight",
                       str(w), "--range-a", paths[la][1], "--range-b", paths[lb][1], "--align", "--json",
                       "--no-progress", "--out", os.path.join(tmp, f"{la}_{lb}_{w}.blend")]
                t0 = time.perf_counter()
                p = subprocess.run(cmd, capture_output=True, text=True, cwd=root, timeout=600)
                seconds = time.perf_counter() - t0
                if p.returncode:
                    raise SystemExit(p.stderr.strip().splitlines()[-1])
                report = json.loads(p.stdout)["feet"][0]
                after = [d for f in report["feet"] for d in f["drift_after"]]
                rows.append({
                    "a": la, "b": lb, "weight": w, "planted": len(after),
                    "after_median": float(np.median(after)), "after_max": float(max(after)),
                    "limit_median": max(np.median(da), np.median(db)) + 0.02,
                    "limit_max": max(max(da), max(db)) + 0.05, "seconds": seconds,
                })
                r = rows[-1]
                r["pass"] = bool(r["after_median"] <= r["limit_median"] + 1e-9 and r["after_max"] <= r["limit_max"] + 1e-9)
    return rows


def cli_table(rows):
    cm = lambda x: f"{100 * x:.1f}"  # noqa: E731
    lines = ["| A x B (command line) | w | planted | after median / limit (cm) | after max / limit (cm) | "
             "command wall time | pass |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['a']} x {r['b']} | {r['weight']:g} | {r['planted']} | {cm(r['after_median'])} / "
                     f"{cm(r['limit_median'])} | {cm(r['after_max'])} / {cm(r['limit_max'])} | {r['seconds']:.1f} s | "
                     f"{'yes' if r['pass'] else 'NO'} |")
    return "\n".join(lines)


def table(rows):
    cm = lambda x: f"{100 * x:.1f}"  # noqa: E731
    lines = ["| A x B | w | planted | sources median (cm) | sources max (cm) | before median / max | "
             "after median / max | root lowered (cm) | lock_feet / blend time | pass |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(
            f"| {r['a']} x {r['b']} | {r['weight']:g} | {r['planted']} | "
            f"{cm(r['source_median'][0])}, {cm(r['source_median'][1])} | {cm(r['source_max'][0])}, "
            f"{cm(r['source_max'][1])} | {cm(r['before_median'])} / {cm(r['before_max'])} | "
            f"{cm(r['after_median'])} / {cm(r['after_max'])} | {cm(r['root_lowered'])} | "
            f"{r['seconds']:.3f} s / {r['blend_seconds']:.3f} s "
            f"({r['seconds'] / r['blend_seconds']:.2f}x) | "
            f"{'yes' if r['pass'] else 'NO'} |")
    return "\n".join(lines)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", required=True, help="the CMU data folder (the one with INDEX.md)")
    parser.add_argument("--json", help="also write the rows as JSON here")
    parser.add_argument("--cli", action="store_true", help="also run the blends through the command line")
    args = parser.parse_args(argv)
    if not os.path.isfile(os.path.join(args.data, "INDEX.md")):
        parser.error(f"no INDEX.md in {args.data}")
    rows = run(args.data)
    print(table(rows))
    if args.cli:
        cli_rows = run_cli(args.data)
        print()
        print(cli_table(cli_rows))
        rows = rows + cli_rows
    if args.json:
        with open(args.json, "w", encoding="utf-8") as fh:
            json.dump(rows, fh, indent=1)
    return 0 if all(r["pass"] for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
