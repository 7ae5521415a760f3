"""Figures of docs/blending.md: a time-aligned SRVT blend of a CMU walk and run.

    .venv/bin/python experiments/plot_blend.py [--out docs/img] [--weight 0.5]

A = walk 07_01 (316 frames), B = run 09_02 (130 frames), both ASF/AMC from tests/data (120 fps). The
angle and pose figures use one gait cycle of each, from one peak of the right knee's angle to the next
(walk frames 91-220, run frames 4-93), so that the pinned ends of the warp match the same phase.
Writes

* ``blend_angles.png``: rotation angles of a few joints over time (seconds) for A, B and the aligned
  blend at ``--weight``, one cycle each;
* ``blend_poses.png``: pose strips (stick figures by forward kinematics on A's skeleton, side view)
  of A, the blend at ``--weight`` and B, at the same fractions of each cycle;
* ``blend_geodesic.png``: d_P*(blend(w), B o phi) and d_P*(blend(w), A) against w (before resampling),
  the straight reference lines of the paper's Fig. 9.6, with and without alignment;
* ``blend_root.png``: the root path (top view) of the blends at w = 0, 0.25, 0.5, 0.75, 1.
"""

import argparse
import pathlib
import sys

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from blender_shapesig.core.io.acclaim import load_acclaim, parse_asf  # noqa: E402
from blender_shapesig.core.blend import blend_clips, geodesic_blend  # noqa: E402
from blender_shapesig.core.geometry.curves import l2_distance  # noqa: E402

ACC = ROOT / "tests" / "data" / "acclaim"
JOINTS = ("lfemur", "ltibia", "rhumerus")
COLORS = {"A": "#1f77b4", "B": "#d62728", "blend": "#2ca02c"}


def rotation_angle_deg(R):
    cos = np.clip((np.trace(R, axis1=-2, axis2=-1) - 1.0) / 2.0, -1.0, 1.0)
    return np.degrees(np.arccos(cos))


def forward_kinematics(clip, skeleton):
    """World joint positions (frames, bones, 3) from a clip of ASF local rotations (L = C M C^-1):
    G = G_parent L, tail = head + G (direction * length), the root's head at the root translation."""
    names = list(skeleton.bones)
    index = {n: i for i, n in enumerate(clip.bones)}
    f = clip.frames
    G = {}
    tails = {}
    heads = {}
    for name in names:
        bone = skeleton.bones[name]
        L = clip.rotations[:, index[name]]
        if bone.parent is None:
            G[name] = L
            heads[name] = clip.root_translation.copy()
        else:
            G[name] = G[bone.parent] @ L
            heads[name] = tails[bone.parent]
        tails[name] = heads[name] + G[name] @ (bone.direction * bone.length)
    segs = [(heads[n], tails[n]) for n in names if skeleton.bones[n].length > 0]
    return segs, f


def plot_angles(a, b, blends, out):
    fig, axes = plt.subplots(len(JOINTS), 1, figsize=(8, 7), sharex=True)
    for ax, joint in zip(axes, JOINTS):
        for clip, label, color, lw in [(a, "A: walk 07_01", COLORS["A"], 2.0),
                                       (b, "B: run 09_02", COLORS["B"], 2.0)]:
            j = clip.bones.index(joint)
            t = np.arange(clip.frames) / clip.fps
            ax.plot(t, rotation_angle_deg(clip.rotations[:, j]), color=color, lw=lw,
                    label=f"{label} ({clip.frames} frames)")
        for w, c in blends:
            j = c.bones.index(joint)
            t = np.arange(c.frames) / c.fps
            ax.plot(t, rotation_angle_deg(c.rotations[:, j]), color=COLORS["blend"], lw=2.0,
                    label=f"blend w={w:.2f} ({c.frames} frames)")
        ax.set_ylabel(f"{joint}\nangle (deg)")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8, ncol=1, loc="upper right")
    axes[-1].set_xlabel("time (s)")
    fig.suptitle("Joint rotation angles over one gait cycle: walk, run and their aligned SRVT blend")
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)


def plot_poses(rows, skeleton, out, count=8, spacing=22.0):
    """Each row: ``count`` poses at equal fractions of the clip, drawn side by side (every pose
    centred on its own slot: its root's forward position is removed), side view."""
    fig, axes = plt.subplots(len(rows), 1, figsize=(11, 2.3 * len(rows)), sharex=True)
    for ax, (label, clip, color) in zip(axes, rows):
        segs, f = forward_kinematics(clip, skeleton)
        frames = np.linspace(0, f - 1, count).round().astype(int)
        root = clip.root_translation
        for slot, k in enumerate(frames):
            dz = slot * spacing - root[k, 2]
            for head, tail in segs:
                p, q = head[k], tail[k]
                # side view: forward (+Z) to the right, up (+Y) up
                ax.plot([p[2] + dz, q[2] + dz], [p[1], q[1]], color=color, lw=1.4)
            ax.text(slot * spacing, root[k, 1] + 12, f"{k / (f - 1):.2f}", fontsize=7, ha="center",
                    color="0.4")
        ax.set_aspect("equal")
        ax.margins(y=0.12)
        ax.set_title(f"{label} ({clip.frames} frames); numbers: fraction of the clip", fontsize=9,
                     loc="left")
        ax.set_yticks([])
        ax.set_xticks([])
    fig.suptitle("One gait cycle: poses at the same fractions of each clip (side view)")
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)


def plot_geodesic(a, b, out):
    ws = np.linspace(0.0, 1.0, 11)
    fig, ax = plt.subplots(figsize=(6, 4))
    for align, style in ((True, "-"), (False, "--")):
        to_b, to_a = [], []
        for w in ws:
            _, info = geodesic_blend(a.rotations, b.rotations, w, align=align, return_info=True)
            G = info["grid"]
            to_b.append(l2_distance(info["curve"], info["curve1"], G, G))
            to_a.append(l2_distance(info["curve"], info["curve0"], G, G))
        name = "aligned" if align else "not aligned"
        ax.plot(ws, to_b, style, marker="o", ms=3, color=COLORS["B"], label=f"to B o phi ({name})")
        ax.plot(ws, to_a, style, marker="o", ms=3, color=COLORS["A"], label=f"to A ({name})")
    ax.set_xlabel("weight w")
    ax.set_ylabel("d_P*")
    ax.set_title("Blend distances lie on straight lines (cf. Fig. 9.6)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)


def plot_root(a, b, out):
    fig, ax = plt.subplots(figsize=(9, 2.6))
    cmap = plt.get_cmap("viridis")
    for w in (0.0, 0.25, 0.5, 0.75, 1.0):
        c = blend_clips(a, b, w)
        p = c.root_translation
        ax.plot(p[:, 2], p[:, 0], color=cmap(w), label=f"w={w:.2f} ({c.frames} frames)")
        ax.plot(p[0, 2], p[0, 0], "o", color=cmap(w), ms=3)
    ax.set_aspect("equal")
    ax.set_xlabel("Z (forward)")
    ax.set_ylabel("X")
    ax.set_title("Root path (top view): walk (w=0) to run (w=1)")
    ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.01, 0.5))
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)


def main(argv=None):
    ap = argparse.ArgumentParser(description="figures of docs/blending.md")
    ap.add_argument("--out", default=str(ROOT / "docs" / "img"))
    ap.add_argument("--weight", type=float, default=0.5)
    args = ap.parse_args(argv)
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    a = load_acclaim(str(ACC / "07_01.amc"), str(ACC / "07-walk.asf"))
    b = load_acclaim(str(ACC / "09_02.amc"), str(ACC / "09-run.asf"))
    skeleton = parse_asf(ACC / "07-walk.asf")
    a_cycle = a.crop(91, 220)
    b_cycle = b.crop(4, 93)
    mid = blend_clips(a_cycle, b_cycle, args.weight)
    blends = [(args.weight, mid)]

    plot_angles(a_cycle, b_cycle, blends, out / "blend_angles.png")
    plot_poses([("A: walk 07_01, frames 91-220", a_cycle, COLORS["A"]),
                (f"blend w={args.weight:.2f} (aligned)", mid, COLORS["blend"]),
                ("B: run 09_02, frames 4-93", b_cycle, COLORS["B"])], skeleton, out / "blend_poses.png")
    plot_geodesic(a, b, out / "blend_geodesic.png")
    plot_root(a, b, out / "blend_root.png")
    for name in ("blend_angles", "blend_poses", "blend_geodesic", "blend_root"):
        print(out / f"{name}.png")


if __name__ == "__main__":
    main()
