"""Ranking a library against a query, the front door of every engine: ``rank_clips`` (-> ``RankList`` of
``RankResult``, ``rows``) checks its arguments, picks the engine of the metric (``engines.engine_for``: by default
the local search, else the signature search or a pairwise measure), runs it through the store and adds the store's
warning and the call's stats. Indexing is ``indexing``'s. See docs/search.md.
"""

import time

from ..blas import one_blas_thread
from ..elastic import DEFAULT_DEPTH
from ..errors import ShapeSigError
from ..io.sources import as_items
from ..metric_names import DEFAULT_METRIC
from .engines import engine_for
from .rows import RankList
from .store import SignatureCache

__all__ = ["rank_clips"]


@one_blas_thread()
def rank_clips(query, library, metric=DEFAULT_METRIC, level=None, rerank=0, top=None, cache=None, *,
               depth=DEFAULT_DEPTH, progress=None, exclude=(), pool=None, allow_partial=True, engine=None) -> RankList:
    """Rank ``library`` (Clips or LibraryItems) by their distance to ``query`` (a Clip), best first.

    ``metric``: ``local`` (the default: the local search, ``local.engine``; ``rerank=K`` sets its shortlist,
    default ``local.features.SHORTLIST``; ``distance`` is the final score, ``first_stage``/``dtw`` its two stages; clips
    the local features cannot read, e.g. without legs, come after the others by sim3 with a warning, and such a
    query is refused in one line), ``sim`` (sim^n, through the index) or any name of ``metric_names.parse_metric``
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
    cancel ranks the items read so far. ``engine``: an engine of ``engines`` (e.g. moments) instead of ``metric``
    and ``level``.
    """
    t0 = time.perf_counter()
    engine = engine if engine is not None else engine_for(metric, level)
    if top is not None:
        top = int(top)
        if top < 1:
            raise ShapeSigError(f"top must be at least 1, got {top}")
    store = cache if cache is not None else SignatureCache()
    before = dict(store.stats)
    items = [it for it in as_items(library) if it.key not in exclude and it.name not in exclude]
    results, warnings, skipped, counts = engine.rank(query, items, store, rerank=rerank, top=top, depth=depth,
                                                     progress=progress, pool=pool, allow_partial=allow_partial)
    store.save_pack()  # the next process looks the library up in one read
    if store.warning:  # the disk could not be used: one line, however many clips
        warnings.insert(0, store.warning)
    if top is not None:
        results = results[:top]
    stats = {k: store.stats[k] - before.get(k, 0) for k in store.stats}
    stats.update(counts, seconds=time.perf_counter() - t0)
    return RankList(results, warnings, skipped, stats)
