"""Shared parts of the local-search experiments (issue 29): reading labelled sets through the package's front door
(``core.io.sources``, raw clips then ``rigs.apply_bone_map``, so crops are cut before the comparison space as a user's
would be), per-clip features cached on disk, the DTW baseline's sequences, the two-stage ranking from distance
matrices, and the scores (leave-one-out / leave-one-actor-out 1-NN and mAP, crop probes)."""

import csv
import os
import pickle
import sys

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

from blender_shapesig.core.search.local import features as ls  # noqa: E402
from blender_shapesig.core import rigs
from blender_shapesig.core.io import sources  # noqa: E402



FEATURES = "canon2"  # the feature recipe's tag in the cache files' names (change it when features change)


class Item:
    """A labelled clip: ``name``, ``label``, ``group`` (actor / format), the raw clip (trimmed, not mapped)."""

    def __init__(self, name, label, group, raw):
        self.name, self.label, self.group, self.raw = name, label, group, raw

    def mapped(self, crop=None):
        """The clip in the comparison space, optionally cropped first: ``crop`` = ("start"|"end", fraction)."""
        c = self.raw
        if crop is not None:
            side, frac = crop
            cut = int(round(frac * c.frames))
            c = c.crop(c.frame_start + cut, None) if side == "start" else c.crop(None, c.frame_end - cut)
        return rigs.apply_bone_map(c, "auto")


def read_spec(spec):
    import dataclasses
    return sources.read_one(dataclasses.replace(spec, bone_map="none"))


def load_hdm05(data):
    items = []
    with open(os.path.join(data, "index.csv"), newline="") as fh:
        for row in csv.DictReader(fh):
            path = os.path.join(data, row["file"])
            folder, base = os.path.split(path)
            asf = os.path.join(folder, base.split("_")[0] + "_" + base.split("_")[1] + ".asf")
            raw = read_spec(sources.ClipSpec(path, asf=asf))
            items.append(Item(os.path.splitext(base)[0], row["label"], row["actor"], raw))
    return items


def load_eval_set(csv_path, data):
    from blender_shapesig import evaluation as ev
    from blender_shapesig.core.clip.prepare import decimate_clip

    items = []
    for e in ev.read_index(csv_path):
        spec = ev.entry_spec(e, data, bone_map="none")
        raw = decimate_clip(sources.read_one(spec), e.step)
        items.append(Item(os.path.splitext(os.path.basename(e.file))[0], e.label, os.path.dirname(e.file), raw))
    return items


def cached(path, make):
    if os.path.exists(path):
        with open(path, "rb") as fh:
            return pickle.load(fh)
    out = make()
    os.makedirs(os.path.dirname(path) or ".", exist_ok=True)
    with open(path, "wb") as fh:
        pickle.dump(out, fh)
    return out


def clip_features(clip, settings=ls.DEFAULT):
    """The local search's features plus the DTW baseline's sequence ``all``: every canonical joint's head of the
    rig (its own proportions) but the hips, relative to the hips, in the hips' heading frame, in leg lengths."""
    f = ls.features(clip, settings)
    heads, _ = ls.rig_positions(clip)
    from blender_shapesig.core.rigs.names import CANONICAL_PARENTS
    names = [j for j in list(CANONICAL_PARENTS)[1:] if j in heads]
    P = np.stack([heads[j] for j in names], axis=1) - heads["hips"][:, None]
    side = (heads["thigh.L"] - heads["thigh.R"]) + (heads["upper_arm.L"] - heads["upper_arm.R"])
    P = ls._resample(P, clip.fps, settings.rate)
    yaw = ls._facing(ls._resample(side, clip.fps, settings.rate))
    c, s = np.cos(yaw), np.sin(yaw)
    local = np.stack([c[:, None] * P[..., 0] + s[:, None] * P[..., 1],
                      -s[:, None] * P[..., 0] + c[:, None] * P[..., 1], P[..., 2]], axis=-1)
    f["all"] = local.reshape(len(local), -1)
    return f


def set_features(items, cache_path, crops=(("start", 0.1), ("end", 0.1))):
    """{"full": [features], ("start", 0.1): [features], ...} for the items (cached)."""
    def make():
        out = {"full": [clip_features(it.mapped()) for it in items]}
        for c in crops:
            out[c] = [clip_features(it.mapped(c)) for it in items]
        return out
    return cached(cache_path, make)


# --------------------------------------------------------------------------------------------- rankings

def two_stage_order(d1_row, candidates, k, d2_of, mix=0.0, dg_of=None, gw=0.0):
    """Candidates (indices) ordered by d1, the first k re-ordered by d2_of(j) (``mix`` > 0: by
    d2 / mean d2 + mix * d1 / mean d1 over the k, ``local_search.combine``)."""
    cand = np.asarray(candidates)
    order = cand[np.argsort(d1_row[cand], kind="stable")]
    if k:
        head = order[:k]
        d2 = np.array([d2_of(j) for j in head])
        dg = None if not gw else np.array([dg_of(j) for j in head])
        score = ls.combine(d1_row[head], d2, mix, dg, gw)
        order = np.concatenate([head[np.argsort(score, kind="stable")], order[k:]])
    return order


def scores(orders, labels, queries):
    """(1-NN accuracy, mAP) of rankings ``orders[i]`` (candidate indices, best first) of query ``queries[i]``."""
    hits, aps = [], []
    for q, order in zip(queries, orders):
        rel = np.array([labels[j] == labels[q] for j in order])
        hits.append(bool(rel[0]))
        if rel.any():
            ranks = np.nonzero(rel)[0] + 1
            aps.append(np.mean(np.arange(1, len(ranks) + 1) / ranks))
    return float(np.mean(hits)), float(np.mean(aps))


def per_class(items, labels, queries, orders):
    """({label: [first results of that label, queries]}, the misses as lines "query (label) -> first (label)")."""
    per, misses = {}, []
    for q, o in zip(queries, orders):
        if labels[o[0]] != labels[q]:
            misses.append(f"{items[q].name} ({labels[q]}) -> {items[o[0]].name} ({labels[o[0]]})")
        p = per.setdefault(labels[q], [0, 0])
        p[0] += labels[o[0]] == labels[q]
        p[1] += 1
    return per, misses


def protocol(items, kind):
    """[(query, candidates)]: "loao" (the clips of the other groups) or "loo" (every other clip)."""
    n = len(items)
    out = []
    for q in range(n):
        if kind == "loao":
            cand = [j for j in range(n) if items[j].group != items[q].group]
        else:
            cand = [j for j in range(n) if j != q]
        out.append((q, cand))
    return out


def dtw_matrix(seqs, band=None, step=1):
    """Full pairwise DTW (our kernel, no band by default) on sequences (every ``step``-th sample)."""
    n = len(seqs)
    D = np.zeros((n, n))
    s = [np.ascontiguousarray(x[::step], dtype=np.float64) for x in seqs]
    for i in range(n):
        for j in range(i + 1, n):
            b = None if band is None else ls._band(len(s[i]), len(s[j]), band)
            D[i, j] = D[j, i] = ls.dtw(s[i], s[j], b)
    return D


def cross_matrix(fn, A, B):
    return np.array([[fn(a, b) for b in B] for a in A])


def _z_combine(d1, d2, mix=ls.MIX, dg=None, global_weight=0.0):
    """The shortlist's score with each stage as a z-score over the shortlist (its spread, not its mean, as the
    unit): both stages count by how far they separate the candidates (experiment, ``LS_COMBINE=z``)."""
    def z(x):
        x = np.asarray(x, float)
        fin = x[np.isfinite(x)]
        if len(fin) < 2:
            return x * 0.0
        return (x - fin.mean()) / max(fin.std(), 1e-12)
    s = z(d2)
    if mix:
        s = s + mix * z(d1)
    return s


if os.environ.get("LS_COMBINE") == "z":
    ls.combine = _z_combine


def mirrored(feat):
    """The local features of the clip's mirror image (left and right swapped): key points swapped in pairs
    (``local.POINTS`` order), the lateral axis (x) and the turned angle negated (experiment: ``LS_MIRROR=1``, a
    query also as its mirror image, the nearer counts)."""
    pose = np.asarray(feat["pose"], float).reshape(len(feat["pose"]), -1, 3).copy()
    pose = pose[:, [0, 2, 1, 4, 3, 6, 5, 8, 7, 10, 9]]
    pose[..., 0] *= -1
    motion = np.asarray(feat["motion"], float).copy()
    motion[:, 0] *= -1
    motion[:, 3] *= -1
    return {**feat, "pose": pose.reshape(len(pose), -1), "motion": motion}


MIRROR = os.environ.get("LS_MIRROR") == "1"
