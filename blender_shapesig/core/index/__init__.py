"""The signature search index: rank a library of clips by the normalized log-signature distance sim^n
(eq. 9.1), optionally re-rank the best by the elastic distance d_S*.

One owner per concept, data flowing one way (words -> entry -> store -> rank):

* ``words``: global Lyndon word codes over a skeleton's letters and the count sketch;
* ``entry``: ``IndexEntry`` (one clip's moving joints, log-signature direction, increments, sketch),
  ``make_entry``, ``entry_distance`` and the increments of two entries on a bone subset;
* ``store``: ``SignatureCache``, a pure store of entries (memory + disk, lazy heavy arrays, memory limit,
  compact mode, format version); it never loads clips nor computes entries;
* ``rank``: ``iter_entries`` (the one index generator: computes what the store lacks and puts it there),
  ``build_index``, ``rank_clips`` -> ``RankList`` of ``RankResult``.
"""

from ..metrics import DEFAULT_LEVEL
from ..io.sources import LibraryItem, clip_key, file_key
from .entry import IndexEntry, entry_distance, make_entry
from .rank import (EXACT_POOL, FEW_SHARED, RankList, RankResult, build_index, clip_items, compute_entries,
                   folder_library, item_entries, iter_entries, rank_clips)
from .store import (CACHE_ENV, CACHE_FORMAT, CACHE_SUBDIR, COMPACT_MAX_DIRECTION, SignatureCache, default_cache_dir,
                    private_cache_dir)
from .words import SKETCH_DIM, sketch, word_codes

__all__ = [
    "DEFAULT_LEVEL", "SKETCH_DIM", "COMPACT_MAX_DIRECTION", "CACHE_FORMAT", "CACHE_ENV", "FEW_SHARED", "EXACT_POOL",
    "RankResult", "RankList", "LibraryItem", "IndexEntry", "SignatureCache",
    "rank_clips", "build_index", "compute_entries", "iter_entries", "item_entries", "clip_key", "file_key",
    "default_cache_dir", "private_cache_dir", "CACHE_SUBDIR", "folder_library", "clip_items", "entry_distance", "make_entry", "word_codes", "sketch",
]
