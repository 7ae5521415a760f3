"""Benchmark of in-betweening and best cuts (``core.blend.transition``), the LaFAN1 protocol on the data we have.

Usage (from the repository root; no Blender needed):

    .venv/bin/python benchmarks/bench_inbetween.py --train DIR... --test DIR... [--train-match S,...]
        [--test-match S,...] [--json OUT.json]

HDM05 development split (actors bd + bk train, dg test; every class folder holds all three actors):

    .venv/bin/python benchmarks/bench_inbetween.py --train ../shared/data/hdm05/train \\
        --train-match HDM_bd_,HDM_bk_ --test ../shared/data/hdm05/train --test-match HDM_dg_ --json out.json

Protocol (``../shared/reference/inbetweening.md``): clips at 30 fps; test windows of 65 frames every 40 frames,
training windows of 50 frames every 20 (for the position statistics only: no method trains); each window centred
on the ground at the root of its last context frame (frame 9) and turned so the root's heading there is zero;
10 context frames, gaps of 5, 15 and 30 frames, the target frame 10 + n known (only that frame: no velocity after
the gap). Metrics over the gap's frames, then the windows: ``l2q`` (global joint quaternions, sign fixed to the
truth's hemisphere), ``l2p`` (global joint positions normalised per joint and axis by the training windows' mean
and standard deviation), ``npss`` (power spectra of the global quaternions), ``foot_skate_cm`` (horizontal
motion of heel and ball points in cm per frame where the point is within 2.5 cm of its lowest height in the
window, pooled over the gap's contact frames), ``seam_step_deg`` (the largest joint rotation step at either seam,
frame 9 -> 10 and the last generated frame -> the target; the truth's is reported as "ground truth"), ``ms`` per
in-between. Methods: zero velocity, interpolation (SLERP of local rotations, linear root), ours (1) (the
velocity-carrying geodesic), ours (2) (the bridge from the training clips). Also: best cuts on takes split in two
overlapping parts (A = frames 0..k+m, B = frames k..end at the clips' own rate; the first cut's A frame - B frame
is k within 2 frames) and speed (best cuts of two 10-s clips, a 30-frame in-between, a bridge from a 1,000-clip
library) as milliseconds and as ratios to the interpolation baseline timed in the same run.
"""

import argparse
import json
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

from blender_shapesig.core.blend.body import resample  # noqa: E402
from blender_shapesig.core.blend.bridge import Bridges  # noqa: E402
from blender_shapesig.core.blend.contacts import feet_positions, legs_of  # noqa: E402
from blender_shapesig.core.blend.transition import best_cuts, inbetween  # noqa: E402
from blender_shapesig.core.clip.skeleton import forward_kinematics, rest_of, unit_meters, up_vector  # noqa: E402
from blender_shapesig.core.errors import ShapeSigError  # noqa: E402
from blender_shapesig.core.geometry import so3  # noqa: E402
from blender_shapesig.core.geometry.curves import geodesic_interpolate  # noqa: E402
from blender_shapesig.core.io.sources import discover, read  # noqa: E402

FPS = 30.0
CONTEXT = 10
GAPS = (5, 15, 30)
TEST_WINDOW, TEST_STEP = 65, 40
TRAIN_WINDOW, TRAIN_STEP = 50, 20
CONTACT_CM = 2.5
METHODS = ("zero_velocity", "interpolation", "ours_1", "ours_2")


def load(dirs, match):
    clips = []
    for spec in discover(dirs):
        if match and not any(m in os.path.basename(spec) for m in match):
            continue
        try:
            clips.extend(read(spec, bone_map="none"))
        except ShapeSigError as exc:
            print(f"skipped {spec}: {exc}", file=sys.stderr)
    return clips


def windows(clip, length, step):
    return [clip.crop(clip.frame_start + s, clip.frame_start + s + length - 1)
            for s in range(0, clip.frames - length + 1, step)]


# ------------------------------------------------------------------------------------------------ global features

def canonical(clip, frame=CONTEXT - 1):
    """(quaternions (F, J, 4), positions (F, J, 3) in metres, up) of the clip centred on the ground at the root of
    ``frame`` and turned so the root's heading there is zero."""
    rest = rest_of(clip)
    heads, _tails, W = forward_kinematics(clip, rest)
    up = up_vector(clip)
    root = rest.root if rest.root is not None else 0
    yaw = so3.heading(W[frame, root], up)
    T = so3.exp(-yaw * up)
    origin = heads[frame, root] - (heads[frame, root] @ up) * up
    unit = unit_meters(clip, [(t, f) for t, _s, f in legs_of(clip).values()])
    pos = (heads - origin) @ T.T * unit
    Q = so3.quat_from_matrix(T[None, None] @ W, scalar_first=True)
    return Q, pos


def npss(gt, pred):
    """NPSS of quaternion features (F, J, 4) over the gap's frames."""
    g = gt.reshape(len(gt), -1)
    p = pred.reshape(len(pred), -1)
    pg = np.abs(np.fft.rfft(g, axis=0)) ** 2
    pp = np.abs(np.fft.rfft(p, axis=0)) ** 2
    tg, tp = pg.sum(axis=0), pp.sum(axis=0)
    ng = pg / np.maximum(tg, 1e-12)
    npp = pp / np.maximum(tp, 1e-12)
    emd = np.abs(np.cumsum(ng, axis=0) - np.cumsum(npp, axis=0)).sum(axis=0)
    return float(np.sum(emd * tg / max(tg.sum(), 1e-12)))


def skate(clip, gap):
    """(sum of horizontal steps in cm, contact frames) of heel and ball points over the gap's frames."""
    legs = legs_of(clip)
    pos = feet_positions(clip, legs)
    up = up_vector(clip)
    unit = unit_meters(clip, [(t, f) for t, _s, f in legs.values()])
    total, count = 0.0, 0
    for side in pos.values():
        for p in side.values():
            h = (p @ up) * unit * 100.0
            step = np.diff(p, axis=0)
            step = step - np.outer(step @ up, up)
            v = np.linalg.norm(step, axis=1) * unit * 100.0
            k = np.arange(CONTEXT, CONTEXT + gap)
            low = h[k] < h.min() + CONTACT_CM
            total += float(v[k - 1][low].sum())
            count += int(low.sum())
    return total, count


def seam_step(clip, gap):
    steps = np.degrees(np.linalg.norm(so3.relative_rotvecs(clip.rotations), axis=-1)).max(axis=1)
    return float(max(steps[CONTEXT - 1], steps[CONTEXT + gap - 1]))


# ------------------------------------------------------------------------------------------------ methods

def _with_gap(window, gap, R, rt):
    out_R = window.rotations[:CONTEXT + gap + 1].copy()
    out_R[CONTEXT:CONTEXT + gap] = R
    out_rt = None
    if window.root_translation is not None:
        out_rt = window.root_translation[:CONTEXT + gap + 1].copy()
        out_rt[CONTEXT:CONTEXT + gap] = rt
    from dataclasses import replace

    return replace(window, rotations=out_R, root_translation=out_rt)


def zero_velocity(window, gap, _lib):
    R = np.repeat(window.rotations[CONTEXT - 1][None], gap, axis=0)
    rt = np.repeat(window.root_translation[CONTEXT - 1][None], gap, axis=0)
    return R, rt


def interpolation(window, gap, _lib):
    s = np.arange(1, gap + 1) / (gap + 1.0)
    ends = window.rotations[[CONTEXT - 1, CONTEXT + gap]]
    R = geodesic_interpolate(ends, np.array([0.0, 1.0]), s)
    p0, p1 = window.root_translation[CONTEXT - 1], window.root_translation[CONTEXT + gap]
    return R, p0[None] + s[:, None] * (p1 - p0)[None]


def ours(window, gap, lib):
    before = window.crop(window.frame_start, window.frame_start + CONTEXT - 1)
    target = window.crop(window.frame_start + CONTEXT + gap, window.frame_start + CONTEXT + gap)
    out = inbetween(before, target, gap, library=lib)
    return out.rotations, out.root_translation


def evaluate(test, stats, gap, method, lib):
    mean, std = stats
    rows = {k: [] for k in ("l2q", "l2p", "npss", "seam", "seam_gt", "ms")}
    sk = np.zeros(2)
    sk_gt = np.zeros(2)
    for w in test:
        t0 = time.perf_counter()
        R, rt = method(w, gap, lib)
        rows["ms"].append((time.perf_counter() - t0) * 1000.0)
        gt = w.crop(w.frame_start, w.frame_start + CONTEXT + gap)
        pred = _with_gap(w, gap, R, rt)
        Qg, Pg = canonical(gt)
        Qp, Pp = canonical(pred)
        k = slice(CONTEXT, CONTEXT + gap)
        qg, qp = Qg[k], Qp[k]
        qp = np.where(np.sum(qg * qp, axis=-1, keepdims=True) < 0, -qp, qp)
        rows["l2q"].append(np.linalg.norm((qg - qp).reshape(gap, -1), axis=1).mean())
        ng, nprd = (Pg[k] - mean) / std, (Pp[k] - mean) / std
        rows["l2p"].append(np.linalg.norm((ng - nprd).reshape(gap, -1), axis=1).mean())
        rows["npss"].append(npss(qg, qp))
        rows["seam"].append(seam_step(pred, gap))
        rows["seam_gt"].append(seam_step(gt, gap))
        sk += skate(pred, gap)
        sk_gt += skate(gt, gap)
    out = {k: float(np.mean(v)) for k, v in rows.items() if k not in ("seam", "seam_gt")}
    out["seam_step_deg"] = float(np.mean(rows["seam"]))
    out["seam_step_deg_gt"] = float(np.mean(rows["seam_gt"]))
    out["foot_skate_cm"] = float(sk[0] / max(sk[1], 1))
    out["foot_skate_cm_gt"] = float(sk_gt[0] / max(sk_gt[1], 1))
    return out


def position_stats(train):
    P = np.concatenate([canonical(w)[1] for w in train])
    return P.mean(axis=0), np.maximum(P.std(axis=0), 1e-6)


# ------------------------------------------------------------------------------------------------ cuts and speed

def split_cuts(clips, overlap=0.5):
    """Per clip (own rate): A = 0..k+m, B = k..end with k a third of the clip and m = ``overlap`` s; True when the
    first cut's A frame - B frame is k within 2 frames."""
    hits, rows = 0, []
    for c in clips:
        m = int(round(overlap * c.fps))
        k = c.frames // 3
        if k + m >= c.frames - 1 or c.frames - k < m:
            continue
        a = c.crop(c.frame_start, c.frame_start + k + m)
        b = c.crop(c.frame_start + k, None)
        try:
            first = best_cuts(a, b, top=1)[0]
        except ShapeSigError:
            continue
        ok = abs(first.a_frame - first.b_frame - k) <= 2
        hits += ok
        rows.append({"clip": c.name, "k": k, "a_frame": first.a_frame, "b_frame": first.b_frame, "hit": bool(ok)})
    return {"takes": len(rows), "first_cut_true": hits, "rate": hits / max(len(rows), 1),
            "misses": [r for r in rows if not r["hit"]][:20]}


def _steps(clip):
    heads = forward_kinematics(clip)[0]
    r = clip.bones.index(clip.root_bone)
    return (np.linalg.norm(np.diff(heads[:, r], axis=0), axis=1),
            np.degrees(np.linalg.norm(so3.relative_rotvecs(clip.rotations), axis=-1)).max(axis=1))


def joins(pairs, frames=None):
    """Transitions across takes (``A:B`` pairs of clip files, read on their own rigs): per pair the largest root
    step at the seams (from 2 frames before the cut to 2 after B starts) over the sources' largest, the largest
    joint step there minus the sources' largest (degrees), and the largest stance drift (cm) of a heel or ball
    contact run touching the generated frames (``contacts.find_contacts`` on the joined clip)."""
    from blender_shapesig.core.blend import feet
    from blender_shapesig.core.blend.contacts import POINTS, find_contacts, stance_drift
    from blender_shapesig.core.blend.transition import transition

    rows = []
    for pair in pairs:
        pa, pb = pair.split(":")
        a, b = read(pa, bone_map="none")[0], read(pb, bone_map="none")[0]
        t0 = time.perf_counter()
        joined = transition(a, b, frames=frames)
        ms = (time.perf_counter() - t0) * 1e3
        info = joined.meta["transition"]
        i, n = info["cut"]["a_frame"], info["frames"]
        rj, jj = _steps(joined)
        seam = slice(max(i - 2, 0), i + n + 3)
        ra, ja = _steps(a)
        rb, jb = _steps(b)
        src_root = max(rj[:i].max(), rj[i + n + 1:].max())  # A, and B as placed on A's rig (A's units)
        legs = legs_of(joined)
        contacts = find_contacts(joined, legs)
        pos = feet_positions(joined, legs)
        unit = unit_meters(joined, [(t, f) for t, _s, f in legs.values()])
        drift = 0.0
        for side in contacts:
            for point in POINTS:
                mask = contacts[side][point].copy()
                keep = np.zeros_like(mask)
                for s_, e_ in _runs_of(mask):
                    if e_ >= i + 1 and s_ <= i + n:
                        keep[s_:e_ + 1] = True
                d = stance_drift(pos[side][point], keep)
                drift = max([drift] + [x * unit * 100 for x in d])
        src_drift = max(max(feet.source_drifts(a), default=0.0), max(feet.source_drifts(b), default=0.0)) * 100
        gap_drift, low_slide = _made_slides(joined, contacts, pos, unit, i, n)
        rows.append({"pair": [a.name, b.name], "cut": info["cut"], "frames": n,
                     "root_step_ratio": float(rj[seam].max() / max(src_root, 1e-12)),
                     "joint_step_excess_deg": float(jj[seam].max() - max(ja.max(), jb.max())),
                     "drift_cm": drift, "source_drift_cm": src_drift, "gap_drift_cm": gap_drift,
                     "low_slide_cm": low_slide, "ms": ms})
    return rows


def _made_slides(joined, contacts, pos, unit, i, n):
    """What the transition itself makes of the feet, over its frames i .. i + n + 1 (A's last frame, the
    generated ones, B's first): ``gap_drift`` the largest slide (cm) of a heel or ball contact (``find_contacts``)
    there, and ``low_slide`` the largest horizontal travel (cm) of a point that stays within 2 cm of its lowest
    height over that span and half a second on each side (low, whatever its speed: a foot pushed over the floor
    is no contact by the speed rule, but slides)."""
    from blender_shapesig.core.blend.contacts import POINTS, stance_drift

    up = up_vector(joined)
    lo, hi = i, min(i + n + 1, joined.frames - 1)
    half = int(round(0.5 * joined.fps))
    gap_drift = low_slide = 0.0
    for side in contacts:
        for point in POINTS:
            p = pos[side][point]
            keep = np.zeros(len(p), bool)
            keep[lo:hi + 1] = contacts[side][point][lo:hi + 1]
            gap_drift = max([gap_drift] + [d * unit * 100 for d in stance_drift(p, keep)])
            h = (p @ up) * unit
            near = h[max(lo - half, 0):hi + half + 1]
            low = np.zeros(len(p), bool)
            low[lo:hi + 1] = h[lo:hi + 1] < near.min() + 0.02
            flat = p - np.outer(p @ up, up)
            low_slide = max([low_slide] + [d * unit * 100 for d in stance_drift(flat, low)])
    return gap_drift, low_slide


def _runs_of(mask):
    m = np.concatenate([[False], np.asarray(mask, bool), [False]])
    d = np.diff(m.astype(np.int8))
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1) - 1))


def _tiled(clip, seconds):
    from dataclasses import replace

    n = int(seconds * clip.fps)
    reps = int(np.ceil(n / clip.frames))
    R = np.concatenate([clip.rotations] * reps)[:n]
    rt = np.concatenate([clip.root_translation] * reps)[:n]
    return replace(clip, rotations=R, root_translation=rt)


def speed(test_clips, train_clips, windows_test):
    from _common import timed

    w = windows_test[0]
    base = timed(lambda: interpolation(w, 30, None), repeat=20).wall_median
    a, b = _tiled(test_clips[0], 10.0), _tiled(test_clips[-1], 10.0)
    cuts = timed(lambda: best_cuts(a, b), repeat=3).wall_median
    ours1 = timed(lambda: ours(w, 30, None), repeat=10).wall_median
    lib = Bridges((train_clips * (1000 // len(train_clips) + 1))[:1000], FPS)
    ours(w, 30, lib)  # features computed once
    ours2 = timed(lambda: ours(w, 30, lib), repeat=3).wall_median
    ms = {"interpolation_30": base * 1e3, "best_cuts_10s": cuts * 1e3, "ours_1_30": ours1 * 1e3,
          "ours_2_30_1000_clips": ours2 * 1e3}
    return {"ms": ms, "ratio_to_interpolation": {k: v / (base * 1e3) for k, v in ms.items()},
            "best_cuts_clip_seconds": [round((a.frames - 1) / a.fps, 2), round((b.frames - 1) / b.fps, 2)]}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--train", nargs="+", required=True)
    p.add_argument("--test", nargs="+", required=True)
    p.add_argument("--train-match", default="", help="keep files whose name holds one of these (comma-separated)")
    p.add_argument("--test-match", default="")
    p.add_argument("--json", metavar="OUT.json")
    p.add_argument("--no-speed", action="store_true")
    p.add_argument("--joins", nargs="*", default=(), metavar="A:B",
                   help="also join these takes (clip files A:B) and measure the seams")
    args = p.parse_args(argv)
    train_own = load(args.train, [m for m in args.train_match.split(",") if m])
    test_own = load(args.test, [m for m in args.test_match.split(",") if m])
    train = [resample(c, FPS) for c in train_own]
    test = [resample(c, FPS) for c in test_own]
    tw = [w for c in train for w in windows(c, TRAIN_WINDOW, TRAIN_STEP)]
    sw = [w for c in test for w in windows(c, TEST_WINDOW, TEST_STEP)]
    print(f"train: {len(train)} clips, {len(tw)} windows; test: {len(test)} clips, {len(sw)} windows")
    stats = position_stats(tw)
    lib = Bridges(train, FPS)
    results = {"train_clips": len(train), "test_clips": len(test), "test_windows": len(sw), "methods": {}}
    methods = {"zero_velocity": zero_velocity, "interpolation": interpolation, "ours_1": ours, "ours_2": ours}
    for name, fn in methods.items():
        results["methods"][name] = {}
        for gap in GAPS:
            r = evaluate(sw, stats, gap, fn, lib if name == "ours_2" else None)
            results["methods"][name][str(gap)] = r
            print(f"{name:14s} gap {gap:2d}: l2q {r['l2q']:.3f} l2p {r['l2p']:.3f} npss {r['npss']:.4f} "
                  f"skate {r['foot_skate_cm']:.2f} cm (gt {r['foot_skate_cm_gt']:.2f}) seam {r['seam_step_deg']:.2f} "
                  f"deg (gt {r['seam_step_deg_gt']:.2f}) {r['ms']:.2f} ms")
    results["cuts"] = split_cuts(test_own)
    print(f"best cuts on split takes: {results['cuts']['first_cut_true']} of {results['cuts']['takes']} first cuts "
          f"true (+-2 frames)")
    if args.joins:
        results["joins"] = joins(args.joins)
        for r in results["joins"]:
            print(f"join {r['pair'][0]} -> {r['pair'][1]}: cut {r['cut']['a_frame']}:{r['cut']['b_frame']}, root step "
                  f"x{r['root_step_ratio']:.2f} of the sources' largest, joint step {r['joint_step_excess_deg']:+.1f} deg over "
                  f"the sources', contact drift {r['drift_cm']:.1f} cm (sources' largest {r['source_drift_cm']:.1f}; "
                  f"over the transition's frames {r['gap_drift_cm']:.1f}, low-foot slide {r['low_slide_cm']:.1f}), "
                  f"{r['ms']:.0f} ms")
    if not args.no_speed:
        results["speed"] = speed(test, train, sw)
        print("speed (ms, ratio to interpolation):",
              {k: (round(v, 2), round(results['speed']['ratio_to_interpolation'][k], 1))
               for k, v in results["speed"]["ms"].items()})
    if args.json:
        from _common import write_json

        write_json(args.json, results)
    return results


if __name__ == "__main__":
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    main()
