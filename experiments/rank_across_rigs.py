#!/usr/bin/env python
"""The same take in other formats and skeletons ranks first, and the comparison-space measurement.

  .venv/bin/python experiments/rank_across_rigs.py --data ../shared/data/cmu [--bone-map auto|none] [--rerank K]
      [--metric sim3|linear3|elastic|...] [--all] [--joints [--plot OUT.png]]

A library of the shared CMU takes in two formats each: AMC 07_01-07_03 and 09_01-09_03 with their cgspeed Daz
BVH, iClone (Character Creator skeleton, 60 fps) 002_01-002_03 with Daz 02_01-02_03, AMC 16_15 with its
MotionBuilder BVH. Every clip queries the library (``core.search.rank_clips``, sim3, through ``core.io.sources``);
the script prints each query's first result and whether it is the same take, and the count.

No crops: every clip is read as a user reads it (``--trim auto``, ``core.clip.trim``), which drops the Daz BVH files'
rest-pose frame and the converter's ramp and the iClone files' T-pose frame; the AMC originals and 16_15 (both
files hold the same 471 frames) have nothing to trim.

``--all``: the 20 clips query a library of every readable shared clip (92: all BVH files and every AMC whose
subject's skeleton is in the data, as ``experiments/dedupe_check.py`` reads them), not only each other.

``--joints``: for every same-take pair, how far the two files are the same motion, joint by joint: each joint's
rotation over 1/15 s in the comparison space (``log(R[k+s] R[k]^T)``, which no rest pose, bone axis or roll
changes), low-passed as the comparison does, at the frame offset that matches the files best, and the relative
difference |w_a - w_b| / |w_a| per joint (0: the same motion; about 1.4: unrelated motions of the same size);
then, for the torso joints, the second file's RMS rotation rate about each axis of the comparison frame over the
first's (x: forward bend, y: the direction of travel, i.e. lateral lean, z: twist; 1.0: the same amount of motion).
``--plot OUT.png``: the chest's lean and bend rates of run 09_02 (AMC and Daz BVH) and of 16_15 (AMC and its
MotionBuilder BVH), aligned as above (docs/img/rigs_daz_lean.png).
"""

import argparse
import dataclasses
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

import numpy as np  # noqa: E402

from blender_shapesig.core import search as index
from blender_shapesig.core.clip import prepare
from blender_shapesig.core.geometry import so3
from blender_shapesig.core.io import sources  # noqa: E402

_AMC = "uscresl_humanoid-gail/mocap/animations"
_ASF = "Jiaqi-Zuo_CSCI520-Motion-Capture-Interpolation/mocapPlayer-starter"
_DAZ = "Przestr_motion-capture/data"
_ICL = "DragonForgedTheArtist_IClone-CMU-Mocap/All_BVH/subjects/002"
_IMU = "martinling_imusim/imusim/tests/io"


def takes():
    """[(label, take, path, asf)] of the shared clips."""
    out = []
    for t in ("07_01", "07_02", "07_03"):
        out += [("amc", t, f"{_AMC}/{t}.amc", f"{_ASF}/07-walk.asf"), ("daz", t, f"{_DAZ}/07/{t}.bvh", None)]
    for t in ("09_01", "09_02", "09_03"):
        out += [("amc", t, f"{_AMC}/running/{t}.amc", f"{_ASF}/09-run.asf"),
                ("daz", t, f"{_DAZ}/09/{t}.bvh", None)]
    for t in ("02_01", "02_02", "02_03"):
        out += [("iclone", t, f"{_ICL}/0{t}.bvh", None), ("daz", t, f"{_DAZ}/02/{t}.bvh", None)]
    out += [("amc", "16_15", f"{_IMU}/16_15.amc", f"{_IMU}/16.asf"),
            ("mb", "16_15", f"{_IMU}/16_15.bvh", None)]
    return out


def _named(spec, name):
    """The library item of ``spec``, its clip and results named ``name``."""
    item = sources.spec_item(spec)
    item.name = name
    loader = item.load
    item.load = lambda: [dataclasses.replace(c, name=name) for c in loader()]
    return item


def library(data, bone_map="auto"):
    """(items, takes): one LibraryItem per shared clip, named ``format:take``."""
    items, names = [], []
    for fmt, take, path, asf in takes():
        spec = sources.ClipSpec(os.path.join(data, path), asf=None if asf is None else os.path.join(data, asf),
                                bone_map=bone_map)
        items.append(_named(spec, f"{fmt}:{take}"))
        names.append(take)
    return items, names


def all_shared(data, items, bone_map="auto"):
    """The items plus every other readable shared clip (``dedupe_check.library``), named ``other:STEM``."""
    import pathlib

    from dedupe_check import library as shared_library  # tools/: this script's folder

    have = {os.path.realpath(os.path.join(data, path)) for _, _, path, _ in takes()}
    out = list(items)
    for p in shared_library(pathlib.Path(data))[0]:
        spec = p if isinstance(p, sources.ClipSpec) else sources.ClipSpec(p)
        if os.path.realpath(spec.path) not in have:
            out.append(_named(dataclasses.replace(spec, bone_map=bone_map),
                              f"other:{os.path.splitext(os.path.basename(spec.path))[0]}"))
    return out


def _motion(clip, joints, seconds=1 / 15):
    """Per joint, its rotation over ``seconds`` (rotation vectors, comparison space) at every frame of the clip
    low-passed as the comparison does (``core.clip.prepare``, at the clip's own rate), the first and last 0.1 s left
    out (take starts and converter ramps)."""
    R = prepare.prepare_rotations(clip.rotations[:, [clip.bones.index(j) for j in joints]], clip.fps, None)
    s, cut = max(1, round(seconds * clip.fps)), round(0.1 * clip.fps)
    return so3.log(R[s:] @ np.swapaxes(R[:-s], -1, -2))[cut:-cut or None]


TORSO = ("hips", "spine", "spine_mid", "chest", "neck", "head")


def _paired(wa, wb, off):
    """The rows of ``wa`` and ``wb`` that meet when a's frame k + off is b's frame k (equal lengths)."""
    x, y = (wa[off:], wb) if off >= 0 else (wa, wb[-off:])
    n = min(len(x), len(y))
    return x[:n], y[:n]


def joint_agreement(a, b, max_offset=15):
    """(offset, {joint: relative difference}, {joint: (gain x, y, z)}) of two clips of one take at one frame rate (see --joints), b's
    frames shifted by the offset in -max_offset..max_offset that matches all joints best (a's frame k + offset
    with b's frame k); the gains are b's RMS rotation rate about each comparison axis over a's."""
    joints = [j for j in a.bones if j in b.bones]
    wa, wb = _motion(a, joints), _motion(b, joints)

    def misfit(off):
        x, y = _paired(wa, wb, off)
        return np.linalg.norm(x - y) / np.linalg.norm(x)

    off = min(range(-max_offset, max_offset + 1), key=misfit)
    x, y = _paired(wa, wb, off)
    rel = {j: float(np.linalg.norm(x[:, i] - y[:, i]) / max(np.linalg.norm(x[:, i]), 1e-12))
           for i, j in enumerate(joints)}
    gain = np.sqrt((y ** 2).mean(axis=0) / np.maximum((x ** 2).mean(axis=0), 1e-24))
    return off, rel, {j: tuple(float(g) for g in gain[i]) for i, j in enumerate(joints)}


def print_joint_agreement(items, take_of):
    by_take = {}
    for item, take in zip(items, take_of):
        by_take.setdefault(take, []).append(item)
    for take, (a, b) in by_take.items():
        ca, cb = a.clips()[0], b.clips()[0]
        if ca.fps != cb.fps:  # the iClone files (60 fps): at the lower rate, by every n-th frame of the other
            ca, cb = sorted((ca, cb), key=lambda c: c.fps)
            cb = prepare.decimate_clip(cb, round(cb.fps / ca.fps))
        off, rel, gain = joint_agreement(ca, cb)
        print(f"{a.name} vs {b.name} (offset {off:+d} frames): "
              + ", ".join(f"{j} {v:.2f}" for j, v in rel.items()))
        print("  torso rate gain (bend, lean, twist): "
              + ", ".join(f"{j} " + "/".join(f"{g:.1f}" for g in gain[j]) for j in TORSO if j in gain))


def plot_lean(items, out, joint="chest"):
    """The figure of ``--plot``: ``joint``'s rotation rate about the lean and bend axes, two same-take pairs."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    by = {it.name: it for it in items}
    fig, axes = plt.subplots(1, 2, figsize=(12, 4), sharey=True)
    for ax, (a, b) in zip(axes, [("amc:09_02", "daz:09_02"), ("amc:16_15", "mb:16_15")]):
        ca, cb = by[a].clips()[0], by[b].clips()[0]
        off, _rel, gain = joint_agreement(ca, cb)
        wa, wb = _paired(_motion(ca, [joint]), _motion(cb, [joint]), off)
        n = len(wa)
        t = np.arange(n) / ca.fps
        rate = ca.fps / max(1, round(ca.fps / 15))  # rad per 1/15 s -> rad/s
        for axis, name, style in ((1, "lean", "-"), (0, "bend", ":")):
            ax.plot(t, wa[:n, 0, axis] * rate, "C0" + style, label=f"{a} {name}")
            ax.plot(t, wb[:n, 0, axis] * rate, "C1" + style, label=f"{b} {name}")
        g = gain[joint]
        ax.set_title(f"{a.split(':')[1]} {joint}: {b.split(':')[0]} / {a.split(':')[0]} RMS rate: "
                     f"bend {g[0]:.1f}x, lean {g[1]:.1f}x, twist {g[2]:.1f}x", fontsize=10)
        ax.set_xlabel("seconds")
        ax.legend(fontsize=8, loc="upper right")
    axes[0].set_ylabel("rotation rate (rad/s), comparison frame")
    fig.suptitle("The same take in two files: the Daz conversion leans the torso ~3x more (left); an exact "
                 "conversion does not (right)", fontsize=11)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print(f"wrote {out}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", required=True, help="the shared CMU folder")
    ap.add_argument("--bone-map", default="auto")
    ap.add_argument("--metric", default="sim3")
    ap.add_argument("--rerank", type=int, default=0)
    ap.add_argument("--all", action="store_true", help="the library: every readable shared clip (92)")
    ap.add_argument("--joints", action="store_true", help="per same-take pair, how far the files' joints agree")
    ap.add_argument("--plot", help="with --joints: write the chest's lean figure to this PNG")
    args = ap.parse_args(argv)
    items, take_of = library(args.data, args.bone_map)
    if args.joints:
        print_joint_agreement(items, take_of)
        if args.plot:
            plot_lean(items, args.plot)
        return 0
    library_items = all_shared(args.data, items, args.bone_map) if args.all else items
    cache = index.SignatureCache()
    ok = 0
    for i, q in enumerate(items):
        res = index.rank_clips(q, library_items, metric=args.metric, cache=cache, exclude=(q.key,), rerank=args.rerank)
        first = res[0] if res else None
        same = first is not None and first.name.split(":")[1] == take_of[i] and first.name != q.name
        ok += same
        d = f"{first.distance:.3f}" if first else "-"
        cov = f"{first.coverage:.2f}" if first else "-"
        print(f"{q.name:14s} -> {first.name if first else '(none)':14s} {d}  coverage {cov}  "
              f"{'ok' if same else 'MISS'}")
    print(f"same take first: {ok}/{len(items)} ({args.metric}, bone map {args.bone_map}, "
          f"library of {len(library_items)} clips)")
    return 0 if ok == len(items) else 1


if __name__ == "__main__":
    sys.exit(main())
