"""The local search as an engine (``LocalEngine``, the ``core.search.engines`` shape; the default, "Motion and
pose"): the readable clips by ``local.rank.rank_local`` (both stages), the clips its features refuse (no legs)
after them by sim3 on their shared bones, with one warning. See docs/search.md.
"""

from ...measure_words import ENGINES
from ...metric_names import DEFAULT_LEVEL, LOCAL
from ...rigs import coverage_from
from ..indexing import compute_entries
from ..rows import RankResult, coverage_rule
from ..signature.engine import query_entry, rank_on_shared_bones
from .features import SHORTLIST
from .rank import local_entries, query_local_entry, rank_local

__all__ = ["LocalEngine"]


def _rank_by_local(query, items, store, shortlist, progress, depth, allow_partial, top=None):
    """(results, warnings, skipped, compared) of the local search: the readable clips by ``local.rank.rank_local``;
    the clips its features refuse after them, by sim3 on their shared bones, with one warning."""
    q = query_local_entry(query, store)
    warnings, skipped = [], []
    got = local_entries(items, store, progress, warnings)
    ok = [(item, e) for item, e in got if not e.refused]
    refused = [(item, e) for item, e in got if e.refused]
    full, part = [], []
    ranked = rank_local(q, ok, store, shortlist or SHORTLIST)
    for i, score, d1, d2 in ranked:
        if top is not None and len(full) >= top:  # rows only for what is kept
            break
        item, e = ok[i]
        # the body is compared whole: every canonical joint both clips have (their rigs' other joints unmapped)
        got = coverage_from(q.joints, q.still, q.rig_joints, e.joints, e.still, e.rig_joints)
        low = coverage_rule(e.name, got, allow_partial, warnings, skipped)
        if low is None:
            continue
        (part if low else full).append(RankResult(
            name=e.name, distance=score, frames=e.frames, key=item.key, source=item.source,
            trimmed=tuple(e.trimmed), metric=LOCAL, first_stage=d1, dtw=d2, partial=low,
            shared=min(q.bones, e.bones), coverage=float(got["coverage"]),
            unmapped=tuple(got["unmapped"]), item=item))
    results = full + part
    if refused:
        warnings.append(f"{len(refused)} clip(s) the local search cannot read ({refused[0][1].name}: "
                        f"{refused[0][1].refused}) are ranked after the others by {ENGINES['sim'].status}")
    if refused and (top is None or len(results) < top):  # their rows only when they can be kept
        qs = query_entry(query, DEFAULT_LEVEL, store)
        names = {(item.key, e.name) for item, e in refused}
        refused_items = list({item.key: item for item, _ in refused}.values())
        pairs = [(item, e) for item, e in compute_entries(refused_items, DEFAULT_LEVEL, store, None, warnings)
                 if (item.key, e.name) in names]
        tail = rank_on_shared_bones(qs, pairs, store, "sim", DEFAULT_LEVEL, DEFAULT_LEVEL, depth, warnings, skipped,
                                     allow_partial)
        tail.sort(key=lambda r: (r.partial, r.distance, r.name))
        for r in tail:
            r.metric = f"sim{DEFAULT_LEVEL}"
        results += tail
    return results, warnings, skipped, len(ranked) + len(refused)


class LocalEngine:
    """The local search; its entries live in the store beside the signature entries (``store.local.contains``)."""

    id = LOCAL
    needs_index = True

    @property
    def words(self):
        return ENGINES["local"]

    def indexed(self, item, store) -> bool:
        return store.local.contains(item.key)

    def index(self, item, store, errors) -> bool:
        """Index one item when the store lacks it; False when it could not be read (one line in ``errors``)."""
        return bool(local_entries([item], store, errors=errors))

    def rank(self, query, items, store, *, rerank=0, top=None, depth, progress=None, pool=None,
             allow_partial=True):
        """(rows, warnings, skipped, stats): ``rank_clips``' contract; ``rerank`` sets the shortlist."""
        shortlist = max(int(rerank or 0), 0) or None
        results, warnings, skipped, compared = _rank_by_local(query, items, store, shortlist, progress, depth,
                                                              allow_partial, top)
        return results, warnings, skipped, {"compared": compared, "library": compared}
