"""A long take built from the CMU BVH clips of tests/data (one Daz skeleton): segments of other takes one after
another, each played at its own speed (channels interpolated, rotations unwrapped: ``planted.resample``), its
root path moved to start where the previous one ended; and the jumps in it labelled from the feet's height
(``airborne``). ``tests/core/search/test_moments_every_occurrence.py``; the experiment on a real long take,
``experiments/moments_every_jump.py``, labels its jumps by the same rule."""

import numpy as np

from blender_shapesig.core.clip import skeleton
from blender_shapesig.core.io.bvh import bvh_text, load_bvh, parse_bvh
from tests.helpers.planted import resample, rotation_columns

__all__ = ["build_take", "airborne", "AIRBORNE_LEGS"]

TRIM = 9  # the Daz files' rest frame and ramp (tests/data/README.md)
AIRBORNE_LEGS = 0.1  # the lowest foot point above the ground by this many leg lengths: airborne
SHORTEST = 0.2  # seconds: a jump's flight (a run's flight phases are about 0.1 s)


def _lowest(clip, feet=("lFoot", "rFoot")):
    """(frames,) the lowest of the feet bones' heads and tails (armature axes: Z up)."""
    heads, tails, _ = skeleton.forward_kinematics(clip)
    idx = [clip.bones.index(b) for b in feet]
    return np.minimum(heads[:, idx, 2], tails[:, idx, 2]).min(axis=1)


def _ground(source):
    return float(np.percentile(_lowest(load_bvh(source))[TRIM:], 5))


def build_take(segments, path):
    """Write the take of ``segments`` [(BVH path, speed)] to ``path``; returns [(first, last)] the frames (file
    numbering, from 1) each segment occupies."""
    rows, spans, end = [], [], None
    header = None
    for source, speed in segments:
        joints, frame_time, values = parse_bvh(source)
        values = values[TRIM:]
        where = np.arange(0, len(values) - 1, speed)
        part = resample(values, rotation_columns(joints), where)
        pos = [joints[0].columns("position")[a] for a in "xz"]
        part[:, joints[0].columns("position")["y"]] -= _ground(source)  # every segment on one floor
        if end is not None:
            part[:, pos] += end - part[0, pos]
        end = part[-1, pos]
        spans.append((len(rows) + 1, len(rows) + len(part)))
        rows.extend(part)
        if header is None:
            text = bvh_text(source)[0].splitlines()
            header = text[:next(i for i, ln in enumerate(text) if ln.strip().upper() == "MOTION") + 1]
            step = frame_time
    body = "\n".join(" ".join(f"{v:.6f}" for v in row) for row in rows)
    with open(path, "w", encoding="utf-8", newline="\n") as f:
        f.write("\n".join(header) + f"\nFrames: {len(rows)}\nFrame Time: {step:.8f}\n{body}\n")
    return spans


def airborne(clip, feet, leg):
    """[(first, last)] the clip's airborne stretches (its own frame numbers): where the lowest of the ``feet``
    bones' heads and tails is more than ``AIRBORNE_LEGS`` leg lengths above the ground (the 5th percentile of that
    lowest point over the take), for at least ``SHORTEST`` seconds: the jumps. ``clip``: read without a bone map (armature
    axes, Z up); ``leg``: the rig's leg length in its units."""
    low = _lowest(clip, feet)
    up = (low - np.percentile(low, 5)) > AIRBORNE_LEGS * leg
    edges = np.flatnonzero(np.diff(np.concatenate([[0], up.astype(int), [0]])))
    return [(int(clip.frame_start + a), int(clip.frame_start + b - 1)) for a, b in zip(edges[::2], edges[1::2])
            if (b - a) >= SHORTEST * clip.fps]
