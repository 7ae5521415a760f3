#!/usr/bin/env python
"""Issue 41, fifth pass: one direction of travel whether a clip has root motion or plays in place, the clips'
durations, DTW on the key points' velocities, the frame furthest from the clip's median pose, the first stage's
weight and the shortlist's size, each as a change of the search before this pass (``describe_before``), alone and
under the fourth pass' gated arm term (``arms.py``'s ``strike_guard_gated``). Scores every set from the cached
features (``arms.py --build``). Adopted: ``k25_travel_gated_striking`` (``local.description``, ``local.shortlisted``).

  .venv/bin/python experiments/local_search/fifth.py [--sets rigs,hdm05,...] [--variants NAME,...] [--misses]
      [--tslearn]

A variant is a dict: ``k`` (the shortlist), ``mix`` (``local.combine``'s weight of the first stage), ``travel``
("clip": the description's travel from the pelvis' path, or from the ground under the lower foot when the pelvis
moves less than half as fast, counted once; "inplace": the pelvis' part from the ground for such a clip, both
kept), ``dirw`` (the mean direction of travel as a unit vector, faded in below 0.1 leg lengths per ``action.TIME``),
``wlen`` (|log| of the durations' ratio), ``wv`` (DTW of the key points' velocities, relative to the shortlist's
mean), ``wp`` / ``up`` (the pose furthest from the clip's median pose, mirror-invariant, leg lengths; its ``up``
nearest join the shortlist), and ``arms.Run.evaluate2``'s arm and turn terms (``cols``, ``w3``, ``u``, ``sgate``,
``tcols``, ``wt``; ``ugate``: the union only for a query whose strike exceeds it). Rows in RESULTS.md, "fifth pass".
"""

import argparse
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import arms as am  # noqa: E402
import common as cm  # noqa: E402
import describe as dsc  # noqa: E402
from blender_shapesig.core.search.local import action as la, description as de, features as ls  # noqa: E402

MIRROR = [0, 2, 1, 4, 3, 6, 5, 8, 7, 10, 9]  # ``rigs.body.POINTS`` left <-> right
GATED = {"cols": [11, 17], "w3": 5.0, "u": 3, "sgate": 0.4}


def _travel(v):
    """(3,) the median speed, mean forward and absolute mean sideways velocity of (T, 2) (forward, side), times TIME."""
    return la.TIME * np.array([np.median(np.hypot(*v.T)), np.mean(v[:, 0]), abs(np.mean(v[:, 1]))])


def _heights(c):
    """(3,) the pelvis' rise, the lower foot's clearance, the pelvis' vertical speed (``action_channels`` ``c``)."""
    low, pz, P = c[:, 3:5].min(axis=1), c[:, 5], de.PERCENTILE
    return [np.percentile(pz, P) - np.percentile(pz, 100 - P), np.percentile(low, P),
            la.TIME * np.percentile(np.abs(c[:, 2]), P)]


def _velocities(feat):
    """(action channels, the pelvis' (T, 2) and the ground's (T, 2) velocities as (forward, side))."""
    c, g = la.action_channels(feat), de.ground_velocity(feat)
    return c, np.column_stack([-c[:, 1], c[:, 0]]), np.column_stack([-g[:, 1], g[:, 0]])


def describe_travel(mode="clip", ratio=0.5, dirw=0.0, s0=0.1):
    """A ``description.describe`` whose travel is the pelvis' or, for a clip playing in place, the ground's."""
    def describe(feat):
        c, pv, gv = _velocities(feat)
        v = gv if np.median(np.hypot(*pv.T)) < ratio * np.median(np.hypot(*gv.T)) else pv
        parts = [_travel(v)] + ([_travel(gv)] if mode == "inplace" else []) + [_heights(c)]
        if dirw:
            m = v.mean(axis=0)
            n = float(np.hypot(*m))
            fade = min(1.0, n * la.TIME / s0) / max(n, 1e-9)
            parts.append(dirw * fade * np.array([m[0], abs(m[1])]))
        return np.concatenate([np.ravel(p) for p in parts]).astype(np.float32)
    return describe


def describe_before(feat):
    """The description before this pass (nine numbers: the pelvis' travel and the ground's, both kept; rise,
    clearance, vertical speed), the base every variant here changes."""
    c, pv, gv = _velocities(feat)
    return np.concatenate([_travel(pv), _travel(gv), _heights(c)]).astype(np.float32)


def velocity_sequence(feat):
    """The key points' velocities (leg lengths per ``action.TIME``) at the second stage's rate and length cap."""
    pose = np.asarray(feat["pose"], float)
    v = np.gradient(pose, axis=0) * float(feat["rate"]) * la.TIME if len(pose) > 1 else pose * 0
    return v[::max(2, int(math.ceil(len(v) / ls.MAX_SEQUENCE)))]


def furthest_pose(feat):
    """(11, 3) the key points of the frame furthest from the clip's median pose, minus that pose."""
    pose = np.asarray(feat["pose"], float).reshape(len(feat["pose"]), -1, 3)
    D = pose - np.median(pose, axis=0)
    return D[int(np.argmax(np.linalg.norm(D.reshape(len(D), -1), axis=1)))]


def pose_distances(a, B):
    """(len(B),) root mean square distance of the key points, the nearer of ``a`` and its mirror image."""
    m = a[MIRROR] * np.array([-1.0, 1.0, 1.0])
    return np.minimum(*(np.sqrt(((B - x) ** 2).sum((1, 2)) / len(a)) for x in (a, m)))


class Run(am.Run):
    def dv(self, tag, q, j, fq):
        key = ("velocity", tag, q, j)
        if key not in self._d2:
            a, b = velocity_sequence(fq[q]), velocity_sequence(self.feats["full"][j])
            d = ls.dtw(a, b, ls._band(len(a), len(b)), int(ls.FREE * len(a)), int(ls.FREE * len(b)))
            self._d2[key] = d / math.sqrt(len(a) + len(b))
        return self._d2[key]

    def evaluate3(self, k=20, mix=1.0, travel=None, dirw=0.0, wlen=0.0, wv=0.0, wp=0.0, up=0, cols=(), w3=0.0, u=0,
                  sgate=0.0, tcols=(), wt=0.0, ugate=None):
        self.k, self.mix = k, mix
        describe = describe_travel(travel, dirw=dirw) if travel else describe_before
        labels = [it.label for it in self.items]

        def numbers(fs):
            return (np.array([describe(f) for f in fs], float), np.array([am.arms(f) for f in fs]),
                    np.array([len(f["pose"]) / float(f["rate"]) for f in fs]),
                    np.array([furthest_pose(f) for f in fs]))
        XB, XA, L, PK = numbers(self.feats["full"])

        def order(tag, Q, D1row, q, cand, nq, fq):
            xb, xa, lq, pq = (x[q] for x in nq)
            cand = np.asarray(cand, int)
            o = cand[np.argsort(D1row[cand], kind="stable")]
            h = list(o[:k])
            if u and (ugate is None or xa[11] > ugate):  # the arm numbers' nearest join the shortlist
                h += list(cand[np.argsort(am.rms(xa[None], XA, list(cols))[0][cand], kind="stable")][:u])
            if up:
                h += list(cand[np.argsort(pose_distances(pq, PK)[cand], kind="stable")][:up])
            h = np.array(list(dict.fromkeys(h)), int)
            s = ls.combine(D1row[h], np.array([self.d2(tag, q, j, Q) for j in h]), mix)
            s = s + 2.0 * np.sqrt(((XB[h] - xb) ** 2).mean(1))
            if w3:
                s = s + w3 * (min(1.0, xa[11] / sgate) if sgate else 1.0) * am.rms(xa[None], XA[h], list(cols))[0]
            if wt:
                s = s + wt * am.rms(xa[None], XA[h], list(tcols))[0]
            if wlen:
                s = s + wlen * np.abs(np.log(L[h] / lq))
            if wv:
                x = np.array([self.dv(tag, q, j, fq) for j in h])
                s = s + wv * x / max(x.mean(), 1e-12)
            if wp:
                s = s + wp * pose_distances(pq, PK[h])
            return np.concatenate([h[np.argsort(s, kind="stable")], [j for j in o if j not in set(h)]]).astype(int)

        full = (XB, XA, L, PK)
        orders = [order("full", self.E, self.D1[q], q, c, full, self.feats["full"]) for q, c in self.prot]
        qs = [q for q, _ in self.prot]
        acc, mAP = cm.scores(orders, labels, qs)
        per, self.misses = cm.per_class(self.items, labels, qs, orders)
        crops, everyone = {}, list(range(len(self.items)))
        for side, (Q, Dc, cf) in self.crops.items():
            nc = numbers(cf)
            crops[side] = sum(order(side, Q, Dc[q], q, everyone, nc, cf)[0] == q for q in everyone)
        hits = sum(labels[o[0]] == labels[q] for q, o in zip(qs, orders))
        return {"acc": acc, "mAP": mAP, "hits": hits, "n": len(qs), "per": per, "crops": crops}


VARIANTS = {"base": {}, "gated": dict(GATED),
            "travel": {"travel": "clip"}, "travel_gated": {"travel": "clip", **GATED},
            "inplace": {"travel": "inplace"}, "direction1": {"travel": "clip", "dirw": 1.0},
            "direction2": {"travel": "clip", "dirw": 2.0}, "k30": {"k": 30}, "k50": {"k": 50},
            "k30_gated": {"k": 30, **GATED}, "k30_travel_gated": {"k": 30, "travel": "clip", **GATED}}
for _w in (0.05, 0.1, 0.2, 0.3):
    VARIANTS[f"duration{_w}"] = {"wlen": _w}
for _w in (0.5, 1.0, 2.0):
    VARIANTS[f"velocity{_w}"] = {"wv": _w}
for _w in (1.0, 2.0, 4.0):
    VARIANTS[f"furthest{_w}"] = {"wp": _w}
    VARIANTS[f"furthest{_w}_u3"] = {"wp": _w, "up": 3}
for _m in (0.0, 0.25, 0.5, 2.0):
    VARIANTS[f"mix{_m}"] = {"mix": _m}
for _w3, _g in ((4.0, 0.3), (4.0, 0.4), (4.0, 0.5), (5.0, 0.3), (5.0, 0.5), (6.0, 0.3), (6.0, 0.4), (6.0, 0.5)):
    VARIANTS[f"k30_gated_w{_w3}_g{_g}"] = {"k": 30, **GATED, "w3": _w3, "sgate": _g}
    VARIANTS[f"travel_gated_w{_w3}_g{_g}"] = {"travel": "clip", **GATED, "w3": _w3, "sgate": _g}
for _k in (22, 25, 28):
    VARIANTS[f"k{_k}_travel_gated"] = {"k": _k, "travel": "clip", **GATED}
    VARIANTS[f"k{_k}_travel_gated_striking"] = {"k": _k, "travel": "clip", **GATED, "ugate": 0.0}
for _wt in (0.5, 1.0, 2.0, 3.0):
    VARIANTS[f"k30_gated_turn{_wt}"] = {"k": 30, **GATED, "tcols": [20], "wt": _wt}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sets", default="rigs,hdm05,cmu27,cmu27_mixed,cmu_large,cmu_mixed_format")
    ap.add_argument("--variants", default="base,travel,travel_gated,k30,k30_gated")
    ap.add_argument("--misses", action="store_true")
    ap.add_argument("--tslearn", action="store_true", help="the rig set's DTW peer in the same run (tslearn, "
                    "benchmark-only: benchmarks/requirements.txt)")
    args = ap.parse_args(argv)
    names = [v for pat in args.variants.split(",") for v in VARIANTS
             if v == pat or (pat.endswith("*") and v.startswith(pat[:-1]))]
    for s in args.sets.split(","):
        run = Run(s)
        if args.tslearn and s == "rigs":  # 1-NN DTW on the 11 key points (``describe.py``'s peer)
            from tslearn.metrics import dtw as ts_dtw
            seqs, labels = [f["pose"] for f in run.feats["full"]], [it.label for it in run.items]
            hits = sum(labels[min(c, key=lambda j: ts_dtw(seqs[q], seqs[j]))] == labels[q] for q, c in run.prot)
            print(f"{s:16s} DTW on the key points (tslearn, 30 Hz, no band) {hits}/{len(run.prot)}", flush=True)
        for v in names:
            print(dsc.fmt(s, v, run.evaluate3(**VARIANTS[v])), flush=True)
            if args.misses and s == "rigs":
                print("\n".join("   - " + m for m in run.misses))
    return 0


if __name__ == "__main__":
    sys.exit(main())
