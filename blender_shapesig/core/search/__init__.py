"""The search: engines behind one shape (``engines``: the local search ``local/``, the default; the signature
search ``signature/``; moments ``moments/``), what they return (``rows``), the index loop (``indexing``), the store
(``store``, ``cache_folder``), the front door ``rank.rank_clips``; ``dedupe`` and ``thumbnails`` build on them. See
docs/search.md.
"""

from ..metric_names import DEFAULT_LEVEL
from ..io.sources import LibraryItem, clip_key, file_key
from .signature.entry import IndexEntry, entry_distance, make_entry
from .indexing import build_index, clip_items, compute_entries, folder_library, iter_entries
from .rank import rank_clips
from .rows import FEW_SHARED, RankList, RankResult
from .signature.engine import EXACT_POOL
from .signature.index import item_entries
from .cache_folder import CACHE_ENV, CACHE_SUBDIR, default_cache_dir, private_cache_dir
from .store import CACHE_FORMAT, COMPACT_MAX_DIRECTION, SignatureCache
from .signature.words import SKETCH_DIM, sketch, word_codes

__all__ = [
    "DEFAULT_LEVEL", "SKETCH_DIM", "COMPACT_MAX_DIRECTION", "CACHE_FORMAT", "CACHE_ENV", "FEW_SHARED", "EXACT_POOL",
    "RankResult", "RankList", "LibraryItem", "IndexEntry", "SignatureCache",
    "rank_clips", "build_index", "compute_entries", "iter_entries", "item_entries", "clip_key", "file_key",
    "default_cache_dir", "private_cache_dir", "CACHE_SUBDIR", "folder_library", "clip_items", "entry_distance", "make_entry", "word_codes", "sketch",
]
