"""Indexing a library, every engine's entries through one loop: ``iter_entries`` yields each item's signature
entries (``signature.index.item_entries``) and, with ``local``, stores its local-search entries
(``local.rank.item_local_entries``) from the same read; ``compute_entries`` and ``build_index`` run it. Library
members, keys and clip files are owned by ``core.io.sources``; ``clip_items`` and ``folder_library`` make them.
See docs/search.md, "The index and its cache".
"""

import dataclasses
import time
from typing import List, Sequence

from ..clip.clip import Clip
from ..errors import ShapeSigError
from ..io.sources import LibraryItem, as_items, clip_item, library
from ..metric_names import DEFAULT_LEVEL
from ..progress import wants_cancel
from .local.rank import item_local_entries
from .signature.index import item_entries
from .store import SignatureCache

__all__ = ["clip_items", "folder_library", "iter_entries", "compute_entries", "build_index"]


def clip_items(clips: Sequence[Clip]) -> List[LibraryItem]:
    """Library items for clips already in memory, keyed by their data."""
    return [clip_item(c) for c in clips]


def folder_library(paths, load=None, asf=None, start=None, recursive=True, end=None) -> List[LibraryItem]:
    """Library items for clip files given directly or found in folders (``sources.library``); ``load(spec)``
    reads one ClipSpec (default: the reader registry)."""
    return library(paths, recursive, load=load, asf=asf, start=start, end=end)


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


