#!/usr/bin/env python
"""A blend across rigs beside its sources, as stick figures (docs/rigs.md, "Blending across rigs"):

  .venv/bin/python experiments/plot_cross_rig_blend.py --data ../shared/data/cmu [--out docs/img/rigs_blend.png]

Two blends at weight 0.5, time-aligned, made by the command line (``blend ... --align``) and read back from the
saved .blend: the iClone / Character Creator walk 002_01 (A) with the Daz run 09_02, and the ASF/AMC run 09_02 (A)
with the Daz walk 07_01. Each row: A, B and the blend on A's rig at four moments of their own durations, the
mapped joints by forward kinematics (``core.clip.skeleton``), in each clip's heading frame (travel to the right), in
leg lengths of its own rig, the hips over the origin at its height; the floor of each rig at its lowest foot.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
for _p in (ROOT, os.path.join(ROOT, "experiments")):
    if _p not in sys.path:
        sys.path.insert(0, _p)

import numpy as np  # noqa: E402

from blender_shapesig.core import rigs
from blender_shapesig.core.clip import skeleton
from blender_shapesig.core.io import sources  # noqa: E402
from rank_across_rigs import _AMC, _ASF, _DAZ, _ICL  # noqa: E402  (the shared clips' folders)

BONES = [("hips", "spine"), ("spine", "chest"), ("chest", "neck"), ("neck", "head")] + [
    (a + s, b + s) for s in (".L", ".R") for a, b in
    (("hips", "thigh"), ("thigh", "shin"), ("shin", "foot"), ("chest", "clavicle"), ("clavicle", "upper_arm"),
     ("upper_arm", "forearm"), ("forearm", "hand"))]


def joints(clip):
    """{joint: (frames, 3)} heads in the heading frame (x: travel), leg lengths, hips at the origin."""
    by_joint = {j: b for b, j in rigs.resolve_map("auto", clip).items()}
    heads, _tails, W = skeleton.forward_kinematics(clip)
    H = rigs.clip_heading(clip, by_joint)
    leg = rigs.leg_length(clip, by_joint)
    hips = heads[:, clip.bones.index(by_joint["hips"])]
    turn = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # Blender's forward -Y to +x
    out = {}
    for j, b in by_joint.items():
        p = ((heads[:, clip.bones.index(b)] - hips * np.array([1.0, 1.0, 0.0])) @ H) @ turn.T / leg
        out[j] = p
    floor = min(out[f][:, 2].min() for f in ("foot.L", "foot.R") if f in out)
    return {j: p - np.array([0.0, 0.0, floor]) for j, p in out.items()}


def blend(data, a, b, asf, out_dir):
    out = os.path.join(out_dir, "blend.blend")
    args = [sys.executable, "-m", "blender_shapesig", "blend", a, b, "--weight", "0.5", "--align", "--out", out,
            "--json", "--no-progress"] + (["--asf", asf] if asf else [])
    got = json.loads(subprocess.run(args, capture_output=True, text=True, cwd=ROOT, check=True).stdout)
    return f"{out}#{got['actions'][0]}"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", required=True, help="the shared CMU folder")
    ap.add_argument("--out", default=os.path.join(ROOT, "docs", "img", "rigs_blend.png"))
    args = ap.parse_args(argv)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    d = args.data
    cases = [("iClone walk 002_01 (CC rig)", os.path.join(d, _ICL, "002_01.bvh"), "Daz run 09_02",
              os.path.join(d, _DAZ, "09", "09_02.bvh"), None),
             ("AMC run 09_02", os.path.join(d, _AMC, "running", "09_02.amc"), "Daz walk 07_01",
              os.path.join(d, _DAZ, "07", "07_01.bvh"), os.path.join(d, _ASF, "09-run.asf"))]
    fig, axes = plt.subplots(2, 3, figsize=(15, 6.4))
    with tempfile.TemporaryDirectory() as tmp:
        for row, (na, a, nb, b, asf) in enumerate(cases):
            spec = blend(d, a, b, asf, tmp)
            clips = [sources.read_one(sources.ClipSpec(a, asf=asf, bone_map="none")),
                     sources.read_one(sources.ClipSpec(b, bone_map="none")),
                     sources.read_one(sources.ClipSpec.parse(spec, bone_map="none"))]
            for col, (clip, title) in enumerate(zip(clips, (na, nb, "blend 0.5 on A's rig"))):
                ax, P = axes[row, col], joints(clip)
                for k, f in enumerate(np.linspace(0, clip.frames - 1, 4).round().astype(int)):
                    dx = 1.2 * k
                    for u, v in BONES:
                        if u in P and v in P:
                            ax.plot([P[u][f, 0] + dx, P[v][f, 0] + dx], [P[u][f, 2], P[v][f, 2]],
                                    color="C3" if u.endswith(".L") or v.endswith(".L") else "C0", lw=1.6)
                ax.axhline(0.0, color="0.6", lw=0.8)
                ax.set_aspect("equal")
                ax.set_xlim(-0.8, 4.4)
                ax.set_ylim(-0.1, 2.1)
                ax.set_title(title, fontsize=10)
                ax.set_xticks([])
    axes[0, 0].set_ylabel("leg lengths")
    axes[1, 0].set_ylabel("leg lengths")
    fig.suptitle("Blends across rigs on A's rig (left side red): four moments each, in leg lengths of each rig",
                 fontsize=11)
    fig.tight_layout()
    fig.savefig(args.out, dpi=100)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
