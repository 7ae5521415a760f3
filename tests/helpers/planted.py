"""Planted near-duplicates: copies of BVH clips that a library report must put in their original's cluster
(``experiments/dedupe_check.py``, ``tests/dedupe/test_dedupe.py``).

* ``renamed``: the same bytes under another name;
* ``rate``: every ``step``-th frame, the frame time multiplied by ``step`` (120 fps -> 60 fps);
* ``trimmed_retimed``: ``trim`` of the frames cut at each end, the rest played through a non-uniform warp
  u + a sin(2 pi u) (speed varying by up to 2 pi a) and ``stretch`` times as many frames; the channels are
  interpolated linearly, rotations unwrapped first (Euler angles never jump by 360 degrees between samples).
"""

import os
import shutil

import numpy as np

from blender_shapesig.core.io.bvh import bvh_text, parse_bvh

__all__ = ["renamed", "rate", "trimmed_retimed", "variant", "plant"]


def _write(path, source, values, frame_time):
    text = bvh_text(source)[0]
    lines = text.splitlines()
    motion = next(i for i, ln in enumerate(lines) if ln.strip().upper() == "MOTION")
    body = "\n".join(" ".join(f"{v:.6g}" for v in row) for row in values)
    with open(path, "w", encoding="utf-8", newline="\n") as f:
        f.write("\n".join(lines[:motion + 1]) + f"\nFrames: {len(values)}\nFrame Time: {frame_time:.8f}\n{body}\n")
    return path


def renamed(source, path):
    shutil.copyfile(source, path)
    return path


def rate(source, path, step=2):
    _joints, frame_time, values = parse_bvh(source)
    return _write(path, source, values[::step], frame_time * step)


def rotation_columns(joints):
    return sorted(c for j in joints for c in j.columns("rotation").values())


def resample(values, rot, where, gain=None):
    """The channels at fractional frames ``where`` (linear interpolation; rotation columns ``rot`` unwrapped
    first, their swing about the mean multiplied by ``gain`` (one factor per column) if given, wrapped back to
    [-180, 180) last)."""
    unwrapped = values.copy()
    unwrapped[:, rot] = np.degrees(np.unwrap(np.radians(values[:, rot]), axis=0))
    x = np.arange(len(values))
    out = np.stack([np.interp(where, x, unwrapped[:, c]) for c in range(values.shape[1])], axis=1)
    if gain is not None:
        mean = out[:, rot].mean(axis=0)
        out[:, rot] = mean + (out[:, rot] - mean) * gain
    out[:, rot] = (out[:, rot] + 180.0) % 360.0 - 180.0
    return out


def trimmed_retimed(source, path, trim=0.1, amplitude=0.06, stretch=1.15):
    joints, frame_time, values = parse_bvh(source)
    n = len(values)
    a, b = int(round(trim * n)), int(round((1.0 - trim) * n)) - 1
    u = np.linspace(0.0, 1.0, int(round((b - a + 1) * stretch)))
    where = a + (b - a) * (u + amplitude * np.sin(2.0 * np.pi * u))
    return _write(path, source, resample(values, rotation_columns(joints), where), frame_time)


def variant(source, path, rng, keep=(0.5, 1.0), speed=(0.8, 1.25), scale=(0.7, 1.3), shortest=2.0):
    """A *different* take made from ``source`` for simulated libraries (benchmarks/bench_dedupe.py): a random
    window of a fraction ``keep`` of the frames (at least ``shortest`` seconds, or the whole take when it is
    shorter), played ``speed`` times as fast, every rotation channel's
    swing about its mean scaled by a random factor in ``scale`` (so variants of one source differ in
    amplitude per joint and axis, as takes of one actor do). ``rng``: a numpy Generator."""
    joints, frame_time, values = parse_bvh(source)
    n = len(values)
    length = min(max(int(rng.uniform(*keep) * n), int(shortest / frame_time), 8), n)
    a = int(rng.integers(0, n - length + 1))
    where = np.arange(a, a + length - 1, rng.uniform(*speed))
    rot = rotation_columns(joints)
    return _write(path, source, resample(values, rot, where, rng.uniform(*scale, size=len(rot))), frame_time)


def plant(folder, walk, run, jump):
    """Plant the three copies into ``folder``: a renamed ``walk``, ``run`` at half its rate and a trimmed,
    re-timed ``jump``; returns ``{copy path: original path}``."""
    os.makedirs(folder, exist_ok=True)
    out = {renamed(walk, os.path.join(folder, "planted_renamed.bvh")): walk,
           rate(run, os.path.join(folder, "planted_half_rate.bvh")): run,
           trimmed_retimed(jump, os.path.join(folder, "planted_trimmed_retimed.bvh")): jump}
    return {os.path.abspath(k): os.path.abspath(v) for k, v in out.items()}
