"""Metric names: the one grammar (``parse_metric_spec``: ``BASE[LEVEL][_OPTION...][+elasticK]``, e.g. ``sim3``,
``elastic``, ``sim3_tensor_levelnorm``), the named measures and defaults (``DEFAULT_LEVEL``, ``DEFAULT_METRIC``)
and each measure's time base (``time_base_smoothing``). Names only: the maths are in ``distances`` and the engines;
``metrics`` is the facade the command line and the Blender layer use. See docs/dev/metrics.md.
"""

import re
from dataclasses import dataclass
from typing import Optional

from .errors import ShapeSigError

__all__ = [
    "METRICS", "SIGNATURE_METRICS", "SMOOTHED_METRICS", "time_base_smoothing", "DEFAULT_LEVEL", "MAX_LEVEL",
    "MetricSpec", "parse_metric_spec", "parse_metric", "metric_label", "LOCAL", "DEFAULT_METRIC", "ALL_METRICS",
]

SIGNATURE_METRICS = ("group", "concat", "linear", "sim")
# The local, pose-aware search (``core.search.local.features``): windows of key-point positions by log-signatures, then a
# DTW re-rank of a shortlist; the default of ``rank`` and of Find Similar (docs/model.md). Between two clips alone
# (``clip_distance``) it is the first stage's distance: the combined score needs a library.
LOCAL = "local"
DEFAULT_METRIC = LOCAL
METRICS = ("l2", "elastic") + SIGNATURE_METRICS  # the measures between curves
ALL_METRICS = (LOCAL,) + METRICS
# Every measure compares clips on one time base (``prepare.prepare_clip``: sampled at ``prepare.COMPARE_FPS`` over
# their durations in seconds). The SRVT measures also low-pass the angular velocity (``prepare.SMOOTH_SECONDS``):
# the square root of the SRVT amplifies the capture jitter, whose velocity grows with the frame rate. The
# signature measures do not (``prepare.SIGNATURE_SMOOTH_SECONDS`` = 0): the log-signature sums increments, the
# jitter mostly cancels, and a low-pass costs them class information (docs/evaluation.md, "Time base").
SMOOTHED_METRICS = ("l2", "elastic")


def time_base_smoothing(base) -> float:
    """The low-pass (seconds) of the comparison time base for a metric base name."""
    from .clip.prepare import SIGNATURE_SMOOTH_SECONDS, SMOOTH_SECONDS

    return SMOOTH_SECONDS if base in SMOOTHED_METRICS else SIGNATURE_SMOOTH_SECONDS
# The log-signature level n (the elastic DP search depth D is the elastic package's).
DEFAULT_LEVEL = 3
MAX_LEVEL = 8

_OPTIONS = ("numpy", "joint", "group", "levelnorm", "tensor")  # canonical order
_OPTION_BASES = {"numpy": ("elastic",), "tensor": ("linear", "sim"), "levelnorm": ("sim",),
                 "joint": ("l2", "elastic"), "group": ("l2", "elastic")}
_SPEC_RE = re.compile(
    r"(?P<base>local|l2|elastic|group|concat|linear|sim)(?P<level>\d*)"
    r"(?P<opts>(?:_(?:numpy|tensor|levelnorm|joint|group))*)"
    r"(?:\+elastic(?P<k>\d+))?"
)


@dataclass(frozen=True)
class MetricSpec:
    """A parsed metric name (see the module docstring); ``name`` is the canonical form."""

    name: str
    base: str
    level: Optional[int] = None
    tensor: bool = False
    levelnorm: bool = False
    numpy_dp: bool = False
    rerank: int = 0
    srvt_norm: Optional[str] = None  # "joint", "group" or None (curves.DEFAULT_SRVT_NORM)

    @property
    def basis(self) -> str:
        """The log-signature coordinates: 'tensor' or 'lyndon'."""
        return "tensor" if self.tensor else "lyndon"

    @property
    def plain(self) -> bool:
        """A base with its level only (what ``distance`` and ``rank`` compute)."""
        return not (self.tensor or self.levelnorm or self.numpy_dp or self.rerank or self.srvt_norm)

    @property
    def first_stage(self) -> "MetricSpec":
        """The shortlist metric of a two-stage spec (the spec itself otherwise)."""
        if not self.rerank:
            return self
        return parse_metric_spec(self.name.split("+", 1)[0])


def _check_level(level):
    level = int(level)
    if not 1 <= level <= MAX_LEVEL:
        raise ShapeSigError(f"signature level must be between 1 and {MAX_LEVEL}, got {level}")
    return level


def parse_metric_spec(name, level=None) -> MetricSpec:
    """Parse a metric name; ``level`` (when given) overrides the level in the name. ShapeSigError when the
    name is not in the grammar."""
    if isinstance(name, MetricSpec):
        name = name.name
    text = str(name).strip().lower()
    m = _SPEC_RE.fullmatch(text)
    if not m:
        raise ShapeSigError(
            f"unknown metric {name!r}: choose one of {', '.join(ALL_METRICS)} (with a level, e.g. sim3), "
            f"optionally _tensor / _levelnorm / _numpy / _joint / _group or +elasticK"
        )
    base, digits = m.group("base"), m.group("level")
    opts = set(filter(None, m.group("opts").split("_")))
    k = int(m.group("k")) if m.group("k") else 0
    for opt in opts:
        if base not in _OPTION_BASES[opt]:
            raise ShapeSigError(f"metric {name!r}: _{opt} only applies to {' and '.join(_OPTION_BASES[opt])}")
    if base in SIGNATURE_METRICS:
        lvl = _check_level(level if level is not None else (digits or DEFAULT_LEVEL))
    elif digits:
        raise ShapeSigError(f"metric {base!r} takes no level")
    else:
        lvl = None
    if {"joint", "group"} <= opts:
        raise ShapeSigError(f"metric {name!r}: choose one SRVT norm, _joint or _group")
    if k and base in ("elastic", LOCAL):
        raise ShapeSigError(f"metric {name!r}: the first stage cannot be {base} (local has its own second stage)")
    canon = base + ("" if lvl is None else str(lvl)) + "".join(f"_{o}" for o in _OPTIONS if o in opts)
    if k:
        canon += f"+elastic{k}"
    return MetricSpec(name=canon, base=base, level=lvl, tensor="tensor" in opts, levelnorm="levelnorm" in opts,
                      numpy_dp="numpy" in opts, rerank=k,
                      srvt_norm=next((o for o in ("joint", "group") if o in opts), None))


def metric_label(name, level=None) -> str:
    """The canonical name of a metric: ('sim', 3) or 'SIM3' -> 'sim3', 'elastic' -> 'elastic'."""
    return parse_metric_spec(name, level).name


def parse_metric(name, level=None):
    """A plain metric name as ``(base, level)``: 'sim3' -> ('sim', 3), 'l2' -> ('l2', None); the level
    argument wins when given. Variants (options, two-stage) are refused: they exist for matrices only."""
    spec = parse_metric_spec(name, level)
    if not spec.plain:
        raise ShapeSigError(f"metric {spec.name!r} is only available for matrices (matrix, evaluate); "
                            f"here choose one of {', '.join(ALL_METRICS)}")
    return spec.base, spec.level
