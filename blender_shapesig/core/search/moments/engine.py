"""Moments as an engine (``MomentsEngine``, the ``core.search.engines`` shape): every window of a take that
matches the query (``windows.rank_windows``); it reads the clips themselves, so it needs no index."""

from ...elastic import DEFAULT_DEPTH
from ...measure_words import ENGINES
from .windows import WINDOW_LEVEL, rank_windows

__all__ = ["MomentsEngine"]


class MomentsEngine:
    """Moments at signature level ``level`` for clips the pose features cannot read (``WINDOW_LEVEL``)."""

    id = "moments"
    needs_index = False

    @property
    def words(self):
        return ENGINES["moments"]

    def __init__(self, level=WINDOW_LEVEL, explain=False, errors=None):
        """``explain``: refined moments get their explanation; ``errors``: a list that gets one line per clip
        that could not be read (else the error is raised)."""
        self.level, self.explain, self.errors = int(level), bool(explain), errors

    def indexed(self, item, store) -> bool:
        return True  # nothing to index: the windows are found in the clips themselves

    def index(self, item, store, errors) -> bool:
        return True

    def rank(self, query, items, store, *, rerank=None, top=None, depth=DEFAULT_DEPTH, progress=None, pool=None,
             allow_partial=True):
        """(rows, warnings, skipped, stats): ``rank_windows``' moments; ``rerank``: moments refined (default
        ``windows.REFINE``)."""
        got = rank_windows(query, items, self.level, rerank, top, depth=depth, explain=self.explain,
                           progress=progress, allow_partial=allow_partial, errors=self.errors)
        return list(got), got.warnings, got.skipped, got.stats
