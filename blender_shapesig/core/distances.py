"""Distances between clips and curves by metric name (``metric_names``): ``curve_distance`` maps a name to the
maths, ``clip_distance`` compares two clips on the comparison time base on the bones they share, ``check_coverage``
counts the joints compared. The local search's distance between two clips is its engine's (``metrics.clip_distance``,
``metrics.compare_clips``). See docs/dev/metrics.md.
"""

from .clip.clip import Clip, restrict_to_shared
from .elastic import DEFAULT_DEPTH
from .errors import CurveError, ShapeSigError
from .metric_names import LOCAL, parse_metric, time_base_smoothing

__all__ = ["curve_distance", "clip_distance", "check_coverage"]


def curve_distance(R0, R1, metric, level=None, depth=DEFAULT_DEPTH):
    """Distance between two curves (same joints, same order) by plain metric name."""
    # imported here: naming a measure does not load numba, iisignature or scipy
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


def clip_distance(a: Clip, b: Clip, metric="sim", level=None, depth=DEFAULT_DEPTH, time_base=True):
    """Distance between two clips on their shared bones (still-in-both bones dropped).

    ``time_base`` (default): both clips are first put on the comparison time base (``prepare.prepare_clip``:
    one rate in seconds; for the SRVT measures also a low-pass of the angular velocity,
    ``time_base_smoothing``), so that a clip and the same motion at another frame rate are close; False
    compares the curves as read."""
    from .clip.prepare import prepare_clip

    base, _ = parse_metric(metric, level)
    if base == LOCAL:
        raise ShapeSigError("the local search's distance of two clips is metrics.clip_distance's (an engine's)")
    if base in ("l2", "elastic"):
        for c in (a, b):
            if c.frames < 2:
                raise CurveError(f"clip {c.name!r} has {c.frames} frame; the {base} distance needs at least two frames")
    a2, b2 = restrict_to_shared(a, b)
    if time_base:
        smooth = time_base_smoothing(base)
        a2, b2 = prepare_clip(a2, smooth=smooth), prepare_clip(b2, smooth=smooth)
    return float(curve_distance(a2.rotations, b2.rotations, metric, level=level, depth=depth))
