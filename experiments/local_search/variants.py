"""The local search's variants (issue 29) and their evaluation on one set from cached features: the first stage's
matrix, the second stage's DTW on the shortlist, 1-NN / mAP under a protocol, and the crop probes."""

import numpy as np

import common as cm
from blender_shapesig.core.search.local import features as ls

# name -> (Settings, shortlist K, re-rank band, re-rank free ends, mix)
VARIANTS = {}


def add(name, shortlist=ls.SHORTLIST, band=ls.BAND, free=ls.FREE, mix=ls.MIX, **kw):
    VARIANTS[name] = (ls.Settings(**kw), shortlist, band, free, mix)


add("default")
add("issue29", action_weight=0.0, still=0.0)  # the default before issue 41 (no action part, no stillness coordinate)
add("action", action_weight=2.0, still=0.0)  # issue 41's action part at its chosen weight, without stillness
add("still", still=1.0)  # issue 41's stillness coordinate (local.STILL): the default now
add("raw", normalize="none")
add("global2", global_weight=2.0)
add("centered_global2", sequence="centered", global_weight=2.0)
add("centered_global4", sequence="centered", global_weight=4.0)
add("w1.0", windows=(1.0,))
add("w0.5", windows=(0.5,))
add("w0.5_1_2", windows=(0.5, 1.0, 2.0))
add("mix0", mix=0.0)
add("mix0.5", mix=0.5)
add("mix2", mix=2.0)
add("closed_ends", free=0.0)
add("k50", shortlist=50)
add("step1", step=1)
add("centered", sequence="centered")
add("vel0.1", velocity_weight=0.1)
add("centered_vel0.1", sequence="centered", velocity_weight=0.1)
add("mix2_vel0.1", mix=2.0, velocity_weight=0.1)
add("centered_band0.1", sequence="centered", band=0.1)
add("centered_band0.1_vel1", sequence="centered", band=0.1, velocity_weight=1.0)
add("centered_vel1", sequence="centered", velocity_weight=1.0)
add("centered_mix0.5", sequence="centered", mix=0.5)
add("k50_step1", shortlist=50, step=1)


def entries(feats, settings):
    return [ls.entry_from_features(f, settings) for f in feats]


def first_matrix(Q, E):
    lib = ls.stack(E)
    return np.stack([ls.first_stage(q, lib) for q in Q])


def evaluate(items, feats, variant, kind="loo"):
    settings, k, band, free, mix = variant
    labels = [it.label for it in items]
    E = entries(feats["full"], settings)
    D1 = first_matrix(E, E)
    M = None
    if cm.MIRROR:  # each query also as its mirror image, the nearer counts
        M = entries([cm.mirrored(f) for f in feats["full"]], settings)
        D1 = np.minimum(D1, first_matrix(M, E))
    cache = {}

    def d2(a, b, qe, ce):
        key = (a, b)
        if key not in cache:
            cache[key] = ls.rerank(qe, [ce], band, free)[0]
            if M is not None:
                cache[key] = min(cache[key], ls.rerank(M[a], [ce], band, free)[0])
        return cache[key]

    prot = cm.protocol(items, kind)
    orders1 = [np.asarray(c)[np.argsort(D1[q, c], kind="stable")] for q, c in prot]
    s1 = cm.scores(orders1, labels, [q for q, _ in prot])
    gw = settings.global_weight
    dg = lambda q, j: float(np.linalg.norm(E[q].path - E[j].path))  # noqa: E731
    orders = [cm.two_stage_order(D1[q], c, k, lambda j, q=q: d2(q, j, E[q], E[j]), mix,
                                 lambda j, q=q: dg(q, j), gw) for q, c in prot]
    s2 = cm.scores(orders, labels, [q for q, _ in prot])
    crops = {}
    everyone = list(range(len(items)))
    for crop in (("start", 0.1), ("end", 0.1)):
        if crop not in feats:
            continue
        Qc = entries(feats[crop], settings)
        Dc = first_matrix(Qc, E)
        if cm.MIRROR:
            Dc = np.minimum(Dc, first_matrix(entries([cm.mirrored(f) for f in feats[crop]], settings), E))
        ok = ok1 = 0
        for q in everyone:
            order = cm.two_stage_order(Dc[q], everyone, k, lambda j, q=q: ls.rerank(Qc[q], [E[j]], band, free)[0], mix,
                                       lambda j, q=q: float(np.linalg.norm(Qc[q].path - E[j].path)), gw)
            ok += order[0] == q
            ok1 += np.argmin(Dc[q]) == q
        crops[crop[0]] = (ok1, ok)
    size = np.mean([ls.entry_bytes(e) for e in E])
    return {"stage1": s1, "two_stage": s2, "crops": crops, "n": len(items), "bytes": size}


def format_row(set_name, name, r):
    c = r["crops"]
    crop = " ".join(f"{k} {v[0]}->{v[1]}/{r['n']}" for k, v in c.items())
    return (f"{set_name:10s} {name:24s} stage1 1-NN {r['stage1'][0]:.3f} mAP {r['stage1'][1]:.3f} | two-stage "
            f"1-NN {r['two_stage'][0]:.3f} mAP {r['two_stage'][1]:.3f} | crops {crop} | {r['bytes'] / 1024:.1f} KB")

# issue 41: the action part (local_action) and the active windows
for _w in (0.25, 0.5, 1.0, 2.0):
    add(f"act{_w}", action_weight=_w)
for _a in (0.2, 0.35, 0.5):
    add(f"active{_a}", active=_a)
    for _w in (0.5, 1.0):
        add(f"act{_w}_active{_a}", action_weight=_w, active=_a)
for _w in (4.0, 8.0):
    add(f"act{_w}", action_weight=_w)
for _w in (1.0, 2.0, 4.0):
    add(f"act{_w}_seqpose", action_weight=_w, sequence="pose_only")
    add(f"act{_w}_mix2", action_weight=_w, mix=2.0)
for _w in (4.0, 8.0):
    for _a in (0.35, 0.5):
        add(f"act{_w}_active{_a}", action_weight=_w, active=_a)
# the first stage's Chamfer means weighted by the windows' energy (rigs.py only), floor after "wchamfer"
for _w in (0.0, 2.0, 4.0):
    for _f in (0.05, 0.2):
        add(f"act{_w}_wchamfer{_f}", action_weight=_w)
for _w in (2.0, 3.0, 4.0):
    add(f"act{_w}_k10", action_weight=_w, shortlist=10)
    add(f"act{_w}_mix0.5", action_weight=_w, mix=0.5)
add("act3.0", action_weight=3.0)
add("act1.5", action_weight=1.5)
add("act1.0", action_weight=1.0)

# issue 41: the still windows' motion parts on the unit sphere (``local._stillness``), weight after "still"
for _c in (0.5, 1.0, 1.5, 2.0):
    add(f"still{_c}", still=_c)
    add(f"act2.0_still{_c}", action_weight=2.0, still=_c)
for _c in (1.0, 1.5):
    add(f"still{_c}_mix2", still=_c, mix=2.0)
    add(f"still{_c}_k10", still=_c, shortlist=10)
    add(f"act2.0_still{_c}_mix2", action_weight=2.0, still=_c, mix=2.0)
    add(f"act4.0_still{_c}", action_weight=4.0, still=_c)
    add(f"still{_c}_mw0.7", still=_c, motion_weight=0.7)


# issue 41: the pelvis' path in a window as a part of its own (``Settings.travel``), the second stage with the pelvis'
# height (``Settings.height``)
for _t in (0.5, 1.0, 1.5, 2.0):
    add(f"travel{_t}", travel=_t)
for _t in (1.0, 1.5):
    for _v in (0.25, 0.5):
        add(f"travel{_t}_vel{_v}", travel=_t, velocity_weight=_v)
    add(f"travel{_t}_mix2", travel=_t, mix=2.0)
    add(f"travel{_t}_mix4", travel=_t, mix=4.0)

add("height", height=1.0)  # the second stage's key points at the pelvis' height about its median
add("travel1.0_height", travel=1.0, height=1.0)
add("travel1.5_height", travel=1.5, height=1.0)
add("travel1.0_height_k10", travel=1.0, height=1.0, shortlist=10)
add("travel1.0_centered", travel=1.0, sequence="centered")

# issue 41, third pass: the shortlist's size with the description term (``describe.py --base``)
for _k in (30, 40):
    add(f"k{_k}", shortlist=_k)
