"""The whole evaluation of metrics on a labelled clip set (reference secs. 6.4, 9.2, 9.3): every metric's
matrix (timed), leave-one-out 1-NN, mAP, silhouette, confusion tables, matrices and figures on disk.

Two-stage metrics (``BASE+elasticK``) reuse the first stage's matrix and, when ``elastic`` is in the same
run, the elastic matrix; their time is the first stage's time plus the time of the elastic pairs they
evaluate (estimated from the elastic matrix's time per pair, or measured pair by pair).
"""

import os
import sys
import time

from ..core.clip.clip import restrict_to_shared
from ..core.elastic.elastic import elastic_distance
from ..core.metrics import DEFAULT_DEPTH, SMOOTHED_METRICS, parse_metric_spec
from ..core.pairwise import distance_matrix
from ..core.clip.prepare import COMPARE_FPS, SIGNATURE_SMOOTH_SECONDS, SMOOTH_SECONDS, prepare_clip
from .index import unique_names
from .plots import plot_dendrogram, plot_mds
from .report import safe_name, write_matrix, write_summary
from .scores import class_order, confusion_table, loo_1nn, mean_average_precision, silhouette, two_stage_1nn

__all__ = ["DEFAULT_METRICS", "EXTRA_METRICS", "evaluate", "load_entries"]

DEFAULT_METRICS = ("l2", "elastic", "group3", "concat3", "linear3", "sim2", "sim3")
EXTRA_METRICS = (
    "elastic_numpy", "linear3_tensor", "sim3_tensor", "sim3_levelnorm", "sim3_levelnorm_tensor",
    "sim3+elastic3", "sim3+elastic5",
)


class _CountBar:
    def __init__(self, progress=None):
        self.progress = progress if callable(progress) else None

    def update(self, n=1):
        if self.progress:
            self.progress(n)

    def close(self):
        pass


def _make_bar(progress, total, desc):
    """A tqdm bar on stderr for ``progress="tqdm"``; else an object passing counts to ``progress(n)``."""
    if progress == "tqdm":
        try:
            from tqdm import tqdm

            return tqdm(total=total, desc=desc, file=sys.stderr, leave=False, dynamic_ncols=True)
        except ImportError:  # pragma: no cover - tqdm is a dev requirement
            pass
    return _CountBar(progress)


class _Matrices:
    """Every metric's matrix once, timed as the shortest of ``repeat`` runs. ``curves``: the curves of the
    signature measures; ``srvt_curves``: those of the SRVT measures (and d_S* of the two-stage searches)."""

    def __init__(self, curves, srvt_curves, depth, workers, repeat, progress, say):
        self.curves, self.srvt_curves, self.depth, self.workers = curves, srvt_curves, depth, workers
        self.repeat, self.progress, self.say = max(1, int(repeat)), progress, say
        self.matrices, self.seconds = {}, {}
        self.pairs = len(curves) * (len(curves) - 1) // 2

    def get(self, spec):
        if spec.name not in self.matrices:
            best = None
            for _ in range(self.repeat):
                bar = _make_bar(self.progress, self.pairs, spec.name)
                t0 = time.perf_counter()
                try:
                    D = distance_matrix(self.curves_for(spec), spec, depth=self.depth, workers=self.workers,
                                        progress=bar.update)
                finally:
                    bar.close()
                took = time.perf_counter() - t0
                best = took if best is None else min(best, took)
            self.matrices[spec.name], self.seconds[spec.name] = D, best
            self.say(f"{spec.name}: {best:.2f} s")
        return self.matrices[spec.name]

    def curves_for(self, spec):
        return self.srvt_curves if spec.base in SMOOTHED_METRICS else self.curves


def load_entries(entries, loader):
    """Every entry's clip: ``loader(entry)``, cropped to ``entry.start``..``entry.end``."""
    clips = []
    for e in entries:
        clip = loader(e)
        if e.start is not None or e.end is not None:
            clip = clip.crop(e.start, e.end)
        clips.append(clip)
    return clips


def _two_stage_row(spec, mats, labels):
    D1 = mats.get(spec.first_stage)
    t_first = mats.seconds[spec.first_stage.name]
    if "elastic" in mats.matrices:
        acc, pred, nb, pairs = two_stage_1nn(D1, labels, spec.rerank, mats.matrices["elastic"])
        t_second = mats.seconds["elastic"] / max(1, mats.pairs) * len(pairs)
        timing = "estimated from the elastic matrix's time per pair"
    else:
        curves, depth = mats.srvt_curves, mats.depth
        t0 = time.perf_counter()
        acc, pred, nb, pairs = two_stage_1nn(
            D1, labels, spec.rerank, lambda i, j: elastic_distance(curves[i], curves[j], depth=depth))
        t_second = time.perf_counter() - t0
        timing = "measured"
    row = {"accuracy": acc, "seconds": t_first + t_second, "first_stage_seconds": t_first,
           "elastic_pairs": len(pairs), "rerank_seconds": t_second, "rerank_timing": timing}
    return row, pred, nb


def _plain_row(spec, mats, names, labels, out_dir, figures):
    D = mats.get(spec)
    acc, pred, nb = loo_1nn(D, labels)
    row = {"accuracy": acc, "seconds": mats.seconds[spec.name], "map": mean_average_precision(D, labels),
           "silhouette": silhouette(D, labels)}
    stem = safe_name(spec.name)
    paths = write_matrix(D, names, os.path.join(out_dir, "matrices"), stem=stem)
    row["matrix"] = os.path.relpath(paths["csv"], out_dir)
    if figures and len(names) >= 3:
        fig_dir = os.path.join(out_dir, "figures")
        os.makedirs(fig_dir, exist_ok=True)
        mds_png = plot_mds(D, names, labels, os.path.join(fig_dir, f"mds_{stem}.png"),
                           title=f"MDS, {spec.name} (1-NN {acc:.0%})")
        tree_png = plot_dendrogram(D, names, labels, os.path.join(fig_dir, f"dendrogram_{stem}.png"),
                                   title=f"Dendrogram, {spec.name}")
        row["figures"] = [os.path.relpath(mds_png, out_dir), os.path.relpath(tree_png, out_dir)]
    return row, pred, nb


def evaluate(entries, loader, metrics=DEFAULT_METRICS, out_dir="eval", depth=DEFAULT_DEPTH, workers=2,
             figures=True, progress=None, log=None, repeat=1, time_base=True, smooth=SMOOTH_SECONDS):
    """Evaluate metrics on labelled clips and write ``out_dir/summary.json`` and ``report.md`` (plus
    matrices and figures). ``loader(entry)`` returns the entry's Clip (uncropped; e.g.
    ``index.entry_loader``); ``entry.start`` / ``entry.end`` crop it (inclusive frame numbers). Returns
    the summary dict.

    ``repeat``: compute every matrix that many times and report the shortest wall time (the machine
    may be shared; the matrices are identical). ``progress``: "tqdm" or a callable counting pairs.
    ``time_base``: compare the clips on the time base of ``core.clip.prepare`` (the default, as the command line
    does: every clip at ``COMPARE_FPS``; the SRVT measures ``metrics.SMOOTHED_METRICS`` after a low-pass of
    ``smooth`` seconds, the signature measures without); False compares the curves as read (the thesis'
    protocol).
    """
    specs = [parse_metric_spec(m) for m in metrics]
    os.makedirs(out_dir, exist_ok=True)
    say = log or (lambda msg: None)
    clips = load_entries(entries, loader)
    names = unique_names([os.path.splitext(os.path.basename(e.file))[0] for e in entries])
    labels = [e.label for e in entries]
    restricted = restrict_to_shared(*clips)
    bones = restricted[0].bones
    curves = srvt_curves = [c.rotations for c in restricted]
    if time_base:
        curves = [prepare_clip(c, smooth=SIGNATURE_SMOOTH_SECONDS).rotations for c in restricted]
        srvt_curves = [prepare_clip(c, smooth=smooth).rotations for c in restricted]
    say(f"{len(curves)} clips, {len(bones)} moving shared bones, frames {min(len(c) for c in curves)}.."
        f"{max(len(c) for c in curves)} ({min(len(c) for c in srvt_curves)}..{max(len(c) for c in srvt_curves)}"
        f" on the SRVT measures' time base)")
    mats = _Matrices(curves, srvt_curves, depth, workers, repeat, progress, say)
    classes = class_order(labels)
    summary = {"clips": len(curves), "metrics": {}, "names": names, "labels": labels, "classes": classes,
               "bones": list(bones), "depth": depth, "workers": workers, "repeat": mats.repeat,
               "time_base": ({"fps": COMPARE_FPS, "smooth_seconds": smooth,
                              "signature_smooth_seconds": SIGNATURE_SMOOTH_SECONDS} if time_base else None),
               "trimmed": {n: c.meta.get("trim", {}).get("kept") for n, c in zip(names, clips)}}
    for spec in specs:
        if spec.rerank:
            row, pred, nb = _two_stage_row(spec, mats, labels)
        else:
            row, pred, nb = _plain_row(spec, mats, names, labels, out_dir, figures)
        _, table = confusion_table(labels, pred, classes)
        row["correct"] = int(round(row["accuracy"] * len(labels)))
        row["confusion"] = {"classes": classes, "table": table.tolist()}
        row["mistakes"] = [{"clip": names[i], "label": labels[i], "nearest": names[nb[i]], "predicted": pred[i]}
                           for i in range(len(labels)) if pred[i] != labels[i]]
        summary["metrics"][spec.name] = row
    write_summary(summary, out_dir)
    return summary
