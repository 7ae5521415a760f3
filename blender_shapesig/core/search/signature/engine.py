"""The signature search as an engine (``SignatureEngine``, the ``core.search.engines`` shape): the query's skeleton
through the index by sim^n (eq. 9.1; exact from the directions, or sketch estimates in a compact store), other
skeletons and every other measure pairwise on the bones they share with the query, an optional d_S* re-rank of
the first rows. See docs/search.md.
"""

import dataclasses

import numpy as np

from ...clip.clip import Clip
from ...distances import curve_distance
from ...errors import ShapeSigError
from ...io.sources import LibraryItem, clip_item
from ...measure_words import ENGINES
from ...rigs import coverage_from
from ..indexing import compute_entries, iter_entries
from ..rows import FEW_SHARED, RankResult, coverage_rule
from .entry import IndexEntry, curve_from_increments, entry_distance, pair_increments, sim_from_increments, \
    sketch_distance
from .index import item_entries, loaded as _loaded

__all__ = ["EXACT_POOL", "SignatureEngine", "query_entry", "rank_on_shared_bones"]

# At least this many sketch candidates are compared exactly.
EXACT_POOL = 64


def query_entry(query, level, store):
    """A private, loaded copy of the query's entry (the store may drop the arrays of its own object to keep
    within its memory limit)."""
    item = None
    if isinstance(query, Clip):
        query = clip_item(query)
    if isinstance(query, LibraryItem):
        item, entries = query, item_entries(query, level, store)
        if len(entries) != 1:
            raise ShapeSigError(f"query {query.name!r} holds {len(entries)} clips; choose one")
        query = entries[0]
    if not isinstance(query, IndexEntry):
        raise ShapeSigError(f"the query must be a Clip, got {type(query).__name__}")
    return dataclasses.replace(_loaded(query, item, store))



def _result(item, e, d, shared, approximate=False, partial=False, got=None):
    got = got or {"coverage": 1.0, "unmapped": []}
    return RankResult(name=e.name, distance=float(d), frames=e.clip_frames or e.frames, key=e.key, source=e.source,
                      shared=shared, approximate=approximate, partial=partial, coverage=float(got["coverage"]),
                      unmapped=tuple(got["unmapped"]), trimmed=e.trimmed, item=item)


def _entry_coverage(q: IndexEntry, e: IndexEntry) -> dict:
    """``rigs.coverage_from`` of two index entries (their bones, still bones and rigs' canonical joints)."""
    return coverage_from(q.bones, q.still, q.rig_joints, e.bones, e.still, e.rig_joints)


def _sketch_candidates(q, same, store, npool):
    """The ``npool`` pairs of ``same`` whose sketches are closest to the query's."""
    S, sq = store.sketch_matrix([e for _, e in same])
    qs = q.sketch.astype(np.float64)
    approx = sq + qs @ qs - 2.0 * (S @ q.sketch).astype(np.float64)
    return [same[i] for i in np.argpartition(approx, npool - 1)[:npool]]


def _rank_same_skeleton(q, same, store, npool, use_sketch, warnings, skipped, allow_partial=True):
    """Results for the clips of the query's skeleton by sim, from the directions (exact) or, for entries a
    compact store keeps no direction of, the sketches (approximate); the coverage rule as ``coverage_rule``."""
    results = []
    for item, e in (_sketch_candidates(q, same, store, npool) if use_sketch else same):
        got = _entry_coverage(q, e)
        partial = coverage_rule(e.name, got, allow_partial, warnings, skipped)
        if partial is None:
            continue
        _loaded(e, item, store)
        if q.exact and e.exact:
            results.append(_result(item, e, entry_distance(q, e), len(q.bones), partial=partial, got=got))
        else:
            results.append(_result(item, e, sketch_distance(q, e), len(q.bones), approximate=True, partial=partial,
                                   got=got))
    return results


def rank_on_shared_bones(q, pairs, store, base, sig_level, level, depth, warnings, skipped, allow_partial=True):
    """Results for clips compared pairwise on the bones they share with the query (other skeletons, or any
    metric other than sim), from their increments; without ``allow_partial``, clips below the coverage rule
    (``rigs.below_minimum``: joints, limb chains) are skipped with a warning naming it, with it they are partial."""
    q_moving = {q.bones[j] for j in q.moving}
    results = []
    for item, e in pairs:
        bones = set(e.bones)
        shared = [b for b in q.bones if b in bones]
        if not shared:
            skipped.append(e.name)
            warnings.append(f"{e.name}: shares no bones with the query {q.name!r}; skipped")
            continue
        moving_shared = q_moving & set(shared)
        got = _entry_coverage(q, e)
        low = coverage_rule(e.name, got, allow_partial, warnings, skipped)
        if low is None:
            continue
        partial = bool(q_moving) and len(moving_shared) < FEW_SHARED * len(q_moving)
        if partial:
            warnings.append(f"{e.name}: shares only {len(moving_shared)} of the query's {len(q_moving)} moving "
                            f"bones; ranked after the clips that share most of them")
        a, b = pair_increments(q, _loaded(e, item, store), shared)
        if base == "sim":
            d = sim_from_increments(a, b, sig_level)
        else:
            d = curve_distance(curve_from_increments(a, base), curve_from_increments(b, base), base, level=level,
                               depth=depth)
        results.append(_result(item, e, d, len(shared), partial=partial or low, got=got))
    return results


def _rerank_elastic(results, pairs, q, store, base, rerank, depth):
    """Re-order the first ``rerank`` results (of the whole-body tier when there is one) by d_S*, filling
    their ``elastic``."""
    from ...elastic.elastic import elastic_distance  # numba is imported only when a re-rank needs the DP

    full = sum(1 for r in results if not r.partial)
    head = results[:min(rerank, full)] if full else results[:rerank]
    by_item = {(id(item), e.name): e for item, e in pairs}
    for r in head:
        if base == "elastic":
            r.elastic = r.distance
            continue
        e = _loaded(by_item[(id(r.item), r.name)], r.item, store)
        bones = set(e.bones)
        a, b = pair_increments(q, e, [x for x in q.bones if x in bones])
        r.elastic = float(elastic_distance(curve_from_increments(a, "elastic"), curve_from_increments(b, "elastic"),
                                           depth=depth))
    head.sort(key=lambda r: (r.elastic, r.distance, r.name))
    results[:len(head)] = head



class SignatureEngine:
    """The signature search (``base`` "sim": sim^n through the index) and every pairwise measure of
    ``metric_names.parse_metric`` (``base`` "l2", "elastic", "group", ...) at signature level ``level``."""

    needs_index = True

    def __init__(self, base="sim", level=3, measure_level=None):
        self.base, self.level = base, int(level)  # level: the entries' (the signature level of sim)
        self.measure_level = measure_level if measure_level is not None else level  # e.g. group3's
        self.id = f"sim{self.level}" if base == "sim" else base

    @property
    def words(self):
        return ENGINES["sim"]  # every signature or pairwise measure is "Motion only"

    def indexed(self, item: LibraryItem, store) -> bool:
        return store.contains(item.key, self.level)

    def index(self, item: LibraryItem, store, errors) -> bool:
        """Index one item when the store lacks it; False when it could not be read (one line in ``errors``)."""
        return bool(next(iter_entries([item], self.level, store, errors))[1])

    def rank(self, query, items, store, *, rerank=0, top=None, depth, progress=None, pool=None,
             allow_partial=True):
        """(rows, warnings, skipped, stats): ``rank_clips``' contract for this engine."""
        base, sig_level, lvl = self.base, self.level, self.measure_level
        rerank = max(int(rerank or 0), 0)
        q = query_entry(query, sig_level, store)
        warnings = []
        pairs = compute_entries(items, sig_level, store, progress, warnings)
        skipped = []
        results = []
        if base == "sim":  # the query's skeleton through the index; other skeletons on their shared bones
            same = [(item, e) for item, e in pairs if e.bones == q.bones]
            npool = pool if pool is not None else max(EXACT_POOL, 4 * (top or 0), rerank)
            results = _rank_same_skeleton(q, same, store, npool, top is not None and len(same) > npool, warnings,
                                          skipped, allow_partial)
        other = [(item, e) for item, e in pairs if base != "sim" or e.bones != q.bones]
        pairwise = rank_on_shared_bones(q, other, store, base, sig_level, lvl, depth, warnings, skipped,
                                        allow_partial)
        compared = sum(not r.approximate for r in results) + len(pairwise)
        results += pairwise
        # Distances over a small part of the body are not comparable with whole-body ones (a clip that shares
        # only the head can look close): clips sharing few of the query's moving bones form a second tier.
        results.sort(key=lambda r: (r.partial, r.distance, r.name))
        if rerank and results:
            _rerank_elastic(results, pairs, q, store, base, rerank, depth)
        return results, warnings, skipped, {"compared": compared, "library": len(pairs)}
