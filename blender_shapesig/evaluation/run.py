"""The whole evaluation of metrics on a labelled clip set (reference secs. 6.4, 9.2, 9.3): every metric's
matrix (timed), leave-one-out (or leave-one-group-out) 1-NN and mAP from every metric's ranking, silhouette,
confusion tables, crop probes, matrices and figures on disk.

Two-stage metrics (``BASE+elasticK``) reuse the first stage's matrix and, when ``elastic`` is in the same
run, the elastic matrix; their time is the first stage's time plus the time of the elastic pairs they
evaluate (estimated from the elastic matrix's time per pair, or measured pair by pair). ``local`` (the default
search) ranks by its first stage's matrix, each query's shortlist re-scored by both stages (``retrieval``).
"""

import os
import time

import numpy as np

from ..core.clip.clip import restrict_to_shared
from ..core.elastic.elastic import elastic_distance
from ..core.search.local import features as local
from ..core.metrics import DEFAULT_DEPTH, LOCAL, SMOOTHED_METRICS, parse_metric_spec
from ..core.pairwise import cross_distance_matrix, distance_matrix
from ..core.progress import Bar
from ..core.clip.prepare import COMPARE_FPS, SIGNATURE_SMOOTH_SECONDS, SMOOTH_SECONDS, prepare_clip
from .index import unique_names
from .plots import plot_dendrogram, plot_mds
from .report import safe_name, write_matrix, write_summary
from . import retrieval
from .scores import class_order, confusion_table, silhouette

__all__ = ["DEFAULT_METRICS", "EXTRA_METRICS", "CROP_FRACTION", "evaluate", "load_entries"]

CROP_FRACTION = 0.1  # crop probes: this fraction of a clip's frames cut at its start (then at its end)

DEFAULT_METRICS = ("l2", "elastic", "group3", "concat3", "linear3", "sim2", "sim3")
EXTRA_METRICS = (
    "elastic_numpy", "linear3_tensor", "sim3_tensor", "sim3_levelnorm", "sim3_levelnorm_tensor",
    "sim3+elastic3", "sim3+elastic5",
)


def _matrix_names(specs):
    """The matrices an evaluation of ``specs`` computes (``_Matrices.get``), in order."""
    names = [s.first_stage.name if s.rerank else s.name for s in specs if s.base != LOCAL]
    return list(dict.fromkeys(names))


class _Matrices:
    """Every metric's matrix once, timed as the shortest of ``repeat`` runs. ``curves``: the curves of the
    signature measures; ``srvt_curves``: those of the SRVT measures (and d_S* of the two-stage searches).
    ``progress``: "tqdm" (a bar per matrix) or ``progress(done, total)`` over the pairs of all ``planned``
    matrices and runs."""

    def __init__(self, curves, srvt_curves, depth, workers, repeat, progress, say, planned=()):
        self.curves, self.srvt_curves, self.depth, self.workers = curves, srvt_curves, depth, workers
        self.repeat, self.progress, self.say = max(1, int(repeat)), progress, say
        self.matrices, self.seconds = {}, {}
        self.pairs = len(curves) * (len(curves) - 1) // 2
        self.bars = isinstance(progress, str) and progress == "tqdm"
        self.total, self.runs = self.pairs * self.repeat * max(len(planned), 1), 0

    def _progress(self, bar):
        """The progress of one run: a bar, or the caller's callback offset by the runs before it."""
        if self.bars:
            return bar
        if not callable(self.progress):
            return None
        offset = self.runs * self.pairs
        return lambda done, _total: self.progress(offset + done, max(self.total, offset + self.pairs))

    def get(self, spec):
        if spec.name not in self.matrices:
            best = None
            for _ in range(self.repeat):
                with Bar(spec.name, enabled=self.bars) as bar:
                    t0 = time.perf_counter()
                    D = distance_matrix(self.curves_for(spec), spec, depth=self.depth, workers=self.workers,
                                        progress=self._progress(bar))
                self.runs += 1
                took = time.perf_counter() - t0
                best = took if best is None else min(best, took)
            self.matrices[spec.name], self.seconds[spec.name] = D, best
            self.say(f"{spec.name}: {best:.2f} s")
        return self.matrices[spec.name]

    def curves_for(self, spec):
        return self.srvt_curves if spec.base in SMOOTHED_METRICS else self.curves


def load_entries(entries, loader):
    """Every entry's clip: ``loader(entry)``, cropped to ``entry.start``..``entry.end`` (clamped to the clip, as
    ``sources.after_read`` crops)."""
    clips = []
    for e in entries:
        clip = loader(e)
        if e.start is not None or e.end is not None:
            clip = clip.crop(e.start, e.end, clamp=True)
        clips.append(clip)
    return clips


def _elastic_of(mats):
    """(d_S*(i, j) of the set's curves, how its time is counted): the elastic matrix when the run has it."""
    if "elastic" in mats.matrices:
        M = mats.matrices["elastic"]
        return (lambda i, j: float(M[i, j])), "estimated from the elastic matrix's time per pair"
    cache, curves, depth = {}, mats.srvt_curves, mats.depth

    def second(i, j):
        key = (min(i, j), max(i, j))
        if key not in cache:
            cache[key] = elastic_distance(curves[key[0]], curves[key[1]], depth=depth)
        return cache[key]
    return second, "measured"


def _two_stage_row(spec, mats, labels, cands):
    D1 = mats.get(spec.first_stage)
    t_first = mats.seconds[spec.first_stage.name]
    second, timing = _elastic_of(mats)
    pairs, orders = set(), []
    t0 = time.perf_counter()
    for i, cand in enumerate(cands):
        order = retrieval.first_stage_order(D1[i], cand)
        pairs.update((min(i, int(j)), max(i, int(j))) for j in order[:spec.rerank])
        orders.append(retrieval.rerank_order(order, spec.rerank, lambda j, i=i: second(i, int(j)))[0])
    t_second = time.perf_counter() - t0
    if "elastic" in mats.matrices:
        t_second = mats.seconds["elastic"] / max(1, mats.pairs) * len(pairs)
    acc, pred, nb, mAP = retrieval.ranking_scores(orders, labels)
    row = {"accuracy": acc, "map": mAP, "seconds": t_first + t_second, "first_stage_seconds": t_first,
           "elastic_pairs": len(pairs), "rerank_seconds": t_second, "rerank_timing": timing}
    return row, pred, nb


def _local_row(entries, names, labels, cands, out_dir):
    """The local search: its first stage for all pairs (the matrix written), then each query's shortlist
    re-scored (``retrieval.local_order``); 1-NN and mAP of that ranking, and of the first stage alone."""
    t0 = time.perf_counter()
    D1 = retrieval.local_first_stage(entries, entries)
    t_first = time.perf_counter() - t0
    orders = [retrieval.local_order(entries[i], entries, D1[i], cand) for i, cand in enumerate(cands)]
    seconds = time.perf_counter() - t0
    acc, pred, nb, mAP = retrieval.ranking_scores(orders, labels)
    acc1, _, _, map1 = retrieval.ranking_scores([retrieval.first_stage_order(D1[i], c) for i, c in enumerate(cands)],
                                                labels)
    paths = write_matrix(D1, names, os.path.join(out_dir, "matrices"), stem="local_first_stage")
    row = {"accuracy": acc, "map": mAP, "seconds": seconds, "first_stage_seconds": t_first,
           "first_stage_accuracy": acc1, "first_stage_map": map1, "shortlist": local.SHORTLIST,
           "matrix": os.path.relpath(paths["csv"], out_dir)}
    return row, pred, nb, D1


def _plain_row(spec, mats, names, labels, cands, out_dir, figures):
    D = mats.get(spec)
    orders = [retrieval.first_stage_order(D[i], cand) for i, cand in enumerate(cands)]
    acc, pred, nb, mAP = retrieval.ranking_scores(orders, labels)
    row = {"accuracy": acc, "seconds": mats.seconds[spec.name], "map": mAP, "silhouette": silhouette(D, labels)}
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


def _crop_probes(spec, crops, mats, local_entries, bones, time_base, smooth):
    """{"start": n, "end": n, "of": clips, "missed": [...]}: how many clips cut at that end rank their source
    first among the full set, by ``spec`` (its second stage too)."""
    out = {"of": len(mats.curves), "missed": []}
    everyone = np.arange(len(mats.curves))
    for side, clips in crops.items():
        found = 0
        if spec.base == LOCAL:
            probes = [local.index_entry(c) for c in clips]
            D = retrieval.local_first_stage(probes, local_entries)
            orders = [retrieval.local_order(p, local_entries, D[i], everyone) for i, p in enumerate(probes)]
        else:
            sel = [c.select(bones) for c in clips]
            if time_base:
                sig = [prepare_clip(c, smooth=SIGNATURE_SMOOTH_SECONDS).rotations for c in sel]
                srvt = [prepare_clip(c, smooth=smooth).rotations for c in sel]
            else:
                sig = srvt = [c.rotations for c in sel]
            first = spec.first_stage
            D = cross_distance_matrix(srvt if first.base in SMOOTHED_METRICS else sig, mats.curves_for(first), first,
                                      depth=mats.depth)
            orders = [retrieval.first_stage_order(D[i], everyone) for i in range(len(clips))]
            if spec.rerank:
                full = mats.srvt_curves
                orders = [retrieval.rerank_order(o, spec.rerank, lambda j, i=i: elastic_distance(
                    srvt[i], full[int(j)], depth=mats.depth))[0] for i, o in enumerate(orders)]
        for i, order in enumerate(orders):
            if int(order[0]) == i:
                found += 1
            else:
                out["missed"].append({"side": side, "clip": i, "nearest": int(order[0])})
        out[side] = found
    return out


def evaluate(entries, loader, metrics=DEFAULT_METRICS, out_dir="eval", depth=DEFAULT_DEPTH, workers=2,
             figures=True, progress=None, log=None, repeat=1, time_base=True, smooth=SMOOTH_SECONDS, groups=None,
             crops=None):
    """Evaluate metrics on labelled clips and write ``out_dir/summary.json`` and ``report.md`` (plus
    matrices and figures). ``loader(entry)`` returns the entry's Clip (uncropped; e.g.
    ``index.entry_loader``); ``entry.start`` / ``entry.end`` crop it (inclusive frame numbers). Returns
    the summary dict.

    ``repeat``: compute every matrix that many times and report the shortest wall time (the machine
    may be shared; the matrices are identical). ``progress``: "tqdm" (a bar on stderr per matrix) or
    ``progress(done, total)`` counting the pairs of every matrix computed (``core.progress``; a cancel raises
    Cancelled).
    ``time_base``: compare the clips on the time base of ``core.clip.prepare`` (the default, as the command line
    does: every clip at ``COMPARE_FPS``; the SRVT measures ``metrics.SMOOTHED_METRICS`` after a low-pass of
    ``smooth`` seconds, the signature measures without); False compares the curves as read (the thesis'
    protocol). ``groups`` (one value per entry, e.g. the actor): each query is ranked only against the clips of
    other groups (leave-one-group-out); else against every other clip. ``crops``: ``{"start": loader, "end":
    loader}``, each ``loader(entry)`` the entry's clip cut at that end (e.g. ``index.entry_loader(cut=...)``):
    every metric's row gets ``crops``, how many cut clips rank their source first among the full set.
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
    mats = _Matrices(curves, srvt_curves, depth, workers, repeat, progress, say, _matrix_names(specs))
    cands = retrieval.candidates(len(clips), groups)
    local_entries = [local.index_entry(c) for c in clips] if any(s.base == LOCAL for s in specs) else None
    crop_clips = {side: load_entries(entries, load) for side, load in crops.items()} if crops else None
    classes = class_order(labels)
    summary = {"clips": len(curves), "metrics": {}, "names": names, "labels": labels, "classes": classes,
               "bones": list(bones), "depth": depth, "workers": workers, "repeat": mats.repeat,
               "time_base": ({"fps": COMPARE_FPS, "smooth_seconds": smooth,
                              "signature_smooth_seconds": SIGNATURE_SMOOTH_SECONDS} if time_base else None),
               "trimmed": {n: c.meta.get("trim", {}).get("kept") for n, c in zip(names, clips)}}
    summary["protocol"] = "leave-one-group-out" if groups is not None else "leave-one-out"
    summary["crop_fraction"] = CROP_FRACTION if crops else None
    for spec in specs:
        if spec.base == LOCAL:
            row, pred, nb, _ = _local_row(local_entries, names, labels, cands, out_dir)
        elif spec.rerank:
            row, pred, nb = _two_stage_row(spec, mats, labels, cands)
        else:
            row, pred, nb = _plain_row(spec, mats, names, labels, cands, out_dir, figures)
        if crop_clips:
            row["crops"] = _crop_probes(spec, crop_clips, mats, local_entries, bones, time_base, smooth)
            for m in row["crops"]["missed"]:
                m["clip"], m["nearest"] = names[m["clip"]], names[m["nearest"]]
        ranked = [i for i in range(len(labels)) if pred[i] is not None]
        pred = [p if p is not None else labels[i] for i, p in enumerate(pred)]
        _, table = confusion_table([labels[i] for i in ranked], [pred[i] for i in ranked], classes)
        row["correct"] = int(round(row["accuracy"] * len(ranked)))
        row["confusion"] = {"classes": classes, "table": table.tolist()}
        row["mistakes"] = [{"clip": names[i], "label": labels[i], "nearest": names[nb[i]], "predicted": pred[i]}
                           for i in range(len(labels)) if pred[i] != labels[i]]
        summary["metrics"][spec.name] = row
    write_summary(summary, out_dir)
    return summary
