"""The local search (``core.search.local.features``) over a library, through the signature cache: every item's local entries
(computed from its comparison-space clips only when the store lacks them; clips the features refuse are kept as
their one-line reason), the query's entry, and the ranking: the first stage over the library's stacked windows
(memoized in the store), the first ``shortlist`` re-scored by ``local.shortlist_scores`` (both stages; the same
take in another file first). ``rank.rank_clips`` turns it into rows (docs/search.md, "The default search").
"""

from collections.abc import Sequence
from typing import List, Optional, Tuple, Union

import numpy as np

from ...clip.clip import Clip
from ...clip.trim import trim_record
from ...errors import ShapeSigError, error_line
from ...measure_words import ENGINES, OPTIONS
from ...io.sources import LibraryItem, as_items, clip_item
from ...progress import wants_cancel
from . import features as local
from .entry import LocalEntry, Refusal
from ..store import SignatureCache

__all__ = ["item_local_entries", "local_entries", "query_local_entry", "cached_query_entry", "rank_local",
           "RankedRows"]


def _entry(clip: Clip, settings) -> Union[LocalEntry, Refusal]:
    try:
        if clip.frames < 2:
            raise ShapeSigError(f"clip {clip.name!r} has {clip.frames} frame; at least two are needed")
        e = local.index_entry(clip, settings)
    except ShapeSigError as exc:
        return Refusal(clip.name, error_line(exc))
    e.frames, e.trimmed, e.bones = int(clip.frames), tuple(int(f) for f in trim_record(clip)), len(clip.bones)
    e.first = int(clip.frame_start)
    e.joints, e.still, e.rig_joints = tuple(clip.bones), tuple(clip.still_bones()), tuple(
        clip.meta.get("rig_joints") or ())
    return e


def item_local_entries(item: LibraryItem, store: SignatureCache, settings=local.DEFAULT, skey=None
                       ) -> List[Union[LocalEntry, Refusal]]:
    """The item's local entries, one per clip: from the store, else computed from its clips (read only then).
    ``skey``: ``local.settings_key(settings)`` when the caller has it (a library's loop)."""
    skey = skey or local.settings_key(settings)
    got = store.local.get(item.key, skey)
    if got is None:
        got = [_entry(c, settings) for c in item.clips()]
        store.local.put(item.key, skey, got)
    return got


def local_entries(items, store: SignatureCache, progress=None, errors=None, settings=local.DEFAULT):
    """[(item, entry)] for every clip of every item (``indexing.iter_entries``' contract for ``progress`` and
    ``errors``: an item that cannot be read is one line in ``errors`` and yields nothing)."""
    items, skey = as_items(items), local.settings_key(settings)
    out = []
    for i, item in enumerate(items):
        if wants_cancel(progress, i, len(items)):
            return out
        try:
            out += [(item, e) for e in item_local_entries(item, store, settings, skey)]
        except ShapeSigError as exc:
            if errors is None:
                raise
            errors.append(f"{item.name}: {exc}")
    wants_cancel(progress, len(items), len(items))
    return out


def query_local_entry(query, store: SignatureCache, settings=local.DEFAULT) -> LocalEntry:
    """The query's local entry (a Clip or a LibraryItem of one clip); a query the local features refuse is refused
    in one line that names the signature search instead."""
    item = clip_item(query) if isinstance(query, Clip) else query
    if not isinstance(item, LibraryItem):
        raise ShapeSigError(f"the query must be a Clip, got {type(query).__name__}")
    got = item_local_entries(item, store, settings)
    if len(got) != 1:
        raise ShapeSigError(f"query {item.name!r} holds {len(got)} clips; choose one")
    if got[0].refused:
        raise ShapeSigError(f"the local search cannot read the query ({got[0].refused}); "
                            f"rank it by {ENGINES['sim'].status} instead (in the panel, {OPTIONS['similarity'].label}: "
                            f"{ENGINES['sim'].label}; on the command line, a signature metric)")
    return got[0]


def cached_query_entry(item: LibraryItem, store: SignatureCache, settings=local.DEFAULT) -> Optional[LocalEntry]:
    """The query item's one local entry when the store holds it, reading nothing else (None otherwise, also for
    a refused clip or an entry older than its ``first`` frame): what a ranking and its report need of the query."""
    got = store.local.get(item.key, local.settings_key(settings))
    if got is None or len(got) != 1 or got[0].refused or got[0].first is None:
        return None
    return got[0]


class RankedRows(Sequence):
    """``rank_local``'s rows, built when read: (index into the pairs, score, first-stage distance, DTW distance or
    None), best first. The shortlist's rows are made at once; a row after it only when it is read (a panel keeping
    the first ten of 100,000 clips reads a few dozen)."""

    def __init__(self, head_rows, d1, worst, m1, mix):
        self._head, self._d1, self._rest = head_rows, d1, None
        self._worst, self._m1, self._mix = worst, m1, mix

    def __len__(self):
        return len(self._d1)

    def _order(self):
        """The rows after the shortlist in the first stage's order (sorted at the first read of one)."""
        if self._rest is None:
            order = np.argsort(self._d1, kind="stable")
            self._rest = order[~np.isin(order, [i for i, *_ in self._head])]
        return self._rest

    def __getitem__(self, k):
        if isinstance(k, slice):
            return [self[i] for i in range(*k.indices(len(self)))]
        if k < 0:
            k += len(self)
        if not 0 <= k < len(self):
            raise IndexError(k)
        if k < len(self._head):
            return self._head[k]
        i = int(self._order()[k - len(self._head)])
        d = float(self._d1[i])
        return i, max(self._worst, (1.0 + self._mix) * d / self._m1), d, None


def rank_local(q: LocalEntry, pairs, store: SignatureCache, shortlist=local.SHORTLIST, mix=local.MIX
               ) -> Sequence[Tuple[int, float, float, object]]:
    """[(index into ``pairs``, score, first-stage distance, DTW distance or None)], best first, for every pair
    (item, entry) of readable entries (a ``RankedRows``: rows after the shortlist are made when read). The
    shortlist (``local.shortlisted``: the first stage's nearest, and for a striking query the nearest by the arms)
    is scored by ``local.shortlist_scores`` (d2 / mean d2 + mix d1 / mean d1 over the shortlist, the query's
    twin in another file first); a clip after it
    scores max(the shortlist's worst, (1 + mix) d1 / mean d1): its first stage stands for both terms, and the order
    stays the first stage's."""
    if not pairs:
        return []
    entries = [e for _, e in pairs]
    block = store.local.stack(entries)
    d1 = local.first_stage(q, block, keep=local.PREFILTER)
    head = local.shortlisted(q, entries, d1, shortlist, block.get("descriptions"))  # the rest: sorted when read
    score, d2 = local.shortlist_scores(q, [entries[i] for i in head], d1[head], mix)
    m1 = max(float(np.mean(d1[head])), 1e-12)
    by = np.argsort(score, kind="stable")
    rows = [(int(head[k]), float(score[k]), float(d1[head[k]]), float(d2[k])) for k in by]
    return RankedRows(rows, d1, float(score.max()), m1, mix)
