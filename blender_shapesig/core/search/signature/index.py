"""The signature search's index of one item: its ``IndexEntry`` list from the store, else computed from its clips
and stored (``item_entries``), and an entry's arrays brought back when the store dropped them (``loaded``). See
docs/search.md, "The index and its cache".
"""

from typing import List, Optional

from ...blas import one_blas_thread
from ...errors import ShapeSigError
from ...io.sources import LibraryItem
from ..store import SignatureCache
from .entry import IndexEntry, make_entry

__all__ = ["item_entries", "loaded"]


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


def loaded(entry: IndexEntry, item: Optional[LibraryItem], store: SignatureCache) -> IndexEntry:
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


