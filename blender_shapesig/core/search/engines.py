"""The search engines behind one shape. An engine has an ``id`` (its metric name), ``words`` (what a person reads
for it, ``core.measure_words.ENGINES``), ``needs_index``, and three steps: ``indexed(item, store)`` (whether the
store holds the item's entries), ``index(item, store, errors)`` (compute and store them; False when the item could
not be read, one line in ``errors``) and ``rank(query, items, store, *, rerank, top, depth, progress, pool,
allow_partial)`` -> (rows, warnings, skipped, stats). The local search (``local.engine``), the signature search
and every pairwise measure (``signature.engine``) and moments (``moments.engine``) have it; ``rank_clips`` and the
panel's Find Similar drive them through it. See docs/search.md.
"""

from ..metric_names import DEFAULT_LEVEL, DEFAULT_METRIC, LOCAL, parse_metric
from .local.engine import LocalEngine
from .moments.engine import MomentsEngine
from .signature.engine import SignatureEngine

__all__ = ["engine_for", "LocalEngine", "MomentsEngine", "SignatureEngine"]


def engine_for(metric=DEFAULT_METRIC, level=None, *, windows=False, explain=False, errors=None):
    """The engine of a metric name (``metric_names.parse_metric``; ``level`` the signature level, default the
    digits of e.g. ``sim2`` or DEFAULT_LEVEL), or moments with ``windows`` (``explain``, ``errors``: its own)."""
    if windows:
        return MomentsEngine(explain=explain, errors=errors)
    base, lvl = parse_metric(metric, level)
    if base == LOCAL:
        return LocalEngine()
    return SignatureEngine(base, lvl if base == "sim" else DEFAULT_LEVEL, lvl)
