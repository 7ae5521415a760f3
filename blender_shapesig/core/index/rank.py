"""Ranking a library against a query and the one index generator: ``iter_entries`` (computes what the store lacks
and stores it), ``build_index`` and ``rank_clips`` (-> ``RankList`` of ``RankResult``): by default the local search
(``local_rank``; clips it cannot read after the others by sim3), else sketches shortlist, exact word-code distances,
other skeletons on their shared bones, an optional d_S* re-rank.
See docs/search.md.
"""

import dataclasses
import time
from dataclasses import dataclass
from typing import List, Optional, Sequence, Tuple

import numpy as np

from ..blas import one_blas_thread
from ..clip.clip import Clip
from ..errors import ShapeSigError
from ..measure_words import ENGINES
from ..progress import wants_cancel
from ..distances import curve_distance
from ..elastic import DEFAULT_DEPTH
from ..metric_names import DEFAULT_LEVEL, DEFAULT_METRIC, LOCAL, parse_metric
from ..rigs import below_minimum, coverage_from
from ..io.sources import LibraryItem, as_items, clip_item, library
from .entry import (IndexEntry, curve_from_increments, entry_distance, make_entry, pair_increments,
                    sim_from_increments, sketch_distance)
from .local import SHORTLIST
from .local_rank import item_local_entries, local_entries, query_local_entry, rank_local
from .store import SignatureCache

__all__ = ["EXACT_POOL", "FEW_SHARED", "RankResult", "RankList", "coverage_rule", "clip_items", "folder_library", "item_entries",
           "iter_entries", "compute_entries", "build_index", "rank_clips"]

# At least this many sketch candidates are compared exactly.
EXACT_POOL = 64
# Warn when the shared bones cover less than this fraction of the query's moving bones.
FEW_SHARED = 0.5


# ----------------------------------------------------------------------------------------- results

@dataclass
class RankResult:
    """One ranked clip. ``distance``: sim^n (or the chosen metric); ``elastic``: d_S* when re-ranked,
    else None; ``frames``: the clip's frame count; ``key``: its library item's key; ``shared``: bones
    compared; ``approximate``: True when ``distance`` is a sketch estimate (only with a compact store);
    ``partial``: the clip shares fewer than FEW_SHARED of the query's moving bones, or (kept by ``allow_partial``)
    is below the coverage rule (``rigs.below_minimum``): ranked after the others; ``unmapped``: the canonical
    joints both rigs have that are not compared."""

    name: str
    distance: float
    elastic: Optional[float] = None
    frames: int = 0
    key: str = ""
    source: str = ""
    shared: int = 0
    approximate: bool = False
    partial: bool = False
    coverage: float = 1.0  # joints compared / canonical joints both rigs have (core.rigs.coverage_from)
    unmapped: Tuple[str, ...] = ()  # canonical joints both rigs have that are not compared
    start: Optional[int] = None  # a moment (``windows.rank_windows``): its frames in the clip's own numbers
    end: Optional[int] = None
    explain: Optional[dict] = None  # ``core.elastic.explain``: per-joint shares, cost over time
    trimmed: Tuple[int, ...] = ()  # (first kept, last kept, first read, last read) when trimming cut frames
    metric: str = ""  # the measure of ``distance`` ("local", "sim3", ...: a local ranking ranks some clips by sim3)
    first_stage: Optional[float] = None  # the local search: the first stage's distance of the clip
    dtw: Optional[float] = None  # the local search: the second stage's DTW distance (the shortlist only)

    def as_dict(self):
        out = {"clip": self.name, "distance": self.distance, "elastic": self.elastic, "frames": self.frames,
               "source": self.source, "coverage": self.coverage, "unmapped": list(self.unmapped),
               "partial": self.partial}
        if self.metric:
            out.update(metric=self.metric, first_stage=self.first_stage, dtw=self.dtw)
        if self.start is not None:
            out.update(start=self.start, end=self.end)
        return out


class RankList(list):
    """``rank_clips``' result: a list of RankResult, best first, plus ``warnings`` (one-line strings),
    ``skipped`` (names of clips that share no bone with the query) and ``stats`` (cache hits and
    misses of this call, clips compared exactly, seconds)."""

    def __init__(self, items=(), warnings=(), skipped=(), stats=None):
        super().__init__(items)
        self.warnings = list(warnings)
        self.skipped = list(skipped)
        self.stats = dict(stats or {})


# ----------------------------------------------------------------------------------------- library
# Library members, keys and clip files are owned by core.io.sources.

def clip_items(clips: Sequence[Clip]) -> List[LibraryItem]:
    """Library items for clips already in memory, keyed by their data."""
    return [clip_item(c) for c in clips]


def folder_library(paths, load=None, asf=None, start=None, recursive=True, end=None) -> List[LibraryItem]:
    """Library items for clip files given directly or found in folders (``sources.library``); ``load(spec)``
    reads one ClipSpec (default: the reader registry)."""
    return library(paths, recursive, load=load, asf=asf, start=start, end=end)


# -------------------------------------------------------------------------------------------- index

@one_blas_thread()  # small products: OpenBLAS threads only wait for each other (core/blas.py)
def item_entries(item: LibraryItem, level, store: SignatureCache) -> List[IndexEntry]:
    """The item's entries: from the store, else computed (its clips loaded) and put in the store."""
    level = int(level)
    got = store.get(item.key, level)
    if got is not None:
        return got
    out = []
    for c in item.clips():
        e = make_entry(c, level, key=item.key)
        e.source = e.source or item.source
        out.append(e)
    store.put(item.key, level, out)
    return out


def _read_once(item: LibraryItem) -> LibraryItem:
    """The item with a loader that reads its clips at most once (both kinds of entries come from one read)."""
    got = []

    def load():
        if not got:
            got.append(item.clips())
        return got[0]

    return dataclasses.replace(item, load=load)


def iter_entries(items, level=DEFAULT_LEVEL, store=None, errors=None, progress=None, local=False):
    """The index loop: yield (item, entries) for every item, in order, each computed only when the store does
    not hold it; with ``local``, the item's local-search entries too (``local_rank.item_local_entries``: in the
    store, not yielded), from the same read. A ShapeSigError while loading an item is recorded in ``errors`` (a list of one-line messages;
    the item then yields no entries) when given, else raised. ``progress(done, total)`` (``core.progress``) is
    called before each item (done = items done) and once more with (total, total) at the end; returning True
    stops the loop there: what was done is yielded (and stored), the rest is not."""
    store = store if store is not None else SignatureCache()
    items = as_items(items)
    for i, item in enumerate(items):
        if wants_cancel(progress, i, len(items)):
            return
        try:
            once = _read_once(item) if local else item
            if local:
                item_local_entries(once, store)
            got = item_entries(once, level, store)
        except ShapeSigError as exc:
            if errors is None:
                raise
            errors.append(f"{item.name}: {exc}")
            got = []
        yield item, got
    wants_cancel(progress, len(items), len(items))


def compute_entries(items, level=DEFAULT_LEVEL, cache=None, progress=None, errors=None, local=False):
    """[(item, entry)] for every clip of every item, through the store (``iter_entries``)."""
    return [(item, e) for item, got in iter_entries(items, level, cache, errors, progress, local) for e in got]


def build_index(items, level=DEFAULT_LEVEL, cache=None, progress=None, local=True):
    """Fill the store for every item (with ``local``, the default, the local search's entries too); returns a dict with clips, errors, cache stats, seconds and warnings (the
    store's one line when it went on in memory only). ``progress``: ``iter_entries``' (a cancel keeps what was
    indexed)."""
    t0 = time.perf_counter()
    errors = []
    got = compute_entries(items, level, cache, progress, errors, local)
    if cache is not None:
        cache.save_pack()
    return {"clips": len(got), "errors": errors, "seconds": time.perf_counter() - t0,
            "stats": dict(cache.stats) if cache is not None else {},
            "warnings": [cache.warning] if getattr(cache, "warning", None) else []}


def _loaded(entry: IndexEntry, item: Optional[LibraryItem], store: SignatureCache) -> IndexEntry:
    """The entry with its direction and increments in memory; when its file has become unreadable meanwhile,
    its item is computed again (ShapeSigError without an item)."""
    if store.heavy(entry) is not None:
        return entry
    if item is None:
        raise ShapeSigError(f"the index entry of {entry.name!r} is gone; build the index again")
    store.forget(entry.key, entry.level)
    for e in item_entries(item, entry.level, store):
        if e.name == entry.name and e.bones == entry.bones and e.moving == entry.moving and store.heavy(e):
            entry.direction, entry.increments, entry.exact = e.direction, e.increments, e.exact
            return entry
    raise ShapeSigError(f"the index entry of {entry.name!r} changed; build the index again")


# ------------------------------------------------------------------------------------------ ranking

def _query_entry(query, level, store):
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


def _result(e, d, shared, approximate=False, partial=False, got=None):
    got = got or {"coverage": 1.0, "unmapped": []}
    return RankResult(name=e.name, distance=float(d), frames=e.clip_frames or e.frames, key=e.key, source=e.source,
                      shared=shared, approximate=approximate, partial=partial, coverage=float(got["coverage"]),
                      unmapped=tuple(got["unmapped"]), trimmed=e.trimmed)


def _entry_coverage(q: IndexEntry, e: IndexEntry) -> dict:
    """``rigs.coverage_from`` of two index entries (their bones, still bones and rigs' canonical joints)."""
    return coverage_from(q.bones, q.still, q.rig_joints, e.bones, e.still, e.rig_joints)


def coverage_rule(name, got, allow_partial, warnings, skipped):
    """The coverage rule for one row (``rigs.below_minimum``): None when it is refused (one warning; without
    ``allow_partial``), else whether the row is partial because of it."""
    why = below_minimum(got)
    if not why:
        return False
    if not allow_partial:
        skipped.append(name)
        missing = ", ".join(got["unmapped"][:6]) + (", ..." if len(got["unmapped"]) > 6 else "")
        warnings.append(f"{name}: {why}" + (f" (unmapped: {missing})" if missing else "")
                        + "; skipped (allow partial matches to rank it)")
        return None
    return True


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
            results.append(_result(e, entry_distance(q, e), len(q.bones), partial=partial, got=got))
        else:
            results.append(_result(e, sketch_distance(q, e), len(q.bones), approximate=True, partial=partial,
                                   got=got))
    return results


def _rank_on_shared_bones(q, pairs, store, base, sig_level, level, depth, warnings, skipped, allow_partial=True):
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
        results.append(_result(e, d, len(shared), partial=partial or low, got=got))
    return results


def _rerank_elastic(results, pairs, q, store, base, rerank, depth):
    """Re-order the first ``rerank`` results (of the whole-body tier when there is one) by d_S*, filling
    their ``elastic``."""
    from ..elastic.elastic import elastic_distance  # numba is imported only when a re-rank needs the DP

    full = sum(1 for r in results if not r.partial)
    head = results[:min(rerank, full)] if full else results[:rerank]
    by_key = {(e.key, e.name): (item, e) for item, e in pairs}
    for r in head:
        if base == "elastic":
            r.elastic = r.distance
            continue
        item, e = by_key[(r.key, r.name)]
        e = _loaded(e, item, store)
        bones = set(e.bones)
        a, b = pair_increments(q, e, [x for x in q.bones if x in bones])
        r.elastic = float(elastic_distance(curve_from_increments(a, "elastic"), curve_from_increments(b, "elastic"),
                                           depth=depth))
    head.sort(key=lambda r: (r.elastic, r.distance, r.name))
    results[:len(head)] = head


def _rank_by_local(query, items, store, shortlist, progress, depth, allow_partial, top=None):
    """(results, warnings, skipped, compared) of the local search: the readable clips by ``local_rank.rank_local``;
    the clips its features refuse after them, by sim3 on their shared bones, with one warning."""
    q = query_local_entry(query, store)
    warnings, skipped = [], []
    got = local_entries(items, store, progress, warnings)
    ok = [(item, e) for item, e in got if not e.get("refused")]
    refused = [(item, e) for item, e in got if e.get("refused")]
    full, part = [], []
    ranked = rank_local(q, ok, store, shortlist or SHORTLIST)
    for i, score, d1, d2 in ranked:
        if top is not None and len(full) >= top:  # rows only for what is kept
            break
        item, e = ok[i]
        # the body is compared whole: every canonical joint both clips have (their rigs' other joints unmapped)
        got = coverage_from(q.get("joints", ()), q.get("still", ()), q.get("rig_joints", ()), e.get("joints", ()),
                            e.get("still", ()), e.get("rig_joints", ()))
        low = coverage_rule(e["name"], got, allow_partial, warnings, skipped)
        if low is None:
            continue
        (part if low else full).append(RankResult(
            name=e["name"], distance=score, frames=e.get("frames", 0), key=item.key, source=item.source,
            trimmed=tuple(e.get("trimmed", ())), metric=LOCAL, first_stage=d1, dtw=d2, partial=low,
            shared=min(q.get("bones", 0), e.get("bones", 0)), coverage=float(got["coverage"]),
            unmapped=tuple(got["unmapped"])))
    results = full + part
    if refused:
        warnings.append(f"{len(refused)} clip(s) the local search cannot read ({refused[0][1]['name']}: "
                        f"{refused[0][1]['refused']}) are ranked after the others by {ENGINES['sim'].status}")
    if refused and (top is None or len(results) < top):  # their rows only when they can be kept
        qs = _query_entry(query, DEFAULT_LEVEL, store)
        names = {(item.key, e["name"]) for item, e in refused}
        refused_items = list({item.key: item for item, _ in refused}.values())
        pairs = [(item, e) for item, e in compute_entries(refused_items, DEFAULT_LEVEL, store, None, warnings)
                 if (item.key, e.name) in names]
        tail = _rank_on_shared_bones(qs, pairs, store, "sim", DEFAULT_LEVEL, DEFAULT_LEVEL, depth, warnings, skipped,
                                     allow_partial)
        tail.sort(key=lambda r: (r.partial, r.distance, r.name))
        for r in tail:
            r.metric = f"sim{DEFAULT_LEVEL}"
        results += tail
    return results, warnings, skipped, len(ranked) + len(refused)


@one_blas_thread()
def rank_clips(query, library, metric=DEFAULT_METRIC, level=None, rerank=0, top=None, cache=None, *,
               depth=DEFAULT_DEPTH, progress=None, exclude=(), pool=None, allow_partial=True) -> RankList:
    """Rank ``library`` (Clips or LibraryItems) by their distance to ``query`` (a Clip), best first.

    ``metric``: ``local`` (the default: the local search, ``local_rank``; ``rerank=K`` sets its shortlist,
    default ``local.SHORTLIST``; ``distance`` is the final score, ``first_stage``/``dtw`` its two stages; clips
    the local features cannot read, e.g. without legs, come after the others by sim3 with a warning, and such a
    query is refused in one line), ``sim`` (sim^n, through the index) or any name of ``metrics.parse_metric``
    (computed pairwise from the cached increments). ``level``: the signature level (default DEFAULT_LEVEL, or the
    digits of e.g. ``sim2``). ``rerank=K``: the first K results are re-ordered by the elastic distance
    d_S* (depth ``depth``), which fills their ``elastic``. ``top``: keep the first ``top``. ``cache``: a
    SignatureCache (default: a fresh in-memory one). ``exclude``: item keys or names to leave out (e.g.
    the query's own action). ``pool``: sketch candidates compared exactly (default max(EXACT_POOL,
    4 top, rerank)). Clips of other skeletons are compared on the shared bones; clips sharing fewer than
    FEW_SHARED of the query's moving bones are ``partial``: warned about and ranked after all others (their
    distances cover a different, smaller part of the body), and never re-ranked above them; clips sharing
    none are skipped with a warning in ``result.warnings``. Clips below the coverage rule (``rigs.below_minimum``:
    ``RankResult.coverage`` or the share of the arms and legs both rigs have that are compared below
    ``rigs.MIN_COVERAGE``) are skipped with a warning, or with ``allow_partial`` kept as ``partial``; every row
    names its ``unmapped`` joints.
    ``progress(done, total)``: over the library's items while their entries are read (``iter_entries``); a
    cancel ranks the items read so far.
    """
    t0 = time.perf_counter()
    base, lvl = parse_metric(metric, level)
    sig_level = lvl if base == "sim" else DEFAULT_LEVEL
    rerank = max(int(rerank or 0), 0)
    if top is not None:
        top = int(top)
        if top < 1:
            raise ShapeSigError(f"top must be at least 1, got {top}")
    store = cache if cache is not None else SignatureCache()
    before = dict(store.stats)
    items = [it for it in as_items(library) if it.key not in exclude and it.name not in exclude]
    if base == LOCAL:
        results, warnings, skipped, compared = _rank_by_local(query, items, store, rerank or None, progress, depth,
                                                              allow_partial, top)
        store.save_pack()
        if store.warning:
            warnings.insert(0, store.warning)
        stats = {k: store.stats[k] - before.get(k, 0) for k in store.stats}
        stats.update(compared=compared, library=compared, seconds=time.perf_counter() - t0)
        results = results[:top] if top is not None else results
        return RankList(results, warnings, skipped, stats)
    q = _query_entry(query, sig_level, store)
    warnings = []
    pairs = compute_entries(items, sig_level, store, progress, warnings)
    store.save_pack()  # the next process looks the library up in one read
    if store.warning:  # the disk could not be used: one line, however many clips
        warnings.insert(0, store.warning)
    skipped = []

    results = []
    if base == "sim":  # the query's skeleton through the index; other skeletons on their shared bones
        same = [(item, e) for item, e in pairs if e.bones == q.bones]
        npool = pool if pool is not None else max(EXACT_POOL, 4 * (top or 0), rerank)
        results = _rank_same_skeleton(q, same, store, npool, top is not None and len(same) > npool, warnings, skipped,
                                      allow_partial)
    other = [(item, e) for item, e in pairs if base != "sim" or e.bones != q.bones]
    pairwise = _rank_on_shared_bones(q, other, store, base, sig_level, lvl, depth, warnings, skipped, allow_partial)
    compared = sum(not r.approximate for r in results) + len(pairwise)
    results += pairwise
    # Distances over a small part of the body are not comparable with whole-body ones (a clip that shares
    # only the head can look close): clips sharing few of the query's moving bones form a second tier.
    results.sort(key=lambda r: (r.partial, r.distance, r.name))
    if rerank and results:
        _rerank_elastic(results, pairs, q, store, base, rerank, depth)
    if top is not None:
        results = results[:top]
    stats = {k: store.stats[k] - before.get(k, 0) for k in store.stats}
    stats.update(compared=compared, library=len(pairs), seconds=time.perf_counter() - t0)
    return RankList(results, warnings, skipped, stats)
