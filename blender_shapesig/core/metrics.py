"""Distances between clips by name: the one place that maps a metric name to the maths.

Names (command line ``--metric``): ``l2`` (d_P*), ``elastic`` (d_S*), ``group`` (rho^n), ``concat``
(sigma_*^n), ``linear`` (sigma_L^n), ``sim`` (sim^n, eq. 9.1). A level may be appended to the
signature names (``group3``, ``sim2``) as in the evaluation tables.

Clips are compared on the bones they share; bones still in both are dropped.
"""

import re

from . import curves, elastic, signatures
from .clip import Clip, restrict_to_shared
from .errors import CurveError, ShapeSigError

__all__ = [
    "METRICS", "SIGNATURE_METRICS", "parse_metric", "metric_label", "clip_distance", "curve_distance",
]

SIGNATURE_METRICS = ("group", "concat", "linear", "sim")
METRICS = ("l2", "elastic") + SIGNATURE_METRICS
DEFAULT_LEVEL = 3
DEFAULT_DEPTH = 9


def parse_metric(name, level=None):
    """Split a metric name like 'sim3' into ('sim', 3); the level argument wins when given."""
    text = str(name).strip().lower()
    if text in METRICS:  # 'l2' is a name, not 'l' at level 2
        base, digits = text, ""
    else:
        m = re.fullmatch(r"([a-z_]+)(\d*)", text)
        base, digits = (m.group(1), m.group(2)) if m else (str(name), "")
    if base not in METRICS:
        raise ShapeSigError(f"unknown metric {name!r}: choose one of {', '.join(METRICS)}")
    if base in SIGNATURE_METRICS:
        lvl = level if level is not None else (int(digits) if digits else DEFAULT_LEVEL)
        if not 1 <= int(lvl) <= 8:
            raise ShapeSigError(f"signature level must be between 1 and 8, got {lvl}")
        return base, int(lvl)
    if digits:
        raise ShapeSigError(f"metric {base!r} takes no level")
    return base, None


def metric_label(name, level=None):
    """The canonical name of a metric with its level: ('sim', 3) or 'sim3' -> 'sim3', 'elastic' -> 'elastic'."""
    base, lvl = parse_metric(name, level)
    return base if lvl is None else f"{base}{lvl}"


def curve_distance(R0, R1, metric, level=None, depth=DEFAULT_DEPTH):
    """Distance between two curves (same joints, same order) by metric name."""
    base, lvl = parse_metric(metric, level)
    if base == "l2":
        return curves.l2_distance(R0, R1)
    if base == "elastic":
        return elastic.elastic_distance(R0, R1, depth=depth)
    fn = {
        "group": signatures.group_distance,
        "concat": signatures.concat_distance,
        "linear": signatures.linear_distance,
        "sim": signatures.normalized_distance,
    }[base]
    return fn(R0, R1, lvl)


def clip_distance(a: Clip, b: Clip, metric="sim", level=None, depth=DEFAULT_DEPTH):
    """Distance between two clips on their shared bones (still-in-both bones dropped)."""
    base, _ = parse_metric(metric, level)
    if base in ("l2", "elastic"):
        for c in (a, b):
            if c.frames < 2:
                raise CurveError(f"clip {c.name!r} has {c.frames} frame; the {base} distance needs at least two frames")
    a2, b2 = restrict_to_shared(a, b)
    return float(curve_distance(a2.rotations, b2.rotations, metric, level=level, depth=depth))
