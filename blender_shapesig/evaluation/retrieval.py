"""Rankings and their scores for every kind of metric, in one protocol: each query ranks its candidates (every other
clip, or with groups the clips of the other groups: leave-one-group-out) by a distance row, optionally the first K
re-ordered by a second stage (``BASE+elasticK``: d_S*; ``local``: ``core.search.local.features.combine`` of both stages);
1-NN and mAP (the shortlist re-ordered, the rest in the first stage's order) from those rankings; and crop probes
(a clip cut by 10 % at one end queries the full set: does it find its source first?)."""

import numpy as np

from ..core.errors import ShapeSigError
from ..core.search.local import features as local

__all__ = ["candidates", "first_stage_order", "rerank_order", "local_order", "ranking_scores", "local_first_stage"]


def candidates(n, groups=None):
    """For each query i, the indices it ranks: j != i, and with ``groups`` only the clips of other groups."""
    if groups is not None and len(groups) != n:
        raise ShapeSigError(f"{len(groups)} groups for {n} clips")
    out = []
    for i in range(n):
        keep = [j for j in range(n) if j != i and (groups is None or groups[j] != groups[i])]
        out.append(np.asarray(keep, dtype=int))
    return out


def first_stage_order(row, cand):
    """``cand`` ordered by ``row`` (NaN last; ties: the lower index first)."""
    r = np.asarray(row, dtype=np.float64)[cand]
    return cand[np.argsort(np.where(np.isnan(r), np.inf, r), kind="stable")]


def rerank_order(order, k, second):
    """``order`` with its first ``k`` re-ordered by ``second(j)`` (stable); returns (order, pairs evaluated)."""
    head = list(order[:k])
    d2 = np.array([second(j) for j in head])
    head = [head[t] for t in np.argsort(d2, kind="stable")]
    return np.concatenate([np.asarray(head, dtype=int), order[k:]]), len(d2)


def local_order(q_entry, entries, row, cand, shortlist=local.SHORTLIST):
    """The local search's ranking of ``cand`` for one query: the first stage's ``row``, its ``local.shortlisted``
    scored by ``local.shortlist_scores``, the others in the first stage's order (``rank_clips``' order)."""
    order = first_stage_order(row, cand)
    d1 = np.full(len(entries), np.inf)
    d1[order] = np.arange(len(order))  # the first stage's order over the candidates only (ties broken as it does)
    head = local.shortlisted(q_entry, entries, d1, shortlist)
    score, _ = local.shortlist_scores(q_entry, [entries[j] for j in head], np.asarray(row)[head])
    return np.concatenate([head[np.argsort(score, kind="stable")], order[~np.isin(order, head)]]).astype(int)


def local_first_stage(queries, entries):
    """(len(queries), len(entries)) first-stage distances (every query against the stacked library)."""
    block = local.stack(entries)
    return np.stack([local.first_stage(q, block) for q in queries]) if queries else np.zeros((0, len(entries)))


def ranking_scores(orders, labels):
    """(1-NN accuracy, predicted labels, nearest indices, mAP) of the rankings ``orders[i]`` of query i (clips
    without a candidate are left out of the accuracy; mAP over the queries with a relevant candidate)."""
    labels = list(labels)
    hits, predicted, nearest, aps = [], [], [], []
    for i, order in enumerate(orders):
        if len(order) == 0:
            predicted.append(None)
            nearest.append(None)
            continue
        nearest.append(int(order[0]))
        predicted.append(labels[order[0]])
        hits.append(predicted[-1] == labels[i])
        rel = np.array([labels[j] == labels[i] for j in order])
        if rel.any():
            ranks = np.flatnonzero(rel) + 1
            aps.append(float(np.mean(np.arange(1, len(ranks) + 1) / ranks)))
    if not hits:
        raise ShapeSigError("no query has a candidate (every clip is alone in its group)")
    return float(np.mean(hits)), predicted, nearest, (float(np.mean(aps)) if aps else float("nan"))
