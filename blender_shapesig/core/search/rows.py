"""What every engine's ranking returns: ``RankResult`` (one row), ``RankList`` (the rows, best first, with warnings,
skipped clips and stats) and the coverage rule every engine applies to a row (``coverage_rule``). See
docs/search.md.
"""

from dataclasses import dataclass, field
from typing import Optional, Tuple

from ..clip.trim import trimmed_range
from ..io.text import json_float
from ..rigs import below_minimum

__all__ = ["FEW_SHARED", "RankResult", "RankList", "coverage_rule"]

# Warn when the shared bones cover less than this fraction of the query's moving bones.
FEW_SHARED = 0.5


@dataclass
class RankResult:
    """One ranked clip. ``distance``: sim^n (or the chosen metric); ``elastic``: d_S* when re-ranked,
    else None; ``frames``: the clip's frame count; ``key``: its library item's key; ``shared``: bones
    compared; ``approximate``: True when ``distance`` is a sketch estimate (only with a compact store);
    ``partial``: the clip shares fewer than FEW_SHARED of the query's moving bones, or (kept by ``allow_partial``)
    is below the coverage rule (``rigs.below_minimum``): ranked after the others; ``unmapped``: the canonical
    joints both rigs have that are not compared; ``item``: the library item the row came from (its path, its action,
    how to read it again), set by every engine (not part of the JSON row)."""

    name: str
    distance: float
    elastic: Optional[float] = None
    frames: int = 0
    key: str = ""
    source: str = ""
    shared: int = 0
    approximate: bool = False
    partial: bool = False
    coverage: float = 1.0  # joints compared / canonical joints both rigs have (core.rigs.coverage_from)
    unmapped: Tuple[str, ...] = ()  # canonical joints both rigs have that are not compared
    start: Optional[int] = None  # a moment (``windows.rank_windows``): its frames in the clip's own numbers
    end: Optional[int] = None
    explain: Optional[dict] = None  # ``core.elastic.explain``: per-joint shares, cost over time
    trimmed: Tuple[int, ...] = ()  # (first kept, last kept, first read, last read) when trimming cut frames
    metric: str = ""  # the measure of ``distance`` ("local", "sim3", ...: a local ranking ranks some clips by sim3)
    first_stage: Optional[float] = None  # the local search: the first stage's distance of the clip
    dtw: Optional[float] = None  # the local search: the second stage's DTW distance (the shortlist only)
    item: Optional[object] = field(default=None, repr=False, compare=False)  # the LibraryItem the row came from

    def as_dict(self, **where):
        """The row as the command line's JSON writes it: ``where`` (e.g. its ``path`` and ``action``) after
        ``elastic``; ``trim`` / ``trimmed`` the frames compared and cut (``clip.trim.trimmed_range``); a moment's
        ``start`` / ``end``; the local search's measure and stages. Non-finite numbers are null."""
        trim = trimmed_range(self.trimmed)
        out = {"clip": self.name, "distance": json_float(self.distance), "elastic": json_float(self.elastic), **where,
               "coverage": self.coverage, "unmapped": list(self.unmapped), "partial": bool(self.partial),
               "trim": trim["frames"], "trimmed": trim["cut"]}
        if self.start is not None:
            out.update(start=self.start, end=self.end)
        if self.metric:  # the local search: the measure of the row (sim3 for clips it cannot read) and both stages
            out.update(metric=self.metric, first_stage=json_float(self.first_stage), dtw=json_float(self.dtw))
        return out


class RankList(list):
    """``rank_clips``' result: a list of RankResult, best first, plus ``warnings`` (one-line strings),
    ``skipped`` (names of clips that share no bone with the query) and ``stats`` (cache hits and
    misses of this call, clips compared exactly, seconds)."""

    def __init__(self, items=(), warnings=(), skipped=(), stats=None):
        super().__init__(items)
        self.warnings = list(warnings)
        self.skipped = list(skipped)
        self.stats = dict(stats or {})


def coverage_rule(name, got, allow_partial, warnings, skipped):
    """The coverage rule for one row (``rigs.below_minimum``): None when it is refused (one warning; without
    ``allow_partial``), else whether the row is partial because of it."""
    why = below_minimum(got)
    if not why:
        return False
    if not allow_partial:
        skipped.append(name)
        missing = ", ".join(got["unmapped"][:6]) + (", ..." if len(got["unmapped"]) > 6 else "")
        warnings.append(f"{name}: {why}" + (f" (unmapped: {missing})" if missing else "")
                        + "; skipped (allow partial matches to rank it)")
        return None
    return True

