#!/usr/bin/env python
"""The CMU sets for the local search (issue 29): leave-one-out on tools/eval_sets (cmu27, cmu27_mixed, cmu_large,
cmu_mixed_format) with the crop probes, and the same take across formats (tools/rank_across_rigs.py's 20 queries,
in a library of those 20 and of every readable shared clip).

  .venv/bin/python experiments/local_search/cmu.py --data PATH/TO/cmu [--out out/local_search] [--variants default]
"""

import argparse
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import common as cm  # noqa: E402
import variants as vs  # noqa: E402

sys.path.insert(0, os.path.join(cm.ROOT, "experiments"))
SETS = ("cmu27", "cmu27_mixed", "cmu_large", "cmu_mixed_format")


def rig_items(data):
    """(items, others): rank_across_rigs' 20 clips (group = take) and every other readable shared clip."""
    import pathlib

    import rank_across_rigs as rar
    from dedupe_check import library as shared_library
    from blender_shapesig.core.io import sources

    items, have = [], set()
    for fmt, take, path, asf in rar.takes():
        spec = sources.ClipSpec(os.path.join(data, path), asf=None if asf is None else os.path.join(data, asf))
        items.append(cm.Item(f"{fmt}:{take}", take, take, cm.read_spec(spec)))
        have.add(os.path.realpath(spec.path))
    others = []
    for p in shared_library(pathlib.Path(data))[0]:
        spec = p if isinstance(p, sources.ClipSpec) else sources.ClipSpec(p)
        if os.path.realpath(spec.path) in have:
            continue
        try:
            raw = cm.read_spec(spec)
            cm.clip_features(cm.Item("", "", "", raw).mapped())
        except Exception as exc:  # noqa: BLE001 - a clip the local search cannot read stays out of the library
            print(f"skip {spec.path}: {exc}", file=sys.stderr)
            continue
        others.append(cm.Item("other:" + os.path.basename(spec.path), "other", "other", raw))
    return items, others


def across_rigs(items, feats, variant, n_lib):
    """Same take first, for the first 20 items querying the first n_lib items' library."""
    settings, k, band, free, mix = variant
    from blender_shapesig.core.search.local import features as ls

    E = vs.entries(feats[:n_lib], settings)
    ok = 0
    for q in range(20):
        cand = [j for j in range(n_lib) if j != q]
        order = cm.two_stage_order(ls.first_stage(E[q], E), cand, k,
                                   lambda j, q=q: ls.rerank(E[q], [E[j]], band, free)[0], mix,
                                   lambda j, q=q: float(np.linalg.norm(E[q].path - E[j].path)),
                                   settings.global_weight)
        ok += items[order[0]].label == items[q].label
    return ok


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", required=True)
    ap.add_argument("--out", default=os.path.join("out", "local_search"))
    ap.add_argument("--variants", default="default")
    ap.add_argument("--sets", default=",".join(SETS))
    args = ap.parse_args(argv)
    loaded = {}
    for name in args.sets.split(","):
        csv_path = os.path.join(cm.ROOT, "tools", "eval_sets", name + ".csv")
        items = cm.load_eval_set(csv_path, args.data)
        loaded[name] = (items, cm.set_features(items, os.path.join(args.out, f"{name}_features_{cm.FEATURES}.pkl")))
    rig, others = cm.cached(os.path.join(args.out, "rigs_items.pkl"), lambda: rig_items(args.data))
    everyone = rig + others
    rig_feats = cm.cached(os.path.join(args.out, f"rigs_features_{cm.FEATURES}.pkl"),
                          lambda: [cm.clip_features(it.mapped()) for it in everyone])
    for v in args.variants.split(","):
        for name, (items, feats) in loaded.items():
            print(vs.format_row(name, v, vs.evaluate(items, feats, vs.VARIANTS[v], "loo")), flush=True)
        a = across_rigs(everyone, rig_feats, vs.VARIANTS[v], 20)
        b = across_rigs(everyone, rig_feats, vs.VARIANTS[v], len(everyone))
        print(f"{'rigs':10s} {v:24s} same take first {a}/20 (library 20), {b}/20 (library {len(everyone)})",
              flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
