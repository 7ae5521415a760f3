"""Distances between clips by name: the one metric grammar (``parse_metric_spec``:
``BASE[LEVEL][_OPTION...][+elasticK]``, e.g. ``sim3``, ``elastic``, ``sim3_tensor_levelnorm``) and the one place
that maps a name to the maths (``curve_distance``, ``clip_distance`` on the comparison time base, on the bones
two clips share; ``DEFAULT_LEVEL``). See docs/dev/metrics.md.
"""

import re
from dataclasses import dataclass
from typing import Optional

from .clip.clip import Clip, restrict_to_shared
from .elastic import DEFAULT_DEPTH
from .errors import CurveError, ShapeSigError

__all__ = [
    "METRICS", "SIGNATURE_METRICS", "SMOOTHED_METRICS", "time_base_smoothing", "DEFAULT_LEVEL", "DEFAULT_DEPTH", "MAX_LEVEL", "MetricSpec",
    "parse_metric_spec", "parse_metric", "metric_label", "clip_distance", "curve_distance",
    "check_coverage", "compare_clips", "LOCAL", "DEFAULT_METRIC", "ALL_METRICS",
]

SIGNATURE_METRICS = ("group", "concat", "linear", "sim")
# The local, pose-aware search (``core.index.local``): windows of key-point positions by log-signatures, then a
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
# The named defaults of the whole package: the log-signature level n (here) and the elastic DP search depth D
# (owned by the elastic package).
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


def curve_distance(R0, R1, metric, level=None, depth=DEFAULT_DEPTH):
    """Distance between two curves (same joints, same order) by plain metric name."""
    # imported here, not at the top: the maths modules (elastic, blend, search) may import the named
    # defaults from this module without an import cycle
    from .geometry import curves
    from .elastic import elastic
    from .signatures import signatures

    base, lvl = parse_metric(metric, level)
    if base == LOCAL:
        raise ShapeSigError("the local search compares clips (their rest skeletons), not curves: use clip_distance")
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


def check_coverage(a: Clip, b: Clip, allow_partial=False, report=False):
    """(joints compared, coverage) of two clips (``rigs.coverage``: compared / canonical joints both rigs have,
    or / moving joints of the smaller clip for clips of one rig read by name); with ``report`` the dict of
    ``rigs.coverage_report`` (``unmapped`` joints, limb ``chains``). ShapeSigError (one line) when a clip's bones
    could not be mapped while the other's were (``rigs.check_comparable``), or when the coverage or the share of
    the limb chains both rigs have that are compared is below ``rigs.MIN_COVERAGE``, unless ``allow_partial``."""
    from .rigs import MIN_COVERAGE, check_comparable, coverage_report

    check_comparable(a, b)
    got = coverage_report(a, b)
    bones, cov = got["bones"], got["coverage"]
    missing = (", ".join(got["unmapped"][:8]) + (", ..." if len(got["unmapped"]) > 8 else "")) or "none"
    if not set(a.bones) & set(b.bones):
        raise ShapeSigError(f"clips {a.name!r} and {b.name!r} share no bones; map the bones")
    if cov < MIN_COVERAGE and not allow_partial:
        raise ShapeSigError(f"clips {a.name!r} and {b.name!r} share {bones} moving joints, coverage {cov:.2f} "
                            f"< {MIN_COVERAGE} (unmapped: {missing}); map the bones "
                            f"or allow partial matches")
    if got["chains_total"] and got["chains"] < MIN_COVERAGE * got["chains_total"] and not allow_partial:
        raise ShapeSigError(f"clips {a.name!r} and {b.name!r} compare {got['chains']} of the {got['chains_total']} "
                            f"arms and legs both rigs have (unmapped: {missing}); map the bones "
                            f"or allow partial matches")
    return got if report else (bones, cov)


def compare_clips(a: Clip, b: Clip, metric="sim", level=None, depth=DEFAULT_DEPTH, allow_partial=False,
                  time_base=True) -> dict:
    """``{"distance", "bones", "coverage", "unmapped"}`` of two clips: ``clip_distance`` after ``check_coverage``."""
    got = check_coverage(a, b, allow_partial, report=True)
    return {"distance": clip_distance(a, b, metric, level, depth, time_base), "bones": got["bones"],
            "coverage": got["coverage"], "unmapped": got["unmapped"]}


def clip_distance(a: Clip, b: Clip, metric="sim", level=None, depth=DEFAULT_DEPTH, time_base=True):
    """Distance between two clips on their shared bones (still-in-both bones dropped).

    ``time_base`` (default): both clips are first put on the comparison time base (``prepare.prepare_clip``:
    one rate in seconds; for the SRVT measures also a low-pass of the angular velocity,
    ``time_base_smoothing``), so that a clip and the same motion at another frame rate are close; False
    compares the curves as read."""
    from .clip.prepare import prepare_clip

    base, _ = parse_metric(metric, level)
    if base == LOCAL:  # the first stage's distance (the second stage ranks a shortlist of a library)
        from .index import local

        return float(local.first_stage(local.index_entry(a), [local.index_entry(b)])[0])
    if base in ("l2", "elastic"):
        for c in (a, b):
            if c.frames < 2:
                raise CurveError(f"clip {c.name!r} has {c.frames} frame; the {base} distance needs at least two frames")
    a2, b2 = restrict_to_shared(a, b)
    if time_base:
        smooth = time_base_smoothing(base)
        a2, b2 = prepare_clip(a2, smooth=smooth), prepare_clip(b2, smooth=smooth)
    return float(curve_distance(a2.rotations, b2.rotations, metric, level=level, depth=depth))
