"""The signature search index: rank a library of clips by sim^n (eq. 9.1) and optionally re-rank the best by d_S*.
Data flows one way, ``words`` (word codes, sketch) -> ``entry`` (``IndexEntry``) -> ``store`` (``SignatureCache``)
-> ``rank`` (``iter_entries``, ``build_index``, ``rank_clips``); ``windows`` and ``dedupe`` build on them.
See docs/search.md.
"""

from ..metric_names import DEFAULT_LEVEL
from ..io.sources import LibraryItem, clip_key, file_key
from .entry import IndexEntry, entry_distance, make_entry
from .rank import (EXACT_POOL, FEW_SHARED, RankList, RankResult, build_index, clip_items, compute_entries,
                   folder_library, item_entries, iter_entries, rank_clips)
from .cache_folder import CACHE_ENV, CACHE_SUBDIR, default_cache_dir, private_cache_dir
from .store import CACHE_FORMAT, COMPACT_MAX_DIRECTION, SignatureCache
from .words import SKETCH_DIM, sketch, word_codes

__all__ = [
    "DEFAULT_LEVEL", "SKETCH_DIM", "COMPACT_MAX_DIRECTION", "CACHE_FORMAT", "CACHE_ENV", "FEW_SHARED", "EXACT_POOL",
    "RankResult", "RankList", "LibraryItem", "IndexEntry", "SignatureCache",
    "rank_clips", "build_index", "compute_entries", "iter_entries", "item_entries", "clip_key", "file_key",
    "default_cache_dir", "private_cache_dir", "CACHE_SUBDIR", "folder_library", "clip_items", "entry_distance", "make_entry", "word_codes", "sketch",
]
