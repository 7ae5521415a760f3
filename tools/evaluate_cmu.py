#!/usr/bin/env python
"""Reproduce (and extend) the thesis' experiments on the shared CMU clips (docs/evaluation.md).

  .venv/bin/python tools/evaluate_cmu.py --data ../shared/data/cmu --out out/eval [--docs docs/img]
      [--hdm05 ../shared/data/hdm05] [--crops]

1. ``evaluate`` on the 27-clip set (tools/eval_sets/cmu27.csv: 12 walks, 12 runs, 3 forward jumps)
   and on the larger set (tools/eval_sets/cmu_large.csv: + 17 walks, 5 other jumps), optionally on
   the ASF/AMC walk/run set (``--sets cmu_amc``, tools/eval_sets/cmu_amc.csv): leave-one-out
   1-NN accuracy, confusion tables and wall time of every metric, with our DP and the plain numpy DP
   baseline in the same run, the signature variants and the two-stage search;
2. the interpolation experiment (thesis Figs 9.1, 9.2, 9.6): every measure between the SRVT
   geodesic blend c(s) of a walk and a run and the run, for s in [0, 1];
3. with ``--docs DIR``: copies the figures used by docs/evaluation.md to DIR/eval_*.png;
4. with ``--hdm05 DIR``: the HDM05 set (tools/eval_sets/hdm05.csv) leave-one-actor-out (``evaluate --group actor``);
   with ``--crops``: every metric's crop probes (a clip cut by 10 % at either end must find its source first).

Everything goes through the library (``blender_shapesig.evaluation``, ``core.pairwise``) and reads clips
through the one clip front door (``core.io.sources``), as ``python -m blender_shapesig evaluate`` does, so the
numbers are that command's.
"""

import argparse
import json
import os
import shutil
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

from blender_shapesig import evaluation as ev  # noqa: E402
from blender_shapesig.core.signatures import tensor  # noqa: E402
from blender_shapesig.core.metrics import DEFAULT_DEPTH, DEFAULT_LEVEL, parse_metric_spec  # noqa: E402

SETS = {
    "cmu27": os.path.join(ROOT, "tools", "eval_sets", "cmu27.csv"),
    "cmu_large": os.path.join(ROOT, "tools", "eval_sets", "cmu_large.csv"),
    "cmu_amc": os.path.join(ROOT, "tools", "eval_sets", "cmu_amc.csv"),
    # The 27 clips cropped only by the rest-pose frame (an explicit start wins over --trim): frames 2..6 still
    # hold the converter's ramp. The ablation of the automatic trimming.
    "cmu27_start2": os.path.join(ROOT, "tools", "eval_sets", "cmu27_start2.csv"),
    # The 27-clip set across formats (docs/rigs.md): walks from ASF/AMC, runs and jumps from the Daz BVH.
    "cmu27_mixed": os.path.join(ROOT, "tools", "eval_sets", "cmu27_mixed.csv"),
    # The AMC set plus the BVH conversion of the walk 16_15 (same bone names; the only such BVH here).
    "cmu_mixed_format": os.path.join(ROOT, "tools", "eval_sets", "cmu_mixed_format.csv"),
    # The 27 clips with every class at 120, 60 and 30 fps (column step: every step-th frame).
    "cmu27_mixed_rate": os.path.join(ROOT, "tools", "eval_sets", "cmu27_mixed_rate.csv"),
    # HDM05 (188 clips, 11 classes, actors bd/bk/dg; paths relative to the hdm05 folder, --hdm05): each clip is
    # ranked among the other actors' clips (leave-one-actor-out)
    "hdm05": os.path.join(ROOT, "tools", "eval_sets", "hdm05.csv"),
}
GROUPS = {"hdm05": "actor"}  # the CSV column of leave-one-group-out, per set
_NORMS = ("l2", "elastic", "l2_group", "elastic_group")  # both SRVT norms (curves.srvt(norm=...))
_SIGNATURE = (
    "group3", "concat3", "linear3", "sim2", "sim3",
    "linear3_tensor", "sim2_tensor", "sim3_tensor", "sim2_levelnorm", "sim3_levelnorm", "sim3_levelnorm_tensor",
)
_TWO_STAGE = (
    "sim3+elastic3", "sim3+elastic5", "sim3+elastic10",
    "sim3_tensor+elastic5", "sim3_tensor+elastic10", "sim2_tensor+elastic5", "sim2_tensor+elastic10",
    "sim3_levelnorm+elastic5", "sim3_levelnorm+elastic10",
    "group3+elastic5", "group3+elastic10",
)
METRICS = {  # "local" first: the default search (docs/model.md)
    "cmu27": ("local",) + _NORMS + ("elastic_numpy",) + _SIGNATURE + _TWO_STAGE,
    "cmu_large": ("local",) + _NORMS + ("elastic_numpy",) + _SIGNATURE + _TWO_STAGE,
    "cmu_amc": ("local",) + _NORMS + _SIGNATURE + _TWO_STAGE,
    "cmu27_start2": ("local",) + _NORMS + _SIGNATURE + ("sim3+elastic10",),
    "cmu_mixed_format": ("local",) + _NORMS + _SIGNATURE + _TWO_STAGE,
    "cmu27_mixed_rate": ("local",) + _NORMS + _SIGNATURE + _TWO_STAGE,
    "cmu27_mixed": ("local",) + _NORMS + _SIGNATURE + ("sim3+elastic10",),
    "hdm05": ("local", "sim3", "elastic", "sim3+elastic10"),
}
ALL_SETS = "cmu27,cmu_large,cmu_amc,cmu27_start2,cmu_mixed_format,cmu27_mixed_rate,cmu27_mixed"

_CACHE = {}  # clips read once for all sets (ClipSpec -> Clip, uncropped)


def make_loader(data):
    return ev.entry_loader(data, cache=_CACHE)


def run_set(name, data, out, metrics, depth, workers, repeat=1, time_base=True, smooth=None, crops=False):
    """``evaluate`` of one set (leave-one-group-out by ``GROUPS[name]`` when it has one); ``crops``: the crop
    probes (10 % cut at either end) of every metric."""
    entries = ev.read_index(SETS[name])
    out_dir = os.path.join(out, name)
    groups = [e.column(GROUPS[name]) for e in entries] if name in GROUPS else None
    probes = {side: ev.entry_loader(data, cut=(side, ev.CROP_FRACTION)) for side in ("start", "end")} if crops else None
    t0 = time.perf_counter()
    summary = ev.evaluate(entries, make_loader(data), metrics, out_dir, depth=depth, workers=workers,
                          figures=True, progress="tqdm", log=lambda m: print(f"[{name}] {m}", file=sys.stderr),
                          repeat=repeat, time_base=time_base, groups=groups, crops=probes,
                          **({} if smooth is None else {"smooth": smooth}))
    print(f"[{name}] done in {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    return summary


def relabelled(summary, out_dir, mapping, path):
    """1-NN accuracy and mAP again with merged labels (e.g. both jump classes as one), from the saved
    matrices; two-stage metrics re-ranked with the saved elastic matrix."""
    labels = [mapping.get(l, l) for l in summary["labels"]]
    rows = {}
    elastic = os.path.join(out_dir, "matrices", "elastic.npy")
    for name in summary["metrics"]:
        spec = parse_metric_spec(name)
        first = os.path.join(out_dir, "matrices", ev.safe_name(spec.first_stage.name) + ".npy")
        if not os.path.exists(first):
            continue
        D = np.load(first)
        if spec.rerank:
            if not os.path.exists(elastic):
                continue
            acc = ev.two_stage_1nn(D, labels, spec.rerank, np.load(elastic))[0]
            rows[name] = {"accuracy": acc}
        else:
            rows[name] = {"accuracy": ev.loo_1nn(D, labels)[0], "map": ev.mean_average_precision(D, labels)}
    with open(path, "w") as fh:
        json.dump({"mapping": mapping, "metrics": rows}, fh, indent=1)
    return rows


def signature_scale(data, out, set_name="cmu27", level=DEFAULT_LEVEL):
    """Per clip: length of the development (total rotation, radians), duration and the norm of every
    level of the log-signature: what the unnormalized measures (rho, sigma_L, sigma_*) are dominated by."""
    from blender_shapesig.core.signatures import signatures
    from blender_shapesig.core.clip.clip import restrict_to_shared

    entries = ev.read_index(SETS[set_name])
    load = make_loader(data)
    clips = restrict_to_shared(*[load(e).crop(e.start, e.end) for e in entries])
    d = 3 * len(clips[0].bones)
    sizes = tensor.lyndon_level_sizes(d, level)
    rows = []
    for e, c in zip(entries, clips):
        inc = signatures.development_increments(c.rotations)
        ls = signatures.log_signature(c.rotations, level)
        blocks = np.split(ls, np.cumsum(sizes)[:-1])
        rows.append({"clip": os.path.splitext(os.path.basename(e.file))[0], "label": e.label, "frames": c.frames,
                     "length": float(np.sum(np.linalg.norm(inc, axis=1))),
                     "level_norms": [float(np.linalg.norm(b)) for b in blocks]})
    with open(os.path.join(out, f"signature_scale_{set_name}.json"), "w") as fh:
        json.dump(rows, fh, indent=1)
    return rows


# ---------------------------------------------------------------------------------------------
# interpolation experiment (Figs 9.1, 9.2, 9.6)


def interpolation(data, out, walk, run, align, steps=21, levels=(1, 2, 3)):
    from blender_shapesig.core.geometry import curves
    from blender_shapesig.core.signatures import signatures
    from blender_shapesig.core.blend import geodesic_blend
    from blender_shapesig.core.clip.clip import restrict_to_shared

    load = make_loader(data)
    a = load(walk).crop(walk.start, walk.end)
    b = load(run).crop(run.start, run.end)
    a, b = restrict_to_shared(a, b)
    s_values = np.linspace(0.0, 1.0, steps)
    rows = {"s": s_values.tolist(), "walk": os.path.basename(walk.file), "run": os.path.basename(run.file),
            "align": align, "measures": {}}
    measures = rows["measures"]

    def put(key, value):
        measures.setdefault(key, []).append(float(value))

    target = None
    for s in s_values:
        c, info = geodesic_blend(a.rotations, b.rotations, float(s), align=align, return_info=True)
        grid = info["grid"]
        C = info["curve"]  # the blend on the merged grid G, in P*
        B1 = info["curve1"]  # b (o phi) on G, in P*: the end point of the geodesic
        if target is None:
            target = B1
        put("d_P*", curves.l2_distance(C, B1, grid, grid))
        for n in levels:
            put(f"rho^{n}", signatures.group_distance(C, B1, n))
            put(f"sigma_*^{n}", signatures.concat_distance(C, B1, n))
            put(f"sigma_L^{n}", signatures.linear_distance(C, B1, n))
            put(f"sim^{n}", signatures.normalized_distance(C, B1, n))
    tag = "aligned" if align else "unaligned"
    with open(os.path.join(out, f"interpolation_{tag}.json"), "w") as fh:
        json.dump(rows, fh, indent=1)
    plot_interpolation(rows, out, tag)
    return rows


def plot_interpolation(rows, out, tag):
    plt = ev.pyplot()
    s = np.array(rows["s"])
    m = rows["measures"]

    def norm(v):
        v = np.asarray(v, dtype=float)
        top = np.max(np.abs(v))
        return v / top if top > 0 else v

    groups = {
        "group": ("Group metric rho^n (Fig. 9.1)", [k for k in m if k.startswith("rho")]),
        "logsig": ("Log-signature metrics sigma_L^n, sigma_*^n (Fig. 9.2)",
                   [k for k in m if k.startswith("sigma")]),
        "sim": ("Normalized difference sim^n (Fig. 9.6)", [k for k in m if k.startswith("sim")]),
    }
    paths = []
    for key, (title, names) in groups.items():
        fig, ax = plt.subplots(figsize=(6.0, 4.2))
        ax.plot(s, norm(m["d_P*"]), "k--", lw=2, label="d_P* (reference)")
        for k in names:
            ax.plot(s, norm(m[k]), marker=".", label=k)
        ax.set_xlabel("s (blend weight: 0 = walk, 1 = run)")
        ax.set_ylabel("distance to the run / max over s")
        ax.set_title(f"{title}\n{rows['walk']} -> {rows['run']}, {tag}", fontsize=10)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7, ncol=2)
        fig.tight_layout()
        path = os.path.join(out, f"interpolation_{key}_{tag}.png")
        fig.savefig(path, dpi=110)
        plt.close(fig)
        paths.append(path)
    return paths


def linearity(rows):
    """Max deviation of each normalized measure from the normalized d_P* line (0 = straight)."""
    ref = np.asarray(rows["measures"]["d_P*"])
    ref = ref / ref.max()
    out = {}
    for k, v in rows["measures"].items():
        v = np.asarray(v)
        v = v / v.max() if v.max() > 0 else v
        out[k] = float(np.max(np.abs(v - ref)))
    return out


# ---------------------------------------------------------------------------------------------


DOC_FIGURES = {
    # docs/img name: (set, file under the set's output)
    "eval_27_mds_l2.png": ("cmu27", "figures/mds_l2.png"),
    "eval_27_mds_elastic.png": ("cmu27", "figures/mds_elastic.png"),
    "eval_27_dendrogram_elastic.png": ("cmu27", "figures/dendrogram_elastic.png"),
    "eval_27_mds_group3.png": ("cmu27", "figures/mds_group3.png"),
    "eval_27_mds_linear3.png": ("cmu27", "figures/mds_linear3.png"),
    "eval_27_mds_concat3.png": ("cmu27", "figures/mds_concat3.png"),
    "eval_27_mds_sim3.png": ("cmu27", "figures/mds_sim3.png"),
    "eval_27_mds_sim3_levelnorm.png": ("cmu27", "figures/mds_sim3_levelnorm.png"),
    "eval_27_dendrogram_sim3.png": ("cmu27", "figures/dendrogram_sim3.png"),
    "eval_large_mds_elastic.png": ("cmu_large", "figures/mds_elastic.png"),
    "eval_large_mds_sim3.png": ("cmu_large", "figures/mds_sim3.png"),
    "eval_large_dendrogram_elastic.png": ("cmu_large", "figures/dendrogram_elastic.png"),
    "eval_27_mds_sim2_tensor.png": ("cmu27", "figures/mds_sim2_tensor.png"),
    "eval_27start2_mds_sim3.png": ("cmu27_start2", "figures/mds_sim3.png"),
    "eval_interp_group.png": (None, "interpolation_group_unaligned.png"),
    "eval_interp_logsig.png": (None, "interpolation_logsig_unaligned.png"),
    "eval_interp_sim.png": (None, "interpolation_sim_unaligned.png"),
    "eval_interp_sim_aligned.png": (None, "interpolation_sim_aligned.png"),
}


def copy_doc_figures(out, docs):
    os.makedirs(docs, exist_ok=True)
    for name, (set_name, rel) in DOC_FIGURES.items():
        src = os.path.join(out, set_name, rel) if set_name else os.path.join(out, rel)
        if os.path.exists(src):
            shutil.copy(src, os.path.join(docs, name))


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", required=True, help="the shared CMU folder (e.g. ../shared/data/cmu)")
    p.add_argument("--out", default="out/eval", help="output folder (default out/eval)")
    p.add_argument("--sets", default=ALL_SETS, help=f"comma-separated, from {ALL_SETS} (default: all)")
    p.add_argument("--raw", action="store_true",
                   help="compare the curves as read (the thesis' protocol), without the time base of core.clip.prepare")
    p.add_argument("--smooth", type=float, help="the time base's low-pass in seconds (default core.clip.prepare's)")
    p.add_argument("--metrics", help="override the metric list (comma-separated) for every set")
    p.add_argument("--depth", type=int, default=DEFAULT_DEPTH)
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--repeat", type=int, default=3, help="time every matrix N times, keep the shortest (default 3)")
    p.add_argument("--no-interpolation", action="store_true")
    p.add_argument("--docs", help="copy the documentation figures to this folder as eval_*.png")
    p.add_argument("--hdm05", help="the shared HDM05 folder (e.g. ../shared/data/hdm05): adds the set hdm05, "
                   "leave-one-actor-out")
    p.add_argument("--crops", action="store_true", help="crop probes of every metric (10%% cut at either end)")
    args = p.parse_args(argv)
    os.makedirs(args.out, exist_ok=True)
    results = {}
    names = [s.strip() for s in args.sets.split(",") if s.strip()] + (["hdm05"] if args.hdm05 else [])
    for name in dict.fromkeys(names):
        metrics = tuple(args.metrics.split(",")) if args.metrics else METRICS[name]
        results[name] = run_set(name, args.hdm05 if name == "hdm05" else args.data, args.out, metrics, args.depth,
                                args.workers, args.repeat, time_base=not args.raw, smooth=args.smooth,
                                crops=args.crops)
        if name == "cmu_large":
            merged = relabelled(results[name], os.path.join(args.out, name), {"forward jump": "jump"},
                                os.path.join(args.out, name, "merged_jumps.json"))
            print(f"== {name} with 'forward jump' and 'jump' merged")
            for metric, row in merged.items():
                print(f"  {metric:26s} {row['accuracy']:.3f}" + (f"  map {row['map']:.3f}" if "map" in row else ""))
    for row in ([] if args.no_interpolation else signature_scale(args.data, args.out)):
        print(f"  {row['clip']} {row['label']:12s} {row['frames']:4d} frames, length {row['length']:7.1f} rad, "
              f"|log S| by level " + " ".join(f"{v:10.1f}" for v in row["level_norms"]), file=sys.stderr)
    if not args.no_interpolation:
        entries = {os.path.basename(e.file): e for e in ev.read_index(SETS["cmu27"])}
        walk, run = entries["07_01.bvh"], entries["09_02.bvh"]
        lin = {}
        for align in (False, True):
            rows = interpolation(args.data, args.out, walk, run, align)
            lin["aligned" if align else "unaligned"] = linearity(rows)
        with open(os.path.join(args.out, "interpolation_linearity.json"), "w") as fh:
            json.dump(lin, fh, indent=1)
        print(json.dumps(lin, indent=1), file=sys.stderr)
    if args.docs:
        copy_doc_figures(args.out, args.docs)
    for name, summary in results.items():
        print(f"== {name}: {summary['clips']} clips")
        for metric, row in summary["metrics"].items():
            extra = "".join(f"  {k} {row[k]:.3f}" for k in ("map", "silhouette") if k in row)
            if "crops" in row:
                extra += f"  crops {row['crops']['start']}+{row['crops']['end']}/{row['crops']['of']}"
            print(f"  {metric:26s} {row['accuracy']:.3f} ({row['correct']}/{summary['clips']})  "
                  f"{row['seconds']:8.2f} s{extra}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
