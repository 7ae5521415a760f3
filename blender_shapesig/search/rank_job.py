"""One Find Similar click of the panel (Blender layer): ``RankJob`` keys and indexes the members of the search
library one per step (so the operator can show progress and Esc can cancel it), ranks them (the local search, the
signature search or moments) and re-ranks the first rows by d_S* one per step, then stores the rows and the status
line; ``rank_into_settings`` runs a whole click synchronously. The library itself is ``library``'s, the rows
``result_rows``'. See docs/dev/blender_layer.md.
"""

import time

from ..actions import frame_rates
from ..rigs import rigmap
from . import library, thumbnails
from ..core import search as index
from ..core.search.engines import engine_for
from ..core.search.local.features import settings_key as local_settings_key
from ..core.errors import ShapeSigError
from ..properties import column_word, index_level, results_of, uses_local
from .result_rows import ELASTIC_COLUMN, SIM_COLUMN, store_results

__all__ = ["RankJob", "rank_into_settings"]


class RankJob:
    """One Find Similar click in small steps, so that the UI can show progress and Esc can cancel it (the
    operator steps it from a timer; headless it runs the steps in a loop):

    1. key each member (``SearchLibrary.members``: a folder file is hashed at its turn, never before the
       progress bar) and index it when the store does not hold it, one clip per step (the engine's ``indexed`` and
       ``index``, ``core.search.engines``, as the command line's rank;
       what is done stays cached when the click is cancelled; clips that fail are counted apart, files that
       are not regular files or are over a cap were skipped unopened and are reported once);
    2. rank every readable clip (``rank_clips`` with that engine; fast: everything is in the store): by the local
       search (Similarity: Motion and pose, the default: its own second stage included), moments, else by sim^n;
    3. sim^n with Re-rank K, the d_S* of the first K rows, one per step (``rank_clips`` with the elastic metric on
       the one clip: the same pair increments and DP as its re-rank).

    The rows are then in the order of ONE column: sim^n, or d_S* when re-ranking (the K re-ranked rows, then
    the next by sim^n up to Show; the message says how many more were ranked). Whole-body matches come before partial ones
    (few shared bones), each tier ascending in that column. ``seconds`` is the whole click, from the start."""

    def __init__(self, context, settings, started=None):
        self.t0 = time.perf_counter() if started is None else started
        self.settings = settings
        self.lib = library.search_library(context, settings)  # no clip file read or hashed yet
        self.action, self.query = self.lib.action, self.lib.query
        self.query_name = self.action.name  # the action may be removed while the click runs
        if self.lib.size < 2:  # the query alone
            raise ShapeSigError("the library is empty: no other action animates this armature"
                                + (" or matches the filter" if settings.name_filter else "")
                                + ("" if settings.use_folders else "; add folders of clips")
                                + self.lib.skipped_text())
        self.cache, self.level, self.local = library.get_cache(context), index_level(settings), uses_local(settings)
        self.rerank, self.top = (0 if self.local else max(int(settings.rerank), 0)), max(int(settings.top), 0)
        self.items = []  # the library's members as they are keyed (without the query)
        self.errors, self.failed, self.indexed = [], set(), 0
        # the engine the command line's rank would use (``core.search.engines``): moments, the local search or sim^n
        self.engine = engine_for("local" if self.local else "sim", None if self.local else self.level,
                                 windows=settings.use_windows, explain=True, errors=self.errors)
        self._members = self.lib.members()
        self.total = self.lib.size + 1 + self.rerank
        self.done = 0
        self.ranked = self.rows = None
        self._head = []

    @property
    def skipped(self):
        """The files left out unread (not regular files, unreadable, over a cap): one-line errors."""
        return self.lib.skipped

    @property
    def progress(self) -> float:
        return min(self.done / max(self.total, 1), 1.0)

    @property
    def finished(self) -> bool:
        return self.rows is not None

    def step(self) -> bool:
        """Do one step; True when the rows are ready."""
        self.done += 1
        if self.ranked is None:
            item = next(self._members, StopIteration)
            if item is StopIteration:
                self._rank()
                return self.finished
            if item is not None:
                self._index(item)
            return False
        self._elastic(self._head.pop(0))
        if not self._head:
            self._order()
        return self.finished

    def _index(self, item):
        """One member (keyed by ``SearchLibrary.members``): indexed when the store lacks it (moments read the
        clips themselves, ``core.search.moments.windows``); what is done stays cached when the click is cancelled."""
        if item is not self.query:
            self.items.append(item)
        # each engine indexes its own entries only (the local search: a clip its features refuse gets its signature
        # entries when ranked), as the command line's rank: one check in memory instead of a file check per click
        if self.engine.indexed(item, self.cache):
            return
        if self.engine.index(item, self.cache, self.errors):
            self.indexed += 1
        else:
            self.failed.add(item.key)

    def run(self):
        """All steps (the synchronous path); returns the rows."""
        while not self.step():
            pass
        return self.rows

    def _rank(self):
        if self.query.key in self.failed:
            raise ShapeSigError(f"the query {self.query.name!r} could not be read: {self.errors[0]}")
        items = [it for it in self.items if it.key not in self.failed]
        if not items:
            reasons = [str(e) for e in self.errors + self.skipped]
            raise ShapeSigError(f"no library clip could be read ({reasons[0] if reasons else 'none found'})"
                                + self.lib.skipped_text())
        windows, cut, pool = self.settings.use_windows, None, None
        if not windows and not self.local:  # sim^n: Timing Check re-ranks the first rows one per step
            cut = min(self.rerank, self.top or self.rerank) if self.rerank else (self.top or None)
            pool = max(index.EXACT_POOL, 4 * max(cut or 0, self.top))
        # moments refine their first rows inside (explained); the local search's second stage runs inside
        self.ranked = index.rank_clips(self.query, items, engine=self.engine, rerank=self.rerank if windows else 0,
                                       top=self.top or None, cache=self.cache, depth=self.settings.depth, pool=pool)
        self.warnings = self.errors + self.ranked.warnings
        # clips (a .blend item may hold several)
        self.compared = self.ranked.stats.get("compared" if windows else "library", len(items))
        self._head = list(self.ranked[:cut]) if self.rerank and cut is not None else []
        self.total = self.done + len(self._head)
        if not self._head:
            self._order()

    def _elastic(self, r):
        """d_S* of one row: rank_clips' elastic metric on that one clip (shared bones, the same depth)."""
        one = index.rank_clips(self.query, [r.item], metric="elastic", cache=self.cache,
                               depth=self.settings.depth)
        r.elastic = next((x.distance for x in one if x.name == r.name), float("nan"))

    def _order(self):
        if self.settings.use_windows:  # moments come in their search's order (stats: by pose and motion, or d_S*)
            self.rows = list(self.ranked)
            self.order_by = self.ranked.stats.get("order_by", "elastic" if self.rerank else "sim")
        elif self.rerank:
            head = [r for r in self.ranked if r.elastic is not None]
            rest = [r for r in self.ranked if r.elastic is None][:max((self.top or len(self.ranked)) - len(head), 0)]
            self.rows = sorted(head, key=lambda r: (r.partial, r.elastic, r.distance, r.name)) + rest  # then by sim
            self.order_by = "elastic"
        else:
            self.rows, self.order_by = list(self.ranked), ("local" if self.local else "sim")
        self.not_listed = max(self.compared - len(self.rows) - len(self.ranked.skipped), 0)
        self.seconds = time.perf_counter() - self.t0

    def _query_bones(self) -> int:
        """The query's bone count from its stored entry (the ranking just stored it), read again only without one."""
        if self.local:
            got = self.cache.local.get(self.query.key, local_settings_key())
            if got and not got[0].refused:
                return int(got[0].bones)
        else:
            got = self.cache.get(self.query.key, self.level)
            if got:
                return len(got[0].bones)
        return len(self.query.clips()[0].bones)

    def store(self):
        """Write the rows and the status message; returns the message."""
        column = self.order_by  # "sim", "elastic" or "local": the measure's key (core.measure_words)
        store_results(self.settings, self.rows, self.query_name, column, self._query_bones(),
                      time.perf_counter() - self.t0)
        thumbnails.start_job(self.cache, self.rows, self.query, self.query_name)  # in the background
        out = results_of()
        msg = (f"{len(self.rows)} results from {self.compared} clips, sorted by {column_word(column)}; "
               f"{self.indexed} newly indexed")
        if self.failed:
            msg += f", {len(self.failed)} could not be read"
        msg += self.lib.skipped_text()
        msg += f"; {out.seconds:.2f} s"
        if self.rerank and self.order_by == ELASTIC_COLUMN:
            msg += (f"; the best {sum(r.elastic is not None for r in self.rows)} by {column_word(SIM_COLUMN)} "
                    f"re-ranked by {column_word(ELASTIC_COLUMN)}")
        if self.not_listed:
            msg += f"; {self.not_listed} more not listed (raise Show)"
        # Auto-Pick: saved maps of the maps folder that could not be read were skipped (one line each)
        self.warnings = (self.warnings + rigmap.skipped_maps(rigmap.maps_folder(auto_only=True))
                         + frame_rates.library_notes(self.lib))
        if self.warnings:
            msg += f"; {len(self.warnings)} warning(s): {self.warnings[0]}"
        out.message = msg
        return msg


def rank_into_settings(context, settings) -> index.RankList:
    """Run a whole Find Similar click synchronously and store its rows; returns them as a RankList."""
    job = RankJob(context, settings)
    job.run()
    job.store()
    return index.RankList(job.rows, job.warnings, job.ranked.skipped, dict(job.ranked.stats, seconds=job.seconds))
