#!/usr/bin/env python
"""The whole take's level-2 log-signature as a "same take" measure (issue 29): per clip, the level-1 and level-2
(Levy areas) terms of the development of its comparison-space curve on every joint, restricted to the joints a pair
shares (the level-2 terms of a channel subset are the subset's areas), so it can be stored per clip (~4 KB) and
compared on shared joints; the distance is the package's ``linear2`` on shared joints.

  .venv/bin/python experiments/local_search/take_signature.py --data PATH/TO/cmu [--out out/local_search]
"""
import argparse, os, sys, pickle, numpy as np
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common as cm, variants as vs
from blender_shapesig.core.clip.prepare import prepare_clip
from blender_shapesig.core.signatures import signatures as sg
from blender_shapesig.core.metrics import time_base_smoothing
from blender_shapesig.core.search.local import features as ls
def take_vec(clip):
    c = prepare_clip(clip, smooth=time_base_smoothing("linear"))
    dx = sg.development_increments(c.rotations)   # (T-1, 3J)
    x = np.vstack([np.zeros(dx.shape[1]), np.cumsum(dx, 0)])[:-1]
    A = 0.5 * (x.T @ dx - dx.T @ x)
    still = [j for j in c.still_bones()] if hasattr(c, "still_bones") else []
    return {"bones": list(c.bones), "s1": dx.sum(0), "A": A, "still": set(still), "dur": c.frames / c.fps}
def d_take(a, b, drop_still=True):
    shared = [j for j in a["bones"] if j in b["bones"] and not (drop_still and j in a["still"] and j in b["still"])]
    ia = np.concatenate([[3*a["bones"].index(j)+k for k in range(3)] for j in shared])
    ib = np.concatenate([[3*b["bones"].index(j)+k for k in range(3)] for j in shared])
    d1 = a["s1"][ia] - b["s1"][ib]
    iu = np.triu_indices(len(ia), 1)
    d2 = a["A"][np.ix_(ia, ia)][iu] - b["A"][np.ix_(ib, ib)][iu]
    return float(np.sqrt((d1**2).sum() + (d2**2).sum()))
if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", required=True)
    ap.add_argument("--out", default=os.path.join("out", "local_search"))
    args = ap.parse_args()
    sys.path.insert(0, os.path.join(cm.ROOT, "experiments"))
    import cmu
    rig, others = cm.cached(os.path.join(args.out, "rigs_items.pkl"), lambda: cmu.rig_items(args.data))
    everyone = rig + others
    V = cm.cached(os.path.join(args.out, "rigs_take2.pkl"), lambda: [take_vec(it.mapped()) for it in everyone])
    for n_lib in (20, len(everyone)):
        ok = 0; miss = []
        for q in range(20):
            ds = [d_take(V[q], V[j]) if j != q else 9e9 for j in range(n_lib)]
            t = int(np.argmin(ds)); a, b = everyone[q], everyone[t]
            g = b.label == a.label or b.name.split(":")[1].startswith(a.label); ok += g
            if not g: miss.append(a.name + "->" + b.name)
        print("take linear2 alone, lib", n_lib, ok, miss)
