#!/usr/bin/env python
"""docs/img/rigs_same_take.png: the same take from two rigs, overlaid before and after mapping (docs/rigs.md).

  .venv/bin/python experiments/plot_rigs.py --data ../shared/data/cmu --out docs/img/rigs_same_take.png

CMU 02_01 (walk) as the cgspeed Daz BVH (hip, abdomen, chest, lThigh, ...; 120 fps, T-pose rest) and as the
iClone / Character Creator BVH (CC_Base_*; 60 fps, 101 bones with twist and share bones), read as a user reads
them (``--trim auto``: the Daz file's rest frame and ramp and the iClone T-pose frame are dropped). Top row: stick figures by forward kinematics
(each rig's own rest offsets and rotations) at three moments, as the files place them (before) and in the
comparison frame (after: heading removed, hips at the origin, scaled to the same height). Bottom row: the
rotation angle from the first frame, |log(R_k R_0^T)|, of corresponding bones: the clips' local rotations in
armature axes (the space used before, which would pair bones by name only) and the comparison space.
"""

import argparse
import os
import sys

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

from blender_shapesig.core import rigs
from blender_shapesig.core.geometry import so3
from blender_shapesig.core.io import sources  # noqa: E402
from blender_shapesig.core.metrics import clip_distance  # noqa: E402

PAIR = (("Daz BVH", "Przestr_motion-capture/data/02/02_01.bvh"),
        ("iClone BVH", "DragonForgedTheArtist_IClone-CMU-Mocap/All_BVH/subjects/002/002_01.bvh"))
CURVES = ("thigh.L", "shin.L", "upper_arm.R", "chest")


def rest_heads(path):
    """{bone: armature-space rest head} of a BVH rig (Blender's importer)."""
    import bpy

    from blender_shapesig.readers.bvh import import_armature

    bpy.ops.wm.read_factory_settings(use_empty=True)
    arm, _ = import_armature(path)
    return {b.name: np.array(b.head_local) for b in arm.data.bones}


def positions(raw, heads, W):
    """(frames, bones, 3): each bone's head by forward kinematics, p_b = p_parent + W_parent (h_b - h_parent)."""
    parents = raw.meta["parents"]
    index = {b: i for i, b in enumerate(raw.bones)}
    P = {}

    def pos(b):
        if b not in P:
            p = parents.get(b)
            if p is None or p not in index:
                P[b] = raw.root_translation if raw.root_translation is not None else np.zeros((raw.frames, 3))
            else:
                P[b] = pos(p) + (W[:, index[p]] @ (heads[b] - heads[p]))
        return P[b]

    return np.stack([pos(b) for b in raw.bones], axis=1)


def segments(mapped):
    """[(joint, canonical parent present)] of a mapped clip."""
    out = []
    for j in mapped.bones:
        p = rigs.CANONICAL_PARENTS[j]
        while p is not None and p not in mapped.bones:
            p = rigs.CANONICAL_PARENTS[p]
        if p is not None:
            out.append((j, p))
    return out


def load(data, path):
    full = os.path.join(data, path)
    raw = sources.read_one(sources.ClipSpec(full, bone_map="none"))
    mapped = rigs.apply_bone_map(raw, "auto")
    heads = rest_heads(full)
    W = rigs.world_rotations(raw)
    P = positions(raw, heads, W)
    return raw, mapped, P


def angle_curve(R):
    return so3.angle(R @ np.swapaxes(R[:1], -1, -2))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", required=True)
    ap.add_argument("--out", required=True)
    args = ap.parse_args(argv)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rigs_ = [load(args.data, path) for _label, path in PAIR]
    colors = ("tab:blue", "tab:orange")
    fig, axes = plt.subplots(2, 2, figsize=(12, 8.5))
    moments = (0.15, 0.4, 0.65)
    for k, ((label, _p), (raw, mapped, P)) in enumerate(zip(PAIR, rigs_)):
        bm = mapped.meta["bone_map"]
        index = {b: i for i, b in enumerate(raw.bones)}
        H = rigs.clip_heading(raw, bm)
        height = np.ptp(P[0, :, 2])
        side = int(np.argmax(np.ptp(P[:, index[bm["hips"]], :2], axis=0)))
        for m in moments:
            f = int(m * (raw.frames - 1))
            for j, p in segments(mapped):
                a, b = P[f, index[bm[j]]], P[f, index[bm[p]]]
                # before: as the file places it (own units, origin and heading; seen along its longer ground axis)
                axes[0, 0].plot([a[side], b[side]], [a[2], b[2]], color=colors[k], lw=1.5, alpha=0.8)
                # after: comparison frame (heading removed), hips at the origin, unit height, moments side by side
                hip = P[f, index[bm["hips"]]]
                a2, b2 = H.T @ (a - hip) / height, H.T @ (b - hip) / height
                dx = 1.2 * moments.index(m)
                axes[0, 1].plot([a2[1] + dx, b2[1] + dx], [a2[2], b2[2]], color=colors[k], lw=2, alpha=0.7)
        axes[0, 0].plot([], [], color=colors[k], label=f"{label} ({len(raw.bones)} bones, {raw.fps:.0f} fps)")
        axes[0, 1].plot([], [], color=colors[k], label=label)
        t = np.linspace(0, 1, raw.frames)
        for c, j in enumerate(CURVES):
            style = ("-", "--", ":", "-.")[c]
            axes[1, 0].plot(t, angle_curve(raw.rotations[:, index[bm[j]]]), style, color=colors[k],
                            label=f"{label}: {bm[j]}")
            axes[1, 1].plot(t, angle_curve(mapped.rotations[:, mapped.bones.index(j)]), style, color=colors[k],
                            label=f"{label}: {j}")
    (raw_a, map_a, _), (raw_b, map_b, _) = rigs_
    shared = sorted(set(raw_a.bones) & set(raw_b.bones))
    d_after = clip_distance(map_a, map_b, "sim3")
    axes[0, 0].set_title(f"before: as the files place them; bones shared by name: {len(shared)}")
    axes[0, 0].set_aspect("equal")
    axes[0, 1].set_title(f"after: {len(map_a.bones)}/{len(map_b.bones)} joints mapped, comparison frame; "
                         f"sim3 = {d_after:.3f}")
    axes[0, 1].set_aspect("equal")
    axes[1, 0].set_title("local rotations (armature axes), bones paired by the map")
    axes[1, 1].set_title("comparison space (world rel. to rest, heading removed)")
    for ax in axes[1]:
        ax.set_xlabel("time (normalized)")
        ax.set_ylabel("angle from frame 1 (rad)")
    for ax in axes.flat:
        ax.legend(fontsize=7, loc="upper right")
    fig.suptitle("CMU 02_01 (walk): Daz BVH and iClone / Character Creator BVH, before and after bone mapping")
    fig.tight_layout()
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    fig.savefig(args.out, dpi=110)
    print(args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
