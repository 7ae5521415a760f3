"""Distances between clips by name, the facade the command line, the Blender layer and scripts use: the metric
grammar and defaults (``metric_names``), the distances (``distances``) and the one dispatch that also reaches the
local search's engine (``clip_distance``, ``compare_clips`` with ``local``). Nothing in ``core`` imports this
module (the owners are imported instead), so it can import every engine. See docs/dev/metrics.md.
"""

from . import distances
from .clip.clip import Clip
from .distances import check_coverage, curve_distance
from .elastic import DEFAULT_DEPTH
from .metric_names import (ALL_METRICS, DEFAULT_LEVEL, DEFAULT_METRIC, LOCAL, MAX_LEVEL, METRICS,
                           SIGNATURE_METRICS, SMOOTHED_METRICS, MetricSpec, metric_label, parse_metric,
                           parse_metric_spec, time_base_smoothing)

__all__ = [
    "METRICS", "SIGNATURE_METRICS", "SMOOTHED_METRICS", "time_base_smoothing", "DEFAULT_LEVEL", "DEFAULT_DEPTH", "MAX_LEVEL", "MetricSpec",
    "parse_metric_spec", "parse_metric", "metric_label", "clip_distance", "curve_distance",
    "check_coverage", "compare_clips", "LOCAL", "DEFAULT_METRIC", "ALL_METRICS",
]


def clip_distance(a: Clip, b: Clip, metric="sim", level=None, depth=DEFAULT_DEPTH, time_base=True):
    """Distance between two clips (``distances.clip_distance``); ``local``: the local search's first stage
    between the two (its second stage ranks a shortlist of a library)."""
    if parse_metric(metric, level)[0] == LOCAL:
        from .search.local import features as local

        return float(local.first_stage(local.index_entry(a), [local.index_entry(b)])[0])
    return distances.clip_distance(a, b, metric, level, depth, time_base)


def compare_clips(a: Clip, b: Clip, metric="sim", level=None, depth=DEFAULT_DEPTH, allow_partial=False,
                  time_base=True) -> dict:
    """``{"distance", "bones", "coverage", "unmapped"}`` of two clips: ``clip_distance`` after ``check_coverage``."""
    got = check_coverage(a, b, allow_partial, report=True)
    return {"distance": clip_distance(a, b, metric, level, depth, time_base), "bones": got["bones"],
            "coverage": got["coverage"], "unmapped": got["unmapped"]}
