"""The tests/data library of the rig-kind tests (issue 38): its walks, runs and jump as read by the package's
readers, plus two idles made here (a walk's and a run's first pose held for 4 s with a slow breathing sway of the
spine, head and upper arms), so that "finds walks first" is asked among walks, runs and idles."""

import csv
import pathlib
from dataclasses import replace

import numpy as np

from blender_shapesig.core.geometry import so3
from blender_shapesig.core.io import sources

DATA = pathlib.Path(__file__).resolve().parents[1] / "data"


def read(rel, step=1):
    """A tests/data clip (comparison space), every ``step``-th frame (120 fps / 4 = 30 fps: fewer frames)."""
    asf = {"07": "07-walk.asf", "09": "09-run.asf", "16": "16.asf"}.get(pathlib.Path(rel).name[:2])
    spec = sources.ClipSpec(str(DATA / rel), asf=str(DATA / "acclaim" / asf) if rel.endswith(".amc") else None)
    clip = sources.read_one(spec)
    rt = None if clip.root_translation is None else clip.root_translation[::step]
    return replace(clip, name=rel, rotations=clip.rotations[::step], root_translation=rt, fps=clip.fps / step)


def idle(base, name, seconds=4.0):
    """``base``'s first pose held for ``seconds``, the spine, head and upper arms swaying 1.5-3 degrees at 0.3 Hz."""
    n = int(seconds * base.fps)
    R = np.repeat(base.rotations[:1], n, axis=0)
    t = np.arange(n) / base.fps
    for joint, degrees in (("spine", 1.5), ("chest", 2.0), ("head", 3.0), ("upper_arm.L", 2.0), ("upper_arm.R", 2.0)):
        if joint in base.bones:
            k = base.bones.index(joint)
            sway = np.radians(degrees) * np.sin(2 * np.pi * 0.3 * t)[:, None] * np.array([1.0, 0.0, 0.0])
            R[:, k] = so3.exp(sway) @ R[:, k]
    rt = None if base.root_translation is None else np.repeat(base.root_translation[:1], n, axis=0)
    return replace(base, name=name, rotations=R, root_translation=rt)


def library(leave_out):
    """({name: label}, clips): every labelled tests/data clip whose file does not contain ``leave_out``, and two
    idles."""
    with open(DATA / "labels.csv", encoding="utf-8") as fh:
        labels = {row["file"]: row["label"] for row in csv.DictReader(fh) if leave_out not in row["file"]}
    clips = [read(f) for f in labels]
    for name, rel in (("idle:07_01", "acclaim/07_01.amc"), ("idle:09_02", "bvh/09_02.bvh")):
        clips.append(idle(read(rel), name))
        labels[name] = "idle"
    return labels, clips


def walks_first(ranked, labels):
    """Assert every walk of the library ranks before every other clip."""
    order = [labels[r.name] for r in ranked]
    walks = order.count("walk")
    assert walks >= 4 and order[:walks] == ["walk"] * walks, [(r.name, round(r.distance, 3)) for r in ranked]
