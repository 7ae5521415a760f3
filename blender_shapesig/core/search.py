"""The signature search under its historical name: a re-export of ``core.index`` (no logic here).

Scripts, the command line, tools and tests written against ``blender_shapesig.core.search`` keep working; new
code imports ``blender_shapesig.core.index``. See that package for the index, the store and the ranking.
"""

from .index import (CACHE_ENV, CACHE_FORMAT, CACHE_SUBDIR, COMPACT_MAX_DIRECTION, DEFAULT_LEVEL, EXACT_POOL,
                    FEW_SHARED, SKETCH_DIM, IndexEntry, LibraryItem, RankList, RankResult, SignatureCache, __all__, build_index,
                    clip_items, clip_key, compute_entries, default_cache_dir, entry_distance, file_key,
                    folder_library, item_entries, iter_entries, make_entry, private_cache_dir, rank_clips, sketch,
                    word_codes)

__all__ = list(__all__)
