#!/usr/bin/env python
"""Issue 41, fourth pass: the arms in the description (strike, guard, reach), the turned angle's rate, the
description's nearest joining the shortlist, and two hubness corrections, as terms on top of the default search
(``describe.py``'s ``SetRun``: the cached features of every set, the first stage and the memoized DTW shared by every
variant; the adopted description term, weight 2, in every variant). Not adopted: RESULTS.md, "fourth pass".

  .venv/bin/python experiments/local_search/arms.py [--sets rigs,hdm05,cmu27,...] [--variants NAME,...]
      [--grid "[{'cols': [11, 17], 'w3': 5.0, 'u': 3}, ...]"] [--misses] [--build DATA_FOLDER]

A variant is a dict of ``Run.evaluate2``'s keywords: ``cols`` (the arm numbers, ``NAMES``) compared by the root
mean square of their differences (leg lengths; speeds times ``action.TIME``) and added with weight ``w3`` to the
shortlist's score; ``u`` of the library's nearest by those numbers join the shortlist; ``sgate``: the arm term's
weight times min(1, the query's strike / sgate); ``tcols``/``wt``: the same for other numbers (the turn); ``beta``
(library) / ``sbeta`` (shortlist): the first stage minus beta times each candidate's mean distance to its ``kh``
nearest (a hub's is small); ``w2``: the adopted description's weight; ``ugate``: the union only for a query whose
strike is at least ``ugate``; ``dcols``/``wd``: the adopted description's columns (``description.PARTS``) counted
again with weight ``wd`` (the direction of travel); ``wfloor``: the first stage's means weighted by the windows'
energy, at least ``wfloor`` of the largest (``rigs.weighted_matrix``; whole clips only, the crops keep the default's).
"""

import argparse
import ast
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common as cm  # noqa: E402
import describe as dsc  # noqa: E402
from blender_shapesig.core.search.local import action as la, description as de, features as ls  # noqa: E402

ARM = 0.68  # the canonical body's arm (upper arm + forearm, leg lengths: ``rigs.body.SEGMENTS``)
NAMES = ("peak", "range", "thrust", "up", "hspeed", "extfrac", "fwdP", "period", "armshare", "fs50", "up50",
         "ths85", "ths98", "fs98", "upP", "thsP", "fwdsh", "dhead", "xmid", "raised", "turn")


def period(pose, rate):
    """The rhythm: the largest autocorrelation of the key points' speed profile at lags 0.25-2 s."""
    T = len(pose)
    if T < 8:
        return 0.0
    v = np.linalg.norm(np.diff(pose.reshape(T, -1), axis=0), axis=1)
    v = v - v.mean()
    den = (v * v).sum()
    lo, hi = max(2, int(0.25 * rate)), min(len(v) - 2, int(2.0 * rate))
    if den <= 1e-12 or hi <= lo:
        return 0.0
    return max(float((v[:-L] * v[L:]).sum() / den) for L in range(lo, hi))


def arms(f, P=85.0, band=0.25):
    """(len(NAMES),) what the arms do (the hand relative to its shoulder in the body's frame, forward -y; "at shoulder
    height": within ``band`` leg lengths of it; each number the further / faster hand, so a left jab matches a right):
    peak: the 98th percentile of the reach forward at shoulder height; range: its P-th minus (100-P)-th percentile
    at any height; thrust / ths*: the hand's forward speed relative to the shoulder (at shoulder height for ths),
    times TIME; up: the hand's height above the shoulder; hspeed: the hand's speed relative to the pelvis; extfrac:
    the share of frames reaching beyond 0.8 arm lengths forward; fwdP / fs50: the reach forward at shoulder height,
    P-th and 50th percentile; period: ``period``; armshare: the arms' share of the limbs' motion; fwdsh: the share of
    the hands' motion that is forward or back at shoulder height; dhead: the median distance of the nearer hand to
    the head (a guard holds the hands by the face); xmid: the nearer hand's median distance from the midline;
    raised: the share of frames with a hand at shoulder height or above; turn: the turned angle's rate times TIME."""
    pose = np.asarray(f["pose"], float).reshape(len(f["pose"]), -1, 3)
    rate, T = float(f["rate"]), len(pose)
    d = pose[:, [5, 6]] - pose[:, [1, 2]]
    fwd, up = -d[..., 1], d[..., 2]
    g = (lambda x: np.gradient(x, axis=0) * rate) if T > 1 else (lambda x: np.zeros_like(x))
    thrust = g(fwd)
    at = np.abs(up) < band
    fs = np.where(at, fwd, 0.0).max(1)
    ths = np.where(at, thrust, 0.0).max(1)
    pc = lambda x, p=P: float(np.percentile(x, p))  # noqa: E731
    fm = fwd.max(1)
    vh = np.linalg.norm(g(pose[:, [5, 6]]), axis=2).max(1)
    va = np.linalg.norm(g(pose[:, [3, 4, 5, 6]]), axis=2).mean(1)
    vl = np.linalg.norm(g(pose[:, [7, 8, 9, 10]]), axis=2).mean(1)
    share = float(va.sum() / max(va.sum() + vl.sum(), 1e-9))
    v = g(d)
    fwdshare = float((np.abs(v[..., 1]) * at).sum() / max(np.linalg.norm(v, axis=2).sum(), 1e-9))
    wr = pose[:, [5, 6]]
    xmid = float(np.percentile(np.abs(wr[..., 0]).min(1), 50))
    dh = float(np.percentile(np.linalg.norm(wr - pose[:, None, 0], axis=2).min(1), 50))
    yaw = np.asarray(f["motion"], float)[:, 3]
    t = la.TIME
    turn = t * abs(yaw[-1] - yaw[0]) / max((T - 1) / rate, 1e-9)
    return np.array([pc(fs, 98), pc(fm) - pc(fm, 100 - P), t * pc(thrust.max(1)), pc(up.max(1)), t * pc(vh),
                     float((fs > 0.8 * ARM).mean()), pc(fs), period(pose, rate), share, pc(fs, 50), pc(up.max(1), 50),
                     t * pc(ths, 85), t * pc(ths, 98), pc(fs, 98), pc(up.max(1)), t * pc(ths), fwdshare, dh, xmid,
                     float((up.max(1) > -band).mean()), turn])


def rms(A, X, cols):
    """(len(A), len(X)) root mean square of the differences of the columns ``cols`` (zeros for none)."""
    if not len(cols):
        return np.zeros((len(A), len(X)))
    return np.sqrt(((A[:, None, cols] - X[None, :, cols]) ** 2).mean(-1))


class Run(dsc.SetRun):
    def _arms(self):
        if not hasattr(self, "_xa"):
            self._xa = {"full": np.array([arms(f) for f in self.feats["full"]])}
            for side, (_Q, _Dc, cf) in self.crops.items():
                self._xa[side] = np.array([arms(f) for f in cf])
        return self._xa

    def _hub(self, lib, kh):
        """(n,) each entry's mean first-stage distance to its ``kh`` nearest among ``lib`` (itself left out)."""
        lib = np.asarray(lib)
        r = np.zeros(len(self.items))
        for e in lib:
            r[e] = np.sort(self.D1[e, lib[lib != e]])[:kh].mean()
        return r

    def evaluate2(self, cols=(), a=0.0, w3=0.0, u=0, w2=2.0, gate=False, sgate=0.0, tcols=(), wt=0.0, beta=0.0,
                  sbeta=0.0, kh=3, ugate=0.0, dcols=(), wd=0.0, wfloor=0.0):
        XA, cols, tcols = self._arms(), list(cols), list(tcols)
        if not hasattr(self, "_d1"):
            self._d1 = {0.0: self.D1}
        if wfloor not in self._d1:  # the first stage with each side's mean weighted by its windows' energy
            import rigs
            import variants as vs
            self._d1[wfloor] = rigs.weighted_matrix(self.E, self.feats["full"], vs.VARIANTS["default"][0], wfloor)
        self.D1 = self._d1[wfloor]
        XB = np.array([de.describe(f) for f in self.feats["full"]], float)
        labels = [it.label for it in self.items]

        def order(tag, Q, D1row, q, cand, dbr, dar, dtr, xq, ddr):
            cand = np.asarray(cand, int)
            if beta:  # the library's hubs: each candidate's own neighbourhood
                D1row = D1row.copy()
                D1row[cand] = D1row[cand] - beta * self._hub(cand, kh)[cand]
            b = D1row[cand] / max(D1row[cand].mean(), 1e-12)
            if a:
                b = b + a * dar[cand] / max(dar[cand].mean(), 1e-12)
            o = cand[np.argsort(b, kind="stable")]
            h = o[:self.k]
            if u and (not ugate or xq[11] >= ugate):  # the arm description's nearest join the shortlist
                near = cand[np.argsort(dar[cand], kind="stable")][:u]
                h = np.array(list(dict.fromkeys(list(h) + list(near))), int)
                o = np.concatenate([h, np.array([j for j in o if j not in set(h)], int)])
            d2 = np.array([self.d2(tag, q, j, Q) for j in h])
            d1h = D1row[h]
            if sbeta:  # the shortlist's hubs
                r = np.array([np.sort(self.D1[e, h[h != e]])[:kh].mean() for e in h])
                d1h = d1h - sbeta * r
            gw = xq[19] if gate else 1.0
            if sgate:
                gw = min(1.0, xq[11] / sgate)
            s = ls.combine(d1h, d2, self.mix) + w2 * dbr[h] + w3 * gw * dar[h] + wt * dtr[h] + wd * ddr[h]
            return np.concatenate([h[np.argsort(s, kind="stable")], o[len(h):]])

        X = XA["full"]
        DB, DA, DT = rms(XB, XB, list(range(XB.shape[1]))), rms(X, X, cols), rms(X, X, tcols)
        DD = rms(XB, XB, list(dcols))
        orders = [order("full", self.E, self.D1[q], q, c, DB[q], DA[q], DT[q], X[q], DD[q]) for q, c in self.prot]
        qs = [q for q, _ in self.prot]
        acc, mAP = cm.scores(orders, labels, qs)
        per, self.misses = cm.per_class(self.items, labels, qs, orders)
        crops, everyone = {}, list(range(len(self.items)))
        for side, (Q, Dc, cf) in self.crops.items():
            Bc, Xc = np.array([de.describe(f) for f in cf], float), XA[side]
            DBc, DAc, DTc = rms(Bc, XB, list(range(XB.shape[1]))), rms(Xc, X, cols), rms(Xc, X, tcols)
            DDc = rms(Bc, XB, list(dcols))
            crops[side] = sum(order(side, Q, Dc[q], q, everyone, DBc[q], DAc[q], DTc[q], Xc[q], DDc[q])[0] == q
                              for q in everyone)
        hits = sum(labels[o[0]] == labels[q] for q, o in zip(qs, orders))
        return {"acc": acc, "mAP": mAP, "hits": hits, "n": len(qs), "per": per, "crops": crops}


# the rows of RESULTS.md's fourth pass (column numbers in ``NAMES``)
VARIANTS = {
    "base": {},
    "strike_guard": {"cols": [11, 17], "w3": 5.0, "u": 3},  # ths85 + dhead: rig set 42/51, HDM05 mAP 0.940
    "strike_guard_gated": {"cols": [11, 17], "w3": 5.0, "u": 3, "sgate": 0.4},  # 40/51, punches 2/3, HDM05 0.972
    "strike_guard_shorthub": {"cols": [11, 17], "w3": 3.0, "u": 5, "sbeta": 0.5},  # 41/51, HDM05 0.955
    "reach_turn": {"cols": [9, 10, 11], "w3": 3.0, "u": 5, "tcols": [20], "wt": 2.0, "w2": 3.0},  # 42/51, punch 1/3
    "turn": {"tcols": [20], "wt": 2.0},  # 39/51, HDM05 0.9746
    "libhub": {"beta": 0.5},  # 40/51 (rig set only: a library-wide statistic)
}


def build(name, data):
    """Write the caches ``describe.load`` reads for one set (features with the crops, and the items' labels)."""
    import pickle
    if name == "rigs":
        import rigs
        cm.cached(os.path.join(dsc.OUT, f"rigset_features_{cm.FEATURES}.pkl"), lambda: rigs.load(data))
        return
    items = cm.load_hdm05(data) if name == "hdm05" else cm.load_eval_set(
        os.path.join(cm.ROOT, "tools", "eval_sets", f"{name}.csv"), data)
    cm.set_features(items, os.path.join(dsc.OUT, f"{name}_features_{cm.FEATURES}.pkl"))
    with open(os.path.join(dsc.OUT, f"{name}_items.pkl"), "wb") as fh:
        pickle.dump([cm.Item(it.name, it.label, it.group, None) for it in items], fh)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sets", default="rigs")
    ap.add_argument("--build", default="", help="write the sets' caches first from this data folder (the rig "
                    "folder for rigs, hdm05's for hdm05, cmu's for the CMU sets)")
    ap.add_argument("--variants", default="base,strike_guard_gated")
    ap.add_argument("--grid", default="", help="a Python literal list of variant dicts (instead of --variants)")
    ap.add_argument("--misses", action="store_true")
    args = ap.parse_args(argv)
    grid = ast.literal_eval(args.grid) if args.grid else [VARIANTS[v] for v in args.variants.split(",")]
    if args.build:
        for s in args.sets.split(","):
            build(s, args.build)
    for s in args.sets.split(","):
        run = Run(s)
        for g in grid:
            label = " ".join(f"{k}={'+'.join(NAMES[c] for c in v) if k in ('cols', 'tcols') else v}"
                             for k, v in g.items()) or "base"
            print(dsc.fmt(s, label, run.evaluate2(**g)), flush=True)
            if args.misses:
                print("\n".join("   - " + m for m in run.misses))
    return 0


if __name__ == "__main__":
    sys.exit(main())
